"""Benchmark: a bank of randomized hidden-effect plants through the diagnosis and the extension.

Two generators: the demo plant with a random effect (``--generator demo``, kinds of
``scenarios.KINDS``) and the other plant families (``--generator families``, families of
``families.FAMILIES``: other names, rhythms, confounding and numbers of causes). Reports per
kind: top-1 cause with its form family (strict), the tests' criteria (an honestly reported
alias counts), the top-1 of mean |TreeSHAP| of an XGBoost residual model (the baseline),
false discoveries on null plants, both causes on two-cause plants, and the extended hybrid's
out-of-support error against the truth over the paper's hybrid's. Usage:

    python benchmarks/diagnosis_bank.py --generator families --scenarios 80 --seed 1
    python benchmarks/diagnosis_bank.py --generator demo --scenarios 42 --seed 1
    python benchmarks/diagnosis_bank.py --summary-of benchmarks/results/diagnosis_bank_families.csv

Out of the support, the even blocks of consecutive parts choose whether the extended hybrid stands there
(the guard; elsewhere the paper's hybrid stands) and the odd blocks are scored, as in the workflow.
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import asdict
from pathlib import Path

import pandas as pd

from hybridtwin.demo import families, scenarios


def run(generator: str, kinds: list[str], n_scenarios: int, seed: int, n_production: int, jobs: int) -> pd.DataFrame:
    rows = []
    all_kinds = list(scenarios.KINDS if generator == "demo" else families.FAMILIES)
    for index in range(n_scenarios):
        kind = kinds[index % len(kinds)]
        draw = seed * 1000 + all_kinds.index(kind) * 100 + index
        start = time.perf_counter()
        outcome = scenarios.run_scenario(kind, draw, n_production, jobs, generator=generator)
        row = {k: v for k, v in asdict(outcome).items() if k not in ("expected", "chosen")}
        row.update(
            draw=draw,
            expected=outcome.expected.cause,
            correct=outcome.correct,
            answer_ok=outcome.answer_ok,
            diagnosis_ok=outcome.diagnosis_ok,
            gain_ok=outcome.gain_ok,
            no_worse=outcome.no_worse,
            others_found=outcome.others_found,
            shap_correct=outcome.shap_correct,
            chosen="; ".join(f"{c.cause}/{c.form}" for c in outcome.chosen),
            ratio_truth=outcome.rmse_oos_extended_hybrid_truth / outcome.rmse_oos_hybrid_truth,
            seconds_total=time.perf_counter() - start,
        )
        rows.append(row)
        print(
            f"{index:3d} {kind:14s} correct={outcome.correct!s:5s} answer={outcome.answer_ok!s:5s} "
            f"chosen=[{row['chosen']}] shap={outcome.shap_top} ratio={row['ratio_truth']:.2f} "
            f"(draw {draw}) | {outcome.effect}",
            flush=True,
        )
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame) -> str:
    lines = []
    effects = table[table["expected"].notna()]
    nulls = table[table["expected"].isna()]
    lines.append(
        f"plants: {len(table)}; right answer (the cause and its form family first, a column the data cannot "
        f"tell from it only with the pair reported, both causes of two): {effects['answer_ok'].mean():.1%} "
        f"({effects['answer_ok'].sum()}/{len(effects)}); strict top-1 (the hidden cause itself first): "
        f"{effects['correct'].sum()}/{len(effects)}; with any reported alias: "
        f"{effects['diagnosis_ok'].sum()}/{len(effects)}; TreeSHAP top-1 column: "
        f"{effects['shap_correct'].sum()}/{len(effects)}"
    )
    lines.append(f"false discoveries on null plants: {(nulls['n_significant'] > 0).sum()}/{len(nulls)}")
    two = table[table["kind"] == "two_causes"]
    if len(two):
        lines.append(f"two-cause plants with both causes named: {(two['answer_ok']).sum()}/{len(two)}")
    ratio = table["ratio_truth"]
    lines.append(
        f"extended hybrid over the paper's hybrid, out of support (odd blocks), against the truth: median "
        f"{ratio.median():.2f}, worst {ratio.max():.2f}; at most 1.1 in {(ratio <= 1.1).sum()}/{len(ratio)}"
    )
    if "extension_stands" in table:
        effects_stand = effects["extension_stands"]
        lines.append(
            f"the extended hybrid stands out of support (chosen on the even blocks) on {effects_stand.sum()}/"
            f"{len(effects)} plants with an effect and {nulls['extension_stands'].sum()}/{len(nulls)} null plants; "
            "elsewhere the paper's hybrid stands there"
        )
    lines.append("")
    lines.append(
        "| kind | plants | right answer (ours) | strict top-1 | any alias | TreeSHAP top-1 "
        "| ratio median | ratio worst | extension stands out of support |"
    )
    lines.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for kind, group in table.groupby("kind", sort=False):
        shap = f"{group['shap_correct'].sum()}/{len(group)}" if group["expected"].notna().all() else "–"
        lines.append(
            f"| {kind} | {len(group)} | {group['answer_ok'].sum()}/{len(group)} | "
            f"{group['correct'].sum()}/{len(group)} | "
            f"{group['diagnosis_ok'].sum()}/{len(group)} | {shap} | {group['ratio_truth'].median():.2f} | "
            f"{group['ratio_truth'].max():.2f} | {group['extension_stands'].sum()}/{len(group)} |"
        )
    misses = table[~table["answer_ok"] | (table["ratio_truth"] > 1.1)]
    if len(misses):
        lines.append("")
        lines.append("misses (not the right answer, or ratio above 1.1):")
        for row in misses.itertuples():
            lines.append(
                f"- {row.kind} (draw {row.draw}): {row.effect}; chosen [{row.chosen}]; ratio {row.ratio_truth:.2f}"
            )
    lines.append(
        f"diagnosis time: median {table['seconds_diagnosis'].median():.1f} s, "
        f"max {table['seconds_diagnosis'].max():.1f} s"
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generator", choices=("demo", "families"), default="families")
    parser.add_argument("--scenarios", type=int, default=16, help="number of plants, cycled over the kinds")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--n-production", type=int, default=70_000, help="demo plants only")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--kinds", nargs="+", default=None)
    parser.add_argument("--out", default=None)
    parser.add_argument("--summary-of", default=None, help="only rewrite the summary (.md) of a bank's CSV")
    args = parser.parse_args()
    if args.summary_of:
        out = Path(args.summary_of)
        table = pd.read_csv(out)
        if "extension_stands" not in table:
            parser.error(f"{out} was written before the out-of-support guard: run the bank again")
    else:
        warnings.filterwarnings("ignore", category=UserWarning)
        kinds = args.kinds or list(scenarios.KINDS if args.generator == "demo" else families.FAMILIES)
        table = run(args.generator, kinds, args.scenarios, args.seed, args.n_production, args.jobs)
        out = Path(args.out or f"benchmarks/out/diagnosis_bank_{args.generator}.csv")
        out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(out, index=False)
    text = summary(table)
    out.with_suffix(".md").write_text(text + "\n")
    print("\n" + text)


if __name__ == "__main__":
    main()
