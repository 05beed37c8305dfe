"""hybridtwin.extension: offset plus diagnosed terms, refitted jointly, trusted only as far as the data show."""

import json
from functools import partial

import numpy as np
import pandas as pd
import pytest
from sklearn.dummy import DummyRegressor

from hybridtwin.crossval import training_subset
from hybridtwin.diagnosis.causes import Cause, Term
from hybridtwin.diagnosis.extension import (
    DiscrepancyExtension,
    Fitting,
    Parts,
    evaluate,
    gain_table,
    guard,
    keeps_out_of_support,
)
from hybridtwin.metrics import block_gains
from hybridtwin.models.compose import guarded
from tests.conftest import says

RNG = np.random.default_rng(5)
A = RNG.normal(0, 1, 3000)
B = 0.8 * A + 0.6 * RNG.normal(0, 1, 3000)
FRAME = pd.DataFrame({"a": A, "b": B, "coil": np.where(A > 0, "K1", "K2")})
LINEAR_A, LINEAR_B = Term(Cause("a", "input", ("a",)), "linear"), Term(Cause("b", "log", ("b",)), "linear")


def test_offset_alone_is_the_mean_residual():
    model = DiscrepancyExtension(()).fit(FRAME, 4.0 + 0.0 * A)
    assert model.offset_ == pytest.approx(4.0)
    assert model.predict(FRAME).shape == (len(FRAME),)  # one value per row, not one number
    np.testing.assert_allclose(model.predict(FRAME), 4.0)


def test_offset_and_one_term_recover_the_residual():
    model = DiscrepancyExtension((LINEAR_A,)).fit(FRAME, 5.0 + 2.0 * A)
    assert model.offset_ == pytest.approx(5.0 + 2.0 * A.mean())
    np.testing.assert_allclose(model.predict(FRAME), 5.0 + 2.0 * A, atol=1e-9)


def test_two_correlated_causes_are_fitted_jointly():
    model = DiscrepancyExtension((LINEAR_A, LINEAR_B)).fit(FRAME, 1.0 + 2.0 * A - 3.0 * B)
    slopes = [form.slope for form in model.forms_]
    assert slopes == pytest.approx([2.0, -3.0], abs=0.02)  # one backfitting pass would be far off
    np.testing.assert_allclose(model.predict(FRAME), 1.0 + 2.0 * A - 3.0 * B, atol=0.05)


def test_a_missing_cause_column_contributes_nothing():
    model = DiscrepancyExtension((LINEAR_A, LINEAR_B)).fit(FRAME, 1.0 + 2.0 * A - 3.0 * B)
    without_b = FRAME.drop(columns="b")
    terms = model.contributions(without_b)
    np.testing.assert_allclose(terms["b"], 0.0)
    np.testing.assert_allclose(model.predict(without_b), model.offset_ + terms["a"])


def test_each_missing_column_is_said_and_the_other_terms_still_count(caplog):
    model = DiscrepancyExtension((LINEAR_A, LINEAR_B)).fit(FRAME, 1.0 + 2.0 * A - 3.0 * B)
    only_b = FRAME[["b"]]  # the first term's column is missing, the second's is all there is
    terms = model.contributions(only_b)
    np.testing.assert_allclose(terms["a"], 0.0)
    np.testing.assert_allclose(terms["b"], model.contributions(FRAME)["b"])
    assert "no column ('a',) here: the a term is set to its mean (0)" in caplog.text
    assert model.to_dict()["format"] == "hybridtwin.DiscrepancyExtension/1"


def test_a_term_fitted_to_a_step_is_held_beyond_the_fitted_values():
    x = RNG.uniform(0, 1, 4000)
    frame = pd.DataFrame({"shim": x})
    residual = np.where(x >= 0.5, 5.0, 0.0) + RNG.normal(0, 0.3, len(x))
    model = DiscrepancyExtension((Term(Cause("shim", "input", ("shim",)), "linear"),)).fit(frame, residual)
    beyond = model.predict(pd.DataFrame({"shim": [x.max(), 2.0, 10.0]}))
    assert beyond == pytest.approx([beyond[0]] * 3)


