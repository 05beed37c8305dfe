"""results/monitor/: the config's monitor batch checked against the frozen models (table, words, figure)."""

from pathlib import Path

from hybridtwin.answers.predictor import Predictor
from hybridtwin.io import files
from hybridtwin.io.runner import run
from hybridtwin.monitor import figure, watch, words


def main(snakemake):
    predictor = Predictor.load(Path(snakemake.input.manifest).parent)
    batch = snakemake.input.batch
    watched = watch.watch(predictor, watch.load_batch(batch, predictor))  # as the command: the same answer
    predictor.write(watched.table, snakemake.output.table)
    with files.atomic_path(snakemake.output.words) as temporary:
        temporary.write_text(words.markdown(watched, Path(batch).name))
    files.save_figure(figure.monitor(watched, f"Monitor: {Path(batch).name}"), snakemake.output.figure)


run(snakemake, main)
