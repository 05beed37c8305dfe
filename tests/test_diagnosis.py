"""hybridtwin.diagnosis' plumbing, by hand: which columns become candidates, the settings from the config,
the subsample, the summary later steps read, the joint held-out share, sums of squares between levels,
the paired held-out test and the confounding notes."""

import json

import numpy as np
import pandas as pd
import pytest

from hybridtwin import diagnosis
from hybridtwin.crossval import (
    folds,
)
from hybridtwin.diagnosis import Candidate, Settings, forms, naming, selection
from hybridtwin.diagnosis import fits as fitting
from hybridtwin.diagnosis.causes import Cause, looks_like_timestamps, parse_timestamps
from hybridtwin.diagnosis.ids import Proxy
from hybridtwin.diagnosis.selection import Selection
from hybridtwin.metrics import block_p_value
from tests.test_diagnosis_rules import coil_plant, material_coils, warming_die


def _plant_columns() -> pd.DataFrame:
    stamps = pd.date_range("2026-03-02 06:00", periods=6, freq="h").strftime("%Y-%m-%d %H:%M")
    return pd.DataFrame(
        {
            "drawin_mm": [1.0, 2, 3, 4, 5, 6],  # the target: excluded by the caller
            "operator_note": [0.0, 1, 0, 1, 0, 1],  # excluded by the config
            "die_temp_c": [40.0, 41, 42, 43, 44, 45],
            "blank_holder_kn": [300.0, 310, 300, 310, 300, 310],  # two values: still a candidate
            "shim_mm": [0.5, 0.6, 0.7, 0.5, 0.6, 0.7],
            "press_id": [7.0] * 6,  # constant
            "lube_gm2": [1.0, 1.0, np.nan, 1.0, 1.0, 1.0],  # one value and a blank: not constant, but blank
            "spm": [12.0, 12, np.inf, 12, 13, 12],
            "strokes": [100.0, 101, 102, 103, 104, 105],  # a number the model does not take
            "time": stamps,
            "coil": list("AABBCC"),  # three levels: at the limit of three
            "note": list("uvwxyz"),  # six distinct texts: more than three
        }
    )


def test_candidates_are_every_usable_column_and_the_pairs_of_inputs():
    settings = Settings(max_levels=3, exclude=("operator_note",))
    frame = _plant_columns()
    candidates, skipped = diagnosis.build_candidates(
        frame, ["die_temp_c", "blank_holder_kn", "shim_mm", "press_id"], ["drawin_mm"], settings
    )
    assert [c.cause for c in candidates] == [
        Cause("die_temp_c", "input", ("die_temp_c",)),
        Cause("blank_holder_kn", "input", ("blank_holder_kn",)),
        Cause("shim_mm", "input", ("shim_mm",)),
        Cause("strokes", "log", ("strokes",)),
        Cause("time", "time", ("time",), "2026-03-02 06:00:00"),
        Cause("coil", "group", ("coil",)),
        Cause("die_temp_c*blank_holder_kn", "interaction", ("die_temp_c", "blank_holder_kn")),
        Cause("die_temp_c*shim_mm", "interaction", ("die_temp_c", "shim_mm")),
        Cause("blank_holder_kn*shim_mm", "interaction", ("blank_holder_kn", "shim_mm")),
    ]
    assert skipped == {
        "press_id": "constant",
        "lube_gm2": "missing or infinite values",
        "spm": "missing or infinite values",
        "note": "text with 6 distinct values (more than 3)",
    }
    np.testing.assert_allclose(candidates[4].values, [0, 1, 2, 3, 4, 5])  # elapsed hours
    np.testing.assert_allclose(candidates[7].values, frame[["die_temp_c", "shim_mm"]].to_numpy())
    without_pairs, _ = diagnosis.build_candidates(
        frame, ["die_temp_c", "shim_mm"], ["drawin_mm"], Settings(max_levels=3, interactions=False)
    )
    assert "operator_note" in [c.name for c in without_pairs]  # only the config excluded it
    assert not [c for c in without_pairs if c.kind == "interaction"]


def test_a_candidate_keeps_its_origin():
    candidate = Candidate.new("time", "time", np.arange(3.0), ("time",), origin="2026-03-02 06:00:00")
    assert candidate.origin == "2026-03-02 06:00:00" and candidate.columns == ("time",)


def test_settings_come_from_the_config_with_the_runs_folds_seed_and_units():
    settings = Settings.from_config(
        {"alpha": 0.05, "exclude": ["operator_note"]}, folds=3, seed=7, unit="deg", input_units={"t_c": "°C"}
    )
    assert settings == Settings(
        folds=3, seed=7, alpha=0.05, exclude=("operator_note",), unit="deg", n_jobs=1, input_units=(("t_c", "°C"),)
    )
    assert Settings.from_config(None, folds=4, seed=1, unit="mm", n_jobs=2) == Settings(folds=4, seed=1, n_jobs=2)