def test_json_round_trip_keeps_trusted_ranges():
    x = RNG.uniform(0, 1, 4000)
    frame = pd.DataFrame({"shim": x, "coil": np.where(x > 0.3, "K1", "K2")})
    residual = np.where(x >= 0.5, 5.0, 0.0) + RNG.normal(0, 0.3, len(x))
    causes = (Term(Cause("shim", "input", ("shim",)), "linear"), Term(Cause("coil", "group", ("coil",)), "group"))
    model = DiscrepancyExtension(causes).fit(frame, residual)
    loaded = DiscrepancyExtension.from_dict(json.loads(json.dumps(model.to_dict())))
    probe = pd.DataFrame({"shim": [-1.0, 0.2, 0.7, 3.0], "coil": ["K1", "K2", "new", "K1"]})
    np.testing.assert_allclose(loaded.predict(probe), model.predict(probe))


def test_gain_table_scores_each_region_on_its_rows():
    measured = np.array([1.0, 2.0, 3.0, 4.0])
    inside = np.array([True, True, False, False])
    predictions = {"hybrid": np.array([1.0, 3.0, 3.0, 2.0]), "extended": measured.copy()}
    matched = {"hybrid": np.array([0.0]), "extended": np.array([1.0])}
    table = gain_table(measured, predictions, inside, np.array([1.0]), matched, truth=measured + 1, noise=2.0)
    row = table.set_index("model").loc["hybrid"]
    assert row["rmse_in_support_cv"] == pytest.approx(np.sqrt(0.5))  # errors 0, -1
    assert row["rmse_out_of_support"] == pytest.approx(np.sqrt(2.0))  # errors 0, 2
    assert row["rmse_matched"] == pytest.approx(1.0)
    assert row["rmse_truth_out_of_support"] == pytest.approx(np.sqrt((1 + 9) / 2))  # truth 4, 5 against 3, 2
    assert row["out_of_support_over_noise"] == pytest.approx(np.sqrt(2.0) / 2.0)
    assert table.set_index("model").loc["extended", "rmse_out_of_support"] == 0.0
    assert (table["n_in_support"] == 2).all() and (table["n_out_of_support"] == 2).all()
    assert row["rmse_truth_in_support_cv"] == pytest.approx(np.sqrt((1 + 0) / 2))  # truth 2, 3 against 1, 3
    assert (table["n_matched"] == 1).all()
    assert (
        table["evaluated_on"]
        .iloc[0]
        .endswith("matched cases (never used for fitting); truth = the demo's noise-free plant")
    )


def test_gain_table_counts_each_region_and_says_what_it_scored():
    inside = np.array([True, False, False])
    table = gain_table(np.zeros(3), {"m": np.ones(3)}, inside, np.zeros(2), {"m": np.zeros(2)}, noise=None)
    row = table.iloc[0]
    assert (row["n_in_support"], row["n_out_of_support"], row["n_matched"]) == (1, 2, 2)
    assert "rmse_truth_out_of_support" not in table.columns
    says(row["evaluated_on"], "measured", "in support out of period", "never on these rows", "matched cases")
    without_noise = gain_table(
        np.zeros(3), {"m": np.ones(3)}, inside, np.zeros(2), {"m": np.zeros(2)}, truth=np.zeros(3)
    )
    assert np.isnan(without_noise["out_of_support_over_noise"].iloc[0])


def test_gain_table_scores_out_of_the_support_on_the_test_rows_only():
    inside = np.array([True, False, False, False])
    measured, predicted = np.zeros(4), np.array([1.0, 2.0, 3.0, 4.0])
    table = gain_table(
        measured, {"m": predicted}, inside, np.zeros(1), {"m": np.zeros(1)}, test=[False, True, False, True]
    )
    row = table.iloc[0]
    assert row["rmse_in_support_cv"] == pytest.approx(1.0)  # in support: every row, test or not
    assert row["rmse_out_of_support"] == pytest.approx(np.sqrt((4 + 16) / 2))  # rows 1 and 3
    assert (row["n_in_support"], row["n_out_of_support"]) == (1, 2)
    assert "on the test blocks (odd blocks of consecutive rows" in row["evaluated_on"]


