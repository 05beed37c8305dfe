"""Speed and peak memory of the input checks on a large production log, against plain pandas.read_csv.

    snakemake --cores 2 && python benchmarks/check_scale.py --rows 1000000

Writes a production CSV of ``--rows`` rows (the demo run's production log, repeated), then in a
fresh process each: (1) ``pandas.read_csv`` of the file, (2) the workflow's check of the file
(``hybridtwin.data.load_production``: every configured column read and checked, errors naming file,
column and row). Reports wall time and peak resident memory of each process.
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from hybridtwin.io.config import check

MEASURE = """
import json, resource, sys, time
import pandas as pd
from hybridtwin.io import data
from hybridtwin.io.reading import CsvFormat
path, how, config = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
start = time.perf_counter()
if how == "pandas":
    frame = pd.read_csv(path)
else:
    columns = data.Columns.from_config(config["columns"])
    frame = data.load_production(path, columns, CsvFormat.from_config(config["csv"]))
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
print(json.dumps({"seconds": seconds, "peak_gib": peak, "rows": len(frame)}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--config", default="config/config.yaml")
    parser.add_argument("--production", default="results/demo/production.csv")
    args = parser.parse_args()
    config = check(yaml.safe_load(Path(args.config).read_text()))
    source = pd.read_csv(args.production, dtype=str, keep_default_na=False)
    repeats = np.resize(np.arange(len(source)), args.rows)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "production.csv"
        source.iloc[repeats].to_csv(path, index=False)
        size = path.stat().st_size / 2**20
        print(f"{args.rows:,} rows, {len(source.columns)} columns, {size:,.0f} MiB")
        print("| step | wall time [s] | peak memory [GiB] |\n|---|---:|---:|")
        for how, label in (("pandas", "pandas.read_csv"), ("check", "the workflow's check (load_production)")):
            result = subprocess.run(
                [sys.executable, "-c", MEASURE, str(path), how, json.dumps(config)],
                check=True,
                capture_output=True,
                text=True,
            )
            measured = json.loads(result.stdout.strip().splitlines()[-1])
            print(f"| {label} | {measured['seconds']:.1f} | {measured['peak_gib']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
