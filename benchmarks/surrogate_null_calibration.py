"""Benchmark: would the GPR's own posterior make a null for the surrogate's error in the diagnosis? (issue 27)

An id's offsets are partly the surrogate's own error wherever the material is per coil. One candidate null: draws
of that error from the GPR posterior, jointly over the in-support parts. This script measures, on plants of the
structures generator (whose simulator is known, so the surrogate's real error is too), how the real error's
spread and its share between coils compare with the draws'. Usage:

    python benchmarks/surrogate_null_calibration.py --plants 40 --seed 5

It writes benchmarks/results/surrogate_null_calibration.{csv,md}.

The approximate residual of a production part is the plant's discrepancy plus the surrogate's error there
(:math:`f(x) - m(x)`, the simulator less the GPR's mean). That error is a smooth function of the inputs, so it is
constant within a coil wherever the material is per coil, and it follows the setting campaigns: it has the
structure of an id's offsets or a slow trend. Draws of it from the GPR's posterior say what such structure the
surrogate alone gives: the null considered for the diagnosis, which takes its null from the data instead
(:mod:`hybridtwin.diagnosis.ids`).

Draws over thousands of parts use pathwise conditioning (Wilson et al., 2020, "Efficiently sampling functions
from Gaussian process posteriors"): a draw of the prior from random Fourier features of the Matérn kernel, at the
parts and the DoE runs together, corrected by the DoE runs' kernel solve. The error is the draw less the
posterior mean it implies, so no measured value enters.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve

N_FEATURES = 2000  # random Fourier features: the prior covariance is right to about 1/sqrt(N_FEATURES)


def _parts(surrogate):
    """The fitted GPR's kernel pieces in its own (standardized, normalized-target) units."""
    gpr = surrogate.gpr_
    amplitude, matern, white = gpr.kernel_.k1.k1, gpr.kernel_.k1.k2, gpr.kernel_.k2
    return gpr, float(amplitude.constant_value), matern, float(white.noise_level)


def _fourier_features(Z, frequencies, phases, variance):
    return np.sqrt(2.0 * variance / len(phases)) * np.cos(Z @ frequencies.T + phases)


def error_draws(surrogate, X, n_draws: int, seed: int, n_features: int = N_FEATURES) -> np.ndarray:
    """``n_draws`` joint draws of the surrogate's latent error f(x) - m(x) at the rows of ``X`` (rows x draws),
    in the target's unit, from its GPR posterior (noise excluded)."""
    gpr, variance, matern, noise = _parts(surrogate)
    rng = np.random.default_rng(seed)
    length = np.broadcast_to(np.asarray(matern.length_scale, float), (gpr.X_train_.shape[1],))
    # the Matérn kernel's spectral density is a multivariate t with 2 nu degrees of freedom, scale 1/length
    dof = 2.0 * matern.nu
    scale = np.sqrt(dof / rng.chisquare(dof, size=(n_features, 1)))
    frequencies = rng.standard_normal((n_features, len(length))) / length * scale
    phases = rng.uniform(0.0, 2.0 * np.pi, n_features)
    weights = rng.standard_normal((n_features, n_draws))
    train = _fourier_features(gpr.X_train_, frequencies, phases, variance) @ weights
    train += rng.normal(0.0, np.sqrt(noise + gpr.alpha), size=train.shape)
    correction = cho_solve((gpr.L_, True), train)  # (K + noise)^-1 (prior at the runs + their noise)
    Z = surrogate.standardizer_.transform(X)
    draws = np.empty((len(Z), n_draws))
    for start in range(0, len(Z), 5000):
        rows = Z[start : start + 5000]
        prior = _fourier_features(rows, frequencies, phases, variance) @ weights
        draws[start : start + 5000] = prior - matern_kernel(gpr, rows) @ correction
    return draws * float(gpr._y_train_std)


def matern_kernel(gpr, Z) -> np.ndarray:
    """The latent kernel (amplitude times Matérn, no noise) between rows ``Z`` and the DoE runs."""
    return gpr.kernel_.k1(Z, gpr.X_train_)


def loo_scale(surrogate) -> float:
    """How far the GPR's own uncertainty understates its leave-one-out errors on the DoE: the root mean square
    of the standardized leave-one-out residuals (closed form), at least 1. Hyperparameters fitted on few runs
    tend to be over-confident; the draws are widened by this factor, never narrowed."""
    gpr = surrogate.gpr_
    inverse = cho_solve((gpr.L_, True), np.eye(len(gpr.X_train_)))
    z = gpr.alpha_.ravel() / np.sqrt(np.diag(inverse))
    return float(max(1.0, np.sqrt(np.mean(z**2))))


def plant_row(kind: str, draw: int, n_draws: int) -> dict:
    """The real surrogate error's spread and between-coil variance on one plant, beside the posterior draws'."""
    from hybridtwin.demo import harness, structures
    from hybridtwin.diagnosis.naming import between_level_ss

    case = structures.draw_structure_plant(kind, draw)
    run = harness.Run.of(case, draw, 1)
    inside = run.inside
    frame = run.production.loc[inside].reset_index(drop=True)
    X = frame[list(run.spec.inputs)]
    simulated = (case.truth - case.offset - case.effect)[inside]
    real = simulated - run.surrogate.predict(X)
    real -= real.mean()  # the diagnosis takes the offset out first
    draws = error_draws(run.surrogate, X, n_draws, draw)
    draws -= draws.mean(axis=0)
    coil = frame[case.names["coil"]].astype(str).to_numpy()
    between = np.array([between_level_ss(coil, d) for d in draws.T]) / len(real)
    real_between = between_level_ss(coil, real) / len(real)
    return dict(
        kind=kind,
        draw=draw,
        n_doe=case.n_doe,
        coils=len(set(coil)),
        real_std=float(real.std()),
        draws_std=float(draws.std(axis=0).mean()),
        real_between=real_between,
        draws_between_median=float(np.median(between)),
        draws_between_q95=float(np.quantile(between, 0.95)),
        loo_scale=loo_scale(run.surrogate),
    )


def main() -> None:
    import argparse
    import warnings
    from pathlib import Path

    import pandas as pd

    from hybridtwin.demo import structures

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plants", type=int, default=40)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--draws", type=int, default=200)
    parser.add_argument("--out", default="benchmarks/results/surrogate_null_calibration.csv")
    args = parser.parse_args()
    warnings.filterwarnings("ignore", category=UserWarning)
    kinds = [k for k in structures.KINDS if k != "coil"]
    rows = []
    for index in range(args.plants):
        rows.append(plant_row(kinds[index % len(kinds)], args.seed * 10_000 + index, args.draws))
        print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False)
    beyond = table["real_between"] > table["draws_between_q95"]
    text = (
        f"plants: {len(table)} (structures generator, seed {args.seed}, no coil effect); "
        f"{args.draws} posterior draws each\n\n"
        f"- the real error's std over the draws': median {np.median(table.real_std / table.draws_std):.2f}\n"
        f"- its variance between coils over the draws' median: median "
        f"{np.median(table.real_between / table.draws_between_median):.1f}\n"
        f"- plants where the real between-coil variance exceeds the draws' 95% quantile (a null at 5% would "
        f"name the coil on these): {int(beyond.sum())} of {len(table)}\n"
        f"- the DoE's leave-one-out scale (the widening it would give): median {table.loo_scale.median():.2f}\n"
    )
    out.with_suffix(".md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