def evaluation_by_hand(
    measured_outside=(16.0, 19.0),
    matched_in_support=True,
    choosing=None,
    more_outside=0,
    more_like="extended",
    max_train_rows=None,
    seed=0,
):
    """Eight parts, six in support (rows 0, 2, 3, 5, 6, 7) with residuals 0, 0, 0, 0, 0, 6; the two outside
    (rows 1 and 4) carry 100, which no model may see. No terms: the extension is the offset (the training
    rows' mean residual); the remainder model is the largest residual it leaves over. Two folds over the
    in-support rows. The hybrid predicts 50 + row; rows 1 and 4 measure ``measured_outside``. Then
    ``more_outside`` parts outside the support, measuring what the extended hybrid (16) or the hybrid
    (50 + row) predicts, as ``more_like`` says: two parts outside cannot decide beyond doubt whether the
    extended hybrid stands; with 100 more, five blocks of parts can."""
    n = 8 + more_outside
    production = pd.DataFrame({"a": np.arange(float(n))})
    inside = np.r_[True, False, True, True, False, True, True, True, np.zeros(more_outside, bool)]
    residual = np.r_[0.0, 100.0, 0.0, 0.0, 100.0, 0.0, 0.0, 6.0, np.full(more_outside, 100.0)]
    measured = 10.0 + residual
    measured[[1, 4]] = measured_outside
    measured[8:] = 16.0 if more_like == "extended" else 50.0 + np.arange(8, n)
    residuals = pd.DataFrame(
        {"measured": measured, "residual_approx": residual, "pred_surrogate": np.full(n, 10.0), "in_support": inside}
    )
    hybrid = np.arange(float(n)) + 50
    matched = pd.DataFrame({"a": [3.5]})
    matched_cases = pd.DataFrame({"in_support": [matched_in_support], "pred_surrogate": [20.0], "pred_hybrid": [21.0]})
    splits = [(np.array([0, 1, 2]), np.array([3, 4, 5])), (np.array([3, 4, 5]), np.array([0, 1, 2]))]
    largest = partial(DummyRegressor, strategy="quantile", quantile=1.0)
    fitting = Fitting(("a",), largest, max_train_rows, seed)
    return evaluate(Parts(production, residuals, hybrid), (), fitting, splits, choosing, (matched, matched_cases))


def test_evaluation_fits_on_in_support_rows_and_scores_them_out_of_fold():
    result = evaluation_by_hand(more_outside=100)
    # all six in-support rows: offset 1, largest leftover 6 - 1 = 5; the same everywhere
    np.testing.assert_allclose(result.production["pred_extended"][:8], np.full(8, 11.0))
    np.testing.assert_allclose(result.production["pred_extended_hybrid"], np.full(108, 16.0))
    # fold 1 trains on rows 0, 2, 3 (offset 0, leftover 0) and predicts rows 5, 6, 7;
    # fold 2 trains on rows 5, 6, 7 (offset 2, leftover 4) and predicts rows 0, 2, 3; rows 1, 4: final models
    np.testing.assert_allclose(result.production["pred_extended_oof"][:8], [12, 11, 12, 12, 11, 10, 10, 10])
    np.testing.assert_allclose(result.production["pred_extended_hybrid_oof"][:8], [16, 16, 16, 16, 16, 10, 10, 10])
    np.testing.assert_allclose(result.scored["extended"], result.production["pred_extended_oof"])
    np.testing.assert_allclose(result.scored["extended_hybrid"], result.production["pred_extended_hybrid_oof"])
    np.testing.assert_allclose(result.scored["surrogate"], np.full(108, 10.0))
    np.testing.assert_allclose(result.scored["hybrid"], np.arange(108.0) + 50)
    assert result.models.extension.offset_ == pytest.approx(1.0)
    assert result.models.out_of_support


def test_with_a_cap_each_fit_takes_a_seeded_sample_of_its_rows():
    # in-support residuals 0, 0, 0, 0, 0, 6: a sample of three of them, by the seed
    residual = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 6.0])
    for seed in range(6):
        sample = residual[training_subset(6, 3, seed)]
        result = evaluation_by_hand(more_outside=100, max_train_rows=3, seed=seed)
        assert result.models.extension.offset_ == pytest.approx(sample.mean())
        np.testing.assert_allclose(result.production["pred_extended_hybrid"][0], 10.0 + sample.max())
    # the folds train on three rows each: no fewer than they have, so the in-support parts' out-of-fold values stay
    inside = [0, 2, 3, 5, 6, 7]
    capped = evaluation_by_hand(more_outside=100, max_train_rows=3).production["pred_extended_oof"].to_numpy()
    whole = evaluation_by_hand(more_outside=100).production["pred_extended_oof"].to_numpy()
    np.testing.assert_allclose(capped[inside], whole[inside])
    # with two of three, each fold's offset is the mean of its sample's residuals (fold 2 trains on 0, 0, 6)
    for seed in range(4):
        oof = evaluation_by_hand(more_outside=100, max_train_rows=2, seed=seed).production["pred_extended_oof"]
        sample = np.array([0.0, 0.0, 6.0])[training_subset(3, 2, seed)]
        np.testing.assert_allclose(oof.to_numpy()[[0, 2, 3]], 10.0 + sample.mean())  # fold 2 predicts rows 0, 2, 3
        np.testing.assert_allclose(oof.to_numpy()[[5, 6, 7]], 10.0)  # fold 1 trains on zeros


