"""The stack: a non-negative least-squares blend of the recommendable models' honest predictions, per region."""

from __future__ import annotations

import numpy as np

from hybridtwin.models import registry


def stack_weights(measured, predictions: dict[str, np.ndarray], rows: np.ndarray) -> dict[str, float]:
    """Non-negative least-squares weights of the models' predictions on ``rows``."""
    from scipy.optimize import nnls

    names = sorted(predictions)
    weights, _ = nnls(np.column_stack([predictions[m][rows] for m in names]), np.asarray(measured, float)[rows])
    return {name: float(w) for name, w in zip(names, weights)}


def members(weights: dict[str, float]) -> list[str]:
    """The models a blend takes: those of non-zero weight (a member weighted 0 need not even be computed)."""
    return [model for model, weight in weights.items() if weight != 0]


def blend(weights: dict[str, float], predictions: dict[str, np.ndarray], rows) -> np.ndarray:
    return sum((weights[m] * predictions[m][rows] for m in members(weights)), np.zeros(len(rows)))


def choosing_blocks(calibration) -> np.ndarray:
    """Per row, its choosing block: the index of its stretch of consecutive calibration rows (-1 for other rows).

    A block is a period of the log: its campaigns, coils and hours; a choice judged on blocks it did not see is
    judged as the next campaign will judge it.
    """
    rows = np.asarray(calibration, bool)
    starts = rows & ~np.r_[False, rows[:-1]]
    return np.where(rows, np.cumsum(starts) - 1, -1)


def folds_of(blocks: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The fold of each of ``rows`` (in time order): its choosing block, or with the rows in a single block,
    the two halves of them."""
    labels = np.asarray(blocks)[rows]
    if len(np.unique(labels)) >= 2:
        return labels
    return (np.arange(len(rows)) >= len(rows) // 2).astype(int)


def cross_fitted_stack(measured, members: dict[str, np.ndarray], rows: np.ndarray, folds: np.ndarray) -> np.ndarray:
    """The stack on ``rows``, each fold's rows (a choosing block: :func:`folds_of`) blended with the weights fitted
    on the other folds: no weight is judged on a block it was fitted on."""
    out = np.full(len(measured), np.nan)
    for fold in np.unique(folds):
        held, rest = rows[folds == fold], rows[folds != fold]
        out[held] = blend(stack_weights(measured, members, rest), members, held)
    return out


def stack_members(predictions: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {m: p for m, p in predictions.items() if m in registry.RECOMMENDABLE and m != registry.STACK.name}
