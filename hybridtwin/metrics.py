"""The paper's error indicators (Eqs. 1-4), defined as error = reference - prediction."""
from __future__ import annotations

import numpy as np


def rmse(y_true, y_pred) -> float:
    err = np.asarray(y_true, float) - np.asarray(y_pred, float)
    return float(np.sqrt(np.mean(err**2))) if err.size else float("nan")


def mae(y_true, y_pred) -> float:
    err = np.asarray(y_true, float) - np.asarray(y_pred, float)
    return float(np.mean(np.abs(err))) if err.size else float("nan")


def bias(y_true, y_pred) -> float:
    """Mean of (reference - prediction): positive when the model under-predicts."""
    err = np.asarray(y_true, float) - np.asarray(y_pred, float)
    return float(np.mean(err)) if err.size else float("nan")


def r2(y_true, y_pred) -> float:
    y_true = np.asarray(y_true, float)
    total = np.sum((y_true - y_true.mean()) ** 2) if y_true.size else 0.0
    if total == 0.0:
        return float("nan")
    return float(1.0 - np.sum((y_true - np.asarray(y_pred, float)) ** 2) / total)


METRICS = {"rmse": rmse, "mae": mae, "bias": bias, "r2": r2}


def scores(y_true, y_pred, names=("r2", "rmse", "mae", "bias")) -> dict[str, float]:
    return {name: METRICS[name](y_true, y_pred) for name in names}
