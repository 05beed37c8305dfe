"""An established peer of the hybrid (GP discrepancy or co-kriging), fitted on the DoE and the in-support parts."""

import logging

from hybridtwin import files, peers
from hybridtwin.files import read_checked
from hybridtwin.runner import run


def main(snakemake):
    p = snakemake.params
    kind = snakemake.wildcards.peer
    fit = peers.fit_peer(
        kind,
        read_checked(snakemake.input.doe),
        read_checked(snakemake.input.production, p.inputs),
        read_checked(snakemake.input.residuals),
        p.inputs,
        p.target,
        p.settings,
        p.seed,
        p.folds,
    )
    logging.info("%s: fitted on %d in-support parts in %.1f s", kind, fit.n_train, fit.fit_seconds)
    files.write_json(fit.model.to_dict(), snakemake.output.model)
    files.write_csv(fit.production, snakemake.output.predictions, float_format=None)
    files.write_json({"model": kind, "fit_seconds": fit.fit_seconds, "n_train": fit.n_train}, snakemake.output.summary)


run(snakemake, main)
