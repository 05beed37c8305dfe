"""hybridtwin.paper.gate by hand: the DoE standardization and the kNN support gate."""

import json
import math

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone

from hybridtwin.paper import residual
from hybridtwin.paper.gate import DoEStandardizer, InputColumnsError, KNNSupportGate, nearest_index

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


def test_standardization_table_names_each_input_with_its_doe_statistics():
    doe = pd.DataFrame({"thickness_mm": [0.6, 0.7, 0.8], "die_temp_c": [20.0, 40.0, 30.0]})
    table = DoEStandardizer().fit(doe).table()
    assert table["column"].tolist() == ["thickness_mm", "die_temp_c"]
    np.testing.assert_allclose(table["doe_mean"], [0.7, 30.0])
    np.testing.assert_allclose(table["doe_std"], [0.1, 10.0])


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


# irregular 1-D DoE: mean 4, deviations -4, -3, -1, 2, 6 -> var 66 / 4 = 16.5
LINE = np.array([0.0, 1.0, 3.0, 6.0, 10.0])[:, None]


LINE_STD = math.sqrt(16.5)


def test_the_neighbour_index_gives_the_exact_k_nearest_distances():
    from scipy.spatial.distance import cdist

    rng = np.random.default_rng(0)
    reference = rng.normal(0, 3, (300, 12))
    # fresh rows, rows that repeat a reference row, and rows a hair away from one
    rows = np.vstack([rng.normal(0, 3, (500, 12)), reference[:20], reference[20:30] + 1e-9])
    distances = nearest_index(reference, 5).kneighbors(rows)[0]
    exact = np.sort(cdist(rows, reference), axis=1)[:, :5]
    np.testing.assert_allclose(distances[:500], exact[:500], rtol=0, atol=1e-12)
    np.testing.assert_allclose(distances, exact, rtol=0, atol=1e-6)
    # a repeated row's distance is a difference of squares' rounding: zero on one BLAS, 1e-7 on another
    assert np.all(distances[500:520, 0] < 1e-6)


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


def test_approximate_residuals_are_measured_less_the_surrogate():
    class Surrogate:
        def predict(self, X, return_std=False):
            return X["a"].to_numpy(float) * 2.0, np.full(len(X), 0.5)

    production = pd.DataFrame({"b": [9.0, 9.0], "a": [1.0, 3.0], "y": [5.0, 4.0]})
    frame = residual.approximate_residuals(Surrogate(), production, ["a"], "y")
    np.testing.assert_allclose(frame["residual_approx"], [3.0, -2.0])
    np.testing.assert_allclose(frame["pred_surrogate_std"], [0.5, 0.5])
    assert list(frame.columns) == ["measured", "pred_surrogate", "pred_surrogate_std", "residual_approx"]


def test_gate_distances_of_a_long_table_are_found_in_parts_with_the_same_numbers(monkeypatch):
    from hybridtwin.paper import gate as gate_module

    rng = np.random.default_rng(4)
    doe = pd.DataFrame(rng.normal(size=(30, 3)), columns=["a", "b", "c"])
    parts = pd.DataFrame(rng.normal(size=(1001, 3)) * 2, columns=["a", "b", "c"])
    fitted = KNNSupportGate(k=3).fit(doe)
    whole = fitted.distance(parts)
    Z = fitted.standardizer_.transform(parts)
    exact = np.sort(np.linalg.norm(Z[:, None, :] - fitted.reference_[None], axis=2), axis=1)[:, :3].mean(axis=1)
    np.testing.assert_allclose(whole, exact, rtol=0, atol=1e-9)
    monkeypatch.setattr(gate_module, "DISTANCE_ROWS", 100)
    np.testing.assert_array_equal(fitted.distance(parts), whole)
    np.testing.assert_array_equal(fitted.distance(parts.to_numpy()), whole)
    assert fitted.distance(parts.iloc[:0]).shape == (0,)
