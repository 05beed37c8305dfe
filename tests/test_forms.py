"""hybridtwin.forms: every discrepancy form on exact data, by hand; trusted ranges; backfitting."""

import json
import warnings

import numpy as np
import pytest

from hybridtwin.diagnosis import forms
from tests.conftest import says

X = np.linspace(0.0, 10.0, 101)


def test_linear_fits_exact_data():
    form = forms.Linear().fit(X, 2.0 + 0.5 * X)
    assert form.slope == pytest.approx(0.5) and form.intercept == pytest.approx(2.0)
    assert form.n_params == 1
    assert form.predict([20.0]) == pytest.approx([12.0])  # no trusted range set: extrapolates
    assert form.describe("die_temp_c", "mm") == "linear: +0.5 mm per unit of die_temp_c"
    assert form.describe("die_temp_c", unit="deg") == "linear: +0.5 deg per unit of die_temp_c"


def test_quadratic_fits_exact_data_and_holds_its_ends():
    form = forms.Quadratic().fit(X, (X - 4.0) ** 2)
    assert form.n_params == 2
    np.testing.assert_allclose(form.predict(X), (X - 4.0) ** 2, atol=1e-9)
    # held at x = 10 and at 0: curvature is not extrapolated
    assert form.predict([12.0, -2.0]) == pytest.approx([36.0, 16.0])
    assert form.describe("t", "mm") == "quadratic in t, vertex at 4"
    says(forms.Quadratic().fit(X, 2.0 * (X - 3.0) ** 2).describe("t", "mm"), "quadratic", "t", "3")
    # held out, the parabola itself is carried on: which shape the data follow beyond the values
    assert form.continued([12.0, -2.0]) == pytest.approx([64.0, 36.0])
    line = forms.Linear().fit(X, 2.0 * X)
    assert line.continued([12.0]) == pytest.approx(line.predict([12.0]))  # a form not held flat: the same


def test_sigmoid_recovers_threshold_width_and_amplitude():
    y = 1.0 - 6.0 / (1.0 + np.exp(-(X - 5.0) / 0.8))
    form = forms.Sigmoid().fit(X, y)
    assert form.n_params == 3
    assert (form.amplitude, form.threshold, form.width) == pytest.approx((-6.0, 5.0, 0.8), abs=1e-3)
    assert form.intercept == pytest.approx(1.0, abs=1e-3)
    says(form.describe("T", "mm"), "saturating", "-6 mm", "T = 5", "3.51")


SPREAD = 9.6  # the 2nd to 98th percentile of X: 0.2 .. 9.8


@pytest.mark.parametrize("share", [0.01, 0.03, 0.08, 0.2, 0.5])
def test_the_sigmoids_start_is_exact_on_its_grid(share):
    # threshold at X's median (a grid percentile), width one of the grid's shares of the spread
    y = 1.0 + 3.0 * (1.0 / (1.0 + np.exp(-(X - 5.0) / (share * SPREAD))))
    assert forms.sigmoid_range(X) == pytest.approx((0.2, 9.8, SPREAD))
    assert forms.sigmoid_grid_start(X, y) == pytest.approx((1.0, 3.0, 5.0, share * SPREAD), abs=1e-9)


def test_the_sigmoids_start_is_exact_on_a_few_points_too():
    # twelve points and the widest grid width: the logistic's column varies by less than 1 in sum of squares
    x = np.linspace(0.0, 10.0, 12)
    _, _, spread = forms.sigmoid_range(x)
    y = 1.0 + 3.0 / (1.0 + np.exp(-(x - np.median(x)) / (0.5 * spread)))
    assert forms.sigmoid_grid_start(x, y) == pytest.approx((1.0, 3.0, np.median(x), 0.5 * spread), abs=1e-9)


def _full_grid_start(x, y):
    """The grid's best point weighed on every row, by plain least squares (the start's definition)."""
    _, _, spread = forms.sigmoid_range(x)
    best = None
    for width in spread * np.array(forms.SIGMOID_WIDTH_SHARES):
        for threshold in np.percentile(x, np.linspace(5, 95, 19)):
            design = np.column_stack([np.ones_like(x), 1.0 / (1.0 + np.exp(-(x - threshold) / width))])
            coefficients = np.linalg.lstsq(design, y, rcond=None)[0]
            error = np.sum((y - design @ coefficients) ** 2)
            if best is None or error < best[0] - 1e-9:
                best = (error, *coefficients, threshold, width)
    return best[1:]


