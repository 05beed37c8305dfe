"""Benchmark: plants of randomly drawn structure (hybridtwin.demo.structures) through the method (issue 27, item 4).

Each plant draws its inputs, simulator, DoE size, per-coil properties, coil length against the setting campaigns,
rhythms, its hidden effect (``structures.KINDS``) and the effect's size against the surrogate's own uncertainty
(log-uniform 0.3-10 times it). Reports the right answers (``Outcome.answer_ok``; on a plant whose effect is below
the detection limit the right answer is that nothing is significant) per effect kind and per size bin, the ids
(group columns) named on plants without a true id effect, beside two baselines on the same in-support residuals:
the column of largest mean |TreeSHAP| (``Outcome.shap_top``) and the top term of an Explainable Boosting Machine
(interpret-core). Usage:

    python benchmarks/structures_bank.py --plants 300 --seed 1
    python benchmarks/structures_bank.py --plants 26 --kinds coil wear --jobs 2
    python benchmarks/structures_bank.py --summary-of benchmarks/results/structures_bank.csv
    python benchmarks/structures_bank.py --summary-of BANK.csv BANK2.csv --overlay REDO.csv REDO2.csv --out ALL.md

Several banks are summarized as one; ``--overlay`` puts the diagnosis' answers of ``bank_redo.py`` reruns (today's
code) in place of the banks' own, plant by plant (the baselines do not depend on the diagnosis and are kept).

The EBM is fitted with 4 outer bags and 10 pairs (the library's defaults, 14 bags and 5x pairs, take about six
times as long); a baseline's top is judged as TreeSHAP's is (``Outcome.shap_correct``: the largest cause, its
near-copy, or for a product either column, and for the EBM the pair's own term too).
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin import diagnosis
from hybridtwin.demo import harness, scenarios, structures
from hybridtwin.demo.families import Expected

SIZE_BINS = (0.0, 1.0, 2.0, 5.0, np.inf)
SIZE_LABELS = ("<1", "1-2", "2-5", "5-10")  # the last bin holds the few several-cause totals above 10
EBM_SETTINGS = dict(outer_bags=4, interactions=10)
EBM_MAX_ROWS = 10_000  # as the diagnosis (its max_rows): a seeded sample of the in-support parts


def residual_table(frame: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """Every column the diagnosis may name, read as it reads them (as ``scenarios.shap_top_column`` builds
    them): numbers, timestamps as elapsed hours, text ids as categories; and each one's EBM feature type."""
    candidates, _ = diagnosis.build_candidates(frame, [], [], diagnosis.Settings(interactions=False, max_levels=10**9))
    table = pd.DataFrame({c.name: c.values.astype(str) if c.kind == "group" else c.values for c in candidates})
    return table, ["nominal" if c.kind == "group" else "continuous" for c in candidates]


def ebm_top_term(frame: pd.DataFrame, residual_values, seed: int, n_jobs: int) -> str:
    """The term of largest importance (mean |contribution|) of an EBM of the residual; pairs as 'a & b'."""
    from interpret.glassbox import ExplainableBoostingRegressor

    frame, residual_values = frame.reset_index(drop=True), np.asarray(residual_values, float)
    if len(frame) > EBM_MAX_ROWS:
        keep = np.sort(np.random.default_rng(seed).choice(len(frame), EBM_MAX_ROWS, replace=False))
        frame, residual_values = frame.iloc[keep].reset_index(drop=True), residual_values[keep]
    table, types = residual_table(frame)
    model = ExplainableBoostingRegressor(feature_types=types, n_jobs=n_jobs, random_state=seed, **EBM_SETTINGS)
    model.fit(table, residual_values)
    return str(model.term_names_[int(np.argmax(model.term_importances()))])


def baseline_names(expected: Expected, top: str) -> bool:
    """A baseline's top column or term names the largest expected cause, its near-copy, or (a product)
    either of its columns or the pair's own term."""
    if expected.cause is None:
        return False
    columns = set(top.split(" & "))
    if "*" in expected.cause:
        pair = set(expected.cause.split("*"))
        return columns == pair or (len(columns) == 1 and columns <= pair)
    return len(columns) == 1 and top in {expected.cause, expected.alias, expected.twin} - {None}


def names_any(expected: Expected, top: str) -> bool:
    """A baseline's top names any expected cause (several-cause plants)."""
    return any(baseline_names(_alone(wanted), top) for wanted in (expected, *expected.also))


def _alone(expected: Expected) -> Expected:
    """The cause without its further causes: judged as the first."""
    return replace(expected, also=())


