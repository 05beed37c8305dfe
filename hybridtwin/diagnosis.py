"""What the simulation gets wrong: rank candidate causes of the approximate residual.

From the in-support approximate residuals minus their mean (the offset), every
candidate column -- model inputs, plant log numbers, timestamps as elapsed
hours, text ids as groups, and products of two inputs -- is fitted with a few
physically plausible forms (see :mod:`hybridtwin.forms`). A form is chosen by
K-fold held-out error with a BIC-style penalty on its parameters. Causes are
then selected forward, each one conditionally on those already chosen, so that
a correlated neighbour of the real cause (Rm next to Rp0.2, ambient next to die
temperature, time next to stroke counter) is not named. A cause counts as
significant when its held-out gain passes a block-wise t-test (blocks of
consecutive rows, robust to drift and autocorrelation; Bonferroni over the
candidates) and its effect is larger than the surrogate's own uncertainty,
which is also in the residual.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from . import forms
from .causes import Cause, Term, parse_timestamps, time_origin
from .crossval import folds as kfolds
from .forms import fit_form
from .metrics import block_means, block_p_value

log = logging.getLogger(__name__)

# ---------------------------------------------------------------- the selection policy, in one place
# (the statistical settings a user may change -- folds, alpha, the number of blocks of the block
# t-test, the surrogate margin -- are in :class:`Settings`, from the config's ``diagnosis:``)

# numeric candidates are scored on held-out quantile bins of their own values, this many per fold:
# enough bins to spread each fold over the range, few enough that a bin holds whole campaigns
BINS_PER_FOLD = 4
# a simpler cause may explain this much less of the residual variance and still count as the same
SHARE_TOLERANCE = 0.05
# forms with at most this many parameters are closed forms (linear, quadratic, step, sigmoid, product);
# more (monotone trend, group offsets) take up the surrogate's own error too
MAX_CLOSED_FORM_PARAMS = 3
# elapsed time and a product of two columns count this many parameters more than they have: both stand
# for something else (what changes with time; one of the two columns)
PROXY_PENALTY = 0.5
# an id stands for a quantity that accounts for at least this share of its level differences
PROXY_SHARE = 0.5
# a product of two columns must account for more: among dozens of pairs with three parameters each,
# one took up half of a few dozen coil offsets by chance (3 of 13 coil_itself plants of the families bank)
PROXY_SHARE_PAIR = 0.75
# confounding: a chosen cause is tested both ways against the strongest rivals that explain at least this
# share of what it explains on its own, at most this many of them
RIVAL_SHARE = 0.5
MAX_RIVALS = 8
# a changed cause changes what the others are fitted to: go round again, a few times at most
REFINE_PASSES = 3


@dataclass(frozen=True)
class Candidate:
    """A cause under test, with its values on the diagnosed rows."""

    cause: Cause
    values: np.ndarray

    @classmethod
    def new(cls, name: str, kind: str, values, columns: tuple[str, ...], origin: str | None = None) -> "Candidate":
        return cls(Cause(name, kind, tuple(columns), origin), values)

    @property
    def name(self) -> str:
        return self.cause.name

    @property
    def kind(self) -> str:
        return self.cause.kind

    @property
    def columns(self) -> tuple[str, ...]:
        return self.cause.columns

    @property
    def origin(self) -> str | None:
        return self.cause.origin

    @property
    def form_names(self) -> tuple[str, ...]:
        if self.kind == "group":
            return ("group",)
        if self.kind == "interaction":
            return ("product", "additive")
        if len(np.unique(self.values)) <= 2:
            return ("step",)
        return tuple(cls.name for cls in forms.NUMERIC_FORMS)


@dataclass(frozen=True)
class Settings:
    folds: int = 5
    seed: int = 0
    alpha: float = 0.01
    max_causes: int = 3
    max_levels: int = 200
    max_rows: int = 10_000
    surrogate_margin: float = 1.0
    interactions: bool = True
    exclude: tuple[str, ...] = ()
    n_blocks: int = 200
    n_jobs: int = 1
    unit: str = "mm"  # of the target: the causes' descriptions give effects in it (config units.target)
    input_units: tuple[tuple[str, str], ...] = ()  # (column, unit) pairs of config units.inputs

    @classmethod
    def from_config(
        cls, config: dict | None, folds: int, seed: int, unit: str, n_jobs: int = 1, input_units: dict | None = None
    ) -> "Settings":
        config = dict(config or {})
        config["exclude"] = tuple(config.get("exclude", ()))
        units = tuple(sorted((input_units or {}).items()))
        return cls(folds=folds, seed=seed, unit=unit, n_jobs=n_jobs, input_units=units, **config)


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

    @property
    def explained_share(self) -> float:
        return float(max(0.0, 1.0 - self.cv_mse / self.null_mse)) if self.null_mse > 0 else 0.0

    @property
    def term(self) -> Term:
        return Term(self.candidate.cause, self.form.name)


@dataclass
class Diagnosis:
    offset: float
    offset_se: float
    n_rows: int
    residual_std: float
    surrogate_std: float
    min_effect: float
    table: pd.DataFrame
    y: np.ndarray
    candidates: dict[str, Candidate]
    skipped: dict[str, str]
    selected: list[Fit] = field(default_factory=list)
    aliases: dict[str, list[str]] = field(default_factory=dict)
    explained_by: dict[str, str] = field(default_factory=dict)
    proxies: dict[str, tuple[str, float]] = field(default_factory=dict)

    @property
    def terms(self) -> tuple[Term, ...]:
        """The chosen causes with their forms: what the extension fits."""
        return tuple(fit.term for fit in self.selected)


# ---------------------------------------------------------------- candidates


def build_candidates(
    frame: pd.DataFrame, inputs, exclude, settings: Settings
) -> tuple[list[Candidate], dict[str, str]]:
    """Candidate causes from every usable column, and the reasons others were skipped."""
    causes, skipped = [], {}
    for column in frame.columns:
        if column in exclude or column in settings.exclude:
            continue
        values = frame[column]
        if values.nunique(dropna=False) < 2:
            skipped[column] = "constant"
            continue
        if pd.api.types.is_numeric_dtype(values):
            if values.isna().any() or not np.isfinite(values.to_numpy(float)).all():
                skipped[column] = "missing or infinite values"
                continue
            causes.append(Cause(column, "input" if column in inputs else "log", (column,)))
        elif parse_timestamps(values) is not None:
            causes.append(Cause(column, "time", (column,), time_origin(values)))
        elif values.nunique() <= settings.max_levels:
            causes.append(Cause(column, "group", (column,)))
        else:
            skipped[column] = f"text with {values.nunique()} distinct values (more than {settings.max_levels})"
    if settings.interactions:
        numeric_inputs = [c for c in causes if c.kind == "input"]
        causes += [
            Cause(f"{a.name}*{b.name}", "interaction", (a.name, b.name))
            for a, b in itertools.combinations(numeric_inputs, 2)
        ]
    # read as the extension and the predictor read them (Cause.values)
    candidates = [Candidate(cause, cause.values(frame)) for cause in causes]
    return candidates, skipped


# ---------------------------------------------------------------- fitting


def held_out(name: str, x, y, splits) -> np.ndarray:
    oof = np.empty(len(y))
    for train, test in splits:
        oof[test] = fit_form(name, x[train], y[train]).predict(x[test])
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


def held_out_worst(name: str, candidate: Candidate, y, settings: Settings) -> np.ndarray:
    """Held-out predictions of a form on the candidate's fold set where they err most."""
    predictions = [held_out(name, candidate.values, y, splits) for splits in fold_sets(candidate, settings)]
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
        score = n * np.log(max(cv_mse, 1e-300)) + full.n_params * np.log(n) - n * np.log(max(null_mse, 1e-300))
        fitted = full.predict(candidate.values)
        fits.append(
            Fit(
                candidate,
                full,
                oof,
                cv_mse,
                null_mse,
                float(score),
                block_p_value(y, oof, settings.n_blocks),
                float(np.ptp(fitted)),
                float(np.std(fitted)),
            )
        )
    fits.sort(key=lambda fit: (fit.score, fit.form.n_params))
    fits = _unseen_saturation_last(_named_form_first(fits, min_effect), min_effect, candidate)
    best = fits[0]
    best.alternatives = fits
    return best


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


