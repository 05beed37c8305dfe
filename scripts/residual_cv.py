"""Step 5b: K-fold CV of the residual model with the tuned hyperparameters: per-fold scores and out-of-fold predictions.

training=filtered: in-support rows only (the paper's model, Table 3).
training=unfiltered: every production row (Table 5's comparison).
"""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of


def main(snakemake):
    spec, training = spec_of(snakemake), snakemake.wildcards.training
    inputs, residuals = pipeline.read_training(snakemake.input.production, snakemake.input.residuals, spec, training)
    result = pipeline.residual_cv(
        inputs,
        residuals,
        spec,
        training,
        files.read_json(snakemake.input.best)["params"],
    )
    files.write_csv(result.per_fold, snakemake.output.folds)
    files.write_table(result.oof, snakemake.output.oof)  # each row's fold: the extension is scored on the same split
    files.write_csv(result.table, snakemake.output.table)


run(snakemake, main)