def _linear_plant(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 1, n)
    return pd.DataFrame({"x": x, "row": np.arange(n, dtype=float)}), 5.0 + 4.0 * x + rng.normal(0, 0.3, n)


def test_a_diagnosis_of_more_rows_than_it_takes_runs_on_a_seeded_sample_of_distinct_rows_in_order():
    frame, residual = _linear_plant(400)
    settings = Settings(max_rows=150, interactions=False, exclude=("row",))
    result = diagnosis.diagnose(frame, residual, ["x"], [], settings, surrogate_std=0.1)
    again = diagnosis.diagnose(frame, residual, ["x"], [], settings, surrogate_std=0.1)
    assert result.n_rows == 150 and list(result.candidates) == ["x"]
    kept = np.flatnonzero(np.isin(frame["x"], result.candidates["x"].values))
    assert len(kept) == 150 and np.all(np.diff(kept) > 0)  # distinct rows, in their order
    # the residual follows its rows, less the offset (their mean)
    assert result.offset == pytest.approx(residual[kept].mean())
    np.testing.assert_allclose(result.y, residual[kept] - residual[kept].mean())
    np.testing.assert_array_equal(result.y, again.y)  # seeded
    other = diagnosis.diagnose(frame, residual, ["x"], [], Settings(max_rows=150, seed=1, exclude=("row",)), 0.1)
    assert not np.array_equal(other.y, result.y)


def test_the_summary_holds_what_later_steps_read():
    frame, residual = _linear_plant(600)
    result = diagnosis.diagnose(frame[["x"]], residual, ["x"], [], Settings(interactions=False), surrogate_std=0.1)
    summary = json.loads(json.dumps(diagnosis.summary_dict(result)))
    assert list(summary) == [
        "offset",
        "offset_se",
        "n_rows",
        "residual_std",
        "surrogate_std",
        "min_effect",
        "selected",
        "aliases",
        "explained_by",
        "skipped",
        "proxies",
        "by_chance",
        "follows_inputs",
        "untold_trends",
        "too_small",
    ]
    assert (summary["n_rows"], summary["surrogate_std"], summary["min_effect"]) == (600, 0.1, 0.1)
    assert summary["too_small"] == []  # the cause is chosen, not too small
    assert summary["offset"] == pytest.approx(residual.mean())
    assert summary["residual_std"] == pytest.approx(np.std(residual - residual.mean()))
    (chosen,) = summary["selected"]
    assert list(chosen) == [
        "name",
        "kind",
        "columns",
        "form",
        "origin",
        "family",
        "description",
        "parameters",
        "explained_share",
        "effect_range",
        "effect_std",
        "p_value",
    ]
    assert (chosen["name"], chosen["kind"], chosen["columns"], chosen["form"]) == ("x", "input", ["x"], "linear")
    assert (chosen["origin"], chosen["family"]) == (None, "linear")
    assert forms.form_from_dict(chosen["parameters"]).slope == pytest.approx(4.0, abs=0.1)
    assert chosen["description"].startswith("linear: +4")
    assert summary["aliases"] == {"x": []} and summary["explained_by"] == {} and summary["skipped"] == {}
    # the causes table: every candidate, the chosen first, in the columns outside tools read
    table = result.table
    assert list(table.columns) == [
        "rank",
        "cause",
        "kind",
        "form",
        "family",
        "n_params",
        "explained_share",
        "conditional_share",
        "effect_range",
        "effect_std",
        "p_value",
        "significant",
        "selected",
        "description",
        "note",
    ]
    row = table.iloc[0]
    assert (row["rank"], row["cause"], row["kind"], row["form"], row["family"]) == (1, "x", "input", "linear", "linear")
    assert (row["n_params"], row["significant"], row["selected"], row["note"]) == (1, True, True, "")
    assert row["description"] == chosen["description"]
    chosen_fit = result.selected[0]
    assert (row["conditional_share"], row["p_value"]) == (chosen_fit.explained_share, chosen_fit.p_value)
    assert (row["effect_range"], row["effect_std"]) == (chosen_fit.effect_range, chosen_fit.effect_std)


