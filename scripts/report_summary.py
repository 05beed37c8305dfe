"""The report's first page: the answer in words and numbers (results/report/summary.rst)."""

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.report.summary import summary_rst


def main(snakemake):
    found = {
        "datasets": read_checked(snakemake.input.datasets),
        "diagnosis": files.read_json(snakemake.input.diagnosis),
        "gain": read_checked(snakemake.input.gain),
        "intervals": read_checked(snakemake.input.intervals),
        "ranking": files.read_json(snakemake.input.manifest)["intervals"]["ranking"],
        "proposals": read_checked(snakemake.input.proposals),
    }
    text = summary_rst(found, snakemake.params.target, snakemake.params.unit)
    with files.atomic_path(snakemake.output.summary) as temporary:
        temporary.write_text(text)


run(snakemake, main)
