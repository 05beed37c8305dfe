"""hybridtwin.diagnosis: the selection rules, each on a small constructed plant whose right answer is known."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from hybridtwin import diagnosis
from hybridtwin.diagnosis import Candidate, Settings, best_fit, forms, ids, levels, naming
from hybridtwin.diagnosis import fits as fitting
from hybridtwin.diagnosis.ids import smooth_first
from hybridtwin.diagnosis.profiles import Identity
from hybridtwin.diagnosis.selection import Selection

SETTINGS = Settings(folds=5, seed=0, interactions=False)


class Lenient(fitting.Rules):
    """Rules under which every fit counts as significant: the rule under test decides alone."""

    def significant(self, fit) -> bool:
        return True


def _diagnose(frame, y, surrogate_std=0.2, inputs=()):
    return diagnosis.diagnose(frame, y, list(inputs), [], SETTINGS, surrogate_std=surrogate_std)


def _term(name: str, kind: str, term, values=None) -> fitting.Fit:
    """A fit whose term is ``term`` itself (on the candidate's ``values``, by default the term)."""
    term = np.asarray(term, float)
    values = term if values is None else values
    return fitting.Fit(
        Candidate.new(name, kind, values, tuple(name.split("*"))), Identity(), term, 1.0, 1.0, -1.0, 0.0, 0.0, 0.0
    )


def test_an_ids_folds_hold_out_whole_levels():
    labels = np.repeat(np.array(["K1", "K2", "K3", "K4", "K5", "K6", "K7"]), [3, 5, 2, 8, 1, 4, 6])
    folds = ids.level_folds(labels, 5, seed=0)
    assert len(folds) == 5
    tested = np.concatenate([test for _, test in folds])
    assert sorted(tested) == list(range(len(labels)))  # each part predicted once
    for train, test in folds:
        assert not set(labels[train]) & set(labels[test])
    assert len(ids.level_folds(labels[:8], 5, seed=0)) == 2  # two levels: two folds


def material_coils(n_coils: int = 60, per_coil: int = 50, seed: int = 5):
    """Coils of a material with two per-coil properties (inputs); the surrogate's error a smooth surface of them."""
    rng = np.random.default_rng(seed)
    m1, m2 = rng.uniform(-1, 1, n_coils), rng.uniform(-1, 1, n_coils)
    coil = np.repeat(np.arange(n_coils), per_coil)
    frame = pd.DataFrame({"coil": [f"C-{c:03d}" for c in coil], "m1": m1[coil], "m2": m2[coil]})
    surface = 1.3 * m1 + 1.3 * m2 + 2.0 * m1 * m2  # std 1.3; each column alone a term of std 0.75-0.8
    return frame, surface[coil], coil, rng


def test_coil_offsets_that_a_smooth_surface_of_the_inputs_gives_are_no_cause():
    frame, surface, _, rng = material_coils()
    y = surface + rng.normal(0, 0.5, len(frame))
    result = _diagnose(frame, y, surrogate_std=1.0, inputs=("m1", "m2"))
    assert result.selected == []  # neither column passes the margin alone, and the id is not named for them
    names, share = result.proxies["coil"].names, result.proxies["coil"].share
    # the surface and the inputs' own forms (each column a slope below the margin) account for the offsets
    assert names[0] == ids.INPUT_SURFACE and set(names[1:]) <= {"m1", "m2"} and share > 0.9
    row = result.table.set_index("cause").loc["coil"]
    assert not row["significant"] and row["note"].startswith("an id, not a cause: the model inputs")


def test_coil_offsets_of_their_own_stand_beside_the_surface():
    frame, surface, coil, rng = material_coils()
    own = rng.normal(0, 1.5, coil.max() + 1)
    y = surface + own[coil] + rng.normal(0, 0.5, len(frame))
    result = _diagnose(frame, y, surrogate_std=1.0, inputs=("m1", "m2"))
    assert [f.candidate.name for f in result.selected] == ["coil"]
    assert "coil" not in result.proxies


def test_several_smooth_quantities_below_the_margin_account_for_an_id_together():
    # coils in time order: the hall's temperature drifts over them, a log column below the margin on its own
    frame, surface, coil, rng = material_coils()
    ambient = 20 + 6 * np.sin(np.linspace(0, 3, len(frame))) + rng.normal(0, 0.3, len(frame))
    frame["ambient_c"] = ambient
    y = surface + 0.8 * (ambient - ambient.mean()) / ambient.std() + rng.normal(0, 0.5, len(frame))
    result = _diagnose(frame, y, surrogate_std=1.0, inputs=("m1", "m2"))
    assert "coil" not in [f.candidate.name for f in result.selected]
    names = result.proxies["coil"].names
    assert names[0] == ids.INPUT_SURFACE and "ambient_c" in names[1:] and set(names[1:]) <= {"ambient_c", "m1", "m2"}


def _two_columns_and_their_product(rng, n):
    """Two uniform inputs ``a`` and ``b``, their candidates by name, and their product's candidate."""
    a, b = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    candidates = {"a": Candidate.new("a", "input", a, ("a",)), "b": Candidate.new("b", "input", b, ("b",))}
    return a, b, candidates, Candidate.new("a*b", "interaction", np.column_stack([a, b]), ("a", "b"))


def test_a_product_stands_only_where_it_beats_the_sum_of_its_columns():
    rng = np.random.default_rng(6)
    n = 4000
    a, b, candidates, pair = _two_columns_and_their_product(rng, n)
    rules = fitting.Rules(SETTINGS, n_tests=3, min_effect=0.1)
    tilt = 1.0 * a + 0.3 * b**2 + rng.normal(0, 0.5, n)  # a tilt in a, a bend in b: no interaction
    tilt -= tilt.mean()
    named = naming.product_or_column(rules.best_fit(pair, tilt), candidates, tilt, rules)
    assert named.candidate.name == "a"
    product = 1.0 * a * b + 0.3 * a + rng.normal(0, 0.5, n)
    product -= product.mean()
    assert naming.product_or_column(rules.best_fit(pair, product), candidates, product, rules).candidate is pair


@pytest.mark.parametrize(
    "slopes, min_effect",
    [((0.4, 0.25), 0.1), ((0.3, 0.0), 1.0)],
    ids=["two slopes, each significant", "one slope, within the surrogate's uncertainty"],
)
def test_a_product_no_better_than_its_columns_apart_is_never_named(slopes, min_effect):
    # two causes are named as two, and a column too small to name alone does not stand in for a product
    rng = np.random.default_rng(7)
    n = 4000
    a, b, candidates, pair = _two_columns_and_their_product(rng, n)
    rules = fitting.Rules(SETTINGS, n_tests=3, min_effect=min_effect)
    y = slopes[0] * a + slopes[1] * b + rng.normal(0, 0.5, n)
    y -= y.mean()
    named = naming.product_or_column(rules.best_fit(pair, y), candidates, y, rules)
    assert named.candidate.name == "a"


@pytest.mark.parametrize("min_effect, named", [(0.05, "a*b"), (0.3, "b")])
def test_a_product_its_columns_apart_do_no_better_than_stands_on_an_interaction_of_its_own(min_effect, named):
    # 400 parts: the product's gain over its columns apart is not significant (p 0.13 and 0.07), and its own
    # a*b term (0.18 std) decides against the surrogate's uncertainty; else the better column (b, by chance)
    rng = np.random.default_rng(1)
    n = 400
    a, b, candidates, pair = _two_columns_and_their_product(rng, n)
    rules = fitting.Rules(SETTINGS, n_tests=3, min_effect=min_effect)
    y = 0.4 * a * b + rng.normal(0, 1.0, n)
    y -= y.mean()
    best = rules.best_fit(pair, y)
    assert best.form.name == "product"
    assert naming.product_or_column(best, candidates, y, rules).candidate.name == named


def test_elapsed_time_ranks_behind_a_logged_quantity_that_predicts_the_same():
    rng = np.random.default_rng(0)
    n = 3000
    strokes = 1000 + np.arange(n) * 2
    stamps = pd.Timestamp("2026-01-05 06:00") + pd.to_timedelta(np.arange(n) * 8, unit="s")
    # "a_time" sorts before "strokes": only the rule can hand the cause to the counter
    frame = pd.DataFrame({"a_time": stamps.strftime("%Y-%m-%d %H:%M:%S"), "strokes": strokes})
    y = 0.002 * (strokes - strokes.mean()) + rng.normal(0, 0.5, n)
    result = _diagnose(frame, y)
    assert [f.candidate.name for f in result.selected] == ["strokes"]
    assert result.selected[0].form.name == "linear"
    assert "a_time" in result.aliases["strokes"]


def test_the_causes_are_described_in_the_targets_unit():
    # a plant that measures springback in degrees reads degrees, in the table and in the summary
    rng = np.random.default_rng(3)
    angle = rng.uniform(80, 100, 2000)
    y = 0.3 * (angle - angle.mean()) + rng.normal(0, 0.5, 2000)
    result = diagnosis.diagnose(
        pd.DataFrame({"angle": angle}), y, ["angle"], [], Settings(folds=5, seed=0, unit="deg"), surrogate_std=0.2
    )
    described = "linear: +0.3026 deg per unit of angle"
    assert result.table.loc[0, "description"] == described
    assert diagnosis.summary_dict(result)["selected"][0]["description"] == described
    # and the cause in its own unit, from the config (units.inputs)
    settings = Settings.from_config({}, folds=5, seed=0, unit="deg", input_units={"angle": "°"})
    result = diagnosis.diagnose(pd.DataFrame({"angle": angle}), y, ["angle"], [], settings, surrogate_std=0.2)
    assert result.table.loc[0, "description"] == "linear: +0.3026 deg per ° of angle"


def coil_plant(explained: float, seed: int = 1):
    """Coils of 60 parts; a per-coil lubricant film with an effect, and coil offsets nothing logged explains."""
    rng = np.random.default_rng(seed)
    n_coils, per_coil = 60, 60
    lube = rng.uniform(0.8, 2.2, n_coils)
    own = rng.normal(0, 1.0, n_coils)
    effect = 3.0 * (lube - lube.mean()) / lube.std()
    coil_term = np.sqrt(explained) * effect + np.sqrt(1 - explained) * 3.0 * own / own.std()
    coil = np.repeat(np.arange(n_coils), per_coil)
    frame = pd.DataFrame(
        {"coil": [f"K{c:03d}" for c in coil], "lube": np.round(lube[coil], 2), "ambient": rng.normal(20, 2, len(coil))}
    )
    return frame, coil_term[coil] + rng.normal(0, 0.5, len(coil))


def test_an_id_stands_for_the_quantity_that_explains_most_of_its_levels():
    frame, y = coil_plant(explained=1.0)
    result = _diagnose(frame, y)
    assert [f.candidate.name for f in result.selected] == ["lube"]
    # coil and lube predict the same: the simpler column is named, the id reported beside it
    assert "lube" in result.table.set_index("cause").loc["coil", "note"]


def test_an_id_stays_as_a_second_cause_where_its_remainder_is_significant():
    frame, y = coil_plant(explained=0.75)
    result = _diagnose(frame, y)
    assert [f.candidate.name for f in result.selected] == ["lube", "coil"]  # ids come last
    assert "coil" not in result.proxies


def test_an_id_that_nothing_explains_is_named_itself():
    frame, y = coil_plant(explained=0.0)
    result = _diagnose(frame, y)
    assert result.selected[0].candidate.name == "coil"
    assert result.selected[0].form.name == "group"
    assert "coil" not in result.proxies


def test_a_closed_form_goes_ahead_of_a_monotone_trend_that_it_matches():
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 1, 3000)
    y = np.where(x >= 0.5, 3.0, 0.0) + rng.normal(0, 0.3, 3000)
    fit = best_fit(Candidate.new("shim", "input", x, ("shim",)), y - y.mean(), SETTINGS)
    by_form = {alt.form.name: alt for alt in fit.alternatives}
    trend_first = [by_form["monotone"], by_form["linear"], by_form["step"]]
    assert fitting._named_form_first(trend_first, min_effect=0.5)[0].form.name == "step"
    # the linear fit does not predict the step within 0.5, so it is passed over
    assert fitting._named_form_first([by_form["monotone"], by_form["linear"]], 0.5)[0].form.name == "monotone"


