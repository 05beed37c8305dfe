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


def cross_fitted_stack(measured, members: dict[str, np.ndarray], rows: np.ndarray) -> np.ndarray:
    """The stack on ``rows``, each half predicted with the weights fitted on the other half (no row scores itself)."""
    out = np.full(len(measured), np.nan)
    first, second = rows[: len(rows) // 2], rows[len(rows) // 2 :]
    out[second] = blend(stack_weights(measured, members, first), members, second)
    out[first] = blend(stack_weights(measured, members, second), members, first)
    return out


def stack_members(predictions: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {m: p for m, p in predictions.items() if m in registry.RECOMMENDABLE and m != registry.STACK.name}
