"""The established alternatives to the paper's hybrid, fitted on the same information (DoE + in-support parts).

- :class:`GPDiscrepancy`: Kennedy–O'Hagan style, the surrogate plus a Gaussian process of the
  approximate residual (Matérn 5/2, one length scale per input, white noise). Hyperparameters by
  marginal likelihood on ``n_hyper`` of its ``n_fit`` rows, then the GP refitted with them fixed on all
  ``n_fit`` (a GP cannot take every in-support part exactly; both subsets are seeded and documented).
- :class:`CoKriging`: AR1 multi-fidelity co-kriging (SMT's MFK): the simulations as low fidelity,
  ``n_high`` in-support parts' measured values as high fidelity.

Both store their training rows and hyperparameters as JSON and are rebuilt from them exactly
(no optimizer runs on load, no pickle). On their own training rows they are scored out-of-fold
(``out_of_fold``: refitted without each fold, the hyperparameters fixed, as the XGBoost residual
model keeps its tuned hyperparameters in its CV folds).
"""

from __future__ import annotations

import copy
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from .crossval import folds, training_subset
from .files import in_support
from .gate import (
    DoEStandardizer,
    input_matrix,
    input_names,
    remember_inputs,
    restore_inputs,
)
from .surrogate import GPRSurrogate

# rows predicted at a time: the cross-covariances with the training rows (and SMT's per-input differences,
# rows x training rows x inputs) stay in cache; co-kriging predicts 30% faster than with 500 rows at a time
BATCH_ROWS = 100


def _batched(predict, X: np.ndarray) -> np.ndarray:
    return (
        np.concatenate([np.ravel(predict(X[start : start + BATCH_ROWS])) for start in range(0, len(X), BATCH_ROWS)])
        if len(X)
        else np.empty(0)
    )


