"""The monitor, fast: the CUSUM by hand, and `hybridtwin monitor` on the tiny stored run (tests/data/models) with
the head of its production log as the batch (in control), with a step added, and with bad input."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from hybridtwin.answers.predictor import Predictor
from hybridtwin.cli import main
from hybridtwin.io.errors import InputError
from hybridtwin.monitor import calibration, chart, regimes, watch, words
from hybridtwin.monitor.changes import NEW, UNEXPLAINED, boundary_of, clocks, moved_cause, new_form, slope, step_of

from .conftest import says

DATA = Path(__file__).resolve().parent / "data"
MODELS = str(DATA / "models")


@pytest.fixture(scope="module")
def predictor():
    return Predictor.load(MODELS)


@pytest.fixture(scope="module")
def parts():
    return pd.read_csv(DATA / "production_head.csv")


@pytest.fixture(scope="module")
def stepped(predictor, parts):
    """The head with the plant 3 expected errors higher from part 201 on."""
    batch = parts.copy()
    batch.loc[200:, "draw_in_mm"] += 3 * 2.41
    return watch.watch(predictor, batch)


def test_one_side_is_the_cusum_recursion_by_hand():
    statistic, start = chart.one_side(np.array([1.0, -2.0, 0.5, 0.5, -0.2, 3.0]))
    # S: max(0, 0+1)=1, max(0, 1-2)=0, 0.5, 1.0, 0.8, 3.8; the excursion began after the zero at index 1
    np.testing.assert_allclose(statistic, [1.0, 0.0, 0.5, 1.0, 0.8, 3.8])
    assert start.tolist() == [0, 2, 2, 2, 2, 2]


def test_cusum_alarms_at_the_first_part_over_the_limit_and_dates_the_start():
    z = np.r_[np.zeros(50), np.full(30, 3.0)]  # each changed part adds 3 - k = 2
    result = chart.cusum(z, reference=1.0, limit=20.0)
    assert result.alarm_at == 60 and result.start_at == 50 and result.direction == 1  # 11 parts: 22 > 20
    assert not result.alarm[:60].any() and result.alarm[60:].all()
    down = chart.cusum(-z, reference=1.0, limit=20.0)
    assert down.alarm_at == 60 and down.direction == -1
    assert chart.cusum(np.full(1000, 0.99), 1.0, 20.0).alarm_at is None  # within the allowance: never


def test_parts_not_judged_leave_the_statistic_as_it_was():
    z = np.r_[np.full(5, 2.0), np.full(100, np.nan), np.full(5, 2.0)]
    result = chart.cusum(z, reference=1.0, limit=8.0)
    assert result.statistic[104] == result.statistic[4] == 5.0
    assert result.alarm_at == 108 and result.start_at == 0
    assert chart.cusum(np.r_[np.zeros(10), 100.0], 1.0, 8.0).alarm_at is None  # one wild part is clipped at 4


def test_regimes_begin_where_a_coil_or_shift_changes_or_an_input_jumps_and_not_at_a_timestamp_or_part_id():
    rng = np.random.default_rng(0)
    n = 400
    log = pd.DataFrame(
        {
            "time": pd.date_range("2026-01-01", periods=n, freq="5s").astype(str),
            "serial": [f"P{i}" for i in range(n)],  # an id per part marks no regime
            "coil": np.repeat(["K1", "K2"], [250, 150]),
            "shim": np.r_[np.full(100, 0.45), np.full(300, 0.55)] + rng.normal(0, 0.004, n),
            "temp": np.linspace(20, 60, n) + rng.normal(0, 0.5, n),  # warms: no jump
        }
    )
    found = regimes.Regimes.learn(log, ["shim", "temp"])
    assert found.columns == ("coil",) and set(found.jumps) == {"shim", "temp"}
    assert np.flatnonzero(found.starts(log)).tolist() == [0, 100, 250]
    assert np.flatnonzero(found.starts(log, settings_only=True)).tolist() == [0, 100]
    assert regimes.Regimes.from_dict(found.to_dict()) == found
    # the parts of a regime that another model predicts sit at a level of their own
    labels = regimes.labels(np.array([1, 0, 0, 1, 0, 0], bool), ["a", "a", "b", "a", "b", "a"])
    assert labels[0] == labels[1] != labels[2] and labels[3] == labels[5] != labels[4] and labels[0] != labels[3]


def test_a_stretch_of_blank_ids_is_one_regime_and_a_change_of_id_is_found_beside_it():
    from hybridtwin.monitor.changes import boundary_of

    coil = pd.Series(["K1"] * 50 + [np.nan] * 30 + ["K2"] * 20, dtype="str")
    found = regimes.Regimes(("coil",), {})
    assert np.flatnonzero(found.starts(pd.DataFrame({"coil": coil}))).tolist() == [0, 50, 80]
    assert regimes.text_changes(coil).sum() == 2
    assert boundary_of(coil, 78) == 80 and boundary_of(coil, 52) == 50
    # ids are compared as their text: "7" and 7 are one id, 7.0 (text "7.0") another
    assert regimes.text_changes(pd.Series(["7", 7, 7.0], dtype=object)).tolist() == [False, True]


def test_the_within_regime_residual_is_against_the_mean_of_the_parts_before_it_by_hand():
    residual = np.array([1.0, 3.0, 2.0, 10.0, 5.0, np.nan, 7.0])
    group = np.array([0, 0, 0, 0, 1, 1, 1])
    got = regimes.within(residual, group, least=1)
    # part 1: (3 - 1) / sqrt(2); part 2: (2 - 2) / sqrt(1.5); part 3: (10 - 2) / sqrt(4 / 3); a new regime restarts
    np.testing.assert_allclose(got[[1, 2, 3, 6]], [2 / np.sqrt(2), 0.0, 8 / np.sqrt(4 / 3), 2 / np.sqrt(2)])
    assert np.isnan(got[[0, 4, 5]]).all()
    windowed = regimes.within(residual, group, least=1, window=1)  # the part before only
    np.testing.assert_allclose(windowed[[2, 3]], [-1 / np.sqrt(2), 8 / np.sqrt(2)])
    means, counts, at = regimes.levels(residual, group, parts=2, least=1)
    np.testing.assert_allclose(means, [2.0, 6.0])
    assert counts.tolist() == [2, 2] and at.tolist() == [1, 6]
    # interleaved regimes (a model pair within one): each level over its own first parts, in time order
    means, counts, at = regimes.levels(np.array([1.0, 4.0, 3.0, 9.0, 8.0, 9.0]), np.array([5, 2, 5, 5, 2, 2]), 2, 1)
    assert means.tolist() == [6.0, 2.0] and counts.tolist() == [2, 2] and at.tolist() == [4, 2]


def _campaigns(rng, n, length, spread):
    """A log-like series: campaigns of ``length`` parts, each off by its own settled amount (SD ``spread``)."""
    group = np.arange(n) // length
    return rng.normal(0, spread, group.max() + 1)[group] + rng.normal(0, 1, n), group


CONSTANTS = chart.Constants({}, 1.0, 1.0, 3.0, 13.0, 8.0)


def test_settled_campaign_errors_raise_no_alarm_where_a_cusum_for_independent_errors_alarms_at_once():
    rng = np.random.default_rng(1)
    residual, group = _campaigns(rng, 10_000, 200, 3.0)  # campaigns 3 noise SDs apart, as out of the support
    z = residual / np.sqrt(10.0)  # the region's expected error: the root mean square of both
    assert chart.cusum(z, 1.0, 20.0).alarm_at is not None  # the plain chart: an alarm within the batch
    quiet = chart.regime_chart(residual, z, np.full(10_000, "r"), group, CONSTANTS)
    assert quiet.alarm_at is None and quiet.statistic.max() < chart.LIMIT


def test_a_step_inside_a_regime_alarms_within_a_few_dozen_parts_and_is_dated():
    rng = np.random.default_rng(2)
    residual, group = _campaigns(rng, 10_000, 400, 3.0)
    residual[3050:] += 1.5  # 1.5 noise SDs, 50 parts into a campaign
    z = residual / np.sqrt(10.0)
    result = chart.regime_chart(residual, z, np.full(10_000, "r"), group, CONSTANTS)
    assert result.alarmed_by == chart.WITHIN and 3050 <= result.alarm_at <= 3050 + 60
    assert abs(result.start_at - 3050) <= 10 and result.direction == 1
    assert result.statistic[result.alarm_at] > chart.LIMIT >= result.statistic[: result.alarm_at].max()


def test_a_shift_that_every_new_regime_carries_alarms_on_the_regimes_levels():
    rng = np.random.default_rng(3)
    residual, group = _campaigns(rng, 10_000, 100, 1.0)
    residual[3000:] += 4.0  # begins with a campaign: the within-regime chart cannot see it
    z = residual / np.sqrt(2.0)
    result = chart.regime_chart(residual, z, np.full(10_000, "r"), group, chart.Constants({}, 1.0, 0.7, 0.7, 13, 8))
    assert result.alarmed_by == chart.LEVEL and 3000 < result.alarm_at < 4000 and result.start_at % 100 == 0


def test_regimes_that_spread_further_than_the_logs_widen_the_level_chart_and_a_shift_they_carry_still_alarms():
    rng = np.random.default_rng(31)
    group = np.arange(10_000) // 200  # 50 regimes
    spread = rng.normal(0, 1.0, 50)  # in control, but three times the log's spread of levels (0.3)
    residual = spread[group] + rng.normal(0, 1.0, 10_000)
    held, pooled = (chart.Constants({}, 1.0, 1.0, 0.3, 1e9, 8.0, regimes) for regimes in (0, 20))
    assert chart.regime_chart(residual, residual, np.full(10_000, "r"), group, held).alarm_at is not None
    assert chart.regime_chart(residual, residual, np.full(10_000, "r"), group, pooled).alarm_at is None
    shifted = residual + 3.0 * (group >= 25)  # from a regime's start on: the levels' chart alone can see it
    found = chart.regime_chart(shifted, shifted, np.full(10_000, "r"), group, pooled)
    assert found.alarmed_by == chart.LEVEL and 5000 < found.alarm_at < 5000 + 5 * 200


def test_the_spread_of_levels_pools_the_logs_regimes_with_those_known_before_and_never_falls_below_the_logs():
    constants = chart.Constants({}, 1.0, 1.0, 0.5, 13.0, 8.0, level_regimes=4)
    means, counts = np.array([3.0, 0.0, 1.5, 2.0]), np.array([100, 20, 50, 8])
    at = np.array([400, 100, 200, 300])  # known in another order than listed: 0.0, 1.5, 2.0, then 3.0

    def pooled(known):  # the log's 4 regimes at 0.5**2 and the spread about their mean of those known before
        levels, scatter = np.array([m for m, _ in known]), np.array([1.0 / n for _, n in known])
        degrees = max(len(known) - 1, 0)
        # the sum of squares about the plain mean holds (1 - 1/k) of each level's scatter, whatever the counts
        excess = np.sum((levels - levels.mean()) ** 2) - scatter.sum() * (1 - 1 / len(known)) if degrees else 0.0
        return np.sqrt(max(0.25, (4 * 0.25 + excess) / (4 + degrees)))

    first, second, third = (0.0, 20), (1.5, 50), (2.0, 8)
    expected = [pooled([first, second, third]), pooled([]), pooled([first]), pooled([first, second])]
    assert expected[1:3] == [0.5, 0.5] and min(expected[0], expected[3]) > 0.6  # above the log's where spread
    np.testing.assert_allclose(chart.between_levels(means, counts, at, constants), expected)
    # a shift every regime of the batch shares is no spread: the chart sums the levels against the log's
    np.testing.assert_allclose(chart.between_levels(np.full(4, 5.0), counts, at, constants), 0.5)
    unpooled = chart.Constants({}, 1.0, 1.0, 0.5, 13.0, 8.0)  # models stored before: the log's spread alone
    np.testing.assert_allclose(chart.between_levels(means, counts, at, unpooled), 0.5)
    assert chart.Constants.from_dict({k: v for k, v in constants.to_dict().items() if k != "level_regimes"}) == unpooled


def test_the_limits_come_from_the_logs_own_regimes_and_are_never_below_the_floor():
    rng = np.random.default_rng(4)
    residual, group = _campaigns(rng, 8000, 200, 3.0)
    starts = np.r_[True, group[1:] != group[:-1]]
    log = pd.DataFrame({"campaign": [f"C{g:03d}" for g in group]})
    z = residual / np.sqrt(10.0)
    found, fitted, _, _ = calibration.constants(log, [], residual, z, np.full(8000, "r"), np.full(8000, "m"))
    assert found.columns == ("campaign",)
    assert fitted.within_scale["r"] == pytest.approx(1.0, abs=0.05) and fitted.level_between == pytest.approx(
        0.95, abs=0.3
    )
    assert fitted.within_limit == calibration.FLOOR_WITHIN  # independent noise inside the regimes: the floor holds
    assert fitted.level_regimes == 40  # the weight of the log's spread of levels beside a batch's own regimes
    # a jump inside regimes (a campaign change the log's columns do not mark) raises the limit
    jumped = residual + np.where((np.arange(8000) % 200) >= 100, 3.0, 0.0)
    _, raised, _, _ = calibration.constants(
        log, [], jumped, jumped / np.sqrt(10.0), np.full(8000, "r"), np.full(8000, "m")
    )
    within = chart.within_steps(jumped, np.full(8000, "r"), group, raised)
    assert raised.within_limit > calibration.FLOOR_WITHIN and raised.within_limit >= calibration.peak(within, 0.5)
    assert calibration.limits(within, np.full(8000, np.nan), starts, 0)[0] == pytest.approx(raised.within_limit)


def test_the_within_regime_quantities_by_stretches_of_whole_regimes_are_those_of_the_whole_log(monkeypatch):
    rng = np.random.default_rng(5)
    residual, group = _campaigns(rng, 8000, 150, 3.0)
    residual[rng.random(8000) < 0.1] = np.nan  # parts not judged, as out of the support's far reach
    log = pd.DataFrame({"campaign": [f"C{g:03d}" for g in group]})
    models = np.where(np.arange(8000) % 7 == 0, "stack", "hybrid")  # interleaved model pairs inside a regime
    args = (log, [], residual, residual / np.sqrt(10.0), np.full(8000, "r"), models)
    whole = calibration.constants(*args)[1]
    monkeypatch.setattr(calibration, "STRETCH_PARTS", 1000)  # eight stretches, cut at regime starts only
    stretched = calibration.constants(*args)[1]
    for name, value in whole.to_dict().items():
        assert stretched.to_dict()[name] == pytest.approx(value, rel=1e-12), name
    starts = np.r_[True, group[1:] != group[:-1]]
    labels = regimes.labels(starts, models)
    bounds = calibration._blocks(starts, 1000)
    found = calibration.stretch_levels(residual, labels, bounds)
    for got, expected in zip(found, chart.regime_levels(residual, labels)):
        np.testing.assert_allclose(got, expected, rtol=1e-12)
    np.testing.assert_allclose(
        calibration.by_stretches(chart.within_residuals, bounds, residual, labels),
        chart.within_residuals(residual, labels),
        atol=1e-11,  # a running sum per stretch, not over the log: the last digits differ
    )


def test_the_floors_keep_independent_noise_quiet_through_the_same_charts():
    rng = np.random.default_rng(6)
    within, levels = [], []
    for _ in range(200):  # batches of 10,000 parts, regimes of 50 to 500
        group = np.repeat(np.arange(100), rng.integers(50, 500, 100))[:10_000]
        within.append(calibration.peak(regimes.within(rng.normal(0, 1, 10_000), group, 5, chart.WITHIN_WINDOW), 0.5))
        levels.append(calibration.peak(rng.normal(0, 1, 200), chart.LEVEL_REFERENCE))
    assert max(within) < calibration.FLOOR_WITHIN and max(levels) < calibration.FLOOR_LEVEL
    assert np.quantile(within, 0.99) > calibration.FLOOR_WITHIN / 2  # the floor is no wild guess either


def test_a_known_cause_moved_when_the_residual_follows_it_by_another_slope_since_the_start():
    rng = np.random.default_rng(5)
    n = 6000
    residual, group = _campaigns(rng, n, 150, 3.0)
    temperature = 40 + 10 * np.sin(np.arange(n) / 700) + rng.normal(0, 0.5, n)
    frame = pd.DataFrame({"temp": temperature})
    judged = np.ones(n, bool)
    reference = {"temp": [0.0, 0.02]}
    assert (
        moved_cause(frame, residual + np.where(np.arange(n) >= 2000, 3.0, 0.0), judged, group, 2000, reference, 1.0)
        is None
    )
    grown = residual + np.where(np.arange(n) >= 2000, 0.4 * (temperature - 30), 0.0)
    name, change = moved_cause(frame, grown, judged, group, 2000, reference, 1.0)
    assert name == "temp" and change == pytest.approx(
        0.4 * np.ptp(np.quantile(temperature[2000:], [0.05, 0.95])), rel=0.3
    )


def _stretches(n: int, length: int) -> list[tuple[int, int]]:
    return [(a, min(a + length, n)) for a in range(0, n, length)]


def test_stretches_of_the_log_hold_whole_regimes_enough_parts_and_enough_regimes():
    short = np.arange(30_000) % 150 == 0  # regimes of 150 parts: 3,000 parts hold 20 of them
    assert calibration._blocks(short, 3000, 10) == _stretches(30_000, 3000)
    long = np.arange(30_000) % 1000 == 0  # of 1,000 parts: ten regimes make a stretch
    assert calibration._blocks(long, 3000, 10) == _stretches(30_000, 10_000)
    assert calibration._blocks(np.arange(24_000) % 1000 == 0, 3000, 10) == [(0, 10_000), (10_000, 24_000)]


def test_a_slope_that_moves_between_stretches_of_the_log_sets_how_far_a_batch_may_move_in_control():
    rng = np.random.default_rng(8)
    n = 30_000
    residual, group = _campaigns(rng, n, 150, 1.0)
    starts = np.arange(n) % 150 == 0
    temperature = 40 + 10 * np.sin(np.arange(n) / 700) + rng.normal(0, 0.5, n)
    judged = np.ones(n, bool)
    steady = residual + 0.1 * (temperature - 40)
    assert calibration.slope_spread(temperature, steady, judged, group, starts) < 0.04  # chance alone
    by_stretch = rng.normal(0.1, 0.1, n // 3000 + 1)[np.arange(n) // 3000]  # the slope of each stretch its own
    wandering = residual + by_stretch * (temperature - 40)
    spread = calibration.slope_spread(temperature, wandering, judged, group, starts)
    assert spread == pytest.approx(0.1, rel=0.5)
    # by hand: the stretches' slopes and errors, and the method of moments on Cochran's Q
    fits = np.array([slope(temperature[a:b], wandering[a:b], group[a:b]) for a, b in _stretches(n, 3000)])
    w = fits[:, 1] ** -2.0
    q = np.sum(w * fits[:, 0] ** 2) - np.sum(w * fits[:, 0]) ** 2 / np.sum(w)
    assert spread**2 == pytest.approx((q - (len(w) - 1)) / (np.sum(w) - np.sum(w**2) / np.sum(w)), rel=1e-9)
    batch = np.where(np.arange(6000) >= 2000, 0.35, 0.1) * (temperature[:6000] - 40) + residual[:6000]
    frame = pd.DataFrame({"temp": temperature[:6000]})
    fitted, error = 0.1, 0.005  # the log's slope, as the standard error clustered by regime sees it
    assert moved_cause(frame, batch, judged[:6000], group[:6000], 2000, {"temp": [fitted, error]}, 0.5) is not None
    assert moved_cause(frame, batch, judged[:6000], group[:6000], 2000, {"temp": [fitted, error, spread]}, 0.5) is None
    grown = np.where(np.arange(6000) >= 2000, 1.0, 0.1) * (temperature[:6000] - 40) + residual[:6000]
    assert moved_cause(frame, grown, judged[:6000], group[:6000], 2000, {"temp": [fitted, error, spread]}, 0.5)


def test_coil_ids_of_a_new_form_name_a_supplier_and_a_shift_label_does_not():
    ids = pd.Series([f"K{1000 + i // 200}" for i in range(3000)] + [f"NEW-K{2000 + i // 200}" for i in range(2000)])
    assert new_form(ids, 3400) == 3000 and new_form(ids, 2000) is None  # found late: the change began there
    assert new_form(pd.Series(np.repeat(["A", "B", "C"], [1000, 1000, 3000])), 2100) is None


def test_a_few_long_coils_are_still_ids():
    # one coil before the change and two after in a batch (structures generator, seed 3800): the batch's two forms
    # against its three values had made the column a label (three values a form asked) and the change "unexplained"
    ids = pd.Series(np.repeat(["003855-B", "NEW-003856-B", "NEW-003857-B"], [3000, 3500, 3500]))
    assert new_form(ids, 3000) == 3000
    assert new_form(pd.Series(np.repeat(["Früh", "Spät", "Nacht"], [1500, 1500, 7000])), 3000) is None


def test_expected_error_is_the_root_mean_square_of_the_regions_calibration(predictor):
    model, errors = next((m, r) for m, per in predictor.intervals.calibration.items() for r in per.items())
    region, values = errors
    # the model found last has a calibration: a missing one (code -1) must not wrap round to it
    got = chart.expected_error(predictor.intervals, ["no_model", model, None, model], [region, region, region, None])
    assert got[1] == pytest.approx(np.sqrt(np.mean(np.square(values)))) and np.isnan(got[[0, 2, 3]]).all()


def test_the_logs_record_is_its_residual_in_the_errors_its_region_expects():
    picked = pd.DataFrame({"pred_recommended": [1.0] * 6, "recommended_model": ["m"] * 6})
    calibrated = SimpleNamespace(
        intervals=SimpleNamespace(calibration={"m": {"in": [2.0, -2.0], "none": [], "exact": [0.0]}}),
        region=SimpleNamespace(interval=np.array(["in", "in", "none", "in", "exact", "in"], object)),
        recommended=lambda level: picked,
    )
    found = calibration.record([5.0, np.nan, 3.0, -1.0, 2.0, np.inf], calibrated, 0.9)
    np.testing.assert_array_equal(found.residual, [4.0, np.nan, 2.0, -2.0, 1.0, np.inf])
    # not judged: no measure, no calibration, a calibration without error, a measure beyond every number
    np.testing.assert_array_equal(found.z, [2.0, np.nan, np.nan, -1.0, np.nan, np.nan])
    assert list(found.models) == ["m"] * 6 and list(found.region) == ["in", "in", "none", "in", "exact", "in"]


def test_the_logs_own_parts_are_in_control(predictor, parts):
    watched = watch.watch(predictor, parts)
    assert watched.chart.alarm_at is None and watched.change is None
    assert not watched.table["alarm"].any() and watched.table["change_start"].isna().all()
    says(words.summary(watched), "in control", "400 parts")
    assert watched.departure is None


def test_parts_unlike_every_logged_part_are_not_judged(predictor, parts):
    batch = parts.copy()
    batch.loc[200:, "shim21_mm"] += 0.3  # far beyond the log: trust 'extrapolation', and no error is expected there
    batch.loc[200:, "draw_in_mm"] += 10.0
    watched = watch.watch(predictor, batch)
    far = watched.table["trust"].to_numpy() == "extrapolation"
    assert far[200:].all() and not far[:200].any() and watched.table["expected_error"][far].isna().all()
    assert watched.chart.alarm_at is None and watched.judged.sum() == 200
    summary = words.summary(watched)
    says(summary, "200 parts judged of 400", "200 of the 400 parts (50%) were not judged")
    # quiet only because nothing after part 200 could be compared: said so, with the setting that took it there
    assert watched.departure.start_part == 201 and watched.departure.columns == ("shim21_mm",)
    # these models were stored before the log's range was: the range of the logged parts they keep, said so
    says(summary.splitlines()[0], "not judged from part 201 on", "shim21_mm at", "beyond the 2,000 logged parts")
    assert "in control" not in summary
    says(summary, "next: run the proposed simulations", "shim21_mm=0.9", "next: append the batch")
    assert watched.departure.shift == pytest.approx(
        watched.table["residual"].iloc[200:].mean() - watched.table["residual"].iloc[:200].mean()
    )


def test_parts_beyond_the_calibration_parts_reach_are_answered_but_not_judged(predictor, parts, monkeypatch):
    # the answers reach as far as the log's parts, test blocks too; the daily check judges a part against its
    # region's calibrated error, and only as far as the calibration parts lay: here, none out of the support
    judging = {"max_distance": None, "beyond": predictor.intervals.reach}
    monkeypatch.setattr(predictor.intervals, "judging", judging)
    watched = watch.watch(predictor, parts)
    outside = ~predictor.where(parts[predictor.inputs]).inside
    assert outside.any() and not outside.all()
    assert (watched.table["trust"][outside] != "extrapolation").all()  # answered, with an interval
    expected = watched.table["expected_error"]
    assert expected[outside].isna().all() and expected[~outside].notna().all()
    assert watched.judged.sum() == (~outside).sum()
    says(words.summary(watched), "were not judged: they lie where the models' error was never calibrated")
    monkeypatch.setattr(predictor.intervals, "judging", None)  # models stored before: the answers' reach
    assert watch.watch(predictor, parts).judged.sum() == len(parts)


def test_a_setting_stepped_where_the_models_cannot_judge_is_named_and_several_at_once_are_a_campaign(predictor, parts):
    batch = parts.copy()
    batch.loc[200:, "cushion_c4_kn"] = batch["cushion_c4_kn"].max() + 80.0
    one = watch.watch(predictor, batch)
    assert one.departure.start_part == 201 and one.departure.columns == ("cushion_c4_kn",)
    says(one.departure.text, "a step in cushion_c4_kn at part 201")
    batch.loc[200:, "cushion_c1_kn"] = batch["cushion_c1_kn"].min() - 80.0
    both = watch.watch(predictor, batch)
    assert set(both.departure.columns) == {"cushion_c4_kn", "cushion_c1_kn"}
    says(both.departure.text, "a new campaign of settings at part 201", "cushion_c1_kn", "cushion_c4_kn")


def test_the_departure_is_the_likeliest_split_of_the_parts_not_judged():
    from hybridtwin.monitor.departure import split_point

    flags = np.r_[np.zeros(120), np.ones(80)]
    assert split_point(flags) == 120
    flags[[10, 50, 90]] = 1  # a few parts not judged before it, a few judged after it
    flags[[150, 170]] = 0
    assert split_point(flags) == 120
    assert split_point(np.ones(60)) is None  # too short to hold a stretch before and after


def _stub_predictor(inputs):
    from types import SimpleNamespace

    return SimpleNamespace(inputs=list(inputs), logged_range={name: (-9.0, 9.0) for name in inputs}, neighbourhood=None)


def test_a_departure_needs_most_parts_since_not_judged_and_most_before_judged():
    from hybridtwin.monitor.departure import departure

    rng = np.random.default_rng(3)
    table = pd.DataFrame({"a": rng.normal(0, 1, 400), "interval_region": "in_support"})
    residual = rng.normal(0, 1, 400)

    def judged(before_share, after_share):
        return np.r_[rng.random(200) < before_share, rng.random(200) < after_share]

    stub = _stub_predictor(["a"])
    found = departure(table, judged(1.0, 0.03), residual, stub)
    assert found is not None and abs(found.start_part - 201) <= 3 and found.outside_support == 0.0
    assert departure(table, judged(1.0, 0.25), residual, stub) is None  # a quarter since still judged
    assert departure(table, judged(0.7, 0.0), residual, stub) is not None  # most before judged: enough
    assert departure(table, judged(0.4, 0.0), residual, stub) is None  # most before not judged either ...
    whole = departure(table, judged(0.0, 0.0), residual, stub)
    assert whole.start_part == 1  # ... unless the whole batch is not judged: then from its first part
    # inside the support (settings unlike the log's): no simulation to propose, only the batch to learn
    steps = words._after_departure(found)
    assert len(steps) == 1 and steps[0].startswith("append the batch")


def test_settings_that_neither_step_nor_leave_the_logged_range_are_a_new_combination():
    from hybridtwin.monitor.departure import _moved

    rng = np.random.default_rng(5)
    settings = pd.DataFrame({"a": rng.normal(0, 1, 400), "b": rng.normal(0, 1, 400)})
    settings.loc[200:, "b"] += 1.0  # moved, inside the log's range, no step beyond the scatter before
    bounds = pd.DataFrame({"low": [-9.0, -9.0], "high": [9.0, 9.0]}, index=["a", "b"])
    columns, text = _moved(settings, 200, (bounds, "the log's"))
    assert columns == ()
    says(text, "no single setting stepped or left the logged range", "furthest moved: b")
    bounds.loc["b", "high"] = 0.5  # most parts since lie above every logged part
    columns, text = _moved(settings, 200, (bounds, "the log's"))
    assert columns == ("b",)
    says(text, "b at", "beyond the log's -9 to 0.5")
    assert _moved(settings, 200, None)[1].startswith("no single setting stepped;")  # no range known: not claimed
    shim = pd.DataFrame({"shim": np.r_[np.full(200, 0.5), np.full(200, 0.6)]})  # logged exactly, stepped up once
    assert _moved(shim, 200, None)[0] == ("shim",)  # a setting, not a clock


@pytest.mark.parametrize("stepped_at, named", [(195, True), (200, True), (240, True), (185, False), (260, False)])
def test_a_departure_names_a_setting_that_steps_from_a_few_parts_before_it_to_fifty_after(stepped_at, named):
    # the departure's part is dated from the parts not judged; the setting that took the batch there may have
    # stepped a few parts before it (parts already beyond the log whose trust turned later) or after it
    from hybridtwin.monitor.departure import _moved

    rng = np.random.default_rng(stepped_at)
    shim = np.r_[np.full(stepped_at, 0.5), np.full(400 - stepped_at, 0.6)] + rng.normal(0, 0.002, 400)
    columns, text = _moved(pd.DataFrame({"shim": shim}), 200, None)
    assert (columns == ("shim",)) is named
    if named:
        says(text, f"a step in shim at part {stepped_at + 1}")


def test_the_models_store_the_logs_range_and_a_departure_is_said_against_it(predictor, parts, monkeypatch):
    spec = {**predictor.spec, "logged_range": {name: [float(parts[name].min()), float(parts[name].max())]
                                               for name in predictor.inputs}}  # fmt: skip
    monkeypatch.setattr(predictor, "spec", spec)
    batch = parts.copy()
    batch.loc[200:, "shim21_mm"] += 0.3
    watched = watch.watch(predictor, batch)
    says(watched.departure.text, "shim21_mm at", f"beyond the log's {parts['shim21_mm'].min():.4g} to")
    batch.loc[100:, "draw_in_mm"] += 3 * 2.41  # a step before the batch leaves: an alarm
    alarmed = watch.watch(predictor, batch, explain=False)
    assert alarmed.chart.alarm_at < 200 and alarmed.departure is not None and alarmed.change is None
    assert words.next_steps(alarmed) == []  # an alarm nothing explained: no advice to teach it to the models


def test_a_batch_of_which_no_part_can_be_judged_is_not_called_in_control(predictor, parts):
    batch = parts.iloc[:50].copy()
    batch["shim21_mm"] += 0.3  # every part far beyond the log
    watched = watch.watch(predictor, batch)
    assert watched.judged.sum() == 0 and watched.chart.alarm_at is None
    says(words.summary(watched), "nothing judged", "none of the 50 parts", "50 of the 50 parts (100%) were not judged")
    few = parts.iloc[:100].copy()
    few["shim21_mm"] += 0.3
    few.loc[:4, "shim21_mm"] -= 0.3  # five parts judged, then none
    mostly = watch.watch(predictor, few)
    says(words.summary(mostly).splitlines()[0], "mostly not judged", "shim21_mm at", "the 5 parts judged of 100")
    # which settings: beyond every logged part's range (no part before to date a step against)
    assert watched.departure.start_part == 1 and watched.departure.columns == ("shim21_mm",)
    says(words.summary(watched), "100% of the parts lie at settings the models cannot judge: shim21_mm at")
    says(words.summary(watched), "run the proposed simulations: 100% of the batch's parts lie outside the support")
    assert "in control" not in words.summary(watched)


def test_a_step_alarms_soon_after_it_starts_and_is_unexplained(stepped):
    assert 200 <= stepped.chart.alarm_at <= 215 and abs(stepped.chart.start_at - 200) <= 3
    assert stepped.table["change_start"].iloc[-1] == stepped.chart.start_at + 1
    assert stepped.change.kind == UNEXPLAINED and stepped.change.shift == pytest.approx(7.2, abs=1.5)
    says(words.summary(stepped), "ALARM at part", "more than the models expect", "unexplained", "append the batch")
    assert "what changed (unexplained): a shift of" in words.summary(stepped)  # the kind said once
    assert "unexplained: unexplained" not in words.markdown(stepped, "batch.csv")
    first, then = words.next_steps(stepped)  # look for the cause before the models learn it
    says(first, f"find what changed at about part {stepped.change.start_part:,}", "no logged column explains it")
    says(then, "append the batch", "once the plant keeps it")


def test_a_setting_that_steps_to_a_new_level_is_named_and_a_warming_trend_is_not():
    rng = np.random.default_rng(0)
    values = np.r_[np.full(400, 0.45), np.full(400, 0.55)] + rng.normal(0, 0.004, 800)
    at, low, high = step_of(values, 402)
    assert abs(at - 400) <= 2 and low == pytest.approx(0.45, abs=0.01) and high == pytest.approx(0.55, abs=0.01)
    assert step_of(np.linspace(20, 60, 800) + rng.normal(0, 0.3, 800), 400) is None
    campaign = np.r_[np.full(400, 0.45), np.full(300, 0.55), np.full(1100, 0.45)] + rng.normal(0, 0.004, 1800)
    assert step_of(campaign, 400) is not None and step_of(campaign, 400, kept=1000) is None  # it did not last
    frame = pd.DataFrame({"strokes": np.arange(10), "t": pd.date_range("2026-01-01", periods=10).astype(str)})
    assert clocks(frame.assign(x=rng.normal(size=10))) == {"strokes", "t"}


def test_a_step_is_looked_for_from_a_few_parts_before_the_start_and_its_levels_compared_either_side_of_it():
    rng = np.random.default_rng(5)
    values = np.r_[np.full(400, 0.45), np.full(400, 0.55)] + rng.normal(0, 0.004, 800)
    at, low, high = step_of(values, 403)  # the chart dated the change 3 parts late: the new level is before it
    assert at == 400 and low == pytest.approx(0.45, abs=0.01) and high == pytest.approx(0.55, abs=0.01)
    assert step_of(values, 430) is None  # a campaign's step 30 parts before the change is no step at it
    at, _, _ = step_of(values, 375)  # one 25 parts after it is dated at its part (the shift then tells)
    assert at == 400
    assert step_of(values, 340) is None  # one 60 parts after it is not looked for


def test_a_step_from_a_scattered_level_to_a_steady_one_is_a_step():
    rng = np.random.default_rng(4)  # a lubrication that scattered from part to part, then set to 2.0 g/m2
    values = np.r_[rng.normal(1.2, 0.2, 400), rng.normal(2.0, 0.01, 400)]
    at, low, high = step_of(values, 402)
    assert abs(at - 400) <= 1 and low == pytest.approx(1.2, abs=0.05) and high == pytest.approx(2.0, abs=0.01)
    assert step_of(np.r_[rng.normal(1.2, 0.2, 400), np.linspace(2.0, 4.0, 400)], 402) is not None
    assert step_of(np.linspace(1.2, 4.0, 800) + rng.normal(0, 0.2, 800), 402) is None  # a ramp, with that scatter
    # a die warming slowly, its scatter from part to part larger than its rise over a hundred parts
    # a chosen draw: the rule without the line's misfit bound calls it a step (as it does 16 of seeds 0-39)
    warming = 20 + 0.005 * np.arange(2000) + np.random.default_rng(4).normal(0, 0.2, 2000)
    assert step_of(warming, 600, kept=1000) is None
    assert step_of(np.where(np.arange(800) == 420, np.nan, values), 402) is None  # a part not logged: no date
    # a setting that scattered by 12 from part to part, set 3 of those above its mean: a step on every draw (a bound
    # that asked a line to leave twice the part-to-part scatter missed half of them)
    for seed in range(10):
        scattered = np.random.default_rng(seed)
        stepped = np.r_[scattered.normal(222, 12, 400), scattered.normal(259, 0.4, 400)]
        assert abs(step_of(stepped, 400)[0] - 400) <= 1


def test_a_new_coil_that_begins_where_the_change_starts_is_found_and_an_id_per_part_is_not():
    coils = pd.Series(np.repeat(["K1", "K2", "K3"], [150, 200, 150]))
    assert boundary_of(coils, 345) == 350 and boundary_of(coils, 335) is None
    assert boundary_of(pd.Series([f"P{i}" for i in range(500)]), 350) is None
    assert boundary_of(pd.Series(np.arange(500.0)), 350) is None


def test_what_changed_names_a_stepped_setting(predictor, parts):
    batch = parts.copy()
    batch.loc[200:, "cushion_c4_kn"] = batch["cushion_c4_kn"].iloc[:200].max() + 8.0
    batch.loc[200:, "draw_in_mm"] += 3 * 2.41
    watched = watch.watch(predictor, batch)
    assert watched.change.kind == NEW and watched.change.column == "cushion_c4_kn", watched.change.text
    says(watched.change.text, "a step in cushion_c4_kn at part")


def test_the_command_writes_the_table_and_monitor_md_and_leaves_the_batch(tmp_path, parts, capsys):
    batch = parts.copy()
    batch.loc[200:, "draw_in_mm"] += 3 * 2.41
    path = tmp_path / "batch.csv"
    batch.to_csv(path, index=False)
    before = path.read_bytes()
    assert main(["monitor", str(path), "--models", MODELS, "-o", str(tmp_path / "out.csv")]) == 0
    out = pd.read_csv(tmp_path / "out.csv")
    assert list(out.columns) == [*parts.columns, *watch.COLUMNS] and len(out) == len(parts)
    assert out["alarm"].iloc[-1] and not out["alarm"].iloc[0] and path.read_bytes() == before
    says((tmp_path / "monitor.md").read_text(), "# Monitor: batch.csv", "ALARM", "What changed")
    says(capsys.readouterr().out, "ALARM at part", "what changed")


@pytest.mark.parametrize(
    "change, expected",
    [
        (lambda b: b.drop(columns="draw_in_mm"), ("no column 'draw_in_mm'", "cannot be monitored")),
        (lambda b: b.rename(columns={"draw_in_mm": "draw_in"}), ("did you mean 'draw_in'?", "cannot be monitored")),
        (lambda b: b.drop(columns="rm_mpa"), ("no column 'rm_mpa'", "that the models take as an input")),
        (lambda b: b.drop(columns="stroke_counter"), ("no column 'stroke_counter'", "extension")),
        (lambda b: b.iloc[[0, 2, 1, *range(3, 400)]], ("column 'timestamp', row 3 (line 4)", "time order")),
        (lambda b: b.assign(draw_in_mm=b["draw_in_mm"].where(b.index != 9)), ("'draw_in_mm'", "row 10 (line 11)")),
    ],
)
def test_bad_batches_stop_with_one_line(predictor, parts, tmp_path, capsys, change, expected):
    path = tmp_path / "batch.csv"
    change(parts).to_csv(path, index=False)
    with pytest.raises(InputError) as error:
        watch.load_batch(path, predictor)
    says(str(error.value), *expected)
    assert main(["monitor", str(path), "--models", MODELS, "-o", str(tmp_path / "out.csv")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: batch file") and err.count("\n") == 1 and not (tmp_path / "out.csv").exists()
    assert "config" not in err  # a user of the stored models has none


def test_a_batch_whose_stroke_counter_goes_down_stops_where_the_log_never_saw_it_go_down(parts, tmp_path):
    counted = Predictor.load(MODELS)
    counted.spec["monitor"] = {**counted.spec.get("monitor", {}), "counters": ["stroke_counter"]}
    path = tmp_path / "batch.csv"
    parts.drop(columns="timestamp").iloc[::-1].to_csv(path, index=False)  # reversed, no timestamp to tell
    with pytest.raises(InputError) as error:
        watch.load_batch(path, counted)
    says(str(error.value), "column 'stroke_counter', row 2 (line 3)", "time order", "reset")
    last, before = parts["stroke_counter"].iloc[-2], parts["stroke_counter"].iloc[-1]
    says(str(error.value), f": {last:g} is below the row before ({before:g})")
    assert len(watch.load_batch(path, Predictor.load(MODELS))) == len(parts)  # a log with no counter: no check
    assert calibration.counters(parts) == ["stroke_counter"]


@pytest.fixture(scope="module")
def regime_predictor(parts):
    """The stored run with the regime charts' constants set on the head of its log (as prediction_intervals sets
    them on the whole log's honest residuals)."""
    loaded = Predictor.load(MODELS)
    plain = watch.watch(loaded, parts, explain=False)
    table = plain.table
    models = loaded.intervals.recommend(loaded.where(loaded.checked(parts)).region)
    found, fitted, _, _ = calibration.constants(
        parts, loaded.inputs, table["residual"].to_numpy(float), plain.chart.z, table["interval_region"], models
    )
    loaded.spec["monitor"] = {"regimes": found.to_dict(), **fitted.to_dict(), "slopes": {}, "limit": chart.LIMIT}
    return loaded


