"""results/diagnosis.md: what the simulation gets wrong, in words, with numbers and units."""

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.report import diagnosis_md as report


def main(snakemake):
    spec = files.read_json(snakemake.input.demo_spec) if snakemake.input.get("demo_spec") else None
    text = report.diagnosis_markdown(
        read_checked(snakemake.input.causes),
        files.read_json(snakemake.input.summary),
        read_checked(snakemake.input.gain),
        snakemake.params.target,
        snakemake.params.unit,
        spec,
        snakemake.params.figures,
    )
    with files.atomic_path(snakemake.output.report) as temporary:
        temporary.write_text(text)


run(snakemake, main)
