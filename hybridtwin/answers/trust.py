"""How far to trust an answer: a plain verdict per row, and the reason in words.

- ``validated``: in the support and inside every DoE range, and like the logged production: the simulations back
  the setting, and the residual models learnt from production parts like it;
- ``calibrated``: outside the support (or beyond a DoE range inside the gate), but no further from the
  simulations than production parts whose errors calibrated or tested the interval: the interval was checked there;
- ``extrapolation``: further than every logged part, or beyond a DoE range by more than the logged parts
  were, or unlike every logged production part as no period of the log was unlike the rest
  (:mod:`.novelty`; inside the support too, where the simulations back the setting but the correction of them
  was never learnt). Nothing checked an interval there: the answer has none (``pred_lower``,
  ``pred_upper`` empty), and the reason names the input and how far it lies beyond the simulations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.answers.regions import same_word

VALIDATED, CALIBRATED, EXTRAPOLATION = "validated", "calibrated", "extrapolation"
TRUST = (VALIDATED, CALIBRATED, EXTRAPOLATION)


@dataclass(frozen=True)
class Reach:
    """What calibrated and tested the intervals: the support's threshold, the furthest kNN distance of a logged part
    (calibration and test blocks alike), and per input how far below the DoE's minimum and above its maximum logged
    parts were (<= 0, >= 0)."""

    threshold: float
    max_distance: float | None
    beyond: dict[str, tuple[float, float]]
    doe_range: dict[str, tuple[float, float]]
    units: dict[str, str]
    novelty: float | None = None  # the largest distance of a log period's parts to the rest of the log

    @classmethod
    def of(cls, beyond: pd.DataFrame, distance, outside, threshold, doe_range, units=None) -> "Reach":
        """From the logged parts' signed distances beyond the DoE's ranges (:func:`regions.outside_range`) and kNN
        distances; ``outside``: which of them lie out of the support."""
        distance, outside = np.asarray(distance, float), np.asarray(outside, bool)
        furthest = float(distance[outside].max()) if outside.any() else None
        reach = {name: (min(0.0, float(beyond[name].min())), max(0.0, float(beyond[name].max()))) for name in beyond}
        return cls(float(threshold), furthest, reach, dict(doe_range), dict(units or {}))


@dataclass
class _Levels:
    """Each row's verdict and what decided it."""

    trust: np.ndarray
    inside: np.ndarray
    amounts: np.ndarray
    distance: np.ndarray
    past_reach: np.ndarray
    too_far: np.ndarray
    novel: np.ndarray


def _levels(in_support, beyond: pd.DataFrame, distance, reach: Reach, novelty=None) -> _Levels:
    inside = np.asarray(in_support, bool)
    distance = np.asarray(distance, float)
    amounts = beyond[list(reach.beyond)].to_numpy(float)
    low = np.array([reach.beyond[name][0] for name in reach.beyond])
    high = np.array([reach.beyond[name][1] for name in reach.beyond])
    past_reach = (amounts < low - 1e-12) | (amounts > high + 1e-12)
    # no logged part out of the support: no interval was ever checked there
    too_far = ~inside & (True if reach.max_distance is None else distance > reach.max_distance)
    in_range = ~(amounts != 0).any(axis=1)
    novel = np.zeros(len(distance), bool)
    if novelty is not None and reach.novelty is not None:
        # in the validated domain as well: the simulations back such a setting, but the residual models, which
        # correct them, never learnt from a part like it
        novel = np.asarray(novelty, float) > reach.novelty
    trust = same_word(len(distance), CALIBRATED)
    trust[inside & in_range] = VALIDATED
    trust[past_reach.any(axis=1) | too_far | novel] = EXTRAPOLATION
    return _Levels(trust, inside, amounts, distance, past_reach, too_far, novel)


def trust_levels(in_support, beyond: pd.DataFrame, distance, reach: Reach, novelty=None) -> np.ndarray:
    """``trust`` per row, without the reasons (their words cost most of the time and memory on a long log)."""
    return _levels(in_support, beyond, distance, reach, novelty).trust


