"""Unit tests against hand-computed values: metrics, DoE standardization, kNN gate, CV, surrogate, residual."""

import json
import logging
import math
import os
import threading
from pathlib import Path

import numpy as np
import optuna
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, RegressorMixin, clone

from hybridtwin.crossval import (
    cross_validate,
    cv_table,
    fold_ids,
    folds,
    splice_out_of_fold,
    splits_of,
    written_splits,
)
from hybridtwin.metrics import bias, mae, r2, rmse, scores
from hybridtwin.paper import residual, tables, tuning
from hybridtwin.paper.gate import DoEStandardizer, InputColumnsError, KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate

optuna.logging.set_verbosity(optuna.logging.WARNING)


# --------------------------------------------------------------------------- 1. metrics


def test_metrics_by_hand():
    y, yhat = [1, 2, 3, 4], [1.5, 2, 2, 5]
    # errors (reference - prediction) = [-0.5, 0, 1, -1]
    assert rmse(y, yhat) == pytest.approx(0.75)  # sqrt((0.25 + 0 + 1 + 1) / 4)
    assert mae(y, yhat) == pytest.approx(0.625)  # (0.5 + 0 + 1 + 1) / 4
    assert bias(y, yhat) == pytest.approx(-0.125)  # (-0.5 + 0 + 1 - 1) / 4
    assert r2(y, yhat) == pytest.approx(0.55)  # 1 - 2.25 / 5
    assert scores(y, yhat) == pytest.approx({"r2": 0.55, "rmse": 0.75, "mae": 0.625, "bias": -0.125})


def test_bias_sign_is_reference_minus_prediction():
    # under-prediction gives a positive bias
    assert bias([3, 5], [2, 4]) == pytest.approx(1.0)
    assert bias([2, 4], [3, 5]) == pytest.approx(-1.0)


def test_metric_edges():
    assert math.isnan(r2([2, 2, 2], [1, 2, 3]))  # constant reference
    assert r2([1, 2, 3], [1, 2, 3]) == 1.0
    assert r2([1, 2, 3], [2, 2, 2]) == pytest.approx(0.0)  # predicting the mean
    for metric in (rmse, mae, bias, r2):
        assert math.isnan(metric([], []))


# --------------------------------------------------------------------------- 2. DoE standardization

DOE = np.array([[0.0, 1.0], [2.0, 3.0], [4.0, 8.0]])


