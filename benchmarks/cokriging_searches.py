"""Benchmark: co-kriging's hyperparameters from one likelihood search or from several, against a plain SMT MFK.

On the published bi-fidelity functions (the plants of ``bifidelity.py``), co-kriging is fitted alone on the
in-support parts of the workflow's gate (the in-memory steps), once per setting:

- ``one search``: one likelihood search of 10 starts on one seeded draw of ``n_high`` parts (the setting before);
- ``3 searches``: three searches of 2 starts, each on its own draw; the hyperparameters whose model predicts
  unseen periods of the ``n_fit`` parts best are kept (the default now);
- ``3 searches, SMT's starts``: the same with SMT's own two starts only (no Latin hypercube starts beyond them);
- ``3 searches, 500 parts`` and ``3 searches, 600 parts``: the same, fitted on the parts searched on (the plain
  MFK's 600 parts, the same seeded draw, in the second);
- ``3 searches, theta >= 1e-3`` and ``... 1e-2``: the default with the length-scale parameters' lower bound raised
  from SMT's 1e-6 (``CoKriging(theta_low=...)``);

beside the plain SMT MFK (``plain_baselines.PlainMFK``). Scored as ``bifidelity.py`` scores: the truth-RMSE over the
noise, out of period on the parts a model trained on, the final model elsewhere; in support and out of it, and in
support on the parts no model trained on (the same predictions for every model: the final model's). Beside it, the
smallest length-scale parameter of each model's discrepancy kriging. Usage:

    python benchmarks/cokriging_searches.py --seeds 12 13      # about 4 minutes a seed, alone on 2 cores
    python benchmarks/cokriging_searches.py --seeds 21 22 --settings "3 searches" "3 searches, 500 parts" \
        "3 searches, 600 parts" --name cokriging_parts

Writes benchmarks/results/cokriging_searches.csv and .md.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from bifidelity import FUNCTIONS, TARGET, plant, plant_case
from plain_baselines import PlainMFK
from results_files import write_results

from hybridtwin.crossval import in_support_out_of_period
from hybridtwin.demo import harness
from hybridtwin.models.cokriging import CoKriging

OUT = Path(__file__).resolve().parent / "results"
SETTINGS = {
    "one search": {"n_searches": 1, "n_start": 10, "n_high": 500, "n_fit": 1000},
    "3 searches": {"n_searches": 3, "n_start": 2, "n_high": 500, "n_fit": 1000},
    # SMT's own two starts only (its given and its random one; n_start 1 adds no Latin hypercube starts)
    "3 searches, SMT's starts": {"n_searches": 3, "n_start": 1, "n_high": 500, "n_fit": 1000},
    # fitted on the parts searched on: no refit on more parts with the hyperparameters held
    "3 searches, 500 parts": {"n_searches": 3, "n_start": 2, "n_high": 500, "n_fit": 500},
    # the plain MFK's own 600 parts (the same seeded draw)
    "3 searches, 600 parts": {"n_searches": 3, "n_start": 2, "n_high": 600, "n_fit": 600},
    # the length-scale parameters kept off SMT's lower bound (1e-6), where the discrepancy's are found
    "3 searches, theta >= 1e-3": {"n_searches": 3, "n_start": 2, "n_high": 500, "n_fit": 1000, "theta_low": 1e-3},
    "3 searches, theta >= 1e-2": {"n_searches": 3, "n_start": 2, "n_high": 500, "n_fit": 1000, "theta_low": 1e-2},
}
DEFAULT_SETTINGS = ["one search", "3 searches"]
N_FOLDS = 5


def in_support(case: dict, seed: int) -> np.ndarray:
    """The workflow's gate on the plant (the in-memory steps)."""
    return harness.Run.of(plant_case(case), seed, 2).residuals["in_support"].to_numpy(bool)


def honest(model, X, inside_rows: np.ndarray, trained: np.ndarray) -> np.ndarray:
    """The final model's predictions, out of period on every in-support part (as the workflow scores it)."""
    inside = X.iloc[inside_rows] if hasattr(X, "iloc") else X[inside_rows]
    with contextlib.redirect_stdout(io.StringIO()):  # SMT prints its search
        values = np.asarray(model.predict(X), float).ravel()
        values[inside_rows] = in_support_out_of_period(model, inside, trained, N_FOLDS)
    return values


def smallest_discrepancy_theta(theta_per_level) -> float:
    """The smallest length-scale parameter of the discrepancy's kriging (level 1; at SMT's lower bound, 1e-6, the
    level's correlation matrix is nearly all ones)."""
    return float(np.min(np.asarray(theta_per_level[1], float)[:-1]))  # the last entry is the noise


