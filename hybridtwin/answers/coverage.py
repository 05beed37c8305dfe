"""How the intervals hold on production rows they were not calibrated on: prediction_intervals.csv, and the
data of its figure."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.stats import beta

from hybridtwin.answers.intervals import (
    MAX_CALIBRATION_ROWS,
    RegionIntervals,
    best_model,
    disagreement,
    honest_predictions,
    min_calibration_rows,
    recommended_prediction,
    subsample,
)
from hybridtwin.answers.regions import (
    MIN_CALIBRATION_ROWS,
    Regions,
    as_regions,
    calibration_rows,
    distance_edges,
    outside_range_by_parts,
    region_label,
    same_word,
)
from hybridtwin.answers.trust import Reach
from hybridtwin.io.files import in_support
from hybridtwin.metrics import rmse
from hybridtwin.models.registry import RECOMMENDED, RECOMMENDED_COLUMN

# test rows scored per region: a coverage near 90% is known to +-0.2 points (95%) from 100,000 rows, and a plant log
# of ten million parts would otherwise spend minutes on the table
MAX_TEST_ROWS = 100_000


def _bounds(
    intervals: RegionIntervals,
    predictions: dict[str, np.ndarray],
    labels: Regions,
    rows: np.ndarray,
    model: str,
    level: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prediction and bounds of one model, or of the recommended one, on ``rows``."""
    if model == RECOMMENDED:
        picked = recommended_prediction(intervals, {m: p[rows] for m, p in predictions.items()}, labels[rows], level)
        return (
            picked[RECOMMENDED_COLUMN].to_numpy(float),
            picked["pred_lower"].to_numpy(float),
            picked["pred_upper"].to_numpy(float),
        )
    lower, upper = intervals.interval(
        model, predictions[model][rows], labels.interval[rows], level, disagreement(predictions, rows)
    )
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
    fitted: RegionIntervals | None = None,
) -> pd.DataFrame:
    """prediction_intervals.csv: on the test rows, per region and model, coverage, mean width and RMSE.

    Two calibrations are compared: by region (what the predictor uses) and one pool of all
    calibration rows. ``recommended`` is the model the predictor picks in each row's region.
    A model is scored on the test rows where it has an honest prediction (``n_test``). ``fitted``: the intervals by
    region, where fitted already (the same calibration, fitted once: its ranking and stack read every calibration
    row).
    """
    measured = np.asarray(measured, float)
    by_region = as_regions(region)
    region = by_region.interval
    pooled = Regions.same(same_word(len(region), "all"))
    methods = {}
    for method, labels, method_edges in (("by_region", by_region, edges), ("pooled", pooled, [])):
        if method != "by_region" or fitted is None:
            fitted = RegionIntervals.fit(measured, honest, labels, calibration, method_edges, seed=seed)
        methods[method] = (fitted, labels, fitted.with_stack(honest, labels))
    scored = Scored(measured, None if truth is None else np.asarray(truth, float), level, seed)
    test = ~calibration
    rows = []
    for name in [*methods["by_region"][0].regions, "all"]:
        region_rows = np.flatnonzero(test & ((region == name) if name != "all" else True))
        if not len(region_rows):
            continue
        label = region_label(name, edges, threshold) if name != "all" else "all production rows"
        for model in [*methods["by_region"][2], RECOMMENDED]:
            for method, fitted in methods.items():
                row = scored.row(fitted, region_rows, model)
                if row is not None:
                    rows.append({"region": name, "region_label": label, "model": model, "calibration": method, **row})
    table = pd.DataFrame(rows)
    # the calibration rows a region's intervals rest on (a seeded sample of MAX_CALIBRATION_ROWS where there are more)
    table["n_calibration"] = (
        table["region"]
        .map({name: min(int(np.sum(calibration & (region == name))), MAX_CALIBRATION_ROWS) for name in set(region)})
        .fillna(min(int(calibration.sum()), MAX_CALIBRATION_ROWS))
    )
    table["evaluated_on"] = _evaluated_on(int(np.sum(test)), truth is not None)
    return table