@pytest.mark.parametrize("n_rows,seed", [(2000, 5), (8000, 3), (8000, 5)])
def test_the_sigmoids_start_is_the_grids_best_on_every_row(n_rows, seed):
    # a parabola: the two sides' saturations nearly tie, and on 8,000 rows (seed 5) every 4th row alone picks the
    # other side; its best ten points, weighed on every row, hold the full grid's choice
    rng = np.random.default_rng(seed)
    x = rng.normal(size=n_rows)
    y = 0.3 * x**2 + rng.normal(size=n_rows)
    assert forms.sigmoid_grid_start(x, y) == pytest.approx(_full_grid_start(x, y), abs=1e-9)


def test_the_sigmoids_jacobian_takes_the_logistic_of_its_own_point():
    theta, other, scale = np.array([0.5, -2.0, 0.45, np.log(0.1)]), np.array([0.1, 1.0, 0.6, np.log(0.3)]), SPREAD
    curve = forms.SigmoidCurve(X, np.sin(X), scale)
    curve.residuals(other)  # the last point it evaluated is another
    np.testing.assert_array_equal(curve.jacobian(theta), forms.SigmoidCurve(X, np.sin(X), scale).jacobian(theta))
    np.testing.assert_array_equal(curve.residuals(theta), forms.SigmoidCurve(X, np.sin(X), scale).residuals(theta))


def test_a_sigmoid_of_a_setting_that_never_changed_is_flat_at_the_mean():
    form = forms.Sigmoid().fit(np.full(20, 3.0), np.arange(20.0))
    assert form.amplitude == 0.0 and form.predict([3.0]) == pytest.approx([9.5])


def test_a_form_on_too_few_edge_rows_is_never_extrapolated():
    x = np.linspace(0.0, 1.0, 200)  # 40 rows beyond the inner quantiles
    assert not forms.extrapolates("linear", x, 3.0 * x)


def test_a_sigmoid_near_the_low_end_is_found_there():
    y = 2.0 - 4.0 / (1.0 + np.exp(-(X - 1.0) / 0.3))
    form = forms.Sigmoid().fit(X, y)
    fitted = (form.intercept, form.amplitude, form.threshold, form.width)
    assert fitted == pytest.approx((2.0, -4.0, 1.0, 0.3), abs=1e-3)


def test_the_sigmoids_jacobian_is_its_residuals_derivative():
    theta = np.array([0.5, -2.0, 0.45, np.log(0.1)])
    curve = forms.SigmoidCurve(X, np.sin(X), SPREAD)
    numeric = np.column_stack(
        [(curve.residuals(theta + step) - curve.residuals(theta - step)) / 2e-6 for step in np.eye(4) * 1e-6]
    )
    np.testing.assert_allclose(curve.jacobian(theta), numeric, atol=1e-6)


@pytest.mark.parametrize("y,threshold", [(np.exp(0.5 * X), 9.8 + SPREAD / 2), (np.log1p(X), 0.2 - SPREAD / 2)])
def test_a_sigmoids_threshold_stays_within_half_a_spread_of_the_data(y, threshold):
    # a convex rise (or a concave one) wants a sigmoid centred far beyond the data: it is held at the bound
    assert forms.Sigmoid().fit(X, y).threshold == pytest.approx(threshold)


def test_step_at_threshold_includes_the_threshold():
    y = np.where(X >= 5.0, 4.0, 1.0)
    form = forms.Step().fit(X, y)
    assert form.n_params == 2
    assert (form.low, form.jump) == pytest.approx((1.0, 3.0))
    assert 4.9 < form.threshold <= 5.0
    # a part exactly at the threshold is above it
    assert form.predict([form.threshold, np.nextafter(form.threshold, -np.inf)]) == pytest.approx([4.0, 1.0])
    assert form.describe("shim", "mm") == f"step of +3 mm at shim = {form.threshold:.4g}"


def test_a_trusted_range_holds_a_form_at_both_of_its_ends():
    form = forms.Linear().fit(X, 2.0 + 0.5 * X)
    form.trust_low, form.trust_high = 1.0, 4.0
    assert form.predict([-5.0, 2.0, 9.0]) == pytest.approx([2.5, 3.0, 4.0])