def test_a_simpler_column_that_predicts_the_same_is_named_with_its_own_form():
    rng = np.random.default_rng(3)
    n = 4000
    temp = rng.uniform(20, 50, n)
    y = 6.0 / (1 + np.exp(-(temp - 35) / 1.5)) + rng.normal(0, 0.4, n)
    y -= y.mean()
    fits = {
        name: best_fit(Candidate.new(name, kind, values, cols), y, SETTINGS, 0.5)
        for name, kind, values, cols in [
            ("temp", "input", temp, ("temp",)),
            ("temp*other", "interaction", np.column_stack([temp, rng.normal(0, 1, n)]), ("temp", "other")),
        ]
    }
    # the pair as the best-scoring candidate: the single column is simpler and predicts the same
    chosen = naming.prefer_simpler(fits["temp*other"], list(fits.values()), y, Lenient(SETTINGS, min_effect=2.0))
    assert chosen.candidate.name == "temp"
    assert chosen.form.name == fits["temp"].form.name == "sigmoid"


@pytest.mark.parametrize("drift_along, expected", [("hours", "time"), ("strokes", "strokes")])
def test_time_gives_way_to_a_logged_quantity_only_where_it_predicts_no_better(drift_along, expected):
    # strokes run with the hours except over idle stops, where only the hours go on
    rng = np.random.default_rng(5)
    n = 4000
    hours = np.cumsum(rng.exponential(0.02, n)) + 30.0 * (np.arange(n) >= 1500) + 30.0 * (np.arange(n) >= 3000)
    strokes = 100_000 + np.arange(n, dtype=float)
    drift = {"hours": hours, "strokes": strokes}[drift_along]
    y = 2.0 * (drift - drift.mean()) / drift.std() + rng.normal(0, 1.0, n)
    y -= y.mean()
    fits = [
        best_fit(Candidate.new(name, kind, values, (name,)), y, SETTINGS, 0.5)
        for name, kind, values in [("time", "time", hours), ("strokes", "log", strokes)]
    ]
    best = min(fits, key=lambda fit: fit.score)
    chosen = naming.prefer_simpler(best, fits, y, Lenient(SETTINGS, min_effect=1.0))
    assert chosen.candidate.name == expected


def test_a_bend_both_columns_show_is_no_reason_to_name_time():
    # the line never stands idle: hours are strokes on another scale; the drift along strokes bends a little
    rng = np.random.default_rng(6)
    n = 4000
    strokes = 100_000 + np.arange(n, dtype=float)
    hours = (strokes - strokes[0]) / 900.0 + rng.normal(0, 0.01, n)
    z = (strokes - strokes.mean()) / strokes.std()
    y = 4.0 * z + 0.5 * (z**2 - 1.0) + rng.normal(0, 1.0, n)  # the bend: std 0.71, 3% of the variance
    y -= y.mean()
    fits = [
        best_fit(Candidate.new(name, kind, values, (name,)), y, SETTINGS, 1.0)
        for name, kind, values in [("time", "time", hours), ("strokes", "log", strokes)]
    ]
    time_bent = next(alt for alt in fits[0].alternatives if alt.form.name == "quadratic")
    strokes_line = next(alt for alt in fits[1].alternatives if alt.form.name == "linear")
    # the bend is real: time's parabola predicts significantly better than a line in strokes ...
    assert naming.better_held_out(time_bent, strokes_line, y, SETTINGS)
    # ... and strokes count by that line (it predicts the parabola within the least effect), but time
    # must also beat the strokes' own parabola, and does not
    chosen = naming.prefer_simpler(time_bent, fits, y, Lenient(SETTINGS, min_effect=1.0))
    assert chosen.candidate.name == "strokes"


def test_no_cause_on_pure_noise():
    rng = np.random.default_rng(4)
    frame = pd.DataFrame({"a": rng.normal(0, 1, 2000), "coil": [f"K{i // 50}" for i in range(2000)]})
    result = _diagnose(frame, rng.normal(0, 1, 2000), surrogate_std=0.3)
    assert result.selected == []
    assert not result.table["significant"].any()


def test_a_sigmoid_that_saturates_beyond_the_data_gives_way_to_a_slope():
    rng = np.random.default_rng(6)
    x = rng.uniform(0, 1, 4000)
    # a slope with a mild S inside (the surrogate's own error): a sigmoid scores best held out
    slope = 4.0 * x + 0.3 * np.tanh((x - 0.5) / 0.08) + rng.normal(0, 0.5, 4000)
    fit = best_fit(Candidate.new("rp02", "input", x, ("rp02",)), slope - slope.mean(), SETTINGS, min_effect=1.0)
    assert min(fit.alternatives, key=lambda alt: alt.score).form.name == "sigmoid"
    assert fit.form.name == "linear"  # it predicts the same, and its change is wider than the data
    step = np.where(x >= 0.5, 4.0, 0.0) + rng.normal(0, 0.5, 4000)
    fit = best_fit(Candidate.new("shim", "input", x, ("shim",)), step - step.mean(), SETTINGS, min_effect=2.0)
    assert fit.form.name in ("step", "sigmoid")  # a change the data show stays a change