def verdicts(in_support, beyond: pd.DataFrame, distance, reach: Reach, novelty=None) -> tuple[np.ndarray, np.ndarray]:
    """``trust`` and ``trust_reason`` per row (``beyond``: each input's signed distance beyond the DoE's range;
    ``novelty``: each row's distance to the logged production, :class:`novelty.ProductionNeighbourhood`)."""
    found = _levels(in_support, beyond, distance, reach, novelty)
    trust, inside, amounts, distance = found.trust, found.inside, found.amounts, found.distance
    reason = np.full(len(trust), "", dtype=object)
    rows = trust == VALIDATED
    reason[rows] = _validated(distance[rows], reach.threshold)
    rows = trust == CALIBRATED
    reason[rows] = _calibrated(inside[rows], amounts[rows], distance[rows], reach)
    rows = trust == EXTRAPOLATION
    reason[rows] = _extrapolated(found.past_reach[rows], amounts[rows], distance[rows], reach)
    only_novel = found.novel & ~found.past_reach.any(axis=1) & ~found.too_far
    if only_novel.any():
        simulated = (inside & ~(amounts != 0).any(axis=1))[only_novel]
        reason[only_novel] = _novel(np.asarray(novelty, float)[only_novel], simulated, reach)
    return trust, reason


def _novel(novelty, simulated, reach: Reach) -> np.ndarray:
    """``simulated``: in the support and every DoE range (the simulations back the setting)."""
    seen = np.where(simulated, "the simulations back it, but ", "").astype(object)
    return (
        "settings unlike every logged production part (distance "
        + numbers(novelty)
        + f" to the nearest, where no period of the log lay further than {reach.novelty:.3g} from the rest): "
        + seen
        + "the plant was never seen here, no interval"
    )


def numbers(values) -> np.ndarray:
    # Python's own formatting: three times numpy.char.mod's speed, the same text
    return np.array(["%.3g" % value for value in np.asarray(values, float).tolist()], dtype=object)


def _validated(distance, threshold: float) -> np.ndarray:
    return (
        "in the validated domain: every input inside the DoE's range, kNN distance "
        + numbers(distance)
        + f" within the support's {threshold:.3g}"
    )


def _calibrated(inside, amounts, distance, reach: Reach) -> np.ndarray:
    where = np.where(inside, "inside the support (kNN distance ", "outside the support (kNN distance ").astype(object)
    side = np.where(inside, " within ", " beyond ").astype(object)
    text = where + numbers(distance) + side + f"{reach.threshold:.3g})"
    beyond = (amounts != 0).any(axis=1)
    text[beyond] = text[beyond] + "; " + _beyond(amounts[beyond], _worst_input(amounts[beyond], reach), reach)
    furthest = f" (kNN distance up to {reach.max_distance:.3g})" if reach.max_distance is not None else ""
    return text + "; production parts this far calibrated or tested the interval" + furthest


def _extrapolated(past_reach, amounts, distance, reach: Reach) -> np.ndarray:
    """The input furthest past what calibrated or tested the interval, or the distance when no input is."""
    scaled = np.where(past_reach, np.abs(amounts) / _spans(reach), -np.inf)
    worst = np.argmax(scaled, axis=1)
    by_input = (
        _beyond(amounts, worst, reach)
        + " ("
        + numbers(np.abs(amounts[np.arange(len(worst)), worst]) / _spans(reach)[worst])
        + " times the DoE's range beyond it); no production part this far calibrated or tested the interval: "
        + "no interval"
    )
    furthest = f"up to {reach.max_distance:.3g}" if reach.max_distance is not None else "none out of the support"
    by_distance = (
        "kNN distance "
        + numbers(distance)
        + f" to the simulations is beyond every production part that calibrated or tested the interval ({furthest}): "
        + "no interval"
    )
    return np.where(past_reach.any(axis=1), by_input, by_distance).astype(object)


def _spans(reach: Reach) -> np.ndarray:
    return np.array([max(high - low, 1e-12) for low, high in (reach.doe_range[name] for name in reach.beyond)])


def _worst_input(amounts, reach: Reach) -> np.ndarray:
    return np.argmax(np.abs(amounts) / _spans(reach), axis=1)


def _beyond(amounts, worst, reach: Reach) -> np.ndarray:
    """'thickness_mm 2 is 1.22 mm above the DoE's maximum 0.778' for each row's input ``worst``."""
    names = np.array(list(reach.beyond), dtype=object)[worst]
    amount = amounts[np.arange(len(worst)), worst]
    units = np.array([(" " + reach.units[n]) if reach.units.get(n) else "" for n in reach.beyond], dtype=object)[worst]
    bounds = np.array([reach.doe_range[n] for n in reach.beyond], float).reshape(-1, 2)[worst]
    above = amount > 0
    bound = np.where(above, bounds[:, 1], bounds[:, 0])
    value = bound + amount
    side = np.where(above, " above the DoE's maximum ", " below the DoE's minimum ").astype(object)
    return names + " " + numbers(value) + " is " + numbers(np.abs(amount)) + units + side + numbers(bound)