def plant_rows(function: str, seed: int, settings: list[str]) -> list[dict]:
    case = plant(function, seed)
    inside = in_support(case, seed)
    rows_in = np.flatnonzero(inside)
    X, y, doe = case["production"][case["inputs"]], case["production"][TARGET].to_numpy(float), case["doe"]
    fitted, trained = {}, []
    start = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        plain = PlainMFK(seed=seed).fit(X.to_numpy()[rows_in], y[rows_in], doe[case["inputs"]], doe[TARGET])
    fitted["plain MFK"] = (
        honest(plain, X.to_numpy(), rows_in, plain.rows_),
        time.perf_counter() - start,
        smallest_discrepancy_theta(plain.theta_),
    )
    trained.append(plain.rows_)
    for name in settings:
        start = time.perf_counter()
        model = CoKriging(random_state=seed, **SETTINGS[name])
        with contextlib.redirect_stdout(io.StringIO()):
            model.fit(X.iloc[rows_in], y[rows_in], X_low=doe[case["inputs"]], y_low=doe[TARGET])
        fitted[name] = (
            honest(model, X, rows_in, model.training_rows_),
            time.perf_counter() - start,
            smallest_discrepancy_theta(model.hyperparameters_),
        )
        trained.append(model.training_rows_)
    # in support, a part a model trained on is scored out of period and any other by the final model: a model
    # trained on more parts has more of the harder predictions; the parts no model trained on compare alike
    untrained = inside.copy()
    untrained[rows_in[np.unique(np.concatenate(trained))]] = False
    rows = []
    for name, (values, seconds, theta) in fitted.items():
        row = {"function": function, "seed": seed, "model": name, "seconds": seconds, "discrepancy_theta_min": theta}
        for side, mask in (("in", inside), ("out", ~inside), ("in, untrained", untrained)):
            error = values[mask] - case["truth"][mask]
            row[side] = float(np.sqrt(np.mean(error**2)) / case["noise"]) if mask.any() else np.nan
        rows.append(row)
    return rows


def summary(table: pd.DataFrame) -> str:
    wide = table.pivot_table(index=["function", "seed"], columns="model", values=["in", "in, untrained", "out"])
    lines = []
    settings = [name for name in SETTINGS if name in set(table["model"])]
    sides = (
        ("in", "in support"),
        ("in, untrained", "in support, the parts no model trained on"),
        ("out", "out of support"),
    )
    for side, title in sides:
        part = wide[side][["plain MFK", *settings]]
        lines += [f"**{title}**: truth-RMSE / noise", "", "| function | seed | " + " | ".join(part.columns) + " |",
                  "|---|---:|" + "---:|" * len(part.columns)]  # fmt: skip
        lines += [
            f"| {function} | {seed} | " + " | ".join(f"{v:.3f}" for v in values) + " |"
            for (function, seed), values in part.iterrows()
        ]
        ratios = {name: part[name] / part["plain MFK"] for name in settings}
        lines += [""] + [
            f"- {name} / plain MFK: median {r.median():.2f}, worst {r.max():.2f}, at most 1.05 on "
            f"{int((r <= 1.05).sum())}/{len(r)}"
            for name, r in ratios.items()
        ]
        lines.append("")
    theta = table.groupby("model")["discrepancy_theta_min"].median()
    lines.append(
        "The discrepancy's smallest length-scale parameter (level 1; SMT's lower bound 1e-6), median: "
        + ", ".join(f"{name} {theta[name]:.1e}" for name in theta.index)
    )
    seconds = table.groupby("model")["seconds"].median()
    lines.append("Fit time, median s: " + ", ".join(f"{name} {seconds[name]:.1f}" for name in seconds.index))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[12, 13])
    parser.add_argument("--functions", nargs="+", default=list(FUNCTIONS))
    parser.add_argument("--settings", nargs="+", default=DEFAULT_SETTINGS, choices=list(SETTINGS))
    parser.add_argument("--name", default="cokriging_searches")
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    rows = []
    for seed in args.seeds:
        for function in args.functions:
            rows += plant_rows(function, seed, args.settings)
            latest = rows[-1 - len(args.settings) :]
            print(f"{function:20s} seed {seed}: " + ", ".join(
                f"{r['model']} {r['in']:.3f}/{r['out']:.3f}" for r in latest), flush=True)  # fmt: skip
    table = pd.DataFrame(rows)
    title = "Co-kriging: one likelihood search or several"
    print(write_results(Path(args.out), args.name, title, table, summary(table)))


if __name__ == "__main__":
    main()
