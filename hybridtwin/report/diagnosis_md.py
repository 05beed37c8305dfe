"""results/diagnosis.md: the diagnosis in words, for process and simulation engineers."""

from __future__ import annotations

import html
import re

import pandas as pd

from hybridtwin.diagnosis.wording import (
    accounted_words,
    by_chance_words,
    settings_in_time_words,
    smooth_inputs_words,
    untold_trend_words,
)
from hybridtwin.models.registry import EXTENDED, HYBRID

# the report's words for the gain table's columns
HEADERS = {
    "rmse_in_support_cv": "in support (CV)",
    "rmse_out_of_support": "out of support",
    "rmse_matched": "matched cases",
    "rmse_truth_in_support_cv": "vs truth, in support (CV)",
    "rmse_truth_out_of_support": "vs truth, out of support",
}


def text(value) -> str:
    """User-supplied text (a column name, a unit) made inert in Markdown and HTML.

    HTML is escaped; of Markdown's marks only those that act mid-line are (emphasis, code, links,
    table cells), so a description stays readable in the raw file.
    """
    return re.sub(r"([\\`*\[\]|])", r"\\\1", html.escape(str(value), quote=False))


def code(name) -> str:
    """A name as a Markdown code span, whatever it holds (a backtick in a name gets a longer fence)."""
    name = str(name)
    fence = "``" if "`" in name else "`"
    return f"{fence} {name} {fence}" if fence == "``" else f"`{name}`"


def _fmt(value, digits: int = 2) -> str:
    return "n/a" if pd.isna(value) else f"{value:.{digits}f}"


def diagnosis_markdown(
    causes: pd.DataFrame,
    summary: dict,
    gain: pd.DataFrame,
    target: str,
    unit: str,
    demo_spec: dict | None,
    figures: str,
) -> str:
    """results/diagnosis.md; ``figures``: the folder of the causes' figures, as the reader finds it."""
    unit = text(unit)
    lines = [f"# What the simulation gets wrong: {code(target)}", ""]
    lines += _data(summary, unit)
    lines += _offset(summary, target, unit)
    lines += _causes(causes, summary, target, unit, figures)
    lines += _too_small(summary, unit)
    lines += _not_separated(summary)
    lines += _gain(gain, unit)
    if demo_spec is not None:
        lines += [
            "",
            "## Demo check",
            "",
            f"The demo plant hides: {demo_spec['hidden_effect_text']}, on top of an offset of "
            f"{demo_spec['offset_mm']:g} {unit}; measurement noise {demo_spec['noise_mm']:g} {unit} "
            "(the noise floor of any RMSE against measurements).",
        ]
    return "\n".join(lines) + "\n"


def _data(summary: dict, unit: str) -> list[str]:
    n_in_support = summary.get("n_in_support", summary["n_rows"])
    sample = (
        f"a seeded random sample of {summary['n_rows']:,} of the {n_in_support:,} in-support production parts "
        "(diagnosis.max_rows)"
        if summary["n_rows"] < n_in_support
        else f"{summary['n_rows']:,} in-support production parts"
    )
    return [
        f"Data: {sample} (approximate residuals "
        f"r = measured − surrogate). Residual spread after the offset: {summary['residual_std']:.2f} {unit} (std). "
        f"The surrogate's own uncertainty on these parts is {summary['surrogate_std']:.2f} {unit}; a cause must "
        f"move the residual by more than {summary['min_effect']:.2f} {unit} (std) to count, or it could be "
        "the surrogate's error rather than the plant's.",
        "",
    ]


def _offset(summary: dict, target: str, unit: str) -> list[str]:
    offset = summary["offset"]
    direction = "higher" if offset > 0 else "lower"
    return [
        "## Offset",
        "",
        f"On average the measured {code(target)} is **{abs(offset):.2f} {unit} {direction}** than simulated "
        f"(± {2 * summary['offset_se']:.2f} {unit}, 2 standard errors over blocks of consecutive parts).",
        "",
    ]


def _causes(causes: pd.DataFrame, summary: dict, target: str, unit: str, figures: str) -> list[str]:
    lines, selected = ["## Causes", ""], summary["selected"]
    if not selected:
        lines += [
            "**No cause beyond the offset is significant.** No candidate column explains the in-support "
            "residual better on held-out parts than the offset alone, by more than the surrogate's own "
            "uncertainty. The simulation's error here is a constant offset (plus noise).",
            "",
        ]
        if len(causes) and not summary.get("too_small"):  # else the strongest found is named as too small
            top = causes.iloc[0]
            lines += [
                f"Strongest candidate, not significant: {code(top['cause'])} ({top['form']}, explains "
                f"{top['explained_share']:.1%} of the offset-free variance, p = {top['p_value']:.2g}).",
                "",
            ]
        return lines
    by_cause = causes.set_index("cause")
    for rank, cause in enumerate(selected, start=1):
        row = by_cause.loc[cause["name"]]
        lines.append(
            f"{rank}. **{code(cause['name'])}**, form *{cause['form']}* ({cause['family']}): "
            f"{text(cause['description'])}. "
            f"It explains {row['explained_share']:.1%} of the offset-free residual variance on its own "
            f"(held-out), changes {code(target)} by {cause['effect_range']:.2f} {unit} peak to peak over the "
            f"data, p = {cause['p_value']:.2g}. Figure: `{figures}/cause_{rank}.png`."
        )
    return lines + [""]


