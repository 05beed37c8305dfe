"""Step 6: retrain the residual model on all its training rows and freeze it (XGBoost JSON)."""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper import residual


def main(snakemake):
    spec, training = spec_of(snakemake), snakemake.wildcards.training
    inputs, residuals = pipeline.read_training(snakemake.input.production, snakemake.input.residuals, spec, training)
    model = pipeline.residual_model(
        inputs,
        residuals,
        spec,
        training,
        files.read_json(snakemake.input.best)["params"],
    )
    residual.save_model(model, snakemake.output.model, spec.inputs)


run(snakemake, main)
