"""Benchmark: where the GP discrepancy's likelihood search starts, against the plain scikit-learn use (issue 33).

On each plant of the families generator (one draw per family), the in-memory steps (:mod:`hybridtwin.demo.harness`)
give the gate, the surrogate and the approximate residuals; then three GP discrepancies are fitted on the same
in-support parts and scored alike (out of period on the parts they trained on, the final model elsewhere):

- ``now``: the workflow's GP discrepancy, its search starting from a noise of the residual's whole spread;
- ``before``: the same, its search starting from the simulator's small noise (1e-2 in normalized units), as
  the surrogate's does;
- ``plain``: scikit-learn's documented use (``benchmarks/plain_baselines.py``).

Each is scored against the noise-free truth on the test blocks (the odd blocks of consecutive parts), in and out of
the support, as truth-RMSE over the noise. Usage:

    python benchmarks/gp_discrepancy_start.py --seed 22      # about 2 minutes a plant on 2 cores, alone

Writes benchmarks/results/gp_discrepancy_start_seed<N>.md and .csv.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd
from plain_baselines import PLAIN_GP, plain_baselines
from results_files import write_results

from hybridtwin.crossval import in_support_out_of_period
from hybridtwin.demo import families, harness
from hybridtwin.io.config import section_defaults
from hybridtwin.models import registry
from hybridtwin.models.gp_discrepancy import GPDiscrepancy
from hybridtwin.paper.surrogate import GPRSurrogate

OUT = Path(__file__).resolve().parent / "results"
ONE_DRAW_PARTS = 500  # the single draw's parts before there were several draws (gp_discrepancy_draws.py)
TRUTH_RMSE = "Truth-RMSE over the noise on the test blocks (odd blocks of consecutive parts), one plant per family"


class SmallNoiseStart(GPRSurrogate):
    """The surrogate's GP as the discrepancy had it: its search starting from a small noise, whatever it is given."""

    def __init__(self, nu=2.5, n_restarts=3, random_state=0, length_scale_bounds=(1e-2, 1e4), noise_bounds=(1e-6, 1.0),
                 noise_start=1e-2):  # fmt: skip
        super().__init__(nu, n_restarts, random_state, length_scale_bounds, noise_bounds, 1e-2)


class Before(GPDiscrepancy):
    surrogate_class = SmallNoiseStart


def honest(model, run: harness.Run, case) -> np.ndarray:
    """The model's target prediction per part: out of period in support (as the workflow scores it), its final fit
    elsewhere."""
    residuals = run.residuals
    inside = np.flatnonzero(residuals["in_support"].to_numpy(bool))
    X = case.production[list(case.inputs)]
    surrogate = residuals[registry.SURROGATE.column].to_numpy(float)
    model.fit(X.iloc[inside], residuals["residual_approx"].to_numpy(float)[inside])
    out = model.predict(X) + surrogate
    out[inside] = in_support_out_of_period(model, X.iloc[inside], model.training_rows_, 5) + surrogate[inside]
    return out


def score(prediction, truth, noise: float, rows) -> float:
    return float(np.sqrt(np.mean((prediction[rows] - truth[rows]) ** 2)) / noise) if rows.any() else float("nan")


def plant_rows(family: str, seed: int) -> list[dict]:
    case = families.draw_plant(family, seed)
    run = harness.Run.of(case, 0)
    n_fit = section_defaults("peers")["gp_n_fit"]
    one = {"n_hyper": ONE_DRAW_PARTS, "n_fit": n_fit, "n_draws": 1}  # the search as measured, before several draws
    models = {"now": GPDiscrepancy(**one), "before": Before(**one)}
    predictions = {name: honest(model, run, case) for name, model in models.items()}
    predictions["plain"] = plain_baselines(case.doe, case.production, run.residuals, case.inputs, case.target, 0)[
        PLAIN_GP
    ]
    test = ~run.choosing
    regions = {"in support": run.inside & test, "out of support": ~run.inside & test}
    return [
        {"plant": f"{family} seed {seed}", "model": name, "region": region, "truth_rmse_over_noise": value}
        for name, p in predictions.items()
        for region, rows in regions.items()
        for value in [score(p, case.truth, case.noise, rows)]
    ]


def summary(table: pd.DataFrame) -> list[str]:
    wide = table.pivot_table(index=["region", "plant"], columns="model", values="truth_rmse_over_noise")
    lines = [
        "| region | plant | before | now | plain | now / plain | before / plain |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for (region, plant), row in wide.iterrows():
        lines.append(
            f"| {region} | {plant} | {row['before']:.3f} | {row['now']:.3f} | {row['plain']:.3f} | "
            f"{row['now'] / row['plain']:.2f} | {row['before'] / row['plain']:.2f} |"
        )
    lines += ["", "| region | median now / plain | worst now / plain | median before / plain | worst before / plain |"]
    lines += ["|---|---:|---:|---:|---:|"]
    for region, part in wide.groupby(level="region"):
        now, before = part["now"] / part["plain"], part["before"] / part["plain"]
        lines.append(
            f"| {region} | {now.median():.2f} | {now.max():.2f} | {before.median():.2f} | {before.max():.2f} |"
        )
    return lines


def per_family(rows_of, names: list[str]) -> pd.DataFrame:
    """The rows of each family's plant (``rows_of(family)``), each plant's time printed."""
    rows = []
    for family in names:
        start = time.perf_counter()
        rows += rows_of(family)
        print(f"{family}: {time.perf_counter() - start:.0f} s", flush=True)
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=22)
    parser.add_argument("--families", nargs="+", default=list(families.FAMILIES))
    args = parser.parse_args()
    table = per_family(lambda family: plant_rows(family, args.seed), args.families)
    summary_text = "\n".join([TRUTH_RMSE + ".", "", *summary(table)])
    title = "The GP discrepancy's likelihood search: where it starts"
    print(write_results(OUT, f"gp_discrepancy_start_seed{args.seed}", title, table, summary_text))


if __name__ == "__main__":
    main()
