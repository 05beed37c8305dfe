"""Benchmark: does `hybridtwin monitor` stay quiet on in-control production, find a change fast, and name it?

Plants from the families generator (:mod:`hybridtwin.demo.families`; the monitor's constants were set on a
demo-generator plant and on seed 33, never on later seeds) or, with ``--generator structures``, from the randomized
structures generator the monitor was never tuned on (:mod:`hybridtwin.demo.structures`: other names, inputs,
rhythms and simulators; stationary effect kinds only, so that the fresh parts are the same plant), drawn with
committed seeds. Per plant the real workflow
runs on the first ``--log`` parts (30,000 by default: a plant's log is tens of thousands of parts; on 8,000, two
shifts and about twenty coils, the limits over the regimes' levels come out too low: docs/benchmarks.md); the next
parts, in batches of 10,000, are the in-control batches (the same plant, drawn anew: new coils, campaigns, days),
and the in-support parts of all of them one more batch. Changed batches are in-control batches with a change from
part 3,001 on: steps of 0.5, 1, 1.5 and 3 times the plant's measurement noise, a drift of one noise unit per 2,000
parts, and four named changes (3 times the noise): a known cause (the extension's first) that grows, a new step in
a setting (the plant answers the new setting as the simulation does, plus the step), a new coil supplier (new coil
ids, each coil off by its own amount), and an unlogged offset (which must be called unexplained). On the same
batches, side by side: a plain CUSUM of the residual (textbook k=0.5, h=5 on the residual over its pooled
calibration error; and with the monitor's k and h), river's ADWIN and Page-Hinkley on the residual (their
defaults). Then 100,000 parts through the command, timed.

    python benchmarks/monitor_bank.py --plants 3 --seed 35      # about 4 minutes a plant, alone on 2 cores
    python benchmarks/monitor_bank.py --plants 6 --seed 38 --generator structures --keep runs/bank38
    python benchmarks/monitor_bank.py --replay runs/bank38      # the changes named again with today's code

``--keep`` leaves each plant's workflow run and its changed batches in the folder; ``--replay`` names their
changes again (a change of the explanation after an alarm, judged in minutes on the same models and batches).

Writes benchmarks/results/monitor_bank.csv (a row per batch and method) and monitor_bank.md (the summary).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fresh_coverage import matched_cases, plant_folder, plant_simulator, run_workflow  # noqa: E402

from hybridtwin.answers.predictor import Predictor  # noqa: E402
from hybridtwin.demo import families, structures  # noqa: E402
from hybridtwin.monitor import chart, watch  # noqa: E402
from hybridtwin.monitor.changes import KNOWN, NEW, UNEXPLAINED, clocks  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "results"
BATCH, START = 10_000, 3000
STEPS = (0.5, 1.0, 1.5, 3.0)
CAUSES = ("known cause grows", "new step in a setting", "new coil supplier", "unlogged offset")
TIMED = 100_000
PLANT_FAMILIES = ("temperature", "shim_step", "coil_property", "two_causes")
# the structures generator's kinds whose plant does not move on after the log (a wear or a season would)
STRUCTURE_KINDS = ("linear", "coil", "step", "product", "sigmoid", "none")


def baselines(residual: np.ndarray, scale: float) -> dict[str, int | None]:
    """First alarm (index) of each baseline on the raw residual."""
    from river import drift

    out = {}
    for name, (k, h) in {"plain CUSUM k=0.5 h=5": (0.5, 5.0), "plain CUSUM k=1 h=20": (1.0, 20.0)}.items():
        out[name] = chart.cusum(residual / scale, k, h, clip=np.inf).alarm_at
    for name, detector in (("ADWIN", drift.ADWIN()), ("Page-Hinkley", drift.PageHinkley())):
        out[name] = None
        for index, value in enumerate(residual):
            detector.update(float(value))
            if detector.drift_detected:
                out[name] = index
                break
    return out


def pooled_scale(predictor) -> float:
    """One error for every part, as a plain chart knows it: the recommended models' calibration errors pooled."""
    intervals = predictor.intervals
    errors = [
        e
        for region, model in intervals.recommended.items()
        for e in intervals.calibration.get(model, {}).get(region, [])
    ]
    return float(np.sqrt(np.mean(np.square(errors))))