class _Rung(NamedTuple):
    """A column on :func:`prefer_simpler`'s ladder, simplest first."""

    complexity: float
    score: float
    name: str
    named: Fit  # the form it would be named with
    counted: Fit  # the form its simplicity was counted by
    column: Fit  # its best fit, with every form tried (``alternatives``)


def prefer_simpler(best: Fit, pool: list[Fit], y, rules: Rules) -> Fit:
    """Among other single-column candidates' fits that predict what the best one predicts, up to
    ``rules.min_effect`` (std of the difference), take the one with the fewest parameters.

    The best candidate's own form is left to the held-out score: a saturating curve
    and a parabola may agree inside the support and part ways outside it.

    Coil ids follow time and campaigns, and a product a*b contains a and b: such
    many-parameter candidates also soak up the surrogate's own error, so they
    can edge out the simple cause that carries the effect.

    Elapsed time counts half a parameter more than it has: time causes nothing by
    itself, it stands for whatever changes with it (tool wear in strokes, a warming
    die), so a logged quantity that predicts the same is named instead.

    Simplicity decides only where the data cannot: going up from the simplest such column,
    one that predicts significantly better held out (:func:`better_held_out`) is taken
    instead. A drift that goes on while the line stands idle is time's, not the stroke
    counter's, however alike the two are over the parts.
    """

    def equivalent(alt: Fit) -> bool:
        return rules.significant(alt) and predicts_the_same(alt, best, rules.min_effect)

    def simplest(fit: Fit) -> Fit | None:
        """A column counts as simple as its simplest form that predicts what the best one predicts."""
        return min((alt for alt in fit.alternatives or [fit] if equivalent(alt)), key=_complexity, default=None)

    own = min(_complexity(best), _complexity(simplest(best)) if simplest(best) else np.inf)
    rivals = []
    for fit in pool:
        if fit.candidate.kind == "interaction" or fit.candidate.name == best.candidate.name:
            continue
        if fit.candidate.kind == "group" and best.candidate.kind != "group":
            continue  # an id is named only where no other column accounts for it (:func:`physical_cause`)
        counted = simplest(fit)
        if counted is not None and _complexity(counted) < own:
            # named with the column's own choice of form (held-out score) among its forms that predict the same
            form = next(alt for alt in fit.alternatives or [fit] if equivalent(alt))
            rivals.append(_Rung(_complexity(counted), form.score, fit.candidate.name, form, counted, fit))
    if not rivals:
        return best
    ladder = sorted(rivals, key=lambda rung: rung[:3]) + [_Rung(own, best.score, best.candidate.name, best, best, best)]
    choice = ladder[0]
    for rung in ladder[1:]:
        # the question is which column, not which form: a rival must predict better than the choice's
        # column does with the rival's own form (a bend in both is no reason to change columns), and
        # than the form the choice was counted by (needing more parameters to match it is not simpler)
        same_form = next(
            (alt for alt in choice.column.alternatives if alt.form.name == rung.named.form.name), choice.counted
        )
        if all(better_held_out(rung.named, ref, y, rules.settings) for ref in (same_form, choice.counted)):
            choice = rung
    return choice.named


