"""Where a batch leaves what the models can judge, and which settings took it there.

A part whose trust verdict is *extrapolation* (a setting unlike every logged part, or further from the simulations
than every part that calibrated the models' in-control error) is not judged: the models' error there is unknown,
so its residual is no evidence that the plant changed. A batch that moves its settings there part-way (a setting
stepped to a level the log never had, a new campaign) then goes quiet on the chart from that part on, and "in
control" would overstate what was checked. :func:`departure` finds that part and says which settings moved: a
setting that steps there (:func:`hybridtwin.monitor.changes.step_of`), else settings beyond every logged part's,
else the setting that moved furthest (their combination is new to the log).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hybridtwin.answers.regions import IN_SUPPORT
from hybridtwin.monitor.changes import MIN_BEFORE, _step_text, _steps, clocks

LEAST_AFTER = 50  # parts from the departure to the end of the batch
GONE = 0.9  # at least this share of the parts since the departure is not judged
JUDGED_BEFORE = 0.5  # and at least this share of the parts before it was
BEYOND = 0.5  # a setting beyond every logged part's range on this share of the parts since names the departure


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
    """The index at which a 0/1 series most likely changes level (least squares of two levels), with at least
    MIN_BEFORE parts before it and LEAST_AFTER after it; None if the series is too short."""
    n = len(flags)
    if n < MIN_BEFORE + LEAST_AFTER:
        return None
    total = np.cumsum(flags)
    split = np.arange(MIN_BEFORE, n - LEAST_AFTER + 1)
    left = total[split - 1] - total[split - 1] ** 2 / split  # a 0/1 series: squares equal values
    right_sum = total[-1] - total[split - 1]
    right = right_sum - right_sum**2 / (n - split)
    return int(split[np.argmin(left + right)])


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
    before = np.asarray(judged, bool)[:at]
    shift = float(np.nanmean(residual[at:]) - (residual[:at][before].mean() if before.any() else 0.0))
    proposed = {name: float(table[name].iloc[at:].median()) for name in inputs}
    outside = float(np.mean(table["interval_region"].to_numpy(object)[at:] != IN_SUPPORT))
    n_after = len(table) - at
    return Departure(at + 1, n_after, float(unjudged[at:].mean()), columns, text, shift, outside, proposed)


def _logged_range(predictor) -> pd.DataFrame | None:
    """Per input, the lowest and highest setting of the logged parts the models keep (their novelty sample); None
    for models stored without it."""
    if predictor.neighbourhood is None:
        return None
    standardizer = predictor.gate.standardizer_
    parts = predictor.neighbourhood.parts_ * standardizer.scale_ + standardizer.mean_
    return pd.DataFrame({"low": parts.min(axis=0), "high": parts.max(axis=0)}, index=predictor.inputs)


def _moved(settings: pd.DataFrame, at: int, logged: pd.DataFrame | None) -> tuple[tuple[str, ...], str]:
    """The settings that took the batch away at index ``at``, and the words for it."""
    steps = _steps(settings, at, clocks(settings)) if at else {}
    if len(steps) == 1:
        ((name, step),) = steps.items()
        return (name,), _step_text(name, step)
    if steps:  # several settings at once: a new campaign
        names = sorted(steps, key=lambda name: -abs(steps[name][2] - steps[name][1]) / _spread(settings[name], at))
        moves = ", ".join(f"{name} {steps[name][1]:.4g} to {steps[name][2]:.4g}" for name in names)
        return tuple(names), f"a new campaign of settings at part {min(s[0] for s in steps.values()) + 1:,}: {moves}"
    since = settings.iloc[at:]
    logged = pd.DataFrame({"low": -np.inf, "high": np.inf}, index=settings.columns) if logged is None else logged
    outside = {
        name: float(np.mean((since[name] < logged.loc[name, "low"]) | (since[name] > logged.loc[name, "high"])))
        for name in settings.columns
    }
    beyond = [name for name in settings.columns if outside[name] >= BEYOND]
    if beyond:
        texts = [
            f"{name} at {since[name].median():.4g} (median), beyond every logged part's "
            f"{logged.loc[name, 'low']:.4g} to {logged.loc[name, 'high']:.4g} on {outside[name]:.0%} of the parts"
            for name in beyond
        ]
        return tuple(beyond), "; ".join(texts)
    if not at:
        return (), "no single setting lies beyond every logged part's range: their combination is new to the log"
    name = max(
        settings.columns,
        key=lambda c: abs(since[c].median() - settings[c].iloc[:at].median()) / _spread(settings[c], at),
    )
    return (), (
        f"no single setting left the logged range: their combination is new to the log (the furthest moved: "
        f"{name}, median {settings[name].iloc[:at].median():.4g} before, {since[name].median():.4g} since)"
    )


def _spread(values: pd.Series, at: int) -> float:
    """A setting's spread before the departure (its SD; a tiny floor for a constant one)."""
    return float(np.std(values.iloc[:at].to_numpy(float))) + 1e-12
