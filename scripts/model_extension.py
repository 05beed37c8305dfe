"""Extend the physics side with the diagnosed causes; measure the gain in and out of the support."""

import numpy as np
import pandas as pd

from hybridtwin import pipeline
from hybridtwin.answers.regions import calibration_rows
from hybridtwin.crossval import capped_note, written_splits
from hybridtwin.diagnosis import extension
from hybridtwin.diagnosis.causes import Term
from hybridtwin.io import files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import demo_truth, run, spec_of
from hybridtwin.paper import residual


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    residuals = read_checked(snakemake.input.residuals)
    matched = read_checked(snakemake.input.matched)
    terms = tuple(Term.from_dict(c) for c in files.read_json(snakemake.input.summary)["selected"])
    # the inputs and the causes' columns: on a long log, not every column of it
    columns = [*spec.inputs, *sorted(extension.DiscrepancyExtension(terms).columns - set(spec.inputs))]
    parts = pipeline.extension_parts(
        read_checked(snakemake.input.production, columns),
        residuals,
        read_checked(snakemake.input.hybrid, pipeline.HYBRID_FOR_EXTENSION),
    )
    # the very split of the hybrid's out-of-fold predictions (rule residual_model writes each row's fold)
    splits = written_splits(read_checked(snakemake.input.hybrid_folds), np.flatnonzero(parts.inside))
    # the blocks that calibrate the intervals choose whether the extended hybrid stands out of the support
    choosing = calibration_rows(len(residuals), p.blocks)
    fitting = pipeline.extension_fitting(spec, files.read_json(snakemake.input.best)["params"])
    matched_cases = (matched, read_checked(snakemake.input.matched_cases))
    result = pipeline.extend(parts, terms, fitting, splits, choosing, matched_cases)
    truth = demo_truth(snakemake.input)
    table = extension.gain_table(
        residuals["measured"],
        result.scored,
        parts.inside,
        matched[p.matched_measured],
        result.matched,
        *truth,
        test=~choosing,
    )
    table["evaluated_on"] += capped_note(spec.max_train_rows, int(in_support(residuals).sum()))
    files.write_csv(table, snakemake.output.table)
    files.write_json(result.models.stored(), snakemake.output.extension)
    residual.save_model(result.models.remainder, snakemake.output.remainder, spec.inputs)
    files.write_table(result.production, snakemake.output.predictions)
    files.write_csv(pd.DataFrame(result.matched), snakemake.output.matched_predictions, float_format=None)


run(snakemake, main)
