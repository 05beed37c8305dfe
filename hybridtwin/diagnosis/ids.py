"""An id is not a cause: what an id's offsets hold once the surrogate's own error and smooth plant quantities are out.

An id (coil, lot, shift) recalls each level from its own parts. Where the material is per coil, the surrogate's
own error is constant within a coil too, and coils run in time order, so a coil's offsets also follow every slow
quantity (wear, ambient temperature, the season). With one parameter per level they out-score a smooth cause
that is too small to pass the surrogate margin alone, or several causes at once.

The surrogate's error is a smooth function of the model inputs; so is any discrepancy that depends on the inputs
alone. Whatever a smooth surface of the inputs predicts of an id's offsets, fitted on the other levels and so
unable to recall a level's own offset, is not the id's. Nor is what the smooth candidates explain (those
significant on their own, uncorrected and below the margin too, the inputs' steps and bends among them). The id is
named only where its offsets, with both held out by level (the candidates alone where the surface beside them
predicts the other levels worse: :func:`held_out_remainder`), still pass every rule of a cause, and spread more than
the surrogate's error gives between as many levels (:func:`surrogate_spread`). A GPR posterior's
draws were the first candidate for this null; on the structures generator's plants the surrogate's real variance
between coils was 3.2 times the draws' (median; above their 95% quantile on 6 of 10 plants:
benchmarks/surrogate_null_calibration.py), so the null is taken from the data instead.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import minimize
from scipy.stats import chi2
from sklearn.linear_model import Ridge, RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from hybridtwin.diagnosis.candidates import Candidate
from hybridtwin.diagnosis.fits import Fit, Rules, is_significant
from hybridtwin.diagnosis.forms import SIGMOID_WIDTH_SHARES, fit_form, logistic
from hybridtwin.diagnosis.naming import between_level_ss
from hybridtwin.diagnosis.wording import INPUT_SURFACE, SMOOTH_INPUTS

# the input surface's ridge penalties, chosen held out by level; up to a surface shrunk to nothing (the smooth
# candidates then account for the offsets alone)
LEVEL_PENALTIES = np.logspace(-3, 8, 12)
MAX_SMOOTH = 3  # smooth candidates that may account for an id's offsets together with the input surface
PASSES = 3  # backfitting passes of the surface and the smooth candidates
LEVEL_HELD = 0.95  # a column with this share of its variance between an id's levels is held by the id
LEVEL_SHUFFLES = 199  # shuffles of the level means among the held columns' values (p >= 0.005)


def _quadratic(regression):
    """A regression on the standardized inputs, their squares and their products."""
    return make_pipeline(StandardScaler(), PolynomialFeatures(2, include_bias=False), regression)


def surface(inputs: np.ndarray, y: np.ndarray, penalty: float):
    """A quadratic surface of the standardized inputs (ridge, :func:`level_penalty`)."""
    return _quadratic(Ridge(alpha=penalty)).fit(inputs, y)


def level_folds(labels, n_folds: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Folds of whole levels: no level is both fitted and predicted."""
    codes = np.unique(np.asarray(labels).astype(str), return_inverse=True)[1]
    n_levels = codes.max() + 1
    fold_of_level = np.random.default_rng(seed).permutation(n_levels) % min(n_folds, n_levels)
    fold = fold_of_level[codes]
    return [(np.flatnonzero(fold != k), np.flatnonzero(fold == k)) for k in range(fold.max() + 1)]


def smooth_accounts(fits: list[Fit], rules: Rules, corrected: bool = False) -> list[Fit]:
    """The smooth candidates that may account for an id's offsets, best first: significant on their own at the
    test's level, of any size; uncorrected for the number of candidates (several small causes may account for
    the offsets together) or, ``corrected``, for them as a cause's test is (these may go before the id; the
    inputs then left to the surface); logged quantities, time, and the inputs' own closed forms (a step the
    quadratic input surface cannot hold), their products left to the surface."""
    n_tests, kinds = (rules.n_tests, ("log", "time")) if corrected else (1, ("log", "time", "input"))
    alone = [fit for fit in fits if is_significant(fit, n_tests, rules.settings, min_effect=0.0)]
    usable = [fit for fit in alone if fit.candidate.kind in kinds]
    return sorted(usable, key=lambda fit: (fit.score, fit.candidate.name))[:MAX_SMOOTH]


