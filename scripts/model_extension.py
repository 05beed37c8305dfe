"""Extend the physics side with the diagnosed causes; measure the gain in and out of the support."""

import numpy as np
import pandas as pd

from hybridtwin import extension, files, intervals, residual
from hybridtwin.causes import Term
from hybridtwin.crossval import written_splits
from hybridtwin.files import in_support, read_checked
from hybridtwin.runner import run


def main(snakemake):
    p = snakemake.params
    residuals = read_checked(snakemake.input.residuals)
    matched = read_checked(snakemake.input.matched)
    terms = tuple(Term.from_dict(c) for c in files.read_json(snakemake.input.summary)["selected"])
    params = files.read_json(snakemake.input.best)["params"]

    def make_xgb():  # evaluate samples each fit's rows (max_train_rows) for the forms and XGBoost alike
        return residual.make_model(params, p.seed, snakemake.threads)

    # the very split of the hybrid's out-of-fold predictions (rule residual_cv writes each row's fold)
    splits = written_splits(read_checked(snakemake.input.hybrid_folds), np.flatnonzero(in_support(residuals)))
    # the blocks that calibrate the intervals choose whether the extended hybrid stands out of the support
    choosing = intervals.calibration_rows(len(residuals), p.blocks)
    # the inputs and the causes' columns: on a long log, not every column of it
    causes_columns = sorted(extension.DiscrepancyExtension(terms).columns - set(p.inputs))
    result = extension.evaluate(
        read_checked(snakemake.input.production, [*p.inputs, *causes_columns]),
        residuals,
        read_checked(snakemake.input.hybrid),
        matched,
        read_checked(snakemake.input.matched_cases),
        p.inputs,
        terms,
        make_xgb,
        splits,
        choosing,
        p.max_train_rows,
        p.seed,
    )
    truth = noise = None
    if snakemake.input.get("truth"):
        truth = read_checked(snakemake.input.truth)["truth_mm"].to_numpy(float)
        noise = float(files.read_json(snakemake.input.demo_spec)["noise_mm"])
    table = extension.gain_table(
        residuals["measured"],
        result.scored,
        in_support(residuals),
        matched[p.matched_measured],
        result.matched,
        truth,
        noise,
        test=~choosing,
    )
    table["evaluated_on"] += residual.capped_note(p.max_train_rows, int(in_support(residuals).sum()))
    files.write_csv(table, snakemake.output.table)
    files.write_json(
        {**result.models.extension.to_dict(), "extended_hybrid_out_of_support": result.models.out_of_support},
        snakemake.output.extension,
    )
    residual.save_model(result.models.remainder, snakemake.output.remainder, p.inputs)
    files.write_csv(result.production, snakemake.output.predictions)
    files.write_csv(pd.DataFrame(result.matched), snakemake.output.matched_predictions, float_format=None)


run(snakemake, main)
