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


def test_the_cached_matern_is_scikit_learns_bit_for_bit():
    from sklearn.gaussian_process.kernels import Matern

    from hybridtwin.paper.surrogate import CachedMatern

    rng = np.random.default_rng(4)
    first, second = rng.normal(size=(60, 5)), rng.normal(size=(40, 5))
    # two length scales on the same rows (the cached differences), then other rows (differences anew)
    for X, scales in ((first, np.full(5, 3.0)), (first, rng.uniform(0.1, 9, 5)), (second, rng.uniform(0.1, 9, 5))):
        ours, theirs = (
            CachedMatern(scales, nu=2.5)(X, eval_gradient=True),
            Matern(scales, nu=2.5)(X, eval_gradient=True),
        )
        for a, b in zip(ours, theirs):
            np.testing.assert_array_equal(a, b)
    isotropic = CachedMatern(2.0, nu=2.5)(first, eval_gradient=True)  # scikit-learn's own path
    np.testing.assert_array_equal(isotropic[1], Matern(2.0, nu=2.5)(first, eval_gradient=True)[1])
    assert repr(CachedMatern(np.full(2, 3.0), nu=2.5)) == repr(Matern(np.full(2, 3.0), nu=2.5))
    CachedMatern.forget()
    assert CachedMatern._differences == (None, None)


def test_the_surrogates_search_finds_what_scikit_learns_kernel_finds(doe30):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

    from hybridtwin.paper.surrogate import CachedMatern

    X, y = doe30
    ours = GPRSurrogate(n_restarts=1).fit(X, y)
    kernel = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(np.full(3, 3.0), (1e-2, 1e4), nu=2.5) + WhiteKernel(
        1e-2, (1e-6, 1.0)
    )
    plain = GaussianProcessRegressor(kernel, normalize_y=True, n_restarts_optimizer=1, random_state=0)
    plain.fit(ours.standardizer_.transform(X), np.asarray(y, float))
    np.testing.assert_array_equal(ours.gpr_.kernel_.theta, plain.kernel_.theta)
    assert repr(ours.gpr_.kernel_) == repr(plain.kernel_)
    assert CachedMatern._differences == (None, None)  # a fit lets go of its rows' differences