def _predict_held_out(train, test, y, inputs, smooth: list[Fit], penalty) -> np.ndarray:
    """The surface and the smooth candidates backfitted on ``train``, predicted on ``test``."""
    terms = [np.zeros(len(train)) for _ in smooth]
    fitted_surface = None
    for _ in range(PASSES):
        if inputs is not None:
            fitted_surface = surface(inputs[train], y[train] - sum(terms, np.zeros(len(train))), penalty)
            base = fitted_surface.predict(inputs[train])
        else:
            base = np.zeros(len(train))
        models = []
        for j, fit in enumerate(smooth):
            others = base + sum((t for k, t in enumerate(terms) if k != j), np.zeros(len(train)))
            models.append(fit_form(fit.form.name, fit.candidate.values[train], y[train] - others))
            terms[j] = models[-1].predict(fit.candidate.values[train])
    prediction = np.zeros(len(test)) if fitted_surface is None else fitted_surface.predict(inputs[test])
    return prediction + sum((m.predict(f.candidate.values[test]) for m, f in zip(models, smooth)), np.zeros(len(test)))


def level_penalty(inputs: np.ndarray, y, splits) -> float:
    """The input surface's ridge penalty by its error on levels it was not fitted on.

    Generalized cross-validation over rows chooses a penalty that recalls each level's offset from the inputs
    that are constant within a level (the material of a coil): held out by level, such a surface predicted the
    other coils' offsets worse than no surface at all (a per-coil oil film's coil offsets: twice their spread).
    """
    search = _quadratic(RidgeCV(alphas=LEVEL_PENALTIES, cv=splits, scoring="neg_mean_squared_error"))
    return float(search.fit(inputs, y).steps[-1][1].alpha_)


@dataclass(frozen=True)
class LevelDesign:
    """What an id's accounting fits on, made once per id: folds of whole levels, the inputs' matrix and the input
    surface's ridge penalty (both None without inputs)."""

    splits: list[tuple[np.ndarray, np.ndarray]]
    matrix: np.ndarray | None
    penalty: float | None

    @classmethod
    def of(cls, group: Candidate, y, inputs: list[Candidate], rules: Rules) -> "LevelDesign":
        splits = level_folds(group.values, rules.settings.folds, rules.settings.seed)
        matrix = np.column_stack([c.values for c in inputs]) if inputs else None
        return cls(splits, matrix, level_penalty(matrix, y, splits) if matrix is not None else None)


def unaccounted(
    group: Candidate, y, inputs: list[Candidate], smooth: list[Fit], rules: Rules, design: LevelDesign | None = None
) -> np.ndarray:
    """``y`` less what the input surface and the smooth candidates predict of it, both fitted on the other
    levels of ``group`` (:func:`held_out_remainder`): what the id's offsets hold beyond them. ``design``: the id's,
    if made already."""
    return held_out_remainder(group, y, inputs, smooth, rules, design)[0]


def held_out_remainder(
    group: Candidate, y, inputs: list[Candidate], smooth: list[Fit], rules: Rules, design: LevelDesign | None = None
) -> tuple[np.ndarray, bool]:
    """``y`` less what the input surface and the smooth candidates predict of it, fitted on the other levels of
    ``group``, centred; or less what the candidates alone predict, where that leaves less of the differences
    between the levels; and whether the surface was kept. The surface's penalty is chosen without the candidates
    (:func:`level_penalty`): beside a trend in time, a surface of per-lot material that drifted with it recalls
    the lots' share of the trend in fitting and predicts other lots worse than the trend alone. Of the two, the
    smaller remainder is kept, so the choice leans towards an id that does not stand."""
    design = design or LevelDesign.of(group, y, inputs, rules)

    def left_by(surface_inputs) -> np.ndarray:
        explained = np.zeros(len(y))
        for train, test in design.splits:
            explained[test] = _predict_held_out(train, test, y, surface_inputs, smooth, design.penalty)
        left = y - explained
        return left - left.mean()

    with_surface = left_by(design.matrix)
    if design.matrix is None or not smooth:
        return with_surface, design.matrix is not None
    smooth_alone = left_by(None)
    labels = np.asarray(group.values).astype(str)
    if between_level_ss(labels, smooth_alone) < between_level_ss(labels, with_surface):
        return smooth_alone, False
    return with_surface, True