def test_the_command_charts_the_regimes_with_the_constants_the_log_set(regime_predictor, parts):
    # the same parts the limits were set on would be quiet by construction: a batch of them shifted by an
    # in-control amount (a tenth of the noise) must stay quiet too
    calm = parts.copy()
    calm["draw_in_mm"] += 0.1 * 2.41
    quiet = watch.watch(regime_predictor, calm)
    assert quiet.chart.alarm_at is None and quiet.chart.group is not None
    calm["draw_in_mm"] += 1.9 * 2.41  # the whole batch twice the noise off: the regimes' levels say so
    assert watch.watch(regime_predictor, calm).chart.alarmed_by == chart.LEVEL
    batch = parts.copy()
    batch.loc[250:, "draw_in_mm"] += 3 * 2.41  # inside a coil
    stepped = watch.watch(regime_predictor, batch)
    assert stepped.chart.alarmed_by == chart.WITHIN and 250 <= stepped.chart.alarm_at <= 280
    assert abs(stepped.chart.start_at - 250) <= 5 and stepped.change.kind == UNEXPLAINED
    says(words.summary(stepped), "ALARM at part", "within a regime")


def test_a_step_is_dated_where_a_short_stretch_not_judged_began_and_never_thousands_of_parts_before(predictor):
    from hybridtwin.monitor.changes import _named

    rng = np.random.default_rng(7)
    frame = pd.DataFrame({"shim": np.r_[np.full(1000, 0.45), np.full(4000, 0.55)] + rng.normal(0, 0.004, 5000)})
    kind, column, _ = _named([], frame, 1100, predictor, 3.0, "mm", gap=100)  # the parts 1,001-1,100 not judged
    assert (kind, column) == (NEW, "shim")
    kind, column, _ = _named([], frame, 4000, predictor, 3.0, "mm", gap=3000)  # 3,000 not judged: too far
    assert (kind, column) == (UNEXPLAINED, None)
    # unless the residual itself (there without an error to judge it by) steps where the shim stepped inside the
    # stretch not judged (parts 501-4,000)
    residual, judged = rng.normal(0, 1.0, 5000), np.arange(5000) >= 4000
    stepped = residual + 3.0 * (np.arange(5000) >= 1000)
    kind, column, _ = _named([], frame, 4000, predictor, 3.0, "mm", gap=3500, shifted=(stepped, judged))
    assert (kind, column) == (NEW, "shim")
    later = residual + 3.0 * (np.arange(5000) >= 2500)  # it stepped 1,500 parts after the shim: not the shim
    kind, column, _ = _named([], frame, 4000, predictor, 3.0, "mm", gap=3500, shifted=(later, judged))
    assert (kind, column) == (UNEXPLAINED, None)
    kind, column, _ = _named([], frame, 4000, predictor, 3.0, "mm", gap=3500, shifted=(residual, judged))
    assert (kind, column) == (UNEXPLAINED, None)  # it did not step inside the stretch: nothing is dated there
    faint = np.tile([1.0, -1.0], 2500) + 0.05 * (np.arange(5000) >= 1000)  # likeliest at 1,000, but 1 SE
    kind, column, _ = _named([], frame, 4000, predictor, 3.0, "mm", gap=3500, shifted=(faint, judged))
    assert (kind, column) == (UNEXPLAINED, None)
    kind, column, _ = _named([], frame, 4000, predictor, 3.0, "mm", gap=3000, shifted=(stepped, judged))
    assert (kind, column) == (NEW, "shim")  # the stretch not judged began where the shim stepped