def test_out_of_the_support_the_paper_hybrid_stands_where_it_measures_closer():
    # the parts outside measure 52 and 53: the hybrid (51, 54) is off by 1 each, the extended hybrid (16) by 36
    # and 100 more parts outside measure what the hybrid predicts there
    result = evaluation_by_hand((52.0, 53.0), matched_in_support=False, more_outside=100, more_like="hybrid")
    assert not result.models.out_of_support
    hybrid_outside = 50.0 + np.arange(8, 108)
    np.testing.assert_allclose(
        result.production["pred_extended_hybrid"], [16, 51, 16, 16, 54, 16, 16, 16, *hybrid_outside]
    )
    np.testing.assert_allclose(result.production["pred_extended_hybrid_oof"][:8], [16, 51, 16, 16, 54, 10, 10, 10])
    np.testing.assert_allclose(result.scored["extended_hybrid"], result.production["pred_extended_hybrid_oof"])
    np.testing.assert_allclose(result.production["pred_extended"], np.full(108, 11.0))  # the extension alone is kept
    assert result.matched["extended_hybrid"][0] == pytest.approx(21.0)  # an out-of-support case takes the hybrid
    assert evaluation_by_hand((52.0, 53.0)).matched["extended_hybrid"][0] == pytest.approx(26.0)  # one inside not


def test_only_out_of_support_choosing_parts_decide():
    rows = np.arange(108)
    assert evaluation_by_hand(more_outside=100, choosing=rows >= 4).models.out_of_support
    # the in-support rows favour the extended hybrid too, but never choose: two parts outside cannot decide
    assert not evaluation_by_hand(more_outside=100, choosing=rows < 8).models.out_of_support
    assert not evaluation_by_hand().models.out_of_support
    assert not evaluation_by_hand(more_outside=100, choosing=rows == 0).models.out_of_support  # none outside


def guard_case(*extended_hybrid, n=20):
    """Blocks of ``n`` parts measuring 0: the hybrid predicts 4, the extended hybrid one value per block.
    The squared-error gain of a part is 16 - extended_hybrid²."""
    values = np.repeat(np.asarray(extended_hybrid, float), n)
    return np.zeros(len(values)), values, np.full(len(values), 4.0)


def test_the_guard_lets_the_extension_stand_only_where_it_wins_beyond_doubt():
    every = np.ones(200, bool)
    assert keeps_out_of_support(*guard_case(*[1.0] * 10), every)  # 10 of 10 blocks gain: p = 1/1024
    assert keeps_out_of_support(*guard_case(*[1.0] * 5), np.ones(100, bool))  # 5 of 5: p = 1/32
    assert not keeps_out_of_support(*guard_case(*[1.0] * 4), np.ones(80, bool))  # 4 of 4: p = 1/16
    # a lower RMSE (gains 16 on 3 blocks, -4.25 on 7: mean 1.825), but the typical block loses: p = 0.5
    assert not keeps_out_of_support(*guard_case(*[0.0] * 3, *[4.5] * 7), every)
    # 9 of 10 blocks gain 7 (p = 0.046), but the tenth loses 65: a higher RMSE
    assert not keeps_out_of_support(*guard_case(*[3.0] * 9, 9.0), every)
    # gains 7 on 6 blocks, 15 on 2, 12 on one, -84 on one (p = 0.025): the same RMSE as the hybrid, 4
    assert not keeps_out_of_support(*guard_case(*[3.0] * 6, 1.0, 1.0, 2.0, 10.0), every)
    assert not keeps_out_of_support(*guard_case(*[4.0] * 10), every)  # a tie
    assert not keeps_out_of_support(*guard_case(*[1.0] * 10), ~every)  # nothing to choose on
    assert not keeps_out_of_support(*guard_case(*[1.0] * 10), np.arange(200) == 3)  # one part cannot decide


