"""Step 8: Figure 3, error distributions of surrogate and hybrid, in support (out-of-fold) and on matched cases."""

from hybridtwin.io import files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import run
from hybridtwin.report import plots


def main(snakemake):
    predictions = read_checked(snakemake.input.predictions)
    inside = predictions[in_support(predictions)]
    cases = read_checked(snakemake.input.cases)
    groups = {
        f"production in support (n={len(inside):,}), hybrid out-of-fold": {
            "surrogate": inside["measured"] - inside["pred_surrogate"],
            "hybrid": inside["measured"] - inside["pred_hybrid_oof"],
        },
        f"matched cases (n={len(cases)})": {"surrogate": cases["error_surrogate"], "hybrid": cases["error_hybrid"]},
    }
    files.save_figure(plots.error_distributions(groups, snakemake.params.unit), snakemake.output.figure)


run(snakemake, main)
