# The established alternatives, fitted on exactly what the filtered hybrid gets: DoE + in-support parts.


rule peer:
    input:
        doe=CHECKED["doe"],
        production=CHECKED["production"],
        residuals=rules.residuals.output.residuals,
    output:
        model=f"{MODELS}/{registry.PEER_FILE.format(name='{peer}')}",
        predictions=f"{RESULTS}/peers/{{peer}}_production.parquet",
        summary=f"{RESULTS}/peers/{{peer}}.json",
    log:
        log_of("peer", "_{peer}"),
    benchmark:
        benchmark_of("peer", "_{peer}")
    wildcard_constraints:
        peer="|".join(PEERS),
    # the peers are the longest steps beside the tuning, and the predictions after the extension wait for
    # them: they go before the proposals and the paper's evaluation figures
    priority: 1
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("peer_{peer}"),
    params:
        code=PACKAGE_CODE,
        spec=spec("target", "seed", "folds"),
        settings=config["peers"],
    script:
        "../../scripts/peer.py"
