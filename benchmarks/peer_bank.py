"""Benchmark: the recommended model against the established peers on many plants (issues 12 and 33's goals).

On each plant (the other plant families, and the demo with its hidden-effect kinds) the paper's
hybrid, the extended hybrid, the GP discrepancy (Kennedy-O'Hagan), AR1 co-kriging (SMT MFK), their
stack and the recommended model are fitted as the workflow fits them and scored against the
noise-free truth on held-out parts (``scenarios.compare_models``), beside a plain SMT MFK and a plain
GP discrepancy fitted on the same information (``plain_baselines.py``). "Best" is the best of the
peers and the plain baselines; a region's choice holds where the recommended model is also the best
on its test blocks. Usage:

    python benchmarks/peer_bank.py --per-family 3 --seed 1
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pandas as pd
from plain_baselines import PLAIN_GP, PLAIN_MFK, plain_baselines

from hybridtwin.demo import families, scenarios
from hybridtwin.io import config
from hybridtwin.models.registry import PEER_NAMES as PEERS

BASELINES = (*PEERS, PLAIN_MFK, PLAIN_GP)
# the peers' settings a run may change (config peers.*)
PEER_KEYS = (
    "gp_n_hyper",
    "gp_n_fit",
    "cokriging_n_high",
    "cokriging_n_fit",
    "cokriging_n_start",
    "cokriging_n_searches",
)


def baselines(case, seed: int):
    """The plain baselines of a plant, on the harness run's residual table (the workflow's surrogate and gate)."""

    def fitted(run):
        return plain_baselines(case.doe, case.production, run.residuals, case.inputs, case.target, seed)

    return fitted


def run(
    per_family: int,
    seed: int,
    demo_kinds: list[str],
    jobs: int,
    peer_settings: dict | None = None,
    out=None,
    only: list[str] | None = None,
):
    """``only``: these families (their draws as in a run of all of them)."""
    rows = []
    plants = [
        ("families", family, seed * 1000 + i * 100 + j)
        for j in range(per_family)
        for i, family in enumerate(families.FAMILIES)
        if only is None or family in only
    ]
    plants += [("demo", kind, seed * 1000 + i) for i, kind in enumerate(demo_kinds)]
    for generator, kind, draw in plants:
        start = time.perf_counter()
        case = families.draw_plant(kind, draw) if generator == "families" else scenarios.demo_case(kind, draw)
        scored = scenarios.compare_models(case, draw, jobs, peer_settings=peer_settings, others=baselines(case, draw))
        best_peer_out = min(scored[f"{p}_out"] for p in BASELINES)
        best_peer_in = min(scored[f"{p}_in"] for p in BASELINES)
        holds = [v for k, v in scored.items() if k.startswith("holds_")]
        row = {
            "generator": generator,
            "kind": kind,
            "draw": draw,
            **scored,
            "ratio_out": scored["recommended_out"] / best_peer_out,
            "ratio_in": scored["recommended_in"] / best_peer_in,
            **{
                f"{peer}_over_{plain}_{side}": scored[f"{peer}_{side}"] / scored[f"{plain}_{side}"]
                for peer, plain in (("cokriging", PLAIN_MFK), ("gp_discrepancy", PLAIN_GP))
                for side in ("in", "out")
            },
            "choices_held": sum(holds),
            "choices": len(holds),
            "seconds": time.perf_counter() - start,
        }
        rows.append(row)
        if out is not None:  # a run cut short keeps the plants it did
            pd.DataFrame(rows).to_csv(out / "peer_bank.csv", index=False)
        print(
            f"{generator:8s} {kind:14s} draw {draw}: out-of-support truth-RMSE recommended "
            f"{scored['recommended_out']:.2f}, best peer {best_peer_out:.2f} (ratio {row['ratio_out']:.2f}); "
            f"in support ratio {row['ratio_in']:.2f} | {scored['recommended_models']} ({row['seconds']:.0f} s)",
            flush=True,
        )
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame) -> str:
    models = (*scenarios.COMPARED_MODELS[:-1], PLAIN_MFK, PLAIN_GP, scenarios.COMPARED_MODELS[-1])
    lines = [
        "| plants | n | "
        + " | ".join(models)
        + " | recommended / best (median, worst) | in support: worst ratio | choices held |",
        "|---|---:|" + "---:|" * len(models) + "---|---:|---:|",
    ]
    for (generator, kind), part in table.groupby(["generator", "kind"], sort=False):
        medians = " | ".join(f"{part[f'{m}_out'].median():.2f}" for m in models)
        lines.append(
            f"| {generator} {kind} | {len(part)} | {medians} | {part['ratio_out'].median():.2f}, "
            f"{part['ratio_out'].max():.2f} | {part['ratio_in'].max():.2f} | "
            f"{part['choices_held'].sum()}/{part['choices'].sum()} |"
        )
    lines.append("")
    lines.append(
        f"out of support, recommended / best of peers and plain baselines: median "
        f"{table['ratio_out'].median():.2f}, worst "
        f"{table['ratio_out'].max():.2f}, at most 1 in {(table['ratio_out'] <= 1).sum()}/{len(table)} plants; "
        f"in support: worst {table['ratio_in'].max():.2f}, within 5% in "
        f"{(table['ratio_in'] <= 1.05).sum()}/{len(table)}; a region's choice held on its test blocks in "
        f"{table['choices_held'].sum()}/{table['choices'].sum()} regions"
    )
    for peer, plain in (("cokriging", PLAIN_MFK), ("gp_discrepancy", PLAIN_GP)):
        ratios = [table[f"{peer}_over_{plain}_{side}"] for side in ("in", "out")]
        lines.append(
            f"\n{peer} / {plain}: in support median {ratios[0].median():.2f}, worst {ratios[0].max():.2f}, at most 1 "
            f"in {(ratios[0] <= 1).sum()}/{len(table)}; out of support median {ratios[1].median():.2f}, worst "
            f"{ratios[1].max():.2f}, at most 1 in {(ratios[1] <= 1).sum()}/{len(table)}; families' medians out of "
            f"support {ratios[1][table['generator'] == 'families'].median():.2f}"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--per-family", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--demo-kinds", nargs="*", default=list(scenarios.KINDS))
    parser.add_argument("--families", nargs="*", default=None, choices=families.FAMILIES, help="only these families")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", default="benchmarks/out")
    defaults = config.section_defaults("peers")
    for key in PEER_KEYS:
        parser.add_argument(f"--{key.replace('_', '-')}", type=int, default=defaults[key], help=f"peers.{key}")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    peer_settings = {key: getattr(args, key) for key in PEER_KEYS}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = run(args.per_family, args.seed, args.demo_kinds, args.jobs, peer_settings, out, args.families)
    root = Path(__file__).resolve().parent.parent
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True).stdout
    dirty = subprocess.run(["git", "status", "--porcelain", "hybridtwin", "benchmarks"], cwd=root, capture_output=True)
    text = (
        f"Command: `{' '.join(['python', *sys.argv])}`, commit {commit.strip()}"
        f"{' (with uncommitted changes)' if dirty.stdout.strip() else ''}, {table['seconds'].sum() / 60:.0f} min.\n\n"
        "table: out-of-support truth-RMSE on held-out parts (the odd blocks, where every model has an honest "
        "prediction: the same parts for all), median over plants (mm)\n\n" + summary(table)
    )
    print("\n" + text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "peer_bank.csv", index=False)
    (out / "peer_bank.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
