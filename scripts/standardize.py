"""Step 1: input standardization with DoE statistics only."""

import pandas as pd

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper.gate import DoEStandardizer


def main(snakemake):
    inputs = snakemake.params.inputs
    doe = read_checked(snakemake.input.doe)
    standardizer = DoEStandardizer().fit(doe[inputs])
    files.write_json(standardizer.to_dict(), snakemake.output.model)
    files.write_csv(
        pd.DataFrame({"column": inputs, "doe_mean": standardizer.mean_, "doe_std": standardizer.scale_}),
        snakemake.output.table,
    )


run(snakemake, main)
