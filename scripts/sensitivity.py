"""Step 9: Table 5, RMSE in and out of the support for the four prediction strategies."""
from hybridtwin import io
from hybridtwin.data import read_checked
from hybridtwin.hybrid import sensitivity_table
from hybridtwin.runner import run


def main(snakemake):
    io.write_csv(sensitivity_table(read_checked(snakemake.input.predictions)), snakemake.output.table)


run(snakemake, main)
