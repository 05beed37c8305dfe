"""Benchmark: how often an id is named where its offsets are nothing but the surrogate's own error (issue 27).

Constructed nulls: L coils of a material (an input constant within each coil) and a setting that varies part by
part; each coil's offset one draw of the surrogate's error, of std ``surrogate_std`` (the surrogate's uncertainty
as the diagnosis is told it), plus measurement noise. No cause is in the residual, so a named coil is a false
discovery. Counted with the id rule as it is (the spread of L draws, :func:`hybridtwin.diagnosis.ids.surrogate_spread`)
and with the margin alone (the rule before it). Usage:

    python benchmarks/id_null_level.py --draws 100 --out benchmarks/results/id_null_level.md
"""

from __future__ import annotations

import argparse
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd

from hybridtwin import diagnosis
from hybridtwin.diagnosis import ids

LEVELS = (10, 21, 40, 80)
PARTS_PER_COIL = 60
NOISE = 0.5  # measurement noise, in units of the surrogate's uncertainty


def null_plant(n_coils: int, seed: int) -> tuple[pd.DataFrame, np.ndarray]:
    rng = np.random.default_rng([27, n_coils, seed])
    coil = np.repeat(np.arange(n_coils), PARTS_PER_COIL)
    frame = pd.DataFrame(
        {
            "coil": [f"C-{c:03d}" for c in coil],
            "rm_mpa": rng.uniform(280, 380, n_coils)[coil],
            "cushion_kn": rng.uniform(150, 350, len(coil)),
        }
    )
    return frame, rng.normal(0, 1.0, n_coils)[coil] + rng.normal(0, NOISE, len(coil))


def named(frame: pd.DataFrame, y: np.ndarray, seed: int) -> set[str]:
    """The causes the diagnosis names on a null plant (each a false discovery)."""
    settings = diagnosis.Settings(seed=seed, interactions=False)
    result = diagnosis.diagnose(frame, y, ["rm_mpa", "cushion_kn"], [], settings, surrogate_std=1.0)
    return {fit.candidate.name for fit in result.selected}


def rates(draws: int) -> pd.DataFrame:
    rows = []
    for n_coils in LEVELS:
        plants = [null_plant(n_coils, seed) for seed in range(draws)]
        spread = [named(frame, y, seed) for seed, (frame, y) in enumerate(plants)]
        with mock.patch.object(ids, "surrogate_spread", lambda error_std, n_levels, alpha: 0.0):
            margin = [named(frame, y, seed) for seed, (frame, y) in enumerate(plants)]
        rows.append(
            dict(
                coils=n_coils,
                draws=draws,
                named_spread_rule=np.mean(["coil" in names for names in spread]),
                anything_spread_rule=np.mean([bool(names) for names in spread]),
                named_margin_alone=np.mean(["coil" in names for names in margin]),
            )
        )
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=100)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    table = rates(args.draws)
    lines = [
        f"`python benchmarks/id_null_level.py --draws {args.draws} --out {args.out}`",
        "",
        f"Constructed nulls: each coil's offset one draw of the surrogate's error (std 1, as told to the diagnosis), "
        f"noise {NOISE}, {PARTS_PER_COIL} parts per coil, a per-coil material input and a setting; alpha "
        f"{diagnosis.Settings().alpha}. Share of plants where the coil id is named, and where anything is (each a "
        "false discovery):",
        "",
        "| coils | plants | coil named: spread rule (today) | anything named: spread rule | coil named: margin alone |",
        "|---:|---:|---:|---:|---:|",
        *(
            f"| {r.coils} | {r.draws} | {r.named_spread_rule:.1%} | {r.anything_spread_rule:.1%} | "
            f"{r.named_margin_alone:.1%} |"
            for r in table.itertuples()
        ),
    ]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
