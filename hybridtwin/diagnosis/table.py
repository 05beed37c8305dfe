"""The diagnosis as a table (discrepancy_causes.csv) and as the summary later steps read (diagnosis.json)."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hybridtwin.diagnosis import forms
from hybridtwin.diagnosis.fits import Rules, is_significant
from hybridtwin.diagnosis.wording import (
    accounted_words,
    by_chance_words,
    settings_in_time_words,
    smooth_inputs_words,
    untold_trend_words,
)

if TYPE_CHECKING:
    from hybridtwin.diagnosis.selection import Diagnosis

log = logging.getLogger(__name__)

TOO_SMALL_SHOWN = 3  # candidates too small to tell from the surrogate's own error, named in the summary


@dataclass(frozen=True)
class Found:
    """What the selection found, as the table reports it: every candidate's marginal fit, its fit given the
    chosen causes, the chosen causes, and what could not be told apart, was explained, or stands for a cause."""

    marginal: dict
    conditional: dict
    chosen: list
    aliases: dict
    explained_by: dict
    proxies: dict
    by_chance: dict = field(default_factory=dict)  # column -> (the id that holds it, its levels, p)
    follows_inputs: dict = field(default_factory=dict)  # a trend in time that follows the settings -> TrendTest
    untold_trends: dict = field(default_factory=dict)  # a chosen trend the test could not see -> TrendTest


def too_small(found: Found, rules: Rules) -> list:
    """The candidates the significance test finds, given the chosen causes, whose effect is within the surrogate's
    own uncertainty (std at most ``rules.min_effect``): too small to tell from the surrogate's own error. Ids
    accounted for and neighbours of a chosen cause are left out (the report says what they are). Best first."""
    if rules.min_effect <= 0:
        return []
    left_out = {fit.candidate.name for fit in found.chosen} | set(found.proxies) | set(found.explained_by)
    left_out |= set(found.follows_inputs)
    left_out |= {name for names in found.aliases.values() for name in names}
    chosen_columns = {column for fit in found.chosen for column in fit.candidate.columns}
    small = [
        fit
        for name, fit in found.conditional.items()
        if name not in left_out
        and not set(fit.candidate.columns) & chosen_columns
        and fit.effect_std <= rules.min_effect
        and is_significant(fit, rules.n_tests, rules.settings, min_effect=0.0)
    ]
    return sorted(small, key=lambda fit: (fit.score, fit.candidate.name))


def causes_table(found: Found, skipped: dict, rules: Rules) -> pd.DataFrame:
    """discrepancy_causes.csv: every candidate, the chosen causes first (in the order chosen), then by share."""
    small = {fit.candidate.name for fit in too_small(found, rules)}
    table = pd.DataFrame([_row(name, fit, found, rules, small) for name, fit in found.marginal.items()])
    order = {fit.candidate.name: i for i, fit in enumerate(found.chosen)}
    table["_chosen"] = table["cause"].map(order).fillna(len(order))
    table = table.sort_values(
        ["_chosen", "explained_share", "cause"], ascending=[True, False, True], kind="stable"
    ).drop(columns="_chosen")
    table.insert(0, "rank", np.arange(1, len(table) + 1))
    if skipped:
        log.info("columns not used as candidates: %s", skipped)
    return table.reset_index(drop=True)


def _row(name: str, fit, found: Found, rules: Rules, small: set) -> dict:
    final = next((s for s in found.chosen if s.candidate.name == name), None)
    if final is not None:
        # the marginal scores of the form that was chosen, which may not be the best-scoring one
        fit = next((alt for alt in fit.alternatives if alt.form.name == final.form.name), fit)
        significant, scored, shown = True, final, final
    else:
        scored = found.conditional.get(name, fit)
        significant = bool(rules.significant(scored if found.chosen else fit))
        significant = significant and name not in found.proxies and name not in found.follows_inputs
        shown = fit
    form = shown.form
    return {
        "cause": name,
        "kind": fit.candidate.kind,
        "form": form.name,
        "family": forms.FAMILIES[form.name],
        "n_params": int(form.n_params),
        "explained_share": fit.explained_share,
        "conditional_share": scored.explained_share,
        "effect_range": shown.effect_range,
        "effect_std": shown.effect_std,
        "p_value": scored.p_value,
        "significant": significant,
        "selected": final is not None,
        "description": form.describe(
            name, rules.settings.unit, fit.candidate.cause.unit(dict(rules.settings.input_units))
        ),
        "note": _note(name, fit, form, significant, found)
        or (_too_small_note(scored.effect_std, rules) if name in small else ""),
    }


def _too_small_note(effect_std: float, rules: Rules) -> str:
    unit = rules.settings.unit
    return (
        f"too small to tell from the surrogate's own error: significant, but it moves the residual by "
        f"{effect_std:.2f} {unit} (std), within the surrogate's own uncertainty {rules.min_effect:.2f} {unit}"
    )


def _note(name: str, fit, form, significant: bool, found: Found) -> str:
    """What the table says of a candidate beside its scores."""
    chosen = [s.candidate.name for s in found.chosen]
    alias_of = [cause for cause, names in found.aliases.items() if name in names]
    if name in found.proxies and name not in chosen:
        names, share, own_p = found.proxies[name][1:]
        if share is None:
            return "an id, not a cause: " + smooth_inputs_words(own_p)
        return (
            f"an id, not a cause: {accounted_words(names)} account for {share:.0%} of the differences between its "
            "levels (fitted on its other levels), and what is left is within what the surrogate's own error "
            "gives between its levels or passes no other rule of a cause"
        )
    if name in found.follows_inputs and name not in chosen:
        return settings_in_time_words(*found.follows_inputs[name])
    if name in found.by_chance and name not in chosen:
        group, levels, p_value = found.by_chance[name]
        return by_chance_words(name, group, levels, p_value) + f"; {group} goes first"
    if name in found.untold_trends and name in chosen:
        return untold_trend_words(*found.untold_trends[name])
    if found.aliases.get(name):
        return "cannot be told apart from " + ", ".join(found.aliases[name]) + " in this data"
    if alias_of:
        return f"cannot be told apart from {alias_of[0]} in this data"
    if name in found.explained_by:
        return f"explained by {found.explained_by[name]}: adds nothing once it is in"
    if not significant and any(set(fit.candidate.columns) & set(s.candidate.columns) for s in found.chosen):
        return "a variant of a chosen cause's column: adds nothing beyond it"
    if form.name == forms.Additive.name:
        return "no interaction: the product does not beat the two main effects"
    return ""


def summary_dict(result: Diagnosis) -> dict:
    """What the later steps and the report need: offset, chosen causes (JSON-safe), confounding."""
    descriptions = result.table.set_index("cause")["description"]  # in the target's unit
    return {
        "offset": result.offset,
        "offset_se": result.offset_se,
        "n_rows": result.n_rows,
        "residual_std": result.residual_std,
        "surrogate_std": result.surrogate_std,
        "min_effect": result.min_effect,
        "selected": [
            {
                "name": f.candidate.name,
                "kind": f.candidate.kind,
                "columns": list(f.candidate.columns),
                "form": f.form.name,
                "origin": f.candidate.origin,
                "family": forms.FAMILIES[f.form.name],
                "description": descriptions[f.candidate.name],
                "parameters": f.form.to_dict(),
                "explained_share": f.explained_share,
                "effect_range": f.effect_range,
                "effect_std": f.effect_std,
                "p_value": f.p_value,
            }
            for f in result.selected
        ],
        "aliases": result.aliases,
        "explained_by": result.explained_by,
        "skipped": result.skipped,
        "proxies": {
            name: {"accounted_by": list(proxy.names), "share": proxy.share, "own_p": proxy.own_p}
            for name, proxy in result.proxies.items()
        },
        # columns an id holds whose form fitted its level means no better than chance: the id went first
        "by_chance": {
            name: {"id": group, "levels": levels, "p_value": p_value}
            for name, (group, levels, p_value) in result.by_chance.items()
        },
        # trends in time that showed nothing between parts run at the same settings: column -> its test
        "follows_inputs": {name: test._asdict() for name, test in result.follows_inputs.items()},
        # chosen trends in time that the test between parts at the same settings could not see
        "untold_trends": {name: test._asdict() for name, test in result.untold_trends.items()},
        # found by the test, given the chosen causes, but within the surrogate's own uncertainty (best first)
        "too_small": [
            {
                "name": f.candidate.name,
                "kind": f.candidate.kind,
                "form": f.form.name,
                "explained_share": f.explained_share,
                "effect_std": f.effect_std,
                "p_value": f.p_value,
            }
            for f in result.too_small[:TOO_SMALL_SHOWN]
        ],
    }
