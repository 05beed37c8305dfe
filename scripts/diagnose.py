"""Diagnosis: rank candidate causes of the in-support approximate residuals; a figure per top cause."""

import logging

from hybridtwin import diagnosis, files, plots, profiles
from hybridtwin.files import in_support, read_checked
from hybridtwin.runner import run
from hybridtwin.surrogate import surrogate_latent_std


def main(snakemake):
    p = snakemake.params
    production = read_checked(snakemake.input.production)
    residuals = read_checked(snakemake.input.residuals)
    inside = in_support(residuals)
    surrogate_std = surrogate_latent_std(
        residuals.loc[inside, "pred_surrogate_std"], files.read_json(snakemake.input.surrogate)["noise_std"]
    )
    settings = diagnosis.Settings.from_config(
        p.settings, folds=p.folds, seed=p.seed, unit=p.unit, n_jobs=snakemake.threads, input_units=p.input_units
    )
    result = diagnosis.diagnose(
        production.loc[inside].drop(columns=[p.target]),
        residuals.loc[inside, "residual_approx"],
        p.inputs,
        [p.target],
        settings,
        surrogate_std=surrogate_std,
    )
    logging.info("offset %.3f; chosen causes: %s", result.offset, [f.candidate.name for f in result.selected])
    files.write_csv(result.table, snakemake.output.table)
    # the ranking may use a sample of the in-support parts: the report says so
    files.write_json({**diagnosis.summary_dict(result), "n_in_support": int(inside.sum())}, snakemake.output.summary)
    for rank, path in enumerate(snakemake.output.figures, start=1):
        if rank > len(result.table):
            files.save_figure(plots.placeholder(f"only {len(result.table)} candidate cause(s)"), path)
            continue
        row = result.table.iloc[rank - 1]
        profile = profiles.cause_profile(result, row["cause"], p.unit, seed=p.seed, input_units=p.input_units)
        files.save_figure(plots.cause_profile(profile, rank, bool(row["significant"])), path)


run(snakemake, main)