def warming_die(drift: float, temp_noise: float, n: int = 4000):
    """A saturation of 8 mm in die temperature and a wear drift of ``drift`` mm along the strokes, the die
    warming over the strokes (scattered by ``temp_noise``): temperature, strokes, residual."""
    rng = np.random.default_rng(8)
    strokes = np.arange(n, dtype=float)
    temp = 30 + 20 * strokes / n + rng.normal(0, temp_noise, n)
    return temp, strokes, 8.0 / (1 + np.exp(-(temp - 42) / 2.0)) - drift * strokes / n + rng.normal(0, 0.5, n)


def test_a_cause_form_is_chosen_again_once_the_other_causes_are_in():
    # a saturation in temperature and a wear drift along strokes that runs with temperature: fitted
    # alone, the temperature's term bends into a parabola; with the drift in, it is the sigmoid again
    temp, strokes, y = warming_die(drift=4.0, temp_noise=4.0)
    y -= y.mean()
    by_name = {
        "temp": Candidate.new("temp", "input", temp, ("temp",)),
        "strokes": Candidate.new("strokes", "log", strokes, ("strokes",)),
    }
    alone = best_fit(by_name["temp"], y, SETTINGS, 0.5)
    quadratic = next(alt for alt in alone.alternatives if alt.form.name == "quadratic")
    models, means = forms.backfit([temp], ["quadratic"], y)
    left = y - models[0].predict(temp) + means[0]
    selection = chosen(y, by_name, quadratic, best_fit(by_name["strokes"], left - left.mean(), SETTINGS, 0.5))
    assert selection.refine()
    assert [(fit.candidate.name, fit.form.name) for fit in selection.chosen][0] == ("temp", "sigmoid")


def test_a_chosen_product_gives_way_to_its_column_that_explains_as_much():
    rng = np.random.default_rng(7)
    n = 3000
    temp, other = rng.uniform(20, 50, n), rng.uniform(0, 1, n)
    y = 6.0 / (1 + np.exp(-(temp - 35) / 2.0)) + rng.normal(0, 0.4, n)
    y -= y.mean()
    pair = Candidate.new("temp*other", "interaction", np.column_stack([temp, other]), ("temp", "other"))
    by_name = {
        "temp": Candidate.new("temp", "input", temp, ("temp",)),
        "other": Candidate.new("other", "input", other, ("other",)),
    }
    selection = chosen(y, by_name, best_fit(pair, y, SETTINGS))
    assert selection.refine()
    assert selection.chosen[0].candidate.name == "temp" and selection.chosen[0].form.name == "sigmoid"
    # a real interaction stays
    y2 = 0.2 * (temp - 35) * (other - 0.5) + rng.normal(0, 0.3, n)
    assert not chosen(y2 - y2.mean(), by_name, best_fit(pair, y2 - y2.mean(), SETTINGS)).refine()


def chosen(y, by_name, *fits) -> Selection:
    """A selection that has chosen ``fits`` among the candidates of ``by_name``, with lenient rules."""
    return Selection(y, list(by_name.values()), Lenient(SETTINGS, min_effect=0.5), {}, list(fits))


def _smooth(name: str, values, score: float = -1.0, p_value: float = 0.0, kind: str = "log") -> fitting.Fit:
    """A smooth candidate's linear fit: its form's name, its values, its score and p-value matter to the id rule."""
    values = np.asarray(values, float)
    candidate = Candidate.new(name, kind, values, (name,))
    return fitting.Fit(candidate, forms.fit_form("linear", values, values), values, 1.0, 1.0, score, p_value, 0.5, 0.5)


def test_the_id_rule_backfits_the_input_surface_and_the_smooth_quantities_and_predicts_held_out_parts():
    rng = np.random.default_rng(3)
    n = 3000
    inputs = rng.uniform(-1, 1, (n, 2))
    wear = np.linspace(0, 1, n)
    ambient = 1.6 * (wear - 0.5) + rng.uniform(-0.5, 0.5, n)  # the weather warmed as the tool wore
    truth = 1.5 * inputs[:, 0] + inputs[:, 0] * inputs[:, 1] + 2.0 * ambient - 1.0 * wear
    y = truth + rng.normal(0, 0.05, n)
    train, test = np.arange(n) % 4 != 0, np.arange(n) % 4 == 0
    smooth = [_smooth("ambient", ambient), _smooth("wear", wear)]
    held_out = ids._predict_held_out(np.flatnonzero(train), np.flatnonzero(test), y, inputs, smooth, 1e-3)
    # each part of the sum found by the others' remainders: the held-out parts are recovered to the noise
    assert np.sqrt(np.mean((held_out - truth[test]) ** 2)) < 0.1
    without_inputs = ids._predict_held_out(np.flatnonzero(train), np.flatnonzero(test), y, None, smooth, None)
    assert np.sqrt(np.mean((without_inputs - truth[test]) ** 2)) > 0.5  # the surface carried the inputs' part


def test_what_an_id_holds_beyond_the_surface_is_centred_and_its_share_is_what_the_surface_took():
    frame, surface, coil, rng = material_coils()
    own = rng.normal(0, 1.0, coil.max() + 1)
    y = surface + own[coil] + rng.normal(0, 0.3, len(frame))
    candidates = [Candidate.new(name, "input", frame[name].to_numpy(float), (name,)) for name in ("m1", "m2")]
    group = Candidate.new("coil", "group", frame["coil"].to_numpy(), ("coil",))
    rules = fitting.Rules(SETTINGS, n_tests=3, min_effect=0.0)
    left = ids.unaccounted(group, y, candidates, [], rules)
    assert abs(left.mean()) < 1e-12
    # the coils' own offsets stay (their std 1.0 against the surface's 1.3): a share of the level differences
    _, names, share, _ = ids.id_stands(rules.best_fit(group, y), y, [*candidates, group], {}, rules)
    offsets = pd.Series(own[coil]).groupby(coil).mean()
    surface_by_coil = pd.Series(surface).groupby(coil).mean()
    expected = surface_by_coil.var() / (surface_by_coil.var() + offsets.var())
    assert names == (ids.INPUT_SURFACE,) and abs(share - expected) < 0.15 and 0.2 < share < 0.9
    flat = np.zeros(len(frame))  # no level differences at all: nothing to share
    assert ids.id_stands(rules.best_fit(group, flat + 1e-9 * rng.normal(size=len(frame))), flat, [group], {}, rules)[
        2
    ] in (0.0, pytest.approx(0.0, abs=1e-6))


def test_the_smooth_candidates_that_may_account_for_an_id_are_the_best_three_significant_alone_uncorrected():
    # 200 candidates tested: a p-value of 0.01 is far from significant once corrected, but counts here
    rules = Lenient(SETTINGS, n_tests=200, min_effect=5.0)  # and of any size: the margin does not apply
    values = np.linspace(0, 1, 50)
    small = dict(p_value=0.005)  # below alpha (0.01)
    fits = [
        _smooth("b_ambient", values, score=-3.0, **small),
        _smooth("a_ambient", values, score=-3.0, **small),  # the same score: by name
        _smooth("wear", values, score=-5.0, **small),
        _smooth("humidity", values, score=-1.0),
        _smooth("shift_hours", values, score=-2.0),
        _smooth("noise", values, score=-9.0, p_value=0.5),  # not significant
        _smooth("worse_than_nothing", values, score=1.0),
        _smooth("oil*bhf", values, score=-9.0, kind="interaction"),  # products are the input surface's
    ]
    chosen = ids.smooth_accounts(fits, rules)
    assert [f.candidate.name for f in chosen] == ["wear", "a_ambient", "b_ambient"]
    # an input's own closed form counts (a step the quadratic surface cannot hold)
    step = _smooth("oil_film", values, score=-4.0, kind="input")
    assert [f.candidate.name for f in ids.smooth_accounts([*fits, step], rules)] == ["wear", "oil_film", "a_ambient"]


