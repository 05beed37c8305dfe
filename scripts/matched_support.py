"""The matched cases' distance to the DoE and their in_support, with the workflow's gate."""

from hybridtwin.io import data, files
from hybridtwin.io.runner import run
from hybridtwin.paper.gate import KNNSupportGate


def main(snakemake):
    matched = files.read_checked(snakemake.input.matched)
    gate = KNNSupportGate.from_dict(files.read_json(snakemake.input.gate))
    support = gate.support_table(matched[snakemake.params.inputs])
    data.warn_matched_outside(support["in_support"].to_numpy(), snakemake.params.paths)
    files.write_csv(support, snakemake.output.support)


run(snakemake, main)
