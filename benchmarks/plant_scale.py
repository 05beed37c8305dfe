"""The whole workflow on a large demo plant: wall time, and per rule time and peak memory.

    python benchmarks/plant_scale.py --rows 1000000
    python benchmarks/plant_scale.py --rows 10000000 --mem-mb 5500   # steps side by side within 5,500 MB

Runs ``snakemake --cores 2`` on the default config with ``demo.n_production`` set to ``--rows``, in
its own results folder (``runs/scale_<rows>``, so the demo's results stay): first only the demo plant's
files (rule demo_data, timed apart, since a plant's own run starts from its files), then the whole
workflow on them, from a results folder emptied but for those files. Prints that run's wall time and the
per-rule table from the Snakemake benchmark files (slowest first; demo_data among them), and the largest memory
of all its processes at once.
"""

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil
import yaml

sys.path.insert(0, str(Path(__file__).parent))
import machine_speed  # noqa: E402
from workflow_timing import rule_times  # noqa: E402


def peak_memory_of(process: subprocess.Popen, every: float = 0.5) -> tuple[int, list[str]]:
    """Wait for ``process``; the largest sum of resident memory of it and all its children seen meanwhile
    (jobs running side by side count together, which Snakemake's per-rule benchmark files do not show), and
    the rule scripts that ran at that moment."""
    root, peak, at_peak = psutil.Process(process.pid), 0, []
    while process.poll() is None:
        total, scripts = 0, []
        for member in [root, *root.children(recursive=True)]:
            try:
                total += member.memory_info().rss
                scripts += [
                    Path(part).name.split(".")[1] for part in member.cmdline() if "/.snakemake/scripts/" in part
                ]
            except (psutil.Error, IndexError):
                pass  # ended between the listing and the reading
        if total > peak:
            peak, at_peak = total, sorted(set(scripts))
        time.sleep(every)
    return peak, at_peak


def clear_results(results: Path, keep: str) -> None:
    """Empty a run's results folder but for the plant's files (folder ``keep``): every step then runs from
    scratch, a tuning study does not resume the trials of an earlier run, and no benchmark file of a step that
    no longer exists is counted."""
    for entry in results.iterdir():
        if entry.name != keep:
            shutil.rmtree(entry) if entry.is_dir() else entry.unlink()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--mem-mb", type=int, help="a memory budget for the steps side by side (--resources mem_mb)")
    args = parser.parse_args()
    print(machine_speed.line(), flush=True)
    results = f"runs/scale_{args.rows}"
    config = yaml.safe_load(Path("config/config.yaml").read_text())
    config["results_dir"] = results
    config.setdefault("demo", {})["n_production"] = args.rows
    config["data"] = {role: f"{results}/demo/{role}.csv" for role in ("doe", "production", "matched")}
    with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as handle:
        yaml.safe_dump(config, handle)
    command = ["snakemake", "--cores", str(args.cores), "--configfile", handle.name]
    budget = ["--resources", f"mem_mb={args.mem_mb}"] if args.mem_mb else []
    # the demo plant's data first, apart: a plant's own run starts from its files
    start = time.perf_counter()
    made = subprocess.run([*command[:1], *config["data"].values(), *command[1:]])  # targets before --configfile
    made_seconds = time.perf_counter() - start
    if made.returncode == 0:
        clear_results(Path(results), keep=Path(config["data"]["doe"]).parent.name)
        start = time.perf_counter()
        run = subprocess.Popen([*command, *budget])
        peak, at_peak = peak_memory_of(run)
        seconds = time.perf_counter() - start
    else:
        run, peak, at_peak, seconds = made, 0, [], 0.0
    within = f", a budget of {args.mem_mb:,} MB (--resources mem_mb)" if args.mem_mb else ""
    print(
        f"\n{args.rows:,} production rows, {args.cores} cores{within}: the workflow on the plant's files in "
        f"{seconds:.0f} s "
        f"(exit {run.returncode}), at most {peak / 2**30:.2f} GiB in all its processes at once (rule scripts then "
        f"running: {', '.join(at_peak) or 'none'}); generating the demo plant's files before it took "
        f"{made_seconds:.0f} s\n"
    )
    table = rule_times(Path(results))
    print(table.to_markdown(index=False, floatfmt=".1f"))
    print(f"\nsum of the rules: {table['seconds'].sum():.1f} s")


if __name__ == "__main__":
    main()