def test_a_new_suppliers_ids_are_named_before_a_setting_that_steps_where_they_begin(predictor):
    from hybridtwin.monitor.changes import _named

    rng = np.random.default_rng(8)
    ids = [f"K{1000 + i // 250}" for i in range(1000)] + [f"NEW-K{2000 + i // 250}" for i in range(3000)]
    shim = np.r_[np.full(1000, 0.45), np.full(3000, 0.55)] + rng.normal(0, 0.004, 4000)
    frame = pd.DataFrame({"shim": shim, "coil": ids})  # the coils' material steps with the supplier, as here the shim
    kind, column, text = _named([], frame, 1000, predictor, 3.0, "mm")
    assert (kind, column) == (NEW, "coil") and "new form (NEW-K2000)" in text
    # and before a known cause whose slope moved with them (their material changes how it acts)
    assert _named([], frame, 1000, predictor, 3.0, "mm", known_moved=("shim", 4.0))[:2] == (NEW, "coil")
    same = frame.assign(coil=[f"K{1000 + i // 250}" for i in range(4000)])  # the same supplier: the setting
    assert _named([], same, 1000, predictor, 3.0, "mm")[:2] == (NEW, "shim")


def test_a_shift_over_the_levels_is_dated_at_its_likeliest_start_not_at_the_charts_last_zero():
    # regimes' levels that drifted up by chance (in control), then a shift of 3.5 level SDs from the sixth on
    steps = np.array([1.5, 1.2, 1.4, 0.2, 1.3, 3.5, 3.4, 3.6, 3.5, 3.3, 3.5])
    cusum = chart.cusum(steps, chart.LEVEL_REFERENCE, 12.0)
    assert cusum.start_at == 0 and cusum.alarm_at is not None  # the last zero: before the in-control drift
    assert chart.likeliest_start(steps, cusum.start_at, cusum.alarm_at, cusum.direction) == 5
    assert chart.likeliest_start(-steps, 0, len(steps) - 1, -1) == 5  # the same, downwards
    spaced = np.full(3 * len(steps), np.nan)
    spaced[::3] = steps  # a level is known at one part of its regime: the others are NaN
    assert chart.likeliest_start(spaced, 0, len(spaced) - 1, 1) == 15


