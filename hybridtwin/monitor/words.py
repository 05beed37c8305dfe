"""The monitor's answer in words: the summary the command prints, monitor.md, and what to do next."""

from __future__ import annotations

import numpy as np

from hybridtwin.monitor.changes import UNEXPLAINED

# what a rerun after appending the batch to the production log (config data.production) runs again: every rule
# that reads the log; the surrogate and its cross-validation read the DoE only and stay
RERUN = (
    "validate_inputs (production), support_gate, residuals, the residual model's tuning, cross-validation and "
    "fit, diagnose, model_extension, the peers, production_predictions, prediction_intervals and the report; "
    "surrogate_cv and surrogate_fit (the DoE only) do not rerun"
)


def headline(watched) -> str:
    chart, n = watched.chart, len(watched.table)
    judged = int(watched.judged.sum())
    if chart.alarm_at is None and not judged:
        return f"nothing judged: none of the {n:,} parts could be compared with the models (see below)"
    if chart.alarm_at is None and watched.departure is not None and judged:
        # quiet only because nothing after that part could be compared: not "in control"
        left = watched.departure
        where = (
            f"not judged from part {left.start_part:,} on: the batch left the settings the models can judge"
            if left.start_part > 1
            else "mostly not judged: the batch lies at settings the models cannot judge"
        )
        return (
            f"{where}: {left.text}; the {judged:,} parts judged of {n:,} behave as the models expect (statistic at "
            f"most {float(chart.statistic.max()):.1f}, limit {chart.limit:g})"
        )
    if chart.alarm_at is None:
        # the parts not judged are not vouched for: the summary says how many and why
        return (
            f"in control: the {judged:,} parts judged of {n:,} behave as the models expect (statistic at most "
            f"{float(chart.statistic.max()):.1f}, limit {chart.limit:g})"
        )
    side = "more" if chart.direction > 0 else "less"
    which = f", the chart {chart.alarmed_by}" if chart.alarmed_by else ""
    return (
        f"ALARM at part {chart.alarm_at + 1:,}: the plant measures {side} than the models expect, since about "
        f"part {chart.start_at + 1:,} (statistic above its limit {chart.limit:g}{which}; {judged:,} of {n:,} parts "
        "judged)"
    )


def unjudged(watched) -> str:
    skipped = len(watched.table) - int(watched.judged.sum())
    if not skipped:
        return ""
    share = skipped / len(watched.table)
    return (
        f"{skipped:,} of the {len(watched.table):,} parts ({share:.0%}) were not judged: they lie where the models' "
        "error was never calibrated (further from the simulations than every part that calibrated it, beyond a DoE "
        "range by more than those parts were, or unlike every logged part), so the models give no error to compare "
        "them with; `hybridtwin predict` on them says how far each lies"
    )


def departed(watched) -> str:
    """Where the batch left what the models can judge: the settings, and the residual there (no verdict)."""
    left = watched.departure
    if left is None:
        return ""
    in_headline = watched.chart.alarm_at is None and watched.judged.any()
    moved = "" if in_headline else f": {left.text}"
    unknown = "which is no verdict: the models' error at those settings is unknown"
    if left.start_part == 1:
        residual = f"; their residual averages {left.shift:+.2f} {watched.unit}, {unknown}"
        return f"{left.not_judged:.0%} of the parts lie at settings the models cannot judge{moved}" + (
            residual if np.isfinite(left.shift) else ""
        )
    residual = f"; there the residual sits {left.shift:+.2f} {watched.unit} from the parts judged before, {unknown}"
    return (
        f"from part {left.start_part:,} on, {left.not_judged:.0%} of the {left.n_after:,} parts were not judged: the "
        f"batch left the settings the models can judge{moved}" + (residual if np.isfinite(left.shift) else "")
    )


# below this many parts in the production log the limits over the regimes' levels rest on too few campaigns and
# coils: on the monitor bank's plants (families generator; docs/benchmarks.md, "Monitor"), logs of 8,000 and
# 20,000 parts gave false alarms on 8 and 6 of 21 in-control batches, logs of 30,000 on 0 and 1 of 21 (two seeds)
SHORT_LOG = 30_000


def short_log(watched) -> str:
    """The caution for limits set on a log shorter than SHORT_LOG parts ('' for a longer one, or models that did
    not store its length)."""
    if watched.log_rows is None or watched.log_rows >= SHORT_LOG:
        return ""
    return (
        f"the limits were set on a log of {watched.log_rows:,} parts, too few campaigns and coils to know how far "
        f"the plant's own level wanders (logs under {SHORT_LOG:,} parts raised false alarms on test plants): "
        "take an alarm over the regimes' levels as a hint, and append production to the log and rerun"
    )


