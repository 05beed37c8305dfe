"""The monitor's constants, calibrated on the production log itself: the in-control record of the plant.

The models' error is not independent from part to part (:mod:`.regimes`): at a campaign of settings or on a coil
the recommended model is off by a settled amount for hundreds of parts, and the log shows how far. A CUSUM tuned
for independent errors alarms on such a record within a few hundred parts (on the benchmark's plants the log's
honest residuals have a lag-1 autocorrelation of 0.65, and the spread of the regimes' levels is seven times what
independent errors would give). So the log's honest residuals (out-of-fold in support, from models that never saw
the part outside), in time order, set the two charts of :func:`chart.regime_chart`:

* the scatter inside a regime (per interval region, in the target's unit) and the spread of the regimes' levels
  (in expected errors), which standardize the two charts;
* each chart's limit ``h``: batches of BATCH_PARTS parts are drawn from the log (a block bootstrap: runs of whole
  regimes at least BLOCK_PARTS long, with replacement, BOOTSTRAP batches); ``h`` is MARGIN (LEVEL_MARGIN over
  the levels) times the highest either chart reaches on any of them, and at least the floor at which independent
  normal errors alarm in one batch in a thousand (times MARGIN).

The workflow stores them in ``predictor.json`` (key ``monitor``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.models.registry import RECOMMENDED_COLUMN
from hybridtwin.monitor import chart, regimes

BOOTSTRAP = 400  # batches drawn from the log's regimes
BATCH_PARTS = 10_000  # parts in each
MARGIN = 1.25  # the limit over the highest statistic the drawn batches reach (within a regime)
# over the regimes' levels: the levels follow the plant's slow rhythms (shifts, days) that a log of a few shifts shows
# only a few of; on the tuning plants (seed 33) fresh in-control batches reached 1.4 times the log's highest
LEVEL_MARGIN = 2.0
# the floors: MARGIN times the statistic that independent normal errors reach in one batch of 10,000 parts in a
# thousand (simulated through the same charts, regimes of 50 to 500 parts: 14.1 within a regime, 5.6 over 200
# regimes' levels); the log's bootstrap cannot go beyond the log's own extremes
FLOOR_WITHIN = 17.5
FLOOR_LEVEL = 7.0
BLOCK_PARTS = 1000  # the bootstrap draws runs of consecutive regimes at least this long
SPREAD_PARTS = 3000  # stretches of the log between which a cause's slope is compared (about a third of a batch)
SPREAD_REGIMES = 10  # and the regimes each holds at least
STRETCH_PARTS = 1_000_000  # the within-regime quantities are computed this many parts at a time (whole regimes)
LEAST_SCALE = 200  # judged within-regime parts a region needs for a scatter of its own


def peak(steps: np.ndarray, reference: float) -> float:
    """The highest the two-sided statistic reaches over ``steps`` (NaN: not judged) with allowance ``reference``."""
    return float(chart.cusum(steps, reference, np.inf).statistic.max(initial=0.0))


def _rms(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values**2))) if len(values) else float("nan")


def scales(raw, inside, region, levels) -> tuple[dict, float, float, float]:
    """The within-regime scatter per region and pooled (target's unit), z's scatter inside a regime, and the
    spread of the regimes' levels beyond it; ``raw``: :func:`chart.within_residuals`, ``inside``: z against the
    mean of its regime's judged parts before it (``regimes.within(z, group, 1)``: sqrt(1 + 1/n) taken out),
    ``levels``: :func:`chart.regime_levels`."""
    region = np.asarray(region, object)
    pooled = _rms(raw)
    per_region = {
        str(name): _rms(raw[region == name])
        for name in sorted(set(region[np.isfinite(raw)].tolist()))
        if np.isfinite(raw[region == name]).sum() >= LEAST_SCALE
    }
    level_within = _rms(inside)
    means, counts, _ = levels
    between = np.sqrt(max(np.mean(means**2) - np.mean(level_within**2 / counts), 0.05**2)) if len(means) else 1.0
    return per_region, pooled, level_within, float(between)


def _blocks(starts: np.ndarray, least: int, regimes: int = 1) -> list[tuple[int, int]]:
    """(first, end) of consecutive runs of whole regimes (``starts``: True where a regime begins), each of at
    least ``least`` parts and ``regimes`` regimes; a short tail joins the block before."""
    bounds, begun = [0], np.flatnonzero(starts)
    for cut in begun[1:]:
        if cut - bounds[-1] >= least and np.sum((begun >= bounds[-1]) & (begun < cut)) >= regimes:
            bounds.append(int(cut))
    tail = len(starts) - bounds[-1]
    if len(bounds) > 1 and (tail < least / 2 or np.sum(begun >= bounds[-1]) < regimes / 2):
        bounds.pop()
    bounds.append(len(starts))
    return list(zip(bounds[:-1], bounds[1:]))


def by_stretches(function, stretches: list[tuple[int, int]], *arrays) -> np.ndarray:
    """``function`` of ``arrays`` (one value per part) on each stretch of whole regimes, joined: a part's value
    inside its regime depends on its regime's parts alone, and the temporaries of a ten-million-part log are then
    those of a stretch (:data:`STRETCH_PARTS`)."""
    return np.concatenate([function(*(values[a:b] for values in arrays)) for a, b in stretches])


def stretch_levels(z, group, stretches: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`chart.regime_levels` stretch by stretch (:func:`by_stretches`), in the same order: a regime's
    label is numbered by its first part, so a later stretch's regimes come after an earlier one's."""
    found = [chart.regime_levels(z[a:b], group[a:b]) for a, b in stretches]
    return tuple(
        np.concatenate(column)
        for column in zip(*[(means, counts, at + a) for (means, counts, at), (a, _) in zip(found, stretches)])
    )


def limits(within: np.ndarray, level: np.ndarray, starts: np.ndarray, seed: int) -> tuple[float, float]:
    """Each chart's limit from batches drawn from the log (``within``, ``level``: the charts' standardized steps
    over the log) in blocks of whole regimes of at least BLOCK_PARTS parts, so that regimes that follow each other
    (a campaign over several coils) stay together."""
    bounds = _blocks(starts, BLOCK_PARTS)
    pieces = [(within[a:b], level[a:b]) for a, b in bounds]
    lengths = np.array([b - a for a, b in bounds])
    rng = np.random.default_rng(seed)
    highest = [0.0, 0.0]
    draws = int(np.ceil(BATCH_PARTS / max(lengths.min(), 1.0))) + 1
    for _ in range(BOOTSTRAP):
        chosen = rng.integers(0, len(pieces), draws)
        chosen = chosen[: int(np.searchsorted(np.cumsum(lengths[chosen]), BATCH_PARTS)) + 1]
        for side, reference in ((0, chart.WITHIN_REFERENCE), (1, chart.LEVEL_REFERENCE)):
            series = np.concatenate([pieces[i][side] for i in chosen])
            highest[side] = max(highest[side], peak(series, reference))
    return max(FLOOR_WITHIN, MARGIN * highest[0]), max(FLOOR_LEVEL, LEVEL_MARGIN * highest[1])


def constants(
    log, inputs, residual, z, region, models, seed: int = 0
) -> tuple[regimes.Regimes, chart.Constants, np.ndarray, np.ndarray]:
    """The regimes, the charts' constants, each part's regime label and where each regime begins, from the log
    (in time order), its honest residuals and z, each part's interval region and recommended model."""
    found = regimes.Regimes.learn(log, inputs)
    starts = found.starts(log)
    group = regimes.labels(starts, models)
    residual = np.where(np.isnan(z), np.nan, residual)
    stretches = _blocks(starts, STRETCH_PARTS)
    # each used twice: for the scales, then for the steps whose highest values set the limits
    raw, levels = by_stretches(chart.within_residuals, stretches, residual, group), stretch_levels(z, group, stretches)
    inside = by_stretches(lambda values, labels: regimes.within(values, labels, 1), stretches, z, group)
    per_region, pooled, level_within, between = scales(raw, inside, region, levels)
    del inside
    provisional = chart.Constants(per_region, pooled, level_within, between, np.inf, np.inf)
    within = chart.within_steps(residual, region, group, provisional, raw)
    level = chart.level_steps(z, group, provisional, levels)
    h_within, h_level = limits(within, level, starts, seed)
    fitted = chart.Constants(per_region, pooled, level_within, between, h_within, h_level, len(levels[0]))
    return found, fitted, group, starts


def slopes(log, causes, residual, z, group, starts) -> dict:
    """Per numeric cause of the models' extension (no clock): the log's slope of the honest residual on it, its
    standard error clustered by regime, and how far the slope moves between stretches of the log beyond that
    error (:func:`slope_spread`): how the in-control residual follows the cause (:func:`changes.moved_cause`
    compares a batch's with it)."""
    from hybridtwin.monitor.changes import clocks, slope

    timing = clocks(log)
    judged = np.isfinite(z)
    judged_residual, judged_group = residual[judged], group[judged]
    out = {}
    for column in sorted(causes):
        if column in log and column not in timing and pd.api.types.is_numeric_dtype(log[column]):
            x = log[column].to_numpy(float)
            fitted, error = slope(x[judged], judged_residual, judged_group)
            if np.isfinite(error):
                out[str(column)] = [fitted, error, slope_spread(x, residual, judged, group, starts)]
    return out


def slope_spread(x, residual, judged, group, starts) -> float:
    """The spread of the residual's slope on ``x`` between stretches of the log beyond their standard errors: the
    DerSimonian-Laird between-study deviation. In control the slope moves from stretch to stretch with the models'
    settled errors at the settings each one ran, which the standard error clustered by regime does not count.
    A stretch is a run of whole regimes (``starts``: True where one begins) of at least SPREAD_PARTS parts and
    SPREAD_REGIMES regimes (a clustered error needs clusters; ``group``: the regime and model labels it clusters
    by); 0 with fewer than three stretches."""
    from hybridtwin.monitor.changes import slope

    group = np.asarray(group)
    bounds = _blocks(starts, SPREAD_PARTS, SPREAD_REGIMES)
    fits = [slope(x[a:b][judged[a:b]], residual[a:b][judged[a:b]], group[a:b][judged[a:b]]) for a, b in bounds]
    fits = np.array([(value, error) for value, error in fits if np.isfinite(error) and error > 0]).reshape(-1, 2)
    if len(fits) < 3:
        return 0.0
    weights = 1.0 / fits[:, 1] ** 2
    mean = np.sum(weights * fits[:, 0]) / weights.sum()
    q = np.sum(weights * (fits[:, 0] - mean) ** 2)
    between = (q - (len(fits) - 1)) / (weights.sum() - np.sum(weights**2) / weights.sum())
    return float(np.sqrt(max(between, 0.0)))


def counters(log) -> list[str]:
    """The log's number columns that never go down over it (a stroke counter): a batch's must not either."""
    from hybridtwin.monitor.changes import clocks

    return sorted(str(c) for c in clocks(log) if pd.api.types.is_numeric_dtype(log[c]))


def log_columns(head: pd.DataFrame, target: str, keep=()) -> list[str]:
    """The production log's columns :func:`calibrate` reads, judged from its first rows (``head``) as the regimes
    and clocks judge them: every one but the measured target (the predictions carry it) and the timestamps (no
    regime starts at a clock's tick, and a date has no slope); ``keep``: columns read whatever they hold (the
    inputs and the extension's causes)."""
    from hybridtwin.diagnosis.causes import looks_like_timestamps

    kept = set(keep)
    return [c for c in head.columns if c in kept or (c != target and not looks_like_timestamps(head[c]))]


@dataclass
class Record:
    """The log's in-control record, part by part in time order: the honest residual of the recommended model, z
    (the residual in the errors its interval region expects; NaN where not judged), each part's interval region
    and its recommended model."""

    residual: np.ndarray
    z: np.ndarray
    region: np.ndarray
    models: np.ndarray


def record(measured, calibrated, level: float) -> Record:
    """The :class:`Record` of the log's measured target under the prediction_intervals rule's calibration (its
    intervals, honest predictions and regions): all the monitor's calibration reads of it, so that every model's
    predictions can go before it runs (0.7 GB on ten million parts)."""
    picked = calibrated.recommended(level)
    expected = chart.expected_error(calibrated.intervals, picked["recommended_model"], calibrated.region.interval)
    residual = np.asarray(measured, float) - picked[RECOMMENDED_COLUMN].to_numpy(float)
    usable = np.isfinite(expected) & (expected > 0) & np.isfinite(residual)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.divide(residual, expected, out=expected)  # in place: ten million parts
    z[~usable] = np.nan
    return Record(residual, z, calibrated.region.interval, picked["recommended_model"].to_numpy(object))


def calibrate(found: Record, log, inputs, seed: int = 0, causes=()) -> dict:
    """The ``monitor`` key of predictor.json from the log's :class:`Record`, the production log itself (every
    column but the target and timestamps, in the same time order) and the columns of the extension's causes."""
    residual, z = found.residual, found.z
    regimes_found, fitted, group, starts = constants(log, inputs, residual, z, found.region, found.models, seed)
    return {
        "regimes": regimes_found.to_dict(),
        **fitted.to_dict(),
        "slopes": slopes(log, causes, residual, z, group, starts),
        "counters": counters(log),
        "limit": chart.LIMIT,
        "log_parts": int(np.count_nonzero(~np.isnan(z))),  # judged: a z of its own, however large
        "log_rows": len(log),
    }
