"""Step 6: retrain the residual model on all its training rows and freeze it (XGBoost JSON)."""

from hybridtwin import files, residual
from hybridtwin.files import read_checked
from hybridtwin.runner import run


def main(snakemake):
    production = read_checked(snakemake.input.production, snakemake.params.inputs)
    residuals = read_checked(snakemake.input.residuals, ["residual_approx", "in_support"])
    rows = residual.training_rows(residuals["in_support"], snakemake.wildcards.training)
    params = files.read_json(snakemake.input.best)["params"]
    model = residual.make_model(params, snakemake.params.seed, snakemake.threads, snakemake.params.max_train_rows)
    model.fit(production.loc[rows, snakemake.params.inputs].to_numpy(float), residuals.loc[rows, "residual_approx"])
    residual.save_model(model, snakemake.output.model, snakemake.params.inputs)


run(snakemake, main)
