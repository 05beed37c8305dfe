"""Benchmark: the plants of an earlier structures bank whose answer a change of the id rules could move, rerun.

Reruns, with today's code, every plant of a ``structures_bank.py`` CSV that got a wrong answer, named an id, or
holds a coil effect (the plants the id rules can touch; ``--all``: every plant; ``--below-limit``: the plants whose
effect is below the surrogate's own uncertainty), and writes a table of the answer before and after, with the ids
named and what the report calls too small to tell from the surrogate's own error. The baselines (TreeSHAP, the EBM)
are not rerun: they do not depend on the diagnosis. "Before" is the bank's own run, so every commit since moves it;
``--against`` names an earlier rerun's CSV (another commit's) and lists the plants whose causes or too-small
effects differ from it, which isolates one change. Usage:

    python benchmarks/bank_redo.py benchmarks/results/structures_bank_seed4.csv --out benchmarks/results/x.md
    python benchmarks/bank_redo.py BANK.csv --all --out new.md --against benchmarks/results/bank_redo_seed4_all.csv
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin.demo import scenarios, structures


def touched(bank: pd.DataFrame) -> pd.DataFrame:
    """The plants a change of the id rules can move: a wrong answer, an id named, or a coil effect."""
    return bank[~bank["answer_ok"] | bank["id_named"] | (bank["kind"] == "coil")]


def rerun(row, jobs: int) -> dict:
    case = structures.draw_structure_plant(row.kind, int(row.draw))
    outcome = scenarios.evaluate(case, int(row.draw), n_jobs=jobs, generator="structures", baseline=False)
    return dict(
        kind=row.kind,
        draw=int(row.draw),
        size=round(float(row.size_ratio), 2),
        before=bool(row.answer_ok),
        after=outcome.answer_ok,
        id_before=bool(row.id_named),
        id_after=any(c.form == "group" for c in outcome.chosen),
        chosen_before=row.chosen if isinstance(row.chosen, str) else "",
        chosen_after="; ".join(f"{c.cause}/{c.form}" for c in outcome.chosen),
        too_small_after="; ".join(outcome.too_small),
        id_too_small=any(small.endswith("/group") for small in outcome.too_small),
    )


def below_limit_words(bank: pd.DataFrame, redone: pd.DataFrame) -> list[str]:
    """On the plants rerun whose effect is below the surrogate's own uncertainty: what the report says."""
    below = redone[redone["draw"].isin(bank.loc[bank["below_limit"].astype(bool), "draw"])]
    if below.empty:
        return []
    named = below["chosen_after"].fillna("") != ""
    small = ~named & (below["too_small_after"].fillna("") != "")
    return [
        f"below the surrogate's uncertainty ({len(below)} plants rerun): a cause named on {int(named.sum())}; "
        f"'too small to tell from the surrogate's own error' on {int(small.sum())} (an id among them on "
        f"{int((small & below['id_too_small']).sum())}); nothing found by the test on {int((~named & ~small).sum())}"
    ]


def against_words(earlier: pd.DataFrame, redone: pd.DataFrame, name: str) -> list[str]:
    """The plants rerun both here and in an earlier rerun whose chosen causes (and too-small effects, where the
    earlier rerun recorded them) differ."""
    columns = [c for c in ("chosen_after", "too_small_after") if c in earlier.columns]
    both = earlier[["draw", *columns]].merge(redone[["kind", "draw", *columns]], on="draw", suffixes=("_then", "_now"))
    both = both.fillna("")
    moved = both[np.any([both[f"{c}_then"] != both[f"{c}_now"] for c in columns], axis=0)]
    labels = {c: c.removesuffix("_after").replace("_", " ") for c in columns}
    compared = " and ".join(labels.values())
    lines = ["", f"against {name}: {len(both)} plants in both, {len(moved)} with another {compared}"]
    if len(moved):
        lines += ["", "| kind | draw | " + " | ".join(f"{labels[c]} then | {labels[c]} now" for c in columns) + " |"]
        lines += ["|---|---:|" + "---|---|" * len(columns)]
        lines += [
            f"| {r['kind']} | {r['draw']} | "
            + " | ".join(f"{r[c + '_then']} | {r[c + '_now']}" for c in columns)
            + " |"
            for _, r in moved.iterrows()
        ]
    return lines


def report(bank: pd.DataFrame, redone: pd.DataFrame, which: str) -> str:
    no_id_effect = redone["kind"] != "coil"
    changed = redone[(redone["before"] != redone["after"]) | (redone["id_before"] != redone["id_after"])]
    right = int(bank["answer_ok"].sum()) - int(redone["before"].sum()) + int(redone["after"].sum())
    lines = [
        f"plants rerun: {len(redone)} of {len(bank)} ({which})",
        f"right answers over the bank: {int(bank['answer_ok'].sum())} -> {right} of {len(bank)}",
        f"an id named on the plants rerun without an id effect: {int(redone.loc[no_id_effect, 'id_before'].sum())} "
        f"-> {int(redone.loc[no_id_effect, 'id_after'].sum())}",
        "right answers per kind, among the plants rerun (before -> after): "
        + ", ".join(
            f"{kind} {int(g['before'].sum())} -> {int(g['after'].sum())} of {len(g)}"
            for kind, g in redone.groupby("kind", sort=False)
        ),
        *below_limit_words(bank, redone),
        "",
        "| kind | draw | size | right before | right after | chosen before | chosen after |",
        "|---|---:|---:|---|---|---|---|",
    ]
    for r in changed.itertuples():
        lines.append(
            f"| {r.kind} | {r.draw} | {r.size:.2f} | {r.before} | {r.after} | {r.chosen_before} | {r.chosen_after} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("bank", help="a structures_bank.py CSV")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", required=True, help="the Markdown table (a CSV of every plant beside it)")
    parser.add_argument("--all", action="store_true", help="rerun every plant, not only those the id rules can touch")
    parser.add_argument("--below-limit", action="store_true", help="rerun the plants whose effect is below the limit")
    parser.add_argument("--against", help="an earlier rerun's CSV: list the plants whose causes differ from it")
    args = parser.parse_args()
    warnings.filterwarnings("ignore", category=UserWarning)
    bank = pd.read_csv(args.bank)
    if args.all:
        plants, which = bank, "every plant"
    elif args.below_limit:
        plants, which = bank[bank["below_limit"].astype(bool)], "the effect below the surrogate's uncertainty"
    else:
        plants, which = touched(bank), "a wrong answer, an id named, or a coil effect"
    redone = pd.DataFrame([rerun(row, args.jobs) for row in plants.itertuples()])
    out = Path(args.out)
    redone.to_csv(out.with_suffix(".csv"), index=False)
    flags = " --all" if args.all else " --below-limit" if args.below_limit else ""
    flags += f" --against {args.against}" if args.against else ""
    command = f"python benchmarks/bank_redo.py {args.bank}{flags} --out {args.out}"
    text = f"`{command}`\n\n" + report(bank, redone, which)
    if args.against:
        text += "\n" + "\n".join(against_words(pd.read_csv(args.against), redone, args.against))
    out.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
