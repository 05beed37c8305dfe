"""Step 4: surrogate predictions and approximate residuals r = measured - y_FEM_hat for every production row."""

import pandas as pd

from hybridtwin import files
from hybridtwin.files import read_checked
from hybridtwin.runner import run
from hybridtwin.surrogate import GPRSurrogate


def main(snakemake):
    production = read_checked(snakemake.input.production)
    support = read_checked(snakemake.input.support)
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate))
    mean, std = surrogate.predict(production[snakemake.params.inputs], return_std=True)
    measured = production[snakemake.params.target].to_numpy(float)
    files.write_csv(
        pd.DataFrame(
            {
                "measured": measured,
                "pred_surrogate": mean,
                "pred_surrogate_std": std,
                "residual_approx": measured - mean,
                "in_support": support["in_support"],
            }
        ),
        # full precision: later rules add to these values, and the frozen predictor must give the same sums
        snakemake.output.residuals,
        float_format=None,
    )


run(snakemake, main)
