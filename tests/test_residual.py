"""hybridtwin.paper.residual: approximate residuals, training rows, the row cap and the stored model."""

import json

import numpy as np
import pandas as pd
import pytest

from hybridtwin.paper import residual

from .test_crossval import FITTED, Recorder
from .test_tuning import SMALL_SPACE


def test_a_row_capped_model_fits_on_a_seeded_sample_and_predicts_every_row():
    FITTED.clear()
    n = 40
    X = np.column_stack([np.arange(n), np.linspace(0, 1, n)])
    y = np.arange(n, dtype=float)
    capped = residual.RowCapped(Recorder(), max_rows=10, seed=4).fit(X, y)
    assert capped.n_fitted_ == 10 and len(capped.estimator_.seen_) == 10
    assert capped.estimator_.seen_ == set(np.sort(np.random.default_rng(4).choice(n, 10, replace=False)).tolist())
    assert capped.estimator_.mean_ == pytest.approx(np.mean(sorted(capped.estimator_.seen_)))
    assert len(capped.predict(X)) == n and capped.estimator_.predicted_ == set(range(n))
    # the same seed, the same sample; fewer rows than the cap: every row, as the model alone
    assert residual.RowCapped(Recorder(), 10, 4).fit(X, y).estimator_.seen_ == capped.estimator_.seen_
    assert residual.RowCapped(Recorder(), 10, 5).fit(X, y).estimator_.seen_ != capped.estimator_.seen_
    assert residual.RowCapped(Recorder(), n, 4).fit(X, y).estimator_.seen_ == set(range(n))
    # a frame is sampled by position
    frame = pd.DataFrame(X, index=np.arange(n) + 100)
    assert residual.RowCapped(Recorder(), 10, 4).fit(frame, y).estimator_.seen_ == capped.estimator_.seen_


def test_training_rows():
    inside = [True, False, True, True, False]
    np.testing.assert_array_equal(residual.training_rows(inside, "filtered"), [0, 2, 3])
    np.testing.assert_array_equal(residual.training_rows(inside, "unfiltered"), [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(residual.training_rows(np.array([1, 0, 1]), "filtered"), [0, 2])
    with pytest.raises(ValueError):
        residual.training_rows(inside, "all")


def test_model_save_load_round_trip(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    params = {name: spec["low"] for name, spec in SMALL_SPACE.items()}
    model = residual.make_model(params, seed=0).fit(X, y)
    path = tmp_path / "model.json"
    residual.save_model(model, path)
    # a row-capped model saves the XGBoost model it fitted
    capped = residual.make_model(params, seed=0, max_train_rows=len(y) // 2).fit(X, y)
    residual.save_model(capped, tmp_path / "capped.json")
    np.testing.assert_array_equal(residual.load_model(tmp_path / "capped.json").predict(X), capped.predict(X))
    assert not np.array_equal(capped.predict(X), model.predict(X))
    json.loads(path.read_text())  # plain JSON text, not a pickle or UBJSON
    loaded = residual.load_model(path)
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    assert not list(tmp_path.glob(".model.json.*"))  # no temporary file left behind
