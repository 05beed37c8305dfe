"""Prediction intervals and the recommended model, per region of the input space.

Errors grow away from the DoE, so one interval width for every row would be
too wide inside the support and too narrow far outside it. The rows are put in
regions: in support, and out of support in bins of the kNN distance to the DoE.
In each region:

- the **recommended model** is the one with the lowest RMSE on the calibration
  rows (honest predictions only: out-of-fold inside the support, models never
  trained on the row outside), all models compared on the same rows;
- its **interval** is split-conformal (Mondrian: by region) on the calibration rows' absolute errors,
  with the finite-sample, training-conditional rule of :func:`conformal_rank`: the interval holds at least
  its level with probability ``1 - DELTA`` over the calibration parts, however few a region has.
- **out of the support** it is widened where the models that correct the surrogate disagree more than they did on
  the region's calibration parts (:func:`disagreement`): the half-width is the larger of the plain one and the
  locally weighted one (Lei et al. 2018: the calibration errors scaled by each part's disagreement plus
  :data:`SPREAD_FLOOR` times its median, their conformal quantile scaled back by the asked part's). A region is
  a band of distance to the DoE; the parts asked about in it may be other settings than those that calibrated
  it, and where the corrections part ways there, the plain interval's errors say nothing of them.

A row inside the gate but beyond the DoE's range in some input takes the
support's model (the models learnt from such parts) and an interval calibrated
out of support, nearest bin (no simulation backs its setting): ``Regions``.

Calibration and test rows are alternating blocks of consecutive production
rows (a plant's log is in time order), so a test row's neighbours in time are
not in the calibration set; the coverage table is computed on the test rows only.
"""

from __future__ import annotations

import functools

import numpy as np
import pandas as pd
from scipy.stats import beta

from hybridtwin.answers.regions import (
    BEYOND_RANGE,
    IN_SUPPORT,
    MIN_CALIBRATION_ROWS,
    Regions,
    as_regions,
    is_outside,
    same_word,
)
from hybridtwin.io.files import in_support, table_of
from hybridtwin.metrics import rmse
from hybridtwin.models import compose, registry
from hybridtwin.models.registry import RECOMMENDED, RECOMMENDED_COLUMN
from hybridtwin.models.stack import (
    blend,
    choosing_blocks,
    cross_fitted_stack,
    folds_of,
    members,
    stack_members,
    stack_weights,
)

# the models a row's prediction can come from (registry.RECOMMENDABLE); the stack blends the others
STACK = registry.STACK.name


MAX_CALIBRATION_ROWS = 5000
# the locally weighted interval's scale: a part's disagreement plus this many times the region's median, so that
# where the corrections happen to agree the part's noise (which their agreement does not shrink) still counts
SPREAD_FLOOR = 2.0
# the intervals hold at least their level with this probability over the draw of a region's calibration parts
# (a small region's errors are a small sample: its plain conformal quantile covers less than the level half the time)
DELTA = 0.1


@functools.cache
def conformal_rank(n: int, level: float, delta: float = DELTA) -> int | None:
    """The rank (1-based, among ``n`` calibration errors sorted up) of the interval's half-width, or None when
    ``n`` errors are too few for ``level``.

    With the k-th smallest of n exchangeable errors, the coverage of a new part is Beta(k, n + 1 - k) over the
    draw of the calibration parts (Vovk 2012, training-conditional conformal prediction); k is the smallest rank
    whose coverage falls below ``level`` with probability at most ``delta``.
    """
    ranks = np.arange(1, n + 1)
    good = ranks[beta.cdf(level, ranks, n + 1 - ranks) <= delta]
    return int(good[0]) if len(good) else None


def disagreement(predictions: dict[str, np.ndarray], rows=None) -> np.ndarray | None:
    """Per row (of ``rows``, default all), the standard deviation of the corrections' predictions
    (:data:`registry.CORRECTIONS`); NaN where one has no value (None where one is not given at all)."""
    if not all(name in predictions for name in registry.CORRECTIONS):
        return None
    rows = slice(None) if rows is None else rows
    values = [np.asarray(predictions[name], float)[rows] for name in registry.CORRECTIONS]
    mean = sum(values) / len(values)  # column by column: no table of every row's values (ten million parts)
    return np.sqrt(sum((value - mean) ** 2 for value in values) / len(values))


