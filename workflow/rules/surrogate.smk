# The GPR surrogate of the simulator and the approximate residuals it yields.


rule surrogate_cv:
    input:
        doe=CHECKED["doe"],
    output:
        table=f"{TABLES}/table2_surrogate_cv.csv",
        folds=f"{TABLES}/surrogate_cv_folds.csv",
        figure=report(
            f"{FIGURES}/surrogate_parity.png", caption="../report/surrogate_parity.rst", category="2. Surrogate"
        ),
    log:
        log_of("surrogate_cv"),
    benchmark:
        benchmark_of("surrogate_cv")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("surrogate_cv"),
    params:
        code=PACKAGE_CODE,
        inputs=INPUTS,
        target=TARGET,
        folds=FOLDS,
        seed=SEED,
        n_restarts=config["surrogate"]["n_restarts"],
        unit=UNIT,
    script:
        "../../scripts/surrogate_cv.py"


rule surrogate_fit:
    input:
        doe=CHECKED["doe"],
    output:
        model=model_file(registry.SURROGATE.name),
    log:
        log_of("surrogate_fit"),
    benchmark:
        benchmark_of("surrogate_fit")
    priority: 2  # on the way to the tuning
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("surrogate_fit"),
    params:
        code=PACKAGE_CODE,
        spec=spec("target", "seed"),
        n_restarts=config["surrogate"]["n_restarts"],
    script:
        "../../scripts/surrogate_fit.py"


rule residuals:
    input:
        production=CHECKED["production"],
        support=rules.support_gate.output.production,
        surrogate=rules.surrogate_fit.output.model,
    output:
        residuals=f"{RESULTS}/residuals/production_residuals.parquet",
    log:
        log_of("residuals"),
    benchmark:
        benchmark_of("residuals")
    priority: 2  # on the way to the tuning
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("residuals"),
    params:
        code=PACKAGE_CODE,
        spec=spec("target"),
    script:
        "../../scripts/residuals.py"
