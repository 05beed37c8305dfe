"""Table builders of hybridtwin.tables and the out-of-fold splicing behind every production error."""

import math

import numpy as np
import pandas as pd
import pytest

from hybridtwin.crossval import (
    capped_note,
    splice_out_of_fold,
)
from hybridtwin.paper import tables
from hybridtwin.paper.tables import dataset_summary, matched_summary, production_predictions, sensitivity_table
from tests.conftest import says


def test_splice_puts_out_of_fold_values_at_the_training_rows():
    final = np.array([10.0, 11.0, 12.0, 13.0])
    spliced = splice_out_of_fold(final, [1, 3], [-1.0, -3.0])
    np.testing.assert_array_equal(spliced, [10.0, -1.0, 12.0, -3.0])
    np.testing.assert_array_equal(final, [10.0, 11.0, 12.0, 13.0])  # the input is not changed


def test_production_predictions_by_hand():
    residuals = pd.DataFrame(
        {
            "measured": [5.0, 6.0, 7.0],
            "pred_surrogate": [4.0, 4.0, 4.0],
            "pred_surrogate_std": [0.1, 0.2, 0.3],
            "residual_approx": [1.0, 2.0, 3.0],
        }
    )
    support = pd.DataFrame({"in_support": [True, False, True], "knn_distance": [0.5, 3.0, 0.7]})
    filtered = np.array([0.9, 2.5, 3.1])  # the final filtered model everywhere
    unfiltered = np.array([1.1, 1.9, 2.9])
    filtered_oof = pd.DataFrame({"row": [0, 2], "pred_residual_oof": [0.8, 3.3]})
    unfiltered_oof = pd.DataFrame({"row": [0, 1, 2], "pred_residual_oof": [1.2, 1.8, 2.7]})
    table = production_predictions(residuals, support, filtered, unfiltered, filtered_oof, unfiltered_oof)
    np.testing.assert_allclose(table["pred_hybrid"], [4.9, 6.5, 7.1])
    np.testing.assert_allclose(table["pred_hybrid_gated"], [4.9, 4.0, 7.1])  # the surrogate alone outside
    np.testing.assert_allclose(table["pred_hybrid_oof"], [4.8, 6.5, 7.3])  # out-of-fold where it was trained
    np.testing.assert_allclose(table["pred_hybrid_unfiltered_oof"], [5.2, 5.8, 6.7])
    assert table["in_support"].tolist() == [True, False, True]
    assert not table.filter(like="_oof").isna().any().any()


def test_unfiltered_out_of_fold_must_cover_every_row():
    residuals = pd.DataFrame(
        {
            "measured": [5.0, 6.0],
            "pred_surrogate": [4.0, 4.0],
            "pred_surrogate_std": [0.1, 0.1],
            "residual_approx": [1.0, 2.0],
        }
    )
    support = pd.DataFrame({"in_support": [True, False], "knn_distance": [0.5, 3.0]})
    table = production_predictions(
        residuals,
        support,
        np.zeros(2),
        np.zeros(2),
        pd.DataFrame({"row": [0], "pred_residual_oof": [1.0]}),
        pd.DataFrame({"row": [0], "pred_residual_oof": [1.0]}),
    )
    assert np.isnan(table["pred_hybrid_unfiltered_oof"].iloc[1])  # never silently filled with a trained value
    assert table["pred_hybrid_unfiltered_oof"].iloc[0] == pytest.approx(5.0)


def test_table1_names_each_data_set_its_role_and_size():
    table = dataset_summary(n_doe=67, n_production=1000, n_in_support=600, n_matched=5, k=5, percentile=95.0)
    expected = pd.DataFrame(
        {
            "dataset": [
                "Numerical DoE",
                "Production (all)",
                "Production in-support subset",
                "Production out-of-support",
                "Matched cases (reserved)",
            ],
            "role": [
                "Train surrogate y_FEM_hat",
                "Unfiltered-train comparison (Table 5)",
                "Train/validate residual model r_hat",
                "Evaluation only (Table 5)",
                "External check",
            ],
            "size": [67, 1000, 600, 400, 5],
            "notes": [
                "simulated target; also defines the standardization and the support",
                "measured target",
                "kNN support gate: k=5, threshold = 95th percentile of DoE leave-one-out distances",
                "never used to train the filtered residual model",
                "true residuals; never used for training or tuning",
            ],
        }
    )
    pd.testing.assert_frame_equal(table, expected)


