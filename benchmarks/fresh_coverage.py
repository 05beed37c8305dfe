"""Benchmark: do the intervals hold on the next production period, on plants of 3,000 to 70,000 parts?

For each plant (the demo generator and the other plant families, drawn with committed seeds), the log is the
first N parts and the fresh parts are the 8,000 that follow (the same plant, a later period: new coils, new
campaigns). The real workflow runs on the log (snakemake, a config of the user's kind); ``hybridtwin``'s frozen
predictor then answers the fresh parts, and each region's coverage of their measured values is counted with its
95% Clopper-Pearson interval, beside the trust verdicts and the daily check's verdict on the same parts
(``hybridtwin monitor``: the first part at which it says the plant no longer matches the models, if any), and
counted again on the parts before that alarm: after it the tool no longer vouches for its models. Usage:

    python benchmarks/fresh_coverage.py --plants 8 --seed 1          # about 2 minutes a plant, alone on 2 cores
    python benchmarks/fresh_coverage.py --plants 8 --seed 10 --keep runs/fresh10
    python benchmarks/fresh_coverage.py --replay runs/fresh10        # the intervals again with today's code

``--keep`` leaves each plant's workflow run and its fresh parts in the folder; ``--replay`` reruns only the
intervals' step (``prediction_intervals``) on the kept runs, and counts the coverage again: a change of the
intervals' rule measured in a minute a plant, on the same models.

Writes benchmarks/results/fresh_coverage.csv (a row per plant and region) and fresh_coverage.md (the summary).
Goal (issue 29): in support within nominal +-2 points, out of support at least nominal - 2 in every region.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from results_files import write_results

from hybridtwin import demo
from hybridtwin.answers.coverage import clopper_pearson
from hybridtwin.answers.predictor import Predictor
from hybridtwin.demo import families, structures
from hybridtwin.monitor import watch

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "results"
N_FRESH = 8000
SIZES = (3000, 8000, 20000, 70000)


STRUCTURE_KINDS = ("linear", "coil", "step", "product", "sigmoid", "none")


def plant(index: int, seed: int, generator: str = "families"):
    """The index-th plant: (name, DoE, log, fresh parts, inputs, target, its simulator), sizes cycling through
    SIZES; ``generator`` 'families': the demo's and the plant families' generators, 'structures': the randomized
    structures generator (other names, inputs, rhythms and simulators)."""
    n = SIZES[index % len(SIZES)]
    draw = seed * 100 + index
    if generator == "structures":
        kind = STRUCTURE_KINDS[index % len(STRUCTURE_KINDS)]
        case = structures.draw_structure_plant(kind, draw, n + N_FRESH)
        production, name = case.production, f"{kind} seed {draw}"
        return (
            name,
            case.doe,
            production.iloc[:n],
            production.iloc[n:].reset_index(drop=True),
            list(case.inputs),
            case.target,
            plant_simulator(case),
        )
    if index % 3 == 0:
        frames = demo.generate(replace(demo.DemoPlant(), seed=draw, n_production=n + N_FRESH))
        production, doe, simulate = frames["production"], frames["doe"], demo.simulator
        inputs, target, name = demo.INPUT_NAMES, demo.TARGET, f"demo seed {draw}"
    else:
        family = families.FAMILIES[index % len(families.FAMILIES)]
        case = families.draw_plant(family, draw, n_production=n + N_FRESH)
        production, doe, inputs, target = case.production, case.doe, case.inputs, case.target
        name, simulate = f"{family} seed {draw}", plant_simulator(case)
    return name, doe, production.iloc[:n], production.iloc[n:].reset_index(drop=True), list(inputs), target, simulate


def plant_simulator(case):
    """The plant's simulator on a frame of its own columns: a structures plant's own; the demo's for a family's
    plant, its columns renamed to the demo's."""
    if isinstance(case, structures.StructureCase):
        return case.simulator
    canonical = {name: key for key, name in case.names.items() if key in demo.INPUT_NAMES}
    return lambda frame: demo.simulator(frame[case.inputs].rename(columns=canonical))