def id_stands(fit: Fit, y, candidates: list[Candidate], conditional: dict[str, Fit], rules: Rules, of_inputs=None):
    """Whether an id's offsets pass the rules of a cause once the input surface and the smooth candidates are out
    (held out by level; the candidates alone where they leave less: :func:`held_out_remainder`), and spread more
    than the surrogate's own error gives between as many levels (:func:`surrogate_spread`); with the names of what
    accounts for them (the surface only where it was kept) and the share of its level differences.

    An id that stands is named after a smooth cause only where the input surface and the logged quantities and
    time significant after the correction account for its offsets (the share returned is theirs): candidates
    significant only uncorrected, and the inputs' closed forms, may not order the causes. On 22 coils in time
    order, closed forms of the ambient temperature, a cushion force and a radius took up 55% of coil offsets
    that no logged column holds, held out by level (families draw 1303).
    """
    inputs = [c for c in candidates if c.kind == "input"]
    smooth = smooth_accounts(list(conditional.values()), rules)
    design = LevelDesign.of(fit.candidate, y, inputs, rules)
    left, surface = held_out_remainder(fit.candidate, y, inputs, smooth, rules, design)
    remainder = rules.best_fit(fit.candidate, left)
    labels = np.asarray(fit.candidate.values).astype(str)
    per_level = max((level_share(labels, c.values) for c in inputs), default=0.0)
    limit = surrogate_spread(rules.min_effect * np.sqrt(per_level), len(np.unique(labels)), rules.settings.alpha)
    stands = bool(rules.significant(remainder) and remainder.effect_std > limit)
    of_inputs = y if of_inputs is None else of_inputs
    own_p = offsets_beyond_inputs_p(fit.candidate, of_inputs, inputs, rules.input_correlation) if stands else None
    if own_p is not None and own_p >= rules.settings.alpha:
        return Proxy(False, (SMOOTH_INPUTS,), None, own_p)
    if stands:  # what orders the causes: the surface and the corrected candidates
        causes = smooth_accounts(list(conditional.values()), rules, corrected=True)
        if [f.candidate.name for f in causes] != [f.candidate.name for f in smooth]:
            smooth = causes
            left, surface = held_out_remainder(fit.candidate, y, inputs, causes, rules, design)
    return Proxy(stands, _names(inputs if surface else [], smooth), accounted_share(labels, y, left), own_p)


class Proxy(NamedTuple):
    """Whether an id stands (:func:`id_stands`); what accounts for its offsets, and the share of its level
    differences they account for held out by level (None where a smooth function of the inputs takes them up
    whole); the p-value of offsets of its own beyond such a function (:func:`offsets_beyond_inputs_p`)."""

    stands: bool
    names: tuple[str, ...]
    share: float | None
    own_p: float | None = None


def offsets_beyond_inputs_p(group: Candidate, y, inputs: list[Candidate], correlation) -> float | None:
    """The p-value of offsets of the id's own beyond a smooth function of the inputs its levels ran at; None
    without inputs or without the simulator's correlation (``correlation``: :attr:`.fits.Rules.input_correlation`).

    The level means of ``y`` are a constant, plus a Gaussian process in the levels' mean inputs with the
    simulator's correlation (the surrogate's kernel, its length scales times a factor between 1/:data:`ROUGHER` and
    :data:`ROUGHER`, of any amplitude), plus each mean's sampling error; the id's own offsets add a variance of
    their own. A likelihood ratio tests that variance against none: half a chi2(1) at the boundary (Self and Liang).
    Levels that ran at near-equal inputs tell the two apart, since a smooth function cannot give them different
    offsets (coils of one campaign, their material within a few per cent of the DoE's range). Levels that each ran
    at inputs of their own do not: the function takes up their offsets as well as the id does. On bi-fidelity
    functions used as simulation and plant, a lot per campaign, an id was named over a discrepancy of the inputs
    alone on 24 of 33 plants; on 3 with this test, the chosen forms of the inputs put back into ``y``
    (:meth:`.selection.Selection._of_inputs`; benchmarks/mf_diagnosis.py)."""
    if correlation is None or not inputs:
        return None
    codes, counts = np.unique(np.asarray(group.values).astype(str), return_inverse=True, return_counts=True)[1:]
    if len(counts) < 3:
        return None
    model = LevelMeans.of(codes, counts, y, [c.values for c in inputs], correlation)
    smooth_only = model.best(own=False)
    with_own = model.best(own=True, start=smooth_only)
    ratio = max(0.0, 2.0 * (model.loglik(with_own) - model.loglik(smooth_only)))
    return float(0.5 * chi2.sf(ratio, 1)) if ratio > 0 else 1.0