def min_calibration_rows(level: float, delta: float = DELTA) -> int:
    """The fewest errors for which :func:`conformal_rank` gives an interval at ``level``: level^n <= delta."""
    return int(np.ceil(np.log(delta) / np.log(level)))


def answer_columns() -> list[str]:
    """The columns of results/predictions/production.csv that the answers' calibration reads (what
    :func:`honest_predictions` takes, the support, the distance to the DoE and the measured value): on a log of
    ten million parts the other half of the table (the final models' predictions, the residuals) is 0.9 GB."""
    oof = [model.oof_column for model in registry.WITH_OOF_COLUMN]
    return ["in_support", "knn_distance", "measured", registry.SURROGATE.column, *oof]


def honest_predictions(predictions: pd.DataFrame) -> dict[str, np.ndarray]:
    """Per model, the predictions no row was trained on (columns of results/predictions/production.csv)."""
    surrogate = predictions[registry.SURROGATE.column].to_numpy(float)
    hybrid = predictions[registry.HYBRID.oof_column].to_numpy(float)
    honest = {
        registry.SURROGATE.name: surrogate,
        registry.HYBRID_GATED.name: compose.gated(surrogate, hybrid, in_support(predictions)),
        registry.HYBRID.name: hybrid,
    }
    for model in registry.WITH_OOF_COLUMN:
        if model.oof_column in predictions:
            honest[model.name] = predictions[model.oof_column].to_numpy(float)
    return honest


def subsample(indices: np.ndarray, limit: int, seed: int) -> np.ndarray:
    if len(indices) <= limit:
        return indices
    return np.sort(np.random.default_rng(seed).choice(indices, limit, replace=False))


def _ranking(measured, candidates: dict[str, np.ndarray], rows: np.ndarray) -> list[str]:
    """The recommendable models by RMSE on the rows where every one of them has a value, the lowest first.

    The same rows for all: each part's noise then weighs on every model alike, and a difference far
    below the noise still shows (on different rows, the noise of the rows decides). The rows are a region's
    choosing blocks, whole stretches of the log that no model's value there was fitted on (the stack's cross-fitted
    by block): the lowest error there is the lowest on campaigns a model did not see. No simplicity guard: on the
    published bi-fidelity functions a guard that kept the simplest model unless the best beat it beyond doubt
    across the blocks kept one up to 3.3 times as far from the truth as the best in support, where the models
    differ far below the noise, and once the surrogate out of support, where a region's parts come from a few
    campaigns (docs: benchmarks, peers on published bi-fidelity functions).
    """
    contenders = {m: p for m, p in candidates.items() if m in registry.RECOMMENDABLE}
    finite = np.all([np.isfinite(p[rows]) for p in contenders.values()], axis=0)
    common = rows[finite]
    if not len(common):  # no row where all have a value: each on its own rows
        scores = {
            m: rmse(measured[rows][np.isfinite(p[rows])], p[rows][np.isfinite(p[rows])]) for m, p in contenders.items()
        }
    else:
        scores = {m: rmse(measured[common], p[common]) for m, p in contenders.items()}
    return sorted(scores, key=lambda m: (scores[m], registry.RECOMMENDABLE.index(m)))


def best_model(measured, candidates: dict[str, np.ndarray], rows: np.ndarray) -> str:
    """The recommendable model of lowest RMSE on ``rows`` (the rows where every one has a value), no guard."""
    return _ranking(np.asarray(measured, float), candidates, rows)[0]


