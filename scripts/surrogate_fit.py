"""Step 3b: fit the GPR surrogate on the whole DoE and save it as JSON."""

import logging

from hybridtwin import files
from hybridtwin.files import read_checked
from hybridtwin.runner import run
from hybridtwin.surrogate import GPRSurrogate


def main(snakemake):
    doe = read_checked(snakemake.input.doe)
    model = GPRSurrogate(n_restarts=snakemake.params.n_restarts, random_state=snakemake.params.seed)
    model.fit(doe[snakemake.params.inputs], doe[snakemake.params.target])
    logging.info("fitted kernel %s; noise %.3f", model.gpr_.kernel_, model.noise_std_)
    files.write_json(model.to_dict(), snakemake.output.model)


run(snakemake, main)
