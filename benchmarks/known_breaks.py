"""The ten breaks of the method a review once found the fast tests missing; each must now fail a fast test.

Applies one break at a time to a copy of the tree and runs the fast tests (no workflow, no scenarios):

    python benchmarks/known_breaks.py
"""

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from mutation import fast_tests

BREAKS = [
    ("hybridtwin/diagnosis/forms.py", "self.offsets.get(level, self.overall)", "self.offsets.get(level, 0.0)"),
    ("hybridtwin/diagnosis/forms.py", "for _ in range(passes if len(values) > 1 else 1):", "for _ in range(1):"),
    ("hybridtwin/diagnosis/naming.py", 'kind in ("time", "interaction")', 'kind in ("interaction",)'),
    ("hybridtwin/crossval.py", "    spliced[np.asarray(rows, int)] = np.asarray(oof, float)\n", ""),
    (
        "hybridtwin/metrics.py",
        "np.array_split(values, min(n_blocks, max(2, len(values) // 20)))",
        "np.array_split(values, len(values))",
    ),
    (
        "hybridtwin/diagnosis/fits.py",
        "    if not fits or fits[0].form.name != forms.Monotone.name:\n        return fits",
        "    return fits",
    ),
    (
        "hybridtwin/diagnosis/forms.py",
        "(np.asarray(x, float) >= self.threshold)",
        "(np.asarray(x, float) > self.threshold)",
    ),
    (
        "hybridtwin/diagnosis/extension.py",
        "return self.offset_ + sum(self.contributions(frame).values(), np.zeros(len(frame)))",
        "return sum(self.contributions(frame).values(), np.zeros(len(frame)))",
    ),
    (
        "hybridtwin/report/diagnosis_md.py",
        'direction = "higher" if offset > 0 else "lower"',
        'direction = "lower" if offset > 0 else "higher"',
    ),
    (
        "hybridtwin/models/compose.py",
        "return np.where(np.asarray(in_support, bool), hybrid, surrogate).astype(float)",
        "return np.asarray(hybrid, float)",
    ),
]

TIMEOUT_S = 300  # the fast tests take under a minute; a break that hangs them is reported, not waited for
FAST_TESTS = fast_tests()  # the list in pyproject.toml's [tool.mutmut], shared with the mutation benchmark


def main() -> int:
    root = Path(__file__).resolve().parent.parent
    survived = 0
    with tempfile.TemporaryDirectory() as scratch:
        copy = Path(scratch) / "tree"
        shutil.copytree(root, copy, ignore=shutil.ignore_patterns("results", ".snakemake", ".git", "out"))
        for number, (path, old, new) in enumerate(BREAKS, start=1):
            target = copy / path
            text = target.read_text()
            if text.count(old) != 1:
                raise SystemExit(f"break {number}: the line to break is no longer in {path}: {old!r}")
            target.write_text(text.replace(old, new, 1))
            try:
                result = subprocess.run(
                    [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *FAST_TESTS],
                    cwd=copy,
                    capture_output=True,
                    text=True,
                    env={**os.environ, "PYTHONPATH": str(copy)},
                    timeout=TIMEOUT_S,
                )
            except subprocess.TimeoutExpired:  # a break that makes the fast tests hang is not caught by them
                result = None
            target.write_text(text)
            if result is None:
                survived += 1
                print(f"{number:2d} HUNG (over {TIMEOUT_S} s) {path}", flush=True)
                continue
            failed = [line for line in result.stdout.splitlines() if line.startswith("FAILED")][:1]
            survived += result.returncode == 0
            verdict = "caught" if result.returncode else "SURVIVED"
            print(f"{number:2d} {verdict} {path}: {failed[0] if failed else ''}", flush=True)
    print(f"{len(BREAKS) - survived} of {len(BREAKS)} breaks caught by the fast tests")
    return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main())