class RegionIntervals:
    """Mondrian split-conformal intervals of several models, with the recommended model per region.

    ``calibration[model][region]`` holds that model's absolute errors on the
    region's calibration rows; stored as such (JSON), refitted with crepes on load.
    """

    def __init__(
        self,
        calibration: dict[str, dict[str, list[float]]],
        ranking: dict[str, list[str]],
        edges: list[float],
        max_distance: float | None,
        weights: dict[str, dict[str, float]] | None = None,
        reach: dict[str, list[float]] | None = None,
        beyond_region: bool = False,
        spreads: dict | None = None,
        recalibrated: dict[str, list[int]] | None = None,
        judging: dict | None = None,
    ):
        self.calibration = calibration
        # the regions calibrated (and, out of the support, chosen) on their test parts too
        # (:func:`~hybridtwin.answers.coverage.short_regions`), with the parts of them the tested interval covered
        self.recalibrated = recalibrated or {}
        # out of the support, per region the corrections' disagreement on each of its calibration parts (None where
        # one had no value), and per model and region the positions among them of the parts it was scored on, where
        # not all (its errors' order); none stored: the plain interval
        self.spreads = spreads or {}
        self.ranking = ranking
        self.weights = weights or {}
        self.edges = list(edges)
        self.max_distance = max_distance
        self.reach = reach or {}
        # how far the calibration parts alone reach ({"max_distance", "beyond"}): where the daily check judges a
        # part against its region's calibrated error (None in files stored before: the answers' reach)
        self.judging = judging
        self.beyond_region = beyond_region  # rows in the gate beyond a DoE range have an interval region of their own
        self._sorted = {
            model: {region: np.sort(np.asarray(errors, float)) for region, errors in per_region.items()}
            for model, per_region in calibration.items()
        }
        self._weighted = {}
        for region, spread in self.spreads.get("regions", {}).items():
            for model, per_region in calibration.items():
                if region in per_region:
                    kept = self.spreads.get("scored", {}).get(model, {}).get(region)
                    model_spread = _as_floats(spread, kept)
                    if len(model_spread) != len(per_region[region]):  # not the parts of its errors: plain
                        continue
                    weighted = _weighted_scores(per_region[region], model_spread)
                    if weighted is not None:
                        self._weighted[model, region] = weighted

    @classmethod
    def fit(
        cls,
        measured,
        honest: dict[str, np.ndarray],
        region: "Regions | np.ndarray",
        calibration: np.ndarray,
        edges: list[float],
        distance=None,
        seed: int = 0,
        reach=None,
        also: np.ndarray | None = None,
        judging=None,
    ) -> "RegionIntervals":
        """``reach``: how far the logged parts that calibrated and tested the intervals lie (:class:`trust.Reach`),
        stored for the trust verdicts; ``judging``: how far the calibration parts alone lie (a :class:`trust.Reach`),
        stored for the daily check;
        ``also``: rows beyond the calibration rows (the test parts of a region whose interval fell short on them,
        :func:`~hybridtwin.answers.coverage.short_regions`) that calibrate their region's interval too, and choose
        its model and stack where the region chooses its own (out of the support; not the gate's parts beyond a
        DoE range, which take the support's model). Their blocks are their own: every other region's fit stays."""
        measured = np.asarray(measured, float)
        region = as_regions(region)
        also = np.zeros(len(measured), bool) if also is None else np.asarray(also, bool)
        weights, stack, ranked_rows = _stacks(measured, stack_members(honest), region, calibration, also)
        candidates = {**honest, STACK: stack} if weights else dict(honest)
        ranking = {
            name: _ranking(measured, {m: p for m, p in candidates.items() if np.isfinite(p[rows]).any()}, rows)
            for name, rows in ranked_rows.items()
        }
        table, spreads = {}, {"regions": {}, "scored": {}}
        errors_of = calibration | also
        for name in sorted(set(region.interval[calibration])):
            rows = subsample(np.flatnonzero(errors_of & (region.interval == name)), MAX_CALIBRATION_ROWS, seed)
            spread = disagreement(candidates, rows) if is_outside(name) else None
            if spread is not None:
                spreads["regions"][name] = [None if np.isnan(v) else v for v in np.round(spread, 6).tolist()]
            for model, prediction in candidates.items():
                # a model without an honest value on a row (NaN) is not scored there
                has = np.isfinite(prediction[rows])
                scored = rows[has]
                if not len(scored):
                    continue
                table.setdefault(model, {})[name] = np.round(np.abs(measured[scored] - prediction[scored]), 6).tolist()
                if spread is not None and not has.all():
                    spreads["scored"].setdefault(model, {})[name] = np.flatnonzero(has).tolist()
        if reach is not None:
            beyond_region = BEYOND_RANGE in set(region.interval[calibration])
            judged = None if judging is None else {"max_distance": judging.max_distance, "beyond": judging.beyond}
            return cls(
                table, ranking, edges, reach.max_distance, weights, reach.beyond, beyond_region, spreads, None, judged
            )
        outside = calibration & (region.interval != IN_SUPPORT)
        max_distance = (
            float(np.max(np.asarray(distance, float)[outside])) if outside.any() and distance is not None else None
        )
        return cls(table, ranking, edges, max_distance, weights, spreads=spreads)

    def with_stack(self, predictions: dict[str, np.ndarray], region) -> dict[str, np.ndarray]:
        """The predictions with the stack added (each row blended with its region's weights; NaN without)."""
        return {**predictions, STACK: _blended(self.weights, predictions, as_regions(region).choice)}

    @property
    def recommended(self) -> dict[str, str]:
        return {name: order[0] for name, order in self.ranking.items()}

    @property
    def regions(self) -> list[str]:
        """The regions with calibrated intervals."""
        return sorted({name for per_region in self.calibration.values() for name in per_region})

    def half_width(self, model: str, region: str, level: float) -> float:
        """The interval's half-width of ``model`` in ``region`` at ``level``; NaN where the region has no
        calibration errors of the model, or too few for the level (:func:`conformal_rank`)."""
        errors = self._sorted.get(model, {}).get(region)
        rank = None if errors is None or not len(errors) else conformal_rank(len(errors), float(level))
        return float(errors[rank - 1]) if rank else float("nan")

    def typical_spread(self, model: str, region: str) -> float | None:
        """The corrections' median disagreement on the parts that calibrated ``model``'s interval in ``region``
        (None where the interval is not weighted by it)."""
        weighted = self._weighted.get((model, region))
        return None if weighted is None else weighted[1] / SPREAD_FLOOR

    def interval(self, model: str, prediction, region, level: float, spread=None) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds at ``level``; NaN in a region without calibration rows (or too few). ``spread``:
        each row's :func:`disagreement`, which widens an interval out of the support (None: the plain one)."""
        prediction = np.asarray(prediction, float)
        region = np.asarray(region, object)
        half = np.full(len(prediction), np.nan)
        for name in pd.unique(region):
            rows = region == name
            half[rows] = self.half_width(model, name, level)
            weighted = self._weighted.get((model, name))
            if weighted is not None and spread is not None:
                scores, floor = weighted
                rank = conformal_rank(len(scores), float(level))
                local = scores[rank - 1] * (np.asarray(spread, float)[rows] + floor) if rank else np.nan
                # where a row's disagreement is unknown (a correction lacks its column), the plain interval
                half[rows] = np.fmax(half[rows], local)
        return prediction - half, prediction + half

    def recommend(self, region, predictions: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The recommended model's name per row: the best of its region's ranking that has a value there
        (a model whose inputs a row lacks has none); the paper's gated hybrid where a region has no calibration."""
        region = as_regions(region).choice
        chosen = same_word(len(region), registry.HYBRID_GATED.name)
        for name, order in self.ranking.items():
            rows = np.flatnonzero(region == name)
            for model in reversed(order):  # from the worst up: the best model with a value is written last
                if predictions is None:
                    chosen[rows] = model
                elif model in predictions:
                    chosen[rows[np.isfinite(predictions[model][rows])]] = model
        return chosen

    def to_dict(self) -> dict:
        return {
            "calibration": self.calibration,
            RECOMMENDED: self.recommended,
            "ranking": self.ranking,
            "distance_edges": self.edges,
            "max_calibrated_distance": self.max_distance,
            "calibrated_reach": self.reach,
            "beyond_region": self.beyond_region,
            "stack_weights": self.weights,
            "calibration_spreads": self.spreads,
            "recalibrated": self.recalibrated,
            "monitor_reach": self.judging,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "RegionIntervals":
        return cls(
            data["calibration"],
            data["ranking"],
            data["distance_edges"],
            data["max_calibrated_distance"],
            data.get("stack_weights"),
            data.get("calibrated_reach"),
            data.get("beyond_region", False),
            data.get("calibration_spreads"),
            data.get("recalibrated"),
            data.get("monitor_reach"),
        )


def _stacks(measured, members: dict[str, np.ndarray], region: Regions, calibration, also: np.ndarray):
    """Per choice region its stack's weights and its rows that choose, and the stack's value on every row that
    calibrates: cross-fitted by block where it chose, blended with the region's weights on the rows ``also`` that
    did not (the gate's parts beyond a DoE range, which take the support's choice)."""
    stack = np.full(len(measured), np.nan)
    choosing = calibration | (also & (region.choice == region.interval))
    blocks = choosing_blocks(calibration)
    blocks = np.where(also, choosing_blocks(also) + blocks.max() + 1, blocks)  # their own: no other region's move
    weights, ranked_rows = {}, {}
    for name in sorted(set(region.choice[calibration])):
        rows = np.flatnonzero(choosing & (region.choice == name))  # all of them: the choice is noisy enough
        complete = rows[np.all([np.isfinite(p[rows]) for p in members.values()], axis=0)] if members else rows[:0]
        if len(complete) >= 2 * MIN_CALIBRATION_ROWS:
            weights[name] = stack_weights(measured, members, complete)
            folds = folds_of(blocks, complete)
            stack[complete] = cross_fitted_stack(measured, members, complete, folds)[complete]
        ranked_rows[name] = rows
    if (also & ~choosing).any():
        stack = np.where(also & ~choosing, _blended(weights, members, region.choice), stack)
    return weights, stack, ranked_rows


def _blended(weights: dict[str, dict[str, float]], predictions: dict[str, np.ndarray], choice) -> np.ndarray:
    """The stack: each row blended with its region's ``weights``; NaN in a region without (or a member missing)."""
    stacked = np.full(len(choice), np.nan)
    for name, region_weights in weights.items():
        rows = np.flatnonzero(choice == name)
        if len(rows) and all(m in predictions for m in members(region_weights)):
            stacked[rows] = blend(region_weights, predictions, rows)
    return stacked


def _as_floats(values, kept=None) -> np.ndarray:
    """A stored list (None for NaN) as floats, at the positions ``kept`` (default all)."""
    floats = np.array([np.nan if v is None else v for v in values], float)
    return floats if kept is None else floats[np.asarray(kept, int)]


def _weighted_scores(errors, spread: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The calibration errors of the parts with a disagreement, scaled by it plus the floor (sorted), and the floor;
    None where no part has one, or the corrections agreed on every part (no scale to weigh by)."""
    known = np.isfinite(spread)
    if not known.any():
        return None
    floor = SPREAD_FLOOR * float(np.median(spread[known]))
    if floor <= 0:
        return None
    return np.sort(np.asarray(errors, float)[known] / (spread[known] + floor)), floor


def recommended_prediction(
    intervals: RegionIntervals, predictions: dict[str, np.ndarray], region, level: float, bounds: bool = True
) -> pd.DataFrame:
    """pred_recommended, recommended_model, pred_lower, pred_upper per row (without the bounds unless
    ``bounds``: on ten million parts they and their making hold 0.3 GB)."""
    region = as_regions(region)
    chosen = intervals.recommend(region, predictions)
    prediction, lower, upper = (np.full(len(chosen) if shown else 0, np.nan) for shown in (True, bounds, bounds))
    spread = disagreement(predictions) if bounds else None  # the predictions of the rows asked about only
    for model in sorted(pd.unique(chosen)):
        rows = np.flatnonzero(chosen == model)
        if bounds:
            lower[rows], upper[rows] = intervals.interval(
                model, predictions[model][rows], region.interval[rows], level, None if spread is None else spread[rows]
            )
        prediction[rows] = predictions[model][rows]
    # the names stay Python objects, a few shared by every row: as pandas' text dtype they were copied into Arrow,
    # and each row's name made again as an object by the monitor's calibration (1.3 GB on ten million parts)
    models = pd.Series(chosen, dtype=object)
    frame = {RECOMMENDED_COLUMN: prediction, "recommended_model": models}
    frame |= {"pred_lower": lower, "pred_upper": upper} if bounds else {}
    return table_of(frame)  # each column its own: a part of them is kept without the rest