def _too_small(summary: dict, unit: str) -> list[str]:
    """Effects the test finds that are within the surrogate's own uncertainty: said as such, not named."""
    small = summary.get("too_small", [])
    if not small:
        return []
    found = "; ".join(
        f"{code(c['name'])} ({c['form']}, {c['effect_std']:.2f} {unit} std, p = {c['p_value']:.2g})" for c in small
    )
    beyond = "beyond the causes above, " if summary["selected"] else ""
    return [
        f"**Too small to tell from the surrogate's own error:** {beyond}the test finds {found}, but each moves the "
        f"residual by less than the surrogate's own uncertainty ({summary['min_effect']:.2f} {unit} std). Such an "
        "effect may be the plant's or the surrogate's own error; more simulations near the production settings "
        "would tell them apart.",
        "",
    ]


def _not_separated(summary: dict) -> list[str]:
    notes = []
    for cause, aliases in summary["aliases"].items():
        if aliases:
            notes.append(
                f"- {code(cause)} cannot be told apart from {', '.join(code(a) for a in aliases)} in this "
                "data: each explains the residual as well as the other once either is in. More varied "
                "data (or a designed trial) is needed to decide."
            )
    for proxy, named in summary.get("proxies", {}).items():
        if named["share"] is None:
            notes.append(f"- {code(proxy)} is an id, not a cause: {smooth_inputs_words(named['own_p'])}.")
            continue
        notes.append(
            f"- {code(proxy)} is an id, not a cause: it stands for whatever changes with it. "
            f"{accounted_words(named['accounted_by'], code)} account for {named['share']:.0%} of the differences "
            "between its levels, fitted on its other levels, and what is left of them is too small to tell from "
            "the surrogate's own error."
        )
    for column, test in summary.get("untold_trends", {}).items():
        notes.append(f"- {code(column)} {untold_trend_words(test['p_value'], test['power'])}.")
    for column, test in summary.get("follows_inputs", {}).items():
        notes.append(f"- {code(column)} is not named: {settings_in_time_words(test['p_value'], test['power'])}.")
    for column, held in summary.get("by_chance", {}).items():
        notes.append(
            f"- {by_chance_words(column, held['id'], held['levels'], held['p_value'], code)}, so "
            f"{code(held['id'])} is named. Levels of known, varied {code(column)} would tell them apart."
        )
    for other, cause in summary["explained_by"].items():
        notes.append(
            f"- {code(other)} looks related on its own but adds nothing once {code(cause)} is in (a correlated "
            "neighbour, not the cause)."
        )
    return ["## What could not be separated", ""] + (
        notes or ["- Nothing: the chosen causes were separated from their correlated neighbours."]
    )


def _gain(gain: pd.DataFrame, unit: str) -> list[str]:
    lines = [
        "",
        "## Gain of the extended model",
        "",
        "extended = surrogate + offset + the terms above; extended hybrid = extended + XGBoost on what is left. "
        f"RMSE in {unit}:",
        "",
    ]
    columns = [c for c in HEADERS if c in gain.columns]
    lines.append("| model | " + " | ".join(HEADERS[c] for c in columns) + " |")
    lines.append("|---" * (len(columns) + 1) + "|")
    for row in gain.itertuples():
        lines.append(f"| {row.model} | " + " | ".join(_fmt(getattr(row, c)) for c in columns) + " |")
    by_model = gain.set_index("model")
    hybrid_out = by_model.loc[HYBRID.name, "rmse_out_of_support"]
    extended_out = by_model.loc[EXTENDED.name, "rmse_out_of_support"]
    return lines + [
        "",
        f"Out of the support, where the black-box correction is not trusted, the extended model's RMSE is "
        f"{_fmt(extended_out)} {unit} against {_fmt(hybrid_out)} {unit} for the paper's hybrid "
        f"(filtered-train, no gate): "
        + (f"{1 - extended_out / hybrid_out:.0%} lower." if extended_out < hybrid_out else "no gain."),
        "",
        f"Evaluated on: {gain['evaluated_on'].iloc[0]}.",
    ]