def better_held_out(fit: Fit, reference: Fit, y, settings: Settings) -> bool:
    """Whether ``fit`` predicts significantly better held out than ``reference`` (paired block test at
    ``settings.alpha``), where both were scored on held-out stretches of their own values; ids and
    products are left to the rules on proxies and pairs."""
    comparable = {"input", "log", "time"}
    if fit.candidate.kind not in comparable or reference.candidate.kind not in comparable:
        return False
    return block_p_value(y, fit.oof, settings.n_blocks, reference=reference.oof) < settings.alpha


def between_level_ss(labels, values) -> float:
    """Count-weighted sum of squares of the level means of ``values`` around their overall mean."""
    codes = np.unique(np.asarray(labels), return_inverse=True)[1]
    values = np.asarray(values, float)
    counts = np.bincount(codes)
    means = np.bincount(codes, weights=values) / counts
    return float(np.sum(counts * (means - values.mean()) ** 2))


def proxy_share(proxy: Fit, rival: Fit, y) -> float:
    """Share of the differences between an id's levels (in ``y``) that ``rival``'s term accounts for."""
    before = between_level_ss(proxy.candidate.values, y)
    if before <= 0:
        return 0.0
    after = between_level_ss(proxy.candidate.values, y - rival.form.predict(rival.candidate.values))
    return 1.0 - after / before


