"""Benchmark: a bank of randomized hidden-effect scenarios through the diagnosis and the extension.

Reports top-1 cause accuracy, false discoveries on null cases, the
extension's out-of-support RMSE over the noise floor, and how many scenarios
meet what the tests ask (so a bank estimates how often a random test draw fails). Usage:

    python benchmarks/diagnosis_bank.py --scenarios 21 --seed 1 --out benchmarks/out/bank.csv
"""
from __future__ import annotations

import argparse
import time
from dataclasses import asdict
from pathlib import Path

import pandas as pd

from hybridtwin import experiment


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=int, default=21, help="number of scenarios, cycled over the kinds")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--n-production", type=int, default=70_000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--kinds", nargs="+", default=list(experiment.KINDS), choices=experiment.KINDS)
    parser.add_argument("--out", default="benchmarks/out/diagnosis_bank.csv")
    args = parser.parse_args()
    rows = []
    for index in range(args.scenarios):
        kind = args.kinds[index % len(args.kinds)]
        start = time.perf_counter()
        outcome = experiment.run_scenario(kind, args.seed * 1000 + experiment.KINDS.index(kind) * 100 + index,
                                          args.n_production, args.jobs)
        row = {k: v for k, v in asdict(outcome).items() if k != "expected"}
        row.update(expected=outcome.expected.cause, correct=outcome.correct, named_or_aliased=outcome.named_or_aliased,
                   diagnosis_ok=outcome.diagnosis_ok, gain_ok=outcome.gain_ok,
                   seconds_total=time.perf_counter() - start,
                   oos_extended_over_noise=outcome.rmse_oos_extended / outcome.noise,
                   oos_extended_hybrid_over_noise=outcome.rmse_oos_extended_hybrid / outcome.noise)
        rows.append(row)
        print(f"{index:3d} {kind:13s} correct={outcome.correct!s:5s} top={outcome.top_cause}/{outcome.top_form} "
              f"oos hybrid={outcome.rmse_oos_hybrid:.2f} extended={outcome.rmse_oos_extended:.2f} "
              f"diagnosis {outcome.seconds_diagnosis:.1f}s | {outcome.effect}", flush=True)
    table = pd.DataFrame(rows)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out, index=False)
    effects, nulls = table[table["kind"] != "none"], table[table["kind"] == "none"]
    print(f"\nscenarios: {len(table)}; top-1 cause accuracy on hidden effects: {effects['correct'].mean():.1%} "
          f"({effects['correct'].sum()}/{len(effects)})")
    print(f"named or reported as cannot-be-told-apart, with the form family: {effects['diagnosis_ok'].sum()}/{len(effects)}")
    print(f"false discoveries on null cases: {(nulls['n_significant'] > 0).sum()}/{len(nulls)}")
    passed = table["diagnosis_ok"] & table["gain_ok"]
    print(f"scenarios meeting the tests' criteria (tests/test_diagnosis_scenarios.py): {passed.sum()}/{len(table)}; "
          "by kind: " + ", ".join(f"{kind} {group.sum()}/{len(group)}" for kind, group in passed.groupby(table["kind"])))
    for model in ("extended", "extended_hybrid"):
        ratio = table[f"oos_{model}_over_noise"]
        print(f"out-of-support RMSE of the {model} model over the noise floor: median {ratio.median():.2f}, "
              f"max {ratio.max():.2f}, under 1.5 in {(ratio < 1.5).sum()}/{len(ratio)}")
    print(f"diagnosis time: median {table['seconds_diagnosis'].median():.1f} s, max {table['seconds_diagnosis'].max():.1f} s")


if __name__ == "__main__":
    main()
