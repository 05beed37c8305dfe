"""The paper's tables built from the workflow's predictions: Table 1 (data sets), Table 5 (sensitivity
to filtering and gating), the matched-case check and the production predictions table."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hybridtwin.crossval import splice_out_of_fold
from hybridtwin.io.files import in_support, table_of
from hybridtwin.metrics import rmse, scores
from hybridtwin.models import compose
from hybridtwin.models.registry import HYBRID, HYBRID_GATED, HYBRID_UNFILTERED, SURROGATE


def dataset_summary(
    n_doe: int, n_production: int, n_in_support: int, n_matched: int, k: int, percentile: float
) -> pd.DataFrame:
    """Table 1: the data sets and their roles."""
    return pd.DataFrame(
        [
            {
                "dataset": "Numerical DoE",
                "role": "Train surrogate y_FEM_hat",
                "size": n_doe,
                "notes": "simulated target; also defines the standardization and the support",
            },
            {
                "dataset": "Production (all)",
                "role": "Unfiltered-train comparison (Table 5)",
                "size": n_production,
                "notes": "measured target",
            },
            {
                "dataset": "Production in-support subset",
                "role": "Train/validate residual model r_hat",
                "size": n_in_support,
                "notes": f"kNN support gate: k={k}, threshold = {percentile:g}th percentile of DoE "
                "leave-one-out distances",
            },
            {
                "dataset": "Production out-of-support",
                "role": "Evaluation only (Table 5)",
                "size": n_production - n_in_support,
                "notes": "never used to train the filtered residual model",
            },
            {
                "dataset": "Matched cases (reserved)",
                "role": "External check",
                "size": n_matched,
                "notes": "true residuals; never used for training or tuning",
            },
        ]
    )


def sensitivity_table(predictions: pd.DataFrame, sample_note: str = "") -> pd.DataFrame:
    """Table 5: production RMSE in and out of the support for four prediction strategies.

    Reads the columns of :func:`production_predictions`. No strategy is scored
    on rows it was trained on: the filtered model is scored with its
    out-of-fold predictions inside the support and its final model (never
    trained there) outside; the unfiltered model with out-of-fold predictions
    everywhere.
    """
    measured = predictions["measured"].to_numpy(float)
    inside = in_support(predictions)
    surrogate = predictions[SURROGATE.column].to_numpy(float)
    filtered = predictions[HYBRID.oof_column].to_numpy(float)
    strategies = {
        "rmse_surrogate_only": surrogate,
        "rmse_filtered_train_no_gate": filtered,
        "rmse_unfiltered_train_no_gate": predictions[HYBRID_UNFILTERED.oof_column].to_numpy(float),
        "rmse_filtered_train_gated": compose.gated(surrogate, filtered, inside),
    }
    rows = []
    for region, mask in (("in_support", inside), ("out_of_support", ~inside), ("all", np.ones_like(inside))):
        row = {"region": region, "samples": int(mask.sum())}
        row.update({name: rmse(measured[mask], pred[mask]) for name, pred in strategies.items()})
        rows.append(row)
    table = pd.DataFrame(rows)
    table["evaluated_on"] = (
        "measured production values; residual models scored out-of-fold on their own "
        "training rows (a split other than the tuning's), the final filtered model on "
        "out-of-support rows; both residual models use the hyperparameters tuned on "
        "in-support rows" + sample_note
    )
    return table


def matched_summary(measured, simulated, surrogate, residual_pred, in_support) -> tuple[pd.DataFrame, pd.DataFrame]:
    """External check on matched cases: predicted vs true residual, and each predictor's error."""
    measured, simulated = np.asarray(measured, float), np.asarray(simulated, float)
    surrogate, residual_pred = np.asarray(surrogate, float), np.asarray(residual_pred, float)
    true_residual = measured - simulated
    predicted = compose.hybrids(surrogate, residual_pred, in_support)
    hybrid, hybrid_gated = predicted[HYBRID.name], predicted[HYBRID_GATED.name]
    errors = {SURROGATE: surrogate, HYBRID: hybrid, HYBRID_GATED: hybrid_gated}
    comparisons = {
        "residual (predicted vs true)": (true_residual, residual_pred),
        "simulation (measured vs FE)": (measured, simulated),
        "surrogate (measured vs y_FEM_hat)": (measured, surrogate),
        "hybrid (measured vs y_hyb)": (measured, hybrid),
        "hybrid gated (measured vs gated y_hyb)": (measured, hybrid_gated),
    }
    rows = []
    for name, (reference, prediction) in comparisons.items():
        error = reference - prediction
        rows.append(
            {
                "comparison": name,
                "n": len(reference),
                **scores(reference, prediction),
                "error_mean": float(np.mean(error)),
                "error_std": float(np.std(error, ddof=1)) if len(error) > 1 else 0.0,
            }
        )
    summary = pd.DataFrame(rows)
    summary["evaluated_on"] = "matched cases only (never used for training or tuning); error = reference - prediction"
    cases = pd.DataFrame(
        {
            "measured": measured,
            "simulated": simulated,
            SURROGATE.column: surrogate,
            HYBRID.column: hybrid,
            HYBRID_GATED.column: hybrid_gated,
            "true_residual": true_residual,
            "pred_residual": residual_pred,
            "error_simulation": measured - simulated,
            **{f"error_{model.name}": measured - value for model, value in errors.items()},
        }
    )
    return summary, cases


