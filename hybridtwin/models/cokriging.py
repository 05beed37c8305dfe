"""The co-kriging peer: AR1 multi-fidelity co-kriging (SMT's MFK), the simulations as low fidelity and in-support
parts' measured values as high fidelity.

The hyperparameters are searched by SMT's likelihood on ``n_high`` parts, with SMT's documented kernel (squared
exponential), length-scale bounds and number of starts (``n_start``: 10, SMT's default; Cobyla, to which SMT's
default TNC switches when the noise is estimated; with 2 starts the search ended in poorer optima on the bi-fidelity
functions, out of support up to 1.5 times the truth-RMSE); the model is then refitted with them held on ``n_fit``
parts (a superset; one likelihood evaluation per level). Campaigns are narrow, and each one's discrepancy is better
known from more of its parts. It stores its training data and hyperparameters as JSON and is rebuilt from them
exactly.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from hybridtwin.crossval import period_folds, training_subset
from hybridtwin.models.batches import batched
from hybridtwin.paper.gate import DoEStandardizer, input_matrix, input_names, remember_inputs, restore_inputs


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

    def __init__(
        self,
        n_high: int = 500,
        n_fit: int | None = None,
        n_start: int = 10,
        corr: str = "squar_exp",
        hyper_opt: str = "Cobyla",
        random_state: int = 0,
    ):
        self.n_high = n_high
        self.n_fit = n_fit
        self.n_start = n_start
        self.corr = corr
        self.hyper_opt = hyper_opt
        self.random_state = random_state

    def _options(self) -> dict:
        return {
            "corr": self.corr,
            "eval_noise": True,
            "hyper_opt": self.hyper_opt,
            "n_start": self.n_start,
            "theta0": [1.0],
            "theta_bounds": [1e-6, 20.0],
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
        y = np.asarray(y, float)
        n_fit = max(self.n_high, self.n_fit or 0)
        self.training_rows_ = rows = training_subset(len(X_high), n_fit, self.random_state)
        # the hyperparameters from a seeded part of the same rows (all of them without n_fit)
        self.hyper_rows_ = rows[training_subset(len(rows), self.n_high, self.random_state + 7)]
        X_low = input_matrix(self, X_low)  # the DoE's columns taken by name, as the parts'
        self.standardizer_ = DoEStandardizer().fit(X_low)  # the DoE's statistics, as the gate's
        low = {"X_low": X_low, "y_low": np.asarray(y_low, float)}
        MFK, FixedMFK = _mfk_class()
        searched = self._train(
            MFK(**self._options()), **low, X_high=X_high[self.hyper_rows_], y_high=y[self.hyper_rows_]
        )
        self.hyperparameters_ = [
            np.append(searched.optimal_theta[level], searched.optimal_noise_all[level]).tolist() for level in range(2)
        ]
        self.data_ = {**low, "X_high": X_high[rows], "y_high": y[rows]}
        self.mfk_ = searched if len(rows) == len(self.hyper_rows_) else self._refit()
        return self

    def _refit(self):
        _, FixedMFK = _mfk_class()
        return self._train(FixedMFK(self.hyperparameters_, **self._options()), **self.data_)

    def out_of_fold(self, n_folds: int, seed: int) -> np.ndarray:
        """Per high-fidelity row (in ``training_rows_`` order, which is time order): co-kriging, its
        hyperparameters fixed, refitted without that row's period (``n_folds`` folds of consecutive rows; the
        simulations kept; ``seed`` unused)."""
        check_is_fitted(self, "mfk_")
        _, FixedMFK = _mfk_class()
        X, y = self.data_["X_high"], self.data_["y_high"]
        out = np.empty(len(y))
        for train, test in period_folds(len(y), n_folds):
            model = FixedMFK(self.hyperparameters_, **self._options())
            self._train(model, self.data_["X_low"], self.data_["y_low"], X[train], y[train])
            out[test] = batched(model.predict_values, self.standardizer_.transform(X[test]))
        return out

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "mfk_")
        X = self.standardizer_.transform(input_matrix(self, X))
        return batched(self.mfk_.predict_values, X)

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
        model.mfk_ = model._refit()
        return model
