"""What the simulation gets wrong: rank candidate causes of the approximate residual.

From the in-support approximate residuals minus their mean (the offset), every
candidate column -- model inputs, plant log numbers, timestamps as elapsed
hours, text ids as groups, and products of two inputs -- is fitted with a few
physically plausible forms (see :mod:`hybridtwin.diagnosis.forms`). A form is chosen by
K-fold held-out error with a BIC-style penalty on its parameters. Causes are
then selected forward, each one conditionally on those already chosen, so that
a correlated neighbour of the real cause (Rm next to Rp0.2, ambient next to die
temperature, time next to stroke counter) is not named. A cause counts as
significant when its held-out gain passes a block-wise test (a t-test or a
signed-rank test over blocks of consecutive rows, the smaller p doubled; robust
to drift and autocorrelation; Bonferroni over the candidates) and its effect is
larger than the surrogate's own uncertainty, which is also in the residual.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hybridtwin.crossval import folds as kfolds
from hybridtwin.diagnosis import forms
from hybridtwin.diagnosis.candidates import Candidate, build_candidates
from hybridtwin.diagnosis.causes import Term
from hybridtwin.diagnosis.confounding import confounding
from hybridtwin.diagnosis.fits import Fit, Rules
from hybridtwin.diagnosis.ids import Proxy, id_stands, smooth_first
from hybridtwin.diagnosis.levels import held_columns, level_chance_p
from hybridtwin.diagnosis.naming import held_out_sum, prefer_simpler, product_or_column
from hybridtwin.diagnosis.policy import (
    MAX_CLOSED_FORM_PARAMS,
    REFINE_PASSES,
    SHARE_TOLERANCE,
    TREND_POWER,
)
from hybridtwin.diagnosis.settings import Settings
from hybridtwin.diagnosis.table import Found, causes_table, too_small
from hybridtwin.diagnosis.trends import TrendTest, is_trend_in_time, trend_test
from hybridtwin.metrics import block_means


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
    proxies: dict[str, Proxy] = field(default_factory=dict)
    too_small: list[Fit] = field(default_factory=list)  # found by the test but within the surrogate's uncertainty
    # columns an id holds that fitted its level means no better than chance: column -> (id, levels, p)
    by_chance: dict[str, tuple[str, int, float]] = field(default_factory=dict)
    # trends in time that showed nothing between parts run at the same settings: column -> its TrendTest
    follows_inputs: dict[str, TrendTest] = field(default_factory=dict)
    # chosen trends in time the test between parts at the same settings could not see: column -> its TrendTest
    untold_trends: dict[str, TrendTest] = field(default_factory=dict)

    @property
    def terms(self) -> tuple[Term, ...]:
        """The chosen causes with their forms: what the extension fits."""
        return tuple(fit.term for fit in self.selected)


@dataclass
class Selection:
    """The forward selection's state: the causes chosen so far (refitted jointly), what they leave of the
    offset-free residual ``y``, every other candidate's fit to that, and the ids not named
    (id -> what accounts for its offsets, held out by level, and the share of its level differences it accounts for)."""

    y: np.ndarray
    candidates: list[Candidate]
    rules: Rules
    marginal: dict[str, Fit]
    chosen: list[Fit] = field(default_factory=list)
    remaining: np.ndarray | None = None
    conditional: dict[str, Fit] = field(default_factory=dict)
    proxies: dict[str, Proxy] = field(default_factory=dict)
    # products that gave way to one of their columns with the other causes in: no interaction, no candidate
    no_interaction: set[str] = field(default_factory=set)
    # columns an id holds that fitted its level means no better than chance: column -> (id, levels, p)
    by_chance: dict[str, tuple[str, int, float]] = field(default_factory=dict)
    # trends in time that showed nothing between parts run at the same settings: column -> its TrendTest
    follows_inputs: dict[str, TrendTest] = field(default_factory=dict)
    # trends in time the test between parts run at the same settings could not see: column -> its TrendTest
    untold_trends: dict[str, TrendTest] = field(default_factory=dict)

    def __post_init__(self):
        self.remaining = self.y if self.remaining is None else self.remaining
        self.conditional = self.conditional or dict(self.marginal)

    @property
    def names(self) -> set[str]:
        return {fit.candidate.name for fit in self.chosen}

    @property
    def settled(self) -> set[str]:
        """The columns chosen, and the trends in time set aside as following the settings."""
        return self.names | set(self.follows_inputs)

    def refit(self) -> None:
        """Joint fit of the chosen causes; what they leave, and every other candidate's fit to it."""
        models, _ = forms.backfit([s.candidate.values for s in self.chosen], [s.form.name for s in self.chosen], self.y)
        # the chosen forms refitted jointly; new records, so that the marginal fits keep their own forms
        self.chosen = [dataclasses.replace(fit, form=model) for fit, model in zip(self.chosen, models)]
        left = self.y - sum(m.predict(s.candidate.values) for s, m in zip(self.chosen, models))
        self.remaining = left - left.mean()
        self.conditional = self.rules.fit_all([c for c in self.candidates if c.name not in self.names], self.remaining)

    def next_cause(self) -> Fit | None:
        """The next cause given those chosen, or None when no candidate is significant.

        An id that predicts best is named only if its offsets stand once the smooth candidates are out."""
        pool = self.pool()
        smooth = [f for f in pool if f.candidate.kind != "group"]
        best = self._next_smooth(smooth) if smooth else None
        # an id is tried only where it predicts better than every significant smooth cause (not a trend in time
        # that followed the settings)
        bar = min(
            (f.score for f in smooth if self.rules.significant(f) and f.candidate.name not in self.follows_inputs),
            default=np.inf,
        )
        named_id, accounted = self._next_id([f for f in pool if f.candidate.kind == "group" and f.score < bar])
        # an id whose offsets are mostly what the smooth causes do is named after them (a lubricant per coil)
        if named_id is None or (
            best is not None and smooth_first(best, named_id, accounted, lambda: self._by_chance(best, named_id))
        ):
            return best
        return self._held_cause(named_id) or named_id

    def _held_cause(self, named_id: Fit) -> Fit | None:
        """A column the id holds whose closed forms fit the id's level means beyond chance
        (:func:`~hybridtwin.diagnosis.levels.level_chance_p`) and whose effect passes the margin: it goes before the
        id, which is then judged on what it leaves. The rules of :func:`smooth_first` weigh a column's share against
        the id's, and an id of one parameter per level takes up every cause its levels carry at once: over 29
        coils a wear in the stroke counter explained 29% of the residual against the coil's 72%, yet fitted the
        coils' means beyond chance (p 0.005; the per-coil product and the oil parabola were then named too,
        structures draw 40063)."""
        seed, alpha = self.rules.settings.seed, self.rules.settings.alpha
        pool = {fit.candidate.name: fit for fit in self.pool() if fit.candidate.kind in ("input", "log")}
        tested = []
        for column in held_columns(named_id.candidate, self.candidates):
            fit = pool.get(column.name)
            if fit is None or fit.effect_std <= self.rules.min_effect or fit.score >= 0:
                continue
            p_value = level_chance_p(column, named_id.candidate, self.remaining, self.candidates, seed, alpha)
            if p_value is not None and p_value < alpha:
                tested.append((p_value, fit.score, fit))
        return min(tested, key=lambda item: item[:2])[2] if tested else None

    def _by_chance(self, column: Fit, named_id: Fit) -> bool:
        """Whether ``column`` is one the id holds (constant within its levels) and fits the id's level means no
        better than the columns it holds fit them shuffled (:func:`~hybridtwin.diagnosis.levels.level_chance_p`)."""
        settings = self.rules.settings
        p_value = level_chance_p(
            column.candidate, named_id.candidate, self.remaining, self.candidates, settings.seed, settings.alpha
        )
        if p_value is None or p_value < settings.alpha:
            return False
        levels = len(np.unique(np.asarray(named_id.candidate.values).astype(str)))
        self.by_chance[column.candidate.name] = (named_id.candidate.name, levels, p_value)
        return True

    def pool(self) -> list[Fit]:
        """The candidates' fits given the chosen causes, less those chosen and the pairs that are no interaction
        (their product does not beat their two columns, or gave way to one of them with the other causes in)."""
        left_out = self.settled | self.no_interaction
        return [f for n, f in self.conditional.items() if n not in left_out and f.form.name != forms.Additive.name]

    def _next_smooth(self, pool: list[Fit]) -> Fit | None:
        """The best significant column, product or time given those chosen that is a cause (a trend in time only
        with evidence beyond the settings that changed with time, :meth:`_beyond_inputs`)."""
        while True:
            named = self._strongest(pool)
            if named is None or self._beyond_inputs(named):
                return named
            pool = [fit for fit in pool if fit.candidate.name != named.candidate.name]

    def _beyond_inputs(self, fit: Fit) -> bool:
        """Whether ``fit`` is no trend in time, or one that shows between parts run at the same settings
        (:func:`~hybridtwin.diagnosis.trends.trend_test`, where the test could see it); a trend that does not is
        recorded, and is no candidate from then on."""
        if not is_trend_in_time(fit.candidate):
            return True
        settings = self.rules.settings
        test = trend_test(
            fit, self._of_inputs(), self.candidates, self.rules.input_correlation, settings.seed, settings.alpha
        )
        if test is None or test.p_value < settings.alpha:
            return True
        if test.power < TREND_POWER:
            self.untold_trends[fit.candidate.name] = test
            return True
        self.follows_inputs[fit.candidate.name] = test
        return False

    def _strongest(self, pool: list[Fit]) -> Fit | None:
        """The best significant column, product or time given those chosen (the simplest that predicts the same).

        A better-scoring candidate that is not significant (a drift whose gain comes in a few blocks) does not
        stop the selection: the ids would then be tried with a significant smooth cause still in the residual.
        """
        significant = [fit for fit in pool if self.rules.significant(fit)]
        if not significant:
            return None
        strongest = min(significant, key=self._rank)
        named = self._named(strongest, pool)
        if strongest.candidate.kind == "interaction" and named.candidate.kind != "interaction":
            # no interaction: its column competes with the other columns, as it would without the pair (a die
            # temperature taken for its product with a cushion force, where the ambient predicted better alone)
            columns = [fit for fit in significant if fit.candidate.kind != "interaction"]
            named = self._named(min(columns + [named], key=self._rank), pool)
        return named if self.rules.significant(named) else None

    def _rank(self, fit: Fit) -> tuple[float, str]:
        return self.rules.strength(fit), fit.candidate.name

    def _named(self, best: Fit, pool: list[Fit]) -> Fit:
        """What ``best`` is named as: the simplest column that predicts the same, a product only where it beats
        its columns."""
        simplest = prefer_simpler(best, pool, self.remaining, self.rules)
        return product_or_column(simplest, {c.name: c for c in self.candidates}, self.remaining, self.rules)

    def _next_id(self, pool: list[Fit]) -> tuple[Fit | None, float]:
        """The best id whose offsets stand once the model inputs' surface and the smooth candidates are out
        (:func:`~hybridtwin.diagnosis.ids.id_stands`), with the share they account for; an id they account
        for is recorded, not named."""
        for fit in sorted(pool, key=lambda fit: (fit.score, fit.candidate.name)):
            if not self.rules.significant(fit):
                continue
            proxy = id_stands(fit, self.remaining, self.candidates, self.conditional, self.rules, self._of_inputs())
            if proxy.stands:
                return fit, proxy.share
            self.proxies[fit.candidate.name] = proxy
        return None, 0.0

    def _of_inputs(self) -> np.ndarray:
        """What is left, with the chosen causes that are functions of the model inputs alone put back: whether an
        id's offsets go beyond a smooth function of the inputs does not depend on how much of that function
        closed forms have taken already (what they leave is rougher than the whole)."""
        inputs = {c.name for c in self.candidates if c.kind == "input"}
        of_inputs = [fit for fit in self.chosen if set(fit.candidate.columns) <= inputs]
        terms = [fit.form.predict(fit.candidate.values) for fit in of_inputs]
        return self.remaining + sum(terms, np.zeros(len(self.y)))

    def found(self, aliases: dict, explained_by: dict) -> Found:
        """What the selection found, as the table reports it, with what could not be told apart (``aliases``) and
        what was explained (``explained_by``): the records kept only where they still hold for the chosen causes
        (the causes after the first may have been chosen again)."""
        names = self.names
        return Found(
            self.marginal,
            self.conditional,
            self.chosen,
            aliases,
            explained_by,
            self.proxies,
            {name: why for name, why in self.by_chance.items() if name not in names and why[0] in names},
            {name: test for name, test in self.follows_inputs.items() if name not in names},
            {name: test for name, test in self.untold_trends.items() if name in names},
        )

    def forward(self) -> None:
        """Forward selection, each step conditional on the causes already chosen; where no cause is left, a
        chosen many-parameter trend may give way to a closed form and a further cause (:meth:`_trend_gives_way`)."""
        while len(self.chosen) < self.rules.settings.max_causes:
            best = self.next_cause()
            if best is not None:
                self.chosen.append(best)
                self.refit()
            elif not self._trend_gives_way():
                break

    def _trend_gives_way(self) -> bool:
        """Whether a chosen many-parameter trend (a monotone trend: a jump at every level it needs) gave way to its
        best significant closed form and the further cause that this leaves significant, the two together
        explaining more held out than the trend (:func:`joint_share`); the selection then goes on from them.

        A monotone trend in a column of few values (a per-lot yield strength, 18 lots) can put a jump wherever
        another per-lot cause puts one: it took up most of a thickness step at 4 times the surrogate's
        uncertainty, which then explained 4% of what was left, not significant; given the yield strength's
        closed form the step explained 27% (p 3e-7), and the two together 0.90 of the residual held out against
        the trend's 0.83 (structures draw 40114)."""
        many = [j for j, fit in enumerate(self.chosen) if fit.form.name == forms.Monotone.name]
        settings = self.rules.settings
        current = joint_share(self.chosen, self.y, settings) if many else 0.0  # what the trend explains now
        for j in many:
            fit = self.chosen[j]
            again = self.rules.best_fit(fit.candidate, self._partial_residual(j))
            closed = [
                alt
                for alt in again.alternatives
                if alt.form.n_params <= MAX_CLOSED_FORM_PARAMS and self.rules.significant(alt)
            ]
            if not closed:
                continue
            trial = self._copy(self.chosen[:j] + [closed[0]] + self.chosen[j + 1 :])
            trial.refit()
            added = trial.next_cause()
            if added is None:
                continue
            if joint_share(trial.chosen + [added], self.y, settings) > current:
                trial.chosen.append(added)
                trial.refit()
                self._adopt(trial)
                return True
        return False

    def _copy(self, chosen: list[Fit]) -> "Selection":
        """A selection with ``chosen`` in place of the causes chosen, and copies of what it records."""
        return dataclasses.replace(
            self,
            chosen=list(chosen),
            proxies=dict(self.proxies),
            no_interaction=set(self.no_interaction),
            by_chance=dict(self.by_chance),
            follows_inputs=dict(self.follows_inputs),
            untold_trends=dict(self.untold_trends),
        )

    def _adopt(self, other: "Selection") -> None:
        """Take ``other``'s state as this selection's."""
        for state in dataclasses.fields(self):
            setattr(self, state.name, getattr(other, state.name))

    def refine(self) -> bool:
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
            if not any([self._refined(j) for j in range(len(self.chosen))]):
                break
            changed = True
        return changed

    def drop_products_an_id_holds(self) -> None:
        """A product chosen before an id goes where it adds nothing significant once the id is in.

        Among dozens of pairs, one can take up part of a few dozen coil offsets by chance (settings change
        with the coils); chosen before the ids (ids come last), it would stand beside the true coil effect.
        """
        if not any(fit.candidate.kind == "group" for fit in self.chosen):
            return
        for j in reversed(range(len(self.chosen))):
            fit = self.chosen[j]
            if fit.candidate.kind == "interaction" and not self.rules.significant(
                self.rules.best_fit(fit.candidate, self._partial_residual(j))
            ):
                del self.chosen[j]
                self.refit()

    def choose_again_after_the_first(self) -> None:
        """The causes after the first were chosen given a first cause that has changed: choose them again (a
        product that gave way to its column is no longer a candidate: the column competes with the others)."""
        del self.chosen[1:]
        self.proxies = {}
        self.refit()
        self.forward()
        self.refine()
        self.refit()

    def _partial_residual(self, j: int) -> np.ndarray:
        """``y`` less the other chosen causes' terms of the joint fit, centred."""
        chosen = self.chosen
        models, means = forms.backfit([s.candidate.values for s in chosen], [s.form.name for s in chosen], self.y)
        rest = self.y - sum(
            m.predict(s.candidate.values) - c for k, (m, s, c) in enumerate(zip(models, chosen, means)) if k != j
        )
        return rest - rest.mean()

    def _refined(self, j: int) -> bool:
        """Choose cause ``j`` (or, for a product, one of its columns) again given the others; whether it changed."""
        fit, rest = self.chosen[j], self._partial_residual(j)
        if fit.candidate.kind == "interaction":
            return self._product_to_column(j, rest)
        again = self.rules.best_fit(fit.candidate, rest)
        if fit.candidate.kind == "time":  # time against the logged quantities again, with the other causes in
            logged = [c for c in self.candidates if c.kind in ("input", "log") and c.name not in self.settled]
            again = prefer_simpler(again, [again] + [self.rules.best_fit(c, rest) for c in logged], rest, self.rules)
        if (again.candidate.name, again.form.name) != (fit.candidate.name, fit.form.name) and self.rules.significant(
            again
        ):
            self.chosen[j] = again
            return True
        return False

    def _product_to_column(self, j: int, rest: np.ndarray) -> bool:
        """A product gives way to one of its columns where that column, given the others, explains as much."""
        by_name = {c.name: c for c in self.candidates}
        current = joint_share(self.chosen, self.y, self.rules.settings)
        singles = [self.rules.best_fit(by_name[c], rest) for c in self.chosen[j].candidate.columns if c in by_name]
        singles = [single for single in singles if self.rules.significant(single)]
        scored = [
            (joint_share(self.chosen[:j] + [single] + self.chosen[j + 1 :], self.y, self.rules.settings), single)
            for single in singles
        ]
        scored = [(share, single) for share, single in scored if share >= current - SHARE_TOLERANCE]
        if not scored:
            return False
        self.no_interaction.add(self.chosen[j].candidate.name)
        self.chosen[j] = self._strongest_column(
            max(scored, key=lambda item: (item[0], item[1].candidate.name))[1], rest
        )
        return True

    def _strongest_column(self, column: Fit, rest: np.ndarray) -> Fit:
        """The column a product gave way to, or another column that ranks ahead of it given the other causes
        (``rest``), named as :meth:`_named` names it: the column competes as it would without the pair."""
        others = [
            c
            for c in self.candidates
            if c.kind in ("input", "log", "time") and c.name not in self.settled | {column.candidate.name}
        ]
        rivals = [fit for fit in self.rules.fit_all(others, rest).values() if self.rules.significant(fit)]
        strongest = min(rivals + [column], key=self._rank)
        if strongest is column:
            return column
        named = prefer_simpler(strongest, rivals + [column], rest, self.rules)
        return named if self.rules.significant(named) else column