def test_an_effect_the_test_finds_within_the_surrogates_uncertainty_is_too_small_to_tell_not_named():
    frame, residual = _linear_plant(600)  # a slope of 4 over [0, 1]: 1.15 std
    result = diagnosis.diagnose(frame[["x"]], residual, ["x"], [], Settings(interactions=False), surrogate_std=2.0)
    summary = json.loads(json.dumps(diagnosis.summary_dict(result)))
    assert summary["selected"] == []
    (small,) = summary["too_small"]
    assert (small["name"], small["kind"], small["form"]) == ("x", "input", "linear")
    assert small["effect_std"] == pytest.approx(4 / np.sqrt(12), rel=0.1) and small["p_value"] < 1e-6
    row = result.table.set_index("cause").loc["x"]
    assert not row["significant"] and row["note"].startswith("too small to tell from the surrogate's own error")
    assert "1.15 mm (std), within the surrogate's own uncertainty 2.00 mm" in row["note"]
    # an effect no larger that the test does not find (noise ten times the slope's) is not too small: not found
    noisy = 5.0 + 4.0 * frame["x"].to_numpy() + np.random.default_rng(1).normal(0, 12.0, len(frame))
    result = diagnosis.diagnose(frame[["x"]], noisy, ["x"], [], Settings(interactions=False), surrogate_std=2.0)
    assert result.too_small == []


def test_beside_a_chosen_cause_only_small_effects_of_other_columns_are_too_small():
    rng = np.random.default_rng(3)
    frame = pd.DataFrame({"x": rng.uniform(0, 1, 800), "z": rng.uniform(0, 1, 800)})
    noise = rng.normal(0, 0.3, len(frame))

    def found(residual, **settings):
        result = diagnosis.diagnose(frame, residual.to_numpy(), ["x", "z"], [], Settings(**settings), surrogate_std=0.6)
        assert [fit.candidate.name for fit in result.selected] == ["x"]
        return [(fit.candidate.name, fit.form.name) for fit in result.too_small]

    # x*z passes the test once x is in, but it holds the chosen cause's column: z alone is what is too small
    assert found(4.0 * frame["x"] + 1.5 * frame["x"] * frame["z"] + noise) == [("z", "linear")]
    # a cause larger than the surrogate's uncertainty left out by max_causes is not too small
    assert found(4.0 * frame["x"] + 3.0 * frame["z"] + noise, max_causes=1) == []


def test_the_summary_names_the_cause_an_id_stands_for():
    result = diagnosis.Diagnosis(
        0.0, 0.1, 3, 1.0, 0.2, 0.2, pd.DataFrame({"cause": [], "description": []}), None, {}, {}
    )
    result.proxies = {"coil": Proxy(False, ("the model inputs", "rm_mpa"), 0.8), "lot": Proxy(False, (), None, 0.4)}
    assert diagnosis.summary_dict(result)["proxies"] == {
        "coil": {"accounted_by": ["the model inputs", "rm_mpa"], "share": 0.8, "own_p": None},
        "lot": {"accounted_by": [], "share": None, "own_p": 0.4},
    }
    result.by_chance = {"thickness": ("coil", 18, 0.065)}
    assert diagnosis.summary_dict(result)["by_chance"] == {"thickness": {"id": "coil", "levels": 18, "p_value": 0.065}}


def test_between_level_sums_of_squares_by_hand():
    # level means a: 2 (two rows), b: 8 (one row); overall mean 4: 2 * (2 - 4)**2 + 1 * (8 - 4)**2
    assert naming.between_level_ss(np.array(list("aab")), [1.0, 3.0, 8.0]) == pytest.approx(24.0)


def test_an_id_whose_levels_do_not_differ_is_nobodys_proxy():
    levels = np.array(list("aabb"))
    coil = fitting.Fit(Candidate.new("coil", "group", levels, ("coil",)), None, None, 1, 1, 0, 0, 0, 0)
    lube = fitting.Fit(
        Candidate.new("lube", "log", np.arange(4.0), ("lube",)),
        forms.Linear().fit([0, 3], [0, 0.3]),
        None,
        1,
        1,
        0,
        0,
        0,
        0,
    )
    assert naming.proxy_share(coil, lube, np.array([0.1, -0.1, 0.1, -0.1])) == 0.0
    # small differences between levels still count: 0.5 of the between-level sum of squares
    y = np.array([0.2, 0.2, -0.2, -0.2])
    half = fitting.Fit(
        Candidate.new("lube", "log", y, ("lube",)),
        forms.Linear().fit([0, 1], [0, 1 - 0.5**0.5]),
        None,
        1,
        1,
        0,
        0,
        0,
        0,
    )
    assert naming.proxy_share(coil, half, y) == pytest.approx(0.5)


def test_the_joint_share_is_the_held_out_share_of_the_terms_fitted_together():
    frame, residual = _linear_plant(500)
    x, y = frame["x"].to_numpy(), residual - 2.0  # not centred: the terms' means and the fold means matter
    settings = Settings(folds=5, seed=3)
    fit = fitting.best_fit(Candidate.new("x", "input", x, ("x",)), y, settings)
    held = fitting.held_out("linear", x, y, folds(len(y), 5, 3))  # a single slope: its own held-out fit
    expected = 1.0 - np.mean((y - held) ** 2) / np.mean(y**2)
    assert selection.joint_share([fit], y, settings) == pytest.approx(expected)
    assert 0.5 < expected < 1.0


