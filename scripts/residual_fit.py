"""Step 6: retrain the residual model on all its training rows and freeze it (XGBoost JSON)."""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper import residual


def main(snakemake):
    spec = spec_of(snakemake)
    model = pipeline.residual_model(
        files.read_matrix(snakemake.input.production, spec.inputs),
        files.read_checked(snakemake.input.residuals, ["residual_approx", "in_support"]),
        spec,
        snakemake.wildcards.training,
        files.read_json(snakemake.input.best)["params"],
    )
    residual.save_model(model, snakemake.output.model, spec.inputs)


run(snakemake, main)
