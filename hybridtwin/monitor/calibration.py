"""The monitor's allowance, calibrated on the production log itself: the in-control record of the plant.

The models' error is not independent from part to part: at a campaign of settings, on a hot day or a coil, the
recommended model can be off by a settled amount for hundreds of parts, and the log shows how far. Run over the
log's honest residuals (out-of-fold in support, from models that never saw the part outside), in time order and
in units of each part's expected error, the chart must stay in control: the allowance ``k`` is the smallest (at
least :data:`chart.REFERENCE`) that keeps the log's statistic under half the limit. The workflow stores it in
``predictor.json`` (key ``monitor``); models without it take :data:`chart.REFERENCE`.
"""

from __future__ import annotations

import numpy as np

from hybridtwin.models.registry import RECOMMENDED_COLUMN
from hybridtwin.monitor import chart

MARGIN = 0.5  # the log's statistic must stay under this share of the limit
HIGHEST = 4.0  # no allowance above this many expected errors (the log's errors are then no in-control record)


def log_peak(z: np.ndarray, reference: float) -> float:
    """The highest the two-sided statistic reaches over ``z`` (NaN: not judged) with allowance ``reference``."""
    return float(chart.cusum(z, reference, np.inf).statistic.max(initial=0.0))


def allowance(z, limit: float = chart.LIMIT, floor: float = chart.REFERENCE) -> float:
    """The smallest allowance at least ``floor`` under which the log's standardized residuals ``z`` keep the
    statistic below ``MARGIN * limit`` (bisection: the peak falls as the allowance grows), at most HIGHEST."""
    z = np.asarray(z, float)
    if log_peak(z, floor) < MARGIN * limit:
        return floor
    low, high = floor, HIGHEST
    for _ in range(30):
        middle = (low + high) / 2
        low, high = (middle, high) if log_peak(z, middle) >= MARGIN * limit else (low, middle)
    return float(high)


def calibrate(measured, calibrated, level: float) -> dict:
    """The ``monitor`` key of predictor.json from the prediction_intervals rule's calibration (its intervals,
    honest predictions and regions) and the log's measured target, in the log's order."""
    from hybridtwin.answers.intervals import recommended_prediction

    picked = recommended_prediction(calibrated.intervals, calibrated.honest, calibrated.region, level)
    expected = chart.expected_error(calibrated.intervals, picked["recommended_model"], calibrated.region.interval)
    residual = np.asarray(measured, float) - picked[RECOMMENDED_COLUMN].to_numpy(float)
    usable = np.isfinite(expected) & (expected > 0) & np.isfinite(residual)
    z = np.where(usable, residual / np.where(usable, expected, 1.0), np.nan)
    return {"allowance": allowance(z), "limit": chart.LIMIT, "log_parts": int(usable.sum())}
