"""How unlike the production that calibrated the intervals a setting is.

An interval is checked on production parts: a new setting as far from every logged part as no period of the
log ever was from the rest of it lies where the plant was never seen, even at a modest distance from the
simulations (a die temperature the log never reached, where a saturation sets in). The distance is the mean
distance to the k nearest logged parts, in DoE-standardized space; the threshold is the largest such distance of
a logged part to the parts of the other periods (blocks of consecutive parts, each left out in turn): a new
period as novel as the most novel of the log's.
"""

from __future__ import annotations

import numpy as np

from hybridtwin.crossval import training_subset
from hybridtwin.paper.gate import nearest_index


class ProductionNeighbourhood:
    """The logged parts (a seeded sample of at most ``max_rows``, standardized) and the novelty threshold."""

    def __init__(self, k: int = 5, n_blocks: int = 20, max_rows: int = 2000, seed: int = 0):
        self.k, self.n_blocks, self.max_rows, self.seed = k, n_blocks, max_rows, seed

    def kept_rows(self, n_rows: int) -> np.ndarray:
        """The positions of the parts kept of a log of ``n_rows`` (in time order: the blocks stay periods)."""
        return training_subset(n_rows, self.max_rows, self.seed)

    def fit(self, Z) -> "ProductionNeighbourhood":
        """``Z``: the log's parts in time order, DoE-standardized; or only its :meth:`kept_rows` (the same fit)."""
        Z = np.asarray(Z, float)
        rows = self.kept_rows(len(Z))
        self.parts_ = Z[rows]
        block = np.arange(len(rows)) * self.n_blocks // max(len(rows), 1)
        others = np.empty(len(rows))
        for b in np.unique(block):
            mine = block == b
            rest = nearest_index(self.parts_[~mine], min(self.k, int((~mine).sum())))
            others[mine] = rest.kneighbors(self.parts_[mine])[0].mean(axis=1)
        self.threshold_ = float(others.max())
        return self

    def distance(self, Z) -> np.ndarray:
        """Mean distance of each row to its k nearest logged parts."""
        k = min(self.k, len(self.parts_))
        return nearest_index(self.parts_, k).kneighbors(np.asarray(Z, float))[0].mean(axis=1)

    def to_dict(self) -> dict:
        return {
            "format": "hybridtwin.ProductionNeighbourhood/1",
            "params": {"k": self.k, "n_blocks": self.n_blocks, "max_rows": self.max_rows, "seed": self.seed},
            "threshold": self.threshold_,
            "parts": np.round(self.parts_, 4).tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> "ProductionNeighbourhood":
        model = cls(**data["params"])
        model.parts_ = np.asarray(data["parts"], float)
        model.threshold_ = float(data["threshold"])
        return model
