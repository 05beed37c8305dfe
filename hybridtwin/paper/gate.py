"""DoE-only standardization and the kNN support gate (the validated domain Omega)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.neighbors import NearestNeighbors
from sklearn.utils.validation import check_is_fitted

from hybridtwin.crossval import rows_of

DISTANCE_ROWS = 500_000  # rows whose distances to the DoE are found at once


def nearest_index(reference, k: int) -> NearestNeighbors:
    """A k-nearest-neighbour index of ``reference`` (standardized inputs) by brute force: on a dozen inputs
    scikit-learn's default (a k-d tree) is five times slower (100,000 rows against 2,000 logged parts: 1.44 s
    against 0.29 s; 1,000,000 rows against 44 DoE runs: 0.79 s against 0.16 s). The distances agree with the
    exact ones to 1e-14, and to 3e-7 for a row on or within a hair of a reference row (its distance from a difference of
    squares): far below any threshold's resolution."""
    return NearestNeighbors(n_neighbors=k, algorithm="brute").fit(reference)


class InputColumnsError(ValueError):
    """A frame given to a fitted model lacks input columns the model was fitted on."""


def remember_inputs(estimator, X) -> None:
    """Record the input column names when fitted on a table (scikit-learn's ``feature_names_in_``)."""
    if hasattr(X, "columns"):
        estimator.feature_names_in_ = np.asarray([str(name) for name in X.columns], dtype=object)


def input_names(estimator) -> list[str] | None:
    names = getattr(estimator, "feature_names_in_", None)
    return None if names is None else [str(name) for name in names]


def input_matrix(estimator, X) -> np.ndarray:
    """The inputs as a float matrix, columns taken by name when both the model and ``X`` have names.

    A table with the columns in another order gives the same answer; a table
    without a column the model was fitted on is an error, never a silent shift.
    """
    names = input_names(estimator)
    if names is not None and hasattr(X, "columns"):
        missing = [name for name in names if name not in X.columns]
        if missing:
            raise InputColumnsError(
                f"no input column {', '.join(map(repr, missing))}; the model was fitted on {', '.join(names)}"
            )
        X = X[names]
    X = np.asarray(X, float)
    if X.ndim != 2 or X.shape[1] != estimator.n_features_in_:
        raise InputColumnsError(
            f"{X.shape[-1]} input columns given, the model was fitted on {estimator.n_features_in_}"
        )
    return X


class DoEStandardizer(TransformerMixin, BaseEstimator):
    """z = (x - mean) / std with the statistics of the data it is fitted on (the DoE).

    Uses the sample standard deviation (ddof=1), as the paper's sigma^DoE.
    """

    def fit(self, X, y=None):
        remember_inputs(self, X)
        X = np.asarray(X, float)
        self.mean_ = X.mean(axis=0)
        self.scale_ = X.std(axis=0, ddof=1) if len(X) > 1 else np.ones(X.shape[1])
        if np.any(~(self.scale_ > 0)):
            raise ValueError(f"constant input column(s) at position(s) {np.flatnonzero(~(self.scale_ > 0)).tolist()}")
        self.n_features_in_ = X.shape[1]
        return self

    def transform(self, X):
        check_is_fitted(self, "mean_")
        return (input_matrix(self, X) - self.mean_) / self.scale_

    def to_dict(self) -> dict:
        return {"inputs": input_names(self), "mean": self.mean_.tolist(), "std": self.scale_.tolist()}

    def table(self) -> pd.DataFrame:
        """tables/doe_standardization.csv: each input's DoE mean and standard deviation."""
        check_is_fitted(self, "mean_")
        return pd.DataFrame({"column": input_names(self), "doe_mean": self.mean_, "doe_std": self.scale_})

    @classmethod
    def from_dict(cls, data: dict) -> "DoEStandardizer":
        standardizer = cls()
        standardizer.mean_ = np.asarray(data["mean"], float)
        standardizer.scale_ = np.asarray(data["std"], float)
        standardizer.n_features_in_ = len(standardizer.mean_)
        restore_inputs(standardizer, data)
        return standardizer


class KNNSupportGate(BaseEstimator):
    """In-support test: mean distance to the k nearest DoE points in DoE-standardized space.

    The threshold is the ``percentile`` of the DoE's own leave-one-out kNN
    distances, so a production part counts as supported when it is no further
    from the DoE cloud than most DoE points are from each other.
    ``predict`` returns True for in-support rows.
    """

    def __init__(self, k: int = 5, percentile: float = 95.0, standardizer: DoEStandardizer | None = None):
        self.k = k
        self.percentile = percentile
        self.standardizer = standardizer

    def fit(self, X, y=None):
        """Fit on the DoE inputs; a given, already fitted ``standardizer`` is used as it is."""
        if len(X) <= self.k:
            raise ValueError(f"the kNN gate needs more than k={self.k} DoE rows, got {len(X)}")
        self.standardizer_ = self.standardizer if self.standardizer is not None else DoEStandardizer().fit(X)
        self.reference_ = self.standardizer_.transform(X)
        remember_inputs(self, X)
        self._index = nearest_index(self.reference_, self.k)
        # k+1 neighbours of each DoE point: the first is the point itself (leave-one-out)
        distances, _ = nearest_index(self.reference_, self.k + 1).kneighbors(self.reference_)
        self.doe_distances_ = distances[:, 1:].mean(axis=1)
        self.threshold_ = float(np.percentile(self.doe_distances_, self.percentile))
        self.n_features_in_ = self.reference_.shape[1]
        return self

    def distance(self, X) -> np.ndarray:
        """Each row's mean distance to its k nearest DoE points, DISTANCE_ROWS rows at a time (standardized inputs,
        neighbours' distances and indices of ten million rows held at once took 2.5 GB)."""
        check_is_fitted(self, "threshold_")
        means = [
            self._index.kneighbors(self.standardizer_.transform(rows_of(X, slice(s, s + DISTANCE_ROWS))))[0].mean(1)
            for s in range(0, len(X), DISTANCE_ROWS)
        ]
        return np.concatenate(means) if means else np.empty(0)

    def predict(self, X) -> np.ndarray:
        return self.within(self.distance(X))

    def within(self, distance) -> np.ndarray:
        """The gate's rule: in support where the kNN distance is at most the threshold."""
        return np.asarray(distance) <= self.threshold_

    def support_table(self, X) -> pd.DataFrame:
        """knn_distance and in_support per row (the support tables of production and matched cases)."""
        distance = self.distance(X)
        return pd.DataFrame({"knn_distance": distance, "in_support": self.within(distance)})

    def to_dict(self) -> dict:
        return {
            "inputs": input_names(self),
            "k": self.k,
            "percentile": self.percentile,
            "threshold": self.threshold_,
            "standardizer": self.standardizer_.to_dict(),
            "reference": self.reference_.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> "KNNSupportGate":
        gate = cls(k=int(data["k"]), percentile=float(data["percentile"]))
        gate.standardizer_ = DoEStandardizer.from_dict(data["standardizer"])
        gate.reference_ = np.asarray(data["reference"], float)
        gate._index = nearest_index(gate.reference_, gate.k)
        gate.threshold_ = float(data["threshold"])
        gate.n_features_in_ = gate.reference_.shape[1]
        restore_inputs(gate, data)
        return gate


def restore_inputs(estimator, data: dict) -> None:
    names = data.get("inputs")
    if names:
        if len(names) != estimator.n_features_in_:
            raise ValueError(f"model file lists {len(names)} inputs for {estimator.n_features_in_} columns")
        estimator.feature_names_in_ = np.asarray(names, dtype=object)