def _column_fit(name, kind, values, y):
    return fitting.best_fit(Candidate.new(name, kind, values, (name,)), y, Settings(folds=5, seed=0))


def test_a_coil_effect_that_two_coils_carry_is_not_lost_to_the_spread_of_its_gain():
    # every coil's offset is learnt held out, but two far coils hold most of the gain: the t-test over the
    # blocks' gains alone stays above a Bonferroni level of about 100 candidates; the signed-rank test does not
    rng = np.random.default_rng(7)
    coil = np.repeat(np.arange(40), 100)
    offsets = rng.normal(0, 0.5, 40)
    offsets[[11, 29]] = [9.0, -9.0]
    y = offsets[coil] + rng.normal(0, 0.3, len(coil))
    y = y - y.mean()
    settings = Settings(folds=5, seed=0)
    fit = fitting.best_fit(Candidate.new("coil", "group", np.char.add("c", coil.astype(str)), ("coil",)), y, settings)
    assert fit.explained_share > 0.95
    assert block_p_value(y, fit.oof, settings.n_blocks) > 1e-4
    assert fit.p_value < 1e-20


def test_a_better_held_out_fit_wins_only_between_columns_scored_on_their_own_values():
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 1, 2000)
    y = 3.0 * x + rng.normal(0, 0.3, 2000)
    y = y - y.mean()
    strong = _column_fit("x", "input", x, y)
    weak = _column_fit("ambient", "log", x + rng.normal(0, 0.5, 2000), y)
    settings = Settings(folds=5, seed=0)
    assert naming.better_held_out(strong, weak, y, settings)
    assert not naming.better_held_out(weak, strong, y, settings)
    coil = _column_fit("coil", "group", np.round(x * 20).astype(int).astype(str), y)
    assert not naming.better_held_out(coil, weak, y, settings)  # ids are left to the proxy rule
    assert not naming.better_held_out(strong, coil, y, settings)


def test_a_near_copy_of_the_cause_is_an_alias_and_a_loose_neighbour_is_explained_by_it():
    rng = np.random.default_rng(5)
    n = 3000
    temp = rng.uniform(30, 60, n)
    frame = pd.DataFrame(
        {
            "die_temp_c": temp,
            "die_temp_sensor_c": temp + rng.normal(0, 0.05, n),  # the same quantity, read twice
            "hall_temp_c": 0.5 * temp + rng.normal(0, 3.0, n),  # follows the die, loosely
        }
    )
    y = 0.4 * (temp - 45) + rng.normal(0, 0.5, n)
    result = diagnosis.diagnose(frame, y, ["die_temp_c"], [], Settings(interactions=False), surrogate_std=0.2)
    (chosen,) = [fit.candidate.name for fit in result.selected]
    copy = ({"die_temp_c", "die_temp_sensor_c"} - {chosen}).pop()
    assert result.aliases == {chosen: [copy]}
    assert result.explained_by == {"hall_temp_c": chosen}
    notes = result.table.set_index("cause")["note"]
    assert notes[copy] == f"cannot be told apart from {chosen} in this data"
    assert notes["hall_temp_c"] == f"explained by {chosen}: adds nothing once it is in"


def _scored(name="x", kind="input", *, cv_mse=1.0, null_mse=4.0, score=-1.0, p_value=0.0, effect_std=1.0, n_params=1):
    """A fit with the given scores (its form a slope of ``n_params`` parameters)."""
    form = forms.Linear()
    form.slope, form.intercept, form.n_params = 1.0, 0.0, n_params
    values = np.arange(4.0)
    return fitting.Fit(
        Candidate.new(name, kind, values, (name,)), form, values, cv_mse, null_mse, score, p_value, 0.0, effect_std
    )


@pytest.mark.parametrize(
    "changes,n_tests,significant",
    [
        ({}, 1, True),
        ({"p_value": 0.008}, 1, True),  # below alpha = 0.01 over one test
        ({"p_value": 0.008}, 0, True),  # no candidates counted: still over one test
        ({"p_value": 0.01}, 1, False),  # at alpha: not below it
        ({"p_value": 0.005}, 10, False),  # Bonferroni: 0.01 / 10
        ({"p_value": 0.0009}, 10, True),
        ({"score": 0.0}, 1, False),  # no better than no term, once its parameters are counted
        ({"score": 0.5}, 1, False),
        ({"effect_std": 0.5}, 1, False),  # no larger than the surrogate's own uncertainty
        ({"effect_std": 0.5000001}, 1, True),
    ],
)
def test_a_cause_is_significant_below_alpha_over_the_tests_with_a_negative_score_and_a_large_effect(
    changes, n_tests, significant
):
    fit = _scored(**changes)
    assert fitting.is_significant(fit, n_tests, Settings(alpha=0.01), min_effect=0.5) is significant


