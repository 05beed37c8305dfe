"""hybridtwin.diagnosis.trends: a trend in time is named only where parts run at the same settings show it."""

import numpy as np
import pandas as pd
import pytest
from sklearn.gaussian_process.kernels import Matern

from hybridtwin import diagnosis
from hybridtwin.diagnosis import Candidate, Settings, best_fit, selection, trends
from hybridtwin.diagnosis.fits import Rules
from hybridtwin.diagnosis.policy import TREND_POWER
from hybridtwin.diagnosis.table import Found, too_small

SETTINGS = Settings(folds=5, seed=0)


def _matern(X, factor):
    """The simulator's correlation of these tests: Matern 5/2, unit length scales on the raw inputs."""
    return Matern(length_scale=np.full(X.shape[1], factor), nu=2.5)(X)


def _campaigns(seed: int, wear: float, campaigns=16, coils=3, parts=120, noise=0.3):
    """Campaigns in time order, each at narrow settings of its own (three coils each); a discrepancy of the
    inputs alone, plus a wear of ``wear`` mm over the log in the stroke counter."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-2, 2, (campaigns, 2))
    X = np.vstack([c + rng.normal(0, 0.05, (coils * parts, 2)) for c in centres])
    x1, x2 = X.T
    strokes = np.arange(len(X), dtype=float)
    y = 2 * np.sin(1.5 * x1) + 0.5 * x2**2 + 0.3 * x1 * x2 + wear * strokes / len(X) + rng.normal(0, noise, len(X))
    coil = np.repeat([f"C{k:03d}" for k in range(campaigns * coils)], parts)
    return pd.DataFrame({"x1": x1, "x2": x2, "coil": coil, "stroke_counter": strokes}), y - y.mean()


def _named(result) -> list[str]:
    return [fit.candidate.name for fit in result.selected]


def test_a_trend_in_strokes_is_not_named_for_campaigns_at_settings_of_their_own():
    frame, y = _campaigns(3, wear=0.0)
    plain = diagnosis.diagnose(frame, y, ["x1", "x2"], [], SETTINGS, surrogate_std=0.05)
    assert "stroke_counter" in _named(plain)  # without the simulator's correlation
    result = diagnosis.diagnose(frame, y, ["x1", "x2"], [], SETTINGS, surrogate_std=0.05, input_correlation=_matern)
    assert _named(result) == ["x1", "x2"] and not result.untold_trends
    assert result.follows_inputs["stroke_counter"].p_value >= SETTINGS.alpha
    row = result.table.set_index("cause").loc["stroke_counter"]
    assert not row["significant"] and "a trend in time that follows the settings" in row["note"]
    summary = diagnosis.summary_dict(result)["follows_inputs"]
    assert summary == {"stroke_counter": result.follows_inputs["stroke_counter"]._asdict()}


def test_a_wear_that_rises_within_the_coils_is_named():
    frame, y = _campaigns(1, wear=3.0)
    result = diagnosis.diagnose(frame, y, ["x1", "x2"], [], SETTINGS, surrogate_std=0.05, input_correlation=_matern)
    assert "stroke_counter" in _named(result) and not result.follows_inputs and not result.untold_trends


@pytest.mark.parametrize(("wear", "beyond"), [(0.0, False), (3.0, True)])
def test_the_trend_test_sees_a_wear_between_parts_at_the_same_settings(wear, beyond):
    frame, y = _campaigns(3, wear=wear)
    columns = [Candidate.new(c, "input", frame[c].to_numpy(), (c,)) for c in ("x1", "x2")]
    columns += [Candidate.new("coil", "group", frame["coil"].to_numpy(), ("coil",))]
    strokes = Candidate.new("stroke_counter", "log", frame["stroke_counter"].to_numpy(), ("stroke_counter",))
    fit = best_fit(strokes, y, SETTINGS)
    test = trends.trend_test(fit, y, columns + [strokes], _matern, 0, 0.01)
    assert (test.p_value < 0.01) if beyond else (test.p_value > 0.05)
    assert test.power > 0.9  # three coils a campaign: parts at the same settings at three times
    assert trends.trend_test(fit, y, columns + [strokes], None, 0, 0.01) is None


def test_a_trend_in_time_is_a_timestamp_or_a_counter_not_a_slow_quantity():
    hours = np.linspace(0, 100, 500)
    assert trends.is_trend_in_time(Candidate.new("t", "time", hours, ("t",)))
    assert trends.is_trend_in_time(Candidate.new("strokes", "log", np.floor(hours * 7), ("strokes",)))
    assert not trends.is_trend_in_time(Candidate.new("ambient", "log", np.sin(hours / 9), ("ambient",)))
    assert not trends.is_trend_in_time(Candidate.new("x", "input", hours, ("x",)))


def test_runs_are_the_stretches_of_one_coil_cut_in_halves():
    coil = Candidate.new("coil", "group", np.array(list("AAAAAAAAAABBBBBBBBBBBBAAC")), ("coil",))
    runs = trends.runs_in_time([coil], 25)
    assert runs.tolist() == [0] * 10 + [1] * 12 + [2] * 2 + [3]
    levels = trends.half_levels(runs, seed=0)
    assert levels.tolist() == [0] * 5 + [1] * 5 + [2] * 6 + [3] * 6 + [4] * 2 + [6]  # short runs stay whole
    assert trends.runs_in_time([], 450).tolist() == [0] * 200 + [1] * 200 + [2] * 50  # blocks without ids


def test_a_trend_the_test_cannot_see_is_named_as_before():
    """One coil per campaign, each at settings of its own, noisy parts: on this committed draw (seed 2) the test's
    power against the trend as fitted is low, and the trend stays named with the note. The design does not make
    low power certain (on most other seeds the halves of each coil show the wear); the rule itself is tested
    with given test results below."""
    frame, y = _campaigns(2, wear=2.0, campaigns=16, coils=1, parts=200, noise=1.0)
    columns = [Candidate.new(c, "input", frame[c].to_numpy(), (c,)) for c in ("x1", "x2")]
    columns += [Candidate.new("coil", "group", frame["coil"].to_numpy(), ("coil",))]
    strokes = Candidate.new("stroke_counter", "log", frame["stroke_counter"].to_numpy(), ("stroke_counter",))
    test = trends.trend_test(best_fit(strokes, y, SETTINGS), y, columns + [strokes], _matern, 0, 0.01)
    assert test.p_value > SETTINGS.alpha and test.power < 0.5
    result = diagnosis.diagnose(frame, y, ["x1", "x2"], [], SETTINGS, surrogate_std=0.05, input_correlation=_matern)
    assert "stroke_counter" in _named(result) and not result.follows_inputs
    assert result.untold_trends["stroke_counter"].power < TREND_POWER
    note = result.table.set_index("cause").loc["stroke_counter", "note"]
    assert note.startswith("cannot be told apart from the settings that changed with time")
    assert diagnosis.summary_dict(result)["untold_trends"]["stroke_counter"]["power"] < TREND_POWER


def _strokes_selection(frame, y):
    columns = [Candidate.new(c, "input", frame[c].to_numpy(), (c,)) for c in ("x1", "x2")]
    columns += [Candidate.new("stroke_counter", "log", frame["stroke_counter"].to_numpy(), ("stroke_counter",))]
    rules = Rules(SETTINGS, len(columns), 0.0, _matern)
    return selection.Selection(y, columns, rules, rules.fit_all(columns, y))


@pytest.mark.parametrize(("power", "dropped"), [(0.95, True), (0.5, False)])
def test_a_trend_is_dropped_only_where_the_test_could_have_seen_it(monkeypatch, power, dropped):
    frame, y = _campaigns(3, wear=0.0)
    chosen = _strokes_selection(frame, y)
    strokes = chosen.marginal["stroke_counter"]
    monkeypatch.setattr(selection, "trend_test", lambda *args: trends.TrendTest(0.5, power))
    assert chosen._beyond_inputs(strokes) is not dropped
    assert ("stroke_counter" in chosen.follows_inputs) is dropped
    assert ("stroke_counter" in chosen.untold_trends) is not dropped
    assert ("stroke_counter" in [fit.candidate.name for fit in chosen.pool()]) is not dropped
    monkeypatch.setattr(selection, "trend_test", lambda *args: trends.TrendTest(0.001, 0.95))
    assert _strokes_selection(frame, y)._beyond_inputs(strokes)  # seen between parts at the same settings


def test_a_trend_that_followed_the_settings_is_not_called_too_small():
    frame, y = _campaigns(3, wear=0.0)
    chosen = _strokes_selection(frame, y)
    chosen.chosen = [chosen.marginal["x1"], chosen.marginal["x2"]]
    chosen.refit()  # the stroke counter is significant given the inputs' forms
    rules = Rules(SETTINGS, 3, min_effect=10.0)  # every effect within the surrogate's uncertainty
    found = Found(chosen.marginal, chosen.conditional, chosen.chosen, {}, {}, {})
    assert "stroke_counter" in [fit.candidate.name for fit in too_small(found, rules)]
    followed = {"stroke_counter": trends.TrendTest(0.5, 0.99)}
    found = Found(chosen.marginal, chosen.conditional, chosen.chosen, {}, {}, {}, {}, followed)
    assert "stroke_counter" not in [fit.candidate.name for fit in too_small(found, rules)]
