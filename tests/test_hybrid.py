"""hybridtwin.hybrid: the gated hybrid, samples of the support and the synthetic corrected data, by hand."""

import numpy as np
import pandas as pd
import pytest
from scipy.stats import qmc

from hybridtwin.models import compose
from hybridtwin.paper import hybrid


class HalfPlaneGate:
    """In support where x0 < ``edge``; distance = x0 (a stand-in whose answers are known by hand)."""

    def __init__(self, edge=0.5):
        self.edge = edge

    def predict(self, X):
        return np.asarray(X)[:, 0] < self.edge

    def distance(self, X):
        return np.asarray(X)[:, 0].copy()


class Linear:
    def __init__(self, weights, intercept=0.0):
        self.weights, self.intercept = np.asarray(weights, float), intercept

    def predict(self, X):
        return np.asarray(X) @ self.weights + self.intercept


LOW, HIGH = np.array([0.0, 10.0]), np.array([1.0, 20.0])


def test_support_samples_lie_in_the_box_and_pass_the_gate():
    samples = hybrid.sample_in_support(HalfPlaneGate(), LOW, HIGH, n_samples=300, seed=3)
    assert samples.shape == (300, 2)
    assert (samples[:, 0] < 0.5).all() and (samples[:, 0] >= 0).all()
    assert ((samples[:, 1] >= 10) & (samples[:, 1] <= 20)).all()
    # the whole in-support part of the box is sampled, not a corner of it
    assert samples[:, 0].max() > 0.45 and samples[:, 1].min() < 10.5 and samples[:, 1].max() > 19.5


def test_support_samples_are_the_first_in_support_draws_of_a_seeded_latin_hypercube():
    samples = hybrid.sample_in_support(HalfPlaneGate(), LOW, HIGH, n_samples=300, seed=3)
    draws = qmc.scale(qmc.LatinHypercube(d=2, seed=np.random.default_rng(3)).random(4 * 300), LOW, HIGH)
    np.testing.assert_array_equal(samples, draws[draws[:, 0] < 0.5][:300])  # one batch of 4 n draws


def test_support_samples_are_seeded():
    first = hybrid.sample_in_support(HalfPlaneGate(), LOW, HIGH, n_samples=50, seed=7)
    np.testing.assert_array_equal(first, hybrid.sample_in_support(HalfPlaneGate(), LOW, HIGH, n_samples=50, seed=7))
    assert not np.array_equal(first, hybrid.sample_in_support(HalfPlaneGate(), LOW, HIGH, n_samples=50, seed=8))


def test_support_samples_keep_drawing_until_enough_pass():
    # 2% of the box is in support: one batch of max(4 n, 1000) = 1000 draws gives about 20 of the 150 asked for
    samples = hybrid.sample_in_support(HalfPlaneGate(edge=0.02), LOW, HIGH, n_samples=150, seed=1)
    assert len(samples) == 150 and (samples[:, 0] < 0.02).all()


def test_no_support_samples_asked_gives_an_empty_table_of_the_right_width():
    assert hybrid.sample_in_support(HalfPlaneGate(), LOW, HIGH, n_samples=0, seed=1).shape == (0, 2)


def test_a_support_too_small_to_sample_is_an_error_that_says_what_to_change():
    with pytest.raises(
        RuntimeError,
        match=r"only 0 of 10 support samples found in 2000 draws; lower synthetic.n_samples or raise gate.percentile",
    ):
        hybrid.sample_in_support(HalfPlaneGate(edge=0.0), LOW, HIGH, n_samples=10, seed=1, max_draws=2000)


def test_synthetic_frame_by_hand():
    X = np.array([[0.2, 10.0], [0.8, 20.0]])
    frame = hybrid.synthetic_frame(
        X, ["a", "b"], Linear([1.0, 1.0]), Linear([0.0, 0.0], intercept=2.0), HalfPlaneGate()
    )
    expected = pd.DataFrame(
        {
            "a": [0.2, 0.8],
            "b": [10.0, 20.0],
            "in_support": [True, False],
            "knn_distance": [0.2, 0.8],
            "pred_surrogate": [10.2, 20.8],
            "pred_residual": [2.0, 2.0],
            "pred_hybrid": [12.2, 22.8],
            "pred_hybrid_gated": [12.2, 20.8],  # the surrogate alone outside the support
        }
    )
    pd.testing.assert_frame_equal(frame, expected)


def test_gated_hybrid_adds_the_residual_only_inside():
    np.testing.assert_allclose(
        compose.gated(np.array([1.0, 2.0, 3.0]), np.array([1.5, 2.5, 3.5]), np.array([1, 0, 1])), [1.5, 2.0, 3.5]
    )
