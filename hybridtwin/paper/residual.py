"""The XGBoost residual model r(x) of the approximate residuals r = measured - y_FEM_hat(x): how it is made,
fitted on a seeded sample of a long log, stored and loaded (its hyperparameters: :mod:`.tuning`)."""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd
import xgboost as xgb
from sklearn.base import BaseEstimator, RegressorMixin, clone

from hybridtwin.crossval import rows_of, training_subset
from hybridtwin.io.files import table_of
from hybridtwin.models.registry import SURROGATE

log = logging.getLogger(__name__)


def make_model(params: dict, seed: int, n_jobs: int = 1, max_train_rows: int | None = None):
    """XGBoost regressor with the hist method, which is deterministic for a fixed seed; with
    ``max_train_rows``, fitted on a seeded sample of at most that many of the rows it is given."""
    model = xgb.XGBRegressor(**params, tree_method="hist", random_state=seed, n_jobs=n_jobs)
    return model if max_train_rows is None else RowCapped(model, max_train_rows, seed)


def training_matrix(X, y, n_jobs: int = 1) -> xgb.QuantileDMatrix:
    """The matrix ``XGBRegressor.fit`` trains a hist model on (its quantile sketch of ``X``), built once for many
    fits on the same rows."""
    return xgb.QuantileDMatrix(np.asarray(X, float), label=np.asarray(y, float), nthread=n_jobs, missing=np.nan)


def fitted_booster(model: xgb.XGBRegressor, matrix: xgb.QuantileDMatrix) -> xgb.Booster:
    """The booster ``model.fit`` would train on the rows of ``matrix``: its parameters and rounds, XGBoost's own
    training."""
    return xgb.train(model.get_xgb_params(), matrix, model.get_num_boosting_rounds())


class RowCapped(RegressorMixin, BaseEstimator):
    """An estimator fitted on a seeded sample of at most ``max_rows`` of the rows it is given (all of them
    when there are fewer): on a plant log of millions of parts its fit time stays bounded. Predicts every
    row."""

    def __init__(self, estimator=None, max_rows: int = 500_000, seed: int = 0):
        self.estimator = estimator
        self.max_rows = max_rows
        self.seed = seed

    def fit_rows(self, n_rows: int) -> np.ndarray:
        """The positions of the rows a fit on ``n_rows`` rows uses (a caller may hand over only these: the same
        fit, without a copy of every row)."""
        return training_subset(n_rows, self.max_rows, self.seed)

    def fit(self, X, y):
        rows = self.fit_rows(len(y))
        self.estimator_ = clone(self.estimator).fit(rows_of(X, rows), np.asarray(y, float)[rows])
        self.n_fitted_ = len(rows)
        return self

    def predict(self, X):
        return self.estimator_.predict(X)


def fitted_estimator(model):
    """The fitted model itself (XGBoost's), inside a :class:`RowCapped` or not."""
    return getattr(model, "estimator_", model)


def save_model(model, path, inputs=None) -> None:
    """XGBoost's own JSON format: loads with xgboost alone, no code runs.

    ``inputs`` names the columns the model was fitted on, in order; the file
    carries them, so a table given later is matched by name.
    """
    from hybridtwin.io.files import atomic_path

    model = fitted_estimator(model)
    if inputs is not None:
        model.get_booster().feature_names = [str(name) for name in inputs]
    with atomic_path(path) as temporary:
        model.save_model(temporary)


def load_model(path) -> xgb.XGBRegressor:
    model = xgb.XGBRegressor()
    model.load_model(path)
    return model


def approximate_residuals(surrogate, production: pd.DataFrame, inputs, target: str) -> pd.DataFrame:
    """The paper's approximate residuals r = y_measured - y_FEM_hat(x) of production rows, with the surrogate's
    prediction and its predictive std (the simulator was not run at these inputs: the surrogate stands in)."""
    mean, std = surrogate.predict(production[list(inputs)], return_std=True)
    measured = production[target].to_numpy(float)
    return table_of(
        {
            "measured": measured,
            SURROGATE.column: mean,
            f"{SURROGATE.column}_std": std,
            "residual_approx": measured - mean,
        }
    )


def evaluation_seed(seed: int) -> int:
    """Seed of the CV split that scores the tuned model: not the split the tuning chose on."""
    return seed + 1


# the residual models' training sets: the in-support parts (the paper's) and every part (Table 5's comparison)
TRAINING_SETS = ("filtered", "unfiltered")


def training_rows(in_support, training: str) -> np.ndarray:
    """Row positions a residual model trains on: in-support rows ('filtered') or all rows ('unfiltered')."""
    inside = np.asarray(in_support, bool)
    if training == "filtered":
        return np.flatnonzero(inside)
    if training == "unfiltered":
        return np.arange(len(inside))
    raise ValueError(f"unknown training set {training!r}")
