# Shared settings of the rules: column names from the config, file layout.

INPUTS = list(config["columns"]["inputs"])
TARGET = config["columns"]["target"]
SEED = config["seed"]
FOLDS = config["cv"]["folds"]

TABLES = "results/tables"
FIGURES = "results/figures"
MODELS = "results/models"


def log_of(rule_name, suffix=""):
    return f"results/logs/{rule_name}{suffix}.log"


def benchmark_of(rule_name, suffix=""):
    return f"results/benchmarks/{rule_name}{suffix}.tsv"


def final_outputs():
    tables = ["table1_datasets", "table2_surrogate_cv", "table3_residual_cv", "table4_hyperparameters",
              "table5_sensitivity", "matched_check"]
    figures = ["figure2_residual_check", "figure3_error_distributions", "support_distances", "surrogate_parity"]
    return (
        [f"{TABLES}/{name}.csv" for name in tables]
        + [f"{FIGURES}/{name}.png" for name in figures]
        + ["results/predictions/production.csv", "results/synthetic/doe_corrected.csv",
           "results/synthetic/support_samples.csv"]
    )