def test_limits_set_on_a_short_log_are_called_a_hint(regime_predictor, parts):
    assert not words.short_log(watch.watch(regime_predictor, parts, explain=False))  # no log length stored
    stored = Predictor.load(MODELS)
    for log_rows, cautioned in ((400, True), (words.SHORT_LOG, False)):
        stored.spec["monitor"] = {**regime_predictor.spec["monitor"], "log_rows": log_rows}
        watched = watch.watch(stored, parts, explain=False)
        assert ("a log of 400 parts" in words.summary(watched)) == cautioned
        assert ("a log of 400 parts" in words.markdown(watched, "batch.csv")) == cautioned


def test_a_shift_over_the_levels_is_dated_where_it_began_when_levels_drifted_the_same_way_before():
    group = np.arange(6000) // 100  # regimes of 100 parts
    level = np.zeros(60)
    level[22:30] = 0.8  # in control, by chance above the mean for eight regimes
    level[30:] = 3.0  # the change, from part 3,000 on
    rng = np.random.default_rng(9)
    residual = level[group] + rng.normal(0, 0.3, 6000)
    constants = chart.Constants({}, 0.3, 0.3, 0.5, 1e9, 8.0)  # only the chart over the levels can alarm
    result = chart.regime_chart(residual, residual, np.full(6000, "r"), group, constants)
    last_zero = chart.cusum(chart.level_steps(residual, group, constants), chart.LEVEL_REFERENCE, 8.0).start_at
    assert result.alarmed_by == chart.LEVEL and group[last_zero] < 30  # the excursion began before the change
    assert result.start_at == 3000