def physical_cause(best: Fit, pool: list[Fit], y, acceptable) -> tuple[Fit, float]:
    """An id (coil, lot, shift) is a proxy, like elapsed time: it stands for whatever changes with it.

    Group offsets recall each level from its own parts, so an id that carries a die
    temperature, a setting and a material at once out-scores each of them. Both kinds are
    put on the same footing by asking what the id's level differences are: when a
    significant candidate that is not an id accounts for most of them
    (:data:`PROXY_SHARE`; :data:`PROXY_SHARE_PAIR` for a product), that candidate is named, the
    best-scoring such one. The id
    stays a candidate for the next step, where it is chosen only if its remainder,
    given the named cause, is significant. Returns the cause and the share it accounts for.
    """
    if best.candidate.kind != "group":
        return best, 0.0
    rivals = [(fit, proxy_share(best, fit, y)) for fit in pool if fit.candidate.kind != "group" and acceptable(fit)]
    rivals = [
        (fit, share)
        for fit, share in rivals
        if share >= (PROXY_SHARE_PAIR if fit.candidate.kind == "interaction" else PROXY_SHARE)
    ]
    if not rivals:
        return best, 0.0
    return min(rivals, key=lambda rival: (rival[0].score, rival[0].candidate.name))


def _complexity(fit: Fit) -> float:
    """Parameters; elapsed time ranks behind a logged quantity of as many parameters, and a product of
    two columns behind one column (both stand for more than a single quantity)."""
    return fit.form.n_params + (PROXY_PENALTY if fit.candidate.kind in ("time", "interaction") else 0.0)


def fit_all(candidates: list[Candidate], y, settings: Settings, min_effect: float) -> dict[str, Fit]:
    """Best fit of every candidate, in parallel over candidates; the order of the result is the input order."""
    fits = Parallel(n_jobs=settings.n_jobs)(delayed(best_fit)(c, y, settings, min_effect) for c in candidates)
    return {c.name: fit for c, fit in zip(candidates, fits)}


def is_significant(fit: Fit, n_tests: int, settings: Settings, min_effect: float) -> bool:
    # a pair counts as an interaction only where the product beats its two main effects;
    # otherwise its columns speak for themselves as candidates of their own
    return (
        fit.p_value < settings.alpha / max(1, n_tests)
        and fit.score < 0
        and fit.effect_std > min_effect
        and fit.form.name != forms.Additive.name
    )


@dataclass(frozen=True)
class Rules:
    """What every step of the selection asks of a fit, fixed once per diagnosis: the settings, the number of
    candidates tested (Bonferroni) and the least effect (the surrogate's own uncertainty times its margin)."""

    settings: Settings
    n_tests: int = 1
    min_effect: float = 0.0

    def significant(self, fit: Fit) -> bool:
        return is_significant(fit, self.n_tests, self.settings, self.min_effect)

    def best_fit(self, candidate: Candidate, y) -> Fit:
        return self.settled(best_fit(candidate, y, self.settings, self.min_effect))

    def fit_all(self, candidates: list[Candidate], y) -> dict[str, Fit]:
        return {name: self.settled(fit) for name, fit in fit_all(candidates, y, self.settings, self.min_effect).items()}

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


# ---------------------------------------------------------------- diagnosis


