"""Speed of the frozen predictor: N what-if rows, loading the models included.

    snakemake --cores 2 && python benchmarks/predict_speed.py --rows 100000

Times (1) ``Predictor.load`` + ``predict`` on a table in memory, and (2) the whole
command ``hybridtwin predict NEW.csv -o OUT.csv`` in a fresh process (reading and
checking the CSV, writing the answers). The rows are the run's production rows,
repeated and shuffled with a fixed seed.
"""

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin import Predictor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=100_000)
    parser.add_argument("--models", default="results/models")
    parser.add_argument("--production", default="results/data/production.csv")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    production = pd.read_csv(args.production)
    rows = np.random.default_rng(0).choice(len(production), args.rows, replace=args.rows > len(production))
    settings = production.iloc[rows].reset_index(drop=True)
    in_memory, without_peers = [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        answers = Predictor.load(args.models).predict(settings)
        in_memory.append(time.perf_counter() - start)
        start = time.perf_counter()
        Predictor.load(args.models, with_peers=False).predict(settings, with_peers=False)
        without_peers.append(time.perf_counter() - start)
    with tempfile.TemporaryDirectory() as folder:
        new, out = Path(folder) / "new.csv", Path(folder) / "out.csv"
        settings.to_csv(new, index=False)
        command, command_without = [], []
        for _ in range(args.repeats):
            for flags, times in (([], command), (["--without-peers"], command_without)):
                start = time.perf_counter()
                subprocess.run(
                    ["hybridtwin", "predict", str(new), "--models", args.models, "-o", str(out), *flags],
                    check=True,
                    capture_output=True,
                )
                times.append(time.perf_counter() - start)
    print(f"{args.rows:,} rows ({answers['in_support'].mean():.0%} in support), best of {args.repeats}:")
    print("| step | wall time [s] |\n|---|---:|")
    print(f"| Predictor.load + predict (table in memory) | {min(in_memory):.2f} |")
    print(f"| the same, with_peers=False (load and predict) | {min(without_peers):.2f} |")
    print(
        f"| hybridtwin predict NEW.csv -o OUT.csv (fresh process: imports, CSV checks, writing) | {min(command):.2f} |"
    )
    print(f"| the same, --without-peers | {min(command_without):.2f} |")


if __name__ == "__main__":
    main()
