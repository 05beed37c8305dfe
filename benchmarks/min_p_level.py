"""Benchmark: the level of the level test's min-p (hybridtwin.diagnosis.levels.min_p) on null data.

Two statistics (a held column alone, and beside another held column) on the same shuffles, under the null: the
data and 199 shuffles exchangeable, the two statistics independent or correlated. Reports how often p falls below
5% and 1%, for ``min_p`` (each shuffle's p among the shuffles) and for the textbook Westfall-Young form (each
shuffle's p among the shuffles and the data), which with 199 shuffles cannot reach 1% unless the data beats every
shuffle in both statistics. Usage:

    python benchmarks/min_p_level.py --draws 20000 --out benchmarks/results/min_p_level.md
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from hybridtwin.diagnosis.levels import LEVEL_SHUFFLES, min_p


def textbook_min_p(observed, shuffled) -> float:
    """Westfall and Young's min-p with each shuffle's p counted over the shuffles and the data."""
    n = len(shuffled[0])
    data = min((1 + np.sum(s >= o)) / (n + 1) for o, s in zip(observed, shuffled))
    each = np.min(
        [((o >= s) + np.sum(s[None, :] >= s[:, None], axis=1)) / (n + 1) for o, s in zip(observed, shuffled)],
        axis=0,
    )
    return float((1 + np.sum(each <= data)) / (n + 1))


def rates(draws: int, correlation: float, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    ours, textbook = np.empty(draws), np.empty(draws)
    for k in range(draws):
        z = rng.normal(size=(LEVEL_SHUFFLES + 1, 2))
        z[:, 1] = correlation * z[:, 0] + np.sqrt(1 - correlation**2) * z[:, 1]
        observed, shuffled = z[0], [z[1:, 0], z[1:, 1]]
        ours[k], textbook[k] = min_p(observed, shuffled), textbook_min_p(observed, shuffled)
    return {
        "min_p < 5%": float(np.mean(ours < 0.05)),
        "min_p < 1%": float(np.mean(ours < 0.01)),
        "textbook < 5%": float(np.mean(textbook < 0.05)),
        "textbook < 1%": float(np.mean(textbook < 0.01)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=20_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="benchmarks/results/min_p_level.md")
    args = parser.parse_args()
    rows = {rho: rates(args.draws, rho, args.seed) for rho in (0.0, 0.6, 0.9)}
    columns = list(next(iter(rows.values())))
    lines = [
        f"`python benchmarks/min_p_level.py --draws {args.draws} --seed {args.seed} --out {args.out}`",
        "",
        f"Null data, two statistics on the same {LEVEL_SHUFFLES} shuffles; the share of draws with p below the level:",
        "",
        "| correlation of the statistics | " + " | ".join(columns) + " |",
        "|---:|" + "---:|" * len(columns),
    ]
    lines += [f"| {rho} | " + " | ".join(f"{row[c]:.4f}" for c in columns) + " |" for rho, row in rows.items()]
    text = "\n".join(lines) + "\n"
    Path(args.out).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
