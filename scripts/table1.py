"""Table 1: the data sets and their roles."""

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper.tables import dataset_summary


def main(snakemake):
    support = read_checked(snakemake.input.support)
    table = dataset_summary(
        len(read_checked(snakemake.input.doe)),
        len(support),
        int(support["in_support"].sum()),
        len(read_checked(snakemake.input.matched)),
        snakemake.params.k,
        snakemake.params.percentile,
    )
    files.write_csv(table, snakemake.output.table)


run(snakemake, main)
