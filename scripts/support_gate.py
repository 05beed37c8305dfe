"""Step 2: kNN support gate; distance and in_support for every production row."""

from hybridtwin import data, files, plots
from hybridtwin.gate import DoEStandardizer, KNNSupportGate
from hybridtwin.runner import run


def main(snakemake):
    inputs = snakemake.params.inputs
    doe, production = (files.read_checked(snakemake.input[name], inputs) for name in ("doe", "production"))
    standardizer = DoEStandardizer.from_dict(files.read_json(snakemake.input.standardization))
    gate = KNNSupportGate(k=snakemake.params.k, percentile=snakemake.params.percentile, standardizer=standardizer).fit(
        doe[inputs]
    )
    support = gate.support_table(production[inputs])
    distance = support["knn_distance"].to_numpy()
    data.check_support(
        support["in_support"].to_numpy(), doe, production, inputs, snakemake.params.paths, gate.threshold_
    )
    files.write_json(gate.to_dict(), snakemake.output.model)
    files.write_csv(support, snakemake.output.production)
    files.save_figure(
        plots.support_distances(gate.doe_distances_, distance, gate.threshold_, snakemake.params.percentile),
        snakemake.output.figure,
    )


run(snakemake, main)