def test_a_pair_that_is_no_interaction_is_never_significant():
    fit = _scored()
    fit.form = forms.Additive().fit(np.column_stack([np.arange(4.0), np.arange(4.0) ** 2]), np.arange(4.0))
    assert not fitting.is_significant(fit, 1, Settings(), min_effect=0.0)


@pytest.mark.parametrize(
    "n_params,min_effect,null_mse,tolerance",
    [
        (1, 3.0, 90.0, 0.05),
        (3, 3.0, 90.0, 0.05),  # a sigmoid is a closed form
        (5, 3.0, 90.0, 0.1),  # a monotone trend: what the surrogate's error (3 mm) can account for, 9 / 90
        (5, 1.0, 90.0, 0.05),  # but never less than the closed forms' margin
    ],
)
def test_a_simpler_cause_may_explain_less_by_what_the_surrogates_error_accounts_for(
    n_params, min_effect, null_mse, tolerance
):
    fit = _scored(n_params=n_params, null_mse=null_mse)
    assert fitting.share_tolerance(fit, min_effect) == pytest.approx(tolerance)


def test_predicting_the_same_is_a_share_within_the_tolerance_and_a_difference_below_the_least_effect():
    reference = _scored(cv_mse=1.0, null_mse=4.0)  # explains 0.75
    at_tolerance = _scored(cv_mse=1.2, null_mse=4.0)  # 0.70: 0.05 less, still the same
    below = _scored(cv_mse=1.25, null_mse=4.0)
    assert fitting.predicts_the_same(at_tolerance, reference, min_effect=0.1)
    assert not fitting.predicts_the_same(below, reference, min_effect=0.1)
    # predictions apart by +-1 alternately: a difference of std 1, not below a least effect of 1
    apart = _scored()
    apart.candidate = Candidate.new("x", "input", np.array([1.0, 0.0, 3.0, 2.0]), ("x",))
    assert fitting.predicts_the_same(apart, reference, min_effect=1.0000001)
    assert not fitting.predicts_the_same(apart, reference, min_effect=1.0)


def test_a_fits_score_is_its_held_out_error_against_no_term_with_a_bic_penalty_in_any_unit():
    rng = np.random.default_rng(9)
    x = rng.uniform(0, 1, 1000)
    y = 2.0 * x + rng.normal(0, 0.5, 1000)
    y = y - y.mean()
    candidate = Candidate.new("x", "input", x, ("x",))
    fit = fitting.best_fit(candidate, y, Settings())
    n = len(y)
    assert fit.score == pytest.approx(n * np.log(fit.cv_mse / fit.null_mse) + fit.form.n_params * np.log(n))
    assert fit.null_mse == pytest.approx(np.mean(y**2))
    fitted = fit.form.predict(x)
    assert (fit.effect_range, fit.effect_std) == pytest.approx((np.ptp(fitted), np.std(fitted)))
    in_metres = fitting.best_fit(candidate, y / 1000.0, Settings())
    assert in_metres.score == pytest.approx(fit.score) and in_metres.form.name == fit.form.name
    noise = fitting.best_fit(candidate, rng.normal(0, 0.001, 1000), Settings())
    assert noise.score > 0  # a millimetre of noise in metres is still noise


def test_value_folds_hold_out_whole_stretches_of_values_and_few_levels_get_shuffled_folds():
    settings = Settings(folds=2, seed=4)
    values = np.arange(40.0)
    splits = fitting.value_folds(Candidate.new("x", "input", values, ("x",)), settings)
    again = fitting.value_folds(Candidate.new("x", "input", values, ("x",)), settings)
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(splits, again))  # seeded
    # 4 bins per fold: eight stretches of five values, each held out whole, four in each fold
    for _, test in splits:
        stretches = np.unique(test // 5)
        assert len(stretches) == 4 and len(test) == 20
    five_levels = np.repeat(np.arange(5.0), 8)  # as many levels as folds: each level held out whole
    for _, test in fitting.value_folds(Candidate.new("x", "input", five_levels, ("x",)), Settings(folds=5)):
        assert len(np.unique(five_levels[test])) == 1
    three_levels = np.repeat(np.arange(3.0), 10)  # fewer levels than folds: shuffled folds
    shuffled = fitting.value_folds(Candidate.new("x", "input", three_levels, ("x",)), Settings(folds=5, seed=2))
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(shuffled, folds(30, 5, 2)))
    coil = Candidate.new("coil", "group", np.array(list("ab") * 10), ("coil",))
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(fitting.value_folds(coil, Settings(seed=2)), folds(20, 5, 2)))


def test_the_rules_fit_with_their_least_effect():
    rng = np.random.default_rng(6)
    x = rng.uniform(0, 1, 4000)
    slope = 4.0 * x + 0.3 * np.tanh((x - 0.5) / 0.08) + rng.normal(0, 0.5, 4000)
    candidate = Candidate.new("rp02", "input", x, ("rp02",))
    rules = fitting.Rules(Settings(folds=5, seed=0, interactions=False), min_effect=1.0)
    assert rules.best_fit(candidate, slope - slope.mean()).form.name == "linear"
    assert rules.fit_all([candidate], slope - slope.mean())["rp02"].form.name == "linear"