def changed(predictor, batch, case, kind, rng) -> tuple[pd.DataFrame, str | None, str]:
    """The batch with a change from part START+1 on; the column and verdict kind the monitor must name."""
    out, after = batch.copy(), np.arange(len(batch)) >= START
    target, noise = case.target, case.noise
    if kind.startswith("step "):
        out.loc[after, target] += float(kind.split()[1]) * noise
        return out, None, ""
    if kind == "drift":
        out.loc[after, target] += noise * (np.arange(len(batch))[after] - START) / 2000.0
        return out, None, ""
    if kind == "unlogged offset":
        out.loc[after, target] += 3 * noise
        return out, None, UNEXPLAINED
    if kind == "known cause grows":
        known = sorted(predictor.extension.extension.columns - clocks(batch))
        known = [column for column in known if pd.api.types.is_numeric_dtype(batch[column])]
        if not known:  # the workflow named no cause but time or a counter: nothing known can grow here
            return None, None, ""
        column = known[0]
        x = out[column].to_numpy(float)
        low, high = np.quantile(x[after], [0.1, 0.9])
        out.loc[after, target] += 2 * 3 * noise * np.clip((x[after] - low) / (high - low), 0.0, 1.0)
        return out, column, KNOWN
    if kind == "new coil supplier":
        coil = case.names["coil"]
        ids = out.loc[after, coil].astype(str)
        levels = {level: rng.normal(3 * noise, 0.5 * noise) for level in ids.unique()}
        out.loc[after, target] += ids.map(levels).to_numpy(float)
        out.loc[after, coil] = "NEW-" + ids
        return out, coil, NEW
    setting, step = _setting(case, out, rng)  # a step in a setting: re-shimmed, or another one moved
    simulate = plant_simulator(case)
    before = out.loc[~after, setting].to_numpy(float)[-300:]
    new = out.copy()
    new.loc[after, setting] = before.max() + step + rng.normal(0, step / 15, after.sum())
    # the plant answers the new setting as the simulation does (its discrepancy stays that of the parts' other
    # conditions), plus the step; not as the models do, whose error at the old settings would stay in the batch
    answer = simulate(new.loc[after]) - simulate(out.loc[after])
    new.loc[after, target] += answer + 3 * noise
    return new, setting, NEW


def _setting(case, batch, rng) -> tuple[str, float]:
    """The setting a re-setup moves and by how much: a shim by 0.03 mm on the families' plants; on the structures'
    plants a model input that is not a coil's material, by a tenth of its spread in the batch."""
    if isinstance(case, structures.StructureCase):
        settings = sorted(case.names[c] for c in case.names if case.names[c] in case.inputs and c not in case.per_coil)
        setting = str(rng.choice(settings))
        return setting, 0.1 * float(np.ptp(batch[setting].to_numpy(float)))
    return case.names[str(rng.choice(["shim20_mm", "shim21_mm"]))], 0.03


def judge(watched, column, kind) -> bool:
    change = watched.change
    if change is None:
        return False
    return change.kind == kind and (kind == UNEXPLAINED or change.column == column)


def named_at_departure(watched, column, start: int) -> bool:
    """Whether, with no alarm after ``start``, the monitor says the batch left the settings the models can judge
    where the change began (within ten parts) and names the stepped setting: no chart can judge those parts, and
    the answer names the setting (a step in a setting only)."""
    left, alarm = watched.departure, watched.chart.alarm_at
    if left is None or column is None or (alarm is not None and alarm >= start):
        return False
    return abs(left.start_part - 1 - start) <= 10 and column in left.columns


def draw(generator: str, index: int, seed: int, n_production: int):
    """The index-th plant of a generator, and its name."""
    if generator == "structures":
        kind = STRUCTURE_KINDS[index % len(STRUCTURE_KINDS)]
        return structures.draw_structure_plant(kind, seed * 100 + index, n_production), kind
    family = PLANT_FAMILIES[index % len(PLANT_FAMILIES)]
    return families.draw_plant(family, seed * 100 + index, n_production=n_production), family


def _kept(folder: Path, plant: str, batches: list[tuple]) -> None:
    """The changed batches with a cause to name, as parquet files beside the plant's run, and what each must
    be named (meta.json), for ``--replay``."""
    listed = []
    for number, kind, altered, column, verdict in batches:
        name = f"b{number}_{kind.replace(' ', '_')}.parquet"
        altered.to_parquet(folder / name)
        listed.append({"file": name, "kind": kind, "column": column, "verdict": verdict})
    (folder / "meta.json").write_text(json.dumps({"plant": plant, "batches": listed}, indent=1))


def replay(keep: Path) -> pd.DataFrame:
    """The monitor's rows of the kept changed batches (``--keep``) with today's code: the alarms and the change
    named, in seconds, on the models the kept run built."""
    rows = []
    for folder in sorted(keep.glob("p*")):
        meta = json.loads((folder / "meta.json").read_text())
        # the run beside the batches (folders kept before 2026-11-29 hold it under run/)
        models = next(path for path in (folder / "results", folder / "run" / "results") if path.is_dir()) / "models"
        predictor = Predictor.load(models)
        scale = pooled_scale(predictor)
        for batch in meta["batches"]:
            altered = pd.read_parquet(folder / batch["file"])
            args = (meta["plant"], batch["kind"], START, batch["column"], batch["verdict"], scale)
            rows += [row for row in _rows(predictor, altered, *args) if row["method"] == "monitor"]
    return pd.DataFrame(rows)


