"""How the models' parts add up to their predictions of the target, in one place.

- the hybrid is the surrogate plus the residual model (the paper's y_hyb = y_FEM_hat + r_hat);
- the gated hybrid is the hybrid in the support and the surrogate alone outside it;
- the extended model is the surrogate plus the named causes' terms, the extended hybrid that plus an
  XGBoost model of what they leave, and, out of the support, the paper's hybrid wherever the guard
  did not let it stand (:func:`hybridtwin.diagnosis.extension.keeps_out_of_support`).
"""

from __future__ import annotations

import numpy as np

from hybridtwin.models.registry import EXTENDED, EXTENDED_HYBRID, HYBRID, HYBRID_GATED, HYBRID_UNFILTERED, SURROGATE


def gated(surrogate, hybrid, in_support) -> np.ndarray:
    """The hybrid inside the support, the surrogate alone outside (the residual gated to zero)."""
    return np.where(np.asarray(in_support, bool), hybrid, surrogate).astype(float)


def guarded(extended_hybrid, hybrid, in_support, stands: bool) -> np.ndarray:
    """The extended hybrid, or where it does not stand (out of the support, by the guard's choice) the paper's."""
    if stands:
        return np.asarray(extended_hybrid, float)
    return np.where(np.asarray(in_support, bool), extended_hybrid, hybrid)


def hybrids(surrogate, residual, in_support, residual_unfiltered=None) -> dict[str, np.ndarray]:
    """The surrogate and the paper's hybrids (and the one trained on every part, where given)."""
    surrogate = np.asarray(surrogate, float)
    hybrid = surrogate + residual
    out = {SURROGATE.name: surrogate, HYBRID_GATED.name: gated(surrogate, hybrid, in_support), HYBRID.name: hybrid}
    if residual_unfiltered is not None:
        out[HYBRID_UNFILTERED.name] = surrogate + residual_unfiltered
    return out


def extended(surrogate, extension, remainder, hybrid, in_support, stands: bool) -> dict[str, np.ndarray]:
    """The extended model (surrogate + the causes' terms) and the extended hybrid (+ the remainder model),
    the latter guarded out of the support."""
    with_causes = np.asarray(surrogate, float) + extension
    return {
        EXTENDED.name: with_causes,
        EXTENDED_HYBRID.name: guarded(with_causes + remainder, hybrid, in_support, stands),
    }
