"""Step 5a: Optuna (seeded TPE) search of the XGBoost residual model's hyperparameters by K-fold CV RMSE."""

import logging

from hybridtwin import files, residual
from hybridtwin.files import in_support, read_checked
from hybridtwin.runner import run


def main(snakemake):
    production = read_checked(snakemake.input.production)
    residuals = read_checked(snakemake.input.residuals)
    inside = in_support(residuals)
    space = residual.search_space(snakemake.params.search_space)
    study = residual.tune(
        production.loc[inside, snakemake.params.inputs],
        residuals.loc[inside, "residual_approx"],
        n_trials=snakemake.params.n_trials,
        n_folds=snakemake.params.folds,
        seed=snakemake.params.seed,
        storage=snakemake.params.storage,
        space=space,
        n_jobs=snakemake.threads,
        warm_start=snakemake.params.warm_start,
    )
    best = residual.best_params(study, space, snakemake.params.n_trials)
    logging.info("study %s: best parameters %s", study.study_name, best)
    files.write_json({"study": study.study_name, "params": best}, snakemake.output.best)
    files.write_csv(residual.hyperparameter_table(best, space), snakemake.output.table)
    files.write_csv(residual.trials_table(study), snakemake.output.trials)


run(snakemake, main)
