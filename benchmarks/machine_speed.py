"""A fixed workload timed: how fast the machine runs on the day, beside a timing benchmark's record.

    python benchmarks/machine_speed.py        # about 10 s (three times the workload), alone on 2 cores

The same code ran 262 s one afternoon and 365 s that evening on the machine the project's sessions use
(``benchmarks/results/plant_scale_259531c.md``): a record's times say little without the machine's speed on the
day. This workload does what the workflow's steps spend their time on (a Cholesky factorization, a scikit-learn
GPR's likelihood search, XGBoost's hist trees, pandas reading a CSV), on one thread, with fixed seeds: the same
work every time. ``workflow_timing.py``, ``closed_loop.py`` and ``plant_scale.py`` print its seconds before they
run; two records compare where their machine speeds do.
"""

from __future__ import annotations

import argparse
import io
import time
import warnings

import numpy as np
import pandas as pd
import xgboost as xgb
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import Matern, WhiteKernel
from threadpoolctl import threadpool_limits

SEED = 0


def workload() -> None:
    rng = np.random.default_rng(SEED)
    a = rng.normal(size=(800, 800))
    for _ in range(30):
        np.linalg.cholesky(a @ a.T + 800 * np.eye(800))
    X, y = rng.normal(size=(250, 12)), rng.normal(size=250)
    kernel = Matern(length_scale=np.ones(12), nu=2.5) + WhiteKernel()
    with warnings.catch_warnings():  # noise as the target: length scales at their bound, as meant
        warnings.simplefilter("ignore", ConvergenceWarning)
        GaussianProcessRegressor(kernel, normalize_y=True, random_state=SEED).fit(X, y)
    X, y = rng.normal(size=(60_000, 12)), rng.normal(size=60_000)
    xgb.train({"tree_method": "hist", "max_depth": 6, "nthread": 1, "seed": SEED}, xgb.DMatrix(X, y), 100)
    pd.read_csv(io.StringIO(pd.DataFrame(X).to_csv(index=False)))


def reference_seconds(repeats: int = 3) -> float:
    """The workload's best wall time of ``repeats``, on one thread."""
    times = []
    with threadpool_limits(1):
        for _ in range(repeats):
            start = time.perf_counter()
            workload()
            times.append(time.perf_counter() - start)
    return min(times)


def line() -> str:
    """The sentence a timing benchmark prints before it runs."""
    return f"machine speed: the reference workload took {reference_seconds():.2f} s (benchmarks/machine_speed.py)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    print(f"{reference_seconds(parser.parse_args().repeats):.2f} s")


if __name__ == "__main__":
    main()
