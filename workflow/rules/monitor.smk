# Watching the plant (optional key monitor: a CSV of new production): the batch checked against the frozen models.


rule monitor:
    input:
        batch=config.get("monitor") or [],
        manifest=rules.prediction_intervals.output.manifest,
        models=PREDICTOR_FILES,
    output:
        table=f"{RESULTS}/monitor/monitor.csv",
        words=f"{RESULTS}/monitor/monitor.md",
        figure=report(
            f"{FIGURES}/monitor.png",
            caption="../report/monitor_figure.rst",
            category="9. Monitor",
        ),
    log:
        log_of("monitor"),
    benchmark:
        benchmark_of("monitor")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("monitor"),
    params:
        code=PACKAGE_CODE,
    script:
        "../../scripts/monitor.py"