def test_small_numbers_keep_lower_case_exponents():
    tiny = X * 1e-6
    step = forms.Step().fit(tiny, np.where(X >= 5.0, 4.0, 1.0))
    says(step.describe("gap", "mm"), "step", "+3 mm", "gap = 4.95e-06")
    sigmoid = forms.Sigmoid().fit(tiny, 1.0 / (1.0 + np.exp(-(X - 5.0) / 0.8)))
    says(sigmoid.describe("gap", "mm"), "saturating", "+1 mm", "gap = 5e-06", "3.51e-06")


def test_step_with_no_valid_split_is_flat():
    form = forms.Step().fit(np.ones(10), np.arange(10.0))
    assert form.jump == 0.0 and form.predict([1.0]) == pytest.approx([4.5])


def test_step_with_no_split_leaving_enough_rows_on_each_side_is_flat_beyond_the_data():
    form = forms.Step().fit(np.array([0.0, 1.0, 2.0]), np.array([0.0, 0.0, 9.0]), min_share=0.5)
    assert (form.threshold, form.low, form.jump) == (3.0, 3.0, 0.0)


def test_step_never_splits_between_equal_values():
    form = forms.Step().fit(np.array([0.0, 1.0, 1.0, 2.0]), np.array([0.0, 0.0, 10.0, 10.0]), min_share=0.0)
    assert form.threshold in (0.5, 1.5)


@pytest.mark.parametrize("min_share,first_split", [(0.02, 2), (0.0, 1)])
def test_step_keeps_the_smallest_share_it_allows_on_either_side(min_share, first_split):
    # 100 rows (min_share 0.02: two per side) or 10 rows (at least one per side), the jump at the edge
    for n in (100, 10):
        x = np.arange(n, dtype=float)
        low_edge = forms.Step().fit(x, np.where(x < first_split, 5.0, 0.0), min_share=min_share)
        high_edge = forms.Step().fit(x, np.where(x >= n - first_split, 5.0, 0.0), min_share=min_share)
        assert (low_edge.threshold, low_edge.jump) == (first_split - 0.5, -5.0)
        assert (high_edge.threshold, high_edge.jump) == (n - first_split - 0.5, 5.0)
    # a lone first part is no step where two are asked on each side: the split moves one part in
    x = np.arange(100.0)
    assert forms.Step().fit(x, np.where(x < 1, 5.0, 0.0), min_share=0.02).threshold == 1.5


@pytest.mark.parametrize("level", [0.0, -5.0])
def test_step_finds_the_split_an_exhaustive_search_finds(level):
    rng = np.random.default_rng(3)
    x = rng.integers(0, 30, 400).astype(float)  # ties: a split lies between distinct values only
    y = level + np.where(x >= 17, 2.0, 0.0) + rng.normal(0, 1.5, 400)

    def sse(threshold):
        above = x >= threshold
        return sum(((y[side] - y[side].mean()) ** 2).sum() for side in (above, ~above))

    values = np.unique(x)
    candidates = (values[1:] + values[:-1]) / 2
    best = candidates[np.argmin([sse(t) for t in candidates])]
    form = forms.Step().fit(x, y, min_share=0.0)
    assert form.threshold == best
    assert form.low == pytest.approx(y[x < best].mean()) and form.jump == pytest.approx(y[x >= best].mean() - form.low)


def test_monotone_picks_the_direction_that_fits_and_counts_its_jumps():
    y = np.where(X < 3, 5.0, np.where(X < 7, 2.0, 0.0))  # decreasing, two jumps
    form = forms.Monotone().fit(X, y)
    np.testing.assert_allclose(form.predict(X), y)
    assert form.n_params == 5  # two jumps (place and height each) and the direction
    assert form.describe("strokes", "mm").startswith("monotone trend of -5 mm over strokes 0..10")


def test_monotone_picks_a_falling_trend_whose_flat_fit_leaves_skewed_residuals():
    y = np.where(X < 9.5, 0.0, -10.0)  # one drop at the end: the flat fit's residuals sum to a negative cube
    form = forms.Monotone().fit(X, y)
    np.testing.assert_allclose(form.predict(X), y)
    assert form.describe("strokes", "mm") == "monotone trend of -10 mm over strokes 0..10"


def test_monotone_is_silent_on_flat_data():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        forms.Monotone().fit(X, np.zeros_like(X))  # sklearn's "auto" direction would warn here


