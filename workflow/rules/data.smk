# The input data: the built-in demo plant (when the config points at it), checks and checked copies.


rule demo_data:
    output:
        doe=f"{DEMO}/doe.csv",
        production=f"{DEMO}/production.csv",
        matched=f"{DEMO}/matched.csv",
        production_truth=f"{DEMO}/production_truth.csv",
        matched_truth=f"{DEMO}/matched_truth.csv",
        spec=f"{DEMO}/demo_spec.json",
    params:
        code=PACKAGE_CODE,
        demo=config["demo"],
    conda:
        "../envs/hybridtwin.yaml"
    log:
        log_of("demo_data"),
    benchmark:
        benchmark_of("demo_data")
    script:
        "../../scripts/demo_data.py"


rule validate_inputs:
    input:
        doe=config["data"]["doe"],
        production=config["data"]["production"],
        matched=config["data"]["matched"],
    output:
        doe=f"{RESULTS}/data/doe.csv",
        production=f"{RESULTS}/data/production.csv",
        matched=f"{RESULTS}/data/matched.csv",
        report=f"{RESULTS}/data/validation_report.txt",
    params:
        code=PACKAGE_CODE,
        settings={key: config[key] for key in ("data", "columns", "csv", "cv", "gate")},
    conda:
        "../envs/hybridtwin.yaml"
    log:
        log_of("validate_inputs"),
    benchmark:
        benchmark_of("validate_inputs")
    script:
        "../../scripts/validate_inputs.py"


rule standardize:
    input:
        doe=rules.validate_inputs.output.doe,
    output:
        model=f"{MODELS}/doe_standardization.json",
        table=f"{TABLES}/doe_standardization.csv",
    params:
        code=PACKAGE_CODE,
        inputs=INPUTS,
    conda:
        "../envs/hybridtwin.yaml"
    log:
        log_of("standardize"),
    benchmark:
        benchmark_of("standardize")
    script:
        "../../scripts/standardize.py"


rule support_gate:
    input:
        doe=rules.validate_inputs.output.doe,
        production=rules.validate_inputs.output.production,
        matched=rules.validate_inputs.output.matched,
        standardization=rules.standardize.output.model,
    output:
        model=f"{MODELS}/support_gate.json",
        production=f"{RESULTS}/support/production_support.csv",
        matched=f"{RESULTS}/support/matched_support.csv",
        figure=report(f"{FIGURES}/support_distances.png", caption="../report/support_distances.rst",
                      category="1. Data and support"),
    params:
        code=PACKAGE_CODE,
        inputs=INPUTS,
        k=config["gate"]["k"],
        percentile=config["gate"]["percentile"],
        paths=config["data"],
    conda:
        "../envs/hybridtwin.yaml"
    log:
        log_of("support_gate"),
    benchmark:
        benchmark_of("support_gate")
    script:
        "../../scripts/support_gate.py"


rule table1:
    input:
        doe=rules.validate_inputs.output.doe,
        matched=rules.validate_inputs.output.matched,
        support=rules.support_gate.output.production,
    output:
        table=report(f"{TABLES}/table1_datasets.csv", caption="../report/table1.rst", category="1. Data and support"),
    params:
        code=PACKAGE_CODE,
        k=config["gate"]["k"],
        percentile=config["gate"]["percentile"],
    conda:
        "../envs/hybridtwin.yaml"
    log:
        log_of("table1"),
    benchmark:
        benchmark_of("table1")
    script:
        "../../scripts/table1.py"
