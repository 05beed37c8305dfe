"""Extend the physics side with the diagnosed causes; measure the gain in and out of the support."""
import numpy as np
import pandas as pd

from hybridtwin import extension, io, residual
from hybridtwin.data import read_checked
from hybridtwin.extension import Cause
from hybridtwin.runner import run
from hybridtwin.validation import folds


def main(snakemake):
    p = snakemake.params
    production = read_checked(snakemake.input.production)
    residuals = read_checked(snakemake.input.residuals)
    matched = read_checked(snakemake.input.matched)
    causes = tuple(Cause.from_dict(c) for c in io.read_json(snakemake.input.summary)["selected"])
    params = io.read_json(snakemake.input.best)["params"]
    inside = residuals["in_support"].astype(bool).to_numpy()
    rows = np.flatnonzero(inside)
    X = production[p.inputs].to_numpy(float)
    r = residuals["residual_approx"].to_numpy(float)
    surrogate = residuals["pred_surrogate"].to_numpy(float)

    def make_xgb():
        return residual.make_model(params, p.seed, snakemake.threads)

    # final models on all in-support rows; out-of-fold corrections on the same folds as the residual CV
    models = extension.fit_models(production.iloc[rows], X[rows], r[rows], causes, make_xgb)
    extended = models.extension.predict(production)
    extended_hybrid = extended + models.remainder.predict(X)
    oof_ext, oof_ext_hyb = extension.cross_validated(production.iloc[rows], X[rows], r[rows], causes, make_xgb,
                                                     folds(len(rows), p.folds, residual.evaluation_seed(p.seed)))
    extended_cv, extended_hybrid_cv = extended.copy(), extended_hybrid.copy()
    extended_cv[rows], extended_hybrid_cv[rows] = oof_ext, oof_ext_hyb
    hybrid = read_checked(snakemake.input.hybrid)
    predictions = {"surrogate": surrogate, "hybrid": hybrid["pred_hybrid_oof"].to_numpy(float),
                   "extended": surrogate + extended_cv, "extended_hybrid": surrogate + extended_hybrid_cv}
    cases = read_checked(snakemake.input.matched_cases)
    if len(cases) != len(matched):
        raise RuntimeError(f"{len(cases)} matched-case predictions for {len(matched)} matched cases")
    surrogate_m = cases["pred_surrogate"].to_numpy(float)
    extended_m = models.extension.predict(matched)
    matched_predictions = {"surrogate": surrogate_m, "hybrid": cases["pred_hybrid"].to_numpy(float),
                           "extended": surrogate_m + extended_m,
                           "extended_hybrid": surrogate_m + extended_m + models.remainder.predict(matched[p.inputs].to_numpy(float))}
    truth = noise = None
    if snakemake.input.get("truth"):
        truth = read_checked(snakemake.input.truth)["truth_mm"].to_numpy(float)
        noise = float(io.read_json(snakemake.input.demo_spec)["noise_mm"])
    table = extension.gain_table(residuals["measured"], predictions, inside, matched[p.matched_measured],
                                 matched_predictions, truth, noise)
    io.write_csv(table, snakemake.output.table)
    io.write_json(models.extension.to_dict(), snakemake.output.extension)
    residual.save_model(models.remainder, snakemake.output.remainder)
    io.write_csv(pd.DataFrame({"pred_extended": surrogate + extended, "pred_extended_hybrid": surrogate + extended_hybrid}),
                 snakemake.output.predictions)


run(snakemake, main)
