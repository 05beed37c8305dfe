"""Prediction intervals by region, the recommended model per region, the peer comparison, the predictor's
manifest, and a sweep figure per named cause (the frozen predictor's answer along the cause's column at typical
production, with its interval, the DoE's range and each value's trust verdict)."""

from pathlib import Path

from hybridtwin import pipeline
from hybridtwin.answers import coverage
from hybridtwin.answers.intervals import answer_columns
from hybridtwin.answers.predictor import Predictor
from hybridtwin.diagnosis.extension import Models
from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import demo_truth, run, spec_of
from hybridtwin.models import peers
from hybridtwin.monitor import calibration as monitor
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.report import plots


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    found = snakemake.input
    predictions = pipeline.read_predictions(
        found.hybrid_predictions, found.extension_predictions, found.peer_predictions, answer_columns()
    )
    causes = Models.from_stored(files.read_json(snakemake.input.extension), None).extension.columns
    doe, matched = read_checked(found.doe), read_checked(found.matched)
    log, production = pipeline.answers_log(found.production, spec, causes), found.production
    gate = KNNSupportGate.from_dict(files.read_json(snakemake.input.gate))
    truth, noise = demo_truth(snakemake.input)
    settings = {**p.settings, "unit": p.unit, "csv": p.csv}
    found = pipeline.answers(predictions, log, doe, gate, spec, settings, causes, p.input_units, truth)
    files.write_csv(found.calibrated.table, snakemake.output.table)
    files.write_json(found.reach.to_dict(), snakemake.output.reach)
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
    level = p.settings["level"]
    comparison = pipeline.comparison(
        predictions, found.calibrated, level, matched[p.matched_measured], at_matched, fits, truth, noise
    )
    files.write_csv(comparison, snakemake.output.comparison)
    shown = coverage.figure_data(
        found.calibrated, predictions["measured"], predictions["knn_distance"], level, spec.seed
    )
    files.save_figure(
        plots.prediction_intervals(**shown, threshold=gate.threshold_, level=level, unit=p.unit),
        snakemake.output.figure,
    )
    # the monitor's calibration last, from the log's record alone: every model's predictions and the intervals'
    # calibration go first (1 GB on ten million parts)
    record, manifest = monitor.record(predictions["measured"], found.calibrated, level), found.manifest
    del predictions, found
    log = pipeline.monitor_log(production, spec, causes, log)
    manifest["monitor"] = monitor.calibrate(record, log, spec.inputs, spec.seed, causes)
    files.write_json(manifest, snakemake.output.manifest)
    # here, not in a step of its own: a process start (2 s) for half a second of sweeps
    predictor = Predictor.load(Path(snakemake.output.manifest).parent)
    named = files.read_json(snakemake.input.summary)["selected"]
    figures = plots.cause_sweeps(
        pipeline.cause_sweeps(predictor, named, log),
        len(named),
        len(snakemake.output.sweeps),
        predictor.doe_range,
        spec.target,
        p.unit,
        predictor.input_units,
    )
    for figure, path in zip(figures, snakemake.output.sweeps):
        files.save_figure(figure, path)


run(snakemake, main)