def diagnose(
    frame: pd.DataFrame, residual, inputs, exclude, settings: Settings, surrogate_std: float = 0.0
) -> Diagnosis:
    """Rank candidate causes of ``residual`` (approximate residuals of in-support rows, in row order).

    ``frame`` holds those rows' production columns; ``exclude`` names columns that
    must not be candidates (the target). ``surrogate_std`` is the surrogate's own
    predictive uncertainty (noise excluded) on these rows: a cause's term must
    vary (standard deviation over the rows) by more than ``surrogate_margin``
    times it, or it could be the surrogate's own error.
    """
    residual = np.asarray(residual, float)
    frame = frame.reset_index(drop=True)
    if len(residual) > settings.max_rows:
        keep = np.sort(np.random.default_rng(settings.seed).choice(len(residual), settings.max_rows, replace=False))
        frame, residual = frame.iloc[keep].reset_index(drop=True), residual[keep]
    offset = float(residual.mean())
    y = residual - offset
    blocks = block_means(residual, settings.n_blocks)
    offset_se = float(np.std(blocks, ddof=1) / np.sqrt(len(blocks)))
    candidates, skipped = build_candidates(frame, inputs, exclude, settings)
    rules = Rules(settings, n_tests=len(candidates), min_effect=settings.surrogate_margin * surrogate_std)

    marginal = rules.fit_all(candidates, y)

    # forward selection, each step conditional on the causes already chosen
    selected: list[Fit] = []
    proxies: dict[str, tuple[str, float]] = {}  # id -> the cause named for it, and the share of its level differences
    conditional: dict[str, Fit] = dict(marginal)
    remaining = y

    def refit() -> tuple[np.ndarray, dict[str, Fit]]:
        """Joint fit of the chosen causes; what they leave, and every other candidate's fit to it."""
        models, _ = forms.backfit([s.candidate.values for s in selected], [s.form.name for s in selected], y)
        # the chosen forms refitted jointly; new records, so that the marginal fits keep their own forms
        selected[:] = [dataclasses.replace(fit, form=model) for fit, model in zip(selected, models)]
        left = y - sum(m.predict(s.candidate.values) for s, m in zip(selected, models))
        chosen = {s.candidate.name for s in selected}
        return left - left.mean(), rules.fit_all([c for c in candidates if c.name not in chosen], left - left.mean())

    def forward() -> None:
        nonlocal remaining, conditional
        while len(selected) < settings.max_causes:
            pool = [
                fit
                for name, fit in conditional.items()
                if name not in {s.candidate.name for s in selected} and fit.form.name != forms.Additive.name
            ]  # a pair that is no interaction is not a candidate
            if not pool:
                break
            best = prefer_simpler(min(pool, key=lambda fit: (fit.score, fit.candidate.name)), pool, remaining, rules)
            named, share = physical_cause(best, pool, remaining, rules.significant)
            if named is not best:
                proxies[best.candidate.name] = (named.candidate.name, share)
                best = prefer_simpler(named, pool, remaining, rules)
            if not rules.significant(best):
                break
            selected.append(best)
            remaining, conditional = refit()

    forward()
    by_name = {c.name: c for c in candidates}
    if _refine(selected, by_name, y, rules):
        # the causes after the first were chosen given a first cause that has changed: choose them again
        del selected[1:]
        remaining, conditional = refit()
        forward()
        _refine(selected, by_name, y, rules)
        remaining, conditional = refit()
        named = {fit.candidate.name for fit in selected}
        proxies = {key: value for key, value in proxies.items() if value[0] in named}

    aliases, explained_by = _confounding(selected, marginal, y, rules)
    table = _table(marginal, conditional, selected, aliases, explained_by, proxies, skipped, rules)
    return Diagnosis(
        offset,
        offset_se,
        len(y),
        float(y.std()),
        surrogate_std,
        rules.min_effect,
        table,
        y,
        {c.name: c for c in candidates},
        skipped,
        selected,
        aliases,
        explained_by,
        proxies,
    )


def joint_share(fits: list[Fit], y, settings: Settings) -> float:
    """Held-out share of ``y`` that several terms explain together (backfitted on each fold's training rows)."""
    oof = np.zeros_like(y)
    for train, test in kfolds(len(y), settings.folds, settings.seed):
        models, means = forms.backfit([f.candidate.values[train] for f in fits], [f.form.name for f in fits], y[train])
        oof[test] = y[train].mean() + sum(
            m.predict(f.candidate.values[test]) - c for m, f, c in zip(models, fits, means)
        )
    return float(1.0 - np.mean((y - oof) ** 2) / np.mean(y**2))


def _refine(selected: list[Fit], by_name: dict[str, Candidate], y, rules: Rules) -> bool:
    """Choose each chosen cause's form again given all the others; returns whether anything changed.

    Chosen one at a time, a cause is fitted with the causes after it still in the
    residual: a wear drift bends a temperature's saturation into a parabola, and a
    product a*b takes up part of a cause chosen after it (a die that warms more under
    higher cushion forces and a wear drift along the same shifts). With every cause in,
    the form is chosen again, and a product gives way to a or b alone where the single
    column explains as much (within :data:`SHARE_TOLERANCE`, held out).
    """
    changed = False
    for _ in range(REFINE_PASSES):
        if not _refine_pass(selected, by_name, y, rules):
            break
        changed = True
    return changed


