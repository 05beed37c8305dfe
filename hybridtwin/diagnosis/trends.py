"""A trend in time is not a cause where settings changed with time: the within-run evidence a trend needs.

Campaigns run in time order, each at settings of its own. Where the discrepancy depends on the inputs alone,
each campaign's parts carry an offset of its settings, and a step or a saturation in the stroke counter (or the
timestamp) follows those offsets from campaign to campaign as well as the inputs do. What tells the two apart is
parts run at the same settings at other times: the halves of one coil (its material, its campaign's settings).
A trend that is a cause shows between them (a wear rises within every coil, a shift splits the coils of one
campaign); a trend that stands for the settings does not.

The test (:func:`trend_test`) takes the means of the halves of each run of parts with the same ids
(or of each block of consecutive parts, without ids) and models them as the id test does
(:func:`~hybridtwin.diagnosis.ids.offsets_beyond_inputs_p`): a constant, plus a Gaussian process in their mean
inputs with the simulator's correlation, plus each mean's sampling error; the trend's fitted values, averaged
the same way, enter as a regressor, and a likelihood ratio tests its coefficient (chi2(1)). The test also says
its power against the trend as fitted: where every run ran at settings of its own, a smooth function of the inputs
can take up any trend, and a large p-value tells nothing (the trend is then named as before).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.stats import chi2, ncx2

from hybridtwin.diagnosis.candidates import Candidate
from hybridtwin.diagnosis.fits import Fit
from hybridtwin.diagnosis.ids import LevelMeans

RUN_BLOCK = 200  # without ids, runs of this many consecutive parts
MIN_HALF = 5  # a run is split in halves where each holds at least this many parts (else kept whole)
MAX_RUNS = 150  # at most this many runs (a seeded sample), their halves the levels the test models
MONOTONE_SHARE = 0.99  # a logged column that rises (or falls) over this share of its changes is a counter


def runs_in_time(candidates: list[Candidate], n_rows: int) -> np.ndarray:
    """A run number per row: consecutive rows with the same value of every id (a coil, its lot), or blocks of
    :data:`RUN_BLOCK` consecutive rows where no id is logged."""
    groups = [np.asarray(c.values).astype(str) for c in candidates if c.kind == "group"]
    if not groups:
        return np.arange(n_rows) // RUN_BLOCK
    changed = np.zeros(n_rows, bool)
    for labels in groups:
        changed[1:] |= labels[1:] != labels[:-1]
    return np.cumsum(changed)


def is_trend_in_time(candidate: Candidate) -> bool:
    """Whether a candidate moves with time alone: a timestamp, or a logged counter that rises (or falls) in row
    order (a stroke counter); a slow quantity that goes up and down (the ambient temperature) is not."""
    if candidate.kind == "time":
        return True
    if candidate.kind != "log":
        return False
    steps = np.diff(np.asarray(candidate.values, float))
    moves = steps[np.isfinite(steps) & (steps != 0)]
    return len(moves) > 0 and max(np.mean(moves > 0), np.mean(moves < 0)) >= MONOTONE_SHARE


def half_levels(runs: np.ndarray, seed: int) -> np.ndarray:
    """A level per row: each run's first and second half (by row order), -1 for rows of runs left out (beyond
    :data:`MAX_RUNS`, a seeded sample of runs kept)."""
    ids, start, size = np.unique(runs, return_index=True, return_counts=True)
    keep = np.ones(len(ids), bool)
    if len(ids) > MAX_RUNS:
        keep[:] = False
        keep[np.random.default_rng(seed).choice(len(ids), MAX_RUNS, replace=False)] = True
    codes = np.searchsorted(ids, runs)
    position = np.arange(len(runs)) - start[codes]
    split = size[codes] >= 2 * MIN_HALF
    second = split & (position >= size[codes] // 2)
    level = 2 * codes + second
    return np.where(keep[codes], level, -1)


def trend_test(fit: Fit, y, candidates: list[Candidate], correlation, seed: int, alpha: float) -> TrendTest | None:
    """The trend ``fit`` (a cause in time) tested beyond a smooth function of the inputs between parts run at the
    same settings (this module's method), at level ``alpha``; None without
    inputs or without the simulator's correlation (:attr:`.fits.Rules.input_correlation`), or with fewer than
    three levels. ``y``: what is left, with the chosen causes of the inputs alone put back."""
    inputs = [c for c in candidates if c.kind == "input"]
    if correlation is None or not inputs:
        return None
    level = half_levels(runs_in_time(candidates, len(y)), seed)
    rows = level >= 0
    codes, counts = np.unique(level[rows], return_inverse=True, return_counts=True)[1:]
    if len(counts) < 3:
        return None
    input_values = [np.asarray(c.values, float)[rows] for c in inputs]
    row_trend = fit.form.predict(fit.candidate.values)[rows]
    y = np.asarray(y, float)[rows]
    without = LevelMeans.of(codes, counts, y, input_values, correlation)
    with_trend = LevelMeans.of(codes, counts, y, input_values, correlation, [row_trend])
    trend = with_trend.regressors[:, 0]
    null = without.best(own=False)
    alternative = with_trend.best(own=False, start=null)
    ratio = max(0.0, 2.0 * (with_trend.loglik(alternative) - without.loglik(null)))
    # the trend as fitted (a coefficient of 1) where it is the plant's: how surely the test would see it
    power = float(ncx2.sf(chi2.ppf(1.0 - alpha, 1), 1, with_trend.information(alternative, trend)))
    return TrendTest(float(chi2.sf(ratio, 1)), power)


class TrendTest(NamedTuple):
    """A trend's test between parts run at the same settings: its p-value, and the power it has at the level
    asked against the trend as fitted (low where every run ran at settings of its own: nothing to tell)."""

    p_value: float
    power: float
