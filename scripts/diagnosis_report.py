"""results/diagnosis.md: what the simulation gets wrong, in words, with numbers and units."""
from hybridtwin import io, report
from hybridtwin.data import read_checked
from hybridtwin.runner import run


def main(snakemake):
    spec = io.read_json(snakemake.input.demo_spec) if snakemake.input.get("demo_spec") else None
    text = report.diagnosis_markdown(read_checked(snakemake.input.causes), io.read_json(snakemake.input.summary),
                                     read_checked(snakemake.input.gain), snakemake.params.target,
                                     snakemake.params.unit, spec)
    with io.atomic_path(snakemake.output.report) as temporary:
        temporary.write_text(text)


run(snakemake, main)
