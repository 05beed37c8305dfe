# Hybrid metamodel for sheet-metal stamping: GPR surrogate of the simulator, kNN
# support gate, XGBoost residual model learned from approximate residuals, and
# the diagnosis of what the simulation gets wrong. See README.md.
import sys
from pathlib import Path

from snakemake.utils import min_version

sys.path.insert(0, workflow.basedir)  # the package beside this file, installed or not
from hybridtwin.io.config import (  # noqa: E402 (light: no numpy, pandas)
    ConfigError,
    check,
    missing_data_files,
    plant_results_dir,
)

min_version("9.0")


configfile: "config/config.yaml"


# one schema, shipped in the package, for keys, types, ranges and defaults; a bad value or a data
# file that does not exist stops the run with one plain line naming the key (before any job runs)
try:
    plant_results_dir(
        config,
        workflow.overwrite_configfiles,
        workflow.config_settings.overwrite_config,
        Path(workflow.basedir, "config/config.yaml"),
    )
    check(config)
    missing_data_files(config, made_by_the_workflow=[Path(config["results_dir"], "demo")])
except ConfigError as error:
    sys.exit(str(error))


# the report opens on the answer (rule report_summary) once a run has written it
SUMMARY = f"{config['results_dir'].rstrip('/')}/report/summary.rst"


report: str(Path(SUMMARY).absolute()) if Path(SUMMARY).exists() else "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/surrogate.smk"
include: "workflow/rules/residual.smk"
include: "workflow/rules/evaluation.smk"
include: "workflow/rules/diagnosis.smk"
include: "workflow/rules/peers.smk"
include: "workflow/rules/predictor.smk"
include: "workflow/rules/enrichment.smk"
include: "workflow/rules/monitor.smk"
include: "workflow/rules/report.smk"


rule all:
    default_target: True
    input:
        final_outputs(),
