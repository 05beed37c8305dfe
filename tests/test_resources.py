"""Each step's memory ask (Snakemake's mem_mb, what SLURM reserves per job): it grows with the production log, covers
what the steps were measured to need, and every rule has one."""

import re
from pathlib import Path

from hybridtwin.io.resources import FLOOR_MB, MEASURED, MEASURED_GB, memory_mb, production_gb

RULES = Path(__file__).resolve().parents[1] / "workflow" / "rules"


def test_the_ask_grows_with_the_log_from_a_floor_and_is_a_round_number():
    small, large = memory_mb("prediction_intervals", MEASURED_GB[0]), memory_mb("prediction_intervals", 1.4)
    assert small == FLOOR_MB < large and large % 100 == 0
    assert memory_mb("prediction_intervals", 14.0) > 5 * large  # ten times the parts: roughly ten times the growth
    assert memory_mb("table1", 14.0) == memory_mb("step never measured", 14.0) == FLOOR_MB


def test_the_ask_covers_every_measured_peak_and_the_intervals_own_process():
    for step, (demo, large) in MEASURED.items():
        assert memory_mb(step, MEASURED_GB[0]) >= demo, step
        assert memory_mb(step, MEASURED_GB[1]) >= large, step
    # the intervals step measured 2.85-2.86 GiB in its own process at ten million parts (2.86 GB in its file)
    assert memory_mb("prediction_intervals", MEASURED_GB[1]) >= 2.86 * 2**30 / 1e6


def test_a_demo_plant_not_made_yet_is_sized_by_its_parts(tmp_path):
    assert production_gb(tmp_path / "absent.csv", 70_000) == MEASURED_GB[0]
    written = tmp_path / "production.csv"
    written.write_bytes(b"x" * 2_000_000)
    assert production_gb(written, 70_000) == 0.002


def test_every_rule_asks_for_its_memory_by_its_steps_name():
    text = "".join(path.read_text() for path in sorted(RULES.glob("*.smk")))
    benchmarks = re.findall(r'benchmark_of\("(\w+)"(?:, "_\{(\w+)\}")?\)', text)
    asks = re.findall(r'mem_mb=memory\("([\w{}]+)"\)', text)
    assert len(asks) == len(benchmarks) == len(re.findall(r"^rule \w+:", text, re.M))
    # a measured step keeps its name: "peer_{peer}" is peer_cokriging and peer_gp_discrepancy
    values = {"role": ["doe", "production", "matched"], "training": ["filtered", "unfiltered"]}
    values["peer"] = ["cokriging", "gp_discrepancy"]
    steps = set()
    for ask in asks:
        wildcard = re.search(r"\{(\w+)\}", ask)
        steps |= {ask} if wildcard is None else {ask.replace(wildcard.group(0), v) for v in values[wildcard.group(1)]}
    assert set(MEASURED) <= steps