def _refine_pass(selected: list[Fit], by_name: dict[str, Candidate], y, rules: Rules) -> bool:
    changed = False
    for j, fit in enumerate(list(selected)):
        # the partial residual of cause j: y less the other causes' terms of the joint fit
        models, means = forms.backfit([s.candidate.values for s in selected], [s.form.name for s in selected], y)
        rest = y - sum(
            m.predict(s.candidate.values) - c for k, (m, s, c) in enumerate(zip(models, selected, means)) if k != j
        )
        rest = rest - rest.mean()
        if fit.candidate.kind != "interaction":
            again = rules.best_fit(fit.candidate, rest)
            if fit.candidate.kind == "time":  # time against the logged quantities again, with the other causes in
                chosen = {s.candidate.name for s in selected}
                logged = [c for c in by_name.values() if c.kind in ("input", "log") and c.name not in chosen]
                again = prefer_simpler(again, [again] + [rules.best_fit(c, rest) for c in logged], rest, rules)
            changed_form = (again.candidate.name, again.form.name) != (fit.candidate.name, fit.form.name)
            if changed_form and rules.significant(again):
                selected[j] = again
                changed = True
            continue
        current = joint_share(selected, y, rules.settings)
        singles = [rules.best_fit(by_name[column], rest) for column in fit.candidate.columns if column in by_name]
        singles = [single for single in singles if rules.significant(single)]
        scored = [
            (joint_share(selected[:j] + [single] + selected[j + 1 :], y, rules.settings), single) for single in singles
        ]
        scored = [(share, single) for share, single in scored if share >= current - SHARE_TOLERANCE]
        if scored:
            selected[j] = max(scored, key=lambda item: (item[0], item[1].candidate.name))[1]
            changed = True
    return changed


def _confounding(selected: list[Fit], marginal: dict[str, Fit], y, rules: Rules):
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


def _table(marginal, conditional, selected, aliases, explained_by, proxies, skipped, rules: Rules) -> pd.DataFrame:
    chosen = [s.candidate.name for s in selected]
    rows = []
    for name, fit in marginal.items():
        if name in chosen:
            final = next(s for s in selected if s.candidate.name == name)
            # the marginal scores of the form that was chosen, which may not be the best-scoring one
            fit = next((alt for alt in fit.alternatives if alt.form.name == final.form.name), fit)
            significant = True
            conditional_share = final.explained_share
            p_value = final.p_value
            form = final.form
            effect_range, effect_std = final.effect_range, final.effect_std
        else:
            after = conditional.get(name, fit)
            significant = bool(rules.significant(after if selected else fit))
            conditional_share = after.explained_share
            p_value = after.p_value
            form = fit.form
            effect_range, effect_std = fit.effect_range, fit.effect_std
        alias_of = [cause for cause, names in aliases.items() if name in names]
        note = ""
        if name in proxies and name not in chosen:
            cause, share = proxies[name]
            note = f"an id that stands for {cause}: it accounts for {share:.0%} of the differences between its levels"
        elif name in aliases and aliases[name]:
            note = "cannot be told apart from " + ", ".join(aliases[name]) + " in this data"
        elif alias_of:
            note = f"cannot be told apart from {alias_of[0]} in this data"
        elif name in explained_by:
            note = f"explained by {explained_by[name]}: adds nothing once it is in"
        elif not significant and any(set(fit.candidate.columns) & set(s.candidate.columns) for s in selected):
            note = "a variant of a chosen cause's column: adds nothing beyond it"
        elif form.name == forms.Additive.name:
            note = "no interaction: the product does not beat the two main effects"
        rows.append(
            {
                "cause": name,
                "kind": fit.candidate.kind,
                "form": form.name,
                "family": forms.FAMILIES[form.name],
                "n_params": int(form.n_params),
                "explained_share": fit.explained_share,
                "conditional_share": conditional_share,
                "effect_range": effect_range,
                "effect_std": effect_std,
                "p_value": p_value,
                "significant": significant,
                "selected": name in chosen,
                "description": form.describe(
                    name, rules.settings.unit, fit.candidate.cause.unit(dict(rules.settings.input_units))
                ),
                "note": note,
            }
        )
    table = pd.DataFrame(rows)
    order = {name: i for i, name in enumerate(chosen)}
    table["_chosen"] = table["cause"].map(order).fillna(len(order))
    table = table.sort_values(
        ["_chosen", "explained_share", "cause"], ascending=[True, False, True], kind="stable"
    ).drop(columns="_chosen")
    table.insert(0, "rank", np.arange(1, len(table) + 1))
    if skipped:
        log.info("columns not used as candidates: %s", skipped)
    return table.reset_index(drop=True)


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
        "proxies": {name: {"cause": cause, "share": share} for name, (cause, share) in result.proxies.items()},
    }
