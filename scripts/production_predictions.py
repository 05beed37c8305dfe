"""results/predictions/production.csv: the hybrid's predictions joined with the extension's and the peers',
in input order."""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run


def main(snakemake):
    table = pipeline.joined_predictions(
        read_checked(snakemake.input.hybrid),
        read_checked(snakemake.input.extension),
        [read_checked(path) for path in snakemake.input.peers],
    )
    files.write_csv(table, snakemake.output.predictions)


run(snakemake, main)