def plant_row(kind: str, draw: int, jobs: int, n_production: int | None) -> dict:
    start = time.perf_counter()
    case = structures.draw_structure_plant(kind, draw, n_production)
    outcome = scenarios.evaluate(case, draw, n_jobs=jobs, generator="structures")
    run = harness.Run.of(case, draw, jobs)  # the same gate, surrogate and residuals as evaluate's
    inside = run.inside
    ebm_top = ebm_top_term(run.production.loc[inside].drop(columns=[case.target]), run.residual[inside], draw, jobs)
    row = {k: v for k, v in asdict(outcome).items() if k not in ("expected", "chosen", "kind")}
    id_named = any(c.form == "group" for c in outcome.chosen)
    row.update(
        kind=kind,
        draw=draw,
        size_ratio=case.size_ratio,
        cause_ratios=";".join(f"{r:.2f}" for r in case.cause_ratios),
        hidden_causes=";".join(case.hidden_causes),
        below_limit=case.below_limit,
        coil_vs_campaign=case.coil_vs_campaign,
        per_coil=";".join(case.per_coil),
        n_doe=case.n_doe,
        n_inputs=case.n_inputs,
        surrogate_std=case.surrogate_std,
        expected=outcome.expected.cause,
        expected_also=";".join(str(e.cause) for e in outcome.expected.also),
        twins=";".join(e.twin for e in (outcome.expected, *outcome.expected.also) if e.twin),
        answer_ok=outcome.answer_ok,
        correct=outcome.correct,
        chosen="; ".join(f"{c.cause}/{c.form}" for c in outcome.chosen),
        id_named=id_named,
        shap_correct=outcome.shap_correct,
        shap_any=names_any(outcome.expected, outcome.shap_top),
        ebm_top=ebm_top,
        ebm_correct=baseline_names(outcome.expected, ebm_top),
        ebm_any=names_any(outcome.expected, ebm_top),
        ratio_truth=outcome.rmse_oos_extended_hybrid_truth / outcome.rmse_oos_hybrid_truth,
        seconds_total=time.perf_counter() - start,
    )
    return row


def run(kinds: list[str], n_plants: int, seed: int, jobs: int, n_production: int | None, out: Path) -> pd.DataFrame:
    """The plants, kinds cycled; the CSV is rewritten after each plant, so that a long bank can be read as it runs."""
    rows = []
    for index in range(n_plants):
        kind, draw = kinds[index % len(kinds)], seed * 10_000 + index
        row = plant_row(kind, draw, jobs, n_production)
        rows.append(row)
        pd.DataFrame(rows).to_csv(out, index=False)
        print(
            f"{index:3d} {kind:14s} size={row['size_ratio']:5.2f} answer={row['answer_ok']!s:5s} "
            f"expected={row['expected']} chosen=[{row['chosen']}] shap={row['shap_top']} ebm={row['ebm_top']} "
            f"({row['seconds_total']:.0f} s, draw {draw}) | {row['effect']}",
            flush=True,
        )
    return pd.DataFrame(rows)


def _count(flags: pd.Series) -> str:
    return f"{int(flags.sum())}/{len(flags)}" if len(flags) else "–"


def _table_row(label: str, group: pd.DataFrame) -> str:
    above = group[group["expected"].notna()]
    below = group[group["below_limit"]]
    nulls = group[group["kind"] == "none"]
    no_id_effect = group[group["kind"] != "coil"]
    return (
        f"| {label} | {len(group)} | {_count(group['answer_ok'])} | {_count(above['answer_ok'])} | "
        f"{_count(below['answer_ok'])} | {_count(nulls['answer_ok'])} | {_count(above['shap_correct'])} | "
        f"{_count(above['ebm_correct'])} | {_count(no_id_effect['id_named'])} |"
    )


HEADER = (
    "| {what} | plants | right answer | right, effect above the limit | right (nothing named), below the limit "
    "| right (nothing named), null | TreeSHAP top-1, above | EBM top term, above | an id named, no id effect |\n"
    "|---|---:|---:|---:|---:|---:|---:|---:|---:|"
)


