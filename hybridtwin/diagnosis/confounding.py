"""Confounding: for each chosen cause and each strong rival, does one explain anything once the other is in?"""

from __future__ import annotations

from hybridtwin.diagnosis.candidates import Candidate
from hybridtwin.diagnosis.fits import Fit, Rules
from hybridtwin.diagnosis.forms import fit_form
from hybridtwin.diagnosis.policy import MAX_RIVALS, RIVAL_SHARE


def confounding(selected: list[Fit], marginal: dict[str, Fit], y, rules: Rules):
    """For each chosen cause A and each strong marginal rival B: does B explain anything once A is in,
    and vice versa?"""
    aliases: dict[str, list[str]] = {}
    explained_by: dict[str, str] = {}
    chosen = {s.candidate.name for s in selected}
    for cause in selected:
        a = cause.candidate
        a_share = marginal[a.name].explained_share
        aliases[a.name] = []
        # rivals built on A's own column are variants of A's form, not confounders
        rivals = [
            fit
            for name, fit in marginal.items()
            if name not in chosen
            and name not in explained_by
            and not set(fit.candidate.columns) & set(a.columns)
            and fit.explained_share >= RIVAL_SHARE * a_share
            and a_share > 0
        ]
        for rival in sorted(rivals, key=lambda f: -f.explained_share)[:MAX_RIVALS]:
            b = rival.candidate
            b_adds = rules.significant(rules.best_fit(b, _without(a, cause.form.name, y)))
            a_adds = rules.significant(rules.best_fit(a, _without(b, rival.form.name, y)))
            if not a_adds and not b_adds:
                aliases[a.name].append(b.name)
            elif a_adds and not b_adds:
                explained_by[b.name] = a.name
    return aliases, explained_by


def _without(candidate: Candidate, form_name: str, y):
    fitted = fit_form(form_name, candidate.values, y).predict(candidate.values)
    remaining = y - fitted
    return remaining - remaining.mean()