def test_an_id_that_stands_goes_after_the_causes_only_not_after_chance_candidates():
    # 30 coils with offsets of their own; an ambient reading follows them by chance (significant at 0.005 of 200
    # tests: far from a cause) and takes up part of their differences. Both kinds of candidate may say whether the
    # id stands; only causes (corrected, logged quantities and time) may put a smooth cause before it
    rng = np.random.default_rng(8)
    coil = np.repeat(np.arange(30), 40)
    own = rng.normal(0, 2.0, 30)[coil]
    y = own + rng.normal(0, 0.3, len(coil))
    ambient = 0.6 * own + rng.normal(0, 1.0, len(coil))
    group = Candidate.new("coil", "group", np.array([f"C-{c:02d}" for c in coil]), ("coil",))
    rules = fitting.Rules(SETTINGS, n_tests=200, min_effect=0.0)
    chance = rules.best_fit(Candidate.new("ambient", "log", ambient, ("ambient",)), y)
    chance = dataclasses.replace(chance, p_value=0.005)
    stands, names, share, _ = ids.id_stands(rules.best_fit(group, y), y, [group], {"ambient": chance}, rules)
    assert stands and names == () and share < 0.05
    cause = dataclasses.replace(chance, p_value=1e-9)
    stands, names, share, _ = ids.id_stands(rules.best_fit(group, y), y, [group], {"ambient": cause}, rules)
    assert stands and names == ("ambient",) and share > 0.2
    assert ids.smooth_accounts([chance], rules) == [chance] and ids.smooth_accounts([chance], rules, True) == []
    as_input = dataclasses.replace(cause, candidate=Candidate.new("ambient", "input", ambient, ("ambient",)))
    assert ids.smooth_accounts([as_input], rules, corrected=True) == []  # the input surface holds the inputs


def test_the_input_surface_is_shrunk_by_its_error_on_held_out_coils_not_on_rows():
    # 40 coils, eight material inputs constant within a coil and no effect of their own; the offsets are a
    # per-coil oil film's. Chosen over rows, the quadratic surface of the inputs recalls each coil's offset and
    # predicts an unseen coil's worse than nothing: the oil film then looked as if it explained none of the id
    rng = np.random.default_rng(11)
    n_coils, per_coil = 40, 60
    coil = np.repeat(np.arange(n_coils), per_coil)
    material = rng.uniform(-1, 1, (n_coils, 8))[coil]
    oil = rng.uniform(1.0, 2.0, n_coils)[coil] + rng.normal(0, 0.01, len(coil))
    y = 3.0 * (oil - oil.mean()) + rng.normal(0, 0.5, len(coil))
    inputs = [Candidate.new(f"m{j}", "input", material[:, j], (f"m{j}",)) for j in range(8)]
    group = Candidate.new("coil", "group", np.array([f"C-{c:02d}" for c in coil]), ("coil",))
    rules = fitting.Rules(SETTINGS, n_tests=10, min_effect=0.3)
    oil_fit = rules.best_fit(Candidate.new("oil_film", "log", oil, ("oil_film",)), y)
    stands, names, share, _ = ids.id_stands(rules.best_fit(group, y), y, [*inputs, group], {"oil_film": oil_fit}, rules)
    assert names == ("oil_film",)  # the surface, shrunk, predicts nothing the oil film does not: left out
    assert not stands and share > 0.9
    splits = ids.level_folds(group.values, SETTINGS.folds, SETTINGS.seed)
    assert ids.level_penalty(material, y, splits) >= 1e4  # the surface shrunk: the inputs hold nothing here


def test_a_season_accounts_for_the_lots_offsets_though_a_material_drifted_with_it():
    # 16 lots in time order, a season in calendar time (no logged column holds it) and six per-lot material
    # inputs, one of which drifted from lot to lot with the season. The surface of the materials, its penalty
    # chosen without the season, took up the lots' share of the season in fitting and predicted other lots
    # worse than the season alone: the lot stood for the season (structures draw 70006)
    rng = np.random.default_rng(1)
    n_lots, per_lot = 16, 150
    lot = np.repeat(np.arange(n_lots), per_lot)
    time = np.linspace(0, 1, n_lots * per_lot)
    material = rng.uniform(-1, 1, (n_lots, 6))
    material[:, 0] = 2 * (np.bincount(lot, time) / per_lot - 0.5) + rng.normal(0, 0.5, n_lots)
    y = 2.0 * np.sin(np.pi * time) + rng.normal(0, 0.5, len(time))
    inputs = [Candidate.new(f"m{j}", "input", material[lot, j], (f"m{j}",)) for j in range(6)]
    group = Candidate.new("lot", "group", np.array([f"L{c:02d}" for c in lot]), ("lot",))
    rules = fitting.Rules(SETTINGS, n_tests=10, min_effect=0.3)
    season = dataclasses.replace(
        rules.best_fit(Candidate.new("timestamp", "time", time, ("timestamp",)), y),
        form=forms.fit_form("quadratic", time, y),
    )
    left = ids.unaccounted(group, y, inputs, [season], rules)
    assert ids.accounted_share(group.values, y, left) > 0.95  # 0.28 with the surface held beside the season
    stands, names, share, _ = ids.id_stands(rules.best_fit(group, y), y, [*inputs, group], {"timestamp": season}, rules)
    assert not stands and names == ("timestamp",) and share > 0.95  # the surface left out, and not named


def test_the_input_surface_is_a_quadratic_of_the_standardized_inputs_whatever_their_units():
    rng = np.random.default_rng(5)
    z = rng.normal(0, 1, (600, 2))
    inputs = np.column_stack([0.005 + 0.001 * z[:, 0], 1000.0 * z[:, 1]])  # a thickness in m and a force in N
    quadratic = z[:, 0] ** 2 + z[:, 0] * z[:, 1] - 0.5 * z[:, 1]
    fitted = ids.surface(inputs, quadratic, penalty=1.0).predict(inputs)
    assert np.sqrt(np.mean((fitted - quadratic) ** 2)) < 0.02 * quadratic.std()
    # a cubic is beyond it: the surface is smooth by construction
    cubic = z[:, 0] ** 3
    left = cubic - ids.surface(inputs, cubic, penalty=1.0).predict(inputs)
    assert left.std() > 0.5 * cubic.std()


def test_columns_fitted_together_predict_their_sum_on_held_out_rows_whatever_their_offsets():
    rng = np.random.default_rng(8)
    a, b = rng.uniform(10, 20, 600), rng.uniform(100, 120, 600)  # far from zero: each form's mean is large
    y = 5.0 + 2.0 * a - 3.0 * b
    splits = [(np.arange(600)[np.arange(600) % 2 == k], np.arange(600)[np.arange(600) % 2 != k]) for k in (0, 1)]
    held_out = naming.held_out_sum([_smooth("a", a), _smooth("b", b)], splits, y)
    assert np.abs(held_out - y).max() < 1e-6


def test_elapsed_time_and_a_product_count_more_parameters_than_they_have():
    column, clock = _smooth("strokes", np.arange(50.0)), _smooth("hours", np.arange(50.0), kind="time")
    product = _smooth("a*b", np.arange(50.0), kind="interaction")
    own = naming._complexity(column)
    assert naming._complexity(clock) == naming._complexity(product) == own + naming.PROXY_PENALTY > own


