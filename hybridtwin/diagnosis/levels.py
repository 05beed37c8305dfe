"""A column an id holds, judged over the id's levels.

A coil's material, and settings that change only where the coil does, have one value per coil: the evidence for
such a column is as many points as there are coils, however many parts each coil holds. Its closed forms are
fitted to the id's level means and judged against the columns the id holds, shuffled among the levels
(:func:`level_chance_p`).
"""

from __future__ import annotations

import math

import numpy as np

from hybridtwin.diagnosis.candidates import Candidate
from hybridtwin.diagnosis.forms import SIGMOID_WIDTH_SHARES, logistic
from hybridtwin.diagnosis.naming import between_level_ss

LEVEL_HELD = 0.95  # a column with this share of its variance between an id's levels is held by the id
LEVEL_SHUFFLES = 199  # shuffles of the level means among the held columns' values (p >= 0.005)


def level_share(labels, values) -> float:
    """The share of a column's variance that lies between the levels of an id (1: constant within each level)."""
    values = np.asarray(values, float)
    total = float(np.sum((values - values.mean()) ** 2))
    return between_level_ss(labels, values) / total if total > 0 else 0.0


def held_columns(group: Candidate, candidates: list[Candidate]) -> list[Candidate]:
    """The numeric columns (inputs and logged quantities) constant within the levels of ``group``, up to
    :data:`LEVEL_HELD` of their variance: a coil's material, or settings that change only where the coil does."""
    labels = np.asarray(group.values).astype(str)
    numeric = [c for c in candidates if c.kind in ("input", "log")]
    return [c for c in numeric if level_share(labels, c.values) >= LEVEL_HELD]


