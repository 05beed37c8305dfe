import os
import signal
import subprocess
from dataclasses import replace

import numpy as np
import pytest

from hybridtwin import demo

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_command(command: list[str], timeout: float, **kwargs) -> subprocess.CompletedProcess:
    """Run a command with its output captured; a hang fails the test instead of stalling the suite.

    The command gets its own process group so that, on a timeout, its children (Snakemake's
    jobs) are killed with it.
    """
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True, **kwargs
    )
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        stdout, stderr = process.communicate()
        raise AssertionError(f"{' '.join(command)} still running after {timeout} s:\n{stderr[-4000:]}") from None
    return subprocess.CompletedProcess(command, process.returncode, stdout, stderr)


def says(text: str, *facts: str) -> None:
    """Prose is checked by its facts (numbers with their units, names), in the order given, not by its wording:
    a rewording passes, a wrong number, unit, name or order fails."""
    at = 0
    for fact in facts:
        found = text.find(fact, at)
        assert found >= 0, f"{fact!r} is not in the text (after {text[:at][-60:]!r}): {text!r}"
        at = found + len(fact)


@pytest.fixture(scope="session")
def small_plant():
    return replace(demo.DemoPlant(), n_production=4000, n_doe=40, n_matched=5, seed=3)


@pytest.fixture(scope="session")
def small_data(small_plant):
    return demo.generate(small_plant)


@pytest.fixture(scope="session")
def tiny_residual_data():
    rng = np.random.default_rng(5)
    X = rng.uniform(0, 1, (200, 3))
    y = 2 * X[:, 0] - X[:, 1] + 0.1 * rng.normal(size=200)
    return X, y


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook reads the groups
def pytest_collection_modifyitems(items):
    """Every test not marked ``scenario`` or ``workflow`` is ``fast`` (the tiers: pyproject's markers). The tests that
    read the workflow's shared run (fixture ``run_dir``) form one xdist group: under ``--dist loadgroup`` one worker
    runs the workflow once for all of them."""
    for item in items:
        if not any(item.get_closest_marker(tier) for tier in ("scenario", "workflow")):
            item.add_marker(pytest.mark.fast)
        if "run_dir" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group("run_dir"))