def plant_rows(index: int, seed: int, n_log: int, n_batches: int, timings: list, generator: str, keep=None) -> list:
    n_fresh = max(n_batches * BATCH, TIMED if index == 0 else 0)
    case, family = draw(generator, index, seed, n_log + n_fresh)
    log, fresh = case.production.iloc[:n_log], case.production.iloc[n_log:].reset_index(drop=True)
    rng = np.random.default_rng([seed, index])
    rows, named = [], []
    with plant_folder(keep, index) as scratch:
        matched = matched_cases(case.doe, log, case.inputs, case.target, rng, plant_simulator(case))
        models = run_workflow(Path(scratch), case.doe, log, matched, case.inputs, case.target, seed)
        predictor = Predictor.load(models)
        scale = pooled_scale(predictor)
        batches = [fresh.iloc[i * BATCH : (i + 1) * BATCH].reset_index(drop=True) for i in range(n_batches)]
        inside = predictor.where(predictor.checked(fresh)).inside
        plant = f"{family} seed {seed * 100 + index}"
        for number, batch in enumerate([*batches, fresh[inside].iloc[:BATCH].reset_index(drop=True)]):
            label = "in control, in support" if number == n_batches else "in control"
            rows += _rows(predictor, batch, plant, label, None, None, "", scale)
        kinds = [f"step {m:g}" for m in STEPS] + ["drift", *CAUSES]
        for number, batch in enumerate(batches[:3]):
            for kind in kinds:
                altered, column, verdict = changed(predictor, batch, case, kind, rng)
                if altered is None:
                    continue
                rows += _rows(predictor, altered, plant, kind, START, column, verdict, scale)
                named += [(number, kind, altered, column, verdict)] if verdict else []
        stored = predictor.spec.get("monitor", {})
        for row in rows:  # what the log set: the charts' limits, the scatter inside a regime against the noise
            row.update({key: stored.get(key, np.nan) for key in ("within_limit", "level_limit", "level_between")})
            row["within_scale_per_noise"] = stored.get("pooled_scale", np.nan) / case.noise
            row["regimes_in_log"] = ", ".join(stored.get("regimes", {}).get("columns", []))
        if index == 0:
            timings.append(timing(models, fresh.iloc[:TIMED], Path(scratch)))
        if keep is not None:
            _kept(Path(scratch), plant, named)
        print(f"{plant}: {len(rows)} rows", flush=True)
    return rows


def _rows(predictor, batch, plant, kind, start, column, verdict, scale) -> list[dict]:
    watched = watch.watch(predictor, batch, explain=bool(verdict))
    alarms = {"monitor": watched.chart.alarm_at, **baselines(watched.table["residual"].to_numpy(float), scale)}
    rows = []
    for method, at in alarms.items():
        row = {"plant": plant, "batch": kind, "method": method, "parts": len(batch), "alarm_at": at}
        row["judged"] = int(watched.judged.sum())
        row["chart"] = watched.chart.alarmed_by if method == "monitor" else ""
        row["start_at"] = watched.chart.start_at if method == "monitor" else np.nan
        row["false_alarm"] = at is not None and (start is None or at < start)
        row["delay"] = np.nan if at is None or start is None or at < start else at - start
        if method == "monitor":
            left = watched.departure
            row["departed_at"] = np.nan if left is None else left.start_part - 1
        if method == "monitor" and verdict:
            row["cause_right"] = judge(watched, column, verdict)
            row["named"] = None if watched.change is None else watched.change.text
            row["departure_named"] = verdict == NEW and named_at_departure(watched, column, start)
        rows.append(row)
    return rows


def timing(predictor_models: Path, batch: pd.DataFrame, folder: Path) -> tuple[float, float]:
    """Seconds for the command (read, load the models, predict, chart, write) and for the check in memory with
    the models loaded (predict and chart)."""
    path = folder / "big.csv"
    batch.to_csv(path, index=False)
    began = time.perf_counter()
    command = [sys.executable, "-m", "hybridtwin.cli", "monitor", str(path), "--models", str(predictor_models)]
    subprocess.run([*command, "-o", str(folder / "o.csv")], check=True, capture_output=True)
    total = time.perf_counter() - began
    predictor = Predictor.load(predictor_models)
    watch.watch(predictor, batch.iloc[:2000])  # the peers are read on first use
    began = time.perf_counter()
    watch.watch(predictor, batch, explain=False)
    return total, time.perf_counter() - began


