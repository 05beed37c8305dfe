"""A candidate's forms fitted to a residual and scored held out: the best form, the rules of significance.

A form is chosen by K-fold held-out error with a BIC-style penalty on its parameters; numeric candidates
are held out in stretches of their own values (:func:`value_folds`).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import logging
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from hybridtwin.crossval import folds as kfolds
from hybridtwin.diagnosis import forms
from hybridtwin.diagnosis.candidates import Candidate
from hybridtwin.diagnosis.causes import Term
from hybridtwin.diagnosis.forms import fit_form
from hybridtwin.diagnosis.policy import BINS_PER_FOLD, MAX_CLOSED_FORM_PARAMS, SHARE_TOLERANCE
from hybridtwin.diagnosis.settings import Settings
from hybridtwin.metrics import evidence_p_value

log = logging.getLogger(__name__)


@dataclass
class Fit:
    """A candidate's best form on a given target, with held-out scores."""

    candidate: Candidate
    form: forms.Form
    oof: np.ndarray
    cv_mse: float
    null_mse: float
    score: float
    p_value: float
    effect_range: float
    effect_std: float
    alternatives: list = field(default_factory=list, repr=False)
    # held out, the form's own continuation beyond the values it was fitted on (a parabola's curvature carried
    # on, where the fitted form holds it flat): which shape the data follow, not how the fitted form extrapolates
    shape_mse: float = float("nan")

    @property
    def explained_share(self) -> float:
        return _share(self.cv_mse, self.null_mse)

    @property
    def shape_share(self) -> float:
        return _share(self.shape_mse, self.null_mse)

    @property
    def term(self) -> Term:
        return Term(self.candidate.cause, self.form.name)


def _share(mse: float, null_mse: float) -> float:
    return float(max(0.0, 1.0 - mse / null_mse)) if null_mse > 0 else 0.0


def held_out(name: str, x, y, splits, continued: bool = False) -> np.ndarray:
    """Held-out predictions of a form; ``continued``: by the form's own continuation beyond its training values."""
    oof = np.empty(len(y))
    for train, test in splits:
        fitted = fit_form(name, x[train], y[train])
        oof[test] = fitted.continued(x[test]) if continued else fitted.predict(x[test])
    return oof


def value_folds(candidate: Candidate, settings: Settings) -> list[tuple[np.ndarray, np.ndarray]]:
    """Folds that hold out whole stretches of a numeric candidate's values.

    Press settings are constant within a campaign, and the surrogate's error is too,
    so the residual carries one level per campaign. Rows held out at random leave each
    campaign's other rows in training, and a many-step form (a monotone trend) would
    be scored on recalling those levels. Held-out quantile bins of the candidate's own
    values, spread over the folds, score a form on values it has not seen: what it
    will meet out of the support. Group ids (their levels must be seen) keep shuffled folds.
    """
    n = len(candidate.values)
    if candidate.kind == "group":
        return kfolds(n, settings.folds, settings.seed)
    edges = np.quantile(candidate.values, np.linspace(0, 1, BINS_PER_FOLD * settings.folds + 1)[1:-1])
    bins = np.unique(np.searchsorted(edges, candidate.values, side="right"), return_inverse=True)[1]
    n_bins = bins.max() + 1
    if n_bins < settings.folds:  # a few levels only: nothing to spread
        return kfolds(n, settings.folds, settings.seed)
    fold_of_bin = np.random.default_rng(settings.seed).permutation(n_bins) % settings.folds
    fold = fold_of_bin[bins]
    return [(np.flatnonzero(fold != k), np.flatnonzero(fold == k)) for k in range(settings.folds)]


def fold_sets(candidate: Candidate, settings: Settings) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """The fold sets a candidate is scored on: one per axis along which it must predict unseen values.

    A product of two columns is scored along each of its columns, and counts by the worse of
    the two, as a single column is scored along its own: on shuffled folds it would recall
    what its columns' settings carry and out-score the single column that causes it.
    """
    if candidate.kind != "interaction":
        return [value_folds(candidate, settings)]
    return [
        value_folds(Candidate.new(column, "input", candidate.values[:, j], (column,)), settings)
        for j, column in enumerate(candidate.columns)
    ]


