"""Benchmark: does tuning the residual model on a seeded sample of the in-support parts cost accuracy?

The Optuna study (the paper's Table 4) heads the demo run's critical path. ``tuning.max_rows`` lets it tune on
a seeded sample; this measures what a smaller sample costs. Per plant (the demo generator and every plant
family, 70,000 parts, committed seeds) the in-support parts of the first 70% of the log tune and fit the
paper's residual model, and the in-support parts of the last 30% score it: the hybrid's RMSE against the
noise-free truth, with hyperparameters tuned

- on every training part (no cap), with the plant's seed and with another one (sampler, folds and XGBoost: the
  spread that the study's own randomness gives), and
- on seeded samples of ``--sizes`` parts, and
- on every training part with the median pruner active from ``--prune-after`` finished trials on (default 5).

The final model is always fitted on every training part. Usage:

    python benchmarks/tuning_sample.py --plants 9 --seed 5 --sizes 3000 6000      # about 2 minutes a plant
    python benchmarks/tuning_sample.py --plants 9 --seed 6 --sizes --prune-after 1 2 --name tuning_pruning

Writes benchmarks/results/tuning_sample.csv (a row per plant and tuning) and tuning_sample.md (the summary).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
from results_files import write_results

from hybridtwin import demo
from hybridtwin.crossval import training_subset
from hybridtwin.demo import families
from hybridtwin.demo.harness import Run
from hybridtwin.io import config as configuration
from hybridtwin.models import registry
from hybridtwin.paper import tuning
from hybridtwin.paper.residual import make_model

OUT = Path(__file__).resolve().parent / "results"
N_PARTS = 70_000
TRAIN_SHARE = 0.7


def plant(index: int, seed: int):
    """The index-th plant: the demo first, then the families in turn; its name, case and draw (the seed of its
    run and its study: with one sampler seed for every plant, the studies' first trials would be the same
    parameters on every plant)."""
    draw = seed * 100 + index
    if index == 0:
        frames = demo.generate(replace(demo.DemoPlant(), seed=draw, n_production=N_PARTS))
        truth = frames["production_truth"]["truth_mm"].to_numpy(float)
        case = families.PlantCase(
            "demo", "", frames["doe"], frames["production"], truth, list(demo.INPUT_NAMES), demo.TARGET, None, 0.0
        )
        return f"demo seed {draw}", case, draw
    family = families.FAMILIES[(index - 1) % len(families.FAMILIES)]
    return f"{family} seed {draw}", families.draw_plant(family, draw, n_production=N_PARTS), draw


def rmse(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def measure(name: str, case, seed: int, sizes: list[int], n_trials: int, prune_after: list[int]) -> list[dict]:
    run = Run.of(case, seed)
    inputs = list(run.spec.inputs)
    X = case.production[inputs].to_numpy(float)
    residual, inside = run.residual, run.inside
    surrogate = run.residuals[registry.SURROGATE.column].to_numpy(float)
    cut = int(TRAIN_SHARE * len(X))
    train = np.flatnonzero(inside[:cut])
    test = cut + np.flatnonzero(inside[cut:])
    default = tuning.PRUNE_AFTER
    tunings = [("every part", train, seed, default), ("every part, other sampler seed", train, seed + 1, default)]
    tunings += [
        (f"sample of {n}", train[training_subset(len(train), n, seed)], seed, default) for n in sizes if n < len(train)
    ]
    tunings += [(f"pruning after {k} trials", train, seed, k) for k in prune_after if k != default]
    rows = []
    for label, tuned_rows, sampler_seed, prune in tunings:
        with tempfile.TemporaryDirectory() as folder:
            start = time.perf_counter()
            study = tuning.tune(
                X[tuned_rows],
                residual[tuned_rows],
                n_trials=n_trials,
                n_folds=run.spec.folds,
                seed=sampler_seed,
                storage=f"{folder}/journal.log",
                prune_after=prune,
            )
            seconds = time.perf_counter() - start
            params = tuning.best_params(study, n_trials=n_trials)
        model = make_model(params, seed).fit(X[train], residual[train])
        error = case.truth[test] - (surrogate[test] + model.predict(X[test]))
        rows.append(
            {
                "plant": name,
                "tuning": label,
                "tuned_on": len(tuned_rows),
                "trained_on": len(train),
                "tested_on": len(test),
                "tuning_s": round(seconds, 1),
                "rmse_vs_truth": rmse(error),
                **{f"param_{k}": v for k, v in params.items()},
            }
        )
        print(
            f"{name}: {label} ({len(tuned_rows)} parts, {seconds:.0f} s): {rows[-1]['rmse_vs_truth']:.4f}", flush=True
        )
    return rows


def summary(table: pd.DataFrame) -> str:
    reference = table[table["tuning"] == "every part"].set_index("plant")["rmse_vs_truth"]
    table = table.assign(ratio=table["rmse_vs_truth"] / table["plant"].map(reference))
    lines = [
        "Hybrid RMSE against the noise-free truth on the in-support parts of the last 30% of each log, over the",
        "same with hyperparameters tuned on every training part (the plant's sampler seed). Ratio 1.00: no cost.",
        "",
        "| tuning | plants | median ratio | worst ratio | best ratio | median tuning time [s] |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for label, group in table.groupby("tuning", sort=False):
        lines.append(
            f"| {label} | {len(group)} | {group['ratio'].median():.3f} | {group['ratio'].max():.3f} | "
            f"{group['ratio'].min():.3f} | {group['tuning_s'].median():.1f} |"
        )
    lines += ["", "Per plant:", "", table.pivot(index="plant", columns="tuning", values="ratio").round(3).to_markdown()]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plants", type=int, default=9)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--sizes", type=int, nargs="*", default=[3000, 6000])
    parser.add_argument(
        "--prune-after",
        type=int,
        nargs="*",
        default=[],
        help="also tune on every part with the median pruner active after this many finished trials",
    )
    parser.add_argument("--trials", type=int, default=configuration.section_defaults("tuning")["n_trials"])
    parser.add_argument("--name", default="tuning_sample")
    args = parser.parse_args()
    rows = []
    for index in range(args.plants):
        name, case, draw = plant(index, args.seed)
        rows += measure(name, case, draw, args.sizes, args.trials, args.prune_after)
        table = pd.DataFrame(rows)
        print(write_results(OUT, args.name, "Tuning on a sample of the in-support parts", table, summary(table)))


if __name__ == "__main__":
    main()