def available_cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _chunks(n_rows: int, n_jobs: int) -> list[slice]:
    """At most ``n_jobs`` stretches of whole batches: each row is predicted in the same batch as in one
    stretch, so the answer does not depend on the number of threads."""
    if n_rows == 0:
        return []
    batches = -(-n_rows // BATCH_ROWS)
    per_chunk = -(-batches // max(1, min(n_jobs, batches))) * BATCH_ROWS
    return [slice(start, min(start + per_chunk, n_rows)) for start in range(0, n_rows, per_chunk)]


class GPDiscrepancy(RegressorMixin, BaseEstimator):
    """A GP of the residual (measured - surrogate); ``predict`` gives the residual correction."""

    def __init__(self, n_hyper: int = 500, n_fit: int = 2000, n_restarts: int = 0, random_state: int = 0):
        self.n_hyper = n_hyper
        self.n_fit = n_fit
        self.n_restarts = n_restarts
        self.random_state = random_state

    def fit(self, X, y):
        remember_inputs(self, X)
        matrix = np.asarray(X, float)
        y = np.asarray(y, float)
        self.n_features_in_ = matrix.shape[1]
        self.training_rows_ = training_subset(len(y), self.n_fit, self.random_state + 1)
        # the hyperparameters from a seeded part of the same rows: every row the GP learnt from is a training row,
        # and so has an out-of-fold prediction
        self.hyper_rows_ = self.training_rows_[
            training_subset(len(self.training_rows_), self.n_hyper, self.random_state)
        ]
        hyper = GPRSurrogate(n_restarts=self.n_restarts, random_state=self.random_state)
        hyper.fit(matrix[self.hyper_rows_], y[self.hyper_rows_])
        self.gp_ = _with_rows(
            hyper.to_dict(), hyper.standardizer_.transform(matrix[self.training_rows_]), y[self.training_rows_]
        )
        return self

    def out_of_fold(self, n_folds: int, seed: int) -> np.ndarray:
        """Per training row (in ``training_rows_`` order): the GP, its hyperparameters fixed, refitted
        without that row's fold."""
        check_is_fitted(self, "gp_")
        state = self.gp_.to_dict()
        Z, y = np.asarray(state["X_train"], float), np.asarray(state["y_train"], float)
        out = np.empty(len(y))
        for train, test in folds(len(y), n_folds, seed):
            out[test] = _batched(_with_rows(state, Z[train], y[train]).gpr_.predict, Z[test])  # Z: standardized
        return out

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "gp_")
        return _batched(self.gp_.predict, input_matrix(self, X))

    def to_dict(self) -> dict:
        return {
            "format": "hybridtwin.GPDiscrepancy/1",
            "params": self.get_params(),
            "inputs": input_names(self),
            "gp": self.gp_.to_dict(),
            "n_fit": len(self.training_rows_),
            "training_rows": self.training_rows_.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> "GPDiscrepancy":
        model = cls(**data["params"])
        model.gp_ = GPRSurrogate.from_dict(data["gp"])
        model.n_features_in_ = model.gp_.n_features_in_
        model.training_rows_ = np.asarray(data["training_rows"], int)
        restore_inputs(model, data)
        return model


def _with_rows(state: dict, Z: np.ndarray, y: np.ndarray) -> GPRSurrogate:
    """The GP of ``state`` (a GPRSurrogate's dict), its hyperparameters fixed, on standardized rows ``Z``
    (GPRSurrogate.from_dict refits without optimizing)."""
    return GPRSurrogate.from_dict({**state, "inputs": None, "X_train": Z.tolist(), "y_train": np.asarray(y).tolist()})


def _mfk_class():
    from smt.applications import MFK

    class FixedMFK(MFK):
        """SMT's MFK trained with given hyperparameters: one likelihood evaluation per level, no search."""

        def __init__(self, fixed, **options):
            super().__init__(**options)
            self._fixed = [np.asarray(level, float) for level in fixed]

        def _run_optimization(self, D):
            # the state MFK's own search sets up before it evaluates the likelihood
            self.D = self._componentwise_distance(D)
            self.noise0 = np.array(self._noise0)
            theta = self._fixed[self._lvl]
            value, par = self._reduced_likelihood_function(theta=theta)
            return value, par, theta

    return MFK, FixedMFK


class CoKriging(RegressorMixin, BaseEstimator):
    """AR1 co-kriging: ``fit(X_high, y_high, X_low=DoE inputs, y_low=simulated)``; ``predict`` gives the target."""

    def __init__(self, n_high: int = 500, n_start: int = 2, random_state: int = 0):
        self.n_high = n_high
        self.n_start = n_start
        self.random_state = random_state

    def _options(self) -> dict:
        return {
            "corr": "matern52",
            "eval_noise": True,
            "hyper_opt": "Cobyla",
            "n_start": self.n_start,
            "theta0": [1.0],
            "theta_bounds": [1e-4, 50.0],
            "seed": self.random_state,
            "print_global": False,
        }

    def _train(self, model, X_low, y_low, X_high, y_high):
        model.set_training_values(self.standardizer_.transform(X_low), np.asarray(y_low, float)[:, None], name=0)
        model.set_training_values(self.standardizer_.transform(X_high), np.asarray(y_high, float)[:, None])
        model.train()
        return model

    def fit(self, X, y, X_low=None, y_low=None):
        remember_inputs(self, X)
        X_high = np.asarray(X, float)
        self.n_features_in_ = X_high.shape[1]
        self.training_rows_ = rows = training_subset(len(X_high), self.n_high, self.random_state)
        X_low = input_matrix(self, X_low)  # the DoE's columns taken by name, as the parts'
        self.standardizer_ = DoEStandardizer().fit(X_low)  # the DoE's statistics, as the gate's
        self.data_ = {
            "X_low": X_low,
            "y_low": np.asarray(y_low, float),
            "X_high": X_high[rows],
            "y_high": np.asarray(y, float)[rows],
        }
        MFK, _ = _mfk_class()
        self.mfk_ = self._train(MFK(**self._options()), **self.data_)
        self.hyperparameters_ = [
            np.append(self.mfk_.optimal_theta[level], self.mfk_.optimal_noise_all[level]).tolist() for level in range(2)
        ]
        return self

    def out_of_fold(self, n_folds: int, seed: int) -> np.ndarray:
        """Per high-fidelity row (in ``training_rows_`` order): co-kriging, its hyperparameters fixed, refitted
        without that row's fold (the simulations kept)."""
        check_is_fitted(self, "mfk_")
        _, FixedMFK = _mfk_class()
        X, y = self.data_["X_high"], self.data_["y_high"]
        out = np.empty(len(y))
        for train, test in folds(len(y), n_folds, seed):
            model = FixedMFK(self.hyperparameters_, **self._options())
            self._train(model, self.data_["X_low"], self.data_["y_low"], X[train], y[train])
            out[test] = _batched(model.predict_values, self.standardizer_.transform(X[test]))
        return out

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "mfk_")
        X = self.standardizer_.transform(input_matrix(self, X))
        return _batched(self.mfk_.predict_values, X)

    def to_dict(self) -> dict:
        return {
            "format": "hybridtwin.CoKriging/1",
            "params": self.get_params(),
            "inputs": input_names(self),
            "standardizer": self.standardizer_.to_dict(),
            "hyperparameters": self.hyperparameters_,
            "training_rows": self.training_rows_.tolist(),
            "data": {key: value.tolist() for key, value in self.data_.items()},
        }

    @classmethod
    def from_dict(cls, data: dict) -> "CoKriging":
        model = cls(**data["params"])
        model.standardizer_ = DoEStandardizer.from_dict(data["standardizer"])
        model.data_ = {key: np.asarray(value, float) for key, value in data["data"].items()}
        model.n_features_in_ = model.data_["X_high"].shape[1]
        model.hyperparameters_ = data["hyperparameters"]
        model.training_rows_ = np.asarray(data["training_rows"], int)
        restore_inputs(model, data)
        _, FixedMFK = _mfk_class()
        model.mfk_ = model._train(FixedMFK(model.hyperparameters_, **model._options()), **model.data_)
        return model


PEERS = ("gp_discrepancy", "cokriging")


@dataclass
class PeerFit:
    model: object
    # pred_<kind>: the final model; pred_<kind>_oof: the same, but out-of-fold on the parts it trained on
    production: pd.DataFrame
    fit_seconds: float
    n_train: int


def fit_peer(
    kind: str,
    doe: pd.DataFrame,
    production: pd.DataFrame,
    residuals: pd.DataFrame,
    inputs,
    target: str,
    settings: dict,
    seed: int,
    n_folds: int = 5,
) -> PeerFit:
    """Fit one peer on the DoE and the in-support parts; predict every production row (a seeded sample of
    ``settings["max_predicted"]`` rows on a larger log, NaN elsewhere) and, on the parts it trained on, out of
    ``n_folds`` folds (the peer refitted without each fold, its hyperparameters fixed), as the hybrid is scored.

    ``residuals``: measured, pred_surrogate, residual_approx, in_support per production row (the
    residuals rule's table).
    """
    inputs = list(inputs)
    inside = np.flatnonzero(in_support(residuals))
    X_in = production.iloc[inside][inputs]
    surrogate = residuals["pred_surrogate"].to_numpy(float)
    start = time.perf_counter()
    if kind == "gp_discrepancy":
        model = GPDiscrepancy(n_hyper=settings["gp_n_hyper"], n_fit=settings["gp_n_fit"], random_state=seed)
        model.fit(X_in, residuals["residual_approx"].to_numpy(float)[inside])
    elif kind == "cokriging":
        model = CoKriging(n_high=settings["cokriging_n_high"], random_state=seed)
        model.fit(X_in, residuals["measured"].to_numpy(float)[inside], X_low=doe[inputs], y_low=doe[target])
    else:
        raise ValueError(f"unknown peer {kind!r}; one of {', '.join(PEERS)}")
    seconds = time.perf_counter() - start
    # a peer predicts row by row against all its training points: on a large log, a seeded sample of rows
    predicted = training_subset(len(production), settings.get("max_predicted", len(production)), seed + 2)
    final = np.full(len(production), np.nan)
    final[predicted] = peer_prediction(kind, model, production.iloc[predicted][inputs], surrogate[predicted])
    trained = inside[model.training_rows_]
    honest = final.copy()
    honest[trained] = _as_target(kind, model.out_of_fold(n_folds, seed), surrogate[trained])
    return PeerFit(model, pd.DataFrame({f"pred_{kind}": final, f"pred_{kind}_oof": honest}), seconds, len(trained))


def _as_target(kind: str, value: np.ndarray, surrogate: np.ndarray) -> np.ndarray:
    """The GP discrepancy predicts a correction of the surrogate, co-kriging the target itself."""
    return surrogate + value if kind == "gp_discrepancy" else value


def peer_prediction(kind: str, model, X: pd.DataFrame, surrogate: np.ndarray) -> np.ndarray:
    """The peer's prediction of the target at ``X``, given the surrogate there."""
    return _as_target(kind, model.predict(X), surrogate)


def predictions_at(models: dict, X: pd.DataFrame, surrogate: np.ndarray, n_jobs: int = 1) -> dict[str, np.ndarray]:
    """Every peer's prediction at ``X`` (the matched cases, say), given the surrogate there.

    With ``n_jobs`` > 1 the rows are shared among as many threads (numpy's kernels release the GIL),
    each with its own copy of the model: SMT's MFK sets its kernel's length scales as it predicts.
    """
    chunks = _chunks(len(X), n_jobs)
    if len(chunks) <= 1:
        return {kind: peer_prediction(kind, model, X, surrogate) for kind, model in models.items()}
    tasks = [
        (kind, model if i == 0 else copy.deepcopy(model), part)
        for kind, model in models.items()
        for i, part in enumerate(chunks)
    ]
    with ThreadPoolExecutor(min(n_jobs, len(tasks))) as pool:
        parts = list(pool.map(lambda t: peer_prediction(t[0], t[1], X.iloc[t[2]], surrogate[t[2]]), tasks))
    return {kind: np.concatenate([p for (k, _, _), p in zip(tasks, parts) if k == kind]) for kind in models}


def load_peer(kind: str, data: dict):
    return {"gp_discrepancy": GPDiscrepancy, "cokriging": CoKriging}[kind].from_dict(data)


COMPARED = (
    "surrogate",
    "hybrid_gated",
    "hybrid",
    "extended",
    "extended_hybrid",
    "gp_discrepancy",
    "cokriging",
    "stack",
    "recommended",
)


def comparison_table(
    measured,
    predictions: dict[str, np.ndarray],
    in_support,
    test: np.ndarray,
    matched_measured,
    matched_predictions: dict[str, np.ndarray],
    fits: dict[str, dict],
    truth=None,
    noise: float | None = None,
) -> pd.DataFrame:
    """peer_comparison.csv: every model on the same held-out production rows, in and out of the support.

    ``predictions`` are honest (out-of-fold on a model's training parts, a peer's included, or from models never
    trained on the row); the rows scored are the test blocks where every model has a value, so all models share
    them.
    ``fits``: per peer, its n_train (the in-support parts it trained on).
    """
    from .extension import gain_table

    names = [m for m in COMPARED if m in predictions]
    rows = np.flatnonzero(test & np.all([np.isfinite(predictions[m]) for m in names], axis=0))
    truth_rows = None if truth is None else np.asarray(truth, float)[rows]
    matched = {m: np.asarray(matched_predictions.get(m, np.full(len(matched_measured), np.nan)), float) for m in names}
    table = gain_table(
        np.asarray(measured, float)[rows],
        {m: predictions[m][rows] for m in names},
        np.asarray(in_support, bool)[rows],
        matched_measured,
        matched,
        truth_rows,
        noise,
    )
    # (fit times vary from run to run, so they stay out of the table: results/peers/<peer>.json and the benchmarks)
    table["n_train"] = table["model"].map({k: v["n_train"] for k, v in fits.items()})
    table["evaluated_on"] = (
        "production test rows (odd blocks of consecutive rows; the recommended model and the stack's weights were "
        "chosen on the even blocks), the same rows for every model: in support out-of-fold for the hybrid and the "
        "extension, and for a peer on the parts it trained on; out of support from models never trained there; matched "
        "cases never used for fitting (the stack and the recommended model are not scored on them)"
        + ("; truth = the demo's noise-free plant" if truth is not None else "")
    )
    return table
