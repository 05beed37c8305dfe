"""hybridtwin.paper.surrogate: the GPR surrogate on a smooth function, its standardization and JSON form."""

import json

import numpy as np
import pandas as pd
import pytest

from hybridtwin.crossval import (
    cross_validate,
)
from hybridtwin.metrics import r2
from hybridtwin.paper.surrogate import GPRSurrogate


def smooth(X):
    return np.sin(3 * X[:, 0]) + X[:, 1] ** 2 + 0.5 * X[:, 2]


@pytest.fixture(scope="module")
def doe30():
    from scipy.stats import qmc

    X = qmc.scale(qmc.LatinHypercube(d=3, seed=np.random.default_rng(1)).random(30), [0, 0, 0], [1, 2, 10])
    return X, smooth(X)


def test_gpr_fits_smooth_function(doe30):
    X, y = doe30
    per_fold, oof = cross_validate(GPRSurrogate(n_restarts=1), X, y, n_folds=5, seed=0)
    assert r2(y, oof) > 0.9
    assert per_fold["r2"].mean() > 0.9


def test_gpr_standardizes_with_training_rows_only(doe30):
    X, y = doe30
    train = np.arange(20)
    model = GPRSurrogate(n_restarts=0).fit(X[train], y[train])
    np.testing.assert_allclose(model.standardizer_.mean_, X[train].mean(axis=0))
    np.testing.assert_allclose(model.standardizer_.scale_, X[train].std(axis=0, ddof=1))
    assert not np.allclose(model.standardizer_.mean_, X.mean(axis=0))
    np.testing.assert_allclose(model.gpr_.X_train_, (X[train] - X[train].mean(0)) / X[train].std(0, ddof=1))


def test_gpr_predicts_a_large_table_in_chunks_with_the_same_numbers(doe30, monkeypatch):
    from hybridtwin.paper import surrogate

    X, y = doe30
    model = GPRSurrogate(n_restarts=0).fit(X, y)
    query = np.random.default_rng(5).uniform([0, 0, 0], [1, 2, 10], (1000, 3))
    mean, std = model.predict(query, return_std=True)
    monkeypatch.setattr(surrogate, "PREDICT_ROWS", 64)
    chunked_mean, chunked_std = model.predict(query, return_std=True)
    np.testing.assert_allclose(chunked_mean, mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(chunked_std, std, rtol=0, atol=1e-12)
    np.testing.assert_allclose(model.predict(query), mean, rtol=0, atol=1e-12)
    # a table (the workflow's production) is cut into the same chunks, each standardized on its own
    monkeypatch.setattr(surrogate, "PREDICT_ROWS", 5000)
    named = GPRSurrogate(n_restarts=0).fit(pd.DataFrame(X, columns=["a", "b", "c"]), y)
    frame = pd.DataFrame(query, columns=["a", "b", "c"])
    whole = named.predict(frame, return_std=True)
    monkeypatch.setattr(surrogate, "PREDICT_ROWS", 64)
    np.testing.assert_allclose(named.predict(frame, return_std=True), whole, rtol=0, atol=1e-12)


def test_gpr_json_round_trip_and_determinism(doe30):
    X, y = doe30
    model = GPRSurrogate(n_restarts=1, random_state=4).fit(X, y)
    text = json.dumps(model.to_dict())
    assert "pickle" not in text
    copy = GPRSurrogate.from_dict(json.loads(text))
    query = np.random.default_rng(2).uniform([0, 0, 0], [1, 2, 10], (50, 3))
    mean, std = model.predict(query, return_std=True)
    mean_copy, std_copy = copy.predict(query, return_std=True)
    np.testing.assert_allclose(mean_copy, mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(std_copy, std, rtol=0, atol=1e-10)
    assert copy.noise_std_ == pytest.approx(model.noise_std_, rel=1e-10)
    again = GPRSurrogate(n_restarts=1, random_state=4).fit(X, y)
    np.testing.assert_array_equal(again.predict(query), model.predict(query))


def test_a_gp_of_given_hyperparameters_factorizes_its_kernel_once_with_the_same_posterior(doe30):
    from sklearn.gaussian_process import GaussianProcessRegressor

    from hybridtwin.paper.surrogate import FixedKernelGPR

    X, y = doe30
    kernel = GPRSurrogate(n_restarts=0).fit(X, y).gpr_.kernel_
    fixed = FixedKernelGPR(kernel).fit(X, y)
    plain = GaussianProcessRegressor(kernel, normalize_y=True, optimizer=None).fit(X, y)
    query = np.random.default_rng(3).uniform([0, 0, 0], [1, 2, 10], (40, 3))
    for ours, theirs in zip(fixed.predict(query, return_std=True), plain.predict(query, return_std=True)):
        np.testing.assert_array_equal(ours, theirs)
    assert np.isnan(fixed.log_marginal_likelihood_value_)  # not computed in fit: the second factorization
    assert fixed.log_marginal_likelihood() == pytest.approx(plain.log_marginal_likelihood_value_, rel=1e-12)
