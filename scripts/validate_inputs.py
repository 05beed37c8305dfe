"""Check the user's three files and write checked copies for the later steps."""
import warnings

from hybridtwin import data, io
from hybridtwin.runner import run


def main(snakemake):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", data.DataWarning)
        frames = data.load_datasets(snakemake.params.settings)
    for warning in caught:
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    for name in ("doe", "production", "matched"):
        io.write_csv(frames[name], snakemake.output[name], float_format=None)  # exact round trip
    lines = [f"{name}: {len(frames[name])} rows, {frames[name].shape[1]} columns" for name in frames]
    lines += [f"WARNING: {warning.message}" for warning in caught]
    with io.atomic_path(snakemake.output.report) as temporary:
        temporary.write_text("\n".join(lines) + "\n")


run(snakemake, main)
