"""Prediction intervals and the recommended model, per region of the input space.

Errors grow away from the DoE, so one interval width for every row would be
too wide inside the support and too narrow far outside it. The rows are put in
regions: in support, and out of support in bins of the kNN distance to the DoE.
In each region:

- the **recommended model** is the one with the lowest RMSE on the calibration
  rows (honest predictions only: out-of-fold inside the support, models never
  trained on the row outside), all models compared on the same rows;
- its **interval** is split-conformal (Mondrian, by region; ``crepes``) on the
  calibration rows' absolute errors.

A row inside the gate but beyond the DoE's range in some input takes the
support's model (the models learnt from such parts) and an interval calibrated
out of support, nearest bin (no simulation backs its setting): ``Regions``.

Calibration and test rows are alternating blocks of consecutive production
rows (a plant's log is in time order), so a test row's neighbours in time are
not in the calibration set; the coverage table is computed on the test rows only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from crepes import ConformalRegressor

from hybridtwin.io.files import in_support
from hybridtwin.metrics import rmse
from hybridtwin.models import compose, registry

IN_SUPPORT = "in_support"
# the models a row's prediction can come from (registry.RECOMMENDABLE); the stack blends the others
STACK = registry.STACK.name
MIN_CALIBRATION_ROWS = 100
MAX_CALIBRATION_ROWS = 5000
# test rows scored per region: a coverage near 90% is known to +-0.2 points (95%) from 100,000 rows, and a plant log
# of ten million parts would otherwise spend minutes on the table
MAX_TEST_ROWS = 100_000


def out_of_support_region(index: int) -> str:
    return f"out_of_support_{index}"


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


def outside_range(frame: pd.DataFrame, doe_range: dict[str, tuple[float, float]]) -> pd.DataFrame:
    """How far each row lies beyond the DoE's range, per input, in the input's own unit (0 inside)."""
    beyond = {}
    for name, (low, high) in doe_range.items():
        values = frame[name].to_numpy(float)
        beyond[name] = np.where(values > high, values - high, np.where(values < low, values - low, 0.0))
    return pd.DataFrame(beyond, index=frame.index)


def describe_outside(beyond: pd.DataFrame, doe_range: dict[str, tuple[float, float]]) -> list[str]:
    """Per row, e.g. 'die_temp_c 4.2 above the DoE's max 55' ('' when every input is in range)."""
    values = beyond.to_numpy(float)
    texts = np.full(len(values), "", dtype=object)
    for j, name in enumerate(beyond.columns):
        rows = np.flatnonzero(values[:, j] != 0)
        low, high = doe_range[name]
        for side, mask, bound in (
            (" above the DoE's max ", values[rows, j] > 0, high),
            (" below the DoE's min ", values[rows, j] < 0, low),
        ):
            at = rows[mask]
            amounts = np.array([f"{abs(v):.4g}" for v in values[at, j]], dtype=object)
            separator = np.where(texts[at] != "", "; ", "").astype(object)
            texts[at] = texts[at] + separator + f"{name} " + amounts + f"{side}{bound:.6g}"
    return texts.tolist()


