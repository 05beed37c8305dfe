"""The closed loop on the demo: simulate the proposed points, add them to the DoE, rerun, compare.

    snakemake --cores 2 && python benchmarks/closed_loop.py

Three DoE extensions of the same size are compared, each in its own copy of the finished run:
the workflow's proposals (results/enrichment/proposed_simulations.csv), a space-filling one (the
maximin of 200 seeded Latin hypercubes in the physical limits: the union of the DoE's and the
production's ranges), and the k-means centres of the out-of-support parts. New rows are simulated
with the demo's simulator and its FE scatter. Reports per extension: the share of production in
support, the recommended model's truth-RMSE on the held-out rows (all of them, and out of support),
the jobs that reran and the run's wall time. The proposals are run twice: with the tuning study
starting warm from the earlier study's best trials (the workflow's default) and cold
(``tuning.warm_start: 0``), to measure what the warm start saves on an enriched DoE.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import machine_speed
import numpy as np
import pandas as pd
import yaml
from scipy.spatial.distance import cdist
from scipy.stats import qmc
from sklearn.cluster import KMeans

from hybridtwin import enrichment
from hybridtwin.demo import plant as demo
from hybridtwin.paper.gate import KNNSupportGate

ROOT = Path(__file__).resolve().parents[1]


def space_filling(doe: np.ndarray, low: np.ndarray, high: np.ndarray, n: int, seed: int) -> np.ndarray:
    """The Latin hypercube (of 200 seeded ones) whose points lie furthest from each other and the DoE."""
    scale = doe.std(axis=0, ddof=1)
    best, best_distance = None, -np.inf
    for draw in range(200):
        points = qmc.scale(qmc.LatinHypercube(d=doe.shape[1], seed=seed + draw).random(n), low, high)
        everything = np.vstack([doe, points]) / scale
        distances = cdist(points / scale, everything)
        distances[distances == 0] = np.inf
        if distances.min() > best_distance:
            best, best_distance = points, distances.min()
    return best


def kmeans_centres(doe: np.ndarray, production: np.ndarray, k: int, percentile: float, n: int, seed: int) -> np.ndarray:
    gate = KNNSupportGate(k=k, percentile=percentile).fit(doe)
    outside = production[~gate.predict(production)]
    z = gate.standardizer_.transform(outside)
    centres = KMeans(n_clusters=n, n_init=1, random_state=seed).fit(z).cluster_centers_
    return centres * gate.standardizer_.scale_ + gate.standardizer_.mean_


def run_extension(workdir: Path, config: dict, points: np.ndarray, inputs: list[str], target: str, seed: int) -> dict:
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        shutil.copytree(workdir / "results", folder / "results", symlinks=True)
        shutil.copytree(
            workdir / ".snakemake",
            folder / ".snakemake",
            symlinks=True,
            ignore=shutil.ignore_patterns("log", "incomplete", "locks", "conda", "singularity"),
        )
        # named, or the run would write a fresh results/config/ beside the copied run (a plant's own config file)
        (folder / "config.yaml").write_text(yaml.safe_dump({**config, "results_dir": "results"}))
        doe_path = folder / config["data"]["doe"]
        doe = pd.read_csv(doe_path)
        new = pd.DataFrame(points, columns=inputs)
        fe_scatter = float(config.get("demo", {}).get("fe_scatter_mm", 1.3))
        new[target] = demo.simulator(new) + np.random.default_rng(seed).normal(0.0, fe_scatter, len(new))
        pd.concat([doe, new[doe.columns]], ignore_index=True).round(4).to_csv(doe_path, index=False)
        start, start_stamp = time.perf_counter(), time.time()
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "snakemake",
                "-s",
                str(ROOT / "Snakefile"),
                "-d",
                str(folder),
                "--configfile",
                str(folder / "config.yaml"),
                "--cores",
                "2",
            ],
            capture_output=True,
            text=True,
        )
        seconds = time.perf_counter() - start
        if result.returncode != 0:
            raise SystemExit(result.stderr[-3000:])
        jobs = len(re.findall(r"^(?:local)?rule (?!all:)\w+:", result.stderr, re.M))
        # each rerun job's own wall time, from the benchmark files it rewrote
        rules = {
            path.stem: float(pd.read_csv(path, sep="\t")["s"].iloc[-1])
            for path in (folder / "results/benchmarks").glob("*.tsv")
            if path.stat().st_mtime >= start_stamp
        }
        return {
            **scores(folder),
            "jobs_rerun": jobs,
            "wall_seconds": seconds,
            "doe_rows": len(doe) + len(new),
            "rule_seconds": rules,
            "best_so_far": best_so_far(folder / "results/tuning/trials.csv"),
        }


def tuning_seconds(rule_seconds: dict) -> float:
    """The tuning's wall time: its workers' (rule tune_worker, one at a time here) and the rule that reads the study."""
    parts = [seconds for rule, seconds in rule_seconds.items() if rule.startswith(("tune_worker", "tune_residual"))]
    return sum(parts) if parts else float("nan")


def best_so_far(trials_csv: Path) -> np.ndarray:
    """The study's best CV RMSE after each trial, in trial order (pruned trials count, without a value)."""
    trials = pd.read_csv(trials_csv).sort_values("trial")
    values = trials["cv_rmse"].where(trials["state"] == "complete", np.inf).fillna(np.inf)
    return np.minimum.accumulate(values.to_numpy(float))


