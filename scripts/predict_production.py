"""Predictions for every production row, in input order."""

from hybridtwin import files, residual
from hybridtwin.files import read_checked
from hybridtwin.runner import run
from hybridtwin.tables import production_predictions


def main(snakemake):
    production = read_checked(snakemake.input.production, snakemake.params.inputs)
    X = production[snakemake.params.inputs].to_numpy(float)
    table = production_predictions(
        residuals=read_checked(snakemake.input.residuals),
        support=read_checked(snakemake.input.support),
        filtered=residual.load_model(snakemake.input.filtered_model).predict(X),
        unfiltered=residual.load_model(snakemake.input.unfiltered_model).predict(X),
        filtered_oof=read_checked(snakemake.input.filtered_oof),
        unfiltered_oof=read_checked(snakemake.input.unfiltered_oof),
    )
    files.write_csv(table, snakemake.output.predictions)


run(snakemake, main)
