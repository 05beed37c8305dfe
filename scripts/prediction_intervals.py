"""Prediction intervals by region, the recommended model per region, the peer comparison, the predictor's
manifest, and a sweep figure per named cause (the frozen predictor's answer along the cause's column at typical
production, with its interval, the DoE's range and each value's trust verdict)."""

from pathlib import Path

from hybridtwin import pipeline
from hybridtwin.answers import coverage
from hybridtwin.answers.predictor import Predictor
from hybridtwin.diagnosis.extension import Models
from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import demo_truth, run, spec_of
from hybridtwin.models import peers
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.report import plots


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    found = snakemake.input
    predictions = pipeline.read_predictions(
        found.hybrid_predictions, found.extension_predictions, found.peer_predictions
    )
    doe, log, matched = (read_checked(found[name]) for name in ("doe", "production", "matched"))
    gate = KNNSupportGate.from_dict(files.read_json(snakemake.input.gate))
    causes = Models.from_stored(files.read_json(snakemake.input.extension), None).extension.columns
    truth, noise = demo_truth(snakemake.input)
    settings = {**p.settings, "unit": p.unit, "csv": p.csv}
    found = pipeline.answers(predictions, log, doe, gate, spec, settings, causes, p.input_units, truth)
    files.write_csv(found.calibrated.table, snakemake.output.table)
    files.write_json(found.reach.to_dict(), snakemake.output.reach)
    files.write_json(found.manifest, snakemake.output.manifest)
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
    # here, not in a step of its own: a process start (2 s) for half a second of sweeps
    write_sweeps(Predictor.load(Path(snakemake.output.manifest).parent), snakemake.input, snakemake.output.sweeps)


def write_sweeps(predictor, found, paths):
    causes = files.read_json(found.summary)["selected"]
    columns = sorted({cause["columns"][0] for cause in causes if cause["kind"] != "group"})
    sweeps = pipeline.cause_sweeps(predictor, causes, read_checked(found.production, columns))
    spec = predictor.spec
    for rank, path in enumerate(paths, start=1):
        shown = sweeps[rank - 1] if rank <= len(sweeps) else None
        if shown is None:
            why = f"no cause {rank}" if rank > len(causes) else f"cause {rank} is an id: no sweep can show it"
            files.save_figure(plots.placeholder(why), path)
            continue
        column, answers = shown
        doe_range = predictor.doe_range.get(column, (float("nan"), float("nan")))
        files.save_figure(plots.sweep(answers, column, doe_range, spec["target"], spec["unit"]), path)


run(snakemake, main)
