# Shared settings of the rules: column names from the config, file layout.
import hashlib
import os
import socket
from pathlib import Path

from hybridtwin.io.resources import memory_mb, production_gb  # standard library only
from hybridtwin.models import registry  # standard library only

# the jobs' outputs are renamed into place only while this run lives (hybridtwin.io.files.check_owner):
# a job orphaned by a killed run cannot overwrite the outputs of a later one
os.environ.setdefault("HYBRIDTWIN_WORKFLOW_PID", str(os.getpid()))  # a job's own re-parse keeps the run's
os.environ.setdefault("HYBRIDTWIN_WORKFLOW_PID_HOST", socket.gethostname())


def sorted_keys(value):
    if isinstance(value, dict):
        return {key: sorted_keys(value[key]) for key in sorted(value)}
    return value


# Rules' params come from the config: with its keys in one order, reordering the keys of a
# config file (or writing it with another tool) reruns nothing.
_canonical = sorted_keys(config)
config.clear()
config.update(_canonical)

INPUTS = list(config["columns"]["inputs"])
TARGET = config["columns"]["target"]
SEED = config["seed"]
FOLDS = config["cv"]["folds"]
MAX_TRAIN_ROWS = config["residual_model"]["max_train_rows"]
UNIT = config["units"]["target"]  # of the target, in every table, figure and text

# every rule's params carry a hash of the package's code, so a change there reruns what it affects
PACKAGE_CODE = hashlib.sha256(
    b"".join(path.read_bytes() for path in sorted((Path(workflow.main_snakefile).parent / "hybridtwin").rglob("*.py")))
).hexdigest()[:16]

PEERS = list(registry.PEER_NAMES)
# everything a run writes lives under one folder, so two plants (or two panels) can run side by side
RESULTS = config["results_dir"].rstrip("/")
TABLES = f"{RESULTS}/tables"
FIGURES = f"{RESULTS}/figures"
MODELS = f"{RESULTS}/models"
DEMO = f"{RESULTS}/demo"


# the run's settings each rule's step uses (hybridtwin.pipeline.Spec): the inputs and what else it names
SPEC = {"inputs": INPUTS, "target": TARGET, "seed": SEED, "folds": FOLDS, "max_train_rows": MAX_TRAIN_ROWS}


def spec(*keys):
    return {key: SPEC[key] for key in ("inputs", *keys)}


def model_file(part):
    """A stored model of the run (registry.FILES: surrogate, gate, residual_filtered, a peer's name, ...)."""
    return f"{MODELS}/{registry.FILES[part]}"


def oof_file(training):
    """The residual model's out-of-fold predictions and folds (rule residual_model) for a training set, or for
    the wildcard ``{training}``."""
    return f"{RESULTS}/residuals/oof_{training}.parquet"


CHECKED = {role: f"{RESULTS}/data/{role}.parquet" for role in ("doe", "production", "matched")}
# what each file is checked against besides itself
CHECKED_AGAINST = {"doe": [], "production": ["doe"], "matched": ["production"]}


# a file checked against production reads production's checked copy (its input columns), not the raw log
# again: on a log of millions of parts that second check would cost as much as the first
AGAINST_CHECKED_COPY = {"production"}


def raw_inputs_of(wildcards):
    return {
        "table": config["data"][wildcards.role],
        **{
            other: CHECKED[other] if other in AGAINST_CHECKED_COPY else config["data"][other]
            for other in CHECKED_AGAINST[wildcards.role]
        },
    }


def validation_settings(wildcards):
    """The config a file's check reads: its own path and those it is checked against, columns, format
    (and, for the DoE, the folds and k it must have rows for)."""
    roles = [wildcards.role, *CHECKED_AGAINST[wildcards.role]]
    settings = {
        "data": {role: config["data"][role] for role in roles},
        "columns": config["columns"],
        "csv": config["csv"],
        "checked_copies": {
            other: CHECKED[other] for other in CHECKED_AGAINST[wildcards.role] if other in AGAINST_CHECKED_COPY
        },
    }
    if "doe" in roles:
        settings.update(cv=config["cv"], gate=config["gate"])
    return settings


# each step's memory grows with the production log (hybridtwin.io.resources): Snakemake's mem_mb, which the SLURM
# executor asks for per job and `--resources mem_mb=N` keeps within N MB on one machine
PRODUCTION_GB = production_gb(config["data"]["production"], config["demo"]["n_production"])
# a log this long (GB of CSV, about 700,000 parts) makes the extension's XGBoost work the run's critical path (an
# estimate between the two logs measured: 70,000 parts, where it is not, and 10,000,000, where it is)
LONG_LOG_GB = 0.1
# the threads of a step on the long log's critical path with nothing beside it (its XGBoost and BLAS work splits
# over the cores; the outputs are the same on one thread or two); one on a short log, where the step runs beside
# another and two would wait for both cores to be free
LONG_LOG_THREADS = 2 if PRODUCTION_GB > LONG_LOG_GB else 1


def memory(step):
    """A rule's mem_mb: ``step`` is the rule's name, with its wildcard where it has one ("peer_{peer}")."""
    return lambda wildcards: memory_mb(step.format(**dict(wildcards.items())), PRODUCTION_GB)


def log_of(rule_name, suffix=""):
    return f"{RESULTS}/logs/{rule_name}{suffix}.log"


def benchmark_of(rule_name, suffix=""):
    return f"{RESULTS}/benchmarks/{rule_name}{suffix}.tsv"


def final_outputs():
    tables = [
        "table1_datasets",
        "table2_surrogate_cv",
        "table3_residual_cv",
        "table4_hyperparameters",
        "table5_sensitivity",
        "matched_check",
        "discrepancy_causes",
        "model_extension",
    ]
    ranks = range(1, config["diagnosis"]["n_figures"] + 1)
    figures_of_causes = [f"{kind}_{rank}" for kind in ("cause", "sweep") for rank in ranks]
    figures = ["figure2_residual_check", "figure3_error_distributions", "support_distances", "surrogate_parity"]
    return (
        [f"{TABLES}/{name}.csv" for name in tables]
        + [f"{FIGURES}/{name}.png" for name in figures + figures_of_causes]
        + [
            f"{RESULTS}/predictions/production.csv",
            f"{RESULTS}/synthetic/doe_corrected.csv",
            f"{RESULTS}/synthetic/support_samples.csv",
            f"{RESULTS}/diagnosis.md",
            f"{TABLES}/prediction_intervals.csv",
            f"{TABLES}/peer_comparison.csv",
            f"{MODELS}/predictor.json",
            f"{RESULTS}/enrichment/proposed_simulations.csv",
            f"{RESULTS}/report/diagnosis.html",  # with every other page of the report (rule report_pages)
            SUMMARY,
        ]
        + ([f"{RESULTS}/predictions/whatif.csv"] if config.get("whatif") else [])
        + ([f"{RESULTS}/monitor/monitor.csv", f"{FIGURES}/monitor.png"] if config.get("monitor") else [])
    )


def demo_truth_inputs(wildcards):
    """The demo's noise-free truth, when the run is on the demo data."""
    if config["data"]["production"] != f"{DEMO}/production.csv":
        return {}
    return {"truth": f"{DEMO}/production_truth.csv", "demo_spec": f"{DEMO}/demo_spec.json"}
