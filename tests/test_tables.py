"""Table builders of hybridtwin.tables and the out-of-fold splicing behind every production error."""

import numpy as np
import pandas as pd
import pytest

from hybridtwin.crossval import splice_out_of_fold
from hybridtwin.tables import dataset_summary, production_predictions


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