def _lubricated_coils(explained: float):
    """Coils of 60 parts with a per-coil lubricant film whose effect makes ``explained`` of the coil offsets
    (tests/test_diagnosis_rules.py), a shim setting and the hall's temperature that do nothing."""
    frame, y = coil_plant(explained)
    frame["shim_mm"] = np.random.default_rng(3).uniform(0.4, 0.6, len(frame))
    return frame, y


def test_the_causes_table_says_why_each_candidate_was_not_chosen_and_lists_the_chosen_first():
    frame, y = _lubricated_coils(explained=1.0)
    result = diagnosis.diagnose(frame, y, ["lube", "shim_mm", "ambient"], [], Settings(), surrogate_std=0.2)
    table = result.table.set_index("cause")
    assert list(table.index) == [
        "lube",
        "lube*ambient",
        "lube*shim_mm",
        "coil",
        "ambient",
        "ambient*shim_mm",
        "shim_mm",
    ]
    assert list(table["rank"]) == [1, 2, 3, 4, 5, 6, 7]
    assert list(table["selected"]) == [True] + [False] * 6
    assert list(table["significant"]) == [True] + [False] * 6
    assert table["note"].to_dict() == {
        "lube": "cannot be told apart from coil in this data",  # the lubricant is logged per coil
        "lube*ambient": "a variant of a chosen cause's column: adds nothing beyond it",
        "lube*shim_mm": "a variant of a chosen cause's column: adds nothing beyond it",
        "coil": "cannot be told apart from lube in this data",
        "ambient": "",
        "ambient*shim_mm": "no interaction: the product does not beat the two main effects",
        "shim_mm": "",
    }
    assert table.loc["ambient*shim_mm", "form"] == "additive"


def test_an_id_not_named_says_what_accounts_for_its_offsets():
    frame, surface, _, rng = material_coils()
    y = surface + rng.normal(0, 0.5, len(frame))
    result = diagnosis.diagnose(frame, y, ["m1", "m2"], [], Settings(interactions=False), surrogate_std=1.0)
    share = result.proxies["coil"].share
    assert result.table.set_index("cause").loc["coil", "note"] == (
        "an id, not a cause: the model inputs (the surrogate's own error, or an effect of the inputs alone) "
        f"and m1 and m2 account for {share:.0%} of the differences between its levels (fitted on its other "
        "levels), and what is left is within what the surrogate's own error gives between its levels or passes "
        "no other rule of a cause"
    )


def test_a_cause_whose_form_changes_once_the_others_are_in_reopens_the_choice_after_it():
    # a saturation in temperature and a wear drift along strokes, with the die warming over the strokes:
    # chosen second, the drift takes a bend of the temperature's term; with both in, it is a line again
    temp, strokes, y = warming_die(drift=6.0, temp_noise=2.0)
    n = len(y)
    frame = pd.DataFrame({"temp": temp, "strokes": strokes})
    result = diagnosis.diagnose(frame, y, ["temp"], [], Settings(interactions=False), surrogate_std=0.25)
    assert [(fit.candidate.name, fit.form.name) for fit in result.selected] == [
        ("temp", "sigmoid"),
        ("strokes", "linear"),
    ]
    drift = result.selected[1].form
    assert drift.slope == pytest.approx(-6.0 / n, rel=0.1)


class Fixed(forms.Form):
    """A form that predicts given values: the rule under test sees only names, parameters and predictions."""

    def __init__(self, name, values, n_params, width=1.0):
        self.name, self.values, self.n_params, self.width = name, np.asarray(values, float), n_params, width

    def _predict(self, x):
        return self.values


def _predicting(form_name, values, n_params, *, kind="input", score=-1.0, width=1.0, cv_mse=1.0):
    x = np.arange(4.0)
    return fitting.Fit(
        Candidate.new("x", kind, x, ("x",)), Fixed(form_name, values, n_params, width), x, cv_mse, 4.0, score, 0, 0, 0
    )


SAME, APART = [0.0, 1.0, 2.0, 3.0], [3.0, 0.0, 3.0, 0.0]


@pytest.mark.parametrize("match_at", [1, 2])
def test_a_closed_form_that_matches_a_winning_trend_goes_ahead_of_it(match_at):
    trend = _predicting("monotone", SAME, 5)
    others = [_predicting("linear", APART, 1), _predicting("quadratic", APART, 2), _predicting("step", APART, 2)]
    others[match_at - 1] = _predicting("sigmoid", SAME, 3)
    fits = [trend, *others]
    reordered = fitting._named_form_first(fits, min_effect=0.5)
    assert reordered == [others[match_at - 1], trend] + [fit for fit in others if fit is not others[match_at - 1]]
    assert fitting._named_form_first([others[0], trend], min_effect=0.5) == [others[0], trend]  # no trend first