def test_the_guard_lengthens_blocks_whose_gains_are_correlated():
    # gains 10 on the first 25 blocks of 20 parts, -1 on the last 25: over 50 blocks p = 0.0009; their
    # neighbours' means are correlated, so the blocks are lengthened to 12: p = 0.09
    measured, extended_hybrid, hybrid = guard_case(*[np.sqrt(6.0)] * 25, *[np.sqrt(17.0)] * 25)
    assert len(block_gains(measured, extended_hybrid, 50, hybrid, min_blocks=10)) == 12
    assert not keeps_out_of_support(measured, extended_hybrid, hybrid, np.ones(1000, bool))


def test_in_support_parts_never_choose():
    measured, extended_hybrid, hybrid = guard_case(*[1.0] * 10)  # every part favours the extended hybrid
    inside = np.arange(200) < 190
    guarded_values, stands = guard(measured, extended_hybrid, hybrid, inside, np.ones(200, bool))
    assert not stands  # ten parts outside: two blocks of gains, p = 0.25 at best
    np.testing.assert_allclose(guarded_values, np.where(inside, 1.0, 4.0))
    assert guard(measured, extended_hybrid, hybrid, np.zeros(200, bool), np.ones(200, bool))[1]  # all outside


def test_the_guard_reads_the_choosing_parts_only():
    measured, extended_hybrid, hybrid = guard_case(*[1.0] * 5, *[9.0] * 5)  # the second half is far worse
    first = np.arange(200) < 100
    assert keeps_out_of_support(measured, extended_hybrid, hybrid, first)
    assert not keeps_out_of_support(measured, extended_hybrid, hybrid, ~first)
    assert not keeps_out_of_support(measured, extended_hybrid, hybrid, np.ones(200, bool))


def test_a_guarded_extended_hybrid_keeps_its_values_in_the_support():
    inside = np.array([True, False])
    np.testing.assert_allclose(guarded([1.0, 2.0], [5.0, 6.0], inside, True), [1.0, 2.0])
    np.testing.assert_allclose(guarded([1.0, 2.0], [5.0, 6.0], inside, False), [1.0, 6.0])


def test_evaluation_predicts_the_matched_cases_with_the_final_models():
    matched = evaluation_by_hand().matched
    assert {name: float(values[0]) for name, values in matched.items()} == pytest.approx(
        {"surrogate": 20.0, "hybrid": 21.0, "extended": 21.0, "extended_hybrid": 26.0}
    )


def test_evaluation_needs_one_prediction_per_matched_case():
    production = pd.DataFrame({"a": [1.0, 2.0]})
    residuals = pd.DataFrame({"residual_approx": [0.0, 1.0], "pred_surrogate": [1.0, 1.0], "in_support": [1, 1]})
    residuals["measured"] = [1.0, 2.0]
    matched = (pd.DataFrame({"a": [1.0]}), pd.DataFrame({"pred_surrogate": [1.0, 2.0], "pred_hybrid": [1.0, 2.0]}))
    with pytest.raises(ValueError, match="2 matched-case predictions for 1 matched cases"):
        evaluate(
            Parts(production, residuals, np.array([1.0, 2.0])), (), Fitting(("a",), DummyRegressor), [], None, matched
        )


def test_the_guard_reads_zero_one_columns_as_flags():
    # in_support and the choosing blocks as a CSV gives them: 0/1 integers, which must not index rows 0 and 1
    measured, extended_hybrid, hybrid = guard_case(9.0, *[1.0] * 9)  # the first block loses, the others gain
    later = (np.arange(200) >= 20).astype(int)
    assert keeps_out_of_support(measured, extended_hybrid, hybrid, later)
    inside = (np.arange(200) < 20).astype(int)
    values, stands = guard(measured, extended_hybrid, hybrid, inside, np.ones(200, int))
    assert stands
    np.testing.assert_allclose(guarded(extended_hybrid, hybrid, inside, False), np.where(inside == 1, 9.0, 4.0))
