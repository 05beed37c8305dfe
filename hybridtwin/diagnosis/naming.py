"""Which column is named for an effect: the simplest that predicts the same, never elapsed time where a logged
quantity accounts for it, and a product only where it beats its two columns."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hybridtwin.diagnosis.candidates import Candidate
from hybridtwin.diagnosis.fits import Fit, Rules, fold_sets, held_out, predicts_the_same
from hybridtwin.diagnosis.forms import backfit
from hybridtwin.diagnosis.policy import PROXY_PENALTY
from hybridtwin.diagnosis.settings import Settings
from hybridtwin.metrics import block_p_value


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
            continue  # ids come last (:mod:`.ids`)
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


def held_out_sum(columns: list[Fit], splits, y) -> np.ndarray:
    """Held-out predictions of several columns' forms fitted together (backfitting) on each fold's rows."""
    oof = np.empty(len(y))
    for train, test in splits:
        models, means = backfit([f.candidate.values[train] for f in columns], [f.form.name for f in columns], y[train])
        oof[test] = y[train].mean() + sum(
            m.predict(f.candidate.values[test]) - c for m, f, c in zip(models, columns, means)
        )
    return oof


def product_or_column(best: Fit, candidates: dict[str, Candidate], y, rules: Rules) -> Fit:
    """A product of two columns stands where it predicts significantly better held out than the sum of its two
    columns, each in its own best form, given the causes already in (``y``), along each column's values.

    A separate mild tilt in one column (yield strength, with tensile strength beside it) is taken up by the
    product's own linear terms; the product's bilinear term then only needs to fit the surrogate's error along
    the other column to out-score the single column. Otherwise the better single column is named, with its tilt
    as its own form, even where it is not significant alone: two slopes within the surrogate's uncertainty and a
    sliver of curvature are no product (the caller then weighs the columns on their own). Only an a*b term of
    its own larger than the surrogate's uncertainty (``rules.min_effect``), which the two columns apart predict
    no better than, keeps a product its columns' weak shapes held level with.
    """
    if best.candidate.kind != "interaction":
        return best
    columns = [rules.best_fit(candidates[name], y) for name in best.candidate.columns if name in candidates]
    if len(columns) < 2:
        return best
    settings = rules.settings
    own_interaction = float(np.std(best.form.own_interaction(best.candidate.values)))
    for splits in fold_sets(best.candidate, settings):
        product = held_out(best.form.name, best.candidate.values, y, splits)
        both = held_out_sum(columns, splits, y)
        if block_p_value(y, product, settings.n_blocks, reference=both) < settings.alpha:
            continue
        apart_better = block_p_value(y, both, settings.n_blocks, reference=product) < settings.alpha
        if apart_better or own_interaction <= rules.min_effect:
            return min(columns, key=lambda fit: (fit.score, fit.candidate.name))
    return best


def _complexity(fit: Fit) -> float:
    """Parameters; elapsed time ranks behind a logged quantity of as many parameters, and a product of
    two columns behind one column (both stand for more than a single quantity)."""
    return fit.form.n_params + (PROXY_PENALTY if fit.candidate.kind in ("time", "interaction") else 0.0)
