"""Steps 5b and 6 on one training set: the residual model's K-fold CV with the tuned hyperparameters (per-fold
scores and out-of-fold predictions), then the model retrained on all its training rows and frozen (XGBoost JSON).

training=filtered: in-support rows only (the paper's model, Table 3).
training=unfiltered: every production row (Table 5's comparison).
"""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper import residual


def main(snakemake):
    spec, training = spec_of(snakemake), snakemake.wildcards.training
    inputs, residuals = pipeline.read_training(snakemake.input.production, snakemake.input.residuals, spec, training)
    params = files.read_json(snakemake.input.best)["params"]
    cv = pipeline.residual_cv(inputs, residuals, spec, training, params)
    files.write_csv(cv.per_fold, snakemake.output.folds)
    files.write_table(cv.oof, snakemake.output.oof)  # each row's fold: the extension is scored on the same split
    files.write_csv(cv.table, snakemake.output.table)
    del cv  # its out-of-fold table, before the final fit's matrices
    model = pipeline.residual_model(inputs, residuals, spec, training, params)
    residual.save_model(model, snakemake.output.model, spec.inputs)


run(snakemake, main)
