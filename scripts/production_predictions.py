"""results/predictions/production.csv: the hybrid's predictions joined with the extension's and the peers',
in input order."""

from hybridtwin.io import files
from hybridtwin.io.runner import run


def main(snakemake):
    found = snakemake.input
    files.write_joined_csv([found.hybrid, found.extension, *found.peers], snakemake.output.predictions)


run(snakemake, main)