def _weighted_r2(basis: np.ndarray, means: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The weighted R^2 of ``means`` on one basis function and an intercept, for every row of ``basis``
    (..., levels): the squared weighted correlation."""
    b = basis - np.sum(basis * weights, axis=-1, keepdims=True)
    covariance = np.sum(weights * b * means, axis=-1)
    spread = np.sum(weights * b * b, axis=-1) * np.sum(weights * means * means, axis=-1)  # per row of ``means`` too
    return np.divide(covariance**2, spread, out=np.zeros_like(covariance), where=spread > 0)


def level_fit_shares(x: np.ndarray, means: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """For each row of ``x`` (orderings of one column's level values, shape (B, L)): the largest share of the
    weighted variance of the level ``means`` that a closed form of it fits -- linear, quadratic, a step (at least
    two levels on each side) or a saturation (thresholds at the inner deciles, the diagnosis' widths)."""
    weights = weights / weights.sum()
    means = means - np.sum(weights * means)
    z = (x - x.mean(axis=1, keepdims=True)) / (np.ptp(x, axis=1, keepdims=True) + 1e-300)
    linear = _weighted_r2(z, means, weights)
    # quadratic: the linear share plus the share of what the line leaves that the square's part off the line fits
    zc = z - np.sum(weights * z, axis=1, keepdims=True)
    square = z**2 - np.sum(weights * z**2, axis=1, keepdims=True)
    off_line = square - _line(zc, square, weights)
    best = linear + _weighted_r2(off_line, means - _line(zc, means, weights), weights) * (1 - linear)
    best = np.maximum(best, step_shares(x, means, weights))
    thresholds, scales = saturation_grid(x[0])  # the values are the same in every ordering
    for scale in scales:
        basis = logistic((x[:, None, :] - thresholds[None, :, None]) / scale)
        best = np.maximum(best, np.max(_weighted_r2(basis, means, weights), axis=1))
    return best


def saturation_grid(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The saturations the level test fits: thresholds at the inner deciles of ``values``, scales of the
    diagnosis' widths (shares of the values' range)."""
    span = np.ptp(values) or 1.0
    return np.quantile(values, np.linspace(0.1, 0.9, 9)), np.asarray(SIGMOID_WIDTH_SHARES) * span


def step_shares(x: np.ndarray, means: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Per row of ``x``: the share of the weighted variance of the level ``means`` (weights summing to 1, means to 0)
    that the best step fits, between two distinct values of x with at least two levels on each side (0 if none)."""
    order = np.argsort(x, axis=1, kind="stable")
    w_sorted, m_sorted = weights[order], means[order]
    below_w, below_m = np.cumsum(w_sorted, axis=1)[:, 1:-2], np.cumsum(w_sorted * m_sorted, axis=1)[:, 1:-2]
    total = np.sum(weights * means * means)
    if not below_w.shape[1] or total <= 0:
        return np.zeros(len(x))
    x_sorted = np.take_along_axis(x, order, axis=1)
    changes = (x_sorted[:, 2:-1] > x_sorted[:, 1:-2]) & (below_w < 1)  # a step lies between two values
    between = below_m**2 / below_w + below_m**2 / np.where(below_w < 1, 1 - below_w, 1.0)  # the means sum to 0
    return np.max(np.where(changes, between, 0.0), axis=1) / total


def _line(zc: np.ndarray, values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The weighted least-squares line of ``values`` on the centred ``zc``, per row."""
    slope = np.sum(weights * zc * values, axis=1, keepdims=True) / np.sum(weights * zc * zc, axis=1, keepdims=True)
    return slope * zc


def min_levels(alpha: float) -> int:
    """The fewest levels whose orderings can give a permutation p below ``alpha``: a form fits an ordering and its
    reverse alike, so L levels give L!/2 distinct fits (six levels at alpha 1%)."""
    return next(n for n in range(2, 20) if math.factorial(n) / 2 * alpha > 1)


def level_mean_weights(codes: np.ndarray, counts: np.ndarray, y) -> np.ndarray:
    """The inverse variance of each level's mean of ``y`` where every level has an offset of its own: the offsets'
    variance (the one-way ANOVA's moment estimate, none if negative) plus the parts' variance within a level over
    the level's parts. A level of 500 parts holds one draw of its offset, as a level of 20 does: weighted by parts,
    three long lots of eighteen outweighed the rest and a yield strength that fitted every lot's mean came out as
    chance (structures draw 40114, p 0.015 by parts, 0.005 so)."""
    y = np.asarray(y, float)
    n, n_levels = len(y), len(counts)
    means = np.bincount(codes, weights=y) / counts
    within = float(np.sum((y - means[codes]) ** 2)) / max(n - n_levels, 1)
    between = float(np.sum(counts * (means - y.mean()) ** 2)) / max(n_levels - 1, 1)
    per_level = (n - np.sum(counts**2) / n) / max(n_levels - 1, 1)  # the parts a level "has" in the moment estimate
    offsets = max(0.0, (between - within) / per_level)
    return 1.0 / (offsets + within / counts + 1e-300)


def level_chance_p(
    column: Candidate, group: Candidate, y, candidates: list[Candidate], seed: int, alpha: float
) -> float | None:
    """How often the level means of ``y`` over ``group``'s levels, shuffled among the levels, are fitted by a
    closed form of some column the id holds at least as well as ``column`` fits them unshuffled (a max-statistic
    permutation p-value over the held columns), alone or beside the held column that fits them best of the others
    (:func:`_beside_partner`; the two at once by :func:`min_p`); None where the id does not hold ``column``, or has
    too few levels for any ordering to reach ``alpha`` (:func:`min_levels`: nothing to tell).

    A column constant within a coil has one value per coil: its evidence is as many points as there are coils,
    however many parts each coil has. Sixteen coils' random offsets were fitted by a step in a per-coil
    anisotropy with 69% of their weighted variance, at p = 2e-17 over blocks of parts and p = 0.03 here
    (structures draw 40086); a true per-coil effect leaves the level means on its form."""
    held = held_columns(group, candidates)
    codes, counts = np.unique(np.asarray(group.values).astype(str), return_inverse=True, return_counts=True)[1:]
    if column.name not in {c.name for c in held} or len(counts) < min_levels(alpha):
        return None
    means = np.bincount(codes, weights=np.asarray(y, float)) / counts
    weights = level_mean_weights(codes, counts, y)
    level_values = {c.name: np.bincount(codes, weights=np.asarray(c.values, float)) / counts for c in held}
    rng = np.random.default_rng(seed)
    orders = np.array([rng.permutation(len(means)) for _ in range(LEVEL_SHUFFLES)])
    x = level_values[column.name]
    tests = [_shares(x, means, list(level_values.values()), weights, orders)]
    beside = _beside_partner(column.name, level_values, means, weights)
    if beside is not None:
        partner, left = beside
        others = [values for name, values in level_values.items() if name != partner]
        tests.append(_shares(x, left, others, weights, orders))
    return min_p(*zip(*tests))


def _shares(x: np.ndarray, means: np.ndarray, columns: list[np.ndarray], weights, orders: np.ndarray):
    """The share of ``means`` that ``x``'s closed forms fit (:func:`level_fit_shares`), and for each row of
    ``orders`` the largest share a column of ``columns`` (level values) fits shuffled by it."""
    observed = level_fit_shares(x[None, :], means, weights)[0]
    return observed, np.max([level_fit_shares(values[orders], means, weights) for values in columns], axis=0)


def min_p(observed, shuffled) -> float:
    """The permutation p-value of several statistics at once (larger: more evidence), each with its values on the
    same shuffles: how often a shuffle's smallest p over the statistics (each shuffle's p among the shuffles) is at
    most the data's (after Westfall and Young's min-p; one statistic: its own p, exactly).

    Westfall and Young count the data among each shuffle's p too; with 199 shuffles that form passes 1% only where
    the data beat every shuffle in every statistic (on null data 0.0% below 1%, against 0.9% here, and 4.1% below
    5% against 5.0%: benchmarks/min_p_level.py)."""
    n = len(shuffled[0])
    data = min((1 + np.sum(s >= o - 1e-12)) / (n + 1) for o, s in zip(observed, shuffled))
    each = np.min([np.sum(s[None, :] >= s[:, None] - 1e-12, axis=1) / n for s in shuffled], axis=0)
    return float((1 + np.sum(each <= data)) / (n + 1))


def _beside_partner(name: str, level_values: dict[str, np.ndarray], means, weights) -> tuple[str, np.ndarray] | None:
    """The held column other than ``name`` whose closed form fits the level ``means`` best, and what that form
    leaves of them; None where the id holds no other column.

    Two per-lot causes at once each leave the other's share of the level means as noise: on 18 constructed coils
    a thickness step beside a strength's saturation fitted the means alone no better than the held columns
    shuffled (p 0.6); against what the strength's form leaves, at p 0.005. The column is shuffled as it is, not
    adjusted for the partner, and the partner is not refitted per shuffle: where the two are correlated this test
    is conservative, and a column that only follows a held cause is passed by the test alone, as before."""
    others = {other: values for other, values in level_values.items() if other != name}
    if not others:
        return None
    shares = {other: level_fit_shares(values[None, :], means, weights)[0] for other, values in others.items()}
    partner = max(sorted(shares), key=shares.get)
    return partner, means - level_fit_values(others[partner], means, weights)


def level_fit_values(x: np.ndarray, means: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The level ``means`` as the closed form of ``x`` that fits them best (weighted least squares over the forms
    of :func:`level_fit_shares`: a line, a parabola, a step, a saturation)."""
    sqrt_w = np.sqrt(weights / weights.sum())
    best, fitted = -np.inf, np.full(len(means), np.sum(weights * means) / weights.sum())
    for basis in _level_bases(x):
        design = np.column_stack([np.ones(len(x)), basis])
        coefficients = np.linalg.lstsq(design * sqrt_w[:, None], means * sqrt_w, rcond=None)[0]
        candidate = design @ coefficients
        error = float(np.sum((sqrt_w * (means - candidate)) ** 2))
        if -error > best:
            best, fitted = -error, candidate
    return fitted


def _level_bases(x: np.ndarray) -> list[np.ndarray]:
    """The closed forms of :func:`level_fit_shares` as least-squares bases beside a constant (levels x k)."""
    z = (x - x.mean()) / (np.ptp(x) + 1e-300)
    bases = [z[:, None], np.column_stack([z, z**2])]
    xs = np.sort(x)
    bases += [(x >= xs[i + 1]).astype(float)[:, None] for i in range(1, len(x) - 2) if xs[i + 1] > xs[i]]
    thresholds, scales = saturation_grid(x)
    bases += [logistic((x - t) / scale)[:, None] for scale in scales for t in thresholds]
    return bases