def production_predictions(
    residuals: pd.DataFrame,
    support: pd.DataFrame,
    filtered: np.ndarray,
    unfiltered: np.ndarray,
    filtered_oof: pd.DataFrame,
    unfiltered_oof: pd.DataFrame,
) -> pd.DataFrame:
    """One row per production row: support, surrogate, residual models and hybrids (without the unfiltered
    model's columns where ``unfiltered`` and ``unfiltered_oof`` are None).

    ``pred_hybrid`` uses the final filtered-train model (no gate); the ``*_oof``
    columns hold out-of-fold predictions for rows a model was trained on, the
    honest basis of every error the workflow reports on production data.
    """
    n = len(residuals)
    surrogate = residuals[SURROGATE.column].to_numpy(float)
    inside = in_support(support)
    filtered_cv = splice_out_of_fold(filtered, filtered_oof["row"], filtered_oof["pred_residual_oof"])
    unfiltered_cv = None
    if unfiltered_oof is not None:
        unfiltered_cv = splice_out_of_fold(
            np.full(n, np.nan), unfiltered_oof["row"], unfiltered_oof["pred_residual_oof"]
        )
    final = compose.hybrids(surrogate, filtered, inside, unfiltered)
    honest = compose.hybrids(surrogate, filtered_cv, inside, unfiltered_cv)
    models = [model for model in (HYBRID, HYBRID_GATED, HYBRID_UNFILTERED) if model.name in final]
    return table_of(
        {
            "row": np.arange(n),
            "in_support": inside,
            "knn_distance": support["knn_distance"].to_numpy(float),
            "measured": residuals["measured"].to_numpy(float),
            SURROGATE.column: surrogate,
            f"{SURROGATE.column}_std": residuals[f"{SURROGATE.column}_std"].to_numpy(float),
            "residual_approx": residuals["residual_approx"].to_numpy(float),
            "pred_residual": filtered,
            **{model.column: final[model.name] for model in models},
            **{model.oof_column: honest[model.name] for model in models if model is not HYBRID_GATED},
        }
    )


def matched_cases_table(matched, simulated: str, measured: str, surrogate, residual_pred, inside):
    """matched_check.csv and matched_cases.csv: each matched case's predictions and errors, numbered from 1."""
    summary, cases = matched_summary(matched[measured], matched[simulated], surrogate, residual_pred, inside)
    cases.insert(0, "in_support", np.asarray(inside, bool))
    cases.insert(0, "matched_row", np.arange(1, len(matched) + 1))
    return summary, cases


def residual_check(predictions: pd.DataFrame, cases: pd.DataFrame, summary: pd.DataFrame) -> dict:
    """Figure 2's data: the predicted residual against its target, in support (out-of-fold) and at the matched
    cases (true residuals), with the matched cases' scores."""
    inside = predictions[in_support(predictions)]
    scores = summary.iloc[0]
    return {
        "production_target": inside["residual_approx"],
        "production_pred": inside[HYBRID.oof_column] - inside[SURROGATE.column],
        "matched_target": cases["true_residual"],
        "matched_pred": cases["pred_residual"],
        "matched_scores": {"r2": scores["r2"], "rmse": scores["rmse"]},
    }


def error_groups(predictions: pd.DataFrame, cases: pd.DataFrame) -> dict[str, dict[str, pd.Series]]:
    """Figure 3's data: the surrogate's and the hybrid's errors in support (out-of-fold) and at the matched cases."""
    inside = predictions[in_support(predictions)]
    return {
        f"production in support (n={len(inside):,}), hybrid out-of-fold": {
            SURROGATE.name: inside["measured"] - inside[SURROGATE.column],
            HYBRID.name: inside["measured"] - inside[HYBRID.oof_column],
        },
        f"matched cases (n={len(cases)})": {
            SURROGATE.name: cases[f"error_{SURROGATE.name}"],
            HYBRID.name: cases[f"error_{HYBRID.name}"],
        },
    }
