# Hybrid metamodel for sheet-metal stamping: GPR surrogate of the simulator, kNN
# support gate, XGBoost residual model learned from approximate residuals, and
# the diagnosis of what the simulation gets wrong. See README.md.
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: "config/config.yaml"


validate(config, workflow.source_path("workflow/schemas/config.schema.yaml"))



report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/surrogate.smk"
include: "workflow/rules/residual.smk"
include: "workflow/rules/evaluation.smk"
include: "workflow/rules/diagnosis.smk"
include: "workflow/rules/peers.smk"
include: "workflow/rules/predictor.smk"
include: "workflow/rules/enrichment.smk"


rule all:
    input:
        final_outputs(),
    default_target: True
