"""Diagnosis: rank candidate causes of the in-support approximate residuals; a figure per top cause."""

import logging

import numpy as np

from hybridtwin import diagnosis, pipeline
from hybridtwin.diagnosis import profiles
from hybridtwin.io import files
from hybridtwin.io.files import in_support
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.report import plots


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    residuals = files.read_checked(snakemake.input.residuals)
    settings = diagnosis.Settings.from_config(
        p.settings, folds=spec.folds, seed=spec.seed, unit=p.unit, n_jobs=spec.n_jobs, input_units=p.input_units
    )
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate))
    # only the in-support parts, which the diagnosis reads (on a long log, a sixth of it)
    production = files.read_checked(snakemake.input.production, rows=np.flatnonzero(in_support(residuals)))
    result = pipeline.diagnose(production, residuals, spec, settings, surrogate)
    logging.info("offset %.3f; chosen causes: %s", result.offset, [f.candidate.name for f in result.selected])
    files.write_csv(result.table, snakemake.output.table)
    # the ranking may use a sample of the in-support parts: the report says so
    summary = {**diagnosis.summary_dict(result), "n_in_support": int(in_support(residuals).sum())}
    files.write_json(summary, snakemake.output.summary)
    for rank, path in enumerate(snakemake.output.figures, start=1):
        if rank > len(result.table):
            files.save_figure(plots.placeholder(f"only {len(result.table)} candidate cause(s)"), path)
            continue
        row = result.table.iloc[rank - 1]
        profile = profiles.cause_profile(result, row["cause"], p.unit, seed=spec.seed, input_units=p.input_units)
        files.save_figure(plots.cause_profile(profile, rank, bool(row["significant"])), path)


run(snakemake, main)
