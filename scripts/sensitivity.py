"""Step 9: Table 5, RMSE in and out of the support for the four prediction strategies."""

from hybridtwin.crossval import capped_note
from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper.tables import sensitivity_table


def main(snakemake):
    predictions = read_checked(snakemake.input.predictions)
    # the unfiltered model trains on every part: a sample of them where the log is longer than the cap
    note = capped_note(snakemake.params.max_train_rows, len(predictions))
    files.write_csv(sensitivity_table(predictions, note), snakemake.output.table)


run(snakemake, main)
