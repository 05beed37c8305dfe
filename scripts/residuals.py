"""Step 4: surrogate predictions and approximate residuals r = measured - y_FEM_hat for every production row."""

from hybridtwin import files, residual
from hybridtwin.files import read_checked
from hybridtwin.runner import run
from hybridtwin.surrogate import GPRSurrogate


def main(snakemake):
    production = read_checked(snakemake.input.production, [*snakemake.params.inputs, snakemake.params.target])
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate))
    residuals = residual.approximate_residuals(surrogate, production, snakemake.params.inputs, snakemake.params.target)
    residuals["in_support"] = read_checked(snakemake.input.support, ["in_support"])["in_support"]
    # full precision: later rules add to these values, and the frozen predictor must give the same sums
    files.write_csv(residuals, snakemake.output.residuals, float_format=None)


run(snakemake, main)
