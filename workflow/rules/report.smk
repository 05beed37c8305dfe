# The report's pages: Snakemake's HTML report shows HTML and images inside the page and offers CSV
# and Markdown only for download, so every table and the diagnosis in words reach it as a page.

# page: (file shown, title, caption, category)
REPORT_PAGES = {
    "table1": (f"{TABLES}/table1_datasets.csv", "Table 1: data sets and support", "table1", "1. Data and support"),
    "table2": (f"{TABLES}/table2_surrogate_cv.csv", "Table 2: surrogate, cross-validated", "table2", "2. Surrogate"),
    "table3": (
        f"{TABLES}/table3_residual_cv.csv",
        "Table 3: residual model, cross-validated",
        "table3",
        "3. Residual model",
    ),
    "table4": (f"{TABLES}/table4_hyperparameters.csv", "Table 4: tuned hyperparameters", "table4", "3. Residual model"),
    "matched_check": (f"{TABLES}/matched_check.csv", "Matched cases", "matched_check", "4. Hybrid evaluation"),
    "table5": (f"{TABLES}/table5_sensitivity.csv", "Table 5: sensitivity to gating", "table5", "4. Hybrid evaluation"),
    "synthetic": (f"{RESULTS}/synthetic/doe_corrected.csv", "Corrected DoE", "synthetic", "5. Synthetic data"),
    "diagnosis": (f"{RESULTS}/diagnosis.md", "What the simulation gets wrong", "diagnosis_md", "6. Diagnosis"),
    "discrepancy_causes": (
        f"{TABLES}/discrepancy_causes.csv",
        "Candidate causes",
        "discrepancy_causes",
        "6. Diagnosis",
    ),
    "model_extension": (
        f"{TABLES}/model_extension.csv",
        "Gain of the extended model",
        "model_extension",
        "6. Diagnosis",
    ),
    "peer_comparison": (
        f"{TABLES}/peer_comparison.csv",
        "Side by side with the established methods",
        "peer_comparison",
        "7. What-if predictions",
    ),
    "prediction_intervals": (
        f"{TABLES}/prediction_intervals.csv",
        "Prediction intervals by region",
        "prediction_intervals",
        "7. What-if predictions",
    ),
    "proposed_simulations": (
        f"{RESULTS}/enrichment/proposed_simulations.csv",
        "Proposed simulations",
        "proposed_simulations",
        "8. Next simulations",
    ),
}
if config.get("monitor"):
    REPORT_PAGES["monitor"] = (f"{RESULTS}/monitor/monitor.md", "Monitor: the new batch", "monitor_md", "9. Monitor")


rule report_summary:
    input:
        datasets=rules.table1.output.table,
        diagnosis=rules.diagnose.output.summary,
        gain=rules.model_extension.output.table,
        intervals=rules.prediction_intervals.output.table,
        manifest=rules.prediction_intervals.output.manifest,
        proposals=rules.propose_simulations.output.table,
    output:
        summary=SUMMARY,
    log:
        log_of("report_summary"),
    benchmark:
        benchmark_of("report_summary")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("report_summary"),
    params:
        code=PACKAGE_CODE,
        target=TARGET,
        unit=UNIT,
    script:
        "../../scripts/report_summary.py"


rule report_pages:
    input:
        **{page: source for page, (source, *_) in REPORT_PAGES.items()},
    output:
        **{
            page: report(f"{RESULTS}/report/{page}.html", caption=f"../report/{caption}.rst", category=category)
            for page, (_, _, caption, category) in REPORT_PAGES.items()
        },
    log:
        log_of("report_pages"),
    benchmark:
        benchmark_of("report_pages")
    conda:
        "../envs/hybridtwin.yaml"
    resources:
        mem_mb=memory("report_pages"),
    params:
        code=PACKAGE_CODE,
        unit=UNIT,
        # the user's own column names, shown as they are
        columns=[*INPUTS, TARGET, config["columns"]["matched_simulated"], config["columns"]["matched_measured"]],
        titles={page: title for page, (_, title, *_) in REPORT_PAGES.items()},
    script:
        "../../scripts/report_pages.py"
