"""The monitoring statistic: CUSUMs of the residual, against what the models and the log's in-control record expect.

Each measured part's residual (measured - recommended prediction) is divided by the in-control error of its
region: the root mean square of the recommended model's calibration errors there (in support, and out of support
by distance to the DoE, :mod:`hybridtwin.answers.regions`). A batch of far settings thus weighs each part by
the error the models already expect there, and is no alarm by itself. A part whose trust verdict is
*extrapolation* (a setting unlike every logged part: no interval) has no in-control error to compare with; it is
not judged and leaves the statistic as it was.

:func:`cusum` is the tabular CUSUM (Page 1954) on both sides of a standardized series ``z`` (clipped at
:data:`CLIP`, so that one wild part cannot raise an alarm alone): ``S+ = max(0, S+ + z - k)``,
``S- = max(0, S- - z - k)``; an alarm at the first part where either exceeds the limit ``h``, the change
estimated to start right after the alarming side's last zero. Run on z itself, as models written before the
regime charts are, it adds up the models' settled error at a campaign or on a coil, which is no change of the
plant (on independent errors, ``k = 1`` and ``h = 20`` would alarm once in 10^15 parts; on a plant's autocorrelated
errors, within a few thousand).

:func:`regime_chart` charts the residual against the in-control process instead (:mod:`.regimes`): inside each
regime (a run of the same coil, settings and model), each part against the level of the parts before it; across
regimes, each regime's level against the spread of levels the log and the batch showed before it. Their constants
and limits are set on the production log (:mod:`.calibration`).
"""

from __future__ import annotations

import itertools
from dataclasses import MISSING, dataclass

import numpy as np
import pandas as pd

REFERENCE = 1.0  # k, in expected errors
LIMIT = 20.0  # h, in expected errors
CLIP = 4.0  # largest |z| one part contributes


def expected_error(intervals, models, regions) -> np.ndarray:
    """Per row, the in-control error of its recommended model in its interval region: the root mean square of
    the calibration errors (NaN where the region has none)."""
    model_codes, model_names = pd.factorize(np.asarray(models, object))
    region_codes, region_names = pd.factorize(np.asarray(regions, object))
    # a last row and column of NaN, where a row without a model or region (code -1) finds none
    per_pair = np.full((len(model_names) + 1, len(region_names) + 1), np.nan)
    for (i, model), (j, region) in itertools.product(enumerate(model_names), enumerate(region_names)):
        errors = np.asarray(intervals.calibration.get(model, {}).get(region, []), float)
        if len(errors):
            per_pair[i, j] = float(np.sqrt(np.mean(errors**2)))
    return per_pair[model_codes, region_codes]


