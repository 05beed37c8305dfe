"""results/predictions/whatif.csv: the frozen models' answers for the settings in the config's whatif file."""

from pathlib import Path

from hybridtwin.answers.predictor import Predictor
from hybridtwin.io.runner import run


def main(snakemake):
    predictor = Predictor.load(Path(snakemake.input.manifest).parent)
    answers = predictor.predict(predictor.read(snakemake.input.whatif), snakemake.params.level)
    predictor.write(answers, snakemake.output.predictions)


run(snakemake, main)
