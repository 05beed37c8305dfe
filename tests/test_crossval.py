"""hybridtwin.crossval by hand: folds, out-of-fold predictions, the CV table and the splice."""

import math

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, RegressorMixin

from hybridtwin.crossval import (
    capped_note,
    cross_validate,
    cv_table,
    fold_ids,
    folds,
    splice_out_of_fold,
    splits_of,
    training_subset,
    written_splits,
)
from hybridtwin.paper import residual
from tests.conftest import says


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
    # rule residual_model writes each row's fold; rule model_extension scores the extension on the split they give
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


def test_cross_validation_reports_the_rows_a_capped_model_trained_on():
    FITTED.clear()
    n = 40
    X = np.column_stack([np.arange(n), np.linspace(0, 1, n)])
    per_fold, oof = cross_validate(residual.RowCapped(Recorder(), 12, 0), X, np.arange(n, dtype=float), 4, 3)
    assert per_fold["n_train"].tolist() == [12] * 4 and per_fold["n_test"].sum() == n
    for model, (train, test) in zip(FITTED, folds(n, 4, seed=3)):
        assert model.seen_ < set(train.tolist()) and model.predicted_ == set(test.tolist())
        # the sample the capped model draws of its fold's rows, whether it is given them all or only the sample
        assert model.seen_ == set(train[training_subset(len(train), 12, 0)].tolist())
    says(capped_note(12, 30), "sample", "at most 12")
    assert capped_note(12, 12) == "" and capped_note(None, 10**6) == ""


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
