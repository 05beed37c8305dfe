"""The outputs catalogue (hybridtwin/io/outputs.yaml) against the workflow: every file a rule declares is
described, by the rule that writes it, and the documentation's outputs page is the catalogue's.

That every column a run writes is described is checked on a real run, in test_workflow.py.
"""

import re
import sys
from pathlib import Path

import pytest
import yaml

from hybridtwin.io import outputs
from hybridtwin.models import registry

from .conftest import ROOT, run_command

sys.path.insert(0, str(Path(ROOT, "docs")))
import gen_outputs  # noqa: E402


@pytest.fixture(scope="module")
def planned_outputs(tmp_path_factory) -> list[tuple[str, str]]:
    """(rule, output under the results folder) of every job of the demo workflow, with a what-if and a monitor
    batch and two tuning workers (one is rule tune_residual itself), planned from scratch (a dry run)."""
    run = tmp_path_factory.mktemp("plan")
    for name in ("settings.csv", "batch.csv"):
        (run / name).write_text("")
    overlay = run / "overlay.yaml"
    overlay.write_text(
        yaml.safe_dump(
            {"results_dir": "results", "whatif": "settings.csv", "monitor": "batch.csv", "tuning": {"workers": 2}}
        )
    )
    command = [
        sys.executable,
        "-m",
        "snakemake",
        "-n",
        "--forceall",
        "-s",
        str(Path(ROOT, "Snakefile")),
        "-d",
        str(run),
    ]
    command += ["--configfile", str(Path(ROOT, "config/config.yaml")), str(overlay)]
    result = run_command(command, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    jobs = re.findall(r"^(?:local)?rule (\w+):\n(?:\s+\w+:.*\n)*?\s+output: (.*)$", result.stdout, re.M)
    assert len(jobs) > 30, result.stdout[-2000:]
    return [(rule, path.removeprefix("results/")) for rule, paths in jobs for path in paths.split(", ")]


def test_every_file_a_rule_writes_is_described_as_that_rules(planned_outputs):
    for rule, path in planned_outputs:
        entry = outputs.entry_for(path)
        assert entry is not None, f"{path} ({rule}) is not in hybridtwin/io/outputs.yaml"
        assert entry.rule == rule, f"{path}: written by {rule}, described as {entry.rule}'s"


def test_every_described_file_is_written_by_a_rule(planned_outputs):
    planned = {path for _, path in planned_outputs}
    # not a rule's declared output: the logs, the benchmark records, the study's journal
    aside = {"logs/{rule}.log", "benchmarks/{rule}.tsv", "optuna/journal.log"}
    for entry in outputs.catalogue():
        if entry.path not in aside:
            assert any(entry.matches(path) for path in planned), f"{entry.path}: no rule writes it (stale?)"


def test_every_step_of_the_steps_table_is_a_rule_with_files():
    rules = {rule for rule, _ in outputs.raw()["steps"]}
    described = {entry.rule for entry in outputs.catalogue()} - {""}
    assert described <= rules, described - rules
    assert rules <= described, rules - described


def test_peer_columns_come_from_the_registry():
    entry = outputs.entry_for("predictions/production.csv")
    columns = dict(entry.columns)
    for peer in registry.PEERS:
        assert peer.column in columns and peer.oof_column in columns
        assert peer.label in columns[peer.column]
    assert not any("{" in name for name, _ in entry.columns)


def test_a_column_the_entry_lacks_is_reported_and_stand_ins_cover_the_runs_inputs():
    entry = outputs.entry_for("enrichment/proposed_simulations.csv")
    header = ["proposal", "thickness_mm", "parts_brought_in", "surprise"]
    assert outputs.undescribed_columns(entry, header, inputs=["thickness_mm"]) == ["surprise"]
    assert outputs.undescribed_columns(entry, header, inputs=[]) == ["thickness_mm", "surprise"]


def test_a_wildcard_stands_for_one_path_part_only():
    entry = outputs.entry_for("peers/cokriging_production.parquet")
    assert entry is not None and entry.path == "peers/{peer}_production.parquet"
    assert not entry.matches("peers/a/b_production.parquet")


def test_the_outputs_page_is_the_catalogues():
    page = Path(ROOT, "docs/outputs.md").read_text(encoding="utf-8")
    assert page == gen_outputs.page(), "docs/outputs.md is stale: python docs/gen_outputs.py > docs/outputs.md"
