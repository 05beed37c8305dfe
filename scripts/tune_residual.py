"""Step 5a: Optuna (seeded TPE) search of the XGBoost residual model's hyperparameters by K-fold CV RMSE.

With ``tuning.workers`` above 1, rule tune_worker runs trials of the shared study (that many at once, each
its own job) and rule tune_residual reads the finished study (running any trial a worker left undone); with
one worker, tune_residual runs the study itself. It writes the best parameters, the trials and Table 4.
"""

import logging

from hybridtwin.io import files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper import tuning


def main(snakemake):
    p = snakemake.params
    production = read_checked(snakemake.input.production, p.inputs)
    residuals = read_checked(snakemake.input.residuals, ["residual_approx", "in_support"])
    rows, tuned_on = tuning.tuning_rows(in_support(residuals), p.max_rows, p.seed)
    space = tuning.search_space(p.search_space)
    worker = int(snakemake.wildcards.get("worker", 0))
    study = tuning.tune(
        production.iloc[rows][p.inputs],
        residuals.iloc[rows]["residual_approx"],
        n_trials=p.n_trials,
        n_folds=p.folds,
        seed=p.seed,
        storage=p.storage,
        space=space,
        n_jobs=snakemake.threads,
        warm_start=p.warm_start,
        worker=worker,
    )
    if "done" in snakemake.output.keys():  # a worker: its share of the study is done
        files.write_json({"study": study.study_name, "worker": worker}, snakemake.output.done)
        return
    best = tuning.best_params(study, space, p.n_trials)
    logging.info("study %s: best parameters %s", study.study_name, best)
    files.write_json({"study": study.study_name, "params": best}, snakemake.output.best)
    files.write_csv(tuning.hyperparameter_table(best, space, tuned_on), snakemake.output.table)
    files.write_csv(tuning.trials_table(study), snakemake.output.trials)


run(snakemake, main)
