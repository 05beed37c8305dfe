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
from hybridtwin.diagnosis.forms import fit_form
from hybridtwin.diagnosis.levels import level_share
from hybridtwin.diagnosis.naming import between_level_ss
from hybridtwin.diagnosis.policy import ID_ACCOUNTED_SMOOTH_FIRST, SMOOTH_SHARE_OF_ID
from hybridtwin.diagnosis.wording import INPUT_SURFACE, SMOOTH_INPUTS

# the input surface's ridge penalties, chosen held out by level; up to a surface shrunk to nothing (the smooth
# candidates then account for the offsets alone)
LEVEL_PENALTIES = np.logspace(-3, 8, 12)
MAX_SMOOTH = 3  # smooth candidates that may account for an id's offsets together with the input surface
PASSES = 3  # backfitting passes of the surface and the smooth candidates


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


def smooth_first(best: Fit, named_id: Fit, accounted: float, by_chance=lambda: False) -> bool:
    """Whether a significant smooth cause goes before an id that stands: the smooth candidates account for
    enough of the id's level differences, or the best is a column that explains most of what the id does;
    never where ``by_chance()`` (asked only then) says the best is a column the id holds that fits its level means
    no better than chance (a per-coil property's step fitted to random coil offsets)."""
    column = best.candidate.kind != "interaction"
    first = accounted >= ID_ACCOUNTED_SMOOTH_FIRST or (
        column and best.explained_share >= SMOOTH_SHARE_OF_ID * named_id.explained_share
    )
    return first and not by_chance()
