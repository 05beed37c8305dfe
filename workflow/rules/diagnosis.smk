# Beyond the paper: what the simulation gets wrong, the physics-side extension and its gain.

N_CAUSE_FIGURES = config["diagnosis"]["n_figures"]


rule diagnose:
    input:
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
        surrogate=rules.surrogate_fit.output.model,
    output:
        table=f"{TABLES}/discrepancy_causes.csv",
        summary=f"{RESULTS}/diagnosis/diagnosis.json",
        figures=report(
            expand(f"{FIGURES}/cause_{{rank}}.png", rank=range(1, N_CAUSE_FIGURES + 1)),
            caption="../report/cause_figure.rst",
            category="6. Diagnosis",
        ),
    log:
        log_of("diagnose"),
    benchmark:
        benchmark_of("diagnose")
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    # one core, beside the tuning, which it does not wait for (its result does not depend on the threads)
    threads: 1
    resources:
        mem_mb=memory("diagnose"),
    params:
        code=PACKAGE_CODE,
        spec=spec("target", "seed", "folds"),
        settings={k: v for k, v in config["diagnosis"].items() if k != "n_figures"},
        unit=UNIT,
        input_units=config["units"]["inputs"],
    script:
        "../../scripts/diagnose.py"


rule model_extension:
    input:
        unpack(demo_truth_inputs),
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
        matched=CHECKED["matched"],
        matched_cases=rules.matched_check.output.cases,
        hybrid=rules.predict_production.output.predictions,
        hybrid_folds=oof_file("filtered"),
        summary=rules.diagnose.output.summary,
        best=rules.tune_residual.output.best,
    output:
        table=f"{TABLES}/model_extension.csv",
        extension=model_file("extension"),
        remainder=model_file("remainder"),
        predictions=f"{RESULTS}/predictions/extension.parquet",
        matched_predictions=f"{RESULTS}/predictions/matched_models.csv",
    log:
        log_of("model_extension"),
    benchmark:
        benchmark_of("model_extension")
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    # on a short log a core, so that it runs beside the peers (with two it waited for both cores to be free, one
    # idle for 4 s of a demo run)
    threads: LONG_LOG_THREADS
    resources:
        mem_mb=memory("model_extension"),
    params:
        code=PACKAGE_CODE,
        spec=spec("seed", "max_train_rows"),
        matched_measured=config["columns"]["matched_measured"],
        blocks=config["intervals"]["blocks"],
    script:
        "../../scripts/model_extension.py"


rule production_predictions:
    input:
        hybrid=rules.predict_production.output.predictions,
        extension=rules.model_extension.output.predictions,
        peers=expand(f"{RESULTS}/peers/{{peer}}_production.parquet", peer=PEERS),
    output:
        predictions=f"{RESULTS}/predictions/production.csv",
    log:
        log_of("production_predictions"),
    benchmark:
        benchmark_of("production_predictions")
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("production_predictions"),
    params:
        code=PACKAGE_CODE,
    script:
        "../../scripts/production_predictions.py"


rule diagnosis_report:
    input:
        unpack(demo_truth_inputs),
        causes=rules.diagnose.output.table,
        summary=rules.diagnose.output.summary,
        gain=rules.model_extension.output.table,
    output:
        report=f"{RESULTS}/diagnosis.md",
    log:
        log_of("diagnosis_report"),
    benchmark:
        benchmark_of("diagnosis_report")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("diagnosis_report"),
    params:
        code=PACKAGE_CODE,
        target=TARGET,
        unit=UNIT,
        figures=FIGURES,
    script:
        "../../scripts/diagnosis_report.py"