def test_production_predictions_columns_are_the_contract_outside_tools_read():
    residuals = pd.DataFrame(
        {"measured": [5.0], "pred_surrogate": [4.0], "pred_surrogate_std": [0.1], "residual_approx": [1.0]}
    )
    support = pd.DataFrame({"in_support": [False], "knn_distance": [3.0]})
    table = production_predictions(
        residuals,
        support,
        np.array([0.5]),
        np.array([0.25]),
        pd.DataFrame({"row": [], "pred_residual_oof": []}),
        pd.DataFrame({"row": [0], "pred_residual_oof": [0.75]}),
    )
    expected = pd.DataFrame(
        {
            "row": [0],
            "in_support": [False],
            "knn_distance": [3.0],
            "measured": [5.0],
            "pred_surrogate": [4.0],
            "pred_surrogate_std": [0.1],
            "residual_approx": [1.0],
            "pred_residual": [0.5],
            "pred_hybrid": [4.5],
            "pred_hybrid_gated": [4.0],
            "pred_hybrid_unfiltered": [4.25],
            "pred_hybrid_oof": [4.5],  # never trained on this row: the final model
            "pred_hybrid_unfiltered_oof": [4.75],
        }
    )
    pd.testing.assert_frame_equal(table, expected)


def test_matched_cases_table_by_hand():
    _, cases = matched_summary([10.0, 12.0], [9.0, 12.5], [9.5, 11.0], [0.5, 1.0], [True, False])
    expected = pd.DataFrame(
        {
            "measured": [10.0, 12.0],
            "simulated": [9.0, 12.5],
            "pred_surrogate": [9.5, 11.0],
            "pred_hybrid": [10.0, 12.0],
            "pred_hybrid_gated": [10.0, 11.0],
            "true_residual": [1.0, -0.5],
            "pred_residual": [0.5, 1.0],
            "error_simulation": [1.0, -0.5],
            "error_surrogate": [0.5, 1.0],
            "error_hybrid": [0.0, 0.0],
            "error_hybrid_gated": [0.0, 1.0],
        }
    )
    pd.testing.assert_frame_equal(cases, expected)


def test_one_matched_case_has_no_spread_rather_than_none():
    summary, _ = matched_summary([10.0], [9.0], [9.5], [0.5], [True])
    assert (summary["error_std"] == 0.0).all() and (summary["n"] == 1).all()


@pytest.mark.parametrize(
    "table, says",
    [
        (
            lambda: matched_summary([10.0], [9.0], [9.5], [0.5], [True])[0],
            "matched cases only (never used for training or tuning); error = reference - prediction",
        ),
        (
            lambda: sensitivity_table(
                pd.DataFrame(
                    {
                        "measured": [1.0, 2.0],
                        "in_support": [True, False],
                        "pred_surrogate": [1.0, 1.0],
                        "pred_hybrid_oof": [1.0, 1.0],
                        "pred_hybrid_unfiltered_oof": [1.0, 1.0],
                    }
                )
            ),
            "measured production values; residual models scored out-of-fold on their own training rows (a split "
            "other than the tuning's), the final filtered model on out-of-support rows; both residual models use "
            "the hyperparameters tuned on in-support rows",
        ),
    ],
)
def test_each_table_says_on_what_data_it_was_computed(table, says):
    assert (table()["evaluated_on"] == says).all()