def test_a_setting_whose_new_level_the_shift_does_not_follow_is_not_named_and_one_it_follows_is(predictor):
    from hybridtwin.monitor.changes import _named

    rng = np.random.default_rng(11)
    level = np.r_[np.full(1000, 0.45), np.full(1200, 0.55), np.full(1800, 0.45)]  # a campaign of 1,200 parts
    frame = pd.DataFrame({"shim": level + rng.normal(0, 0.004, 4000)})
    judged, noise = np.ones(4000, bool), rng.normal(0, 1.0, 4000)
    stays = noise + 3.0 * (np.arange(4000) >= 1000)  # the shift stays after the campaign: time, not the shim
    regime = (stays, judged, np.zeros(4000), 1.0)  # the regime charts: a new level must last 1,000 parts
    kind, column, _ = _named([], frame, 1000, predictor, 3.0, "mm", regime=regime, shifted=(stays, judged))
    assert (kind, column) == (UNEXPLAINED, None)
    follows = noise + 3.0 * (level > 0.5)  # the shift ends with the campaign: the shim
    kind, column, _ = _named([], frame, 1000, predictor, 3.0, "mm", regime=regime, shifted=(follows, judged))
    assert (kind, column) == (NEW, "shim")
    kept = frame.assign(shim=np.where(np.arange(4000) >= 1000, 0.55, 0.45) + rng.normal(0, 0.004, 4000))
    kind, column, _ = _named([], kept, 1000, predictor, 3.0, "mm", regime=regime, shifted=(stays, judged))
    assert (kind, column) == (NEW, "shim")  # re-shimmed for good: the shim is the lead, though time fits as well
    late = frame.assign(shim=np.where(np.arange(4000) >= 1020, 0.55, 0.45) + rng.normal(0, 0.004, 4000))
    kind, column, _ = _named([], late, 1000, predictor, 3.0, "mm", regime=regime, shifted=(stays, judged))
    assert (kind, column) == (UNEXPLAINED, None)  # re-shimmed 20 parts after the shift began: not its cause
    falls = -stays  # the same, the residual falling
    kind, column, _ = _named([], late, 1000, predictor, -3.0, "mm", regime=regime, shifted=(falls, judged))
    assert (kind, column) == (UNEXPLAINED, None)
    wild = np.tile([22.0, -18.0], 2000)  # the 20 parts before the shim's step: two thirds of the shift, but wild
    unclear = np.where(np.arange(4000) < 1020, wild, stays)
    kind, column, _ = _named([], late, 1000, predictor, 3.0, "mm", regime=regime, shifted=(unclear, judged))
    assert (kind, column) == (NEW, "shim")
    further = np.r_[np.full(1000, 0.45), np.full(1200, 0.55), np.full(1800, 0.65)]  # on the same way, not back
    onward = frame.assign(shim=further + rng.normal(0, 0.004, 4000))
    shifted = (noise + 30.0 * (further - 0.45), judged)  # the residual follows the shim
    kind, column, _ = _named([], onward, 1000, predictor, 3.0, "mm", regime=regime, shifted=shifted)
    assert (kind, column) == (NEW, "shim")