def clopper_pearson(covered: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The exact binomial interval of a coverage measured as ``covered`` of ``n`` parts: what ``n`` test parts
    can tell of it (on 60 parts, a measured 90% is anything from about 80% to 96%)."""
    tail = (1 - confidence) / 2
    low = beta.ppf(tail, covered, n - covered + 1) if covered > 0 else 0.0
    high = beta.ppf(1 - tail, covered + 1, n - covered) if covered < n else 1.0
    return float(low), float(high)


def short_regions(table: pd.DataFrame, level: float) -> dict[str, list[int]]:
    """The regions where the recommended model's interval (by region) covered fewer of the test parts than
    ``level`` beyond the binomial uncertainty (the table's ``coverage_high``, its 95% Clopper-Pearson bound, lies
    below), with the parts it covered and their count: there the calibration parts said less of the errors than
    the test parts show (parts of a few coils or campaigns, all alike)."""
    rows = table[(table["model"] == RECOMMENDED) & (table["calibration"] == "by_region") & (table["region"] != "all")]
    rows = rows[rows["coverage_high"] < level]
    return {name: [round(c * n), int(n)] for name, c, n in zip(rows["region"], rows["coverage"], rows["n_test"])}


@dataclass(frozen=True)
class Scored:
    """How one model's intervals (or the recommended model's) are scored on a region's test rows."""

    measured: np.ndarray
    truth: np.ndarray | None
    level: float
    seed: int

    def row(self, fitted: tuple, region_rows: np.ndarray, model: str) -> dict | None:
        """Coverage (with its 95% Clopper-Pearson interval), width and RMSE on a seeded sample of the rows where
        the model has a value (None: none)."""
        intervals, labels, predictions = fitted
        # a model is sampled among the rows it has a value for (a peer predicts a sample of a long log)
        valued = region_rows if model == RECOMMENDED else region_rows[np.isfinite(predictions[model][region_rows])]
        idx = subsample(valued, MAX_TEST_ROWS, self.seed)
        prediction, lower, upper = _bounds(intervals, predictions, labels, idx, model, self.level)
        ok = np.isfinite(prediction) & np.isfinite(lower)
        if not ok.any():
            return None
        idx, prediction, lower, upper = idx[ok], prediction[ok], lower[ok], upper[ok]
        measured = self.measured[idx]
        covered = int(np.sum((measured >= lower) & (measured <= upper)))
        row = {
            "nominal_level": self.level,
            "n_test": len(idx),
            "coverage": covered / len(idx),
            **dict(zip(("coverage_low", "coverage_high"), clopper_pearson(covered, len(idx)))),
            "mean_width": float(np.mean(upper - lower)),
            "rmse_test": rmse(measured, prediction),
        }
        if self.truth is not None:
            reference = self.truth[idx]
            row["coverage_truth"] = float(np.mean((reference >= lower) & (reference <= upper)))
            row["rmse_truth_test"] = rmse(reference, prediction)
        return row


def _evaluated_on(n_test: int, with_truth: bool) -> str:
    return (
        "production test rows (odd blocks of consecutive rows), never used to calibrate the intervals or choose "
        "the model (even blocks); predictions out of period inside the support (K folds of consecutive parts: no "
        "model that predicted a part saw its period), models never trained on the row outside it; every test row of "
        "a region with calibration rows is scored, those further from the DoE than every calibration row with their "
        "region's interval (the answers call such settings calibrated: the test rows tested it there); coverage of "
        "the measured value, with its 95% Clopper-Pearson interval; "
        "best_on_test: the model of lowest RMSE on a region's test rows (choice_holds: it is the one recommended); "
        "recalibrated: the predictor's region there is chosen and calibrated on the test rows too (the gate's rows "
        "beyond a DoE range: its interval only), the table being the tested interval's"
        + (
            f"; a seeded sample of {MAX_TEST_ROWS:,} test rows per region where there are more"
            if n_test > MAX_TEST_ROWS
            else ""
        )
        + ("; coverage_truth and rmse_truth_test against the demo's noise-free plant" if with_truth else "")
    )