def _delays(rows: pd.DataFrame) -> list[str]:
    cells = []
    for kind in [f"step {m:g}" for m in STEPS] + ["drift"]:
        here = rows[rows["batch"] == kind]
        within = float((here["delay"] <= 150).mean())
        cells.append(f"{here['delay'].median():.0f} ({within:.0%})" if here["delay"].notna().any() else "none")
    return cells


def _named(table: pd.DataFrame) -> list[str]:
    monitor = table[(table["method"] == "monitor") & table["batch"].isin(CAUSES)]
    lines = ["## What changed: named right", "", "| change | batches | alarmed after the start | named right | "
             "named right, of those alarmed after the start | no alarm: the setting named where the batch left what "
             "the models judge |", "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for kind, rows in [*monitor.groupby("batch"), ("all", monitor)]:
        after = rows[rows["delay"].notna()]
        right, right_after = rows["cause_right"].astype(bool), after["cause_right"].astype(bool)
        share = f"{right_after.mean():.0%}" if len(after) else "-"
        departed = int(rows.get("departure_named", pd.Series(False, index=rows.index)).fillna(False).astype(bool).sum())
        lines.append(f"| {kind} | {len(rows)} | {len(after)} | {int(right.sum())} ({right.mean():.0%}) | "
                     f"{int(right_after.sum())} ({share}) | {departed} |")  # fmt: skip
    return lines


def summary(table: pd.DataFrame, seconds: tuple[float, float]) -> str:
    names = [f"step {m:g}x noise" for m in STEPS] + ["drift 1 noise / 2,000 parts", "early alarms (changed)"]
    lines = ["## False alarms and delays (parts after the change starts: median, and the share within 150)", ""]
    lines += ["| method | in-control batches with an alarm | in support | " + " | ".join(names) + " |"]
    lines += ["|---|---:|---:|" + "---:|" * len(names)]
    for method, rows in table.groupby("method", sort=False):
        control = rows[rows["batch"] == "in control"]
        support = rows[rows["batch"] == "in control, in support"]
        changed_rows = rows[~rows["batch"].str.startswith("in control")]
        cells = [f"{int(control['false_alarm'].sum())} of {len(control)}",
                 f"{int(support['false_alarm'].sum())} of {len(support)}", *_delays(rows),
                 f"{int(changed_rows['false_alarm'].sum())} of {len(changed_rows)}"]  # fmt: skip
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    per_plant = table.groupby("plant")[["within_limit", "level_limit", "within_scale_per_noise"]].first()
    alarmed = table[(table["method"] == "monitor") & table["alarm_at"].notna()]
    lines += ["", *_named(table), "", "Limits per plant (block bootstrap of its log): "
              + "; ".join(f"{plant}: h {row.within_limit:.1f} within a regime, {row.level_limit:.1f} over the "
                          f"regimes' levels, scatter inside a regime {row.within_scale_per_noise:.2f} x the noise"
                          for plant, row in per_plant.iterrows()) + ".", "",
              "Alarms by chart: " + ", ".join(f"{name or 'plain'} {n}" for name, n in
                                               alarmed["chart"].value_counts().items()) + ".", "",
              f"100,000 parts through `hybridtwin monitor` (read, load the models, predict, chart, write): "
              f"{seconds[0]:.1f} s wall time; in memory with the models loaded (predict, chart): "
              f"{seconds[1]:.1f} s"]  # fmt: skip
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plants", type=int, default=3)
    parser.add_argument("--seed", type=int, default=32)
    parser.add_argument("--log", type=int, default=30_000, help="parts the workflow learns from")
    parser.add_argument("--batches", type=int, default=7, help="in-control batches of 10,000 parts per plant")
    parser.add_argument("--name", default="monitor_bank", help="the results' file name (.csv, .md)")
    parser.add_argument("--generator", choices=("families", "structures"), default="families")
    parser.add_argument("--keep", type=Path, help="keep each plant's run and its changed batches in this folder")
    parser.add_argument("--replay", type=Path, help="only name the changes of a --keep folder's batches again")
    args = parser.parse_args()
    if args.replay:
        print("\n".join(_named(replay(args.replay))))
        return
    # the commit the run starts at (a commit made while it runs must not be credited with its numbers)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT)
    rows, timings = [], []
    for index in range(args.plants):
        rows += plant_rows(index, args.seed, args.log, args.batches, timings, args.generator, args.keep)
    table = pd.DataFrame(rows)
    OUT.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT / f"{args.name}.csv", index=False)
    text = (f"# Monitor bank\n\n`python benchmarks/monitor_bank.py {' '.join(sys.argv[1:])}` at commit "
            f"{commit.stdout.strip()}\n\n{summary(table, timings[0] if timings else (np.nan, np.nan))}\n")  # fmt: skip
    (OUT / f"{args.name}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