def distance_edges(distance_out: np.ndarray, n_bins: int) -> list[float]:
    """Inner edges of equal-count distance bins over the out-of-support calibration rows.

    Fewer bins when there are too few rows for each to hold ``MIN_CALIBRATION_ROWS``.
    """
    n_bins = max(1, min(n_bins, len(distance_out) // MIN_CALIBRATION_ROWS))
    if n_bins == 1:
        return []
    edges = np.quantile(np.asarray(distance_out, float), np.arange(1, n_bins) / n_bins)
    return [float(edge) for edge in np.unique(edges)]


def regions(in_support, beyond_range, distance, edges) -> np.ndarray:
    """Region label per row: 'in_support' or 'out_of_support_<bin>' (bins from 1, nearest first)."""
    inside = np.asarray(in_support, bool) & ~np.asarray(beyond_range, bool)
    bins = np.searchsorted(np.asarray(edges, float), np.asarray(distance, float), side="right")
    names = np.array([out_of_support_region(b) for b in range(1, len(edges) + 2)], dtype=object)
    labels = names[bins]
    labels[inside] = IN_SUPPORT
    return labels


@dataclass(frozen=True)
class Regions:
    """Two region labels per row: where its model is chosen, and where its interval is calibrated.

    They differ only for a row inside the gate but beyond the DoE's range in some input. Its model is
    chosen among the in-support ranking, because every model saw such parts in training (the row's
    honest errors are out-of-fold ones, like those of the rest of the support); its interval is
    calibrated out of support, because no simulation backs the setting.
    """

    choice: np.ndarray
    interval: np.ndarray

    @classmethod
    def of(cls, in_support, beyond_range, distance, edges) -> "Regions":
        return cls(
            regions(in_support, np.zeros(len(distance), bool), distance, edges),
            regions(in_support, beyond_range, distance, edges),
        )

    @classmethod
    def same(cls, labels) -> "Regions":
        """One labelling for both (no row beyond the DoE's range, or a single pooled region)."""
        labels = np.asarray(labels, object)
        return cls(labels, labels)

    def __getitem__(self, rows) -> "Regions":
        return Regions(self.choice[rows], self.interval[rows])


def _regions(region) -> Regions:
    return region if isinstance(region, Regions) else Regions.same(region)


def calibration_rows(n_rows: int, n_blocks: int) -> np.ndarray:
    """True for calibration rows: the even ones of ``n_blocks`` blocks of consecutive rows."""
    block = np.arange(n_rows) * n_blocks // max(n_rows, 1)
    return block % 2 == 0


def _subsample(indices: np.ndarray, limit: int, seed: int) -> np.ndarray:
    if len(indices) <= limit:
        return indices
    return np.sort(np.random.default_rng(seed).choice(indices, limit, replace=False))


def stack_weights(measured, predictions: dict[str, np.ndarray], rows: np.ndarray) -> dict[str, float]:
    """Non-negative least-squares weights of the models' predictions on ``rows``."""
    from scipy.optimize import nnls

    names = sorted(predictions)
    weights, _ = nnls(np.column_stack([predictions[m][rows] for m in names]), np.asarray(measured, float)[rows])
    return {name: float(w) for name, w in zip(names, weights)}


def blend(weights: dict[str, float], predictions: dict[str, np.ndarray], rows) -> np.ndarray:
    return sum((w * predictions[m][rows] for m, w in weights.items()), np.zeros(len(rows)))


def _cross_fitted_stack(measured, members: dict[str, np.ndarray], rows: np.ndarray) -> np.ndarray:
    """The stack on ``rows``, each half predicted with the weights fitted on the other half (no row scores itself)."""
    out = np.full(len(measured), np.nan)
    first, second = rows[: len(rows) // 2], rows[len(rows) // 2 :]
    out[second] = blend(stack_weights(measured, members, first), members, second)
    out[first] = blend(stack_weights(measured, members, second), members, first)
    return out


def _stack_members(predictions: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {m: p for m, p in predictions.items() if m in registry.RECOMMENDABLE and m != STACK}


def _ranking(measured, candidates: dict[str, np.ndarray], rows: np.ndarray) -> list[str]:
    """The recommendable models, best first, by RMSE on the rows where every one of them has a value.

    The same rows for all: each part's noise then weighs on every model alike, and a difference far
    below the noise still shows (on different rows, the noise of the rows decides).
    """
    contenders = {m: p for m, p in candidates.items() if m in registry.RECOMMENDABLE}
    common = rows[np.all([np.isfinite(p[rows]) for p in contenders.values()], axis=0)]
    if not len(common):  # no row where all have a value: each on its own rows
        scores = {
            m: rmse(measured[rows][np.isfinite(p[rows])], p[rows][np.isfinite(p[rows])]) for m, p in contenders.items()
        }
    else:
        scores = {m: rmse(measured[common], p[common]) for m, p in contenders.items()}
    return sorted(scores, key=lambda m: (scores[m], registry.RECOMMENDABLE.index(m)))


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
    ):
        self.calibration = calibration
        self.ranking = ranking
        self.weights = weights or {}
        self.edges = list(edges)
        self.max_distance = max_distance
        self._conformal = {}
        for model, per_region in calibration.items():
            labels = np.concatenate([[region] * len(errors) for region, errors in per_region.items()]).astype(object)
            errors = np.concatenate([np.asarray(errors, float) for errors in per_region.values()])
            self._conformal[model] = ConformalRegressor().fit(errors, bins=labels)

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
    ) -> "RegionIntervals":
        measured = np.asarray(measured, float)
        region = _regions(region)
        members = _stack_members(honest)
        stack = np.full(len(measured), np.nan)
        weights, ranked_rows = {}, {}
        for name in sorted(set(region.choice[calibration])):
            rows = np.flatnonzero(calibration & (region.choice == name))  # all of them: the choice is noisy enough
            complete = rows[np.all([np.isfinite(p[rows]) for p in members.values()], axis=0)] if members else rows[:0]
            if len(complete) >= 2 * MIN_CALIBRATION_ROWS:
                weights[name] = stack_weights(measured, members, complete)
                stack[complete] = _cross_fitted_stack(measured, members, complete)[complete]
            ranked_rows[name] = rows
        candidates = {**honest, STACK: stack} if weights else dict(honest)
        ranking = {
            name: _ranking(measured, {m: p for m, p in candidates.items() if np.isfinite(p[rows]).any()}, rows)
            for name, rows in ranked_rows.items()
        }
        table = {}
        for name in sorted(set(region.interval[calibration])):
            rows = _subsample(np.flatnonzero(calibration & (region.interval == name)), MAX_CALIBRATION_ROWS, seed)
            for model, prediction in candidates.items():
                # a model without an honest value on a row (NaN) is not scored there
                scored = rows[np.isfinite(prediction[rows])]
                if len(scored):
                    table.setdefault(model, {})[name] = np.round(
                        np.abs(measured[scored] - prediction[scored]), 6
                    ).tolist()
        outside = calibration & (region.interval != IN_SUPPORT)
        max_distance = (
            float(np.max(np.asarray(distance, float)[outside])) if outside.any() and distance is not None else None
        )
        return cls(table, ranking, edges, max_distance, weights)

    def with_stack(self, predictions: dict[str, np.ndarray], region) -> dict[str, np.ndarray]:
        """The predictions with the stack added (each row blended with its region's weights; NaN without)."""
        choice = _regions(region).choice
        stacked = np.full(len(choice), np.nan)
        for name, weights in self.weights.items():
            rows = np.flatnonzero(choice == name)
            if len(rows) and all(m in predictions for m in weights):
                stacked[rows] = blend(weights, predictions, rows)
        return {**predictions, STACK: stacked}

    @property
    def recommended(self) -> dict[str, str]:
        return {name: order[0] for name, order in self.ranking.items()}

    @property
    def regions(self) -> list[str]:
        """The regions with calibrated intervals."""
        return sorted({name for per_region in self.calibration.values() for name in per_region})

    def interval(self, model: str, prediction, region, level: float) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds at ``level``; NaN in a region without calibration rows."""
        prediction = np.asarray(prediction, float)
        region = np.asarray(region, object)
        lower = np.full(len(prediction), np.nan)
        upper = np.full(len(prediction), np.nan)
        known = np.isin(region, list(self.calibration.get(model, {}))) & np.isfinite(prediction)
        if known.any():
            bounds = self._conformal[model].predict_int(prediction[known], bins=region[known], confidence=level)
            lower[known], upper[known] = bounds[:, 0], bounds[:, 1]
        return lower, upper

    def recommend(self, region, predictions: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The recommended model's name per row: the best of its region's ranking that has a value there
        (a model whose inputs a row lacks has none); the paper's gated hybrid where a region has no calibration."""
        region = _regions(region).choice
        chosen = np.full(len(region), registry.HYBRID_GATED.name, dtype=object)
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
            "recommended": self.recommended,
            "ranking": self.ranking,
            "distance_edges": self.edges,
            "max_calibrated_distance": self.max_distance,
            "stack_weights": self.weights,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "RegionIntervals":
        return cls(
            data["calibration"],
            data["ranking"],
            data["distance_edges"],
            data["max_calibrated_distance"],
            data.get("stack_weights"),
        )


def recommended_prediction(
    intervals: RegionIntervals, predictions: dict[str, np.ndarray], region, level: float
) -> pd.DataFrame:
    """pred_recommended, recommended_model, pred_lower, pred_upper per row."""
    region = _regions(region)
    chosen = intervals.recommend(region, predictions)
    n = len(chosen)
    out = pd.DataFrame(
        {
            "pred_recommended": np.full(n, np.nan),
            "recommended_model": chosen,
            "pred_lower": np.full(n, np.nan),
            "pred_upper": np.full(n, np.nan),
        }
    )
    for model in sorted(set(chosen)):
        rows = np.flatnonzero(chosen == model)
        lower, upper = intervals.interval(model, predictions[model][rows], region.interval[rows], level)
        out.loc[rows, "pred_recommended"] = predictions[model][rows]
        out.loc[rows, "pred_lower"] = lower
        out.loc[rows, "pred_upper"] = upper
    return out


def _region_label(name: str, edges: list[float], threshold: float) -> str:
    if name == IN_SUPPORT:
        return "in support"
    index = int(name.rsplit("_", 1)[1])
    low = edges[index - 2] if index >= 2 else None
    high = edges[index - 1] if index - 1 < len(edges) else None
    if low is None and high is None:
        return "out of support (every distance)"
    if low is None:
        return f"out of support, distance up to {high:.3g} (threshold {threshold:.3g})"
    if high is None:
        return f"out of support, distance above {low:.3g}"
    return f"out of support, distance {low:.3g} to {high:.3g}"


def _bounds(
    intervals: RegionIntervals,
    predictions: dict[str, np.ndarray],
    labels: Regions,
    rows: np.ndarray,
    model: str,
    level: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prediction and bounds of one model, or of the recommended one, on ``rows``."""
    if model == "recommended":
        picked = recommended_prediction(intervals, {m: p[rows] for m, p in predictions.items()}, labels[rows], level)
        return (
            picked["pred_recommended"].to_numpy(float),
            picked["pred_lower"].to_numpy(float),
            picked["pred_upper"].to_numpy(float),
        )
    lower, upper = intervals.interval(model, predictions[model][rows], labels.interval[rows], level)
    return predictions[model][rows], lower, upper


def coverage_table(
    measured,
    honest: dict[str, np.ndarray],
    region,
    calibration: np.ndarray,
    edges: list[float],
    threshold: float,
    level: float,
    truth=None,
    seed: int = 0,
) -> pd.DataFrame:
    """prediction_intervals.csv: on the test rows, per region and model, coverage, mean width and RMSE.

    Two calibrations are compared: by region (what the predictor uses) and one pool of all
    calibration rows. ``recommended`` is the model the predictor picks in each row's region.
    A model is scored on the test rows where it has an honest prediction (``n_test``).
    """
    measured = np.asarray(measured, float)
    by_region = _regions(region)
    region = by_region.interval
    pooled = Regions.same(np.full(len(region), "all", dtype=object))
    methods = {}
    for method, labels, method_edges in (("by_region", by_region, edges), ("pooled", pooled, [])):
        fitted = RegionIntervals.fit(measured, honest, labels, calibration, method_edges, seed=seed)
        methods[method] = (fitted, labels, fitted.with_stack(honest, labels))
    test = ~calibration
    models = [*methods["by_region"][2], "recommended"]
    rows = []
    for name in [*methods["by_region"][0].regions, "all"]:
        in_region = test & ((region == name) if name != "all" else True)
        if not in_region.any():
            continue
        label = _region_label(name, edges, threshold) if name != "all" else "all production rows"
        region_rows = np.flatnonzero(in_region)
        for model in models:
            for method, (intervals, labels, predictions) in methods.items():
                # a model is sampled among the rows it has a value for (a peer predicts a sample of a long log)
                valued = (
                    region_rows if model == "recommended" else region_rows[np.isfinite(predictions[model][region_rows])]
                )
                idx = _subsample(valued, MAX_TEST_ROWS, seed)
                prediction, lower, upper = _bounds(intervals, predictions, labels, idx, model, level)
                ok = np.isfinite(prediction) & np.isfinite(lower)
                if not ok.any():
                    continue
                idx, prediction, lower, upper = idx[ok], prediction[ok], lower[ok], upper[ok]
                row = {
                    "region": name,
                    "region_label": label,
                    "model": model,
                    "calibration": method,
                    "nominal_level": level,
                    "n_test": len(idx),
                    "coverage": float(np.mean((measured[idx] >= lower) & (measured[idx] <= upper))),
                    "mean_width": float(np.mean(upper - lower)),
                    "rmse_test": rmse(measured[idx], prediction),
                }
                if truth is not None:
                    reference = np.asarray(truth, float)[idx]
                    row["coverage_truth"] = float(np.mean((reference >= lower) & (reference <= upper)))
                    row["rmse_truth_test"] = rmse(reference, prediction)
                rows.append(row)
    table = pd.DataFrame(rows)
    # the calibration rows a region's intervals rest on (a seeded sample of MAX_CALIBRATION_ROWS where there are more)
    table["n_calibration"] = (
        table["region"]
        .map({name: min(int(np.sum(calibration & (region == name))), MAX_CALIBRATION_ROWS) for name in set(region)})
        .fillna(min(int(calibration.sum()), MAX_CALIBRATION_ROWS))
    )
    table["evaluated_on"] = (
        "production test rows (odd blocks of consecutive rows), never used to calibrate the intervals or choose "
        "the model (even blocks); predictions out-of-fold inside the support (the paper's shuffled K-fold, so a "
        "test part's neighbours in time were in the training folds: in-support coverage is that of periods already "
        "seen), models never trained on the row outside it (a peer's out-of-fold on the parts it trained on too); "
        "coverage of the measured value"
        + (
            f"; a seeded sample of {MAX_TEST_ROWS:,} test rows per region where there are more"
            if np.sum(test) > MAX_TEST_ROWS
            else ""
        )
        + ("; coverage_truth and rmse_truth_test against the demo's noise-free plant" if truth is not None else "")
    )
    return table


@dataclass
class Calibration:
    """What the prediction_intervals rule computes from a run's production predictions."""

    intervals: RegionIntervals
    table: pd.DataFrame
    region: Regions
    calibration: np.ndarray
    honest: dict[str, np.ndarray]  # with the stack


def calibrate(
    predictions: pd.DataFrame,
    inputs: pd.DataFrame,
    doe_range: dict[str, tuple[float, float]],
    threshold: float,
    level: float,
    n_bins: int,
    n_blocks: int,
    seed: int,
    truth=None,
) -> Calibration:
    """Regions, intervals and recommended models from results/predictions/production.csv, and their test table."""
    beyond = (outside_range(inputs, doe_range) != 0).any(axis=1).to_numpy()
    inside = in_support(predictions)
    distance = predictions["knn_distance"].to_numpy(float)
    calibration = calibration_rows(len(predictions), n_blocks)
    edges = distance_edges(distance[calibration & ~(inside & ~beyond)], n_bins)
    region = Regions.of(inside, beyond, distance, edges)
    honest = honest_predictions(predictions)
    measured = predictions["measured"].to_numpy(float)
    fitted = RegionIntervals.fit(measured, honest, region, calibration, edges, distance, seed)
    table = coverage_table(measured, honest, region, calibration, edges, threshold, level, truth, seed)
    table["recommended"] = [
        model == "recommended" or fitted.recommended.get(name) == model
        for name, model in zip(table["region"], table["model"])
    ]
    return Calibration(fitted, table, region, calibration, fitted.with_stack(honest, region))


def figure_data(calibrated: Calibration, measured, distance, level: float, seed: int, n_shown: int = 4000) -> dict:
    """What the intervals figure shows: a seeded sample of held-out rows, the recommended model's errors
    there, and per region the interval's median half-width and the recommended model's coverage."""
    test = np.flatnonzero(~calibrated.calibration)
    shown = np.sort(np.random.default_rng(seed).choice(test, min(len(test), n_shown), replace=False))
    # the half-widths' medians on a seeded sample of a long log (every row up to MAX_TEST_ROWS), with the shown rows
    rows = np.union1d(shown, _subsample(np.arange(len(calibrated.region.interval)), MAX_TEST_ROWS, seed))
    honest = {model: prediction[rows] for model, prediction in calibrated.honest.items()}
    picked = recommended_prediction(calibrated.intervals, honest, calibrated.region[rows], level)
    error = np.asarray(measured, float)[rows] - picked["pred_recommended"].to_numpy(float)
    half = ((picked["pred_upper"] - picked["pred_lower"]) / 2).to_numpy(float)
    region = calibrated.region.interval[rows]
    table = calibrated.table
    recommended = table[(table["model"] == "recommended") & (table["calibration"] == "by_region")]
    is_shown = np.isin(rows, shown)
    return {
        "distance": np.asarray(distance, float)[shown],
        "error": error[is_shown],
        "region": region[is_shown],
        "half_width": {name: float(np.nanmedian(half[region == name])) for name in calibrated.intervals.regions},
        "coverage": dict(zip(recommended["region"], recommended["coverage"])),
    }
