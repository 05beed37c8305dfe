"""How often the diagnosis' block test cries wolf where parts share their coil's error.

    python benchmarks/significance_level.py --draws 300

A constructed null: the residual is a per-coil offset plus noise (25 coils of 400 parts, in
time order), and two rival predictions are per-coil guesses, neither better than the other.
A test that holds its level gives p < 0.05 in about 5% of the draws. Reported for the
diagnosis' test (the t-test or the signed-rank test over ``diagnosis.Settings().n_blocks``
blocks of consecutive parts, whichever is smaller, doubled), for the t-test alone (the test
before) and for the variant tried and dropped: blocks lengthened (batch means, down to 20)
while what the prediction leaves is correlated.
"""

import argparse

import numpy as np

from hybridtwin.diagnosis import Settings
from hybridtwin.metrics import batch_means, block_p_value, evidence_p_value


def coil_shared_errors(seed: int, n_coils: int = 25, parts_per_coil: int = 400):
    rng = np.random.default_rng(seed)
    coil = np.repeat(np.arange(n_coils), parts_per_coil)
    residual = rng.normal(0, 1, n_coils)[coil] + rng.normal(0, 1, len(coil))
    return residual, rng.normal(0, 0.5, n_coils)[coil], rng.normal(0, 0.5, n_coils)[coil]


def lengthened_p_value(residual, prediction, reference, n_blocks: int, min_blocks: int = 20) -> float:
    blocks = len(batch_means(residual - prediction, n_blocks, min_blocks))
    return block_p_value(residual, prediction, blocks, reference=reference)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=300)
    args = parser.parse_args()
    n_blocks = Settings().n_blocks
    draws = [coil_shared_errors(seed) for seed in range(args.draws)]
    tests = {
        f"the diagnosis' test ({n_blocks} blocks)": lambda y, a, b: evidence_p_value(y, a, n_blocks, reference=b),
        f"the t-test alone ({n_blocks} blocks)": lambda y, a, b: block_p_value(y, a, n_blocks, reference=b),
        "blocks lengthened while what is left is correlated": lambda y, a, b: lengthened_p_value(y, a, b, n_blocks),
    }
    print(f"{args.draws} draws, nominal 5%, 1% and 0.01% (about the Bonferroni level of a diagnosis' 100 candidates):")
    print("| test | p < 0.05 | p < 0.01 | p < 0.0001 |\n|---|---:|---:|---:|")
    for name, test in tests.items():
        p = np.array([test(*draw) for draw in draws])
        print(f"| {name} | {np.mean(p < 0.05):.1%} | {np.mean(p < 0.01):.1%} | {np.mean(p < 1e-4):.1%} |")


if __name__ == "__main__":
    main()
