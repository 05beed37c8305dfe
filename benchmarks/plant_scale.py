"""The whole workflow on a large demo plant: wall time, and per rule time and peak memory.

    python benchmarks/plant_scale.py --rows 1000000

Runs ``snakemake --cores 2`` on the default config with ``demo.n_production`` set to ``--rows``, in
its own results folder (``runs/scale_<rows>``, so the demo's results stay): first only the demo plant's
files (rule demo_data, timed apart, since a plant's own run starts from its files), then the whole
workflow on them. Prints that run's wall time and the per-rule table from the Snakemake benchmark
files (slowest first; demo_data among them).
"""

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).parent))
from workflow_timing import main as timing_table  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--cores", type=int, default=2)
    args = parser.parse_args()
    results = f"runs/scale_{args.rows}"
    config = yaml.safe_load(Path("config/config.yaml").read_text())
    config["results_dir"] = results
    config.setdefault("demo", {})["n_production"] = args.rows
    config["data"] = {role: f"{results}/demo/{role}.csv" for role in ("doe", "production", "matched")}
    with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as handle:
        yaml.safe_dump(config, handle)
    command = ["snakemake", "--cores", str(args.cores), "--configfile", handle.name]
    # the demo plant's data first, apart: a plant's own run starts from its files
    start = time.perf_counter()
    made = subprocess.run([*command, *config["data"].values()])
    made_seconds = time.perf_counter() - start
    start = time.perf_counter()
    run = subprocess.run(command) if made.returncode == 0 else made
    seconds = time.perf_counter() - start
    print(
        f"\n{args.rows:,} production rows, {args.cores} cores: the workflow on the plant's files in {seconds:.0f} s "
        f"(exit {run.returncode}); generating the demo plant's files before it took {made_seconds:.0f} s\n"
    )
    timing_table(f"{results}/benchmarks")


if __name__ == "__main__":
    main()
