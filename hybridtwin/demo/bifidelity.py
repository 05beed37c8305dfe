"""Published bi-fidelity functions as simulation and plant, with a press line's log columns.

Each function of the ``mf2`` package (a developer requirement) is a plant: its low fidelity is the simulator, its
high fidelity the plant's truth, so nothing but the inputs drives the discrepancy. The log is drawn as the
families generator draws it (:mod:`hybridtwin.demo.families`, not tuned on these functions):

- a timestamp in three 8-hour shifts with idle days, and a stroke counter;
- coil ids (coils of 150-600 parts) and a lot per campaign of 2-5 coils;
- each campaign runs narrow settings of its own (a scatter of 2% of the box), half of them near an edge of the box,
  beyond the DoE (10 runs per input, at least 30, over the inner 80% of the box);
- the plant's noise is 2% of the function's spread; 20,000 parts.
"""

from __future__ import annotations

import zlib

import numpy as np
import pandas as pd
from scipy.stats import qmc

from hybridtwin.demo import families

FUNCTIONS = (
    "forrester", "bohachevsky", "booth", "branin", "himmelblau", "six_hump_camelback",
    "currin", "park91a", "park91b", "borehole", "hartmann6",
)  # fmt: skip
N_PARTS, NOISE_SHARE, SCATTER = 20_000, 0.02, 0.02
LOG_COLUMNS = ("timestamp", "stroke_counter", "coil_id", "lot")


def doe_and_spread(f, rng) -> tuple[np.ndarray, float]:
    """A function's DoE (a Latin hypercube of 10 runs per input, at least 30, over the inner 80% of the box) and the
    spread of its high fidelity over the whole box (20,000 points)."""
    low, high, d = np.asarray(f.l_bound, float), np.asarray(f.u_bound, float), f.ndim
    width = high - low
    doe_x = qmc.scale(qmc.LatinHypercube(d=d, seed=rng).random(max(30, 10 * d)), low + 0.1 * width, high - 0.1 * width)
    return doe_x, float(np.ptp(f.high(qmc.scale(qmc.LatinHypercube(d=d, seed=rng).random(20_000), low, high))))


def at_an_edge(centre: np.ndarray, f, rng) -> None:
    """Moves one input of a campaign's ``centre`` to between 1% and 7% of the box from an edge: beyond the DoE."""
    low, high = np.asarray(f.l_bound, float), np.asarray(f.u_bound, float)
    j = rng.integers(f.ndim)
    inset = rng.uniform(0.01, 0.07) * (high[j] - low[j])
    centre[j] = high[j] - inset if rng.random() < 0.5 else low[j] + inset


def scattered(centre: np.ndarray, n: int, f, rng) -> np.ndarray:
    """``n`` parts' inputs about a campaign's ``centre``: a scatter of :data:`SCATTER` of the box, kept in it."""
    low, high = np.asarray(f.l_bound, float), np.asarray(f.u_bound, float)
    return np.clip(centre + rng.normal(0, SCATTER * (high - low), (n, f.ndim)), low, high)


def plant(function: str, seed: int) -> families.PlantCase:
    """DoE, production log (inputs, target and log columns) and noise-free truth of one function's plant."""
    import mf2

    f = getattr(mf2, function)
    rng = np.random.default_rng([seed, zlib.crc32(function.encode())])
    low, high, d = np.asarray(f.l_bound, float), np.asarray(f.u_bound, float), f.ndim
    width = high - low
    inputs = [f"x{j + 1}" for j in range(d)]
    doe_x, spread = doe_and_spread(f, rng)
    elapsed, _, _, strokes = families._timeline(N_PARTS, rng)
    coil = families._coils(N_PARTS, rng)
    coils_per_lot = rng.integers(2, 6, coil.max() + 2)
    lot = np.repeat(np.arange(len(coils_per_lot)), coils_per_lot)[: coil.max() + 1][coil]
    X = np.empty((N_PARTS, d))
    for level in np.unique(lot):
        rows = lot == level
        centre = low + width * rng.uniform(0.2, 0.8, d)
        if rng.random() < 0.5:
            at_an_edge(centre, f, rng)
        X[rows] = scattered(centre, rows.sum(), f, rng)
    truth = f.high(X)
    noise = NOISE_SHARE * spread
    stamps = pd.Timestamp("2025-03-03 06:00") + pd.to_timedelta(np.round(elapsed), unit="s")
    production = pd.DataFrame(X, columns=inputs).assign(
        y=truth + rng.normal(0, noise, N_PARTS),
        timestamp=stamps.strftime("%Y-%m-%d %H:%M:%S"),
        stroke_counter=strokes,
        coil_id=[f"C{c:04d}" for c in coil],
        lot=[f"L{c:03d}" for c in lot],
    )
    doe = pd.DataFrame(doe_x, columns=inputs).assign(y=f.low(doe_x))
    expected = families.Expected(None)
    return families.PlantCase("bifidelity", function, doe, production, truth, inputs, "y", expected, noise)
