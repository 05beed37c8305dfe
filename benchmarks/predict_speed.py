"""Speed of the frozen predictor: N what-if rows, loading the models included.

    snakemake --cores 2 && python benchmarks/predict_speed.py --rows 100000

Times (1) ``Predictor.load`` + ``predict`` on a table in memory, the default answer (the models each row's
recommendation needs) and ``all_models``; and (2) the whole command ``hybridtwin predict NEW.csv -o OUT.csv`` in a
fresh process (imports, reading and checking the CSV, writing the answers). The rows are the run's production
rows, repeated and shuffled with a fixed seed. Goal (issue 29): under 5 s for 100,000 rows through the command.
"""

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin import Predictor


def timed(action, repeats: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = action()
        best = min(best, time.perf_counter() - start)
    return best, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=100_000)
    parser.add_argument("--models", default="results/models")
    parser.add_argument("--production", default="results/demo/production.csv")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    production = pd.read_csv(args.production)
    rows = np.random.default_rng(0).choice(len(production), args.rows, replace=args.rows > len(production))
    settings = production.iloc[rows].reset_index(drop=True)
    default, answers = timed(lambda: Predictor.load(args.models).predict(settings), args.repeats)
    every, _ = timed(lambda: Predictor.load(args.models).predict(settings, all_models=True), args.repeats)
    with tempfile.TemporaryDirectory() as folder:
        new, out = Path(folder) / "new.csv", Path(folder) / "out.csv"
        settings.to_csv(new, index=False)
        command = ["hybridtwin", "predict", str(new), "--models", args.models, "-o", str(out)]
        fresh, _ = timed(lambda: subprocess.run(command, check=True, capture_output=True), args.repeats)
        fresh_all, _ = timed(lambda: subprocess.run([*command, "--all-models"], check=True), args.repeats)
    models = answers["recommended_model"].value_counts(normalize=True)
    print(f"{args.rows:,} rows, recommended: " + ", ".join(f"{m} {share:.0%}" for m, share in models.items()))
    print(f"best of {args.repeats}:\n| step | wall time [s] |\n|---|---:|")
    print(f"| Predictor.load + predict (table in memory) | {default:.2f} |")
    print(f"| the same, all_models=True | {every:.2f} |")
    print(f"| hybridtwin predict NEW.csv -o OUT.csv (fresh process: imports, CSV checks, writing) | {fresh:.2f} |")
    print(f"| the same, --all-models | {fresh_all:.2f} |")


if __name__ == "__main__":
    main()
