"""Step 9: Table 5, RMSE in and out of the support for the four prediction strategies."""

from hybridtwin import files
from hybridtwin.files import read_checked
from hybridtwin.runner import run
from hybridtwin.tables import sensitivity_table


def main(snakemake):
    files.write_csv(sensitivity_table(read_checked(snakemake.input.predictions)), snakemake.output.table)


run(snakemake, main)