def matched_cases(doe, log, inputs, target, rng, simulate) -> pd.DataFrame:
    """Seven plant trials re-simulated: the log's parts nearest the DoE's centre, the plant's simulator
    (``simulate`` on a frame of its columns) with its scatter."""
    centre = (log[inputs] - doe[inputs].mean()) / doe[inputs].std()
    rows = np.argsort((centre**2).sum(axis=1).to_numpy())[:7]
    cases = log.iloc[rows][inputs].reset_index(drop=True)
    cases["simulated"] = simulate(cases) + rng.normal(0, 1.3, len(cases))
    cases["measured"] = log.iloc[rows][target].to_numpy()
    return cases


def run_workflow(folder: Path, doe, log, matched, inputs, target, seed: int, env: dict | None = None) -> Path:
    """The workflow on a plant's files in ``folder``; ``env``: the environment of its processes (default: ours)."""
    for name, frame in (("doe", doe), ("production", log), ("matched", matched)):
        frame.to_csv(folder / f"{name}.csv", index=False)
    config = {
        "data": {name: str(folder / f"{name}.csv") for name in ("doe", "production", "matched")},
        "columns": {
            "inputs": inputs,
            "target": target,
            "matched_simulated": "simulated",
            "matched_measured": "measured",
        },
        "results_dir": str(folder / "results"),
        "seed": seed,
        "tuning": {"n_trials": 10},
    }
    (folder / "plant.yaml").write_text(yaml.safe_dump(config))
    command = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(folder)]
    command += ["--configfile", str(folder / "plant.yaml"), "--cores", "2", "--quiet"]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return folder / "results" / "models"


def coverage_rows(
    name: str, n_log: int, answers: pd.DataFrame, measured: np.ndarray, level: float, alarm_at: int | None
) -> list[dict]:
    """Per region with an interval: the coverage of the fresh parts' measured values, of all of them and of those
    before the daily check's first alarm (``alarm_at``, 0-based; None: no alarm), where the tool still vouches
    for its models."""
    rows = []
    has = answers["pred_lower"].notna().to_numpy()
    covered = (measured >= answers["pred_lower"].to_numpy()) & (measured <= answers["pred_upper"].to_numpy())
    before = np.arange(len(answers)) < (len(answers) if alarm_at is None else alarm_at)
    for region in sorted(set(answers.loc[has, "interval_region"])):
        here = has & (answers["interval_region"] == region).to_numpy()
        k, n = int(covered[here].sum()), int(here.sum())
        low, high = clopper_pearson(k, n)
        width = float((answers["pred_upper"] - answers["pred_lower"])[here].mean())
        k_before, n_before = int(covered[here & before].sum()), int((here & before).sum())
        rows.append(
            {"plant": name, "n_log": n_log, "region": region, "n_fresh": n, "coverage": k / n, "coverage_low": low,
             "coverage_high": high, "nominal": level, "mean_width": width, "n_before_alarm": n_before,
             "coverage_before_alarm": k_before / n_before if n_before else np.nan}
        )  # fmt: skip
    verdicts = answers["trust"].value_counts(normalize=True)
    for row in rows:
        row.update({f"share_{verdict}": float(verdicts.get(verdict, 0.0)) for verdict in ("validated", "calibrated")})
        row["share_extrapolation"] = float(verdicts.get("extrapolation", 0.0))
    return rows


def _pooled(rows: pd.DataFrame, coverage: str, parts: str) -> tuple[int, int, float, float]:
    k, n = int((rows[coverage].fillna(0) * rows[parts]).round().sum()), int(rows[parts].sum())
    return (k, n, *clopper_pearson(k, n))


def summary(table: pd.DataFrame) -> str:
    lines = [
        "| region | plants | fresh parts | coverage (pooled) | 95% interval | worst plant | mean width | "
        "before the daily check's alarm: parts | coverage (pooled) | 95% interval | worst region (100+ parts) |",
        "|---|---:|---:|---:|---|---:|---:|---:|---:|---|---:|",
    ]
    for region, rows in table.groupby(table["region"].where(table["region"] == "in_support", "out of support")):
        k, n, low, high = _pooled(rows, "coverage", "n_fresh")
        k_before, n_before, low_before, high_before = _pooled(rows, "coverage_before_alarm", "n_before_alarm")
        counted = rows.loc[rows["n_before_alarm"] >= 100, "coverage_before_alarm"]
        lines.append(
            f"| {region} | {rows['plant'].nunique()} | {n:,} | {k / n:.1%} | {low:.1%} to {high:.1%} | "
            f"{rows['coverage'].min():.1%} | {rows['mean_width'].mean():.2f} | {n_before:,} | "
            + (f"{k_before / n_before:.1%} | {low_before:.1%} to {high_before:.1%} | " if n_before else "– | – | ")
            + (f"{counted.min():.1%} |" if len(counted) else "– |")
        )
    lines += ["", "| plant | log | worst region | the daily check on the fresh parts |", "|---|---:|---|---|"]
    for plant, rows in table.groupby("plant", sort=False):
        worst = rows.loc[rows["coverage"].idxmin()]
        alarm = rows["monitor_alarm_at"].iloc[0]
        said = "no alarm" if np.isnan(alarm) else f"alarm at part {alarm:,.0f}"
        lines.append(
            f"| {plant} | {rows['n_log'].iloc[0]:,} | {worst['region']} {worst['coverage']:.1%} of "
            f"{worst['n_fresh']:,} | {said} |"
        )
    return "\n".join(lines)


