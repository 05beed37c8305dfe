"""The in-control process the log shows: runs of parts with the same coil (lot, shift) and the same settings.

The models' error is not independent from part to part. At a campaign of settings or on a coil the recommended model
is off by a settled amount (out of the support, where no part was learnt from, by as much as two or three times the
measurement noise) for as long as the campaign or the coil lasts; inside such a run the residual scatters by the
measurement noise alone, part after part. A *regime* is such a run: it begins where a text column that marks runs
(a coil id, a lot, a shift) takes a new value, or where an input jumps by more than it moves from part to part (a
new campaign of settings, a die cold after a break). The columns and jumps are learnt on the production log and
stored with the models (``predictor.json``, key ``monitor``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

JUMP = 6.0  # an input's change from one part to the next beyond this many robust SDs of such changes starts a regime
MIN_RUN = 20  # a column that changes more often than once in this many parts of the log marks no regime


def robust_step(values: np.ndarray) -> float:
    """A robust SD of a column's change from one part to the next (1.4826 times the median absolute deviation)."""
    steps = np.diff(values)
    steps = steps[np.isfinite(steps)]
    if not len(steps):
        return 0.0
    return float(1.4826 * np.median(np.abs(steps - np.median(steps))))


@dataclass(frozen=True)
class Regimes:
    """Which columns start a regime: text columns (a change of value) and numeric inputs (a jump beyond
    ``jumps[column]``)."""

    columns: tuple[str, ...]
    jumps: dict[str, float]

    @classmethod
    def learn(cls, log: pd.DataFrame, inputs) -> "Regimes":
        """From the production log, in time order: text columns that are not timestamps and change at most once in
        MIN_RUN parts; inputs whose jumps (beyond JUMP robust SDs of their part-to-part change) come at most that
        often."""
        from hybridtwin.diagnosis.causes import looks_like_timestamps

        most = len(log) / MIN_RUN
        columns = []
        for column in log.columns:
            values = log[column]
            if column in inputs or pd.api.types.is_numeric_dtype(values) or looks_like_timestamps(values):
                continue
            if np.sum(text_changes(values)) <= most:
                columns.append(str(column))
        jumps = {}
        for column in inputs:
            values = log[column].to_numpy(float)
            threshold = JUMP * robust_step(values)
            if np.sum(np.abs(np.diff(values)) > threshold) <= most:
                jumps[str(column)] = threshold
        return cls(tuple(columns), jumps)

    def starts(self, frame: pd.DataFrame, settings_only: bool = False) -> np.ndarray:
        """Per part, True where a regime begins (the first part always); ``settings_only``: where an input jumps
        (a campaign of settings, which may span several coils)."""
        new = np.zeros(len(frame), bool)
        if not len(frame):
            return new
        new[0] = True
        for column in () if settings_only else self.columns:
            if column in frame:
                new[1:] |= text_changes(frame[column])
        for column, threshold in self.jumps.items():
            if column in frame:
                new[1:] |= np.abs(np.diff(frame[column].to_numpy(float))) > threshold
        return new

    def to_dict(self) -> dict:
        return {"columns": list(self.columns), "jumps": dict(self.jumps)}

    @classmethod
    def from_dict(cls, data: dict) -> "Regimes":
        return cls(tuple(data["columns"]), {str(k): float(v) for k, v in data["jumps"].items()})


def text_changes(values: pd.Series) -> np.ndarray:
    """Per part after the first, whether a column's text differs from the part before's. A stretch of blanks is one
    value: an id missing over a run of parts is one unknown coil, not a new one at every part. Compared as codes,
    not as one Python string per part (a 10,000,000-part log)."""
    codes = pd.factorize(pd.Series(values).astype(str))[0]
    return codes[1:] != codes[:-1]


def labels(starts: np.ndarray, models=None) -> np.ndarray:
    """Each part's regime, numbered from 0; with ``models`` (each part's recommended model), a regime and model
    pair: neighbouring regions of the input space may recommend models whose predictions differ by a settled amount
    at the same settings, so the parts of one regime that take another model sit at a level of their own."""
    regime = np.cumsum(np.asarray(starts, bool)) - 1
    if models is None:
        return regime
    codes = pd.factorize(np.asarray(models, object))[0]
    return pd.factorize(regime * (codes.max(initial=0) + 1) + codes)[0]


def within(residual: np.ndarray, group: np.ndarray, least: int, window: int | None = None) -> np.ndarray:
    """Each judged part's residual against the mean of the (up to ``window``) judged parts before it in its regime,
    in units of that difference's SD for a unit scatter (``sqrt(1 + 1/n)`` with ``n`` parts in the mean): a
    self-starting chart (Hawkins 1987) whose level follows a slow trend inside a regime (a die warming over a
    shift); ``group``: each part's regime (:func:`labels`). NaN for a part not judged (NaN residual) and for the
    first ``least`` judged parts of a regime, whose level is not yet known."""
    residual = np.asarray(residual, float)
    out = np.full(len(residual), np.nan)
    judged = np.flatnonzero(np.isfinite(residual))
    if not len(judged):
        return out
    # each regime's judged parts together, in time order, and the judged parts before each in its regime
    order, before = _by_group(np.asarray(group)[judged])
    values = residual[judged][order]
    total = np.r_[0.0, np.cumsum(values)]
    counted = before if window is None else np.minimum(before, window)
    sums = total[np.arange(len(values))] - total[np.arange(len(values)) - counted]
    usable = before >= least
    mean = sums / np.maximum(counted, 1)
    scaled = (values - mean) / np.sqrt(1.0 + 1.0 / np.maximum(counted, 1))
    out[judged[order[usable]]] = scaled[usable]
    return out


def _by_group(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The order that puts each group's elements together (in their order), and in that order each element's
    count of earlier elements of its group."""
    order = np.argsort(group, kind="stable")
    ordered = group[order]
    first = np.r_[True, ordered[1:] != ordered[:-1]]
    position = np.arange(len(group))
    return order, position - np.maximum.accumulate(np.where(first, position, 0))


def _rank_in_group(group: np.ndarray) -> np.ndarray:
    """Each element's count of earlier elements of its group, in the given order."""
    order, before = _by_group(group)
    rank = np.empty(len(group), np.int64)
    rank[order] = before
    return rank


def levels(z: np.ndarray, group: np.ndarray, parts: int, least: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per regime with at least ``least`` judged parts: the mean of ``z`` over its first ``parts`` judged parts, how
    many, and the index of the part at which that mean is known (its last such part)."""
    z = np.asarray(z, float)
    judged = np.flatnonzero(np.isfinite(z))
    if not len(judged):
        return np.zeros(0), np.zeros(0, int), np.zeros(0, int)
    group = np.asarray(group)[judged]
    first = _rank_in_group(group) < parts  # a table of these rows only: a long log's regimes hold far more
    frame = pd.DataFrame({"g": group[first], "x": z[judged[first]], "at": judged[first]})
    grouped = frame.groupby("g").agg(mean=("x", "mean"), n=("x", "size"), at=("at", "max"))
    grouped = grouped[grouped["n"] >= least]
    return grouped["mean"].to_numpy(float), grouped["n"].to_numpy(int), grouped["at"].to_numpy(int)
