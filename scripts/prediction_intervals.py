"""Prediction intervals by region, the recommended model per region, and the predictor's manifest."""
import numpy as np

from hybridtwin import intervals, io, plots, predictor
from hybridtwin.data import read_checked
from hybridtwin.runner import run


def main(snakemake):
    p = snakemake.params
    predictions = read_checked(snakemake.input.predictions)
    production = read_checked(snakemake.input.production)
    doe = read_checked(snakemake.input.doe)
    threshold = float(io.read_json(snakemake.input.gate)["threshold"])
    truth = read_checked(snakemake.input.truth)["truth_mm"].to_numpy(float) if snakemake.input.get("truth") else None
    doe_range = {name: (float(doe[name].min()), float(doe[name].max())) for name in p.inputs}
    result = intervals.calibrate(predictions, production[p.inputs], doe_range, threshold, p.settings["level"],
                                 p.settings["distance_bins"], p.settings["blocks"], p.seed, truth)
    io.write_csv(result.table, snakemake.output.table)
    io.write_json(predictor.manifest(p.inputs, p.target, p.unit, p.csv, doe, result.intervals, p.settings["level"],
                                     threshold), snakemake.output.manifest)
    # the figure: held-out rows, the recommended model's errors and its interval per region
    test = np.flatnonzero(~result.calibration)
    shown = np.sort(np.random.default_rng(p.seed).choice(test, min(len(test), 4000), replace=False))
    picked = intervals.recommended_prediction(result.intervals, result.honest, result.region, p.settings["level"])
    error = predictions["measured"].to_numpy(float) - picked["pred_recommended"].to_numpy(float)
    half = ((picked["pred_upper"] - picked["pred_lower"]) / 2).to_numpy(float)
    half_width = {name: float(np.nanmedian(half[result.region == name])) for name in result.intervals.regions}
    recommended = result.table[(result.table["model"] == "recommended") & (result.table["calibration"] == "by_region")]
    coverage = dict(zip(recommended["region"], recommended["coverage"]))
    io.save_figure(plots.prediction_intervals(predictions["knn_distance"].to_numpy(float)[shown], error[shown],
                                              result.region[shown], half_width, coverage, threshold,
                                              p.settings["level"], p.unit), snakemake.output.figure)


run(snakemake, main)
