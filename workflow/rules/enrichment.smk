# The next simulations to run, where production runs outside the support.


rule propose_simulations:
    input:
        doe=CHECKED["doe"],
        production=CHECKED["production"],
        support=rules.support_gate.output.production,
        surrogate=rules.surrogate_fit.output.model,
    output:
        table=f"{RESULTS}/enrichment/proposed_simulations.csv",
        share=report(
            f"{FIGURES}/enrichment_share.png", caption="../report/enrichment_share.rst", category="8. Next simulations"
        ),
        map=report(
            f"{FIGURES}/enrichment_map.png", caption="../report/enrichment_map.rst", category="8. Next simulations"
        ),
    log:
        log_of("propose_simulations"),
    benchmark:
        benchmark_of("propose_simulations")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("propose_simulations"),
    params:
        code=PACKAGE_CODE,
        inputs=INPUTS,
        k=config["gate"]["k"],
        percentile=config["gate"]["percentile"],
        seed=SEED,
        settings=config["enrichment"],
    script:
        "../../scripts/propose_simulations.py"