def test_a_product_that_adds_nothing_is_dropped_only_once_an_id_is_chosen():
    rng = np.random.default_rng(9)
    n = 2000
    temp, other = rng.uniform(20, 50, n), rng.uniform(0, 1, n)
    coil = np.repeat(np.arange(40), n // 40)
    y = 0.2 * (temp - 35) + rng.normal(0, 0.4, 40)[coil] + rng.normal(0, 0.3, n)
    y -= y.mean()
    pair = Candidate.new("temp*other", "interaction", np.column_stack([temp, other]), ("temp", "other"))
    group = Candidate.new("coil", "group", coil.astype(str), ("coil",))
    by_name = {"temp": Candidate.new("temp", "input", temp, ("temp",)), "coil": group}
    rules = fitting.Rules(SETTINGS, n_tests=3, min_effect=0.1)  # the product is not significant given the rest

    def selection(*fits):
        return Selection(y, list(by_name.values()), rules, {}, list(fits))

    without_id = selection(best_fit(by_name["temp"], y, SETTINGS), best_fit(pair, y, SETTINGS))
    without_id.drop_products_an_id_holds()
    assert [fit.candidate.name for fit in without_id.chosen] == ["temp", "temp*other"]
    with_id = selection(best_fit(by_name["temp"], y, SETTINGS), best_fit(pair, y, SETTINGS))
    with_id.chosen.append(best_fit(group, y, SETTINGS))
    with_id.refit()
    with_id.drop_products_an_id_holds()
    assert [fit.candidate.name for fit in with_id.chosen] == ["temp", "coil"]


def test_a_product_chosen_first_gives_way_to_its_column_with_the_causes_after_it_kept():
    rng = np.random.default_rng(7)
    n = 3000
    temp, other, strokes = rng.uniform(20, 50, n), rng.uniform(0, 1, n), np.arange(n, dtype=float)
    y = 6.0 / (1 + np.exp(-(temp - 35) / 2.0)) + 8.0 * strokes / n + rng.normal(0, 0.4, n)
    y -= y.mean()
    pair = Candidate.new("temp*other", "interaction", np.column_stack([temp, other]), ("temp", "other"))
    by_name = {
        "temp": Candidate.new("temp", "input", temp, ("temp",)),
        "other": Candidate.new("other", "input", other, ("other",)),
        "strokes": Candidate.new("strokes", "log", strokes, ("strokes",)),
    }
    selection = chosen(y, by_name, best_fit(pair, y, SETTINGS), best_fit(by_name["strokes"], y, SETTINGS))
    assert selection.refine()
    assert [fit.candidate.name for fit in selection.chosen] == ["temp", "strokes"]
    assert selection.no_interaction == {"temp*other"}


def test_a_product_that_gave_way_to_its_column_is_no_candidate_when_the_causes_are_chosen_again():
    # a wear along the strokes and a campaign setting that tracks it: a product of the setting once out-scored the
    # wear and gave way to the setting alone; chosen again, the setting competes with the wear as a column
    rng = np.random.default_rng(8)
    n = 600
    strokes, r, pin = np.arange(n, dtype=float), rng.uniform(0, 1, n), np.repeat(np.arange(10.0), n // 10)
    y = 4.0 * strokes / n + 3.0 * (r - 0.5) * (pin - 4.5) / 9 + rng.normal(0, 0.2, n)
    pair = Candidate.new("r*pin", "interaction", np.column_stack([r, pin]), ("r", "pin"))
    columns = [Candidate.new(name, "input", v, (name,)) for name, v in (("strokes", strokes), ("r", r), ("pin", pin))]
    selection = Selection(y - y.mean(), [*columns, pair], Lenient(SETTINGS, min_effect=0.1), {})
    selection.refit()
    assert {f.candidate.name for f in selection.pool()} == {"strokes", "r", "pin", "r*pin"}
    selection.no_interaction.add("r*pin")
    assert {f.candidate.name for f in selection.pool()} == {"strokes", "r", "pin"}


def test_an_id_that_predicts_what_a_column_predicts_is_not_named_in_its_place_by_simplicity():
    rng = np.random.default_rng(10)
    n = 3000
    temp = rng.uniform(20, 50, n)
    shift = np.where(temp > 35, "late", "early")  # an id of two levels that follows the die temperature
    y = 5.0 / (1 + np.exp(-(temp - 35) / 0.3)) + rng.normal(0, 0.3, n)
    y -= y.mean()
    column = best_fit(Candidate.new("temp", "input", temp, ("temp",)), y, SETTINGS, 0.5)
    group = best_fit(Candidate.new("shift", "group", shift, ("shift",)), y, SETTINGS, 0.5)
    assert naming._complexity(group) < naming._complexity(column)  # the id alone would be the simpler
    rules = Lenient(SETTINGS, min_effect=0.5)
    assert naming.prefer_simpler(column, [column, group], y, rules).candidate.name == "temp"  # ids come last


def test_elapsed_time_chosen_gives_way_on_refining_to_the_logged_counter_that_predicts_the_same():
    rng = np.random.default_rng(11)
    n = 3000
    hours = np.arange(n) / 10.0
    strokes = np.arange(n) * 1.0 + rng.normal(0, 0.5, n)  # the press ran steadily: strokes follow time
    y = 2.0 * hours / hours.max() + rng.normal(0, 0.3, n)
    y -= y.mean()
    by_name = {
        "hours": Candidate.new("hours", "time", hours, ("hours",)),
        "strokes": Candidate.new("strokes", "log", strokes, ("strokes",)),
    }
    selection = chosen(y, by_name, best_fit(by_name["hours"], y, SETTINGS))
    assert selection.refine()
    assert [fit.candidate.name for fit in selection.chosen] == ["strokes"]


def test_forward_selection_names_a_real_product_first():
    rng = np.random.default_rng(12)
    n = 3000
    thickness, cushion = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    y = 8.0 * (thickness - 0.5) * (cushion - 0.5) + rng.normal(0, 0.3, n)
    y -= y.mean()
    candidates = [
        Candidate.new("thickness", "input", thickness, ("thickness",)),
        Candidate.new("cushion", "input", cushion, ("cushion",)),
        Candidate.new(
            "thickness*cushion", "interaction", np.column_stack([thickness, cushion]), ("thickness", "cushion")
        ),
    ]
    rules = fitting.Rules(SETTINGS, n_tests=3, min_effect=0.3)
    selection = Selection(y, candidates, rules, rules.fit_all(candidates, y))
    selection.forward()
    assert [fit.candidate.name for fit in selection.chosen] == ["thickness*cushion"]


def _scored(name: str, kind: str, share: float) -> fitting.Fit:
    """A fit that explains ``share`` of the residual's variance held out."""
    values = np.linspace(0, 1, 20)
    candidate = Candidate.new(name, kind, values, tuple(name.split("*")))
    return fitting.Fit(candidate, forms.fit_form("linear", values, values), values, 1.0 - share, 1.0, -1.0, 0.0, 1, 1)


def test_a_column_that_explains_most_of_what_an_id_does_goes_before_it():
    # a die temperature's saturation and a wear the coils' offsets follow: the surface of the inputs accounts
    # for little of the offsets (a quadratic cannot hold a saturation), but the column explains most of it
    coil = _scored("coil", "group", 0.8)
    assert smooth_first(_scored("die_temp", "input", 0.6), coil, accounted=0.0)
    assert smooth_first(_scored("strokes", "log", 0.5), coil, accounted=0.0)
    # offsets nothing logged causes: the best column explains a small part of them, the id goes first
    assert not smooth_first(_scored("air_temp", "input", 0.3), coil, accounted=0.0)
    assert not smooth_first(_scored("air_temp", "input", 0.45), coil, accounted=0.2)
    # ... unless the smooth candidates account for enough of its level differences held out by level
    assert smooth_first(_scored("air_temp", "input", 0.3), coil, accounted=0.25)
    # a product may take up a few coils' offsets by chance: its share does not put it first
    assert not smooth_first(_scored("rm*cushion", "interaction", 0.75), coil, accounted=0.1)


def test_the_spread_the_surrogate_error_gives_between_levels_is_its_chi_square_quantile():
    assert ids.surrogate_spread(1.0, 21, 0.01) == pytest.approx(1.371, abs=1e-3)
    assert ids.surrogate_spread(2.0, 21, 0.01) == pytest.approx(2 * 1.371, abs=2e-3)
    assert ids.surrogate_spread(1.0, 80, 0.01) < ids.surrogate_spread(1.0, 21, 0.01)  # more levels, less chance
    labels = np.repeat(np.arange(10), 30)
    rng = np.random.default_rng(0)
    assert levels.level_share(labels, rng.normal(size=10)[labels]) == pytest.approx(1.0)  # constant within a level
    assert levels.level_share(labels, rng.normal(size=300)) < 0.1


def test_coil_offsets_within_what_the_surrogate_error_gives_between_coils_are_not_named():
    # 21 coils of a material (an input constant per coil): the surrogate's error has one draw per coil, and the
    # spread of 21 draws exceeds the margin by up to 1.37 times (alpha 1%). Offsets nothing logged explains
    rng = np.random.default_rng(21)
    n_coils, per_coil = 21, 80
    coil = np.repeat(np.arange(n_coils), per_coil)
    frame = pd.DataFrame({"coil": [f"C-{c:03d}" for c in coil], "m1": rng.uniform(-1, 1, n_coils)[coil]})
    offsets = rng.normal(0, 1, n_coils)
    offsets = ((offsets - offsets.mean()) / offsets.std())[coil]
    noise = rng.normal(0, 0.3, len(coil))
    small = _diagnose(frame, 1.2 * offsets + noise, surrogate_std=1.0, inputs=("m1",))
    assert small.selected == [] and "coil" in small.proxies
    large = _diagnose(frame, 1.6 * offsets + noise, surrogate_std=1.0, inputs=("m1",))
    assert [f.candidate.name for f in large.selected] == ["coil"]
    # a shift's or a crew's levels, over which every input varies, hold little of the surrogate's error
    frame["m1"] = rng.uniform(-1, 1, len(coil))
    varied = _diagnose(frame, 1.2 * offsets + noise, surrogate_std=1.0, inputs=("m1",))
    assert [f.candidate.name for f in varied.selected] == ["coil"]


def _coils(n_coils: int, parts: int, seed: int):
    """An id of ``n_coils`` levels in time order, ``parts`` parts each, and two per-coil columns."""
    rng = np.random.default_rng(seed)
    coil = np.repeat(np.arange(n_coils), parts)
    labels = np.array([f"C{c:03d}" for c in coil])
    thickness = rng.normal(0.7, 0.02, n_coils)[coil]
    strength = rng.normal(300, 20, n_coils)[coil]
    candidates = [
        Candidate.new("coil", "group", labels, ("coil",)),
        Candidate.new("thickness", "input", thickness, ("thickness",)),
        Candidate.new("strength", "input", strength, ("strength",)),
        Candidate.new("die_temp", "input", rng.normal(40, 5, len(coil)), ("die_temp",)),  # varies within coils
    ]
    return rng, coil, candidates


def test_a_column_an_id_holds_is_judged_over_its_levels_against_the_columns_it_holds_shuffled():
    rng, coil, candidates = _coils(16, 50, seed=3)
    group, thickness, strength, die_temp = candidates
    assert [c.name for c in levels.held_columns(group, candidates)] == ["thickness", "strength"]
    assert levels.level_chance_p(die_temp, group, rng.normal(size=len(coil)), candidates, seed=0, alpha=0.01) is None
    # a true per-coil effect: the level means lie on its form
    true = 3 * (thickness.values - 0.7) / 0.02 + rng.normal(0, 0.3, len(coil))
    assert levels.level_chance_p(thickness, group, true, candidates, seed=0, alpha=0.01) == pytest.approx(1 / 200)
    # random coil offsets: over many plants the column fits them beyond chance at the level's rate only
    p_values = [
        levels.level_chance_p(thickness, group, np.random.default_rng(s).normal(size=16)[coil], candidates, s, 0.01)
        for s in range(40)
    ]
    assert np.mean(np.array(p_values) < 0.05) <= 0.1
    assert np.median(p_values) > 0.3


def test_the_level_shares_are_the_closed_forms_fitted_to_the_weighted_level_means():
    rng = np.random.default_rng(0)
    x, means, counts = rng.normal(size=12), rng.normal(size=12), rng.integers(5, 50, 12)
    xx, yy = np.repeat(x, counts), np.repeat(means, counts)
    shares = [
        1 - np.sum((yy - forms.fit_form(name, xx, yy).predict(xx)) ** 2) / np.sum((yy - yy.mean()) ** 2)
        for name in ("linear", "quadratic")
    ]
    assert levels.level_fit_shares(x[None, :], means, counts.astype(float))[0] >= max(shares) - 1e-9


def _exhaustive_step(x, means, counts) -> float:
    """The best step's share of the part-weighted variance, over every split between two distinct values with two
    levels or more on each side."""
    yy, best = np.repeat(means, counts), 0.0
    for cut in np.unique(x):
        below = x <= cut
        if below.sum() >= 2 and (~below).sum() >= 2:
            fitted = np.where(
                np.repeat(below, counts), yy[np.repeat(below, counts)].mean(), yy[~np.repeat(below, counts)].mean()
            )
            best = max(best, 1 - np.sum((yy - fitted) ** 2) / np.sum((yy - yy.mean()) ** 2))
    return best


def test_the_step_share_is_the_best_split_between_distinct_values():
    rng = np.random.default_rng(4)
    counts = rng.integers(5, 50, 12)
    weights = counts / counts.sum()
    for x in (
        rng.normal(size=12),
        np.repeat([1.0, 2.0, 3.0, 4.0], 3),
    ):  # distinct values; ties (a setting per campaign)
        means = rng.normal(size=12)
        means = means - np.sum(weights * means)
        assert levels.step_shares(x[None, :], means, weights)[0] == pytest.approx(_exhaustive_step(x, means, counts))
    # levels that share a value are not split: the offsets change inside the second value's levels
    x, means = np.repeat([1.0, 2.0, 3.0, 4.0], 3), np.array([-1.0] * 4 + [3.0] * 8)
    means = means - np.sum(weights * means)
    shared = levels.step_shares(x[None, :], means, weights)[0]
    assert shared == pytest.approx(_exhaustive_step(x, means, counts)) and shared < 0.95


def test_a_column_that_fits_an_ids_level_means_by_chance_does_not_go_before_it():
    coil = _scored("coil", "group", 0.8)
    assert not smooth_first(_scored("thickness", "input", 0.6), coil, accounted=0.4, by_chance=lambda: True)
    assert smooth_first(_scored("thickness", "input", 0.6), coil, accounted=0.0, by_chance=lambda: False)


def _per_coil_plant(seed: int, true_effect: bool):
    """14 coils of 80 parts with offsets of their own (or an effect of a per-coil thickness), a thickness that
    follows the offsets loosely, a per-coil strength and a die temperature that varies within coils."""
    rng = np.random.default_rng(seed)
    coil = np.repeat(np.arange(14), 80)
    own = rng.normal(0, 1.5, 14)
    thickness = 0.7 + 0.01 * (own + rng.normal(0, 1.5, 14))
    frame = pd.DataFrame(
        {
            "coil": np.array([f"K{c:02d}" for c in coil]),
            "thickness": thickness[coil] + rng.normal(0, 1e-5, len(coil)),
            "strength": rng.normal(300, 20, 14)[coil],
            "die_temp": rng.normal(40, 5, len(coil)),
        }
    )
    effect = 150 * (frame["thickness"].to_numpy() - 0.7) if true_effect else own[coil]
    return frame, effect + rng.normal(0, 0.5, len(coil))


def test_coil_offsets_a_per_coil_column_fits_by_chance_name_the_coil_and_say_why():
    frame, y = _per_coil_plant(5, true_effect=False)
    result = _diagnose(frame, y, surrogate_std=0.3, inputs=("thickness", "strength", "die_temp"))
    assert [f.candidate.name for f in result.selected] == ["coil"]  # without the level test: thickness, coil
    note = result.table.set_index("cause").loc["thickness", "note"]
    assert note.startswith("thickness is constant within each level of coil: its form fits the offsets of the 14")


def test_a_true_per_coil_effect_fits_the_level_means_beyond_chance_and_is_named():
    frame, y = _per_coil_plant(5, true_effect=True)
    result = _diagnose(frame, y, surrogate_std=0.3, inputs=("thickness", "strength", "die_temp"))
    assert [f.candidate.name for f in result.selected][:1] == ["thickness"]


def test_a_saturation_of_the_diagnosis_widths_at_an_inner_decile_fits_the_level_means_whole():
    x = np.linspace(0.0, 10.0, 21)
    means = 1.0 / (1.0 + np.exp(-(x - np.quantile(x, 0.5)) / (0.08 * 10.0)))
    weights = np.full(21, 30.0)
    assert levels.level_fit_shares(x[None, :], means, weights)[0] == pytest.approx(1.0)
    # neither a line, a parabola nor a step fits it whole
    xx, yy = np.repeat(x, 30), np.repeat(means, 30)
    for name in ("linear", "quadratic", "step"):
        fitted = forms.fit_form(name, xx, yy).predict(xx)
        assert 1 - np.sum((yy - fitted) ** 2) / np.sum((yy - yy.mean()) ** 2) < 0.99


def test_the_level_shares_of_many_orderings_at_once_are_those_of_each_alone():
    rng = np.random.default_rng(1)
    x, means, weights = rng.normal(size=9), rng.normal(size=9), rng.integers(5, 60, 9).astype(float)
    orders = np.array([rng.permutation(9) for _ in range(50)])
    together = levels.level_fit_shares(x[orders], means, weights)
    alone = [levels.level_fit_shares(x[order][None, :], means, weights)[0] for order in orders]
    np.testing.assert_allclose(together, alone, rtol=1e-12)


def test_an_id_of_too_few_levels_for_any_ordering_to_reach_alpha_says_nothing():
    assert levels.min_levels(0.01) == 6 and levels.min_levels(0.05) == 5
    rng, coil, candidates = _coils(5, 40, seed=2)
    group, thickness = candidates[0], candidates[1]
    perfect = 3 * (thickness.values - 0.7) / 0.02
    assert levels.level_chance_p(thickness, group, perfect, candidates, seed=0, alpha=0.01) is None
    assert levels.level_chance_p(thickness, group, perfect, candidates, seed=0, alpha=0.05) is not None


def test_a_column_is_judged_against_the_best_of_the_columns_the_id_holds():
    # the offsets follow the strength: the thickness is judged on its own fit, not on the strength's
    rng, coil, candidates = _coils(16, 50, seed=3)
    group, thickness, strength = candidates[:3]
    y = (strength.values - 300) / 20 + rng.normal(0, 0.2, len(coil))
    p_strength = levels.level_chance_p(strength, group, y, candidates, seed=0, alpha=0.01)
    p_thickness = levels.level_chance_p(thickness, group, y, candidates, seed=0, alpha=0.01)
    assert p_strength == pytest.approx(1 / 200) and p_thickness > 0.02  # 0.035: not at alpha 0.01


def test_a_long_level_holds_one_draw_of_its_offset_as_a_short_one_does():
    # three long lots and fifteen short ones; the offsets follow the strength's saturation and a thickness step
    counts = np.array([500, 300, 300] + [10, 20, 30, 40, 15] * 3)
    rng = np.random.default_rng(3)
    lot = np.repeat(np.arange(len(counts)), counts)
    strength, thickness = rng.uniform(200, 230, len(counts)), rng.uniform(0.66, 0.74, len(counts))
    offsets = 4 * np.tanh((strength - 215) / 3) + np.where(thickness > 0.7, 3.0, -3.0)
    y = offsets[lot] + rng.normal(0, 1.5, len(lot))
    candidates = [
        Candidate.new("lot", "group", np.array([f"L{k:02d}" for k in lot]), ("lot",)),
        Candidate.new("strength", "input", strength[lot], ("strength",)),
        Candidate.new("thickness", "input", thickness[lot], ("thickness",)),
    ]
    # weighted by parts, the three long lots outweigh the rest (p 0.38); each a draw of its offset, p 1/200
    assert levels.level_chance_p(candidates[1], candidates[0], y, candidates, seed=0, alpha=0.01) == pytest.approx(
        1 / 200
    )
    weights = levels.level_mean_weights(lot, counts, y)
    assert weights[0] / weights[-1] < 1.2  # 500 parts against 15: the offsets' variance dominates both
    # without offsets of their own, a level's mean weighs as its parts
    flat = rng.normal(0, 1.0, len(lot))
    weights = levels.level_mean_weights(lot, counts, flat)
    assert weights[0] / weights[3] == pytest.approx(50, rel=0.3)


def _standing_coil(y, frame, min_effect: float):
    """The selection on a per-coil plant, its coil's fit: the id that stands, whatever the other rules say."""
    candidates, _ = diagnosis.build_candidates(frame, ["thickness", "strength", "die_temp"], [], SETTINGS)
    rules = fitting.Rules(SETTINGS, n_tests=len(candidates), min_effect=min_effect)
    selection = Selection(y - y.mean(), candidates, rules, rules.fit_all(candidates, y - y.mean()))
    return selection, selection.conditional["coil"]


def test_a_column_the_id_holds_goes_before_it_where_it_fits_the_level_means_beyond_chance():
    frame, y = _per_coil_plant(5, true_effect=True)
    selection, coil = _standing_coil(y, frame, min_effect=0.3)
    assert selection._held_cause(coil).candidate.name == "thickness"  # its evidence: the 14 coils
    # ... and its effect must pass the margin
    assert _standing_coil(y, frame, min_effect=10.0)[0]._held_cause(coil) is None
    # random coil offsets that the thickness follows loosely: no held column beyond chance
    frame, y = _per_coil_plant(5, true_effect=False)
    selection, coil = _standing_coil(y, frame, min_effect=0.3)
    assert selection._held_cause(coil) is None


def _ranked(name: str, kind: str, score: float) -> fitting.Fit:
    return dataclasses.replace(_scored(name, kind, 0.5), score=score)


def test_a_product_that_is_no_interaction_leaves_its_column_to_compete_with_the_others(monkeypatch):
    # the product ranks first but is named as its column; the ambient, alone, predicts better than that column
    product, die_temp = _ranked("die_temp*cushion", "interaction", -30.0), _ranked("die_temp", "input", -20.0)
    ambient = _ranked("ambient", "input", -25.0)
    pool = [product, die_temp, ambient]
    selection = Selection(
        np.zeros(20), [f.candidate for f in pool], Lenient(SETTINGS), {f.candidate.name: f for f in pool}
    )
    monkeypatch.setattr(Selection, "_named", lambda self, best, pool: die_temp if best is product else best)
    assert selection._next_smooth(pool) is ambient
    # a product that is one (named as itself) is not second-guessed
    monkeypatch.setattr(Selection, "_named", lambda self, best, pool: best)
    assert selection._next_smooth(pool) is product
    # nor is its column where that column is the strongest of the columns
    weaker = _ranked("ambient", "input", -10.0)
    monkeypatch.setattr(Selection, "_named", lambda self, best, pool: die_temp if best is product else best)
    assert selection._next_smooth([product, die_temp, weaker]) is die_temp


def test_a_product_that_gives_way_on_refining_leaves_its_column_to_compete_with_the_others():
    rng = np.random.default_rng(4)
    die_temp, ambient = rng.normal(40, 5, 600), rng.normal(20, 3, 600)
    candidates = [
        Candidate.new("die_temp", "input", die_temp, ("die_temp",)),
        Candidate.new("ambient", "input", ambient, ("ambient",)),
    ]
    rules = fitting.Rules(SETTINGS, n_tests=2)
    selection = Selection(np.zeros(600), candidates, rules, {})
    # what the other causes leave follows the ambient: the die temperature the product gave way to yields
    rest = 0.5 * (ambient - 20) + rng.normal(0, 0.3, 600)
    column = rules.best_fit(candidates[0], rest)
    assert selection._strongest_column(column, rest).candidate.name == "ambient"
    # ... and where it follows the die temperature, the column stays
    rest = 0.3 * (die_temp - 40) + rng.normal(0, 0.3, 600)
    column = rules.best_fit(candidates[0], rest)
    assert selection._strongest_column(column, rest) is column


def _matern(X, factor):
    """The simulator's correlation of these tests: Matern 5/2, unit length scales on the raw inputs."""
    from sklearn.gaussian_process.kernels import Matern

    return Matern(length_scale=np.full(X.shape[1], factor), nu=2.5)(X)


def _levels_at(centres, scatter, rng, parts=150):
    """Parts of one level per centre, their inputs scattered about it: (inputs, level labels)."""
    X = np.vstack([c + rng.normal(0, scatter, (parts, len(c))) for c in centres])
    return X, np.repeat([f"L{k:02d}" for k in range(len(centres))], parts)


def _inputs(X):
    return [Candidate.new(f"x{j + 1}", "input", X[:, j], (f"x{j + 1}",)) for j in range(X.shape[1])]


def test_offsets_of_levels_at_near_equal_inputs_are_the_ids_own():
    rng = np.random.default_rng(5)
    X, labels = _levels_at(rng.normal(0, 0.05, (15, 2)), 0.02, rng)  # coils of one campaign
    offsets = rng.normal(0, 1.0, 15)
    y = offsets[np.unique(labels, return_inverse=True)[1]] + rng.normal(0, 0.3, len(X))
    group = Candidate.new("coil", "group", labels, ("coil",))
    assert ids.offsets_beyond_inputs_p(group, y, _inputs(X), _matern) < 0.01


def test_offsets_of_levels_at_inputs_of_their_own_are_what_a_smooth_function_gives():
    rng = np.random.default_rng(5)
    X, labels = _levels_at(rng.uniform(-2, 2, (15, 2)), 0.05, rng)  # a lot per campaign
    y = 3 * np.sin(1.5 * X[:, 0]) + X[:, 1] ** 2 + rng.normal(0, 0.3, len(X))
    group = Candidate.new("lot", "group", labels, ("lot",))
    assert ids.offsets_beyond_inputs_p(group, y, _inputs(X), _matern) > 0.1
    assert ids.offsets_beyond_inputs_p(group, y, _inputs(X), None) is None


def test_a_lot_per_campaign_is_not_named_for_a_discrepancy_of_the_inputs_alone():
    rng = np.random.default_rng(7)
    X, labels = _levels_at(rng.uniform(-2, 2, (16, 2)), 0.05, rng, parts=200)
    x1, x2 = X.T
    y = (x1**2 + x2 - 1.5) ** 2 + (x1 + x2**2 - 2) ** 2  # Himmelblau's valleys: no form of one column holds them
    y = y - y.mean() + rng.normal(0, 0.5, len(X))
    frame = pd.DataFrame({"x1": x1, "x2": x2, "lot": labels})
    settings = Settings(folds=5, seed=0)
    plain = diagnosis.diagnose(frame, y, ["x1", "x2"], [], settings, surrogate_std=0.05)
    assert "lot" in [f.candidate.name for f in plain.selected]  # without the simulator's correlation
    result = diagnosis.diagnose(frame, y, ["x1", "x2"], [], settings, surrogate_std=0.05, input_correlation=_matern)
    assert "lot" not in [f.candidate.name for f in result.selected]
    assert result.proxies["lot"].share is None and result.proxies["lot"].own_p >= 0.01
    note = result.table.set_index("cause").loc["lot", "note"]
    assert "ran at inputs of their own" in note


def test_the_id_test_sees_the_chosen_forms_of_the_inputs_put_back_and_nothing_else():
    rng = np.random.default_rng(9)
    n = 400
    x, strokes = rng.uniform(-1, 1, n), np.arange(n, dtype=float)
    y = 2.0 * x**2 + strokes / n + rng.normal(0, 0.1, n)
    columns = [Candidate.new("x", "input", x, ("x",)), Candidate.new("strokes", "log", strokes, ("strokes",))]
    selection = Selection(y - y.mean(), columns, Lenient(SETTINGS), {})
    selection.chosen = [best_fit(columns[0], y, SETTINGS), best_fit(columns[1], y, SETTINGS)]
    selection.refit()
    x_term = selection.chosen[0].form.predict(x)  # the stroke counter's term stays out
    np.testing.assert_allclose(selection._of_inputs(), selection.remaining + x_term)


def _saturating_plant(seed: int):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 1, 400)
    return Candidate.new("x", "input", x, ("x",)), np.tanh(6 * (x - 0.5)) + 0.1 * rng.normal(size=400)


def test_a_fit_asked_again_on_the_same_target_is_remembered_and_comes_as_a_copy():
    candidate, y = _saturating_plant(5)
    rules = fitting.Rules(SETTINGS, n_tests=1, min_effect=0.0)
    first = rules.best_fit(candidate, y)
    again, third = rules.best_fit(candidate, y), rules.fit_all([candidate], y)["x"]
    assert len(rules.memory.fits) == 1
    fresh = best_fit(candidate, y, SETTINGS)
    for fit in (first, again, third):
        assert (fit.form.name, fit.score, fit.oof.tolist()) == (fresh.form.name, fresh.score, fresh.oof.tolist())
    assert again is not third and again.form is not third.form and again.alternatives[0] is again
    assert again.candidate is candidate and again.oof is not third.oof
    assert all(stored is not fit for stored, _ in rules.memory.fits.values() for fit in (first, again, third))
    rules.best_fit(candidate, y + 1.0)  # another target, another candidate of the same values, another one's
    renamed = Candidate.new("x2", "input", candidate.values, ("x2",))
    rules.fit_all([renamed, Candidate.new("x", "input", candidate.values[::-1].copy(), ("x",))], y)
    assert len(rules.memory.fits) == 4 and rules.best_fit(renamed, y).candidate is renamed
    loose = fitting.Rules(SETTINGS, n_tests=1, min_effect=5.0, memory=rules.memory)
    assert loose.best_fit(candidate, y).effect_std == fresh.effect_std and len(rules.memory.fits) == 5
    four_folds = fitting.Rules(dataclasses.replace(SETTINGS, folds=4), n_tests=1, memory=rules.memory)
    four_folds.best_fit(candidate, y)
    assert len(rules.memory.fits) == 6


def test_the_fit_memory_forgets_the_oldest_fits_beyond_its_bytes():
    candidate, y = _saturating_plant(6)
    fit = best_fit(candidate, y, SETTINGS)
    size = sum(alternative.oof.nbytes for alternative in fit.alternatives)
    memory = fitting.FitMemory(max_bytes=2 * size)
    for shift in range(3):
        memory.put(memory.key(candidate, y + shift), fit)
    assert memory.get(memory.key(candidate, y)) is None and memory.get(memory.key(candidate, y + 2)) is not None
    assert memory.bytes == 2 * size


def test_a_column_beside_another_held_cause_is_judged_on_what_that_cause_leaves(monkeypatch):
    # 18 coils whose offsets follow a strength's saturation and a thickness step at once
    rng, coil, candidates = _coils(18, 40, seed=3)
    group, thickness, strength = candidates[:3]
    y = 2.5 * forms.logistic((strength.values - 300) / 6) + 1.2 * (thickness.values > 0.7)
    y = y + rng.normal(0, 0.5, len(coil))
    assert levels.level_chance_p(thickness, group, y, candidates, seed=0, alpha=0.01) == pytest.approx(1 / 200)
    # the partner is the held column that fits the means best, not a third one of no effect
    means = np.bincount(coil, weights=y) / np.bincount(coil)
    level_values = {c.name: c.values[::40] for c in candidates[1:3]} | {"width": rng.normal(1500, 5, 18)}
    assert levels._beside_partner("thickness", level_values, means, np.ones(18))[0] == "strength"
    # judged alone, the strength's share is noise to the thickness: no better than chance
    monkeypatch.setattr(levels, "_beside_partner", lambda *args: None)
    assert levels.level_chance_p(thickness, group, y, candidates, seed=0, alpha=0.01) > 0.3


def test_two_held_columns_fit_random_coil_offsets_beyond_chance_at_no_more_than_the_level():
    p_values = []
    for s in range(40):
        _, coil, candidates = _coils(16, 50, seed=100 + s)
        offsets = np.random.default_rng(s).normal(size=16)[coil]
        p_values.append(levels.level_chance_p(candidates[1], candidates[0], offsets, candidates, s, 0.01))
    assert np.mean(np.array(p_values) < 0.05) <= 0.05
    assert np.median(p_values) > 0.3


def test_the_min_p_of_one_statistic_is_its_own_p_and_of_two_copies_the_same():
    shuffled = np.random.default_rng(0).uniform(size=199)
    for observed in (0.5, 0.99, 1.5):
        own = (1 + np.sum(shuffled >= observed)) / 200
        assert levels.min_p([observed], [shuffled]) == pytest.approx(own)
        assert levels.min_p([observed, observed], [shuffled, shuffled]) == pytest.approx(own)
    # a second, independent statistic costs: the smaller of two p-values is smaller by chance
    other = np.random.default_rng(1).uniform(size=199)
    assert levels.min_p([0.9, 0.5], [shuffled, other]) > min(
        levels.min_p([0.9], [shuffled]), levels.min_p([0.5], [other])
    )


def test_the_level_fit_values_are_the_form_whose_share_the_level_shares_report():
    rng = np.random.default_rng(2)

    def share(x, means, weights):
        w = weights / weights.sum()
        fitted = levels.level_fit_values(x, means, weights)
        return 1 - np.sum(w * (means - fitted) ** 2) / np.sum(w * (means - np.sum(w * means)) ** 2)

    for n_levels in (7, 12, 25):
        x, means, weights = rng.normal(size=n_levels), rng.normal(size=n_levels), rng.integers(1, 60, n_levels)
        x[:3] = x[3]  # ties: a setting shared by several coils
        weights = weights.astype(float)
        assert share(x, means, weights) == pytest.approx(levels.level_fit_shares(x[None, :], means, weights)[0])
    # a saturation of the diagnosis' widths is fitted whole; a step with one level on a side is not a form
    x, weights = np.linspace(0.0, 10.0, 15), np.full(15, 20.0)
    saturation = forms.logistic((x - np.quantile(x, 0.5)) / (forms.SIGMOID_WIDTH_SHARES[0] * 10.0))
    np.testing.assert_allclose(levels.level_fit_values(x, saturation, weights), saturation, atol=1e-9)
    lone = (x == x.max()).astype(float)
    assert share(x, lone, weights) == pytest.approx(levels.level_fit_shares(x[None, :], lone, weights)[0])
    assert share(x, lone, weights) < 0.9


def test_a_monotone_trend_that_took_up_a_second_per_lot_cause_gives_way_to_a_closed_form_and_that_cause():
    # 18 lots of a jittered yield strength (a saturation) and a thickness (a step): the trend's jumps took up
    # most of the step, which was then not significant
    rng = np.random.default_rng(15)
    sizes = np.maximum(1, rng.geometric(1 / 80, 18))
    strength, thickness = rng.uniform(200, 230, 18), rng.uniform(0.66, 0.75, 18)
    lot = np.repeat(np.arange(18), sizes)
    frame = pd.DataFrame({"ys": strength[lot] + rng.normal(0, 0.12, len(lot)), "thickness": thickness[lot]})
    y = 9 * forms.logistic((frame["ys"].to_numpy() - 215.7) / 5) + 4 * (thickness[lot] >= 0.70)
    result = _diagnose(frame, y + rng.normal(0, 0.5, len(lot)), surrogate_std=0.5, inputs=("ys", "thickness"))
    assert sorted(f.candidate.name for f in result.selected) == ["thickness", "ys"]  # before: the trend alone
