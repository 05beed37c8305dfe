"""The GP discrepancy peer (Kennedy-O'Hagan style): the surrogate plus a Gaussian process of the approximate
residual (Matern 5/2, one length scale per input, white noise).

Hyperparameters by marginal likelihood on ``n_hyper`` of its ``n_fit`` rows, then the GP refitted with them
fixed on all ``n_fit`` (a GP cannot take every in-support part exactly; both subsets are seeded). The likelihood
search starts from a noise as large as the residual's spread, not from the simulator's small scatter: from there it
stopped in poorer optima, about twice the plain scikit-learn use's error in support on the families' shim-step,
coil-property and time-drift plants. It stores
its training rows and hyperparameters as JSON and is rebuilt from them exactly (no optimizer on load).
"""

from __future__ import annotations

from functools import partial

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from hybridtwin.crossval import SEARCH_FOLDS, lowest_on_periods, out_of_period, periods, training_subset
from hybridtwin.models.batches import batched
from hybridtwin.paper.gate import input_matrix, input_names, remember_inputs, restore_inputs
from hybridtwin.paper.surrogate import GPRSurrogate

DRAW_SEEDS = 100  # the k-th extra draw of hyperparameter rows is seeded random_state + DRAW_SEEDS + k


class GPDiscrepancy(RegressorMixin, BaseEstimator):
    """A GP of the residual (measured - surrogate); ``predict`` gives the residual correction.

    ``surrogate_class``: the GP it fits, with its kernel (a subclass with another ``_kernel`` is another peer).
    """

    surrogate_class = GPRSurrogate

    def __init__(
        self, n_hyper: int = 300, n_fit: int = 2000, n_restarts: int = 0, n_draws: int = 3, random_state: int = 0
    ):
        self.n_hyper = n_hyper
        self.n_fit = n_fit
        self.n_restarts = n_restarts
        self.n_draws = n_draws
        self.random_state = random_state

    def fit(self, X, y, X_low=None, y_low=None):
        """``X_low``, ``y_low`` (the simulations) are not used: the surrogate already carries them."""
        remember_inputs(self, X)
        matrix = np.asarray(X, float)
        y = np.asarray(y, float)
        self.n_features_in_ = matrix.shape[1]
        self.training_rows_ = rows = training_subset(len(y), self.n_fit, self.random_state + 1)
        # the hyperparameters from seeded parts of the same rows: every row the GP learnt from is a training row,
        # and so has an out-of-fold prediction; several draws where the rows allow (all rows: one)
        n_draws = self.n_draws if len(rows) > self.n_hyper else 1
        seeds = [self.random_state] + [self.random_state + DRAW_SEEDS + k for k in range(1, n_draws)]
        draws = [rows[training_subset(len(rows), self.n_hyper, seed)] for seed in seeds]
        found = [self._searched(matrix, y, draw) for draw in draws]
        # one draw's optimum varies with the draw: the draws' GPs are judged on periods of the rows they did not see
        held_out = [self._period_predictions(gp.to_dict(), SEARCH_FOLDS) for gp in found] if n_draws > 1 else []
        self.draw_errors_, best = lowest_on_periods(held_out, y[rows])
        self.gp_, self.hyper_rows_ = found[best], draws[best]
        return self

    def _searched(self, matrix: np.ndarray, y: np.ndarray, draw: np.ndarray) -> GPRSurrogate:
        """The GP on every training row with the hyperparameters its likelihood search finds on ``draw``."""
        # the residual is mostly noise: the likelihood search starts there (normalized units: all of it)
        hyper = self.surrogate_class(n_restarts=self.n_restarts, random_state=self.random_state, noise_start=1.0)
        hyper.fit(matrix[draw], y[draw])
        rows = self.training_rows_
        return self._with_rows(hyper.to_dict(), hyper.standardizer_.transform(matrix[rows]), y[rows])

    def out_of_period(self, X, period, training_period) -> np.ndarray:
        """Each row of ``X`` predicted by the GP refitted, its hyperparameters held, without the training rows of
        the row's period: ``period`` per row of ``X``, ``training_period`` per training row (``training_rows_``)."""
        check_is_fitted(self, "gp_")
        Z = self.gp_.standardizer_.transform(input_matrix(self, X))
        return out_of_period(partial(self._without, self.gp_.to_dict()), Z, period, training_period)

    def _period_predictions(self, state: dict, n_folds: int) -> np.ndarray:
        """Each training row of the GP ``state`` predicted without its period (``n_folds`` periods of consecutive
        training rows)."""
        Z = np.asarray(state["X_train"], float)
        period = periods(len(Z), n_folds)
        return out_of_period(partial(self._without, state), Z, period, period)

    def _without(self, state: dict, keep: np.ndarray):
        """The GP of ``state``, its hyperparameters held, on its training rows where ``keep``, as a function of
        standardized rows."""
        Z, y = np.asarray(state["X_train"], float), np.asarray(state["y_train"], float)
        return partial(batched, self._with_rows(state, Z[keep], y[keep]).gpr_.predict)

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "gp_")
        return batched(self.gp_.predict, input_matrix(self, X))

    def _with_rows(self, state: dict, Z: np.ndarray, y: np.ndarray) -> GPRSurrogate:
        """The GP of ``state`` (a surrogate's dict), its hyperparameters fixed, on standardized rows ``Z``
        (``from_dict`` refits without optimizing)."""
        rows = {"inputs": None, "X_train": Z.tolist(), "y_train": np.asarray(y).tolist()}
        return self.surrogate_class.from_dict({**state, **rows})

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
        model = cls(**{"n_draws": 1, **data["params"]})  # files written before the draws searched one
        model.gp_ = cls.surrogate_class.from_dict(data["gp"])
        model.n_features_in_ = model.gp_.n_features_in_
        model.training_rows_ = np.asarray(data["training_rows"], int)
        restore_inputs(model, data)
        return model