ROUGHER = 10.0  # the discrepancy may vary up to ten times faster in the inputs than the simulator does


@dataclass(frozen=True)
class LevelMeans:
    """The Gaussian likelihood of an id's level means (:func:`offsets_beyond_inputs_p`); parameters: the logs of
    the smooth function's variance and of the id's own (over the means' variance), and of the length factor.
    ``regressors`` (levels x k): terms beside the constant, at their generalized least squares (a trend's values,
    :func:`~hybridtwin.diagnosis.trends.trend_test`)."""

    means: np.ndarray
    sampling: np.ndarray
    correlation: Callable[[float], np.ndarray]
    regressors: np.ndarray | None = None

    @classmethod
    def of(cls, codes, counts, y, input_values, correlation, row_regressors=()) -> "LevelMeans":
        """The model of the level means of ``y`` (a level code per row, ``counts`` rows a level), their sampling
        variance from the scatter within the levels, the correlation at the levels' mean inputs (``input_values``:
        one column per input) and the level means of ``row_regressors`` (one value per row each) beside the
        constant."""
        y = np.asarray(y, float)

        def level_means(values) -> np.ndarray:
            return np.bincount(codes, weights=np.asarray(values, float)) / counts

        means = level_means(y)
        within = float(np.sum((y - means[codes]) ** 2)) / max(len(y) - len(counts), 1)
        level_inputs = np.column_stack([level_means(values) for values in input_values])
        regressors = np.column_stack([level_means(r) for r in row_regressors]) if len(row_regressors) else None
        return cls(means, within / counts, lambda factor: correlation(level_inputs, factor), regressors)

    def _lower(self, theta) -> np.ndarray | None:
        """The Cholesky factor of the means' covariance at ``theta``; None where it is not positive definite."""
        scale = float(np.var(self.means) + np.mean(self.sampling)) or 1.0
        smooth, own, factor = np.exp(theta)
        n = len(self.means)
        covariance = scale * (smooth * self.correlation(factor) + own * np.eye(n)) + np.diag(self.sampling)
        covariance[np.diag_indices(n)] += 1e-10 * scale
        try:
            return np.linalg.cholesky(covariance)
        except np.linalg.LinAlgError:
            return None

    def loglik(self, theta) -> float:
        lower = self._lower(theta)
        if lower is None:
            return -np.inf
        white, ones = solve_triangular(lower, self.means, lower=True), self._white_ones(lower)
        if self.regressors is None:
            left = _off_constant(white, ones)
        else:
            design = np.column_stack([ones, solve_triangular(lower, self.regressors, lower=True)])
            left = white - design @ np.linalg.lstsq(design, white, rcond=None)[0]
        return float(-0.5 * left @ left - np.sum(np.log(np.diag(lower))))

    def information(self, theta, values) -> float:
        """The generalized least squares information on the coefficient of ``values`` (one per level) beside the
        constant, at ``theta``: what a coefficient of 1 gives a likelihood-ratio test as its noncentrality."""
        lower = self._lower(theta)
        if lower is None:
            return 0.0
        left = _off_constant(solve_triangular(lower, np.asarray(values, float), lower=True), self._white_ones(lower))
        return float(left @ left)

    def _white_ones(self, lower: np.ndarray) -> np.ndarray:
        return solve_triangular(lower, np.ones(len(self.means)), lower=True)

    def best(self, own: bool, start=None) -> np.ndarray:
        """The parameters of the largest likelihood, the id's own variance left at none unless ``own``."""
        limit = np.log(ROUGHER)
        bounds = [(-20.0, 12.0), (-30.0, 12.0) if own else (-30.0, -30.0), (-limit, limit)]
        starts = [(s, -30.0 if not own else o, f) for s in (-3.0, 1.0) for o in (-3.0, 0.0) for f in (-limit, 0.0)]
        if start is not None:
            starts.append(tuple(start))
        tried = [
            minimize(lambda theta: -self.loglik(theta), np.array(s, float), method="L-BFGS-B", bounds=bounds)
            for s in dict.fromkeys(starts)
        ]
        return min(tried, key=lambda result: result.fun).x


