"""hybridtwin.metrics beyond the paper's indicators (those: test_units.py): empty inputs, lag-1 correlation."""

import warnings

import numpy as np
import pytest

from hybridtwin.metrics import bias, lag1_correlation, mae, r2, rmse


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