def test_standardizer_statistics_by_hand():
    std = DoEStandardizer().fit(DOE)
    # column 0: mean 2, deviations -2, 0, 2 -> var 8 / 2 = 4 -> std 2
    # column 1: mean 4, deviations -3, -1, 4 -> var 26 / 2 = 13 -> std sqrt(13)
    np.testing.assert_allclose(std.mean_, [2.0, 4.0])
    np.testing.assert_allclose(std.scale_, [2.0, math.sqrt(13.0)])
    np.testing.assert_allclose(
        std.transform(DOE), [[-1, -3 / math.sqrt(13)], [0, -1 / math.sqrt(13)], [1, 4 / math.sqrt(13)]]
    )
    # the DoE's own standardized columns have mean 0 and sample std 1
    z = std.transform(DOE)
    np.testing.assert_allclose(z.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(z.std(axis=0, ddof=1), 1.0)


def test_standardizer_applies_doe_statistics_to_production():
    std = DoEStandardizer().fit(DOE)
    production = np.array([[10.0, 4.0], [-2.0, 4.0 + 2 * math.sqrt(13)], [2.0, 4.0]])
    np.testing.assert_allclose(std.transform(production), [[4.0, 0.0], [-2.0, 2.0], [0.0, 0.0]])
    # transforming production data does not change the statistics
    np.testing.assert_allclose(std.mean_, [2.0, 4.0])
    np.testing.assert_allclose(std.scale_, [2.0, math.sqrt(13.0)])
    # fit_transform on production would give other statistics: not what transform does
    assert not np.allclose(DoEStandardizer().fit(production).mean_, std.mean_)


def test_standardizer_constant_column_raises():
    with pytest.raises(ValueError, match=r"constant input column\(s\) at position\(s\) \[1\]"):
        DoEStandardizer().fit(np.array([[1.0, 5.0], [2.0, 5.0], [3.0, 5.0]]))


def test_standardizer_of_two_rows_scales_by_their_spread():
    np.testing.assert_allclose(DoEStandardizer().fit(np.array([[0.0, 0.0], [2.0, 4.0]])).scale_, [2**0.5, 8**0.5])


def test_standardizer_of_one_row_centres_without_scaling():
    std = DoEStandardizer().fit(np.array([[1.0, 2.0]]))  # no spread to scale by: unit scale, not NaN
    np.testing.assert_array_equal(std.scale_, [1.0, 1.0])
    np.testing.assert_array_equal(std.transform(np.array([[3.0, 2.0]])), [[2.0, 0.0]])


def test_standardizer_round_trip():
    std = DoEStandardizer().fit(DOE)
    copy = DoEStandardizer.from_dict(json.loads(json.dumps(std.to_dict())))
    np.testing.assert_array_equal(copy.mean_, std.mean_)
    np.testing.assert_array_equal(copy.scale_, std.scale_)
    production = np.array([[1.0, 2.0], [7.0, -3.0]])
    np.testing.assert_array_equal(copy.transform(production), std.transform(production))


# --------------------------------------------------------------------------- 3. kNN support gate

# irregular 1-D DoE: mean 4, deviations -4, -3, -1, 2, 6 -> var 66 / 4 = 16.5
LINE = np.array([0.0, 1.0, 3.0, 6.0, 10.0])[:, None]
LINE_STD = math.sqrt(16.5)


def test_gate_leave_one_out_distances_k1():
    gate = KNNSupportGate(k=1, percentile=75).fit(LINE)
    # nearest *other* DoE point: 0->1 (1), 1->0 (1), 3->1 (2), 6->3 (3), 10->6 (4)
    np.testing.assert_allclose(gate.doe_distances_, np.array([1, 1, 2, 3, 4]) / LINE_STD)
    # 75th percentile of [1, 1, 2, 3, 4] (linear): position 0.75 * 4 = 3 -> 3
    assert gate.threshold_ == pytest.approx(3 / LINE_STD)


def test_gate_leave_one_out_distances_k2():
    gate = KNNSupportGate(k=2, percentile=50).fit(LINE)
    # two nearest others: 0->(1,3), 1->(1,2), 3->(2,3), 6->(3,4), 10->(4,7)
    np.testing.assert_allclose(gate.doe_distances_, np.array([2.0, 1.5, 2.5, 3.5, 5.5]) / LINE_STD)
    assert gate.threshold_ == pytest.approx(2.5 / LINE_STD)  # median


def test_gate_distance_and_predict_k1():
    gate = KNNSupportGate(k=1, percentile=75).fit(LINE)
    query = np.array([[3.0], [8.0], [4.5], [14.0], [20.0], [-5.0]])
    # nearest DoE point: 3 (0), 6 or 10 (2), 3 or 6 (1.5), 10 (4), 10 (10), 0 (5)
    expected = np.array([0.0, 2.0, 1.5, 4.0, 10.0, 5.0]) / LINE_STD
    np.testing.assert_allclose(gate.distance(query), expected, atol=1e-12)
    inside = gate.predict(query)
    assert inside.dtype == bool
    np.testing.assert_array_equal(inside, [True, True, True, False, False, False])


def test_gate_uses_standardized_space_2d():
    # 3 x 3 grid, columns on scales 1 and 10; each column has sample std sqrt(0.75) (times 10)
    grid = np.array([[a, b] for a in (0.0, 1.0, 2.0) for b in (0.0, 10.0, 20.0)])
    gate = KNNSupportGate(k=2, percentile=90).fit(grid)
    h = 1 / math.sqrt(0.75)  # standardized grid spacing, the same in both directions
    # every grid point has at least two neighbours at one spacing (in raw units a corner would give 1.5)
    np.testing.assert_allclose(gate.doe_distances_, h)
    assert gate.threshold_ == pytest.approx(h)
    np.testing.assert_allclose(gate.standardizer_.mean_, [1.0, 10.0])
    np.testing.assert_allclose(gate.standardizer_.scale_, [math.sqrt(0.75), 10 * math.sqrt(0.75)])
    # (0.5, 0): half a spacing from (0, 0) and (1, 0)
    assert gate.distance(np.array([[0.5, 0.0]]))[0] == pytest.approx(0.5 * h)
    # (1, 5): half a spacing from (1, 0) and (1, 10)
    assert gate.distance(np.array([[1.0, 5.0]]))[0] == pytest.approx(0.5 * h)
    # a grid point: distance 0 to itself and h to its nearest neighbour -> h / 2
    assert gate.distance(grid[4:5])[0] == pytest.approx(0.5 * h)
    np.testing.assert_array_equal(
        gate.predict(np.array([[1.0, 10.0], [0.5, 5.0], [6.0, 0.0], [1.0, 80.0]])), [True, True, False, False]
    )


def test_gate_uses_given_standardizer():
    fixed = DoEStandardizer.from_dict({"mean": [0.0], "std": [1.0]})
    gate = KNNSupportGate(k=1, percentile=75, standardizer=fixed).fit(LINE)
    np.testing.assert_allclose(gate.doe_distances_, [1, 1, 2, 3, 4])
    assert gate.threshold_ == pytest.approx(3.0)


def test_gate_round_trip():
    rng = np.random.default_rng(0)
    doe = rng.uniform(0, 1, (30, 3)) * [1, 100, 0.01]
    gate = KNNSupportGate(k=3, percentile=90).fit(doe)
    copy = KNNSupportGate.from_dict(json.loads(json.dumps(gate.to_dict())))
    query = rng.uniform(-0.5, 1.5, (200, 3)) * [1, 100, 0.01]
    np.testing.assert_array_equal(copy.predict(query), gate.predict(query))
    np.testing.assert_allclose(copy.distance(query), gate.distance(query), rtol=0, atol=1e-12)
    assert copy.threshold_ == gate.threshold_
    assert copy.get_params() == {"k": 3, "percentile": 90, "standardizer": None}
    assert 0 < gate.predict(query).sum() < len(query)


def test_gate_support_table_gives_distance_and_verdict_per_row():
    gate = KNNSupportGate(k=1, percentile=75).fit(LINE)
    table = gate.support_table(np.array([[8.0], [14.0]]))  # nearest DoE points 6 or 10 (2) and 10 (4)
    assert table.columns.tolist() == ["knn_distance", "in_support"]
    np.testing.assert_allclose(table["knn_distance"], np.array([2.0, 4.0]) / LINE_STD)
    assert table["in_support"].tolist() == [True, False]  # threshold 3 / std


NAMED_DOE = pd.DataFrame({"die_temp": [20.0, 40.0, 60.0, 30.0, 50.0, 45.0], "blank_mm": [1.0, 1.2, 0.8, 0.9, 1.1, 1.3]})


@pytest.mark.parametrize("model", [DoEStandardizer(), KNNSupportGate(k=2, percentile=80)])
def test_columns_are_matched_by_name_in_any_order_and_after_a_round_trip(model):
    """A what-if table with the columns in another order gets the same answer; the names survive the file."""
    fitted = clone(model).fit(NAMED_DOE)  # a fresh estimator: the parameter is shared by every run in a process
    answer = (lambda m, X: m.transform(X)) if isinstance(model, DoEStandardizer) else (lambda m, X: m.distance(X))
    query = pd.DataFrame({"blank_mm": [1.0, 1.5], "die_temp": [35.0, 80.0]})  # reversed order
    expected = answer(fitted, query[["die_temp", "blank_mm"]].to_numpy())
    data = json.loads(json.dumps(fitted.to_dict()))
    assert data["inputs"] == ["die_temp", "blank_mm"]
    loaded = type(model).from_dict(data)
    for each in (fitted, loaded):
        assert each.feature_names_in_.tolist() == ["die_temp", "blank_mm"]
        np.testing.assert_allclose(answer(each, query), expected)
        with pytest.raises(InputColumnsError, match="no input column 'blank_mm'; the model was fitted on die_temp"):
            answer(each, query[["die_temp"]])
        with pytest.raises(InputColumnsError, match="1 input columns given, the model was fitted on 2"):
            answer(each, query[["die_temp"]].to_numpy())


def test_a_model_file_with_the_wrong_number_of_names_is_an_error():
    data = DoEStandardizer().fit(NAMED_DOE).to_dict() | {"inputs": ["die_temp"]}
    with pytest.raises(ValueError, match="model file lists 1 inputs for 2 columns"):
        DoEStandardizer.from_dict(data)


def test_a_gate_fitted_on_an_array_has_no_names_and_takes_columns_by_position():
    gate = KNNSupportGate(k=2, percentile=80).fit(NAMED_DOE.to_numpy())
    assert gate.to_dict()["inputs"] is None and not hasattr(gate, "feature_names_in_")
    np.testing.assert_allclose(gate.distance(NAMED_DOE), gate.distance(NAMED_DOE.to_numpy()))


def test_gate_needs_one_row_more_than_k_and_counts_the_threshold_as_inside():
    gate = KNNSupportGate(k=4, percentile=75).fit(LINE)  # five rows for k = 4: enough
    assert gate.n_features_in_ == 1
    assert gate.within(np.array([gate.threshold_, np.nextafter(gate.threshold_, np.inf)])).tolist() == [True, False]
    with pytest.raises(ValueError, match="the kNN gate needs more than k=5 DoE rows, got 5"):
        KNNSupportGate(k=5).fit(LINE)


def test_gate_sklearn_clone():
    params = clone(KNNSupportGate(k=3, percentile=90)).get_params()
    assert params == {"k": 3, "percentile": 90, "standardizer": None}
    # the paper's gate: five neighbours, the 95th percentile of the DoE's own distances
    assert KNNSupportGate().get_params() == {"k": 5, "percentile": 95.0, "standardizer": None}


# --------------------------------------------------------------------------- 4. CV without leakage


def test_folds_partition_rows():
    split = folds(23, 5, seed=7)
    assert len(split) == 5
    tests = np.concatenate([test for _, test in split])
    np.testing.assert_array_equal(np.sort(tests), np.arange(23))  # every row tested exactly once
    for train, test in split:
        assert not set(train) & set(test)
        np.testing.assert_array_equal(np.sort(np.concatenate([train, test])), np.arange(23))
        assert len(test) in (4, 5)


def test_written_fold_ids_give_back_the_very_split():
    # rule residual_cv writes each row's fold; rule model_extension scores the extension on the split they give
    split = folds(23, 5, seed=7)
    ids = fold_ids(23, 5, seed=7)
    assert sorted(set(ids)) == [1, 2, 3, 4, 5]
    for (train, test), (train_again, test_again) in zip(split, splits_of(ids), strict=True):
        np.testing.assert_array_equal(train, train_again)
        np.testing.assert_array_equal(test, test_again)
    rows = np.arange(23) * 3  # in-support rows of a larger log
    written = pd.DataFrame({"row": rows, "fold": ids})
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(written_splits(written, rows), split, strict=True))
    assert ids.dtype.kind == "i" and sorted(set(ids.tolist())) == [1, 2, 3, 4, 5]  # written as 1..5, not 1.0
    with pytest.raises(ValueError, match="the written folds belong to other rows than these: rerun the residual CV"):
        written_splits(written, rows + 1)