def plant_folder(keep: Path | None, index: int):
    """Where a plant's workflow runs: a scratch folder, or with ``--keep`` one that stays (``keep``/p<index>)."""
    if keep is None:
        return tempfile.TemporaryDirectory()
    (keep / f"p{index}").mkdir(parents=True, exist_ok=True)
    return contextlib.nullcontext(str(keep / f"p{index}"))


def rerun_intervals(folder: Path) -> None:
    """The kept run's intervals step (and what reads it) again with today's package, every other step kept."""
    command = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(folder)]
    command += ["--configfile", str(folder / "plant.yaml"), "--cores", "2", "--quiet"]
    command += ["--forcerun", "prediction_intervals", "--rerun-triggers", "mtime"]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def answer_fresh(name: str, n_log: int, models: Path, fresh: pd.DataFrame, target: str) -> list[dict]:
    """The frozen predictor's coverage of the fresh parts, per region, with the daily check's first alarm."""
    predictor = Predictor.load(models)
    answers = predictor.predict(fresh, all_models=True)
    alarm_at = watch.watch(predictor, fresh, explain=False).chart.alarm_at
    found = coverage_rows(name, n_log, answers, fresh[target].to_numpy(float), predictor.level, alarm_at)
    for row in found:  # the monitor's first alarm (1-based part of the fresh period), NaN: none
        row["monitor_alarm_at"] = np.nan if alarm_at is None else alarm_at + 1
    alarm = "no alarm" if alarm_at is None else f"monitor alarm at part {alarm_at + 1:,}"
    covered = "; ".join(f"{r['region']} {r['coverage']:.1%} of {r['n_fresh']}" for r in found)
    print(f"{name:28s} log {n_log:>6,}: {covered}; {alarm}", flush=True)
    return found


def replay(keep: Path) -> list[dict]:
    """Every kept plant's coverage with the intervals fitted again by today's code."""
    rows = []
    for folder in sorted(keep.glob("p*"), key=lambda path: int(path.name[1:])):
        meta = json.loads((folder / "meta.json").read_text())
        rerun_intervals(folder)
        fresh = pd.read_parquet(folder / "fresh.parquet")
        rows += answer_fresh(meta["plant"], meta["n_log"], folder / "results" / "models", fresh, meta["target"])
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plants", type=int, default=8)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--keep", type=Path, help="keep each plant's run and its fresh parts in this folder")
    parser.add_argument("--replay", type=Path, help="only fit the intervals of a --keep folder's runs again")
    parser.add_argument("--name", default="fresh_coverage", help="the results' file name")
    parser.add_argument("--generator", choices=("families", "structures"), default="families")
    args = parser.parse_args()
    rows = replay(args.replay) if args.replay else []
    for index in range(0 if args.replay else args.plants):
        name, doe, log, fresh, inputs, target, simulate = plant(index, args.seed, args.generator)
        with plant_folder(args.keep, index) as scratch:
            matched = matched_cases(doe, log, inputs, target, np.random.default_rng(index), simulate)
            models = run_workflow(Path(scratch), doe, log, matched, inputs, target, args.seed)
            rows += answer_fresh(name, len(log), models, fresh, target)
            if args.keep is not None:
                fresh.to_parquet(Path(scratch) / "fresh.parquet")
                meta = {"plant": name, "n_log": len(log), "target": target}
                (Path(scratch) / "meta.json").write_text(json.dumps(meta))
    table = pd.DataFrame(rows)
    print(write_results(OUT, args.name, "Intervals on the next production period", table, summary(table)))


if __name__ == "__main__":
    main()
