"""results/predictions/production.csv: the hybrid's predictions joined with the extension's, in input order."""
import pandas as pd

from hybridtwin import io
from hybridtwin.data import read_checked
from hybridtwin.runner import run


def main(snakemake):
    hybrid = read_checked(snakemake.input.hybrid)
    extension = read_checked(snakemake.input.extension)
    if len(hybrid) != len(extension):
        raise RuntimeError(f"{len(hybrid)} hybrid rows but {len(extension)} extension rows")
    io.write_csv(pd.concat([hybrid, extension], axis=1), snakemake.output.predictions)


run(snakemake, main)
