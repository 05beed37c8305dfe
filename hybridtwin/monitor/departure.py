"""Where a batch leaves what the models can judge, and which settings took it there.

A part whose trust verdict is *extrapolation* (a setting unlike every logged part, or further from the simulations
than every logged part whose error the intervals were calibrated or tested on) is not judged: the models' error
there is unknown, so its residual is no evidence that the plant changed. A batch that moves its settings there
part-way (a setting stepped to a level the log never had, a new campaign) then goes quiet on the chart from that
part on, and "in control" would overstate what was checked. :func:`departure` finds that part and says which
settings moved: a setting that steps there (:func:`hybridtwin.monitor.changes.step_of`; several at once: a new
campaign), else settings beyond the log's range, else none of these (the parts are unlike what calibrated the
models in another way: a combination of settings, or further from the simulations), with the setting that moved
furthest.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hybridtwin.answers.regions import IN_SUPPORT
from hybridtwin.monitor.changes import MIN_BEFORE, _step_text, _steps, two_levels, typical_setting

LEAST_AFTER = 50  # parts from the departure to the end of the batch
GONE = 0.9  # at least this share of the parts since the departure is not judged
JUDGED_BEFORE = 0.5  # and at least this share of the parts before it was
BEYOND = 0.5  # a setting beyond the logged range on this share of the parts since names the departure


@dataclass(frozen=True)
class Departure:
    start_part: int  # from 1
    n_after: int  # parts from there to the end of the batch
    not_judged: float  # share of them not judged
    columns: tuple[str, ...]  # the settings named
    text: str  # which settings took the batch there, in words
    shift: float  # the residual since the departure less the judged parts' before it (information: not judged)
    outside_support: float  # share of the parts since the departure outside the DoE's support
    proposed: dict = field(default_factory=dict)  # the departed parts' typical setting, to simulate


def split_point(flags: np.ndarray) -> int | None:
    """The index at which a 0/1 series most likely changes level (two levels by least squares), with at least
    MIN_BEFORE parts before it and LEAST_AFTER after it; None if the series is too short."""
    if len(flags) < MIN_BEFORE + LEAST_AFTER:
        return None
    split, misfit = two_levels(np.asarray(flags, float))
    allowed = (split >= MIN_BEFORE) & (split <= len(flags) - LEAST_AFTER)
    return int(split[allowed][np.argmin(misfit[allowed])])


def departure(table: pd.DataFrame, judged: np.ndarray, residual, predictor) -> Departure | None:
    """The part from which the batch stays where the models cannot judge it (at least GONE of the parts since, at
    least JUDGED_BEFORE of those before), and the settings that took it there; None if it does not leave."""
    unjudged = ~np.asarray(judged, bool)
    at = split_point(unjudged.astype(float))
    if at is None or unjudged[at:].mean() < GONE or unjudged[:at].mean() > 1 - JUDGED_BEFORE:
        if not len(unjudged) or unjudged.mean() < GONE:
            return None
        at = 0  # the batch lies there from its first parts
    inputs = [name for name in predictor.inputs if name in table]
    columns, text = _moved(table[inputs], at, _logged_range(predictor))
    residual = np.asarray(residual, float)
    before = np.asarray(judged, bool)[:at] & np.isfinite(residual[:at])
    since = residual[at:][np.isfinite(residual[at:])]
    shift = float(since.mean() - (residual[:at][before].mean() if before.any() else 0.0)) if len(since) else np.nan
    proposed = typical_setting(table, inputs, at)
    # outside the support: not in the in-support region (beyond the gate, or inside it beyond a DoE range)
    outside = float(np.mean(table["interval_region"].to_numpy(object)[at:] != IN_SUPPORT))
    n_after = len(table) - at
    return Departure(at + 1, n_after, float(unjudged[at:].mean()), columns, text, shift, outside, proposed)


def _logged_range(predictor) -> tuple[pd.DataFrame, str] | None:
    """Per input, the lowest and highest logged setting, and what they are the range of: the whole log (stored
    with the models), or for models stored before it the logged parts they keep (their novelty sample); None
    without either."""
    if predictor.logged_range is not None:
        bounds = predictor.logged_range
        low, high = [bounds[name][0] for name in predictor.inputs], [bounds[name][1] for name in predictor.inputs]
        return pd.DataFrame({"low": low, "high": high}, index=predictor.inputs), "the log's"
    if predictor.neighbourhood is None:
        return None
    standardizer = predictor.gate.standardizer_
    parts = predictor.neighbourhood.parts_ * standardizer.scale_ + standardizer.mean_
    kept = pd.DataFrame({"low": parts.min(axis=0), "high": parts.max(axis=0)}, index=predictor.inputs)
    return kept, f"the {len(parts):,} logged parts the models keep"


def _moved(settings: pd.DataFrame, at: int, logged: tuple[pd.DataFrame, str] | None) -> tuple[tuple[str, ...], str]:
    """The settings that took the batch away at index ``at``, and the words for it (``logged``: the logged range
    and its name, :func:`_logged_range`)."""
    steps = _steps(settings, at, set()) if at else {}  # the inputs are settings: none is a clock
    if len(steps) == 1:
        ((name, step),) = steps.items()
        return (name,), _step_text(name, step)
    if steps:  # several settings at once: a new campaign
        names = sorted(steps, key=lambda name: -abs(steps[name][2] - steps[name][1]) / _spread(settings[name], at))
        moves = ", ".join(f"{name} {steps[name][1]:.4g} to {steps[name][2]:.4g}" for name in names)
        return tuple(names), f"a new campaign of settings at part {min(s[0] for s in steps.values()) + 1:,}: {moves}"
    since = settings.iloc[at:]
    beyond = _beyond(since, logged) if logged is not None else {}
    if beyond:
        return tuple(beyond), "; ".join(beyond.values())
    # unlike what calibrated the models in another way: a combination of settings, or far from the simulations
    text = "no single setting stepped" + (" or left the logged range" if logged is not None else "")
    if at:
        before = settings.iloc[:at].median()
        name = max(settings.columns, key=lambda c: abs(since[c].median() - before[c]) / _spread(settings[c], at))
        text += f"; the furthest moved: {name}, median {before[name]:.4g} before, {since[name].median():.4g} since"
    return (), text + " (`hybridtwin predict` gives each part's reason)"


def _beyond(since: pd.DataFrame, logged: tuple[pd.DataFrame, str]) -> dict[str, str]:
    """The settings beyond the logged range on at least BEYOND of the parts, each with its words."""
    bounds, whose = logged
    out = {}
    for name in since.columns:
        low, high = bounds.loc[name, "low"], bounds.loc[name, "high"]
        share = float(np.mean((since[name] < low) | (since[name] > high)))
        if share >= BEYOND:
            out[name] = (
                f"{name} at {since[name].median():.4g} (median), beyond {whose} {low:.4g} to {high:.4g} on "
                f"{share:.0%} of the parts"
            )
    return out


def _spread(values: pd.Series, at: int) -> float:
    """A setting's spread before the departure (its SD; a tiny floor for a constant one)."""
    return float(np.std(values.iloc[:at].to_numpy(float))) + 1e-12