def test_approximate_residuals_are_measured_less_the_surrogate():
    class Surrogate:
        def predict(self, X, return_std=False):
            return X["a"].to_numpy(float) * 2.0, np.full(len(X), 0.5)

    production = pd.DataFrame({"b": [9.0, 9.0], "a": [1.0, 3.0], "y": [5.0, 4.0]})
    frame = residual.approximate_residuals(Surrogate(), production, ["a"], "y")
    np.testing.assert_allclose(frame["residual_approx"], [3.0, -2.0])
    np.testing.assert_allclose(frame["pred_surrogate_std"], [0.5, 0.5])
    assert list(frame.columns) == ["measured", "pred_surrogate", "pred_surrogate_std", "residual_approx"]


def test_folds_seeded():
    a, b, c = folds(40, 4, seed=1), folds(40, 4, seed=1), folds(40, 4, seed=2)
    for (train_a, test_a), (train_b, test_b) in zip(a, b):
        np.testing.assert_array_equal(train_a, train_b)
        np.testing.assert_array_equal(test_a, test_b)
    assert any(not np.array_equal(test_a, test_c) for (_, test_a), (_, test_c) in zip(a, c))
    with pytest.raises(ValueError):
        folds(3, 5, seed=0)


FITTED = []  # every Recorder fitted in cross_validate registers here (clones do not share attributes)


class Recorder(RegressorMixin, BaseEstimator):
    """Remembers the row ids (X[:, 0]) it was fitted on and the ones it predicted; predicts the mean of its y."""

    def __init__(self, tag: str = "r"):
        self.tag = tag

    def fit(self, X, y):
        self.seen_ = set(np.asarray(X)[:, 0].astype(int).tolist())
        self.mean_ = float(np.mean(y))
        self.predicted_ = set()
        FITTED.append(self)
        return self

    def predict(self, X):
        self.predicted_ |= set(np.asarray(X)[:, 0].astype(int).tolist())
        return np.full(len(X), self.mean_)


def test_cross_validate_never_trains_on_test_rows():
    FITTED.clear()
    n = 17
    X = np.column_stack([np.arange(n), np.linspace(0, 1, n)])
    y = np.arange(n, dtype=float) ** 2
    per_fold, oof = cross_validate(Recorder(), X, y, n_folds=4, seed=3)
    assert len(FITTED) == 4
    assert per_fold["n_train"].tolist() == [len(m.seen_) for m in FITTED]
    assert per_fold["n_test"].sum() == n
    for model, (train, test) in zip(FITTED, folds(n, 4, seed=3)):
        assert model.seen_ == set(train.tolist())
        assert not model.seen_ & model.predicted_
        assert model.predicted_ == set(test.tolist())
        np.testing.assert_allclose(oof[test], y[train].mean())
    assert set().union(*(m.predicted_ for m in FITTED)) == set(range(n))


