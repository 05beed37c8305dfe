"""Every table and the diagnosis in words as an HTML page of the report."""

from pathlib import Path

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.report import pages


def main(snakemake):
    for page, title in snakemake.params.titles.items():
        source = snakemake.input[page]
        if source.endswith(".md"):
            text = pages.markdown_page(Path(source).read_text(), title, source)
        else:
            text = pages.table_page(
                read_checked(source), title, source, snakemake.params.unit, snakemake.params.columns
            )
        with files.atomic_path(snakemake.output[page]) as temporary:
            temporary.write_text(text)


run(snakemake, main)
