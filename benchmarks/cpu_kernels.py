"""Same data, same config, another CPU: do the numbers stay the same?

NumPy and SciPy's OpenBLAS picks its compute kernels by the CPU (AVX-512 on one machine, AVX2 on another), and
kernels round differently in the last bits. This benchmark runs the workflow on the same plant's files once per
kernel, forced with ``OPENBLAS_CORETYPE`` (one machine stands in for several), and compares:

- every table and model file, byte for byte;
- the frozen predictors' answers on the plant's next 8,000 parts (every model's column, the interval's bounds), in
  mm and against the recommended model's RMS error there (the first kernel's).

    python benchmarks/cpu_kernels.py --plants 2 --seed 14 --generator structures
    python benchmarks/cpu_kernels.py --plants 1 --seed 12 --kernels default Haswell Zen

``default`` is the kernel OpenBLAS picks on this machine. Plants as ``fresh_coverage.py`` draws them (3,000 and
8,000 parts first). Writes benchmarks/results/<name>.csv (a row per plant, kernel and answer column) and .md.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from fresh_coverage import OUT, matched_cases, plant, run_workflow
from results_files import write_results

from hybridtwin.answers.predictor import Predictor


def kernel_env(kernel: str) -> dict:
    env = {key: value for key, value in os.environ.items() if key != "OPENBLAS_CORETYPE"}
    return env if kernel == "default" else {**env, "OPENBLAS_CORETYPE": kernel}


def differing_files(first: Path, second: Path) -> list[str]:
    """The tables and model files of two results folders that differ byte for byte."""
    names = sorted(
        path.relative_to(first).as_posix() for folder in ("tables", "models") for path in (first / folder).glob("*")
    )
    return [name for name in names if (first / name).read_bytes() != (second / name).read_bytes()]


def answer_differences(reference: pd.DataFrame, other: pd.DataFrame, error: float) -> list[dict]:
    """Per numeric answer column, the largest and the RMS difference (mm, and the largest over ``error``)."""
    rows = []
    for column in reference.columns:
        if not column.startswith("pred_") or reference[column].dtype.kind != "f":
            continue
        gap = np.abs(reference[column].to_numpy(float) - other[column].to_numpy(float))
        gap = gap[np.isfinite(gap)]
        largest = float(gap.max()) if len(gap) else 0.0
        rms = float(np.sqrt(np.mean(gap**2))) if len(gap) else 0.0
        rows.append({"column": column, "max_mm": largest, "rms_mm": rms, "max_per_error": largest / error})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plants", type=int, default=2)
    parser.add_argument("--seed", type=int, default=14)
    parser.add_argument("--generator", choices=("families", "structures"), default="structures")
    parser.add_argument("--kernels", nargs="+", default=["default", "Haswell"])
    parser.add_argument("--name", default="cpu_kernels")
    args = parser.parse_args()
    rows, lines = [], []
    for index in range(args.plants):
        name, doe, log, fresh, inputs, target, simulate = plant(index, args.seed, args.generator)
        matched = matched_cases(doe, log, inputs, target, np.random.default_rng(index), simulate)
        with tempfile.TemporaryDirectory() as scratch:
            answers, folders = {}, {}
            for kernel in args.kernels:
                folder = Path(scratch) / kernel
                folder.mkdir()
                models = run_workflow(folder, doe, log, matched, inputs, target, args.seed, kernel_env(kernel))
                folders[kernel] = models.parent
                answers[kernel] = Predictor.load(models).predict(fresh.drop(columns=[target]), all_models=True)
            first = args.kernels[0]
            measured = fresh[target].to_numpy(float)
            error = float(np.sqrt(np.nanmean((measured - answers[first]["pred_recommended"].to_numpy(float)) ** 2)))
            for kernel in args.kernels[1:]:
                differ = differing_files(folders[first], folders[kernel])
                found = answer_differences(answers[first], answers[kernel], error)
                rows += [{"plant": name, "n_log": len(log), "kernel": kernel, **row} for row in found]
                worst = max(found, key=lambda row: row["max_mm"])
                lines.append(
                    f"- {name} ({len(log):,}-part log), {kernel} against {first}: {len(differ)} table and model "
                    f"files differ ({', '.join(differ) or 'none'}); on the next {len(fresh):,} parts the largest "
                    f"difference {worst['max_mm']:.3g} mm in `{worst['column']}` ({worst['max_per_error']:.2f} x the "
                    f"recommended model's RMS error there, {error:.3g} mm)"
                )
        print(lines[-1], flush=True)
    table = pd.DataFrame(rows)
    summary = "\n".join(lines) + "\n\n" + table.to_markdown(index=False, floatfmt=".3g")
    print(write_results(OUT, args.name, "The same plant under other CPU kernels", table, summary))


if __name__ == "__main__":
    main()
