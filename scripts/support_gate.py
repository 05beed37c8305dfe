"""Steps 1 and 2: the inputs standardized with DoE statistics only; the kNN support gate, its distance and
in_support for every production row."""

from hybridtwin import pipeline
from hybridtwin.io import data, files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.report import plots


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    doe, production = (files.read_checked(snakemake.input[name], spec.inputs) for name in ("doe", "production"))
    found = pipeline.support(doe, production, spec, p.k, p.percentile)
    files.write_json(found.gate.standardizer_.to_dict(), snakemake.output.standardization)
    files.write_csv(found.gate.standardizer_.table(), snakemake.output.standardization_table)
    data.check_support(
        found.table["in_support"].to_numpy(), doe, production, spec.inputs, p.paths, found.gate.threshold_
    )
    files.write_json(found.gate.to_dict(), snakemake.output.model)
    files.write_table(found.table, snakemake.output.production)
    files.save_figure(
        plots.support_distances(
            found.gate.doe_distances_, found.table["knn_distance"].to_numpy(), found.gate.threshold_, p.percentile
        ),
        snakemake.output.figure,
    )


run(snakemake, main)