def _off_constant(white: np.ndarray, ones: np.ndarray) -> np.ndarray:
    """A whitened vector less the constant at its generalized least squares (``ones``: the whitened constant)."""
    return white - ones * (ones @ white) / (ones @ ones)


def _names(inputs: list[Candidate], smooth: list[Fit]) -> tuple[str, ...]:
    """What accounts for an id's offsets, in words: the input surface, then the smooth candidates."""
    return tuple(([INPUT_SURFACE] if inputs else []) + [f.candidate.name for f in smooth])


def accounted_share(labels, y, left) -> float:
    """The share of the differences between an id's levels in ``y`` that is gone in ``left``."""
    before = between_level_ss(labels, y)
    return float(max(0.0, 1.0 - between_level_ss(labels, left) / before)) if before > 0 else 0.0


def level_share(labels, values) -> float:
    """The share of a column's variance that lies between the levels of an id (1: constant within each level)."""
    values = np.asarray(values, float)
    total = float(np.sum((values - values.mean()) ** 2))
    return between_level_ss(labels, values) / total if total > 0 else 0.0


def surrogate_spread(error_std: float, n_levels: int, alpha: float) -> float:
    """The spread (std) of ``n_levels`` offsets that the surrogate's own error exceeds with probability ``alpha``.

    Where an input is constant within each level (the material of a coil), each level's share of the surrogate's
    error is one draw of it, of std ``error_std`` (the surrogate's uncertainty times its margin, scaled by the
    share of that input's variance between the levels: a shift, over which every input varies, holds little of
    it). The spread of L such draws exceeds ``error_std`` times sqrt(chi2_{1-alpha}(L-1) / (L-1)): the margin a
    smooth cause passes is their expected spread, and L offsets pass it by chance; an id must pass this quantile
    (1.37 times the margin for 21 coils at alpha 1%, 1.19 for 80).
    """
    dof = max(1, n_levels - 1)
    return error_std * float(np.sqrt(chi2.ppf(1.0 - alpha, dof) / dof))


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
    # a saturation: logistic bases at the inner deciles of the values, of the diagnosis' widths
    thresholds = np.quantile(x[0], np.linspace(0.1, 0.9, 9))
    span = np.ptp(x[0]) or 1.0
    for width in SIGMOID_WIDTH_SHARES:
        basis = logistic((x[:, None, :] - thresholds[None, :, None]) / (width * span))
        best = np.maximum(best, np.max(_weighted_r2(basis, means, weights), axis=1))
    return best


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
    same shuffles: how often a shuffle's smallest p over the statistics is at most the data's (Westfall and
    Young's min-p; one statistic: its own p)."""
    n = len(shuffled[0])
    data = min((1 + np.sum(s >= o - 1e-12)) / (n + 1) for o, s in zip(observed, shuffled))
    each = np.min([np.sum(s[None, :] >= s[:, None] - 1e-12, axis=1) / n for s in shuffled], axis=0)
    return float((1 + np.sum(each <= data)) / (n + 1))


def _beside_partner(name: str, level_values: dict[str, np.ndarray], means, weights) -> tuple[str, np.ndarray] | None:
    """The held column other than ``name`` whose closed form fits the level ``means`` best, and what that form
    leaves of them; None where the id holds no other column.

    Two per-lot causes at once each leave the other's share to the level means as noise: on 18 lots, a yield
    strength's saturation beside a thickness step fitted the means alone no better than the held columns
    shuffled (p 0.025), and the lot was named for both; beside the thickness, the strength is judged on what
    the step leaves."""
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
    thresholds, span = np.quantile(x, np.linspace(0.1, 0.9, 9)), np.ptp(x) or 1.0
    bases += [logistic((x - t) / (w * span))[:, None] for w in SIGMOID_WIDTH_SHARES for t in thresholds]
    return bases
