"""Step 5b: K-fold CV of the residual model with the tuned hyperparameters: per-fold scores and out-of-fold predictions.

training=filtered: in-support rows only (the paper's model, Table 3).
training=unfiltered: every production row (Table 5's comparison).
"""

import pandas as pd

from hybridtwin import files, residual
from hybridtwin.crossval import cross_validate, cv_table, fold_ids
from hybridtwin.files import read_checked
from hybridtwin.runner import run


def main(snakemake):
    production = read_checked(snakemake.input.production, snakemake.params.inputs)
    residuals = read_checked(snakemake.input.residuals, ["residual_approx", "in_support"])
    rows = residual.training_rows(residuals["in_support"], snakemake.wildcards.training)
    X = production.loc[rows, snakemake.params.inputs]
    y = residuals.loc[rows, "residual_approx"].to_numpy(float)
    params = files.read_json(snakemake.input.best)["params"]
    model = residual.make_model(params, snakemake.params.seed, snakemake.threads, snakemake.params.max_train_rows)
    # a fold split other than the tuning's, so the score is not the winning trial's own
    seed = residual.evaluation_seed(snakemake.params.seed)
    per_fold, oof = cross_validate(model, X, y, snakemake.params.folds, seed)
    files.write_csv(per_fold, snakemake.output.folds)
    # each row's fold, so that the extension is scored on the same split (rule model_extension)
    fold = fold_ids(len(y), snakemake.params.folds, seed)
    files.write_csv(pd.DataFrame({"row": rows, "pred_residual_oof": oof, "fold": fold}), snakemake.output.oof)
    files.write_csv(
        cv_table(
            per_fold,
            y,
            oof,
            f"XGBoost residual model ({snakemake.wildcards.training} train)",
            f"approximate residuals of {len(y)} production rows "
            f"({'in support' if snakemake.wildcards.training == 'filtered' else 'all'}), "
            f"{snakemake.params.folds}-fold CV on a split other than the tuning's; hyperparameters "
            "were tuned by CV on the in-support rows"
            + residual.capped_note(snakemake.params.max_train_rows, len(y)),  # the final fit takes every row
        ),
        snakemake.output.table,
    )


run(snakemake, main)
