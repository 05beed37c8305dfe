"""A sweep figure per named cause: the answer along the cause's column at typical production, with its interval,
the DoE's range and each value's trust verdict."""

from pathlib import Path

from hybridtwin import pipeline
from hybridtwin.answers.predictor import Predictor
from hybridtwin.io import files
from hybridtwin.io.runner import run
from hybridtwin.report import plots


def main(snakemake):
    predictor = Predictor.load(Path(snakemake.input.manifest).parent)
    causes = files.read_json(snakemake.input.summary)["selected"]
    columns = sorted({cause["columns"][0] for cause in causes if cause["kind"] != "group"})
    production = files.read_checked(snakemake.input.production, columns)
    sweeps = pipeline.cause_sweeps(predictor, causes, production)
    spec = predictor.spec
    for rank, path in enumerate(snakemake.output.figures, start=1):
        shown = sweeps[rank - 1] if rank <= len(sweeps) else None
        if shown is None:
            why = f"no cause {rank}" if rank > len(causes) else f"cause {rank} is an id: no sweep can show it"
            files.save_figure(plots.placeholder(why), path)
            continue
        column, answers = shown
        doe_range = predictor.doe_range.get(column, (float("nan"), float("nan")))
        files.save_figure(plots.sweep(answers, column, doe_range, spec["target"], spec["unit"]), path)


run(snakemake, main)