def test_group_offsets_and_unseen_levels_get_the_mean():
    labels = np.array(["a", "a", "b", "b", "b", "c"])
    y = np.array([1.0, 3.0, 4.0, 4.0, 4.0, 10.0])
    form = forms.Group().fit(labels, y)
    assert form.offsets == {"a": 2.0, "b": 4.0, "c": 10.0}
    assert form.n_params == 2
    assert form.overall == pytest.approx(26.0 / 6)
    np.testing.assert_allclose(form.predict(np.array(["c", "zz", "a"])), [10.0, 26.0 / 6, 2.0])
    assert form.describe("coil_id", "mm") == "offsets per coil_id level: 3 levels, sd 3.4 mm"


def test_product_and_additive_fit_exact_data():
    rng = np.random.default_rng(0)
    ab = rng.uniform(0, 1, (200, 2))
    a, b = ab.T
    y = 1.0 + 2.0 * a - 1.0 * b + 3.0 * a * b
    product = forms.Product().fit(ab, y)
    np.testing.assert_allclose(product.predict(ab), y, atol=1e-9)
    assert product.coefficients[3] == pytest.approx(3.0)
    assert product.n_params == 3
    says(product.describe("a*b", "mm"), "interaction", "+3 mm", "a x b")
    additive = forms.Additive().fit(ab, 1.0 + 2.0 * a - 1.0 * b)
    assert additive.n_params == 2
    assert additive.coefficients[1:] == pytest.approx([2.0, -1.0])
    says(additive.describe("a*b", "mm"), "additive", "+2 mm", "of a", "-1 mm", "of b")


def test_a_products_own_interaction_is_its_a_b_term_beyond_the_columns_slopes():
    rng = np.random.default_rng(0)
    ab = rng.uniform(0, 1, (400, 2))
    a, b = ab.T
    slopes = forms.Product().fit(ab, 2.0 * a - 1.0 * b)
    np.testing.assert_allclose(slopes.own_interaction(ab), 0.0, atol=1e-9)
    product = forms.Product().fit(ab, 2.0 * a - 1.0 * b + 3.0 * a * b)
    own = product.own_interaction(ab)
    # what no line in a and b fits: orthogonal to them, and never more than the whole term
    design = np.column_stack([np.ones_like(a), a, b])
    np.testing.assert_allclose(design.T @ own, 0.0, atol=1e-8)
    np.testing.assert_allclose(own, product.predict(ab) - design @ np.linalg.lstsq(design, product.predict(ab))[0])
    assert 0.2 < np.std(own) < np.std(product.predict(ab))
    assert not np.any(forms.Additive().fit(ab, 2.0 * a).own_interaction(ab))


@pytest.mark.parametrize(
    "name,x,y",
    [
        ("linear", X, 2 * X),
        ("quadratic", X, X**2),
        ("sigmoid", X, 1 / (1 + np.exp(-(X - 5)))),
        ("step", X, (X > 5) * 2.0),
        ("monotone", X, np.sqrt(X)),
        ("group", np.array(list("abcab")), np.arange(5.0)),
        ("product", np.column_stack([X, X[::-1]]), X * X[::-1]),
        ("additive", np.column_stack([X, X[::-1] ** 2]), X + X[::-1] ** 2),
    ],
)
def test_every_form_survives_a_json_round_trip(name, x, y):
    form = forms.fit_form(name, x, y)
    if name != "group":
        forms.set_trusted_range(form, x, y)
    loaded = forms.form_from_dict(json.loads(json.dumps(form.to_dict())))
    assert loaded.name == name and loaded.n_params == form.n_params
    probe = x if name == "group" else np.concatenate([x, x * 3 + 1])
    np.testing.assert_allclose(loaded.predict(probe), form.predict(probe))


# ------------------------------------------------------------------ how far a form is trusted


def test_a_slope_fitted_to_a_step_is_held_constant_beyond_the_data():
    rng = np.random.default_rng(1)
    x = rng.uniform(0.0, 1.0, 4000)
    y = np.where(x >= 0.5, 5.0, 0.0) + rng.normal(0, 0.5, len(x))
    form = forms.fit_form("linear", x, y)
    assert not forms.extrapolates("linear", x, y)  # on the edges the slope overshoots the plateaus
    forms.set_trusted_range(form, x, y)
    assert (form.trust_low, form.trust_high) == pytest.approx((x.min(), x.max()))
    assert form.predict([3.0]) == pytest.approx(form.predict([x.max()]))


