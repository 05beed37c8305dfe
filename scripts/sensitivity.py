"""Step 9: Table 5, RMSE in and out of the support for the four prediction strategies; step 8: Figure 2 (the
residual model at the matched cases) and Figure 3 (the error distributions of the surrogate and the hybrids), from
the same production predictions."""

from hybridtwin.crossval import capped_note
from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper import tables
from hybridtwin.report import plots


def main(snakemake):
    p = snakemake.params
    predictions = read_checked(snakemake.input.predictions)
    # the unfiltered model trains on every part: a sample of them where the log is longer than the cap
    note = capped_note(p.max_train_rows, len(predictions))
    files.write_csv(tables.sensitivity_table(predictions, note), snakemake.output.table)
    summary, cases = read_checked(snakemake.input.summary), read_checked(snakemake.input.cases)
    shown = tables.residual_check(predictions, cases, summary)
    files.save_figure(plots.residual_check(**shown, unit=p.unit), snakemake.output.figure)
    errors = tables.error_groups(predictions, cases)
    files.save_figure(plots.error_distributions(errors, p.unit), snakemake.output.errors)


run(snakemake, main)
