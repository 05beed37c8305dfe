"""The plain library uses beside which the benchmarks score the peers and the recommendation (issue 33).

Fitted on the same information as the workflow's peers (the DoE and the in-support parts) and scored alike: out of
period on every in-support part (five periods of consecutive parts, each predicted by the model refitted without its
period's training parts, the hyperparameters held), the final model elsewhere.

- a plain SMT MFK: the documented use (``MFK(theta0=d * [1.0])``, noise estimated: the parts are noisy), inputs
  scaled to the DoE's box, 600 in-support parts as high fidelity;
- a plain GP discrepancy: the workflow's surrogate plus a scikit-learn GP of the residual (Matern 5/2, a length scale
  per input, white noise, the target normalized), hyperparameters on 300 in-support parts, refitted on 2,000.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hybridtwin.crossval import in_support_out_of_period, out_of_period, training_subset
from hybridtwin.models import registry

PLAIN_MFK, PLAIN_GP = "plain_mfk", "plain_gp_discrepancy"


class PlainMFK:
    """SMT's MFK as its documentation shows it: ``theta0=d * [1.0]`` and the defaults (squared exponential, TNC,
    10 starts), noise estimated (the parts are noisy); inputs scaled to the DoE's box."""

    def __init__(self, n_high: int = 600, seed: int = 0):
        self.n_high, self.seed = n_high, seed

    def _scale(self, X):
        return (np.asarray(X, float) - self.low_) / self.width_

    def _model(self, theta=None):
        from smt.applications import MFK

        from hybridtwin.models.cokriging import _mfk_class

        options = {"theta0": self.d_ * [1.0], "eval_noise": True, "print_global": False}
        return MFK(**options) if theta is None else _mfk_class()[1](theta, **options)

    def _train(self, model, X, y):
        model.set_training_values(self._scale(self.doe_x_), self.doe_y_[:, None], name=0)
        model.set_training_values(self._scale(X), np.asarray(y, float)[:, None])
        model.train()
        return model

    def fit(self, X, y, doe_x, doe_y):
        self.doe_x_, self.doe_y_ = np.asarray(doe_x, float), np.asarray(doe_y, float)
        self.low_, self.width_ = self.doe_x_.min(axis=0), np.ptp(self.doe_x_, axis=0)
        self.d_ = self.doe_x_.shape[1]
        self.rows_ = training_subset(len(y), self.n_high, self.seed)
        self.X_, self.y_ = np.asarray(X, float)[self.rows_], np.asarray(y, float)[self.rows_]
        self.model_ = self._train(self._model(), self.X_, self.y_)
        self.theta_ = [np.append(self.model_.optimal_theta[k], self.model_.optimal_noise_all[k]) for k in range(2)]
        return self

    def predict(self, X):
        return self.model_.predict_values(self._scale(X)).ravel()

    def out_of_period(self, X, period, training_period) -> np.ndarray:
        return out_of_period(self._without, np.asarray(X, float), period, training_period)

    def _without(self, keep):
        model = self._train(self._model(self.theta_), self.X_[keep], self.y_[keep])
        return lambda X: model.predict_values(self._scale(X)).ravel()


class PlainGPDiscrepancy:
    """scikit-learn's GP of the residual (measured - surrogate): Matern 5/2 with a length scale per input plus white
    noise, the target normalized; hyperparameters on ``n_hyper`` parts, then refitted on ``n_fit`` with them."""

    def __init__(self, n_hyper: int = 300, n_fit: int = 2000, seed: int = 0):
        self.n_hyper, self.n_fit, self.seed = n_hyper, n_fit, seed

    def fit(self, X, residual, doe_x, doe_y=None):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

        doe_x = np.asarray(doe_x, float)
        self.low_, self.width_ = doe_x.min(axis=0), np.ptp(doe_x, axis=0)
        X, residual = self._scaled(X), np.asarray(residual, float)
        self.rows_ = training_subset(len(residual), self.n_fit, self.seed + 1)
        hyper = self.rows_[training_subset(len(self.rows_), self.n_hyper, self.seed)]
        kernel = ConstantKernel() * Matern(length_scale=np.ones(X.shape[1]), nu=2.5) + WhiteKernel()
        tuned = GaussianProcessRegressor(kernel, normalize_y=True, random_state=self.seed).fit(
            X[hyper], residual[hyper]
        )
        self.kernel_ = tuned.kernel_
        self.X_, self.y_ = X[self.rows_], residual[self.rows_]
        self.gp_ = self._fixed(self.X_, self.y_)
        return self

    def _fixed(self, X, y):
        from sklearn.gaussian_process import GaussianProcessRegressor

        return GaussianProcessRegressor(self.kernel_, normalize_y=True, optimizer=None).fit(X, y)

    def predict(self, X):
        return self.gp_.predict(self._scaled(X))

    def _scaled(self, X):
        return (np.asarray(X, float) - self.low_) / self.width_

    def out_of_period(self, X, period, training_period) -> np.ndarray:
        return out_of_period(self._without, np.asarray(X, float), period, training_period)

    def _without(self, keep):
        gp = self._fixed(self.X_[keep], self.y_[keep])
        return lambda X: gp.predict(self._scaled(X))


def plain_baselines(doe, production, residuals: pd.DataFrame, inputs, target: str, seed: int, n_folds: int = 5):
    """Both plain baselines' honest predictions of every part: out of period on the in-support parts, as the peers
    (``residuals``: the workflow's residual table: measured, pred_surrogate, residual_approx, in_support)."""
    inside = np.flatnonzero(residuals["in_support"].to_numpy(bool))
    X = production[list(inputs)].to_numpy(float)
    surrogate = residuals[registry.SURROGATE.column].to_numpy(float)
    doe_x, doe_y = doe[list(inputs)], doe[target]
    out = {}
    for name, model, learnt, offset in (
        (PLAIN_MFK, PlainMFK(seed=seed), residuals["measured"].to_numpy(float), 0.0),
        (PLAIN_GP, PlainGPDiscrepancy(seed=seed), residuals["residual_approx"].to_numpy(float), surrogate),
    ):
        model.fit(X[inside], learnt[inside], doe_x, doe_y)
        offset = np.broadcast_to(offset, len(X))
        honest = model.predict(X) + offset
        honest[inside] = in_support_out_of_period(model, X[inside], model.rows_, n_folds) + offset[inside]
        out[name] = honest
    return out