def test_matched_summary_by_hand():
    measured = [10.0, 12.0, 14.0]
    simulated = [9.0, 12.0, 15.0]
    surrogate = [9.5, 11.0, 14.5]
    residual_pred = [0.5, 1.0, -1.0]
    in_support = [True, True, False]
    summary, cases = tables.matched_summary(measured, simulated, surrogate, residual_pred, in_support)

    np.testing.assert_allclose(cases["true_residual"], [1.0, 0.0, -1.0])
    np.testing.assert_allclose(cases["pred_hybrid"], [10.0, 12.0, 13.5])
    np.testing.assert_allclose(cases["pred_hybrid_gated"], [10.0, 12.0, 14.5])  # surrogate outside the support
    np.testing.assert_allclose(cases["error_hybrid"], [0.0, 0.0, 0.5])
    np.testing.assert_allclose(cases["error_hybrid_gated"], [0.0, 0.0, -0.5])
    np.testing.assert_allclose(cases["error_surrogate"], [0.5, 1.0, -0.5])

    rows = summary.set_index("comparison")
    assert (rows["n"] == 3).all()
    res = rows.loc["residual (predicted vs true)"]  # errors [0.5, -1, 0]
    assert res["rmse"] == pytest.approx(math.sqrt(1.25 / 3))
    assert res["mae"] == pytest.approx(0.5)
    assert res["bias"] == pytest.approx(-0.5 / 3)
    assert res["r2"] == pytest.approx(1 - 1.25 / 2)  # true residual mean 0, SST 2
    sim = rows.loc["simulation (measured vs FE)"]  # errors [1, 0, -1]
    assert (sim["rmse"], sim["bias"], sim["error_std"]) == pytest.approx((math.sqrt(2 / 3), 0.0, 1.0))
    sur = rows.loc["surrogate (measured vs y_FEM_hat)"]  # errors [0.5, 1, -0.5]
    assert (sur["rmse"], sur["mae"], sur["bias"]) == pytest.approx((math.sqrt(0.5), 2 / 3, 1 / 3))
    hyb = rows.loc["hybrid (measured vs y_hyb)"]  # errors [0, 0, 0.5]
    assert hyb["rmse"] == pytest.approx(math.sqrt(0.25 / 3))
    assert hyb["bias"] == pytest.approx(0.5 / 3)
    assert hyb["error_mean"] == pytest.approx(0.5 / 3)
    assert hyb["error_std"] == pytest.approx(math.sqrt(1 / 12))
    assert hyb["r2"] == pytest.approx(1 - 0.25 / 8)  # measured mean 12, SST 8
    gat = rows.loc["hybrid gated (measured vs gated y_hyb)"]  # errors [0, 0, -0.5]
    assert (gat["rmse"], gat["bias"]) == pytest.approx((math.sqrt(0.25 / 3), -0.5 / 3))


def test_sensitivity_table_by_hand():
    predictions = pd.DataFrame(
        {
            "measured": [10.0, 10.0, 10.0, 10.0],
            "in_support": [True, True, False, False],
            "pred_surrogate": [9.0, 11.0, 8.0, 13.0],  # errors [1, -1, 2, -3]
            "pred_hybrid_oof": [10.0, 10.5, 9.0, 10.0],  # errors [0, -0.5, 1, 0]
            "pred_hybrid_unfiltered_oof": [11.0, 10.0, 10.0, 12.0],  # errors [-1, 0, 0, -2]
        }
    )
    table = tables.sensitivity_table(predictions).set_index("region")
    assert table["samples"].to_dict() == {"in_support": 2, "out_of_support": 2, "all": 4}
    assert table["evaluated_on"].iloc[0].endswith("tuned on in-support rows")
    noted = tables.sensitivity_table(predictions, capped_note(3, 4))
    says(noted["evaluated_on"].iloc[0], "at most 3", "residual_model.max_train_rows")
    expected = {
        "rmse_surrogate_only": (1.0, math.sqrt(6.5), math.sqrt(15 / 4)),
        "rmse_filtered_train_no_gate": (math.sqrt(0.125), math.sqrt(0.5), math.sqrt(1.25 / 4)),
        "rmse_unfiltered_train_no_gate": (math.sqrt(0.5), math.sqrt(2.0), math.sqrt(5 / 4)),
        # gated: filtered hybrid inside [0, -0.5], surrogate outside [2, -3]
        "rmse_filtered_train_gated": (math.sqrt(0.125), math.sqrt(6.5), math.sqrt(13.25 / 4)),
    }
    for column, (inside, outside, everywhere) in expected.items():
        got = table[column]
        assert (got["in_support"], got["out_of_support"], got["all"]) == pytest.approx((inside, outside, everywhere)), (
            column
        )
    assert (
        table.loc["out_of_support", "rmse_filtered_train_gated"] == table.loc["out_of_support", "rmse_surrogate_only"]
    )
    assert (
        table.loc["in_support", "rmse_filtered_train_gated"] == table.loc["in_support", "rmse_filtered_train_no_gate"]
    )


