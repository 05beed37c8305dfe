"""Benchmark: how much the GP discrepancy's answer depends on its draw of hyperparameter parts (issue 33).

On each plant of the families generator (one draw per family), the in-memory steps (:mod:`hybridtwin.demo.harness`)
give the gate, the surrogate and the approximate residuals once; then the GP discrepancy is fitted with three model
seeds (each another draw of its ``gp_n_hyper`` hyperparameter parts, and of its ``gp_n_fit`` training parts), with
one draw of 500 parts (the method before) and with ``gp_n_draws`` draws of ``--draw-parts`` parts (default
``gp_n_hyper``), beside the plain
scikit-learn use (``benchmarks/plain_baselines.py``). Each is scored against the noise-free truth on the test blocks
(the odd blocks of consecutive parts), in and out of the support, as truth-RMSE over the noise. Usage:

    python benchmarks/gp_discrepancy_draws.py --seed 23      # a few minutes a plant on 2 cores, alone

Writes benchmarks/results/gp_discrepancy_draws_seed<N>_of<parts>.md and .csv.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from gp_discrepancy_start import ONE_DRAW_PARTS, TRUTH_RMSE, honest, per_family, score
from plain_baselines import PLAIN_GP, plain_baselines
from results_files import write_results

from hybridtwin.demo import families, harness
from hybridtwin.io.config import section_defaults
from hybridtwin.models.gp_discrepancy import GPDiscrepancy

OUT = Path(__file__).resolve().parent / "results"
MODEL_SEEDS = (0, 1, 2)


def plant_rows(family: str, seed: int, draw_parts: int) -> list[dict]:
    """``draw_parts``: the parts of each of the several draws; the single draw has ONE_DRAW_PARTS (the method
    before)."""
    case = families.draw_plant(family, seed)
    run = harness.Run.of(case, 0)
    sizes = section_defaults("peers")
    n_fit, n_draws = sizes["gp_n_fit"], sizes["gp_n_draws"]
    test = ~run.choosing
    regions = {"in support": run.inside & test, "out of support": ~run.inside & test}
    plain = plain_baselines(case.doe, case.production, run.residuals, case.inputs, case.target, 0)[PLAIN_GP]
    predictions = {("plain", 0): plain}
    for model_seed in MODEL_SEEDS:
        for draws, parts in ((1, ONE_DRAW_PARTS), (n_draws, draw_parts)):
            model = GPDiscrepancy(n_hyper=parts, n_fit=n_fit, n_draws=draws, random_state=model_seed)
            name = "1 draw" if draws == 1 else f"{draws} draws of {parts}"
            predictions[(name, model_seed)] = honest(model, run, case)
    return [
        {
            "plant": f"{family} seed {seed}",
            "model": name,
            "model_seed": model_seed,
            "region": region,
            "truth_rmse_over_noise": score(p, case.truth, case.noise, rows),
        }
        for (name, model_seed), p in predictions.items()
        for region, rows in regions.items()
    ]


def summary(table: pd.DataFrame) -> list[str]:
    lines = [
        "| region | plant | plain | "
        + " | ".join(f"{name}: seeds {', '.join(map(str, MODEL_SEEDS))} (worst / best)" for name in _variants(table))
        + " |"
    ]
    lines += ["|---|---|---:|" + "---|" * len(_variants(table))]
    spread = {}
    for (region, plant), part in table.groupby(["region", "plant"]):
        values = part.set_index(["model", "model_seed"])["truth_rmse_over_noise"]
        cells = []
        for name in _variants(table):
            scores = values[name]
            spread.setdefault((region, name), []).append(
                {
                    "spread": scores.max() / scores.min(),
                    "median_over_plain": scores.median() / values[("plain", 0)],
                    "worst_over_plain": scores.max() / values[("plain", 0)],
                }
            )
            cells.append(", ".join(f"{v:.3f}" for v in scores) + f" ({scores.max() / scores.min():.2f})")
        lines.append(f"| {region} | {plant} | {values[('plain', 0)]:.3f} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "| region | variant | median worst / best over the seeds | largest | median of (seeds' median / plain) "
        "| worst seed / plain, worst plant |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for (region, name), rows in spread.items():
        frame = pd.DataFrame(rows)
        lines.append(
            f"| {region} | {name} | {frame['spread'].median():.2f} | {frame['spread'].max():.2f} | "
            f"{frame['median_over_plain'].median():.2f} | {frame['worst_over_plain'].max():.2f} |"
        )
    return lines


def _variants(table: pd.DataFrame) -> list[str]:
    return [name for name in dict.fromkeys(table["model"]) if name != "plain"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=23)
    parser.add_argument("--families", nargs="+", default=list(families.FAMILIES))
    parser.add_argument("--draw-parts", type=int, help="parts of each of the several draws (default gp_n_hyper)")
    args = parser.parse_args()
    args.draw_parts = args.draw_parts or section_defaults("peers")["gp_n_hyper"]
    table = per_family(lambda family: plant_rows(family, args.seed, args.draw_parts), args.families)
    text = "; per variant the three model seeds' scores and the worst over the best."
    summary_text = "\n".join([TRUTH_RMSE + text, "", *summary(table)])
    title = "The GP discrepancy: one draw of hyperparameter parts or several"
    print(write_results(OUT, f"gp_discrepancy_draws_seed{args.seed}_of{args.draw_parts}", title, table, summary_text))


if __name__ == "__main__":
    main()
