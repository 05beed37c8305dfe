"""Warm against cold start of the tuning study on new data.

    snakemake --cores 2 && python benchmarks/warm_start.py

The earlier study is run on the in-support residuals of the run's first 90% of production rows
(the log before its newest parts); the new data are all of them. On the new data, a cold study
(an empty journal) and a warm one (the earlier study's best ``--warm`` trials first) run the same
number of trials with the same seed. Reports the best CV RMSE each reaches, the trials the warm
study needs to reach the cold study's best, and their wall times.
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from hybridtwin.paper import tuning

ROOT = Path(__file__).resolve().parents[1]


def best_so_far(study) -> np.ndarray:
    values = [t.value if t.value is not None else np.inf for t in sorted(study.trials, key=lambda t: t.number)]
    return np.minimum.accumulate(values)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    parser.add_argument("--results", default=str(ROOT / "results"))
    parser.add_argument("--trials", type=int, default=25)
    parser.add_argument("--warm", type=int, default=5)
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    config = yaml.safe_load(Path(args.config).read_text())
    inputs, seed, folds = (
        config["columns"]["inputs"],
        int(config.get("seed", 0)),
        int(config.get("cv", {}).get("folds", 5)),
    )
    production = pd.read_parquet(Path(args.results) / "data/production.parquet")
    residuals = pd.read_parquet(Path(args.results) / "residuals/production_residuals.parquet")
    inside = residuals["in_support"].astype(bool).to_numpy()
    X, y = production.loc[inside, inputs].to_numpy(float), residuals.loc[inside, "residual_approx"].to_numpy(float)
    earlier = np.flatnonzero(inside)[: int(0.9 * inside.sum())]
    rows = {"earlier": np.isin(np.flatnonzero(inside), earlier)}
    space = tuning.search_space(config.get("tuning", {}).get("search_space"))
    with tempfile.TemporaryDirectory() as folder:
        warm_journal, cold_journal = str(Path(folder) / "warm.log"), str(Path(folder) / "cold.log")
        tuning.tune(
            X[rows["earlier"]],
            y[rows["earlier"]],
            n_trials=args.trials,
            n_folds=folds,
            seed=seed,
            storage=warm_journal,
            space=space,
            n_jobs=2,
        )
        timings, studies = {}, {}
        for name, journal, warm in (("cold", cold_journal, 0), ("warm", warm_journal, args.warm)):
            start = time.perf_counter()
            studies[name] = tuning.tune(
                X,
                y,
                n_trials=args.trials,
                n_folds=folds,
                seed=seed,
                storage=journal,
                space=space,
                n_jobs=2,
                warm_start=warm,
            )
            timings[name] = time.perf_counter() - start
        cold, warm = best_so_far(studies["cold"]), best_so_far(studies["warm"])
    reached = int(np.argmax(warm <= cold[-1]) + 1) if (warm <= cold[-1]).any() else None
    print(f"{len(y):,} in-support parts ({rows['earlier'].sum():,} in the earlier study), {args.trials} trials each\n")
    print("| study on the new data | best CV RMSE | trials to reach the cold study's best | wall time [s] |")
    print("|---|---:|---:|---:|")
    print(f"| cold (empty journal) | {cold[-1]:.4f} | {int(np.argmax(cold <= cold[-1]) + 1)} | {timings['cold']:.0f} |")
    print(
        f"| warm (earlier study's best {args.warm} first) | {warm[-1]:.4f} | {reached if reached else 'not reached'} "
        f"| {timings['warm']:.0f} |"
    )


if __name__ == "__main__":
    main()