@dataclass
class Calibration:
    """What the prediction_intervals rule computes from a run's production predictions."""

    intervals: RegionIntervals
    table: pd.DataFrame
    region: Regions
    calibration: np.ndarray
    honest: dict[str, np.ndarray]  # with the stack
    # the intervals and honest predictions (with their stack) the table tested, where a short region was chosen
    # and calibrated on its test parts since
    tested: tuple[RegionIntervals, dict[str, np.ndarray]] | None = None
    _picked: dict = field(default_factory=dict, init=False, repr=False)

    def recommended(self, level: float) -> pd.DataFrame:
        """The recommended model and its prediction on every production row (honest predictions), computed once
        per level: the monitor's calibration and the peer comparison both read it (0.8 s on ten million); without
        the interval, which they do not read (0.3 GB made and held on ten million)."""
        if level not in self._picked:
            self._picked[level] = recommended_prediction(self.intervals, self.honest, self.region, level, bounds=False)
        return self._picked[level]

    def as_tested(self) -> tuple[RegionIntervals, dict[str, np.ndarray]]:
        """The intervals and honest predictions (with their stack) as the table tested them on the test parts: a
        recalibrated region's from before its test parts chose and calibrated it."""
        return self.tested or (self.intervals, self.honest)

    def held_out(self, level: float) -> dict[str, np.ndarray]:
        """Every model's honest prediction and the recommended one's, as the table tested them (:meth:`as_tested`)."""
        if self.tested is None:
            return {**self.honest, RECOMMENDED: self.recommended(level)[RECOMMENDED_COLUMN].to_numpy(float)}
        intervals, honest = self.as_tested()
        picked = recommended_prediction(intervals, honest, self.region, level, bounds=False)
        return {**honest, RECOMMENDED: picked[RECOMMENDED_COLUMN].to_numpy(float)}


def calibrate(
    predictions: pd.DataFrame,
    inputs: pd.DataFrame,
    doe_range: dict[str, tuple[float, float]],
    threshold: float,
    settings: dict,
    seed: int,
    truth=None,
    units: dict | None = None,
) -> Calibration:
    """Regions, intervals and recommended models from results/predictions/production.csv, and their test table
    (``settings``: the config's ``intervals``: level, distance_bins, blocks)."""
    level = settings["level"]
    inside = in_support(predictions)
    distance = predictions["knn_distance"].to_numpy(float)
    calibration = calibration_rows(len(predictions), settings["blocks"])
    beyond = beyond_range(inputs, doe_range)
    least = max(MIN_CALIBRATION_ROWS, min_calibration_rows(level))
    edges = distance_edges(distance[calibration & ~inside], settings["distance_bins"], least)
    region = Regions.of(inside, beyond, distance, edges, np.sum(calibration & inside & beyond) >= least)
    honest = honest_predictions(predictions)
    measured = predictions["measured"].to_numpy(float)
    # how far the parts of the regions with an interval reach, test blocks too: the latest block, where the plant
    # runs now, is one of them; a region no calibration part lies in has no interval, and its parts reach nothing
    answered = np.isin(region.interval, np.unique(region.interval[calibration]))
    # the daily check judges a part against its region's calibrated error: only as far as the calibration parts lie
    # (a warm die beyond them, within the test blocks' reach, drifted inside a regime more than they did)
    reach, judging = (
        Reach.of(extremes, distance[rows], ~inside[rows], threshold, doe_range, units)
        for rows, extremes in zip((answered, calibration), range_extremes(inputs, doe_range, answered, calibration))
    )
    fitted = RegionIntervals.fit(measured, honest, region, calibration, edges, distance, seed, reach, None, judging)
    # every part of a region with an interval lies within the reach: each such test part is scored
    table = coverage_table(measured, honest, region, calibration, edges, threshold, level, truth, seed, fitted)
    table[RECOMMENDED] = [
        model == RECOMMENDED or fitted.recommended.get(name) == model
        for name, model in zip(table["region"], table["model"])
    ]
    with_stack = fitted.with_stack(honest, region)
    best = best_on_test(measured, with_stack, region.choice, calibration, fitted)
    table["best_on_test"] = table["region"].map(best)
    table["choice_holds"] = table["region"].map({name: fitted.recommended[name] == m for name, m in best.items()})
    short = short_regions(table, level)
    table["recalibrated"] = table["region"].isin(list(short))
    if not short:
        return Calibration(fitted, table, region, calibration, with_stack)
    # those regions' model and interval from their test parts too; the table stays the tested ones'
    also = ~calibration & np.isin(region.interval, list(short))
    refitted = RegionIntervals.fit(measured, honest, region, calibration, edges, distance, seed, reach, also, judging)
    refitted.recalibrated = short
    return Calibration(refitted, table, region, calibration, refitted.with_stack(honest, region), (fitted, with_stack))


