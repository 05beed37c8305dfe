"""Predictions for every production row, in input order."""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper import residual


def main(snakemake):
    spec = spec_of(snakemake)
    table = pipeline.hybrid_predictions(
        files.read_checked(snakemake.input.production, spec.inputs),
        files.read_checked(snakemake.input.residuals),
        files.read_checked(snakemake.input.support),
        {training: residual.load_model(snakemake.input[f"{training}_model"]) for training in residual.TRAINING_SETS},
        {training: files.read_checked(snakemake.input[f"{training}_oof"]) for training in residual.TRAINING_SETS},
        spec,
    )
    files.write_table(table, snakemake.output.predictions)


run(snakemake, main)
