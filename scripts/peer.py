"""An established peer of the hybrid (a registry.PEERS entry), fitted on the DoE and the in-support parts."""

import logging

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.models import peers


def main(snakemake):
    spec, name = spec_of(snakemake), snakemake.wildcards.peer
    residuals = files.read_checked(snakemake.input.residuals)
    # only the rows the peer learns from and predicts (on a long log, a fraction of it)
    rows = peers.rows_read(residuals, snakemake.params.settings, spec.seed)
    production = files.read_checked(snakemake.input.production, spec.inputs, rows)
    fit = pipeline.peer(
        name, files.read_checked(snakemake.input.doe), production, residuals, spec, snakemake.params.settings
    )
    logging.info("%s: fitted on %d in-support parts in %.1f s", name, fit.n_train, fit.fit_seconds)
    files.write_json(fit.model.to_dict(), snakemake.output.model)
    files.write_table(fit.production, snakemake.output.predictions)
    files.write_json({"model": name, "fit_seconds": fit.fit_seconds, "n_train": fit.n_train}, snakemake.output.summary)


run(snakemake, main)