def next_steps(watched) -> list[str]:
    """What to do after an alarm: run the simulations the change needs, and append the batch and rerun; where the
    batch left the settings the models can judge and nothing alarmed before: simulate those settings."""
    change = watched.change
    if watched.chart.alarm_at is None:
        return _after_departure(watched.departure)
    if change is None:  # an alarm not explained (the API's explain=False): nothing to learn before it is
        return []
    parts = f"the parts since part {change.start_part:,}"
    steps = [_simulate(change.outside_support, parts, change.proposed)] if change.proposed else []
    if change.kind == UNEXPLAINED:
        # a shift no logged column explains may be a fault (a gauge, a worn insert): the models would learn it
        steps.append(
            f"find what changed at about part {change.start_part:,}: no logged column explains it (a gauge, a die "
            "insert, a material lot or a setting that is not logged?); if it is a fault, fix it rather than "
            "teach it to the models"
        )
    return [*steps, _append("the offset, once the plant keeps it" if change.kind == UNEXPLAINED else "the change")]


def _after_departure(left) -> list[str]:
    """To judge the parts a batch took where the models cannot: simulations where they lie outside the support,
    and in any case the batch in the production log, so that the models learn those settings."""
    if left is None:
        return []
    parts = f"the parts since part {left.start_part:,}" if left.start_part > 1 else "the batch's parts"
    steps = [_simulate(left.outside_support, parts, left.proposed)] if left.outside_support > 0.5 else []
    return [*steps, _append(f"the settings of {parts} and can judge them next time")]


def _simulate(outside: float, parts: str, setting: dict) -> str:
    shown = ", ".join(f"{name}={value:.4g}" for name, value in setting.items())
    return (
        f"run the proposed simulations: {outside:.0%} of {parts} lie outside the support; simulate their typical "
        f"setting ({shown}), add it to the DoE, and the rerun proposes more "
        "(results/enrichment/proposed_simulations.csv)"
    )


def _append(learnt: str) -> str:
    return (
        "append the batch to the production log (config data.production) and rerun the workflow, so that the "
        f"models learn {learnt}: the rules that rerun are {RERUN}"
    )


def summary(watched) -> str:
    """What the command prints: the verdict, what changed, what to do."""
    lines = [headline(watched)]
    if watched.change is not None:
        change = watched.change
        lines.append(
            f"what changed ({change.kind}): {change.text}; the residual moved by {change.shift:+.2f} "
            f"{watched.unit} over the {change.n_after:,} parts judged since part {change.start_part:,}"
        )
    lines += [note for note in [unjudged(watched), departed(watched), short_log(watched)] if note]
    lines += [f"next: {step}" for step in next_steps(watched)]
    return "\n".join(lines)


def statistic_row(result) -> str:
    if result.group is None:  # models stored before the regime charts: the plain CUSUM of z
        return f"| statistic: allowance k, limit h | {result.reference:g}, {result.limit:g} expected errors |"
    from hybridtwin.monitor.chart import LEVEL_REFERENCE, WITHIN_REFERENCE

    return (
        f"| statistic | the higher of two CUSUMs, each scaled so that its limit (set on the log) is {result.limit:g}: "
        f"within a regime (k = {WITHIN_REFERENCE:g} within-regime SDs) and over the regimes' levels "
        f"(k = {LEVEL_REFERENCE:g} level SDs) |"
    )


def markdown(watched, batch_name: str) -> str:
    """monitor.md: the same, for the report and beside the output table."""
    table = watched.table
    judged = watched.judged
    residual = table["residual"].to_numpy(float)
    rows = [
        "| what | value |",
        "|---|---|",
        f"| parts | {len(table):,} |",
        f"| parts judged | {int(judged.sum()):,} |",
        f"| mean residual of the judged parts | {np.mean(residual[judged]) if judged.any() else float('nan'):+.2f} "
        f"{watched.unit} |",
        statistic_row(watched.chart),
    ]
    text = [f"# Monitor: {batch_name}", "", headline(watched) + ".", ""]
    if watched.change is not None:
        text += [f"**What changed** ({watched.change.kind}): {watched.change.text}.", ""]
    for note in (unjudged(watched), departed(watched), short_log(watched)):
        text += [note + ".", ""] if note else []
    steps = next_steps(watched)
    if steps:
        text += ["**Next**:", "", *[f"- {step}." for step in steps], ""]
    return "\n".join([*text, *rows, ""])
