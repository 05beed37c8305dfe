"""Prediction intervals by region, the recommended model per region, the peer comparison and the predictor's
manifest."""

from hybridtwin import pipeline
from hybridtwin.answers import coverage, predictor
from hybridtwin.diagnosis.causes import unit_of
from hybridtwin.diagnosis.extension import Models
from hybridtwin.io import files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import demo_truth, run, spec_of
from hybridtwin.models import peers
from hybridtwin.monitor import calibration as monitor
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.report import plots


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    predictions = read_checked(snakemake.input.predictions)
    doe = read_checked(snakemake.input.doe)
    threshold = float(files.read_json(snakemake.input.gate)["threshold"])
    truth, noise = demo_truth(snakemake.input)
    level = p.settings["level"]
    causes = Models.from_stored(files.read_json(snakemake.input.extension), None).extension.columns
    columns = [*spec.inputs, *sorted(causes - set(spec.inputs))]
    # read once: the monitor's regimes need every column of the log (its ids and shifts), the rest these
    log = read_checked(snakemake.input.production)
    production = log[[name for name in log.columns if name in set(columns)]]
    units = {name: unit_of(name, p.input_units) for name in columns}
    result = pipeline.calibrate(predictions, production, doe, spec, threshold, p.settings, truth, units)
    files.write_csv(result.table, snakemake.output.table)
    settings = {"inputs": spec.inputs, "target": spec.target, "unit": p.unit, "csv": p.csv, "level": level}
    typical = pipeline.typical(production, in_support(predictions), columns)
    gate = KNNSupportGate.from_dict(files.read_json(snakemake.input.gate))
    reach = pipeline.production_reach(production, gate, spec, p.settings["blocks"])
    files.write_json(reach.to_dict(), snakemake.output.reach)
    manifest = predictor.manifest(doe, result, {**settings, "threshold": threshold}, typical, units)
    manifest["monitor"] = monitor.calibrate(predictions["measured"], result, level, log, spec.inputs, spec.seed, causes)
    files.write_json(manifest, snakemake.output.manifest)
    matched = read_checked(snakemake.input.matched)
    peer_models = {name: peers.load_peer(name, files.read_json(snakemake.input[f"peer_{name}"])) for name in p.peers}
    at_matched = pipeline.matched_predictions(
        matched,
        spec,
        read_checked(snakemake.input.matched_models),
        read_checked(snakemake.input.matched_cases),
        peer_models,
        GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate)),
    )
    fits = {summary["model"]: summary for summary in map(files.read_json, snakemake.input.peers_summary)}
    comparison = pipeline.comparison(
        predictions, result, level, matched[p.matched_measured], at_matched, fits, truth, noise
    )
    files.write_csv(comparison, snakemake.output.comparison)
    shown = coverage.figure_data(result, predictions["measured"], predictions["knn_distance"], level, spec.seed)
    files.save_figure(
        plots.prediction_intervals(**shown, threshold=threshold, level=level, unit=p.unit), snakemake.output.figure
    )


run(snakemake, main)