@pytest.mark.parametrize("kind,moved", [("input", True), ("log", True), ("time", True), ("interaction", False)])
def test_a_sigmoid_wider_than_its_data_gives_way_to_a_simpler_form_that_predicts_the_same(kind, moved):
    # the values span 3: a change of 4.39 widths over more than 3 shows no saturation in the data
    sigmoid = _predicting("sigmoid", SAME, 3, kind=kind, width=0.7)
    as_many = _predicting("quadratic", SAME, 3, kind=kind)  # the same, but not simpler
    fewer_apart = _predicting("step", APART, 2, kind=kind)  # simpler, but not the same
    slope = _predicting("linear", SAME, 1, kind=kind)
    fits = [sigmoid, as_many, fewer_apart, slope]
    expected = [slope, sigmoid, as_many, fewer_apart] if moved else fits
    assert fitting._unseen_saturation_last(fits, 0.5, sigmoid.candidate) == expected
    assert fitting._unseen_saturation_last([sigmoid, slope], 0.5, sigmoid.candidate)[0] is (slope if moved else sigmoid)


def test_a_sigmoid_whose_change_fits_inside_its_data_stays():
    narrow = _predicting("sigmoid", SAME, 3, width=3.0 / forms.SIGMOID_SPAN)  # 10-90% over exactly the span
    slope = _predicting("linear", SAME, 1)
    assert fitting._unseen_saturation_last([narrow, slope], 0.5, narrow.candidate) == [narrow, slope]
    assert fitting._unseen_saturation_last([], 0.5, narrow.candidate) == []


@pytest.mark.parametrize(
    "carried_on,moved",
    [(0.76, True), (0.73, False), (0.70, False)],  # the saturation explains 0.6875 (1 - 1.25 / 4); tolerance 0.05
)
def test_a_parabola_goes_ahead_of_a_saturation_only_where_carried_on_it_predicts_clearly_better(carried_on, moved):
    saturation = _predicting("sigmoid", SAME, 3, cv_mse=1.25)
    saturation.shape_mse = 1.25
    parabola = _predicting("quadratic", APART, 2, cv_mse=2.0)  # held flat, it explains less: 0.5
    parabola.shape_mse = 4.0 * (1.0 - carried_on)
    fits = [saturation, _predicting("linear", APART, 1), parabola]
    expected = [parabola, saturation, fits[1]] if moved else fits
    assert fitting._parabola_the_data_follow(fits) == expected
    assert fitting._parabola_the_data_follow([parabola, saturation]) == [parabola, saturation]  # nothing to move
    assert fitting._parabola_the_data_follow([]) == []


@pytest.mark.parametrize("seed", [0, 1])
def test_a_parabola_steep_at_its_sparse_end_is_named_a_parabola_and_a_saturation_a_saturation(seed):
    # a long upper tail of values (a cushion force's), the vertex at the 15th percentile: held out by value, the
    # parabola held flat beyond its values predicted the steep end flat, and a saturation won (structures 60040)
    rng = np.random.default_rng(seed)
    x = 290.0 + rng.gamma(2.0, 12.0, 1500)
    noise = rng.normal(0.0, 1.0, len(x))
    cushion = Candidate.new("cushion_kn", "input", x, ("cushion_kn",))
    parabola = 0.005 * (x - np.quantile(x, 0.15)) ** 2 + noise
    saturation = 6.0 / (1.0 + np.exp(-(x - np.quantile(x, 0.5)) / 4.0)) + noise
    for y, named in ((parabola, "quadratic"), (saturation, "sigmoid")):
        assert fitting.best_fit(cushion, y - y.mean(), Settings(seed=0), 0.6).form.name == named


def _trend(**scores) -> fitting.Fit:
    fit = _scored(**scores)
    fit.form = forms.Monotone()
    return fit


@pytest.mark.parametrize(
    "named_p,trend_p,trend_score,stays",
    [
        (0.02, 0.001, -2.0, "trend"),  # the slope under the bar, its better trend above it: the trend stays
        (0.001, 0.001, -2.0, "named"),  # the slope significant itself: it stands
        (0.02, 0.02, -2.0, "named"),  # neither significant: nothing to settle
        (0.02, 0.001, -1.0, "named"),  # a trend that scored no better was never put behind the slope
    ],
)
def test_a_named_form_that_took_a_trends_place_stands_only_where_it_is_significant(
    named_p, trend_p, trend_score, stays
):
    named, trend = _scored("wear", p_value=named_p, score=-1.0), _trend(p_value=trend_p, score=trend_score)
    named.alternatives = [named, trend]
    settled = fitting.Rules(Settings(alpha=0.01), n_tests=1, min_effect=0.5).settled(named)
    assert settled.form.name == {"trend": "monotone", "named": "linear"}[stays]
    if stays == "trend":
        assert settled.alternatives[0] is settled and settled.alternatives[1] is named


