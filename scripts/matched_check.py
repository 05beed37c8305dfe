"""Step 7: external check on the matched cases -> their support (with the workflow's gate), matched_check.csv and
the per-case table (Figure 2 is drawn with Table 5, from the production predictions)."""

from hybridtwin.io import data, files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import run, spec_of
from hybridtwin.paper import residual, tables
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate


def main(snakemake):
    p, spec = snakemake.params, spec_of(snakemake)
    matched = read_checked(snakemake.input.matched)
    inputs = matched[list(spec.inputs)]
    support = KNNSupportGate.from_dict(files.read_json(snakemake.input.gate)).support_table(inputs)
    data.warn_matched_outside(support["in_support"].to_numpy(), p.paths)
    files.write_csv(support, snakemake.output.support)
    X = inputs.to_numpy(float)
    summary, cases = tables.matched_cases_table(
        matched,
        p.matched_simulated,
        p.matched_measured,
        GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate)).predict(X),
        residual.load_model(snakemake.input.model).predict(X),
        in_support(support),
    )
    files.write_csv(summary, snakemake.output.summary)
    files.write_csv(cases, snakemake.output.cases)


run(snakemake, main)