def held_out_worst(name: str, candidate: Candidate, y, settings: Settings, continued: bool = False) -> np.ndarray:
    """Held-out predictions of a form on the candidate's fold set where they err most."""
    predictions = [held_out(name, candidate.values, y, splits, continued) for splits in fold_sets(candidate, settings)]
    return max(predictions, key=lambda oof: float(np.mean((y - oof) ** 2)))


def best_fit(candidate: Candidate, y, settings: Settings, min_effect: float = 0.0) -> Fit:
    """The candidate's form with the lowest penalized held-out error (BIC-style penalty).

    The other forms tried are kept in ``alternatives`` (best first).
    """
    n = len(y)
    null_mse = float(np.mean(y**2))
    fits = []
    for name in candidate.form_names:
        try:
            oof = held_out_worst(name, candidate, y, settings)
            full = fit_form(name, candidate.values, y)
        except (np.linalg.LinAlgError, ValueError) as error:
            log.debug("form %s on %s failed: %s", name, candidate.name, error)
            continue
        cv_mse = float(np.mean((y - oof) ** 2))
        score = _penalized(cv_mse, null_mse, full.n_params, n)
        # a form held flat beyond its values (a parabola) is also judged held out by its own continuation
        carried = held_out_worst(name, candidate, y, settings, continued=True) if _holds_flat(full) else oof
        shape_mse = float(np.mean((y - carried) ** 2))
        fitted = full.predict(candidate.values)
        fits.append(
            Fit(
                candidate,
                full,
                oof,
                cv_mse,
                null_mse,
                float(score),
                evidence_p_value(y, oof, settings.n_blocks),
                float(np.ptp(fitted)),
                float(np.std(fitted)),
                shape_mse=shape_mse,
            )
        )
    fits.sort(key=lambda fit: (fit.score, fit.form.n_params))
    fits = _unseen_saturation_last(_named_form_first(fits, min_effect), min_effect, candidate)
    fits = _parabola_the_data_follow(fits)
    best = fits[0]
    best.alternatives = fits
    return best


def _penalized(mse: float, null_mse: float, n_params: int, n: int) -> float:
    """A held-out error's BIC-style score against the null (no effect): lower is better."""
    return n * np.log(max(mse, 1e-300)) + n_params * np.log(n) - n * np.log(max(null_mse, 1e-300))


def _holds_flat(form: forms.Form) -> bool:
    return type(form).continued is not forms.Form.continued


def _unseen_saturation_last(fits: list[Fit], min_effect: float, candidate: Candidate) -> list[Fit]:
    """A sigmoid whose change (10-90%) is wider than the values it was fitted on gives way to a simpler
    closed form that predicts the same within ``min_effect``.

    Such a sigmoid shows no saturation in the data: it is a trend with a bend the data do
    not show (the surrogate's own error along the column can put one there), and it says
    "saturating" where the data say "slope".
    """
    first = fits[0] if fits else None
    if first is None or first.form.name != forms.Sigmoid.name or candidate.kind not in ("input", "log", "time"):
        return fits
    if forms.SIGMOID_SPAN * first.form.width <= float(np.ptp(candidate.values)):
        return fits
    simpler = [
        fit for fit in fits[1:] if fit.form.n_params < first.form.n_params and predicts_the_same(fit, first, min_effect)
    ]
    if not simpler:
        return fits
    choice = min(simpler, key=lambda fit: (fit.form.n_params, fit.score))
    return [choice] + [fit for fit in fits if fit is not choice]