def test_candidates_are_ranked_by_their_best_significant_form_not_by_the_form_they_are_named_with():
    # a wear named by its slope (it predicts what its better trend does) against a looser neighbour that scores
    # between the two: the wear's trend is what it predicts held out
    rules = fitting.Rules(Settings(alpha=0.01), n_tests=1, min_effect=0.5)
    slope = _scored("wear", "log", score=-1.0, p_value=0.001)
    trend = _trend(name="wear", kind="log", score=-3.0, p_value=0.001)
    trend.form = forms.fit_form("monotone", trend.candidate.values, trend.candidate.values)
    slope.alternatives = [slope, trend]
    ambient = _scored("ambient", "log", score=-2.0, p_value=0.001)
    ambient.form.slope = -1.0  # predicts otherwise than the wear: not a simpler rival of it
    assert rules.strength(slope) == -3.0 and rules.strength(ambient) == -2.0
    selection = Selection(np.zeros(4), [slope.candidate, ambient.candidate], rules, {})
    assert selection._next_smooth([ambient, slope]) is slope
    trend.p_value = 0.02  # a better trend that is not significant does not count
    assert rules.strength(slope) == -1.0
    assert selection._next_smooth([ambient, slope]) is ambient


def test_value_folds_hold_out_whole_levels_of_a_numeric_candidate():
    from hybridtwin.diagnosis import Candidate, Settings
    from hybridtwin.diagnosis.fits import value_folds

    rng = np.random.default_rng(0)
    levels = rng.permutation(np.repeat(np.linspace(0.4, 0.7, 40), 50))  # 40 campaign settings, 50 parts each
    settings = Settings(folds=5, seed=3)
    splits = value_folds(Candidate.new("shim", "input", levels, ("shim",)), settings)
    assert sorted(np.concatenate([test for _, test in splits]).tolist()) == list(range(len(levels)))
    for train, test in splits:
        assert not set(levels[train]) & set(levels[test]), "a setting level on both sides of a fold"
        assert len(np.unique(levels[test])) == 8, "each fold holds out four bins of two levels each"
    ids = np.array([f"K{i % 30}" for i in range(len(levels))])
    shuffled = value_folds(Candidate.new("coil", "group", ids, ("coil",)), settings)
    assert all(set(ids[train]) >= set(ids[test]) for train, test in shuffled), "group levels are seen in training"


@pytest.mark.parametrize("with_product, expected", [(False, "additive"), (True, "product")])
def test_a_pair_is_an_interaction_only_where_the_product_beats_its_main_effects(with_product, expected):
    from hybridtwin import diagnosis
    from hybridtwin.diagnosis import Candidate, Settings, best_fit
    from hybridtwin.diagnosis.fits import is_significant

    rng = np.random.default_rng(1)
    a, b = rng.uniform(-1, 1, (2, 3000))
    y = 2.0 * a + 3.0 * b + (4.0 * a * b if with_product else 0.0) + rng.normal(0, 0.3, 3000)
    fit = best_fit(Candidate.new("a*b", "interaction", np.column_stack([a, b]), ("a", "b")), y - y.mean(), Settings())
    assert fit.form.name == expected
    assert is_significant(fit, 1, Settings(), min_effect=0.1) == with_product
    assert diagnosis.forms.FAMILIES[fit.form.name] == ("interaction" if with_product else "additive")


def test_day_first_stamps_read_in_one_format_as_each_on_its_own_and_a_mixed_column_still_reads():
    stamps = pd.Series(pd.date_range("2025-03-11 06:00", periods=500, freq="37s")).dt.strftime("%d.%m.%Y %H:%M:%S")
    one_by_one = pd.to_datetime(stamps, format="mixed", dayfirst=True)
    assert parse_timestamps(stamps).equals(one_by_one) and parse_timestamps(stamps).iloc[0].month == 3
    mixed = pd.Series(["04.03.2026 06:00:00", "05.03.2026 07:30", "13.03.2026", "2026-03-06 08:00:00"])
    expected = ("2026-03-04 06:00", "2026-03-05 07:30", "2026-03-13", "2026-03-06 08:00")  # no one format fits all
    assert parse_timestamps(mixed).tolist() == [pd.Timestamp(t) for t in expected]
    assert parse_timestamps(pd.Series(["C-001", "C-002", "C-003"])) is None
    assert looks_like_timestamps(stamps) and not looks_like_timestamps(pd.Series(["130480", "130481"]))  # a counter
    assert not looks_like_timestamps(pd.Series(["130480", "", "130482"]))  # with a blank cell
