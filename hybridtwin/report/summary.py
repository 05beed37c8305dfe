"""The report's first page: the answer in words and numbers, before any table.

What the simulation gets wrong and how sure we are, the extended model's gain, how much of production lies in
the validated domain, which model is recommended where and with what interval, and the next simulations to
run. Written as reStructuredText: Snakemake's report shows it as the workflow's description, on the page the
report opens on.
"""

from __future__ import annotations

import re

import pandas as pd

from hybridtwin.diagnosis.wording import (
    accounted_words,
    by_chance_words,
    settings_in_time_words,
    smooth_inputs_words,
    untold_trend_words,
)
from hybridtwin.models import registry

REGION_WORDS = {"in_support": "in the validated domain (in support)"}


def summary_rst(found: dict, target: str, unit: str) -> str:
    """``found``: the run's results (keys: datasets, causes, diagnosis, gain, intervals, ranking, proposals)."""
    lines = [f"**What the simulation gets wrong, and what to do about it** (target ``{target}``, in {unit})", ""]
    lines += _errors(found["diagnosis"], target, unit)
    lines += _gain(found["gain"], unit)
    lines += _domain(found["datasets"])
    lines += _recommended(found["intervals"], found["ranking"], unit)
    lines += _proposals(found["proposals"])
    lines += [
        "*How it was computed*: a GPR surrogate of the simulations, a kNN support gate in DoE-standardized space, "
        "an XGBoost model of the approximate residuals of in-support parts (the paper's hybrid), the diagnosis of "
        "the residual, the extension with the named causes, two established peers and their blend, and split-"
        "conformal intervals per region. Every number above is on production parts the models never trained on. "
        "The tables, figures and the diagnosis in words are in the categories on the left.",
    ]
    return "\n".join(lines) + "\n"


def _errors(diagnosis: dict, target: str, unit: str) -> list[str]:
    offset = diagnosis["offset"]
    direction = "higher" if offset > 0 else "lower"
    lines = [
        f"* **Offset**: the measured ``{target}`` is {abs(offset):.2f} {unit} {direction} than simulated "
        f"(± {2 * diagnosis['offset_se']:.2f} {unit}).",
    ]
    if not diagnosis["selected"]:
        lines.append(
            f"* **Causes**: none beyond the offset is significant: no logged column moves the residual by more than "
            f"the surrogate's own uncertainty ({diagnosis['min_effect']:.2f} {unit})."
        )
    for small in diagnosis.get("too_small", [])[:1]:
        lines.append(
            f"* **Too small to tell from the surrogate's own error**: ``{small['name']}`` moves the residual by "
            f"{small['effect_std']:.2f} {unit} (std), within the surrogate's own uncertainty."
        )
    for rank, cause in enumerate(diagnosis["selected"], start=1):
        lines.append(
            f"* **Cause {rank}**: ``{cause['name']}``, {_rst(cause['description'])} (explains "
            f"{cause['explained_share']:.0%} of the residual's variance held out, p = {cause['p_value']:.1g})."
        )
    for proxy, named in diagnosis.get("proxies", {}).items():
        if named.get("share") is None:
            lines.append(f"  ``{proxy}`` is an id, not a cause: {smooth_inputs_words(named['own_p'])}.")
            continue
        accounted = accounted_words(named["accounted_by"], lambda name: f"``{name}``")
        lines.append(f"  ``{proxy}`` is an id, not a cause: {accounted} account for its offsets.")
    for column, test in diagnosis.get("untold_trends", {}).items():
        lines.append(f"  ``{column}`` {untold_trend_words(test['p_value'], test['power'])}.")
    for column, test in diagnosis.get("follows_inputs", {}).items():
        lines.append(f"  ``{column}`` is not named: {settings_in_time_words(test['p_value'], test['power'])}.")
    for column, held in diagnosis.get("by_chance", {}).items():
        words = by_chance_words(column, held["id"], held["levels"], held["p_value"], lambda name: f"``{name}``")
        lines.append(f"  {words}.")
    return lines + [""]


def _gain(gain: pd.DataFrame, unit: str) -> list[str]:
    by_model = gain.set_index("model")
    hybrid = by_model.loc[registry.HYBRID.name, "rmse_out_of_support"]
    extended = by_model.loc[registry.EXTENDED_HYBRID.name, "rmse_out_of_support"]
    if abs(1 - extended / hybrid) < 0.005:
        verdict = "the same: out of the support the paper's hybrid stands (no cause beat it beyond doubt)"
    else:
        verdict = (
            f"{1 - extended / hybrid:.0%} lower" if extended < hybrid else "higher: the paper's hybrid is the safer"
        )
    return [
        f"* **Gain out of the support**: the extended hybrid's error is {extended:.2f} {unit} (RMSE) against "
        f"{hybrid:.2f} {unit} for the paper's hybrid: {verdict} "
        f"({int(by_model.loc[registry.HYBRID.name, 'n_out_of_support']):,} held-out parts).",
        "",
    ]


def _domain(datasets: pd.DataFrame) -> list[str]:
    sizes = datasets.set_index("dataset")["size"]
    inside, everything = int(sizes.iloc[2]), int(sizes.iloc[1])
    return [
        f"* **Validated domain**: {inside:,} of {everything:,} production parts ({inside / everything:.0%}) lie "
        "in the support of the simulations; the rest are answered from models checked on parts like them, or "
        "marked as extrapolation with no interval.",
        "",
    ]


def _recommended(intervals: pd.DataFrame, ranking: dict, unit: str) -> list[str]:
    rows = intervals[(intervals["model"] == registry.RECOMMENDED) & (intervals["calibration"] == "by_region")]
    rows = rows.sort_values("region", key=lambda region: region.map(_region_order), kind="stable")
    lines = [
        ".. list-table:: Recommended model and its interval, per region (held-out production parts)",
        "   :header-rows: 1",
        "",
        "   * - region",
        "     - recommended model",
        "     - interval (mean width)",
        "     - coverage on held-out parts",
    ]
    for row in rows.itertuples():
        if row.region == "all":
            continue
        model = ranking.get(row.region, ranking.get("in_support", ["?"]))[0]
        lines += [
            f"   * - {REGION_WORDS.get(row.region, row.region_label)}",
            f"     - {registry.BY_NAME[model].label if model in registry.BY_NAME else model}",
            f"     - {row.nominal_level:.0%}: ±{row.mean_width / 2:.2f} {unit}",
            f"     - {row.coverage:.1%} ({row.coverage_low:.0%} to {row.coverage_high:.0%}, {row.n_test:,} parts)",
        ]
    return lines + [""]


def _region_order(region: str) -> tuple:
    """In support first, then the gate's parts beyond a DoE range, then out of support by distance."""
    return (region != "in_support", not region.startswith("beyond"), region)


def _proposals(proposals: pd.DataFrame) -> list[str]:
    if not len(proposals):
        return ["* **Next simulations**: none needed: every production part lies in the support.", ""]
    first = proposals.iloc[0]
    return [
        f"* **Next simulations**: {len(proposals)} proposed (``enrichment/proposed_simulations.csv``); the first "
        f"alone brings {int(first['parts_brought_in']):,} production parts into the support "
        f"({first['share_in_support_after']:.0%} of production in support after it).",
        "",
    ]


def _rst(text) -> str:
    """A user's text made inert in reStructuredText (no emphasis, references or substitutions)."""
    return re.sub(r"([\\*`|_])", r"\\\1", str(text))
