"""GPR surrogate of the simulator: Matern 5/2 (ARD), constant mean, learned noise.

The model file is JSON: the fitted kernel hyperparameters and the training
data. Loading rebuilds the same GaussianProcessRegressor with the optimizer
switched off (:class:`FixedKernelGPR`), which reproduces the fitted posterior
exactly; nothing is pickled.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel
from sklearn.utils.validation import check_is_fitted

from hybridtwin.crossval import rows_of
from hybridtwin.paper.gate import DoEStandardizer, input_names, remember_inputs, restore_inputs

# rows per prediction chunk: its kernel temporaries stay in cache (100,000 rows 4 times faster than in one chunk)
PREDICT_ROWS = 5_000


class FixedKernelGPR(GaussianProcessRegressor):
    """A GaussianProcessRegressor whose hyperparameters are given (``optimizer=None``): fitting factorizes the
    training kernel once, for the posterior. scikit-learn's fit computes the log-marginal likelihood too, only to
    store it (``log_marginal_likelihood_value_``, NaN here): a second factorization, half of every load of a
    2,000-part GP discrepancy and of each of its refits on other periods."""

    def __init__(self, kernel=None, *, normalize_y: bool = True):
        super().__init__(kernel, normalize_y=normalize_y, optimizer=None)

    def log_marginal_likelihood(self, theta=None, eval_gradient=False, clone_kernel=True):
        if getattr(self, "_fitting", False):
            return np.nan
        if theta is None and hasattr(self, "kernel_"):  # not stored: computed when asked
            theta = self.kernel_.theta
        return super().log_marginal_likelihood(theta, eval_gradient, clone_kernel)

    def fit(self, X, y):
        self._fitting = True
        try:
            return super().fit(X, y)
        finally:
            self._fitting = False


class GPRSurrogate(RegressorMixin, BaseEstimator):
    """Inputs are standardized with the statistics of the training (DoE) rows."""

    def __init__(
        self,
        nu: float = 2.5,
        n_restarts: int = 3,
        random_state: int = 0,
        length_scale_bounds: tuple[float, float] = (1e-2, 1e4),
        noise_bounds: tuple[float, float] = (1e-6, 1.0),
        noise_start: float = 1e-2,  # the noise where the likelihood search starts (normalized units)
    ):
        self.nu = nu
        self.n_restarts = n_restarts
        self.random_state = random_state
        self.length_scale_bounds = length_scale_bounds
        self.noise_bounds = noise_bounds
        self.noise_start = noise_start

    def _kernel(self, n_features: int):
        # normalize_y scales the target to unit variance, so these bounds are in those units
        return ConstantKernel(1.0, (1e-3, 1e3)) * Matern(
            length_scale=np.full(n_features, 3.0), length_scale_bounds=self.length_scale_bounds, nu=self.nu
        ) + WhiteKernel(self.noise_start, self.noise_bounds)

    def fit(self, X, y):
        remember_inputs(self, X)
        self.standardizer_ = DoEStandardizer().fit(X)
        self.n_features_in_ = self.standardizer_.n_features_in_
        self.gpr_ = GaussianProcessRegressor(
            self._kernel(self.n_features_in_),
            normalize_y=True,
            n_restarts_optimizer=self.n_restarts,
            random_state=self.random_state,
        )
        self.gpr_.fit(self.standardizer_.transform(X), np.asarray(y, float))
        return self

    def predict(self, X, return_std: bool = False):
        """In chunks of PREDICT_ROWS rows, each standardized on its own: the kernel's (rows x DoE runs) temporaries
        and the standardized inputs stay small on a large log (ten million rows standardized whole took 2 GB)."""
        check_is_fitted(self, "gpr_")
        if len(X) <= PREDICT_ROWS:
            return self.gpr_.predict(self.standardizer_.transform(X), return_std=return_std)
        parts = [
            self.gpr_.predict(
                self.standardizer_.transform(rows_of(X, slice(s, s + PREDICT_ROWS))), return_std=return_std
            )
            for s in range(0, len(X), PREDICT_ROWS)
        ]
        if return_std:
            return np.concatenate([mean for mean, _ in parts]), np.concatenate([std for _, std in parts])
        return np.concatenate(parts)

    def input_correlation(self, X, length_factor: float = 1.0) -> np.ndarray:
        """The correlation of the simulator's response between the rows of ``X`` as the fitted kernel has it (its
        Matern part, the amplitude and noise left out), with every length scale times ``length_factor``."""
        check_is_fitted(self, "gpr_")
        matern = self.gpr_.kernel_.k1.k2
        return matern.clone_with_theta(matern.theta + np.log(length_factor))(self.standardizer_.transform(X))

    @property
    def noise_std_(self) -> float:
        """Learned noise (FE numerical scatter) in the target's unit."""
        return float(np.sqrt(self.gpr_.kernel_.k2.noise_level) * self.gpr_._y_train_std)

    def to_dict(self) -> dict:
        check_is_fitted(self, "gpr_")
        return {
            "format": "hybridtwin.GPRSurrogate/1",
            "params": self.get_params(),
            "inputs": input_names(self),
            "kernel": repr(self.gpr_.kernel_),
            "theta": self.gpr_.kernel_.theta.tolist(),
            "standardizer": self.standardizer_.to_dict(),
            "X_train": self.gpr_.X_train_.tolist(),
            "y_train": (self.gpr_.y_train_ * self.gpr_._y_train_std + self.gpr_._y_train_mean).tolist(),
            "noise_std": self.noise_std_,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "GPRSurrogate":
        params = dict(data["params"])
        params["length_scale_bounds"] = tuple(params["length_scale_bounds"])
        params["noise_bounds"] = tuple(params["noise_bounds"])
        model = cls(**params)
        X_train = np.asarray(data["X_train"], float)
        kernel = model._kernel(X_train.shape[1]).clone_with_theta(np.asarray(data["theta"], float))
        model.standardizer_ = DoEStandardizer.from_dict(data["standardizer"])
        model.gpr_ = FixedKernelGPR(kernel, normalize_y=True)
        model.gpr_.fit(X_train, np.asarray(data["y_train"], float))
        model.n_features_in_ = X_train.shape[1]
        restore_inputs(model, data)
        return model


def surrogate_latent_std(predictive_std, noise_std: float) -> float:
    """Mean predictive std of the surrogate's mean (the learned noise taken out): its own uncertainty."""
    variance = np.asarray(predictive_std, float) ** 2 - float(noise_std) ** 2
    return float(np.mean(np.sqrt(np.clip(variance, 0.0, None))))
