"""Where a run's time goes: wall time, the sum of the rules' times, and the critical path.

    python benchmarks/workflow_timing.py --run            # the demo from an empty results folder, then the table
    python benchmarks/workflow_timing.py results          # the table of a finished run's results folder

``--run`` runs ``snakemake --cores 2`` with the default config into a fresh temporary results folder and
times it. The per-rule times come from Snakemake's ``benchmark:`` files; the critical path is the longest
chain of dependent jobs in the run's DAG (``snakemake --dag``), weighted by those times: no number of
cores makes the run shorter than it. The difference between the wall time and the busiest of the two
bounds (critical path; sum of the rules over the cores) is Snakemake's own time: parsing, planning, and
starting jobs. ``--out FILE`` writes the Markdown there as well.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import machine_speed
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
CORES = 2


def snakemake(*args: str) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(ROOT), *args]
    return subprocess.run(command, capture_output=True, text=True, check=True)


def run_config(results: Path) -> list[str]:
    """The demo's config pointed at ``results``: its outputs there, and the demo plant's files it makes there."""
    demo = results / "demo"
    data = ", ".join(f"{role}: {demo / role}.csv" for role in ("doe", "production", "matched"))
    return ["--config", f"results_dir={results}", f"data={{{data}}}"]


def rule_times(results: Path) -> pd.DataFrame:
    """One row per job: its benchmark file's name (rule and wildcards), seconds and peak memory."""
    rows = []
    for path in sorted((results / "benchmarks").glob("*.tsv")):
        bench = pd.read_csv(path, sep="\t")
        rows.append({"job": path.stem, "seconds": bench["s"].iloc[-1], "max_rss_mb": bench["max_rss"].iloc[-1]})
    return pd.DataFrame(rows).sort_values("seconds", ascending=False, ignore_index=True)


def dag_edges(results: Path) -> tuple[dict[str, str], list[tuple[str, str]]]:
    """The run's jobs (named as their benchmark files are) and their dependencies, from ``snakemake --dag``."""
    dot = snakemake("--dag", "--forceall", *run_config(results)).stdout
    names = {}
    for node, label in re.findall(r'^\s*(\d+)\[label = "([^"]+)"', dot, re.M):
        rule, *wildcards = label.split("\\n")
        names[node] = "_".join([rule, *(w.split(": ", 1)[1] for w in wildcards)])
    edges = [(names[a], names[b]) for a, b in re.findall(r"^\s*(\d+) -> (\d+)", dot, re.M)]
    return names, edges


def critical_path(seconds: dict[str, float], edges: list[tuple[str, str]]) -> tuple[float, list[str]]:
    """The longest chain of dependent jobs (an edge a -> b: b needs a), by their seconds."""
    needs: dict[str, list[str]] = {}
    for before, after in edges:
        needs.setdefault(after, []).append(before)
    memo: dict[str, tuple[float, list[str]]] = {}

    def longest(job: str) -> tuple[float, list[str]]:
        if job not in memo:
            chains = [longest(before) for before in needs.get(job, [])]
            length, chain = max(chains, default=(0.0, []))
            memo[job] = (length + seconds.get(job, 0.0), [*chain, job])
        return memo[job]

    return max(longest(job) for job in {job for edge in edges for job in edge} | set(seconds))


def report(results: Path, wall: float | None) -> str:
    table = rule_times(results)
    _, edges = dag_edges(results)
    seconds = dict(zip(table["job"], table["seconds"]))
    length, chain = critical_path(seconds, edges)
    total = table["seconds"].sum()
    lines = ["| step | time [s] | peak memory [MB] |", "|---|---:|---:|"]
    lines += [f"| {row.job} | {row.seconds:.1f} | {row.max_rss_mb:.0f} |" for row in table.itertuples()]
    lines += [
        "",
        f"- sum of the steps: {total:.1f} s ({total / CORES:.1f} s on {CORES} cores at best)",
        f"- critical path: {length:.1f} s: " + " → ".join(job for job in chain if seconds.get(job, 0) > 0),
    ]
    if wall is not None:
        lines.append(f"- wall time from an empty results folder: {wall:.1f} s, {len(table)} jobs")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="?", default="results", help="a finished run's results folder")
    parser.add_argument("--run", action="store_true", help="run the demo from an empty results folder first")
    parser.add_argument("--out", help="also write the Markdown to this file")
    parser.add_argument("--keep", help="with --run: run into this new folder and keep it (logs, outputs)")
    args = parser.parse_args()
    wall = None
    with tempfile.TemporaryDirectory(prefix="timing-") as scratch:
        results = Path(args.results).resolve()
        if args.run:
            results = Path(args.keep or Path(scratch, "results")).resolve()
            if results.exists():
                sys.exit(f"{results} exists: --run starts from an empty results folder")
            speed = machine_speed.line()
            start = time.perf_counter()
            snakemake("--cores", str(CORES), *run_config(results))
            wall = time.perf_counter() - start
        text = report(results, wall) + (f"\n- {speed}" if args.run else "")
    print(text)
    if args.out:
        command = "python benchmarks/workflow_timing.py" + (" --run" if args.run else f" {args.results}")
        Path(args.out).write_text(f"# Where the demo run's time goes\n\n`{command}`\n\n{text}\n")


if __name__ == "__main__":
    main()
