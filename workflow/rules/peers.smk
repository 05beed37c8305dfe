# The established alternatives, fitted on exactly what the filtered hybrid gets: DoE + in-support parts.


rule peer:
    input:
        doe=CHECKED["doe"],
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
    output:
        model=f"{MODELS}/peer_{{peer}}.json",
        predictions=f"{RESULTS}/peers/{{peer}}_production.csv",
        summary=f"{RESULTS}/peers/{{peer}}.json",
    log:
        log_of("peer", "_{peer}"),
    benchmark:
        benchmark_of("peer", "_{peer}")
    wildcard_constraints:
        peer="gp_discrepancy|cokriging",
    conda:
        "../envs/hybridtwin.yaml"
    params:
        code=PACKAGE_CODE,
        inputs=INPUTS,
        target=TARGET,
        seed=SEED,
        folds=config["cv"]["folds"],
        settings=config["peers"],
    script:
        "../../scripts/peer.py"