def test_cross_validate_keeps_fractions_of_an_integer_target_and_numbers_folds_from_one():
    FITTED.clear()
    per_fold, oof = cross_validate(Recorder(), np.arange(4.0)[:, None], np.array([1, 2, 3, 10]), n_folds=4, seed=0)
    np.testing.assert_allclose(oof, [15 / 3, 14 / 3, 13 / 3, 6 / 3])  # a measured column read as integers
    assert per_fold.columns.tolist() == ["fold", "n_train", "n_test", "rmse", "mae", "bias", "r2"]
    assert per_fold["fold"].tolist() == [1, 2, 3, 4]


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


def test_cross_validation_reports_the_rows_a_capped_model_trained_on():
    FITTED.clear()
    n = 40
    X = np.column_stack([np.arange(n), np.linspace(0, 1, n)])
    per_fold, oof = cross_validate(residual.RowCapped(Recorder(), 12, 0), X, np.arange(n, dtype=float), 4, 3)
    assert per_fold["n_train"].tolist() == [12] * 4 and per_fold["n_test"].sum() == n
    for model, (train, test) in zip(FITTED, folds(n, 4, seed=3)):
        assert model.seen_ < set(train.tolist()) and model.predicted_ == set(test.tolist())
    assert residual.capped_note(12, 30).startswith("; each model fitted on a seeded sample of at most 12 ")
    assert residual.capped_note(12, 12) == "" and residual.capped_note(None, 10**6) == ""


def test_splice_keeps_fractions_put_into_an_integer_column():
    np.testing.assert_array_equal(splice_out_of_fold(np.array([10, 11, 12]), [1], [-1.5]), [10.0, -1.5, 12.0])


def test_cross_validate_oof_leave_one_out_by_hand():
    FITTED.clear()
    X = np.arange(4.0)[:, None]
    y = np.array([1.0, 2.0, 3.0, 10.0])
    per_fold, oof = cross_validate(Recorder(), X, y, n_folds=4, seed=0)
    # leave-one-out: each prediction is the mean of the other three y
    np.testing.assert_allclose(oof, [15 / 3, 14 / 3, 13 / 3, 6 / 3])
    # per-fold rmse of one row is |y - oof|, whatever the fold order
    assert sorted(per_fold["rmse"]) == pytest.approx(sorted([4.0, 8 / 3, 4 / 3, 8.0]))


def test_cv_table_summarizes_folds_and_pools_the_out_of_fold_predictions():
    per_fold = pd.DataFrame({"rmse": [1.0, 3.0], "mae": [1.0, 2.0], "bias": [0.5, -0.5], "r2": [0.25, 0.75]})
    y, oof = np.array([1.0, 2.0, 3.0, 4.0]), np.array([2.0, 2.0, 3.0, 2.0])  # errors -1, 0, 0, 2
    table = cv_table(per_fold, y, oof, model="m", evaluated_on="the DoE")
    assert table.columns.tolist()[-4:] == ["pooled_r2", "pooled_rmse", "pooled_mae", "evaluated_on"]
    row = table.iloc[0]
    assert (row["model"], row["n"], row["folds"], row["evaluated_on"]) == ("m", 4, 2, "the DoE")
    assert (row["cv_rmse_mean"], row["cv_rmse_std"]) == pytest.approx((2.0, math.sqrt(2.0)))  # sample std
    assert (row["cv_mae_mean"], row["cv_mae_std"]) == pytest.approx((1.5, math.sqrt(0.5)))
    assert (row["cv_bias_mean"], row["cv_r2_mean"]) == pytest.approx((0.0, 0.5))
    assert row["pooled_rmse"] == pytest.approx(math.sqrt(5 / 4))
    assert row["pooled_mae"] == pytest.approx(3 / 4)
    assert row["pooled_r2"] == pytest.approx(1 - 5 / 5)  # SSE 5, y's SST 5


def test_cv_table_of_one_fold_has_no_spread():
    per_fold = pd.DataFrame({"rmse": [1.0], "mae": [1.0], "bias": [0.0], "r2": [0.5]})
    row = cv_table(per_fold, np.array([1.0, 3.0]), np.array([1.0, 3.0]), "m", "x").iloc[0]
    assert row["cv_rmse_std"] == 0.0 and row["folds"] == 1


# --------------------------------------------------------------------------- 5. GPR surrogate


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


# --------------------------------------------------------------------------- 6. residual model

TABLE4 = {
    "n_estimators",
    "max_depth",
    "learning_rate",
    "subsample",
    "colsample_bytree",
    "min_child_weight",
    "gamma",
    "reg_alpha",
    "reg_lambda",
}


def test_search_space_overrides():
    space = tuning.search_space({"n_estimators": {"low": 5, "high": 20}, "gamma": {"high": 1.0}})
    assert set(space) == TABLE4
    assert space["n_estimators"] == {"low": 5, "high": 20, "type": "int"}
    assert space["gamma"] == {"low": 0.0, "high": 1.0, "type": "float"}
    assert space["learning_rate"] == tuning.DEFAULT_SEARCH_SPACE["learning_rate"]
    # the default is not modified
    assert tuning.DEFAULT_SEARCH_SPACE["n_estimators"] == {"low": 50, "high": 600, "type": "int"}
    assert tuning.search_space(None) == tuning.DEFAULT_SEARCH_SPACE
    with pytest.raises(ValueError):
        tuning.search_space({"max_depth": {"low": 8, "high": 3}})


