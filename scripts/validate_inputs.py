"""Check one of the user's files (with what it is checked against) and write its checked copy."""

import warnings

from hybridtwin.io import data, files
from hybridtwin.io.reading import DataWarning
from hybridtwin.io.runner import run


def main(snakemake):
    role = snakemake.wildcards.role
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DataWarning)
        frame = data.load_datasets(snakemake.params.settings, roles=(role,))[role]
    for warning in caught:
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    files.write_table(frame, snakemake.output.table, float_format=None)  # every value kept
    lines = [f"{role}: {len(frame)} rows, {frame.shape[1]} columns"]
    lines += [f"WARNING: {warning.message}" for warning in caught]
    with files.atomic_path(snakemake.output.report) as temporary:
        temporary.write_text("\n".join(lines) + "\n")


run(snakemake, main)
