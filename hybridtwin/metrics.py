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


def block_means(values, n_blocks: int) -> np.ndarray:
    """Means over at most ``n_blocks`` blocks of consecutive rows (at least 2 blocks, about 20 rows or more each;
    ``np.array_split``'s blocks, never an empty one), of at least one value."""
    values = np.asarray(values, float)
    n_blocks = min(n_blocks, max(2, len(values) // 20), len(values))
    size, longer = divmod(len(values), n_blocks)
    lengths = np.full(n_blocks, size) + (np.arange(n_blocks) < longer)  # np.array_split's blocks
    return np.add.reduceat(values, np.r_[0, np.cumsum(lengths)[:-1]]) / lengths


def batch_means(values, n_blocks: int, min_blocks: int) -> np.ndarray:
    """Block means, with blocks doubled in length while neighbouring means stay correlated.

    The batch-means method of simulation output analysis (Law and Carson, 1979): parts of
    one coil or one setting campaign share their error, so block means shorter than a
    coil are not independent. Blocks grow until the lag-1 correlation of their means is
    below its 2-standard-error bound (2/sqrt(m)), but never below ``min_blocks`` blocks.
    """
    means = block_means(values, n_blocks)
    while len(means) // 2 >= min_blocks and lag1_correlation(means) >= 2.0 / np.sqrt(len(means)):
        means = block_means(values, len(means) // 2)
    return means


def lag1_correlation(values) -> float:
    values = np.asarray(values, float) - np.mean(values)
    denominator = float(np.sum(values**2))
    return float(np.sum(values[:-1] * values[1:]) / denominator) if denominator > 0 else 0.0


def block_gains(y, prediction, n_blocks: int, reference=None, min_blocks: int | None = None) -> np.ndarray:
    """Means over blocks of consecutive rows of the squared-error gain of ``prediction`` over ``reference``
    (default: predicting zero). With ``min_blocks``, blocks are lengthened until their means are
    uncorrelated (:func:`batch_means`)."""
    y, prediction = np.asarray(y, float), np.asarray(prediction, float)
    reference = np.zeros_like(y) if reference is None else np.asarray(reference, float)
    gains = (y - reference) ** 2 - (y - prediction) ** 2
    return block_means(gains, n_blocks) if min_blocks is None else batch_means(gains, n_blocks, min_blocks)


def block_p_value(y, prediction, n_blocks: int, reference=None, min_blocks: int | None = None) -> float:
    """One-sided p-value that ``prediction`` beats ``reference`` (default: predicting zero), from means over
    blocks of consecutive rows (:func:`block_gains`).

    Gains of neighbouring parts are correlated (drift, campaigns); block means are nearly
    independent, so a t-test over them does not overstate the evidence as one over rows would.
    """
    return _t_p_value(block_gains(y, prediction, n_blocks, reference, min_blocks))


def _t_p_value(means: np.ndarray) -> float:
    """One-sided p-value of the t-test that the mean of ``means`` is above zero."""
    se = means.std(ddof=1) / np.sqrt(len(means))
    if se == 0:
        return 0.0 if means.mean() > 0 else 1.0
    from scipy import stats  # here: scipy.stats costs a small rule half its run time to import

    return float(stats.t.sf(means.mean() / se, df=len(means) - 1))


def _signed_rank_p_value(means: np.ndarray) -> float:
    """One-sided p-value of the Wilcoxon signed-rank test that ``means`` lie above zero."""
    if not np.any(means):
        return 1.0
    from scipy import stats

    return float(stats.wilcoxon(means, alternative="greater").pvalue)


def evidence_p_value(y, prediction, n_blocks: int, reference=None) -> float:
    """One-sided p-value that ``prediction`` beats ``reference`` (default: predicting zero), by the t-test or the
    signed-rank test over block means of the gain (:func:`block_gains`), whichever is smaller, doubled
    (Bonferroni over the two).

    The t-test is weak where the gain is positive in nearly every block but of very unequal size: a few coils
    or campaigns far from the rest carry most of it, and its spread grows with the effect (ten coils whose
    offsets explained 96% held out: p = 0.003 by the t-test, 1e-13 by the signed-rank test). The signed-rank
    test is weak where the gain comes in a few blocks only (a step that a few campaigns reach).
    """
    means = block_gains(y, prediction, n_blocks, reference)
    return min(1.0, 2.0 * min(_t_p_value(means), _signed_rank_p_value(means)))


def signed_rank_p_value(y, prediction, reference, n_blocks: int, min_blocks: int) -> float:
    """One-sided p-value that ``prediction`` beats ``reference`` in the typical stretch of consecutive rows:
    the Wilcoxon signed-rank test over the block means of the gain (:func:`block_gains`).

    Unlike the t-test of :func:`block_p_value`, a gain that is positive almost everywhere but of very
    unequal size (a drift, an effect that only some coils reach) does not count against it.
    """
    return _signed_rank_p_value(block_gains(y, prediction, n_blocks, reference, min_blocks))