def test_hyperparameter_table_has_table4_parameters():
    space = tuning.search_space(None)
    params = {name: spec["low"] for name, spec in space.items()}
    table = tuning.hyperparameter_table(params, space)
    assert len(table) == 9
    assert set(table["xgboost_name"]) == TABLE4
    assert table["parameter"].notna().all() and table["parameter"].nunique() == 9
    row = table.set_index("xgboost_name").loc["learning_rate"]
    assert (row["search_low"], row["search_high"], row["log_scale"]) == (0.005, 0.3, True)
    assert table.set_index("xgboost_name").loc["max_depth", "value"] == 2


def test_the_study_tunes_on_a_sample_of_the_support_only_beyond_max_rows_and_says_so():
    inside = np.zeros(1000, bool)
    inside[::2] = True  # 500 in-support parts
    rows, said = tuning.tuning_rows(inside, 1000, seed=3)
    np.testing.assert_array_equal(rows, np.flatnonzero(inside))
    assert said == "K-fold CV RMSE on the 500 in-support production parts"
    rows, said = tuning.tuning_rows(inside, 200, seed=3)
    assert len(rows) == 200 and inside[rows].all() and np.all(np.diff(rows) > 0)
    np.testing.assert_array_equal(rows, tuning.tuning_rows(inside, 200, seed=3)[0])  # seeded
    assert "a seeded sample of 200 of the 500 in-support" in said and "tuning.max_rows" in said