def test_a_continuing_trend_is_trusted_as_far_again_as_the_data_span():
    rng = np.random.default_rng(2)
    x = rng.uniform(0.0, 1.0, 4000)
    y = 6.0 * x + rng.normal(0, 0.5, len(x))
    form = forms.fit_form("linear", x, y)
    assert forms.extrapolates("linear", x, y)
    forms.set_trusted_range(form, x, y)
    span = x.max() - x.min()
    assert (form.trust_low, form.trust_high) == pytest.approx((x.min() - span, x.max() + span))
    assert form.predict([x.max() + 0.5 * span]) == pytest.approx([form.intercept + form.slope * (x.max() + 0.5 * span)])
    assert form.predict([x.max() + 5 * span]) == pytest.approx(form.predict([x.max() + span]))


def _coils(seed: int, slope: float):
    """40 coils of 150 parts; a per-coil quantity x and per-coil offsets (plus ``slope`` * x)."""
    rng = np.random.default_rng(seed)
    x = np.repeat(rng.uniform(0, 1, 40), 150)
    return x, slope * x + np.repeat(rng.normal(0, 1, 40), 150) + rng.normal(0, 0.2, len(x))


def test_a_slope_that_a_few_coils_at_the_edges_make_is_not_extrapolated():
    # draw 24: the coils beyond the inner stretch happen to line up with the slope; 50 blocks of
    # their parts (a few blocks per coil) would call that a continuing trend (p < 0.01)
    x, y = _coils(24, slope=0.0)
    assert not forms.extrapolates("linear", x, y)
    # a trend that carries on: beyond the inner quantiles it must stand out from the offsets of
    # the few coils out there (here up to 3 mm against their 1 mm sd)
    x, y = _coils(24, slope=30.0)
    assert forms.extrapolates("linear", x, y)


def test_a_pair_is_held_per_column():
    rng = np.random.default_rng(3)
    ab = rng.uniform(0, 1, (3000, 2))
    y = np.where(ab[:, 0] * ab[:, 1] > 0.25, 3.0, 0.0) + rng.normal(0, 0.3, 3000)
    form = forms.set_trusted_range(forms.fit_form("product", ab, y), ab, y)
    assert np.ndim(form.trust_low) == 1 and len(form.trust_low) == 2
    assert form.predict([[5.0, 5.0]]) == pytest.approx(form.predict([[ab[:, 0].max(), ab[:, 1].max()]]))


def test_group_offsets_never_get_a_range():
    form = forms.set_trusted_range(forms.fit_form("group", np.array(list("aab")), np.arange(3.0)), None, None)
    assert form.trust_low is None


# ------------------------------------------------------------------ backfitting


def test_backfitting_recovers_two_correlated_slopes():
    rng = np.random.default_rng(4)
    a = rng.normal(0, 1, 2000)
    b = 0.8 * a + 0.6 * rng.normal(0, 1, 2000)  # correlated: one pass would give biased slopes
    y = 2.0 * a - 3.0 * b
    models, means = forms.backfit([a, b], ["linear", "linear"], y, passes=30)
    assert models[0].slope == pytest.approx(2.0, abs=1e-3)
    assert models[1].slope == pytest.approx(-3.0, abs=1e-3)
    np.testing.assert_allclose(sum(m.predict(v) - c for m, v, c in zip(models, [a, b], means)), y - y.mean(), atol=1e-2)
    one_pass, _ = forms.backfit([a, b], ["linear", "linear"], y, passes=1)
    assert abs(one_pass[0].slope - 2.0) > 0.5  # what a single pass would have given


def test_a_causes_unit_comes_from_the_config_or_its_name_and_reaches_the_description():
    from hybridtwin.diagnosis.causes import Cause, unit_of

    assert unit_of("die_temp_c") == "°C" and unit_of("shim20_mm") == "mm" and unit_of("rp02_mpa") == "MPa"
    assert unit_of("coil") == "" and unit_of("die_temp", {"die_temp": "°F"}) == "°F"
    assert Cause("t", "time", ("timestamp",)).unit() == "h" and Cause("c", "group", ("coil_c",)).unit() == ""
    assert Cause("a*b", "interaction", ("a_mm", "b_mm")).unit() == ""
    step = forms.Step().fit(np.array([40.0, 41.0, 50.0, 51.0] * 10), np.array([0.0, 0.0, 5.0, 5.0] * 10))
    assert step.describe("die_temp_c", "mm", "°C") == "step of +5 mm at die_temp_c = 45.5 °C"
    assert step.describe("die_temp_c", "mm") == "step of +5 mm at die_temp_c = 45.5"
    line = forms.Linear().fit(np.array([0.0, 1.0, 2.0]), np.array([0.0, 2.0, 4.0]))
    assert line.describe("rp02_mpa", "mm", "MPa") == "linear: +2 mm per MPa of rp02_mpa"


