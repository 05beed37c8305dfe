"""Step 3a: K-fold CV of the GPR surrogate on the DoE -> Table 2 and a parity plot."""

from hybridtwin.crossval import cross_validate, cv_table
from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.report import plots


def main(snakemake):
    doe = read_checked(snakemake.input.doe)
    X, y = doe[snakemake.params.inputs], doe[snakemake.params.target]
    model = GPRSurrogate(n_restarts=snakemake.params.n_restarts, random_state=snakemake.params.seed)
    per_fold, oof = cross_validate(model, X, y, snakemake.params.folds, snakemake.params.seed)
    table = cv_table(
        per_fold,
        y,
        oof,
        "GPR surrogate (Matern 5/2, constant mean, learned noise)",
        f"DoE, {len(y)} rows, {snakemake.params.folds}-fold CV; inputs standardized per training fold",
    )
    files.write_csv(table, snakemake.output.table)
    files.write_csv(per_fold, snakemake.output.folds)
    files.save_figure(
        plots.parity(
            y,
            oof,
            f"simulated {snakemake.params.target} (DoE)",
            snakemake.params.unit,
            title="GPR surrogate, out-of-fold",
        ),
        snakemake.output.figure,
    )


run(snakemake, main)