def trials_to_reach(curve: np.ndarray, target: float) -> str:
    reached = np.flatnonzero(curve <= target + 1e-12)
    return str(reached[0] + 1) if len(reached) else "not reached"


def scores(folder: Path) -> dict:
    table1 = pd.read_csv(folder / "results/tables/table1_datasets.csv").set_index("dataset")["size"]
    intervals = pd.read_csv(folder / "results/tables/prediction_intervals.csv")
    recommended = intervals[(intervals["model"] == "recommended") & (intervals["calibration"] == "by_region")]
    comparison = pd.read_csv(folder / "results/tables/peer_comparison.csv").set_index("model")
    return {
        "share_in_support": table1["Production in-support subset"] / table1["Production (all)"],
        "rmse_truth_all_heldout": float(recommended.set_index("region").loc["all", "rmse_truth_test"]),
        "rmse_truth_out_of_support": float(comparison.loc["recommended", "rmse_truth_out_of_support"]),
        "n_out_of_support_heldout": int(comparison.loc["recommended", "n_out_of_support"]),
    }


def require_up_to_date(workdir: Path, config: Path) -> None:
    """Stop unless the run to extend is up to date with this code: otherwise the rerun remakes the demo plant's
    files too (the package's code is a param of every step) and loses the added DoE rows without a word."""
    dry = subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(workdir), "-n"]
        + ["--configfile", str(config)],
        capture_output=True,
        text=True,
    )
    if "Nothing to be done" not in dry.stdout + dry.stderr:
        raise SystemExit(f"{workdir / 'results'} is not up to date with this code: run `snakemake --cores 2` first")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workdir", default=str(ROOT))
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    workdir = Path(args.workdir)
    config = yaml.safe_load(Path(args.config).read_text())
    require_up_to_date(workdir, Path(args.config))
    print(machine_speed.line(), flush=True)
    inputs, target = list(config["columns"]["inputs"]), config["columns"]["target"]
    gate = config.get("gate", {})
    k, percentile = int(gate.get("k", 5)), float(gate.get("percentile", 95))
    doe = pd.read_parquet(workdir / "results/data/doe.parquet")[inputs].to_numpy(float)
    production = pd.read_parquet(workdir / "results/data/production.parquet")[inputs].to_numpy(float)
    proposals = pd.read_csv(workdir / "results/enrichment/proposed_simulations.csv")[inputs].to_numpy(float)
    n = len(proposals)
    low, high = enrichment.physical_limits(doe, production, 0.05)
    extensions = {
        "proposals": proposals,
        "space-filling (maximin LHS)": space_filling(doe, low, high, n, args.seed),
        "k-means of out-of-support parts": kmeans_centres(doe, production, k, percentile, n, args.seed),
    }
    rows = [
        {
            "extension": "none (today's DoE)",
            **scores(workdir),
            "jobs_rerun": 0,
            "wall_seconds": 0.0,
            "doe_rows": len(doe),
        }
    ]
    for name, points in extensions.items():
        rows.append({"extension": name, **run_extension(workdir, config, points, inputs, target, args.seed)})
        print({k: v for k, v in rows[-1].items() if k not in ("rule_seconds", "best_so_far")}, flush=True)
    cold_config = {**config, "tuning": {**config.get("tuning", {}), "warm_start": 0}}
    cold = run_extension(workdir, cold_config, proposals, inputs, target, args.seed)
    print(f"\n{n} points added to a {len(doe)}-run DoE\n")
    print(
        "| DoE extension | DoE rows | in support | recommended vs truth, held-out rows | same, out of support "
        "(held-out rows left out) | jobs rerun | wall time [s] |\n|---|---:|---:|---:|---:|---:|---:|"
    )
    for row in rows:
        print(
            f"| {row['extension']} | {row['doe_rows']} | {row['share_in_support']:.1%} | "
            f"{row['rmse_truth_all_heldout']:.2f} | {row['rmse_truth_out_of_support']:.2f} "
            f"({row['n_out_of_support_heldout']:,}) | {row['jobs_rerun']} | {row['wall_seconds']:.0f} |"
        )
    print("\nThe jobs that reran after adding the proposals, with their wall time [s] (benchmark files):\n")
    print("| rule | wall time [s] |\n|---|---:|")
    for rule, seconds in sorted(rows[1]["rule_seconds"].items(), key=lambda item: -item[1]):
        print(f"| {rule} | {seconds:.1f} |")
    warm = rows[1]
    print(
        f"\nThe tuning study of the rerun after adding the proposals ({config.get('tuning', {}).get('n_trials', 25)} "
        "trials, same seed), warm against cold start:\n"
    )
    print(
        "| tuning study | best CV RMSE | trials to reach the cold study's best "
        "| tuning wall time (tune_worker, tune_residual) [s] | workflow rerun wall time [s] |\n"
        "|---|---:|---:|---:|---:|"
    )
    for name, run in (("cold (`tuning.warm_start: 0`)", cold), ("warm (the earlier study's best trials first)", warm)):
        print(
            f"| {name} | {run['best_so_far'][-1]:.4f} | {trials_to_reach(run['best_so_far'], cold['best_so_far'][-1])} "
            f"| {tuning_seconds(run['rule_seconds']):.1f} | {run['wall_seconds']:.0f} |"
        )


if __name__ == "__main__":
    main()