def _parabola_the_data_follow(fits: list[Fit]) -> list[Fit]:
    """A parabola ahead of a winning saturation where, carried on beyond each held-out stretch of values, it
    predicts that stretch clearly better (by more than :data:`SHARE_TOLERANCE` of the residual variance).

    The fitted parabola is held flat beyond its values, and held out by value a steep end is then predicted flat:
    a saturation, flat there by its nature, won in its place (structures draws 40053 and 60040, a parabola with
    its vertex inside the values: 0.61 against 0.71 held out; carried on, the parabola 0.94). Where the two
    explain about as much, the saturation stays: it does not carry a curvature beyond the data."""
    first = fits[0] if fits else None
    if first is None or first.form.name != forms.Sigmoid.name:
        return fits
    for index, fit in enumerate(fits[1:], start=1):
        if fit.form.name == forms.Quadratic.name and fit.shape_share > first.shape_share + SHARE_TOLERANCE:
            return [fit] + fits[:index] + fits[index + 1 :]
    return fits


def _named_form_first(fits: list[Fit], min_effect: float) -> list[Fit]:
    """A few-parameter form ahead of a winning monotone trend that it matches within ``min_effect``.

    The monotone trend takes up every bend in the data, the surrogate's own error
    along the column among them; a closed form that predicts the same within that
    error says what the effect is (a step at 0.50 mm) and how it extrapolates.
    """
    if not fits or fits[0].form.name != forms.Monotone.name:
        return fits
    for index, fit in enumerate(fits[1:], start=1):
        if predicts_the_same(fit, fits[0], min_effect):
            return [fit] + fits[:index] + fits[index + 1 :]
    return fits


def predicts_the_same(fit: Fit, reference: Fit, min_effect: float) -> bool:
    """Whether ``fit`` explains about as much as ``reference`` and predicts it within ``min_effect`` (std)."""
    difference = fit.form.predict(fit.candidate.values) - reference.form.predict(reference.candidate.values)
    return (
        fit.explained_share >= reference.explained_share - share_tolerance(reference, min_effect)
        and float(np.std(difference)) < min_effect
    )


def share_tolerance(fit: Fit, min_effect: float) -> float:
    """How much less of the residual variance a simpler cause may explain and still count as the same.

    A many-level fit (coil offsets that follow the setting campaigns, a monotone trend)
    takes up the surrogate's own error along with the effect, so against it the margin is
    what that error can account for; a closed form of a few parameters cannot.
    """
    if fit.form.n_params <= MAX_CLOSED_FORM_PARAMS:
        return SHARE_TOLERANCE
    return max(SHARE_TOLERANCE, min_effect**2 / fit.null_mse)


def best_fits(candidates: list[Candidate], y, settings: Settings, min_effect: float) -> list[Fit]:
    """:func:`best_fit` of each candidate, in parallel over them where there are several."""
    if len(candidates) == 1:
        return [best_fit(candidates[0], y, settings, min_effect)]
    return Parallel(n_jobs=settings.n_jobs)(delayed(best_fit)(c, y, settings, min_effect) for c in candidates)


def is_significant(fit: Fit, n_tests: int, settings: Settings, min_effect: float) -> bool:
    # a pair counts as an interaction only where the product beats its two main effects;
    # otherwise its columns speak for themselves as candidates of their own
    return (
        fit.p_value < settings.alpha / max(1, n_tests)
        and fit.score < 0
        and fit.effect_std > min_effect
        and fit.form.name != forms.Additive.name
    )


def _digest(values) -> bytes:
    values = np.ascontiguousarray(values)
    data = pd.util.hash_array(values.ravel()).tobytes() if values.dtype == object else values.tobytes()
    return hashlib.blake2b(data, digest_size=16).digest() + f"{values.dtype.str}{values.shape}".encode()


class FitMemory:
    """The best fits one diagnosis has made, by candidate and target: the selection asks again for fits it made
    before (its second pass after the first cause, the refinements), and a fit depends on those alone.

    Copies go in and come out, so no caller shares a fit or a form with another (the candidate, an input that
    nothing changes, is shared: a deep copy of an id's labels would copy every string); beyond ``max_bytes`` of
    held-out predictions the oldest fits are forgotten."""

    def __init__(self, max_bytes: int = 256 * 2**20):
        self.max_bytes, self.bytes, self.fits = max_bytes, 0, OrderedDict()

    @staticmethod
    def key(candidate: Candidate, y) -> tuple:
        return candidate.cause, _digest(candidate.values), _digest(y)

    def get(self, key) -> Fit | None:
        stored = self.fits.get(key)
        return None if stored is None else _copy(stored[0])

    def put(self, key, fit: Fit) -> None:
        size = sum(alternative.oof.nbytes for alternative in fit.alternatives)
        if key in self.fits:
            self.bytes -= self.fits.pop(key)[1]
        self.fits[key] = (_copy(fit), size)
        self.bytes += size
        while self.bytes > self.max_bytes and self.fits:
            self.bytes -= self.fits.popitem(last=False)[1][1]


