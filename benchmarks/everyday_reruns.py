"""What reruns after the everyday changes, measured with ``snakemake -n`` on a copy of a finished run.

    snakemake --cores 2 && python benchmarks/everyday_reruns.py

Each change is made in its own copy of the working folder (results and Snakemake's metadata):
DoE rows added, production rows appended, a matched case added, ``tuning.n_trials`` changed, a
figure setting changed, the interval level changed. Prints a Markdown table of the rules that
would rerun, and of those that would not.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def append_rows(path: Path, n: int) -> None:
    """Append the last n data rows again, as a plant appends its new rows."""
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines + lines[-n:]))


def config_with(base: dict, section: str, key: str, value) -> dict:
    config = yaml.safe_load(yaml.safe_dump(base))
    config.setdefault(section, {})[key] = value
    return config


def planned(workdir: Path, config: Path) -> list[str]:
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "snakemake",
            "-n",
            "-s",
            str(ROOT / "Snakefile"),
            "-d",
            str(workdir),
            "--configfile",
            str(config),
            "--cores",
            "2",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    jobs = re.findall(r"^(?:local)?rule (\w+):\n(?:    .*\n)*?    output: ([^\n]*)", result.stdout, re.M)
    names = []
    for rule, outputs in jobs:
        if rule == "all":
            continue
        role = re.search(r"data/(doe|production|matched)\.parquet", outputs) if rule == "validate_inputs" else None
        peer = re.search(r"peer_(\w+)\.json", outputs) if rule == "peer" else None
        names.append(f"{rule} ({role.group(1)})" if role else f"{rule} ({peer.group(1)})" if peer else rule)
    return sorted(set(names))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workdir", default=str(ROOT), help="a folder with a finished run (results/, .snakemake/)")
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    args = parser.parse_args()
    base = yaml.safe_load(Path(args.config).read_text())
    data = base["data"]
    changes = {
        "10 DoE rows added": lambda folder: append_rows(folder / data["doe"], 10),
        "a week of production appended (500 rows)": lambda folder: append_rows(folder / data["production"], 500),
        "a matched case added": lambda folder: append_rows(folder / data["matched"], 1),
        "tuning.n_trials 25 -> 30": ("tuning", "n_trials", base.get("tuning", {}).get("n_trials", 25) + 5),
        "diagnosis.n_figures 3 -> 4 (a figure setting)": ("diagnosis", "n_figures", 4),
        "intervals.level 0.9 -> 0.8": ("intervals", "level", 0.8),
    }
    every = None
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for name, change in changes.items():
            folder = Path(scratch) / "run"
            shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(Path(args.workdir) / "results", folder / "results", symlinks=True)
            shutil.copytree(
                Path(args.workdir) / ".snakemake",
                folder / ".snakemake",
                symlinks=True,
                ignore=shutil.ignore_patterns("log", "incomplete", "locks", "conda", "singularity"),
            )
            config = base if callable(change) else config_with(base, *change)
            # the results where the finished run left them (a config file's own name would name another folder)
            config = {**config, "results_dir": "results"}
            (folder / "config.yaml").write_text(yaml.safe_dump(config))
            if every is None:
                every = planned(folder, folder / "config.yaml")
                if every:
                    raise SystemExit(f"the run in {args.workdir} is not up to date: {every} would run")
            if callable(change):
                change(folder)
            rows.append((name, planned(folder, folder / "config.yaml")))
    print("| change | reruns | does not rerun (among the steps on the DoE) |\n|---|---|---|")
    doe_side = {"validate_inputs (doe)", "surrogate_cv", "surrogate_fit", "demo_data"}
    for name, rules in rows:
        kept = sorted(doe_side - set(rules))
        print(f"| {name} | {len(rules)}: {', '.join(rules)} | {', '.join(kept) or '–'} |")


if __name__ == "__main__":
    main()
