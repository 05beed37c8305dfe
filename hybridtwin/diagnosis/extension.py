"""The physics-side extension: extended(x) = surrogate(x) + offset + sum_j g_j(cause_j; theta_j).

The causes and their forms come from the diagnosis; their few parameters are
refitted here on the in-support rows (by backfitting when there are several).
The extended hybrid adds an XGBoost model of what the extension leaves over. Out of the support it
stands only where it beat the paper's hybrid beyond doubt on the measured parts of the choosing blocks
(:func:`guard`): a wrong cause, or trees that carry less of the surrogate's error
once a term took the effect, must never make the paper's method worse where it matters most.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin

from hybridtwin.crossval import splice_out_of_fold, training_subset
from hybridtwin.diagnosis import forms
from hybridtwin.diagnosis.causes import Term
from hybridtwin.io.files import in_support, table_of
from hybridtwin.metrics import rmse, signed_rank_p_value
from hybridtwin.models import compose
from hybridtwin.models.batches import by_parts
from hybridtwin.models.registry import EXTENDED, EXTENDED_HYBRID, HYBRID, SURROGATE

log = logging.getLogger(__name__)


class DiscrepancyExtension(RegressorMixin, BaseEstimator):
    """Offset plus the diagnosed terms; ``fit(frame, residual)`` / ``predict(frame)`` give the residual correction.

    ``terms`` are :class:`~hybridtwin.causes.Term` (or their dicts). ``frame`` is a table of
    production columns (it must hold the causes' columns; at prediction a missing column
    contributes zero, the term's mean).
    """

    def __init__(self, terms: tuple = ()):
        self.terms = terms

    def _terms(self) -> list[Term]:
        return [t if isinstance(t, Term) else Term.from_dict(t) for t in self.terms]

    @property
    def columns(self) -> set[str]:
        """The production columns its terms read."""
        return {column for term in self._terms() for column in term.cause.columns}

    def fit(self, frame: pd.DataFrame, residual):
        residual = np.asarray(residual, float)
        self.offset_ = float(residual.mean())
        terms = self._terms()
        values = [t.cause.values(frame) for t in terms]
        target = residual - self.offset_
        self.forms_, self.means_ = forms.backfit(values, [t.form for t in terms], target)
        for j, (form, x) in enumerate(zip(self.forms_, values)):
            # how far each term is trusted beyond its in-support values: judged on its partial residual
            others = sum(
                (f.predict(v) - m for k, (f, v, m) in enumerate(zip(self.forms_, values, self.means_)) if k != j),
                np.zeros_like(target),
            )
            forms.set_trusted_range(form, x, target - others)
        return self

    def contributions(self, frame: pd.DataFrame) -> dict[str, np.ndarray]:
        """Each cause's centred contribution; zero where the frame lacks the cause's column."""
        out = {}
        for term, form, mean in zip(self._terms(), self.forms_, self.means_):
            cause = term.cause
            if not set(cause.columns) <= set(frame.columns):
                log.warning("no column %s here: the %s term is set to its mean (0)", cause.columns, cause.name)
                out[cause.name] = np.zeros(len(frame))
                continue
            out[cause.name] = form.predict(cause.values(frame)) - mean
        return out

    def predict(self, frame: pd.DataFrame) -> np.ndarray:
        return self.offset_ + sum(self.contributions(frame).values(), np.zeros(len(frame)))

    def to_dict(self) -> dict:
        return {
            "format": "hybridtwin.DiscrepancyExtension/1",
            "offset": self.offset_,
            "causes": [t.to_dict() for t in self._terms()],
            "forms": [f.to_dict() for f in self.forms_],
            "means": self.means_,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "DiscrepancyExtension":
        model = cls(terms=tuple(Term.from_dict(c) for c in data["causes"]))
        model.offset_ = float(data["offset"])
        model.forms_ = [forms.form_from_dict(f) for f in data["forms"]]
        model.means_ = [float(m) for m in data["means"]]
        return model


# the guard's choice in models/extension.json
STANDS_KEY = "extended_hybrid_out_of_support"


@dataclass
class Models:
    """The four predictors of the residual correction, fitted on in-support rows."""

    extension: DiscrepancyExtension
    remainder: object  # XGBoost model of residual - extension
    out_of_support: bool = True  # whether the extended hybrid stands out of the support (the guard's choice)

    def stored(self) -> dict:
        """models/extension.json: the extension's terms and the guard's choice (the remainder is stored apart,
        in XGBoost's own format)."""
        return {**self.extension.to_dict(), STANDS_KEY: self.out_of_support}

    @classmethod
    def from_stored(cls, data: dict, remainder) -> "Models":
        return cls(DiscrepancyExtension.from_dict(data), remainder, bool(data[STANDS_KEY]))


# beyond doubt out of the support: better on average, and a positive gain in the typical stretch of
# consecutive parts by the signed-rank test (a drift's or a coil's gains are positive but very unequal
# across stretches, which a t-test counts against them)
GUARD_ALPHA = 0.05
GUARD_BLOCKS = 50
MIN_GUARD_BLOCKS = 10  # blocks are lengthened down to this many while their means stay correlated


def keeps_out_of_support(measured, extended_hybrid, hybrid, choosing) -> bool:
    """The guard's choice: the extended hybrid stands out of the support only where it beats the paper's
    hybrid beyond doubt on the measured values of the ``choosing`` out-of-support parts.

    Beyond doubt: a lower RMSE, and a positive gain in the typical block of consecutive choosing parts
    (the choosing blocks joined end to end) by the one-sided Wilcoxon signed-rank test at
    :data:`GUARD_ALPHA` (:func:`metrics.signed_rank_p_value`). The test needs five blocks of about 20
    parts to reach it: with fewer than 100 choosing parts outside, or a tie, or a gain within the noise,
    the data cannot decide and the paper's hybrid stands. The same parts for both, so each part's noise
    weighs on both alike.
    """
    rows = np.asarray(choosing, bool)
    if rows.sum() < 2:
        return False
    measured = np.asarray(measured, float)[rows]
    extended_hybrid = np.asarray(extended_hybrid, float)[rows]
    hybrid = np.asarray(hybrid, float)[rows]
    return bool(
        rmse(measured, extended_hybrid) < rmse(measured, hybrid)
        and signed_rank_p_value(measured, extended_hybrid, hybrid, GUARD_BLOCKS, MIN_GUARD_BLOCKS) < GUARD_ALPHA
    )


def guard(measured, extended_hybrid, hybrid, in_support, choosing) -> tuple[np.ndarray, bool]:
    """The extended hybrid after the guard's choice on the out-of-support ``choosing`` rows, and that choice."""
    inside = np.asarray(in_support, bool)
    stands = keeps_out_of_support(measured, extended_hybrid, hybrid, np.asarray(choosing, bool) & ~inside)
    return compose.guarded(extended_hybrid, hybrid, inside, stands), stands


@dataclass(frozen=True)
class Fitting:
    """How the extension's models are fitted: on which inputs the remainder's XGBoost model (``make_xgb()``
    makes a fresh one) learns, and each fit on a seeded sample of at most ``max_rows`` of its rows."""

    inputs: tuple[str, ...]
    make_xgb: Callable
    max_rows: int | None = None
    seed: int = 0


@dataclass
class Parts:
    """The production parts the extension learns from and is judged on, in row order.

    ``production``: the inputs and the causes' columns; ``residuals``: measured, residual_approx,
    pred_surrogate, in_support; ``hybrid``: the paper's hybrid (out of the support the final model's value,
    which the guard compares with).
    """

    production: pd.DataFrame
    residuals: pd.DataFrame
    hybrid: np.ndarray

    @property
    def inside(self) -> np.ndarray:
        return in_support(self.residuals)

    @property
    def residual(self) -> np.ndarray:
        return self.residuals["residual_approx"].to_numpy(float)

    @property
    def surrogate(self) -> np.ndarray:
        return self.residuals[SURROGATE.column].to_numpy(float)


def fit_models(frame: pd.DataFrame, residual: np.ndarray, terms, fitting: Fitting, rows) -> Models:
    """The extension and the XGBoost remainder, both on a seeded sample of at most ``fitting.max_rows`` of the
    ``rows`` (positions in ``frame`` and ``residual``): only the sample is copied, not every training row (a fold
    of ten million parts)."""
    rows = np.asarray(rows)
    rows = rows[training_subset(len(rows), fitting.max_rows or len(rows), fitting.seed)]
    frame, residual = frame.iloc[rows], residual[rows]
    X = frame[list(fitting.inputs)].to_numpy(float)
    extension = DiscrepancyExtension(terms).fit(frame, residual)
    remainder = fitting.make_xgb().fit(X, residual - extension.predict(frame))
    return Models(extension, remainder)


def cross_validated(frame: pd.DataFrame, residual: np.ndarray, terms, fitting: Fitting, splits, rows):
    """Out-of-fold residual corrections of the extension and the extended hybrid on ``rows`` (positions in
    ``frame`` and ``residual``, which ``splits`` index into): a fold's rows are taken as it needs them."""
    extended = np.empty(len(rows))
    extended_hybrid = np.empty(len(rows))
    for train, test in splits:
        models = fit_models(frame, residual, terms, fitting, rows[train])
        held = frame.iloc[rows[test]]
        extended[test] = models.extension.predict(held)
        extended_hybrid[test] = extended[test] + models.remainder.predict(held[list(fitting.inputs)].to_numpy(float))
    return extended, extended_hybrid


def fit_guarded(parts: Parts, terms, fitting: Fitting, choosing=None) -> tuple[Models, dict[str, np.ndarray]]:
    """The extension and the extended hybrid fitted on the in-support parts, their predictions for every part,
    and the guard's choice on the out-of-support ``choosing`` parts (None: all) of whether the extended hybrid
    stands there (:func:`keeps_out_of_support`)."""
    rows = np.flatnonzero(parts.inside)
    models = fit_models(parts.production, parts.residual, terms, fitting, rows)
    rest = by_parts(models.remainder.predict, parts.production, fitting.inputs)
    terms_and_rest = (models.extension.predict(parts.production), rest)
    final = compose.extended(parts.surrogate, *terms_and_rest, parts.hybrid, parts.inside, True)
    choosing = np.ones(len(parts.inside), bool) if choosing is None else choosing
    final[EXTENDED_HYBRID.name], models.out_of_support = guard(
        parts.residuals["measured"], final[EXTENDED_HYBRID.name], parts.hybrid, parts.inside, choosing
    )
    return models, final


def predict(models: Models, frame: pd.DataFrame, X: np.ndarray, surrogate, hybrid, inside) -> dict[str, np.ndarray]:
    """The extended model and the (guarded) extended hybrid at the rows of ``frame``."""
    return compose.extended(
        surrogate, models.extension.predict(frame), models.remainder.predict(X), hybrid, inside, models.out_of_support
    )


@dataclass
class Evaluation:
    """The fitted extension and its predictions: final models everywhere and, for scoring, out-of-fold
    values on the in-support rows (``scored``; the ``*_oof`` columns of ``production``), plus the matched cases."""

    models: Models
    production: pd.DataFrame
    scored: dict[str, np.ndarray]
    matched: dict[str, np.ndarray]


def evaluate(parts: Parts, terms, fitting: Fitting, splits, choosing=None, matched=None) -> Evaluation:
    """Fit the extension and the extended hybrid on the in-support parts, predict with all four models, and score
    the in-support parts out of fold.

    ``splits`` are the folds over the in-support rows, the same as the hybrid's out-of-fold predictions;
    ``choosing`` the parts whose measured values decide, out of the support, whether the extended hybrid stands
    there. ``matched``: (matched cases' table, their in_support, surrogate and hybrid predictions).
    """
    models, final = fit_guarded(parts, terms, fitting, choosing)
    rows = np.flatnonzero(parts.inside)
    surrogate = parts.surrogate
    oof = cross_validated(parts.production, parts.residual, terms, fitting, splits, rows)
    scored = {SURROGATE.name: surrogate, HYBRID.name: parts.hybrid}
    for model, values in zip((EXTENDED, EXTENDED_HYBRID), oof):
        scored[model.name] = splice_out_of_fold(final[model.name], rows, surrogate[rows] + values)
    production = table_of(
        {
            **{model.column: final[model.name] for model in (EXTENDED, EXTENDED_HYBRID)},
            **{model.oof_column: scored[model.name] for model in (EXTENDED, EXTENDED_HYBRID)},
        }
    )
    return Evaluation(models, production, scored, _at_matched(models, fitting, *matched) if matched else {})


def _at_matched(models: Models, fitting: Fitting, matched: pd.DataFrame, cases: pd.DataFrame) -> dict:
    """The four models at the matched cases (``cases``: their in_support, surrogate and hybrid predictions)."""
    if len(cases) != len(matched):
        raise ValueError(f"{len(cases)} matched-case predictions for {len(matched)} matched cases")
    surrogate, hybrid = cases[SURROGATE.column].to_numpy(float), cases[HYBRID.column].to_numpy(float)
    X = matched[list(fitting.inputs)].to_numpy(float)
    return {
        SURROGATE.name: surrogate,
        HYBRID.name: hybrid,
        **predict(models, matched, X, surrogate, hybrid, in_support(cases)),
    }


def gain_table(
    measured,
    predictions: dict[str, np.ndarray],
    in_support,
    matched_measured,
    matched_predictions: dict[str, np.ndarray],
    truth=None,
    noise: float | None = None,
    test=None,
    scored: dict[str, np.ndarray] | None = None,
) -> pd.DataFrame:
    """model_extension.csv: RMSE in support (out-of-fold), out of support and on matched cases per model.

    ``predictions`` hold, per model, out-of-fold values on in-support rows and
    final-model values elsewhere, so no row is scored by a model trained on it.
    ``test``: the rows scored out of the support (None: all; else those the guard did not choose on);
    ``scored``: per model, the rows it is scored on (default: every row), counted in its ``n_*`` columns.
    """
    inside = np.asarray(in_support, bool)
    measured = np.asarray(measured, float)
    outside = ~inside if test is None else ~inside & np.asarray(test, bool)
    truth = None if truth is None else np.asarray(truth, float)
    rows = []
    for model, pred in predictions.items():
        mask = np.ones(len(measured), bool) if scored is None else np.asarray(scored[model], bool)
        here, there = inside & mask, outside & mask
        row = {
            "model": model,
            "rmse_in_support_cv": rmse(measured[here], pred[here]),
            "rmse_out_of_support": rmse(measured[there], pred[there]),
            "rmse_matched": rmse(matched_measured, matched_predictions[model]),
        }
        if truth is not None:
            row["rmse_truth_in_support_cv"] = rmse(truth[here], pred[here])
            row["rmse_truth_out_of_support"] = rmse(truth[there], pred[there])
            row["out_of_support_over_noise"] = row["rmse_out_of_support"] / noise if noise else float("nan")
        row.update(n_in_support=int(here.sum()), n_out_of_support=int(there.sum()), n_matched=len(matched_measured))
        rows.append(row)
    table = pd.DataFrame(rows)
    table["evaluated_on"] = (
        "measured production values: in support out of period (K folds of consecutive parts, the hybrid's own; "
        "the causes and forms were chosen on all in-support rows, only their parameters refitted per fold), out "
        "of support with models fitted on the in-support rows (never on these rows)"
        + (
            ""
            if test is None
            else " on the test blocks (odd blocks of consecutive rows; whether the extended hybrid stands out of "
            "the support was chosen on the even ones)"
        )
        + "; matched cases (never used for fitting)"
        + ("; truth = the demo's noise-free plant" if truth is not None else "")
    )
    return table