def _copy(fit: Fit) -> Fit:
    """A deep copy of ``fit`` and its alternatives that shares their candidate."""
    return copy.deepcopy(fit, {id(fit.candidate): fit.candidate})


@dataclass(frozen=True)
class Rules:
    """What every step of the selection asks of a fit, fixed once per diagnosis: the settings, the number of
    candidates tested (Bonferroni) and the least effect (the surrogate's own uncertainty times its margin);
    ``input_correlation``: the simulator's correlation between rows of the model inputs, and a length-scale factor
    (:meth:`~hybridtwin.paper.surrogate.GPRSurrogate.input_correlation`), None without a surrogate."""

    settings: Settings
    n_tests: int = 1
    min_effect: float = 0.0
    input_correlation: Callable[[np.ndarray, float], np.ndarray] | None = None
    memory: FitMemory = field(default_factory=FitMemory, compare=False, repr=False)

    def significant(self, fit: Fit) -> bool:
        return is_significant(fit, self.n_tests, self.settings, self.min_effect)

    def strength(self, fit: Fit) -> float:
        """How well a candidate predicts held out, to rank it against the others: the best penalized score among
        its significant forms (its own form's where none is significant).

        The form a cause is named with can score worse than one it stands for: a slope put ahead of the monotone
        trend it predicts the same as, within the surrogate's uncertainty (:func:`_named_form_first`). Ranked by
        the slope, a wear drift fell behind a parabola in the ambient temperature that follows it loosely and that
        its trend beats held out (two-cause draw 1420)."""
        return min([fit.score, *(alt.score for alt in fit.alternatives if self.significant(alt))])

    def best_fit(self, candidate: Candidate, y) -> Fit:
        return self.settled(self._best_fits([candidate], y)[0])

    def fit_all(self, candidates: list[Candidate], y) -> dict[str, Fit]:
        return {c.name: self.settled(fit) for c, fit in zip(candidates, self._best_fits(candidates, y))}

    def _best_fits(self, candidates: list[Candidate], y) -> list[Fit]:
        """Each candidate's :func:`best_fit` on ``y``: from :attr:`memory` where this diagnosis made it before, the
        others fitted (in parallel where there are several)."""
        keys = [self.memory.key(candidate, y) + (self.settings, self.min_effect) for candidate in candidates]
        known = [self.memory.get(key) for key in keys]
        missing = [candidate for candidate, fit in zip(candidates, known) if fit is None]
        new = iter(best_fits(missing, y, self.settings, self.min_effect))
        fits = [next(new) if fit is None else fit for fit in known]
        for key, fit, was_known in zip(keys, fits, known):
            if was_known is None:
                self.memory.put(key, fit)
        return fits

    def settled(self, fit: Fit) -> Fit:
        """A form put ahead of a better-scoring monotone trend (it predicts the same, and says what the
        effect is) stands only where it is significant itself; where only the trend is, the trend stays.

        A closed form explains less held out than the trend it replaced (the trend's extra is allowed as the
        surrogate's own error), and a wear drift's slope then fell under the Bonferroni bar while its trend
        stood far above it: a weaker column took its place (two-cause draw 1420).
        """
        if self.significant(fit):
            return fit
        trends = [alt for alt in fit.alternatives if alt.form.name == forms.Monotone.name and alt.score < fit.score]
        if not trends or not self.significant(trends[0]):
            return fit
        trend = dataclasses.replace(trends[0])
        trend.alternatives = [trend] + [alt for alt in fit.alternatives if alt is not trends[0]]
        return trend
