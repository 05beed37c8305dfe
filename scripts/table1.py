"""Table 1: the data sets and their roles."""
from hybridtwin import io
from hybridtwin.data import read_checked
from hybridtwin.hybrid import dataset_summary
from hybridtwin.runner import run


def main(snakemake):
    support = read_checked(snakemake.input.support)
    table = dataset_summary(len(read_checked(snakemake.input.doe)), len(support), int(support["in_support"].sum()),
                            len(read_checked(snakemake.input.matched)), snakemake.params.k, snakemake.params.percentile)
    io.write_csv(table, snakemake.output.table)


run(snakemake, main)
