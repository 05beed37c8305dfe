# Predictions, the matched-case check, the sensitivity study and the synthetic corrected data.


rule predict_production:
    input:
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
        support=rules.support_gate.output.production,
        filtered_model=model_file("residual_filtered"),
        unfiltered_model=model_file("residual_unfiltered"),
        filtered_oof=oof_file("filtered"),
        unfiltered_oof=oof_file("unfiltered"),
    output:
        predictions=f"{RESULTS}/predictions/hybrid.parquet",
    log:
        log_of("predict_production"),
    benchmark:
        benchmark_of("predict_production")
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    # ten million parts: 49 s on one thread, alone on the critical path (XGBoost's predictions 34 s of it)
    threads: LONG_LOG_THREADS
    resources:
        mem_mb=memory("predict_production"),
    params:
        code=PACKAGE_CODE,
        spec=spec(),
    script:
        "../../scripts/predict_production.py"


# the matched cases' support is found here, apart from the gate (a new matched case reruns this check, not the
# models) and not in a step of its own (a process start, 1.4 s, for a kNN query of a few rows); it does not wait
# for the production predictions (the extension, which waits for this check, then starts as soon as they are made)
rule matched_check:
    input:
        matched=CHECKED["matched"],
        gate=rules.support_gate.output.model,
        surrogate=rules.surrogate_fit.output.model,
        model=model_file("residual_filtered"),
    output:
        support=f"{RESULTS}/support/matched_support.csv",
        summary=f"{TABLES}/matched_check.csv",
        cases=f"{TABLES}/matched_cases.csv",
    log:
        log_of("matched_check"),
    benchmark:
        benchmark_of("matched_check")
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("matched_check"),
    params:
        code=PACKAGE_CODE,
        spec=spec(),
        matched_simulated=config["columns"]["matched_simulated"],
        matched_measured=config["columns"]["matched_measured"],
        paths=config["data"],
    script:
        "../../scripts/matched_check.py"


# Figures 2 and 3 are drawn here, from the production predictions Table 5 reads (a step of their own read them
# again: 2.6 s and 1.4 GB at ten million parts); right after those predictions: on a short log beside the extension,
# on a long one before it (later it ran beside the intervals: 4.5 GiB at once at ten million parts)
rule sensitivity:
    input:
        predictions=rules.predict_production.output.predictions,
        summary=rules.matched_check.output.summary,
        cases=rules.matched_check.output.cases,
    output:
        table=f"{TABLES}/table5_sensitivity.csv",
        figure=report(
            f"{FIGURES}/figure2_residual_check.png", caption="../report/figure2.rst", category="4. Hybrid evaluation"
        ),
        errors=report(
            f"{FIGURES}/figure3_error_distributions.png",
            caption="../report/figure3.rst",
            category="4. Hybrid evaluation",
        ),
    log:
        log_of("sensitivity"),
    benchmark:
        benchmark_of("sensitivity")
    priority: 2
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("sensitivity"),
    params:
        code=PACKAGE_CODE,
        max_train_rows=MAX_TRAIN_ROWS,
        unit=UNIT,
    script:
        "../../scripts/sensitivity.py"


rule synthetic:
    input:
        doe=CHECKED["doe"],
        gate=rules.support_gate.output.model,
        surrogate=rules.surrogate_fit.output.model,
        model=model_file("residual_filtered"),
    output:
        doe=f"{RESULTS}/synthetic/doe_corrected.csv",
        support=f"{RESULTS}/synthetic/support_samples.csv",
    log:
        log_of("synthetic"),
    benchmark:
        benchmark_of("synthetic")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("synthetic"),
    params:
        code=PACKAGE_CODE,
        inputs=INPUTS,
        target=TARGET,
        seed=SEED,
        n_samples=config["synthetic"]["n_samples"],
    script:
        "../../scripts/synthetic.py"
