"""Generated plants with a known answer: the demo plant, other plant families, and the scenario harness.

``plant``: the seeded demo plant the default workflow runs on; ``families``: plants drawn another
way (other names, rhythms, confounding and numbers of causes); ``scenarios``: hidden effects run
through the method in memory, for the tests and ``benchmarks/diagnosis_bank.py``.
"""

from hybridtwin.demo.plant import (
    INPUT_NAMES,
    INPUTS,
    MATCHED_MEASURED,
    MATCHED_SIMULATED,
    TARGET,
    DemoPlant,
    HiddenEffect,
    describe_plant,
    effect,
    generate,
    plant_from_config,
    plant_truth,
    simulator,
)

__all__ = [
    "INPUT_NAMES",
    "INPUTS",
    "MATCHED_MEASURED",
    "MATCHED_SIMULATED",
    "TARGET",
    "DemoPlant",
    "HiddenEffect",
    "describe_plant",
    "effect",
    "generate",
    "plant_from_config",
    "plant_truth",
    "simulator",
]
