# The XGBoost residual model: Optuna tuning, CV, final fits (filtered and unfiltered training sets).


# what a tuning job needs; the workers and the rule that reads their study share it
TUNING_PARAMS = {
    "code": PACKAGE_CODE,
    "inputs": INPUTS,
    "folds": FOLDS,
    "seed": SEED,
    "n_trials": config["tuning"]["n_trials"],
    "max_rows": config["tuning"]["max_rows"],
    "warm_start": config["tuning"]["warm_start"],
    "search_space": config["tuning"]["search_space"],
    # the study journal lives outside the outputs, so a killed run resumes it
    "storage": config["tuning"]["storage"] or f"{RESULTS}/optuna/journal.log",
}


rule tune_worker:
    input:
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
    output:
        done=f"{RESULTS}/tuning/worker_{{worker}}.json",
    log:
        log_of("tune_worker", "_{worker}"),
    benchmark:
        benchmark_of("tune_worker", "_{worker}")
    wildcard_constraints:
        worker=r"\d+",
    # the tuning heads the run's critical path (tuning, residual models, checks, extension, intervals): it
    # starts first, and the steps after it (priority 1) go before the peers and the proposals
    priority: 2
    conda:
        "../envs/hybridtwin.yaml"
    # one core: the peers and the diagnosis, which do not wait for the tuning, run on the other
    # (XGBoost's hist results do not depend on the thread count; a cluster profile sets more)
    threads: 1
    resources:
        mem_mb=memory("tune_worker"),
    params:
        **TUNING_PARAMS,
    script:
        "../../scripts/tune_residual.py"


rule tune_residual:
    input:
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
        # one worker is this rule itself: a job of its own would cost a process start on the critical path
        workers=expand(
            f"{RESULTS}/tuning/worker_{{worker}}.json",
            worker=range(config["tuning"]["workers"] if config["tuning"]["workers"] > 1 else 0),
        ),
    output:
        best=f"{RESULTS}/tuning/best_params.json",
        trials=f"{RESULTS}/tuning/trials.csv",
        table=f"{TABLES}/table4_hyperparameters.csv",
    log:
        log_of("tune_residual"),
    benchmark:
        benchmark_of("tune_residual")
    priority: 2  # with one worker it runs the study: it heads the critical path
    conda:
        "../envs/hybridtwin.yaml"
    # one core, so that it never waits for both to be free (the study with one worker, or a trial the workers
    # left undone, runs here alike)
    threads: 1
    resources:
        mem_mb=memory("tune_residual"),
    params:
        **TUNING_PARAMS,
    script:
        "../../scripts/tune_residual.py"


# one job per training set: the K-fold CV and the final fit read the same rows, and a job of its own for the fit
# cost a process start (1.8 s of imports) and a second read of the log for about a second of work
rule residual_model:
    input:
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
        best=rules.tune_residual.output.best,
    output:
        folds=f"{RESULTS}/residuals/cv_folds_{{training}}.csv",
        oof=oof_file("{training}"),
        table=f"{RESULTS}/residuals/cv_{{training}}.csv",
        model=f"{MODELS}/{registry.RESIDUAL_FILE}",
    log:
        log_of("residual_model", "_{training}"),
    benchmark:
        benchmark_of("residual_model", "_{training}")
    wildcard_constraints:
        training="filtered|unfiltered",
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    threads: 1
    resources:
        mem_mb=memory("residual_model_{training}"),
    params:
        code=PACKAGE_CODE,
        spec=spec("seed", "folds", "max_train_rows"),
    script:
        "../../scripts/residual_model.py"


rule table3:
    input:
        table=f"{RESULTS}/residuals/cv_filtered.csv",
    output:
        table=f"{TABLES}/table3_residual_cv.csv",
    log:
        log_of("table3"),
    benchmark:
        benchmark_of("table3")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("table3"),
    params:
        code=PACKAGE_CODE,
    shell:
        "cp {input.table} {output.table}.tmp 2> {log} && mv {output.table}.tmp {output.table}"
