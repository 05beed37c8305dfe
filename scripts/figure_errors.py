"""Step 8: Figure 3, error distributions of surrogate and hybrid, in support (out-of-fold) and on matched cases."""

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper.tables import error_groups
from hybridtwin.report import plots


def main(snakemake):
    groups = error_groups(read_checked(snakemake.input.predictions), read_checked(snakemake.input.cases))
    files.save_figure(plots.error_distributions(groups, snakemake.params.unit), snakemake.output.figure)


run(snakemake, main)