# ------------------------------------------------------------------ descriptions in the causes' own units


def test_every_description_carries_the_causes_unit_and_its_numbers():
    quadratic = forms.Quadratic().fit(X, (X - 7.0) ** 2)  # the vertex away from the data's centre (5)
    says(quadratic.describe("t", "mm", "°C"), "quadratic", "t", "7 °C")
    sigmoid = forms.Sigmoid().fit(X, 1.0 - 6.0 / (1.0 + np.exp(-(X - 5.0) / 0.8)))
    says(sigmoid.describe("T", "mm", "°C"), "saturating", "-6 mm", "T = 5 °C", "3.51 °C")
    monotone = forms.Monotone().fit(X, -np.sqrt(X))  # falls fastest at the start: first and last knots count
    says(monotone.describe("strokes", "mm", "strokes"), "monotone", "-3.16 mm", "strokes", "0..10 strokes")


def test_a_flat_parabola_is_described_without_a_vertex():
    flat = forms.form_from_dict(
        {"form": "quadratic", "center": 0.0, "low": 0.0, "high": 1.0, "coefficients": [0, 1, 0]}
    )
    assert flat.describe("t", "mm") == "quadratic"


def test_group_offsets_of_no_rows_are_no_rows():
    form = forms.Group().fit(np.array(["a", "b"]), np.array([1.0, 2.0]))
    assert form.predict(np.array([], dtype=str)).shape == (0,)


def test_a_pair_is_extrapolated_only_where_its_product_goes_on_beyond_the_inner_values():
    rng = np.random.default_rng(4)
    ab = rng.uniform(0, 1, (3000, 2))
    low, high = np.quantile(ab, forms.EDGE_QUANTILES, axis=0)
    noise = rng.normal(0, 0.05, 3000)
    in_mm = ab * [1.0, 100.0] + [0.0, 100.0]  # columns of different ranges: each is held at its own edges
    assert forms.extrapolates("product", in_mm, 4 * ab[:, 0] * ab[:, 1] + noise)
    held = np.clip(ab, low, high)  # the same interaction, flat beyond the inner quantiles of each column
    assert not forms.extrapolates("product", in_mm, 4 * held[:, 0] * held[:, 1] + noise)


@pytest.mark.parametrize("parked_at", ["top", "bottom"])
def test_a_setting_parked_at_its_limit_is_judged_on_its_one_edge(parked_at):
    # a third of the parts run at the setting's limit: its edge rows all lie on the other side
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.uniform(0.0, 1.0, 700), np.ones(300)])
    if parked_at == "bottom":
        x = 1.0 - x
    y = 3.0 * x + rng.normal(0, 0.05, 1000)
    inner, low, high = forms.edge_split(x)
    assert (~inner).sum() == 100
    assert forms.extrapolates("linear", x, y)
    assert not forms.extrapolates("linear", x, np.clip(y, 3.0 * low, 3.0 * high))


@pytest.mark.parametrize(
    "x,judged",
    [
        (np.arange(251.0), True),  # 25 rows beyond each quantile: 50 on the edges
        (np.arange(241.0), False),  # 48 on the edges
        (np.arange(101.0), False),  # plenty inside, 20 on the edges
        (np.concatenate([np.zeros(920), np.linspace(1, 2, 80)]), False),  # the quantiles coincide: no inner stretch
    ],
)
def test_the_edges_are_judged_only_with_fifty_rows_on_them(x, judged):
    split = forms.edge_split(x)
    assert (split is not None) == judged
    if judged:
        inner, low, high = split
        assert (low, high) == (25.0, 225.0) and inner.sum() == 201  # both quantiles are inner values


def test_a_pair_with_a_column_held_at_one_value_has_no_edges():
    rng = np.random.default_rng(6)
    a = rng.uniform(0, 1, 1000)
    assert forms.edge_split(np.column_stack([a, np.where(a > 0.95, 1.0, 0.0)])) is None


def test_group_offsets_are_never_extrapolated():
    assert not forms.extrapolates("group", np.repeat(["a", "b"], 200), np.repeat([0.0, 5.0], 200))
