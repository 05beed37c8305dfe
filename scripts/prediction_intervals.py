"""Prediction intervals by region, the recommended model per region, the peer comparison and the predictor's
manifest."""

from hybridtwin import files, intervals, peers, plots, predictor
from hybridtwin.files import in_support, read_checked
from hybridtwin.runner import run
from hybridtwin.surrogate import GPRSurrogate


def main(snakemake):
    p = snakemake.params
    predictions = read_checked(snakemake.input.predictions)
    production = read_checked(snakemake.input.production, p.inputs)
    doe = read_checked(snakemake.input.doe)
    threshold = float(files.read_json(snakemake.input.gate)["threshold"])
    truth = noise = None
    if snakemake.input.get("truth"):
        truth = read_checked(snakemake.input.truth)["truth_mm"].to_numpy(float)
        noise = float(files.read_json(snakemake.input.demo_spec)["noise_mm"])
    doe_range = {name: (float(doe[name].min()), float(doe[name].max())) for name in p.inputs}
    level = p.settings["level"]
    result = intervals.calibrate(
        predictions,
        production[p.inputs],
        doe_range,
        threshold,
        level,
        p.settings["distance_bins"],
        p.settings["blocks"],
        p.seed,
        truth,
    )
    files.write_csv(result.table, snakemake.output.table)
    files.write_json(
        predictor.manifest(p.inputs, p.target, p.unit, p.csv, doe, result.intervals, level, threshold),
        snakemake.output.manifest,
    )

    picked = intervals.recommended_prediction(result.intervals, result.honest, result.region, level)
    models = {**result.honest, "recommended": picked["pred_recommended"].to_numpy(float)}
    matched_cases = read_checked(snakemake.input.matched)
    matched_inputs = matched_cases[p.inputs]
    peer_models = {
        kind: peers.load_peer(kind, files.read_json(path))
        for kind, path in zip(peers.PEERS, snakemake.input.peer_models)
    }
    matched = {
        **read_checked(snakemake.input.matched_models).to_dict("series"),
        "hybrid_gated": read_checked(snakemake.input.matched_cases)["pred_hybrid_gated"],
        **peers.predictions_at(
            peer_models,
            matched_inputs,
            GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate)).predict(matched_inputs),
        ),
    }
    fits = {summary["model"]: summary for summary in map(files.read_json, snakemake.input.peers_summary)}
    comparison = peers.comparison_table(
        predictions["measured"],
        models,
        in_support(predictions),
        ~result.calibration,
        matched_cases[p.matched_measured],
        matched,
        fits,
        truth,
        noise,
    )
    files.write_csv(comparison, snakemake.output.comparison)
    shown = intervals.figure_data(result, predictions["measured"], predictions["knn_distance"], level, p.seed)
    files.save_figure(
        plots.prediction_intervals(**shown, threshold=threshold, level=level, unit=p.unit), snakemake.output.figure
    )


run(snakemake, main)