def test_training_rows():
    inside = [True, False, True, True, False]
    np.testing.assert_array_equal(residual.training_rows(inside, "filtered"), [0, 2, 3])
    np.testing.assert_array_equal(residual.training_rows(inside, "unfiltered"), [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(residual.training_rows(np.array([1, 0, 1]), "filtered"), [0, 2])
    with pytest.raises(ValueError):
        residual.training_rows(inside, "all")


@pytest.fixture(scope="module")
def tiny_residual_data():
    rng = np.random.default_rng(5)
    X = rng.uniform(0, 1, (200, 3))
    y = 2 * X[:, 0] - X[:, 1] + 0.1 * rng.normal(size=200)
    return X, y


SMALL_SPACE = tuning.search_space({"n_estimators": {"low": 5, "high": 20}, "max_depth": {"low": 2, "high": 3}})


def _complete(study):
    return sorted(study.get_trials(states=(optuna.trial.TrialState.COMPLETE,)), key=lambda t: t.number)


def test_tune_writes_journal_and_resumes(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    journal = tmp_path / "j.log"
    kwargs = dict(n_folds=3, seed=0, storage=str(journal), space=SMALL_SPACE)
    first = tuning.tune(X, y, n_trials=3, **kwargs)
    assert journal.exists() and journal.stat().st_size > 0
    before = [(t.number, t.params, t.value) for t in _complete(first)]
    assert len(before) == 3
    for _, params, value in before:
        assert set(params) == TABLE4 and 5 <= params["n_estimators"] <= 20 and value > 0

    resumed = tuning.tune(X, y, n_trials=5, **kwargs)
    assert resumed.study_name == first.study_name
    after = _complete(resumed)
    assert len(after) == 5
    assert [(t.number, t.params, t.value) for t in after[:3]] == before
    # the resumed trials explore new points instead of replaying the first ones with a restarted sampler
    assert len({json.dumps(t.params, sort_keys=True) for t in after}) == 5
    # the resumed study is read back from the journal, not from memory
    names = optuna.study.get_all_study_names(tuning.open_storage(str(journal)))
    assert names == [first.study_name]

    # asking again for trials already finished runs nothing new
    assert len(_complete(tuning.tune(X, y, n_trials=4, **kwargs))) == 5

    best = tuning.best_params(resumed, SMALL_SPACE)
    assert best == min(after, key=lambda t: (t.value, t.number)).params

    other = tuning.tune(X, y + 1, n_trials=1, **kwargs)
    assert other.study_name != first.study_name
    assert len(_complete(other)) == 1
    assert sorted(optuna.study.get_all_study_names(tuning.open_storage(str(journal)))) == sorted(
        [first.study_name, other.study_name]
    )


def test_tune_takes_over_a_lock_left_by_a_killed_worker(tiny_residual_data, tmp_path, monkeypatch):
    """A worker killed while writing leaves Optuna's lock link behind; the next run must not wait forever."""
    X, y = tiny_residual_data
    monkeypatch.chdir(tmp_path)  # a relative journal path, as in the config
    monkeypatch.setattr(tuning, "LOCK_GRACE_S", 2)
    journal = Path("results/optuna/journal.log")
    tuning.tune(X, y, n_trials=1, n_folds=3, seed=0, storage=str(journal), space=SMALL_SPACE)
    assert tuning.journal_lock(str(journal)).acquire()  # and never released, as by a killed worker
    finished = []
    worker = threading.Thread(
        target=lambda: finished.append(
            tuning.tune(X, y, n_trials=2, n_folds=3, seed=0, storage=str(journal), space=SMALL_SPACE)
        ),
        daemon=True,
    )
    worker.start()
    worker.join(timeout=60)
    assert finished and len(_complete(finished[0])) == 2, "the stale lock was never released"


def test_tune_fresh_study_is_deterministic(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    runs = [
        tuning.tune(X, y, n_trials=2, n_folds=3, seed=1, storage=str(tmp_path / f"{i}.log"), space=SMALL_SPACE)
        for i in range(2)
    ]
    assert [(t.params, t.value) for t in _complete(runs[0])] == [(t.params, t.value) for t in _complete(runs[1])]


def test_tune_objective_is_cv_rmse(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    study = tuning.tune(X, y, n_trials=1, n_folds=3, seed=0, storage=str(tmp_path / "j.log"), space=SMALL_SPACE)
    trial = _complete(study)[0]
    per_fold, _ = cross_validate(residual.make_model(trial.params, 0), X, y, 3, 0)
    assert trial.value == pytest.approx(per_fold["rmse"].mean(), rel=1e-12)


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


# --------------------------------------------------------------------------- 7. matched cases


def test_matched_summary_by_hand():
    measured = [10.0, 12.0, 14.0]
    simulated = [9.0, 12.0, 15.0]
    surrogate = [9.5, 11.0, 14.5]
    residual_pred = [0.5, 1.0, -1.0]
    in_support = [True, True, False]
    summary, cases = tables.matched_summary(measured, simulated, surrogate, residual_pred, in_support)

    np.testing.assert_allclose(cases["true_residual"], [1.0, 0.0, -1.0])
    np.testing.assert_allclose(cases["pred_hybrid"], [10.0, 12.0, 13.5])
    np.testing.assert_allclose(cases["pred_hybrid_gated"], [10.0, 12.0, 14.5])  # surrogate outside the support
    np.testing.assert_allclose(cases["error_hybrid"], [0.0, 0.0, 0.5])
    np.testing.assert_allclose(cases["error_hybrid_gated"], [0.0, 0.0, -0.5])
    np.testing.assert_allclose(cases["error_surrogate"], [0.5, 1.0, -0.5])

    rows = summary.set_index("comparison")
    assert (rows["n"] == 3).all()
    res = rows.loc["residual (predicted vs true)"]  # errors [0.5, -1, 0]
    assert res["rmse"] == pytest.approx(math.sqrt(1.25 / 3))
    assert res["mae"] == pytest.approx(0.5)
    assert res["bias"] == pytest.approx(-0.5 / 3)
    assert res["r2"] == pytest.approx(1 - 1.25 / 2)  # true residual mean 0, SST 2
    sim = rows.loc["simulation (measured vs FE)"]  # errors [1, 0, -1]
    assert (sim["rmse"], sim["bias"], sim["error_std"]) == pytest.approx((math.sqrt(2 / 3), 0.0, 1.0))
    sur = rows.loc["surrogate (measured vs y_FEM_hat)"]  # errors [0.5, 1, -0.5]
    assert (sur["rmse"], sur["mae"], sur["bias"]) == pytest.approx((math.sqrt(0.5), 2 / 3, 1 / 3))
    hyb = rows.loc["hybrid (measured vs y_hyb)"]  # errors [0, 0, 0.5]
    assert hyb["rmse"] == pytest.approx(math.sqrt(0.25 / 3))
    assert hyb["bias"] == pytest.approx(0.5 / 3)
    assert hyb["error_mean"] == pytest.approx(0.5 / 3)
    assert hyb["error_std"] == pytest.approx(math.sqrt(1 / 12))
    assert hyb["r2"] == pytest.approx(1 - 0.25 / 8)  # measured mean 12, SST 8
    gat = rows.loc["hybrid gated (measured vs gated y_hyb)"]  # errors [0, 0, -0.5]
    assert (gat["rmse"], gat["bias"]) == pytest.approx((math.sqrt(0.25 / 3), -0.5 / 3))


# --------------------------------------------------------------------------- 8. sensitivity table (Table 5)


def test_sensitivity_table_by_hand():
    predictions = pd.DataFrame(
        {
            "measured": [10.0, 10.0, 10.0, 10.0],
            "in_support": [True, True, False, False],
            "pred_surrogate": [9.0, 11.0, 8.0, 13.0],  # errors [1, -1, 2, -3]
            "pred_hybrid_oof": [10.0, 10.5, 9.0, 10.0],  # errors [0, -0.5, 1, 0]
            "pred_hybrid_unfiltered_oof": [11.0, 10.0, 10.0, 12.0],  # errors [-1, 0, 0, -2]
        }
    )
    table = tables.sensitivity_table(predictions).set_index("region")
    assert table["samples"].to_dict() == {"in_support": 2, "out_of_support": 2, "all": 4}
    assert table["evaluated_on"].iloc[0].endswith("tuned on in-support rows")
    noted = tables.sensitivity_table(predictions, residual.capped_note(3, 4))
    assert noted["evaluated_on"].iloc[0].endswith("at most 3 of its training rows (residual_model.max_train_rows)")
    expected = {
        "rmse_surrogate_only": (1.0, math.sqrt(6.5), math.sqrt(15 / 4)),
        "rmse_filtered_train_no_gate": (math.sqrt(0.125), math.sqrt(0.5), math.sqrt(1.25 / 4)),
        "rmse_unfiltered_train_no_gate": (math.sqrt(0.5), math.sqrt(2.0), math.sqrt(5 / 4)),
        # gated: filtered hybrid inside [0, -0.5], surrogate outside [2, -3]
        "rmse_filtered_train_gated": (math.sqrt(0.125), math.sqrt(6.5), math.sqrt(13.25 / 4)),
    }
    for column, (inside, outside, everywhere) in expected.items():
        got = table[column]
        assert (got["in_support"], got["out_of_support"], got["all"]) == pytest.approx((inside, outside, everywhere)), (
            column
        )
    assert (
        table.loc["out_of_support", "rmse_filtered_train_gated"] == table.loc["out_of_support", "rmse_surrogate_only"]
    )
    assert (
        table.loc["in_support", "rmse_filtered_train_gated"] == table.loc["in_support", "rmse_filtered_train_no_gate"]
    )


# --- diagnosis internals ------------------------------------------------------------------------------------------


def test_value_folds_hold_out_whole_levels_of_a_numeric_candidate():
    from hybridtwin.diagnosis import Candidate, Settings
    from hybridtwin.diagnosis.fits import value_folds

    rng = np.random.default_rng(0)
    levels = rng.permutation(np.repeat(np.linspace(0.4, 0.7, 40), 50))  # 40 campaign settings, 50 parts each
    settings = Settings(folds=5, seed=3)
    splits = value_folds(Candidate.new("shim", "input", levels, ("shim",)), settings)
    assert sorted(np.concatenate([test for _, test in splits]).tolist()) == list(range(len(levels)))
    for train, test in splits:
        assert not set(levels[train]) & set(levels[test]), "a setting level on both sides of a fold"
        assert len(np.unique(levels[test])) == 8, "each fold holds out four bins of two levels each"
    ids = np.array([f"K{i % 30}" for i in range(len(levels))])
    shuffled = value_folds(Candidate.new("coil", "group", ids, ("coil",)), settings)
    assert all(set(ids[train]) >= set(ids[test]) for train, test in shuffled), "group levels are seen in training"


@pytest.mark.parametrize("with_product, expected", [(False, "additive"), (True, "product")])
def test_a_pair_is_an_interaction_only_where_the_product_beats_its_main_effects(with_product, expected):
    from hybridtwin import diagnosis
    from hybridtwin.diagnosis import Candidate, Settings, best_fit
    from hybridtwin.diagnosis.fits import is_significant

    rng = np.random.default_rng(1)
    a, b = rng.uniform(-1, 1, (2, 3000))
    y = 2.0 * a + 3.0 * b + (4.0 * a * b if with_product else 0.0) + rng.normal(0, 0.3, 3000)
    fit = best_fit(Candidate.new("a*b", "interaction", np.column_stack([a, b]), ("a", "b")), y - y.mean(), Settings())
    assert fit.form.name == expected
    assert is_significant(fit, 1, Settings(), min_effect=0.1) == with_product
    assert diagnosis.forms.FAMILIES[fit.form.name] == ("interaction" if with_product else "additive")


def test_tuning_logs_every_trial_with_the_best_so_far(tmp_path, caplog):
    rng = np.random.default_rng(0)
    X = rng.random((200, 3))
    y = X[:, 0] + rng.normal(0, 0.1, 200)
    space = tuning.search_space({"n_estimators": {"low": 10, "high": 20}})
    with caplog.at_level(logging.INFO, logger="hybridtwin.paper.tuning"):
        tuning.tune(X, y, n_trials=4, n_folds=3, seed=1, storage=str(tmp_path / "journal.log"), space=space)
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("tuning: trial")]
    assert [line.split(",")[1].split(":")[0].strip() for line in lines] == [f"{i} of 4" for i in range(1, 5)]
    assert all("best so far" in line for line in lines)


def test_tuning_workers_sample_apart_and_each_takes_the_warm_start(tmp_path):
    rng = np.random.default_rng(0)
    X = rng.random((200, 3))
    y = X[:, 0] + rng.normal(0, 0.1, 200)
    space = tuning.search_space({"n_estimators": {"low": 10, "high": 20}})

    def study(storage, worker=0, data=(X, y), seed=1, n_trials=1, warm_start=0):
        return tuning.tune(
            *data,
            n_trials=n_trials,
            n_folds=3,
            seed=seed,
            storage=str(tmp_path / storage),
            space=space,
            worker=worker,
            warm_start=warm_start,
        )

    # the same study's seed in two workers would try the same parameters first
    assert study("a.log").trials[0].params != study("b.log", worker=1).trials[0].params
    assert study("c.log").trials[0].params == study("d.log").trials[0].params
    # an earlier study (another seed, 4 trials); on new data whichever worker opens the study first
    # tries the earlier best first
    new_data = (X, y + 0.01)
    for storage, worker in (("e.log", 0), ("f.log", 1)):
        earlier = study(storage, seed=7, n_trials=4)
        best = min(earlier.trials, key=lambda t: t.value).params
        cold = study(f"cold-{storage}", worker=worker, data=new_data).trials[0].params
        warm = study(storage, worker=worker, data=new_data, warm_start=1).trials[0].params
        assert warm == best and cold != best


def _table_to_write():
    return pd.DataFrame(
        {
            "x": [1.0 / 3, np.nan, 1e-9, -2.5e7, np.inf, 43.4761234567, 0.125, -1.5e-20],
            "n": [1, 2, 3, 4, 5, 6, 7, 8],
            "text": ["a", "b, with a comma", 'a "quote"', "d", "", None, "ä", "h"],
            "flag": [True, False, True, False, True, True, False, False],
        }
    )


def test_csv_writer_with_a_decimal_comma_gives_pandas_float_format_text(tmp_path):
    from hybridtwin.io import files

    frame = _table_to_write()
    files.write_csv(frame, tmp_path / "ours.csv", sep=";", decimal=",")
    frame.to_csv(
        tmp_path / "pandas.csv", index=False, float_format=files.FLOAT_FORMAT, lineterminator="\n", sep=";", decimal=","
    )
    assert (tmp_path / "ours.csv").read_text() == (tmp_path / "pandas.csv").read_text()


@pytest.mark.parametrize("sep", [",", ";"])
def test_csv_writer_gives_the_float_format_values_and_every_other_value_back(tmp_path, sep):
    from hybridtwin.io import files

    frame = _table_to_write()
    files.write_csv(frame, tmp_path / "ours.csv", sep=sep)
    back = pd.read_csv(tmp_path / "ours.csv", sep=sep, keep_default_na=False, na_values=[""])
    expected = frame.assign(x=[float(files.FLOAT_FORMAT % value) for value in frame["x"]])
    expected["text"] = expected["text"].replace("", None)  # an empty text reads back as missing, as with pandas
    pd.testing.assert_frame_equal(back, expected, check_dtype=False)
    assert back["x"].tolist()[5] == 43.476123 and back["flag"].dtype == bool
    # exact digits: every float reads back to itself
    files.write_csv(frame, tmp_path / "exact.csv", float_format=None, sep=sep)
    assert pd.read_csv(tmp_path / "exact.csv", sep=sep)["x"].tolist()[5] == 43.4761234567


def test_a_plain_table_is_written_by_arrow_with_the_text_pandas_writes(tmp_path, monkeypatch):
    from hybridtwin.io import files

    frame = pd.DataFrame(
        {
            "x": [1.0 / 3, np.nan, 2.0, -0.0, np.inf, 123456789.0, 0.1],
            "n": [1, 2, 3, 4, 5, 6, -7],
            "text": ["a", None, "K26000", "", "ä", "2026-03-02 06:00:00", "b"],
            "flag": [True, False, True, False, True, True, False],
        }
    )
    arrow_writer, arrow_used = files._write_text_columns, []
    monkeypatch.setattr(files, "_write_text_columns", lambda *args: arrow_used.append(1) or arrow_writer(*args))
    for float_format, pandas_format in ((None, None), ("%.3g", "%.3g")):
        files.write_csv(frame, tmp_path / "ours.csv", float_format=float_format)
        expected = frame.assign(x=[float(pandas_format % v) for v in frame["x"]]) if pandas_format else frame
        expected.to_csv(tmp_path / "pandas.csv", index=False, lineterminator="\n")
        assert (tmp_path / "ours.csv").read_text() == (tmp_path / "pandas.csv").read_text()
    assert len(arrow_used) == 2
    back = pd.read_csv(tmp_path / "ours.csv")
    assert back["x"].dtype == float and back["x"].tolist()[2] == 2.0  # a whole float stays a float


@pytest.mark.parametrize(
    "frame",
    [
        pd.DataFrame({"x": [1.0, np.nan, 3.0]}),  # one column: pandas writes "" where Arrow would leave a blank line
        pd.DataFrame({"x": [1, "a"], "y": [1.0, 2.0]}),  # numbers and text in one column
        pd.DataFrame({"t": pd.to_datetime(["2020-01-01 10:00", "2020-01-02 00:00"]), "y": [1.0, 2.0]}),
        pd.DataFrame([[1.0, 2.0]], columns=["a", "a"]),  # the same name twice
        pd.DataFrame({1: [1.0], "1": [2.0]}),  # names that are not text
        pd.DataFrame({"x": [1.5, 2.5], "y": pd.Categorical(["a", "b"])}),
        pd.DataFrame({"x": [1.5, 2.5], "n": pd.array([1, None], dtype="Int64")}),
        pd.DataFrame({"x": [1.5, 2.5], "text": ["a, b", 'say "c"']}),
        pd.DataFrame({"x, y": [1.5], "z": [2.5]}),
    ],
)
def test_any_other_table_is_written_by_pandas(tmp_path, frame):
    from hybridtwin.io import files

    files.write_csv(frame, tmp_path / "ours.csv", float_format=None)
    frame.to_csv(tmp_path / "pandas.csv", index=False, lineterminator="\n")
    assert (tmp_path / "ours.csv").read_text() == (tmp_path / "pandas.csv").read_text()


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_an_output_gets_the_mode_of_any_new_file(tmp_path, monkeypatch, mask):
    from hybridtwin.io import files

    monkeypatch.setattr(files, "_UMASK", mask)
    files.write_json({"a": 1}, tmp_path / "out.json")
    assert (tmp_path / "out.json").stat().st_mode & 0o777 == 0o666 & ~mask


def test_rounding_to_significant_digits_agrees_with_percent_g(tmp_path):
    from hybridtwin.io import files

    rng = np.random.default_rng(0)
    values = np.concatenate(
        [
            rng.normal(0, 1, 20_000) * 10.0 ** rng.integers(-300, 300, 20_000),
            rng.normal(0, 1, 20_000) * 10.0 ** rng.integers(-6, 7, 20_000),  # the sizes of measured values
            [0.0, -0.0, np.nan, np.inf, -np.inf, 5e-324, 1.7976931348623157e308, 0.125, 0.135, 999.99999999, 9.5],
        ]
    )
    for digits in (1, 2, 8, 10):
        expected = np.array([float(f"%.{digits}g" % value) for value in values])
        np.testing.assert_array_equal(files.rounded_to_significant(values, digits), expected)
    with pytest.raises(ValueError, match="1 to 10 significant"):
        files.write_csv(pd.DataFrame({"x": [1.0]}), tmp_path / "unused.csv", float_format="%.11g")
    assert not list(tmp_path.iterdir())


def test_a_study_on_new_data_starts_from_the_earlier_studys_best_trials(tmp_path):
    rng = np.random.default_rng(0)
    X = rng.random((150, 3))
    y = X[:, 0] + rng.normal(0, 0.1, 150)
    space = tuning.search_space({"n_estimators": {"low": 10, "high": 20}})
    journal = str(tmp_path / "journal.log")
    first = tuning.tune(X, y, n_trials=6, n_folds=3, seed=1, storage=journal, space=space)
    best = sorted(
        (t for t in first.trials if t.state == optuna.trial.TrialState.COMPLETE), key=lambda t: (t.value, t.number)
    )[:3]
    enriched = np.vstack([X, rng.random((10, 3))])
    second = tuning.tune(
        enriched,
        np.append(y, rng.random(10)),
        n_trials=4,
        n_folds=3,
        seed=1,
        storage=journal,
        space=space,
        warm_start=3,
    )
    assert second.study_name != first.study_name
    assert [t.params for t in second.trials[:3]] == [t.params for t in best]
    cold = tuning.tune(
        enriched[:-1],
        np.append(y, rng.random(9)),
        n_trials=2,
        n_folds=3,
        seed=1,
        storage=str(tmp_path / "other.log"),
        space=space,
        warm_start=3,
    )
    assert cold.trials[0].params != best[0].params  # nothing earlier in its storage: a cold start


def test_a_job_whose_workflow_is_gone_writes_nothing(tmp_path, monkeypatch):
    import subprocess
    import sys

    from hybridtwin.io import files

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()  # reaped: its pid no longer runs
    target = tmp_path / "best_params.json"
    target.write_text("the later run's\n")
    monkeypatch.setenv(files.OWNER_ENVIRONMENT, str(gone.pid))
    with pytest.raises(files.OrphanedJob, match="cannot overwrite"):
        files.write_json({"params": 1}, target)
    assert target.read_text() == "the later run's\n"
    assert [p.name for p in tmp_path.iterdir()] == ["best_params.json"]  # no temporary file left either
    monkeypatch.setenv(files.OWNER_ENVIRONMENT, str(os.getpid()))  # a running workflow: written
    files.write_json({"params": 1}, target)
    assert "params" in target.read_text()


def test_a_cluster_job_on_another_machine_is_not_taken_for_an_orphan(tmp_path, monkeypatch):
    from hybridtwin.io import files

    monkeypatch.setenv(files.OWNER_ENVIRONMENT, "999999999")  # no such process here
    monkeypatch.setenv(files.OWNER_ENVIRONMENT + "_HOST", "another-node")
    files.write_json({"params": 1}, tmp_path / "best.json")
    assert (tmp_path / "best.json").exists()
