# The frozen predictor: intervals by region, the recommended model, and what-if answers.


rule prediction_intervals:
    input:
        unpack(demo_truth_inputs),
        **{f"peer_{name}": model_file(name) for name in PEERS},
        # predictions/production.csv's parts: that CSV is written for the user, after this step
        hybrid_predictions=rules.production_predictions.input.hybrid,
        extension_predictions=rules.production_predictions.input.extension,
        peer_predictions=rules.production_predictions.input.peers,
        production=CHECKED["production"],
        doe=CHECKED["doe"],
        gate=rules.support_gate.output.model,
        matched=CHECKED["matched"],
        matched_models=rules.model_extension.output.matched_predictions,
        matched_cases=rules.matched_check.output.cases,
        surrogate=rules.surrogate_fit.output.model,
        extension=rules.model_extension.output.extension,
        peers_summary=expand(f"{RESULTS}/peers/{{peer}}.json", peer=PEERS),
        # the rest of what the frozen predictor reads, for the sweeps along the named causes
        residual_models=[model_file("residual_filtered"), model_file("residual_unfiltered")],
        remainder=rules.model_extension.output.remainder,
        summary=rules.diagnose.output.summary,
    output:
        manifest=f"{MODELS}/predictor.json",
        reach=model_file("production_reach"),
        comparison=f"{TABLES}/peer_comparison.csv",
        table=f"{TABLES}/prediction_intervals.csv",
        figure=report(
            f"{FIGURES}/prediction_intervals.png",
            caption="../report/prediction_intervals_figure.rst",
            category="7. What-if predictions",
        ),
        sweeps=report(
            expand(f"{FIGURES}/sweep_{{rank}}.png", rank=range(1, N_CAUSE_FIGURES + 1)),
            caption="../report/cause_sweep.rst",
            category="6. Diagnosis",
        ),
    log:
        log_of("prediction_intervals"),
    benchmark:
        benchmark_of("prediction_intervals")
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("prediction_intervals"),
    params:
        code=PACKAGE_CODE,
        spec=spec("target", "seed"),
        peers=PEERS,
        unit=UNIT,
        input_units=config["units"]["inputs"],
        csv=config["csv"],
        matched_measured=config["columns"]["matched_measured"],
        settings=config["intervals"],
    script:
        "../../scripts/prediction_intervals.py"


# every file the frozen predictor reads
PREDICTOR_FILES = [
    rules.surrogate_fit.output.model,
    rules.support_gate.output.model,
    model_file("residual_filtered"),
    model_file("residual_unfiltered"),
    rules.model_extension.output.extension,
    rules.model_extension.output.remainder,
    model_file("production_reach"),
    [model_file(name) for name in PEERS],
]


rule whatif:
    input:
        whatif=config.get("whatif") or [],
        manifest=rules.prediction_intervals.output.manifest,
        models=PREDICTOR_FILES,
    output:
        predictions=f"{RESULTS}/predictions/whatif.csv",
    log:
        log_of("whatif"),
    benchmark:
        benchmark_of("whatif")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("whatif"),
    params:
        code=PACKAGE_CODE,
        level=config["intervals"]["level"],
    script:
        "../../scripts/whatif.py"
