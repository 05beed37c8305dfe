"""Step 7: external check on the matched cases -> matched_check.csv, per-case table, Figure 2."""

import numpy as np

from hybridtwin.io import files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper import residual
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.paper.tables import matched_summary
from hybridtwin.report import plots


def main(snakemake):
    p = snakemake.params
    matched = read_checked(snakemake.input.matched)
    support = read_checked(snakemake.input.support)
    X = matched[p.inputs].to_numpy(float)
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate)).predict(X)
    residual_pred = residual.load_model(snakemake.input.model).predict(X)
    summary, cases = matched_summary(
        matched[p.matched_measured], matched[p.matched_simulated], surrogate, residual_pred, in_support(support)
    )
    cases.insert(0, "in_support", in_support(support))
    cases.insert(0, "matched_row", np.arange(1, len(matched) + 1))
    files.write_csv(summary, snakemake.output.summary)
    files.write_csv(cases, snakemake.output.cases)

    predictions = read_checked(snakemake.input.predictions)
    inside = predictions[in_support(predictions)]
    residual_row = summary.iloc[0]
    files.save_figure(
        plots.residual_check(
            inside["residual_approx"],
            inside["pred_hybrid_oof"] - inside["pred_surrogate"],
            cases["true_residual"],
            cases["pred_residual"],
            {"r2": residual_row["r2"], "rmse": residual_row["rmse"]},
            p.unit,
        ),
        snakemake.output.figure,
    )


run(snakemake, main)