def beyond_range(inputs: pd.DataFrame, doe_range: dict) -> np.ndarray:
    """Which rows lie beyond a DoE range, a million rows at a time."""
    beyond = np.zeros(len(inputs), bool)
    for rows, amounts in outside_range_by_parts(inputs, doe_range):
        beyond[rows] = (amounts != 0).any(axis=1).to_numpy()
    return beyond


def range_extremes(inputs: pd.DataFrame, doe_range: dict, *counted: np.ndarray) -> list[pd.DataFrame]:
    """Per row mask of ``counted``, the smallest and largest distance beyond each DoE range of its rows (what
    :meth:`Reach.of` reads of them), in one pass a million rows at a time: the distances of a ten-million-part log
    (1 GB) are never held whole."""
    extremes = [[] for _ in counted]
    for rows, amounts in outside_range_by_parts(inputs, doe_range):
        for found, mask in zip(extremes, counted):
            counting = amounts[mask[rows]]
            found += [counting.min(), counting.max()]
    return [pd.DataFrame(found, columns=list(doe_range)) for found in extremes]


def best_on_test(measured, honest: dict[str, np.ndarray], choice, calibration, fitted: RegionIntervals) -> dict:
    """Per region where a model is chosen: the model of lowest RMSE on its test rows (the odd blocks), among the
    models its ranking holds: whether the choice made on the choosing blocks held on the blocks that followed."""
    best = {}
    for name, order in fitted.ranking.items():
        rows = np.flatnonzero(~calibration & (np.asarray(choice) == name))
        candidates = {m: honest[m] for m in order if m in honest and np.isfinite(honest[m][rows]).any()}
        if len(rows) and candidates:
            best[name] = best_model(measured, candidates, rows)
    return best


def figure_data(calibrated: Calibration, measured, distance, level: float, seed: int, n_shown: int = 4000) -> dict:
    """What the intervals figure shows: a seeded sample of held-out rows, the recommended model's errors
    there, and per region the interval's median half-width and the recommended model's coverage."""
    test = np.flatnonzero(~calibrated.calibration)
    shown = np.sort(np.random.default_rng(seed).choice(test, min(len(test), n_shown), replace=False))
    # the half-widths' medians on a seeded sample of a long log (every row up to MAX_TEST_ROWS), with the shown rows
    rows = np.union1d(shown, subsample(np.arange(len(calibrated.region.interval)), MAX_TEST_ROWS, seed))
    intervals, honest = calibrated.as_tested()  # the held-out rows' errors against the intervals they tested
    picked = recommended_prediction(intervals, {m: p[rows] for m, p in honest.items()}, calibrated.region[rows], level)
    error = np.asarray(measured, float)[rows] - picked[RECOMMENDED_COLUMN].to_numpy(float)
    half = ((picked["pred_upper"] - picked["pred_lower"]) / 2).to_numpy(float)
    region = calibrated.region.interval[rows]
    table = calibrated.table
    recommended = table[(table["model"] == RECOMMENDED) & (table["calibration"] == "by_region")]
    is_shown = np.isin(rows, shown)
    return {
        "distance": np.asarray(distance, float)[shown],
        "error": error[is_shown],
        "region": region[is_shown],
        "half_width": {name: float(np.nanmedian(half[region == name])) for name in intervals.regions},
        "coverage": dict(zip(recommended["region"], recommended["coverage"])),
    }
