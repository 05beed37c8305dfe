"""Each step's memory, for Snakemake's scheduler (``resources: mem_mb``): on a cluster the SLURM executor asks
for it per job, and ``snakemake --resources mem_mb=N`` keeps the steps running side by side on one machine
within N MB.

A step's peak grows with the production log (every part is read, gated, predicted); fits and choices work on
seeded samples. The estimate is a line through two measured runs of the demo plant, alone on 2 cores: 70,000
parts (9.8 MB of CSV; ``benchmarks/results/workflow_timing_1046381.md``) and 10,000,000 (1.40 GB;
``plant_scale_4c74d70.md``; the demo plant's own making from ``plant_scale_6c33722.md``), each step's peak from
Snakemake's benchmark files (the intervals and the proposals from ``plant_scale_b39d8ea.md``), with a margin for
what those files' sampling misses (the intervals measured 2.86 GB there and 3.06 GB in their own process).
"""

from __future__ import annotations

from pathlib import Path

# step (rule, with its wildcard where it has one) -> (peak MB on the demo, peak MB on 10,000,000 parts)
MEASURED = {
    "demo_data": (222, 3102),
    "validate_inputs_doe": (123, 123),
    "validate_inputs_production": (192, 2914),
    "validate_inputs_matched": (2, 1014),
    "support_gate": (295, 1521),
    "residuals": (280, 1477),
    "tune_residual": (291, 1485),
    "tune_worker": (291, 1485),  # not measured apart: a worker runs the study tune_residual runs with one worker
    "residual_model_filtered": (249, 923),  # workflow_timing_259531c.md, plant_scale_259531c.md
    "residual_model_unfiltered": (295, 2317),  # workflow_timing_259531c.md, plant_scale_259531c.md
    "predict_production": (304, 2131),
    "matched_check": (184, 183),  # workflow_timing_b353689.md, plant_scale_b353689.md: no production predictions
    "model_extension": (277, 2400),
    "production_predictions": (200, 771),
    "prediction_intervals": (429, 2857),  # from plant_scale_b39d8ea.md
    "propose_simulations": (759, 1895),  # from plant_scale_b39d8ea.md
    "peer_cokriging": (1138, 2057),
    "peer_gp_discrepancy": (431, 1373),
    "diagnose": (357, 1343),
    "sensitivity": (198, 1764),  # with Figures 2 and 3 (1,663 MB at ten million parts, plant_scale_b353689.md)
}
MEASURED_GB = (0.0098, 1.405)  # the two runs' production CSV, GB
BYTES_PER_PART = 140  # the demo's production CSV (17 columns), for a demo plant not made yet
MARGIN = 1.3  # on what grows with the log: the benchmark files sample the memory less often than it peaks
FLOOR_MB = 500  # a step's Python process with pandas, scikit-learn and the package imported


def memory_mb(step: str, production_gb: float) -> int:
    """MB to ask for ``step`` on a production log of ``production_gb`` GB of CSV (a step not measured: the floor;
    the report's and the tables' small steps stay near it at any size)."""
    demo, large = MEASURED.get(step, (FLOOR_MB, FLOOR_MB))
    per_gb = max(0.0, (large - demo) / (MEASURED_GB[1] - MEASURED_GB[0]))
    estimate = max(FLOOR_MB, demo) + MARGIN * per_gb * max(0.0, production_gb - MEASURED_GB[0])
    return int(-(-estimate // 100) * 100)  # up to the next 100 MB


def production_gb(path, demo_parts: int | None = None) -> float:
    """The production log's size in GB: the file's, or for the demo plant not made yet ``demo_parts`` parts'."""
    file = Path(path)
    if file.is_file():
        return file.stat().st_size / 1e9
    return (demo_parts or 0) * BYTES_PER_PART / 1e9
