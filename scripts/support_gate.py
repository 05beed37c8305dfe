"""Step 2: kNN support gate; distance and in_support for every production row and matched case."""
import pandas as pd

from hybridtwin import data, io, plots
from hybridtwin.gate import DoEStandardizer, KNNSupportGate
from hybridtwin.runner import run


def main(snakemake):
    inputs = snakemake.params.inputs
    doe, production, matched = (data.read_checked(snakemake.input[name]) for name in ("doe", "production", "matched"))
    standardizer = DoEStandardizer.from_dict(io.read_json(snakemake.input.standardization))
    gate = KNNSupportGate(k=snakemake.params.k, percentile=snakemake.params.percentile,
                          standardizer=standardizer).fit(doe[inputs])
    supports = {}
    for name, frame in (("production", production), ("matched", matched)):
        distance = gate.distance(frame[inputs])
        supports[name] = pd.DataFrame({"knn_distance": distance, "in_support": distance <= gate.threshold_})
    data.check_support(supports["production"]["in_support"].to_numpy(), supports["matched"]["in_support"].to_numpy(),
                       doe, production, matched, inputs, snakemake.params.paths, gate.threshold_)
    io.write_json(gate.to_dict(), snakemake.output.model)
    io.write_csv(supports["production"], snakemake.output.production)
    io.write_csv(supports["matched"], snakemake.output.matched)
    io.save_figure(plots.support_distances(gate.doe_distances_, supports["production"]["knn_distance"],
                                           gate.threshold_, snakemake.params.percentile), snakemake.output.figure)


run(snakemake, main)