def one_side(steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The one-sided CUSUM ``S_t = max(0, S_{t-1} + step_t)`` (``S_0 = 0``) and, per part, the index of the part
    after its last zero (where the current excursion began).

    Lindley's recursion in closed form: with ``C`` the running sum, ``S_t = C_t - min(0, min_{s<=t} C_s)``.
    """
    total = np.cumsum(steps)
    floor = np.minimum.accumulate(np.minimum(total, 0.0))
    statistic = total - floor
    # the excursion begins after the last part at which the running sum reached its floor (before part 0: -1)
    at_floor = np.where(total <= floor, np.arange(len(steps)), -1)
    return statistic, np.maximum.accumulate(at_floor) + 1


@dataclass(frozen=True)
class Chart:
    """The chart over a batch: per part the standardized residual, both sides' statistic, and the verdict."""

    z: np.ndarray  # NaN for a part not judged
    up: np.ndarray
    down: np.ndarray
    limit: float
    reference: float
    alarm_at: int | None  # index of the first part in alarm
    start_at: int | None  # index of the part the change is estimated to start at
    direction: int  # +1: the plant measures more than the models expect; -1: less; 0: no alarm
    alarmed_by: str = ""  # which chart alarmed (WITHIN or LEVEL; empty: the plain chart, or no alarm)
    group: np.ndarray | None = None  # each part's regime and model (the regime charts), or None (the plain chart)
    scale: float = float("nan")  # the within-regime scatter the log showed (the target's unit; the regime charts)

    @property
    def statistic(self) -> np.ndarray:
        return np.maximum(self.up, self.down)

    @property
    def alarm(self) -> np.ndarray:
        flags = np.zeros(len(self.z), bool)
        if self.alarm_at is not None:
            flags[self.alarm_at :] = True
        return flags


def cusum(z, reference: float = REFERENCE, limit: float = LIMIT, clip: float = CLIP) -> Chart:
    """The two-sided CUSUM of ``z`` (NaN: a part not judged, which changes nothing)."""
    z = np.asarray(z, float)
    judged = np.clip(np.nan_to_num(z, nan=0.0), -clip, clip)
    allowance = np.where(np.isnan(z), 0.0, reference)
    up, up_start = one_side(judged - allowance)
    down, down_start = one_side(-judged - allowance)
    over = np.flatnonzero(np.maximum(up, down) > limit)
    if not len(over):
        return Chart(z, up, down, limit, reference, None, None, 0)
    at = int(over[0])
    direction = 1 if up[at] > limit else -1
    start = int((up_start if direction > 0 else down_start)[at])
    # a part not judged cannot start a change: the first judged part of the excursion
    judged_from = np.flatnonzero(~np.isnan(z[start : at + 1]))
    return Chart(
        z, up, down, limit, reference, at, start + int(judged_from[0]) if len(judged_from) else start, direction
    )


# ---------------------------------------------------------------- the chart of the in-control process (regimes)

WITHIN, LEVEL = "within a regime", "regime levels"
WITHIN_REFERENCE = 0.5  # k of the within-regime chart, in SDs of the within-regime scatter
LEVEL_REFERENCE = 1.0  # k of the regime-level chart, in SDs of a regime's level (neighbouring regimes are alike)
LEAST_WITHIN = 5  # judged parts of a regime that set its level before the within-regime chart judges a part
WITHIN_WINDOW = 200  # the within-regime level: the mean of at most this many judged parts before (a slow trend)
LEVEL_PARTS = 50  # a regime's level: the mean z of its first this-many judged parts
LEAST_LEVEL = 5  # a regime with fewer judged parts has no level


@dataclass(frozen=True)
class Constants:
    """The regime charts' constants, calibrated on the production log (:mod:`.calibration`)."""

    within_scale: dict  # interval region -> SD of the self-starting within-regime residual (target's unit)
    pooled_scale: float  # the same over every region (a region the log did not show)
    level_within: float  # SD of z inside a regime
    level_between: float  # SD of the regimes' levels in z beyond what the scatter inside them gives
    within_limit: float
    level_limit: float
    # the log's regimes with a level: the weight of ``level_between`` beside a batch's own regimes (0: the log's
    # spread alone, as models stored before it were charted)
    level_regimes: int = 0

    def to_dict(self) -> dict:
        return dict(self.__dict__)

    @classmethod
    def from_dict(cls, data: dict) -> "Constants":
        fields = cls.__dataclass_fields__
        return cls(**{name: data[name] for name in fields if name in data or fields[name].default is MISSING})


def within_residuals(residual, group) -> np.ndarray:
    """Each part's self-starting within-regime residual in the target's unit (:func:`regimes.within`)."""
    from hybridtwin.monitor.regimes import within

    return within(residual, group, LEAST_WITHIN, WITHIN_WINDOW)


def regime_levels(z, group) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The regimes' levels in z, how many parts each, and the part at which each is known (:func:`regimes.levels`)."""
    from hybridtwin.monitor.regimes import levels

    return levels(z, group, LEVEL_PARTS, LEAST_LEVEL)


def within_steps(residual, region, group, constants: Constants, raw=None) -> np.ndarray:
    """Each part's self-starting within-regime residual in SDs of the log's within-regime scatter (NaN: not
    judged, or among the first parts of its regime); ``raw``: :func:`within_residuals`, if computed already."""
    region = np.asarray(region, object)
    scale = np.full(len(region), constants.pooled_scale)
    for name, value in constants.within_scale.items():
        scale[region == name] = value
    return (within_residuals(residual, group) if raw is None else raw) / scale


def level_steps(z, group, constants: Constants, found=None) -> np.ndarray:
    """Per part, NaN except at the part where a regime's level becomes known: there, the level in SDs of the
    regime levels seen before it (for that many parts): :func:`between_levels`; ``found``: :func:`regime_levels`,
    if computed already."""
    means, counts, at = regime_levels(z, group) if found is None else found
    between = between_levels(means, counts, at, constants)
    out = np.full(len(np.asarray(z)), np.nan)
    out[at] = means / np.sqrt(between**2 + constants.level_within**2 / counts)
    return out


def between_levels(means, counts, at, constants: Constants) -> np.ndarray:
    """Per regime, the spread of the regimes' levels beyond their scatter: the log's (``level_between``, over
    its ``level_regimes`` regimes) pooled with the spread about their mean of the batch's regimes whose level was
    known before it, and never below the log's.

    A later period runs settings and coils the log did not, where the models' settled error differs more from regime
    to regime than over the log's regimes: on four of the structures generator's seed-40 plants fresh in-control
    regimes spread 2 to 5 times as far as the log's, in the support too, and a chart held to the log's spread
    alarmed on 6 of 42 in-control batches (benchmarks/monitor_bank.py, seed 40). Each regime counts once, the log's
    and the batch's alike (the log's weight is its regime count; the batch's, its regimes known before less one; the
    levels come from :func:`regime_levels`, finite). The batch's spread is taken about its own mean, so that a shift
    its regimes share (a change before the batch began) does not widen it; the chart still sums the levels
    themselves."""
    means, counts, at = (np.asarray(values, float) for values in (means, counts, at))
    log_variance = constants.level_between**2
    if not constants.level_regimes or not len(means):
        return np.full(len(means), constants.level_between)
    order = np.argsort(at, kind="stable")
    known = np.arange(len(means))  # the batch's regimes known before each, in the order known
    sums, squares, scatter = (
        np.r_[0.0, np.cumsum(values[order])[:-1]] for values in (means, means**2, constants.level_within**2 / counts)
    )
    # the sum of squares about the mean of those known before, less what the scatter inside them gives (0 for
    # fewer than two)
    about_mean = squares - sums**2 / np.maximum(known, 1) - scatter * (known - 1) / np.maximum(known, 1)
    degrees = np.maximum(known - 1, 0)
    pooled = (constants.level_regimes * log_variance + about_mean) / (constants.level_regimes + degrees)
    between = np.empty(len(means))
    between[order] = np.sqrt(np.maximum(pooled, log_variance))
    return between


def regime_chart(residual, z, region, group, constants: Constants) -> Chart:
    """The two charts of the in-control process, each a two-sided CUSUM scaled so that its limit is LIMIT:

    * within a regime, each judged part's residual against the level of the judged parts before it in its regime
      (a step in the middle of a campaign or a coil: found within a few dozen parts);
    * across regimes, each regime's level against the spread of levels the log and the batch showed before it (a
      change that begins with a new coil, a new setting, or a drift that every new regime carries on).

    ``group``: each part's regime and recommended model (:func:`regimes.labels`). The alarm is the first part at
    which either passes its limit."""
    group = np.asarray(group)
    residual = np.where(np.isnan(np.asarray(z, float)), np.nan, np.asarray(residual, float))
    inner = cusum(within_steps(residual, region, group, constants), WITHIN_REFERENCE, constants.within_limit)
    levels = level_steps(z, group, constants)
    outer = cusum(levels, LEVEL_REFERENCE, constants.level_limit)
    a, b = LIMIT / constants.within_limit, LIMIT / constants.level_limit
    up, down = np.maximum(inner.up * a, outer.up * b), np.maximum(inner.down * a, outer.down * b)
    z = np.asarray(z, float)
    candidates = [(c.alarm_at, name, c) for name, c in ((WITHIN, inner), (LEVEL, outer)) if c.alarm_at is not None]
    if not candidates:
        return Chart(z, up, down, LIMIT, WITHIN_REFERENCE, None, None, 0, "", group, constants.pooled_scale)
    at, name, alarmed = min(candidates, key=lambda item: item[0])
    start = alarmed.start_at
    if name == LEVEL:  # a regime's level is known at its last counted part: the change began with the regime
        start = likeliest_start(levels, start, at, alarmed.direction)
        start = int(np.flatnonzero((group == group[start]) & ~np.isnan(z))[0])
    return Chart(
        z, up, down, LIMIT, WITHIN_REFERENCE, at, start, alarmed.direction, name, group, constants.pooled_scale
    )


def likeliest_start(steps: np.ndarray, first: int, at: int, direction: int) -> int:
    """The index, among the charted ``steps`` (NaN: none) from ``first`` to ``at``, where a shift of unknown size
    in ``direction`` most likely began: the maximum-likelihood change point of a mean shift from zero in unit-
    variance steps, ``argmax_tau (sum_{t >= tau} x_t)^2 / n_tau`` over the steps of the shift's sign (Hinkley
    1971). The CUSUM's last zero, ``first``, dates a shift early whenever the in-control steps before it happened
    to drift the same way; a setting that stepped there would then be named for a change that came later."""
    where = first + np.flatnonzero(~np.isnan(steps[first : at + 1]))
    if len(where) < 2:
        return first
    tail = np.cumsum((direction * steps[where])[::-1])[::-1]  # the sum from each step to the alarm
    counts = np.arange(len(where), 0, -1)
    score = np.where(tail > 0, tail**2 / counts, 0.0)
    return int(where[int(np.argmax(score))])
