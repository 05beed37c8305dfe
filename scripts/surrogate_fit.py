"""Step 3b: fit the GPR surrogate on the whole DoE and save it as JSON."""

import logging

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of


def main(snakemake):
    model = pipeline.surrogate(files.read_checked(snakemake.input.doe), spec_of(snakemake), snakemake.params.n_restarts)
    logging.info("fitted kernel %s; noise %.3f", model.gpr_.kernel_, model.noise_std_)
    files.write_json(model.to_dict(), snakemake.output.model)


run(snakemake, main)