def joint_share(fits: list[Fit], y, settings: Settings) -> float:
    """Held-out share of ``y`` that several terms explain together (backfitted on each fold's training rows)."""
    oof = held_out_sum(fits, kfolds(len(y), settings.folds, settings.seed), y)
    return float(1.0 - np.mean((y - oof) ** 2) / np.mean(y**2))


def _rows(frame: pd.DataFrame, residual, settings: Settings) -> tuple[pd.DataFrame, np.ndarray]:
    """The diagnosed rows: all of them, or a seeded sample of ``settings.max_rows`` in row order."""
    residual = np.asarray(residual, float)
    frame = frame.reset_index(drop=True)
    if len(residual) <= settings.max_rows:
        return frame, residual
    keep = np.sort(np.random.default_rng(settings.seed).choice(len(residual), settings.max_rows, replace=False))
    return frame.iloc[keep].reset_index(drop=True), residual[keep]


def diagnose(frame, residual, inputs, exclude, settings: Settings, surrogate_std=0.0, input_correlation=None):
    """Rank candidate causes of ``residual`` (approximate residuals of in-support rows, in row order).

    ``frame`` holds those rows' production columns; ``exclude`` names columns that
    must not be candidates (the target). ``surrogate_std`` is the surrogate's own
    predictive uncertainty (noise excluded) on these rows: a cause's term must
    vary (standard deviation over the rows) by more than ``surrogate_margin``
    times it, or it could be the surrogate's own error. ``input_correlation``: :attr:`Rules.input_correlation`.
    """
    frame, residual = _rows(frame, residual, settings)
    offset = float(residual.mean())
    y = residual - offset
    blocks = block_means(residual, settings.n_blocks)
    candidates, skipped = build_candidates(frame, inputs, exclude, settings)
    rules = Rules(settings, len(candidates), settings.surrogate_margin * surrogate_std, input_correlation)
    selection = Selection(y, candidates, rules, rules.fit_all(candidates, y))
    selection.forward()
    if selection.refine():
        selection.choose_again_after_the_first()
    selection.drop_products_an_id_holds()
    found = selection.found(*confounding(selection.chosen, selection.marginal, y, rules))
    table = causes_table(found, skipped, rules)
    return Diagnosis(
        offset,
        float(np.std(blocks, ddof=1) / np.sqrt(len(blocks))),
        len(y),
        float(y.std()),
        surrogate_std,
        rules.min_effect,
        table,
        y,
        {c.name: c for c in candidates},
        skipped,
        selection.chosen,
        found.aliases,
        found.explained_by,
        selection.proxies,
        too_small(found, rules),
        found.by_chance,
        found.follows_inputs,
        found.untold_trends,
    )
