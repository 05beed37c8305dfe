"""Prediction intervals by region, the recommended model per region, the peer comparison and the predictor's manifest."""
import numpy as np

from hybridtwin import intervals, io, peers, plots, predictor
from hybridtwin.data import read_checked
from hybridtwin.runner import run
from hybridtwin.surrogate import GPRSurrogate


def main(snakemake):
    p = snakemake.params
    predictions = read_checked(snakemake.input.predictions)
    production = read_checked(snakemake.input.production)
    doe = read_checked(snakemake.input.doe)
    threshold = float(io.read_json(snakemake.input.gate)["threshold"])
    truth = noise = None
    if snakemake.input.get("truth"):
        truth = read_checked(snakemake.input.truth)["truth_mm"].to_numpy(float)
        noise = float(io.read_json(snakemake.input.demo_spec)["noise_mm"])
    doe_range = {name: (float(doe[name].min()), float(doe[name].max())) for name in p.inputs}
    level = p.settings["level"]
    result = intervals.calibrate(predictions, production[p.inputs], doe_range, threshold, level,
                                 p.settings["distance_bins"], p.settings["blocks"], p.seed, truth)
    io.write_csv(result.table, snakemake.output.table)
    io.write_json(predictor.manifest(p.inputs, p.target, p.unit, p.csv, doe, result.intervals, level, threshold),
                  snakemake.output.manifest)

    picked = intervals.recommended_prediction(result.intervals, result.honest, result.region, level)
    models = {**result.honest, "recommended": picked["pred_recommended"].to_numpy(float)}
    matched = {**read_checked(snakemake.input.matched_models).to_dict("series"),
               "hybrid_gated": read_checked(snakemake.input.matched_cases)["pred_hybrid_gated"]}
    matched_inputs = read_checked(snakemake.input.matched)[p.inputs]
    matched_surrogate = GPRSurrogate.from_dict(io.read_json(snakemake.input.surrogate)).predict(matched_inputs)
    for kind, path in zip(peers.PEERS, snakemake.input.peer_models):
        model = peers.load_peer(kind, io.read_json(path))
        matched[kind] = peers.peer_prediction(kind, model, matched_inputs, matched_surrogate)
    fits = {summary["model"]: summary for summary in map(io.read_json, snakemake.input.peers_summary)}
    comparison = peers.comparison_table(predictions["measured"], models, predictions["in_support"].astype(bool),
                                        ~result.calibration, read_checked(snakemake.input.matched)[p.matched_measured],
                                        matched, fits, truth, noise)
    io.write_csv(comparison, snakemake.output.comparison)

    # the figure: held-out rows, the recommended model's errors and its interval per region
    test = np.flatnonzero(~result.calibration)
    shown = np.sort(np.random.default_rng(p.seed).choice(test, min(len(test), 4000), replace=False))
    error = predictions["measured"].to_numpy(float) - picked["pred_recommended"].to_numpy(float)
    half = ((picked["pred_upper"] - picked["pred_lower"]) / 2).to_numpy(float)
    half_width = {name: float(np.nanmedian(half[result.region == name])) for name in result.intervals.regions}
    recommended = result.table[(result.table["model"] == "recommended") & (result.table["calibration"] == "by_region")]
    coverage = dict(zip(recommended["region"], recommended["coverage"]))
    io.save_figure(plots.prediction_intervals(predictions["knn_distance"].to_numpy(float)[shown], error[shown],
                                              result.region[shown], half_width, coverage, threshold, level, p.unit),
                   snakemake.output.figure)


run(snakemake, main)