def summary(table: pd.DataFrame) -> str:
    table = table.copy()
    table["chosen"] = table["chosen"].fillna("")  # nothing chosen: an empty field in the CSV
    above, below = table[table["expected"].notna()], table[table["below_limit"]]
    lines = [
        f"plants: {len(table)}; right answers: {_count(table['answer_ok'])}; with an effect above the detection "
        f"limit: {_count(above['answer_ok'])} (TreeSHAP top-1 column {_count(above['shap_correct'])}, any cause "
        f"{_count(above['shap_any'])}; EBM top term {_count(above['ebm_correct'])}, any cause "
        f"{_count(above['ebm_any'])}); below the limit, nothing named: {_count(below['answer_ok'])}"
        f"; null plants, nothing named: {_count(table[table['kind'] == 'none']['answer_ok'])}",
        "",
        HEADER.format(what="effect kind"),
        *[_table_row(kind, group) for kind, group in table.groupby("kind", sort=False)],
        "",
        HEADER.format(what="size (effect std / surrogate's)"),
    ]
    effects = table[table["kind"] != "none"]
    bins = pd.cut(effects["size_ratio"], SIZE_BINS, labels=SIZE_LABELS, right=False)
    lines += [_table_row(str(label), group) for label, group in effects.groupby(bins, observed=True)]
    lines += _id_lines(table)
    lines += _miss_lines(table)
    lines.append(
        f"diagnosis time: median {table['seconds_diagnosis'].median():.1f} s, "
        f"max {table['seconds_diagnosis'].max():.1f} s; "
        f"a plant with the EBM: median {table['seconds_total'].median():.0f} s"
    )
    return "\n".join(lines)


def _id_lines(table: pd.DataFrame) -> list[str]:
    """Ids named where no id effect was put in; below the limit apart (there nothing should be named at all)."""
    named = table[(table["kind"] != "coil") & table["id_named"]]
    below = table[table["below_limit"] & table["id_named"]]
    lines = [
        "",
        f"an id (group column) named on plants without a true id effect: {len(named)} of "
        f"{int((table['kind'] != 'coil').sum())}; on plants below the detection limit: {len(below)} of "
        f"{int(table['below_limit'].sum())}",
    ]
    lines += [
        f"- {r.kind} (draw {r.draw}, size {r.size_ratio:.2f}): chosen [{r.chosen}]; {r.effect}"
        for r in named.itertuples()
    ]
    return lines


def _expected_words(cause, also) -> str:
    """What was expected, as read back from the CSV (a missing value: nothing significant)."""
    if not isinstance(cause, str):
        return "nothing significant"
    return cause + (f" and {also.replace(';', ', ')}" if isinstance(also, str) and also else "")


def _miss_lines(table: pd.DataFrame) -> list[str]:
    misses = table[~table["answer_ok"]]
    if not len(misses):
        return []
    lines = ["", "not the right answer:"]
    for r in misses.itertuples():
        lines.append(
            f"- {r.kind} (draw {r.draw}, size {r.size_ratio:.2f}, coils {r.coil_vs_campaign}, DoE {r.n_doe}): "
            f"expected {_expected_words(r.expected, r.expected_also)}; chosen [{r.chosen}]; {r.effect}"
        )
    return lines


def overlaid(bank: pd.DataFrame, redone: pd.DataFrame) -> pd.DataFrame:
    """``bank`` with the diagnosis' answers of a ``bank_redo.py`` rerun in place of its own, on the plants rerun."""
    answers = {"after": "answer_ok", "chosen_after": "chosen", "id_after": "id_named"}
    redone = redone.set_index(["kind", "draw"])[list(answers)].rename(columns=answers)
    redone["chosen"] = redone["chosen"].fillna("")  # nothing chosen in the rerun: update() would skip a missing value
    table = bank.set_index(["kind", "draw"])
    table.update(redone)
    table[["answer_ok", "id_named"]] = table[["answer_ok", "id_named"]].astype(bool)
    return table.reset_index()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plants", type=int, default=len(structures.KINDS), help="number of plants, kinds cycled")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--kinds", nargs="+", default=list(structures.KINDS), choices=structures.KINDS)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--n-production", type=int, default=None, help="parts per plant (default: drawn)")
    parser.add_argument("--out", default="benchmarks/results/structures_bank.csv")
    parser.add_argument("--summary-of", nargs="+", default=None, help="only summarize banks' CSVs (.md beside)")
    parser.add_argument("--overlay", nargs="*", default=[], help="bank_redo.py CSVs whose answers replace the banks'")
    args = parser.parse_args()
    if args.summary_of:
        table = pd.concat([pd.read_csv(path) for path in args.summary_of], ignore_index=True)
        for path in args.overlay:
            table = overlaid(table, pd.read_csv(path))
        several = len(args.summary_of) > 1 or args.overlay
        out = Path(args.out if several else args.summary_of[0])
    else:
        warnings.filterwarnings("ignore", category=UserWarning)
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        table = run(args.kinds, args.plants, args.seed, args.jobs, args.n_production, out)
    text = summary(table)
    out.with_suffix(".md").write_text(text + "\n")
    print("\n" + text)


if __name__ == "__main__":
    main()
