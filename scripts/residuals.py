"""Step 4: surrogate predictions and approximate residuals r = measured - y_FEM_hat for every production row."""

from hybridtwin import pipeline
from hybridtwin.io import files
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper.surrogate import GPRSurrogate


def main(snakemake):
    spec = spec_of(snakemake)
    production = files.read_checked(snakemake.input.production, [*spec.inputs, spec.target])
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate))
    inside = files.read_checked(snakemake.input.support, ["in_support"])["in_support"]
    # full precision: later rules add to these values, and the frozen predictor must give the same sums
    files.write_table(
        pipeline.residuals(surrogate, production, spec, inside), snakemake.output.residuals, float_format=None
    )


run(snakemake, main)
