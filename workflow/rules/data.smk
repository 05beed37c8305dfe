# The input data: the built-in demo plant (when the config points at it), checks and checked copies.


rule demo_data:
    output:
        doe=f"{DEMO}/doe.csv",
        production=f"{DEMO}/production.csv",
        matched=f"{DEMO}/matched.csv",
        production_truth=f"{DEMO}/production_truth.csv",
        matched_truth=f"{DEMO}/matched_truth.csv",
        spec=f"{DEMO}/demo_spec.json",
    log:
        log_of("demo_data"),
    benchmark:
        benchmark_of("demo_data")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("demo_data"),
    params:
        code=PACKAGE_CODE,
        demo=config["demo"],
    script:
        "../../scripts/demo_data.py"


rule validate_inputs:
    # one job per file, so a checked copy is rewritten only when its file (or what it is checked against) changes
    input:
        unpack(raw_inputs_of),
    output:
        table=f"{RESULTS}/data/{{role}}.parquet",
        report=f"{RESULTS}/data/validation_{{role}}.txt",
    log:
        log_of("validate_inputs", "_{role}"),
    benchmark:
        benchmark_of("validate_inputs", "_{role}")
    wildcard_constraints:
        role="doe|production|matched",
    # on the way to the tuning, and to the matched-case check on the critical path (a priority is not passed on
    # to what a job waits for)
    priority: 2
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("validate_inputs_{role}"),
    params:
        code=PACKAGE_CODE,
        settings=validation_settings,
    script:
        "../../scripts/validate_inputs.py"


# the DoE's standardization is made here: a step of its own cost a process start (1.3 s) for milliseconds of work
rule support_gate:
    input:
        doe=CHECKED["doe"],
        production=CHECKED["production"],
    output:
        standardization=f"{MODELS}/doe_standardization.json",
        standardization_table=f"{TABLES}/doe_standardization.csv",
        model=model_file("gate"),
        production=f"{RESULTS}/support/production_support.parquet",
        figure=report(
            f"{FIGURES}/support_distances.png",
            caption="../report/support_distances.rst",
            category="1. Data and support",
        ),
    log:
        log_of("support_gate"),
    benchmark:
        benchmark_of("support_gate")
    priority: 2  # on the way to the tuning
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("support_gate"),
    params:
        code=PACKAGE_CODE,
        spec=spec(),
        k=config["gate"]["k"],
        percentile=config["gate"]["percentile"],
        paths=config["data"],
    script:
        "../../scripts/support_gate.py"


rule table1:
    input:
        doe=CHECKED["doe"],
        matched=CHECKED["matched"],
        support=rules.support_gate.output.production,
    output:
        table=f"{TABLES}/table1_datasets.csv",
    log:
        log_of("table1"),
    benchmark:
        benchmark_of("table1")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("table1"),
    params:
        code=PACKAGE_CODE,
        k=config["gate"]["k"],
        percentile=config["gate"]["percentile"],
    script:
        "../../scripts/table1.py"
