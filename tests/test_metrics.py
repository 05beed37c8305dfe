"""hybridtwin.metrics beyond the paper's indicators (those: test_units.py): empty inputs, lag-1 correlation, the block
t-test and its batch means."""

import math
import warnings

import numpy as np
import pytest

from hybridtwin.metrics import (
    batch_means,
    bias,
    block_gains,
    block_means,
    block_p_value,
    evidence_p_value,
    lag1_correlation,
    mae,
    r2,
    rmse,
    scores,
    signed_rank_p_value,
)


@pytest.mark.parametrize("metric", [rmse, mae, bias, r2])
def test_no_rows_give_nan_without_a_warning(metric):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a mean over no rows would warn: the metric must not compute one
        assert np.isnan(metric([], []))


def test_lag1_correlation_by_hand():
    # centred: -1.5, -0.5, 0.5, 1.5; sum of squares 5; neighbour products 0.75 - 0.25 + 0.75 = 1.25
    assert lag1_correlation([1.0, 2.0, 3.0, 4.0]) == pytest.approx(0.25)
    # alternating: -1, 1, -1, 1 around 0 -> products -1 three times over 4
    assert lag1_correlation([0.0, 2.0, 0.0, 2.0]) == pytest.approx(-0.75)


def test_constant_values_are_uncorrelated():
    assert lag1_correlation([3.0, 3.0, 3.0]) == 0.0


def test_block_test_counts_blocks_not_rows():
    y = np.ones(40)
    prediction = np.r_[np.ones(20), np.zeros(20)]  # gain 1 in the first block, 0 in the second
    # block means [1, 0]: t = 0.5 / (0.7071 / sqrt 2) = 1 with 1 degree of freedom
    assert block_p_value(y, prediction, n_blocks=2) == pytest.approx(0.25)
    # a t-test over the 40 rows would call this highly significant
    assert block_p_value(y, np.ones(40), n_blocks=2) == 0.0
    assert block_p_value(y, np.zeros(40), n_blocks=2) == 1.0


def test_block_means_are_the_means_of_array_splits_blocks():
    values = np.random.default_rng(3).normal(size=1001)
    for n_values, n_blocks in [(1001, 7), (1001, 200), (41, 50), (3, 5), (2, 2)]:
        expected = [block.mean() for block in np.array_split(values[:n_values], min(n_blocks, max(2, n_values // 20)))]
        np.testing.assert_allclose(block_means(values[:n_values], n_blocks), expected, rtol=1e-12)


def test_batch_means_lengthen_blocks_while_their_means_stay_correlated():
    values = np.r_[np.ones(200), -np.ones(200)]
    # 40 blocks: 20 of +1, 20 of -1 (lag-1 correlation 0.95); halved to 20, 10, then 5 blocks of 80 rows:
    # [1, 1, 0, -1, -1], lag-1 correlation (1 + 0 + 0 + 1) / 4 = 0.5 below 2 / sqrt(5)
    np.testing.assert_allclose(batch_means(values, 40, min_blocks=5), [1, 1, 0, -1, -1])
    assert len(batch_means(values, 40, min_blocks=10)) == 10  # never fewer than asked
    alternating = np.repeat(np.tile([1.0, -1.0], 20), 20)  # neighbouring block means anti-correlated
    assert len(batch_means(alternating, 40, min_blocks=5)) == 40


def test_block_gains_are_the_block_means_of_the_squared_error_gain():
    y = np.zeros(60)
    reference = np.full(60, 2.0)  # squared error 4
    prediction = np.r_[np.zeros(20), np.ones(20), np.full(20, 3.0)]  # squared errors 0, 1, 9
    np.testing.assert_allclose(block_gains(y, prediction, 3, reference), [4.0, 3.0, -5.0])
    np.testing.assert_allclose(block_gains(y, prediction, 3), [0.0, -1.0, -9.0])  # against predicting zero


def test_the_signed_rank_test_weighs_each_block_by_the_rank_of_its_gain():
    y, reference = np.zeros(100), np.full(100, 2.0)
    gains_of = np.repeat  # five blocks of 20 parts; the reference's squared error is 4
    assert signed_rank_p_value(y, gains_of([0.0] * 5, 20), reference, 5, 5) == pytest.approx(1 / 32)
    # gains 4, 3.75, 3, 1.75 and -5: the loss has the largest rank, W = 1 + 2 + 3 + 4 = 10 of 15, which 10
    # of the 32 sign patterns reach: p = 10/32, though the mean gain is positive
    mixed = gains_of([0.0, 0.5, 1.0, 1.5, 3.0], 20)
    assert signed_rank_p_value(y, mixed, reference, 5, 5) == pytest.approx(10 / 32)
    assert signed_rank_p_value(y, reference, reference, 5, 5) == 1.0  # no gain anywhere


def blocks_with_gains(gains, rows: int = 20):
    """Residual and prediction whose squared-error gain over predicting zero is ``gains``, block by block:
    a gain g >= 0 is a part predicted exactly (y = sqrt g), a loss -g a part of 0 predicted as sqrt g."""
    y = np.repeat([np.sqrt(g) if g >= 0 else 0.0 for g in gains], rows)
    prediction = np.repeat([np.sqrt(abs(g)) for g in gains], rows)
    return y, prediction


def test_the_diagnosis_test_takes_the_signed_rank_test_where_few_blocks_carry_a_gain_found_in_every_block():
    # a gain in every block, nearly all of it in one (a few coils or campaigns far from the rest)
    y, prediction = blocks_with_gains([0.01, 0.02, 0.03, 0.04, 100.0])
    assert block_p_value(y, prediction, 5) > 0.15  # t = 1.0: the one large block makes the spread
    # every block a gain: W = 15 of 15, which 1 of the 32 sign patterns reaches; doubled for the two tests
    assert evidence_p_value(y, prediction, 5) == pytest.approx(2 / 32)


def test_the_diagnosis_test_takes_the_t_test_where_the_gain_comes_in_a_few_blocks_only():
    # a step that two campaigns reach: a large gain in two blocks, a small loss in three
    y, prediction = blocks_with_gains([-1.0, -1.0, -1.0, 20.0, 20.0])
    t_only = block_p_value(y, prediction, 5)
    # mean 7.4, sd 11.5: t = 1.44 with 4 degrees of freedom; W = 9 of 15 by the signed ranks (p = 0.31)
    assert t_only == pytest.approx(0.1118, abs=1e-4)
    assert evidence_p_value(y, prediction, 5) == pytest.approx(2 * t_only)
    reference = np.zeros_like(y)  # against a reference given explicitly, the same
    assert evidence_p_value(y, prediction, 5, reference) == pytest.approx(2 * t_only)


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
