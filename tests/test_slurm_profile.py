"""profiles/slurm and requirements-slurm.txt: the pins, and the profile planning the demo workflow.

The real run on a SLURM cluster is a benchmark (benchmarks/slurm_local.py: it needs root and a few minutes).
"""

import importlib.metadata
import re
import sys
from pathlib import Path

import pytest
import yaml
from packaging.requirements import Requirement

from .conftest import ROOT, run_command

PROFILE = Path(ROOT, "profiles/slurm/config.yaml")
PINS = Path(ROOT, "requirements-slurm.txt")
PLUGINS = ("snakemake-executor-plugin-slurm", "snakemake-executor-plugin-slurm-jobstep")


def pins() -> dict[str, str]:
    lines = [line.split("#")[0].strip() for line in PINS.read_text().splitlines()]
    return dict(line.split("==") for line in lines if line)


def rules() -> set[str]:
    return {
        name
        for path in Path(ROOT, "workflow/rules").glob("*.smk")
        for name in re.findall(r"^rule (\w+):", path.read_text(), re.M)
    }


def test_every_cluster_requirement_is_pinned_to_one_version():
    lines = [line.split("#")[0].strip() for line in PINS.read_text().splitlines()]
    for line in filter(None, lines):
        assert re.fullmatch(r"[A-Za-z0-9._-]+==\d[\w.]*", line), f"not pinned: {line}"
    assert set(PLUGINS) <= set(pins())
    # laptops do not need the plugin
    assert not any(plugin in Path(ROOT, "environment.txt").read_text() for plugin in PLUGINS)


def test_the_pins_were_tested_with_the_snakemake_the_environment_pins():
    # a new Snakemake in environment.txt asks for the plugin's pin to be checked again (and this line changed)
    (snakemake,) = re.findall(r"^snakemake==(\S+)", Path(ROOT, "environment.txt").read_text(), re.M)
    assert f"snakemake=={snakemake}" in PINS.read_text()


def test_the_profile_runs_every_job_on_slurm_with_its_resources():
    profile = yaml.safe_load(PROFILE.read_text())
    assert profile["executor"] == "slurm"
    assert {"slurm_partition", "slurm_account", "runtime", "mem_mb"} <= set(profile["default-resources"])
    # a renamed rule would silently lose its threads and resources
    assert set(profile["set-threads"]) <= rules()
    assert set(profile["set-resources"]) <= rules()
    assert all(isinstance(n, int) and n >= 1 for n in profile["set-threads"].values())


def installed(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        pytest.skip(f"{name} is not installed (pip install -r requirements-slurm.txt)")


@pytest.mark.parametrize("plugin", PLUGINS)
def test_the_installed_plugin_is_the_pinned_one_and_fits_the_installed_snakemake(plugin):
    assert installed(plugin) == pins()[plugin]
    for requirement in map(Requirement, importlib.metadata.requires(plugin) or []):
        if requirement.marker is None or requirement.marker.evaluate():
            version = importlib.metadata.version(requirement.name)
            assert requirement.specifier.contains(version, prereleases=True), f"{plugin} needs {requirement}: {version}"


def test_the_profile_plans_the_demo_workflow_with_two_tuning_workers(tmp_path):
    installed("snakemake-executor-plugin-slurm")
    overlay = tmp_path / "run.yaml"
    overlay.write_text(yaml.safe_dump({"results_dir": "results", "tuning": {"workers": 2}}))
    command = [
        sys.executable, "-m", "snakemake", "-n", "--profile", str(PROFILE.parent), "-s", str(Path(ROOT, "Snakefile")),
        "-d", str(tmp_path / "run"), "--configfile", str(Path(ROOT, "config/config.yaml")), str(overlay),
    ]  # fmt: skip
    result = run_command(command, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    planned = dict(re.findall(r"^(\w+)\s+(\d+)$", result.stdout, re.M))
    assert planned["tune_worker"] == "2" and planned["tune_residual"] == "1"
