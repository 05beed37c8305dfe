"""The hybrid predictor y_hyb(x) = y_FEM_hat(x) + r_hat(x), gated to the support, and synthetic data."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.stats import qmc

from hybridtwin.models import compose
from hybridtwin.models.registry import HYBRID, HYBRID_GATED, SURROGATE


def sample_in_support(gate, bounds_low, bounds_high, n_samples: int, seed: int, max_draws: int = 200_000):
    """Latin-hypercube candidates in the DoE bounding box, kept where the gate says in support."""
    if n_samples == 0:
        return np.empty((0, len(bounds_low)))
    sampler = qmc.LatinHypercube(d=len(bounds_low), seed=np.random.default_rng(seed))
    kept, drawn = [], 0
    while sum(len(block) for block in kept) < n_samples and drawn < max_draws:
        batch = max(4 * n_samples, 1000)
        candidates = qmc.scale(sampler.random(batch), bounds_low, bounds_high)
        drawn += batch
        kept.append(candidates[gate.predict(candidates)])
    samples = np.vstack(kept)
    if len(samples) < n_samples:
        raise RuntimeError(
            f"only {len(samples)} of {n_samples} support samples found in {drawn} draws; "
            "lower synthetic.n_samples or raise gate.percentile"
        )
    return samples[:n_samples]


def synthetic_frame(X: np.ndarray, inputs, surrogate, residual_model, gate) -> pd.DataFrame:
    """Inputs with surrogate, residual and (gated) hybrid predictions: the synthetic corrected data."""
    X = np.asarray(X, float)
    inside = gate.predict(X)
    surrogate_pred = surrogate.predict(X)
    residual_pred = residual_model.predict(X)
    frame = pd.DataFrame(X, columns=list(inputs))
    frame["in_support"] = inside
    frame["knn_distance"] = gate.distance(X)
    predicted = compose.hybrids(surrogate_pred, residual_pred, inside)
    frame[SURROGATE.column] = surrogate_pred
    frame["pred_residual"] = residual_pred
    frame[HYBRID.column] = predicted[HYBRID.name]
    frame[HYBRID_GATED.column] = predicted[HYBRID_GATED.name]
    return frame