def test_matched_cases_table_numbers_the_cases_from_one_and_keeps_their_support():
    matched = pd.DataFrame({"sim": [9.0, 12.5, 8.0], "meas": [10.0, 12.0, 7.0]})
    summary, cases = tables.matched_cases_table(matched, "sim", "meas", [9.5, 11.0, 8.5], [0.5, 1.0, -1.0], [1, 0, 1])
    assert list(cases.columns[:3]) == ["matched_row", "in_support", "measured"]
    assert cases["matched_row"].tolist() == [1, 2, 3]
    assert cases["in_support"].tolist() == [True, False, True]
    np.testing.assert_array_equal(cases["simulated"], [9.0, 12.5, 8.0])
    np.testing.assert_array_equal(cases["error_hybrid_gated"], [0.0, 1.0, -0.5])  # 7 - (8.5 - 1)
    assert summary["n"].tolist() == [3] * 5


def _predictions_and_cases():
    predictions = pd.DataFrame(
        {
            "in_support": [True, False, True],
            "measured": [10.0, 20.0, 12.0],
            "pred_surrogate": [9.0, 18.0, 12.5],
            "residual_approx": [1.0, 2.0, -0.5],
            "pred_hybrid_oof": [9.75, 30.0, 12.0],
        }
    )
    summary, cases = matched_summary([10.0, 12.0], [9.0, 12.5], [9.5, 11.0], [0.5, 1.0], [True, False])
    return predictions, cases, summary


def test_residual_check_pairs_each_residual_with_its_target_in_support_and_at_the_matched_cases():
    predictions, cases, summary = _predictions_and_cases()
    shown = tables.residual_check(predictions, cases, summary)
    np.testing.assert_array_equal(shown["production_target"], [1.0, -0.5])  # the in-support rows only
    np.testing.assert_array_equal(shown["production_pred"], [0.75, -0.5])  # out-of-fold hybrid - surrogate
    np.testing.assert_array_equal(shown["matched_target"], [1.0, -0.5])
    np.testing.assert_array_equal(shown["matched_pred"], [0.5, 1.0])
    first = summary.iloc[0]  # the residual's own row: predicted against true
    assert first["comparison"].startswith("residual") and shown["matched_scores"] == {
        "r2": first["r2"],
        "rmse": first["rmse"],
    }


def test_error_groups_are_the_surrogate_and_hybrid_errors_in_support_and_at_the_matched_cases():
    predictions, cases, _ = _predictions_and_cases()
    groups = tables.error_groups(predictions, cases)
    production, matched = groups
    assert production == "production in support (n=2), hybrid out-of-fold" and matched == "matched cases (n=2)"
    np.testing.assert_array_equal(groups[production]["surrogate"], [1.0, -0.5])
    np.testing.assert_array_equal(groups[production]["hybrid"], [0.25, 0.0])
    np.testing.assert_array_equal(groups[matched]["surrogate"], [0.5, 1.0])
    np.testing.assert_array_equal(groups[matched]["hybrid"], [0.0, 0.0])
