"""Extend the physics side with the diagnosed causes; measure the gain in and out of the support."""
import pandas as pd

from hybridtwin import extension, io, residual
from hybridtwin.data import read_checked
from hybridtwin.extension import Cause
from hybridtwin.runner import run
from hybridtwin.validation import folds


def main(snakemake):
    p = snakemake.params
    residuals = read_checked(snakemake.input.residuals)
    matched = read_checked(snakemake.input.matched)
    causes = tuple(Cause.from_dict(c) for c in io.read_json(snakemake.input.summary)["selected"])
    params = io.read_json(snakemake.input.best)["params"]

    def make_xgb():
        return residual.make_model(params, p.seed, snakemake.threads)

    # the same folds as the hybrid's out-of-fold predictions (rule residual_cv)
    splits = folds(int(residuals["in_support"].sum()), p.folds, residual.evaluation_seed(p.seed))
    result = extension.evaluate(read_checked(snakemake.input.production), residuals, read_checked(snakemake.input.hybrid),
                                matched, read_checked(snakemake.input.matched_cases), p.inputs, causes, make_xgb, splits)
    truth = noise = None
    if snakemake.input.get("truth"):
        truth = read_checked(snakemake.input.truth)["truth_mm"].to_numpy(float)
        noise = float(io.read_json(snakemake.input.demo_spec)["noise_mm"])
    table = extension.gain_table(residuals["measured"], result.scored, residuals["in_support"].astype(bool),
                                 matched[p.matched_measured], result.matched, truth, noise)
    io.write_csv(table, snakemake.output.table)
    io.write_json(result.models.extension.to_dict(), snakemake.output.extension)
    residual.save_model(result.models.remainder, snakemake.output.remainder, p.inputs)
    io.write_csv(result.production, snakemake.output.predictions)
    io.write_csv(pd.DataFrame(result.matched), snakemake.output.matched_predictions, float_format=None)


run(snakemake, main)
