"""results/predictions/production.csv: the hybrid's predictions joined with the extension's and the peers',
in input order."""

import pandas as pd

from hybridtwin import files
from hybridtwin.files import read_checked
from hybridtwin.runner import run


def main(snakemake):
    parts = [
        read_checked(snakemake.input.hybrid),
        read_checked(snakemake.input.extension),
        *(read_checked(path) for path in snakemake.input.peers),
    ]
    lengths = {len(part) for part in parts}
    if len(lengths) != 1:
        raise RuntimeError(f"prediction tables of different lengths: {sorted(lengths)}")
    files.write_csv(pd.concat(parts, axis=1), snakemake.output.predictions)


run(snakemake, main)
