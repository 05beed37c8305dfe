"""The next simulations: enrichment.n_points DoE points that bring the most production parts into the support."""

import logging

from hybridtwin import enrichment
from hybridtwin.io import files
from hybridtwin.io.files import in_support, read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper.surrogate import GPRSurrogate
from hybridtwin.report import plots


def main(snakemake):
    p = snakemake.params
    doe, parts = read_checked(snakemake.input.doe), files.read_matrix(snakemake.input.production, p.inputs)
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate))
    settings = enrichment.EnrichmentSettings.from_config(p.settings, p.seed)
    proposal = enrichment.propose(
        doe[p.inputs].to_numpy(float),
        parts,
        p.k,
        p.percentile,
        settings,
        surrogate_std=lambda X: surrogate.predict(X, return_std=True)[1],
    )
    # besides the inputs' matrix, only the ids and times a proposal names, at the parts it serves (a long log's 1 GB)
    head = files.read_head(snakemake.input.production, 1)
    columns, rows = enrichment.served_columns(head, p.inputs), enrichment.served_rows(proposal)
    table = enrichment.proposals_table(proposal, read_checked(snakemake.input.production, columns, rows), p.inputs)
    if proposal.share_before == 1.0:
        logging.warning(
            "every production part %s is already in the support: nothing to propose (empty table written)",
            "counted" if proposal.n_counted == proposal.n_production else "of the sample counted (enrichment.max_rows)",
        )
    elif len(table) < settings.n_points:
        logging.info("%d point(s) bring every part into the support; no more are proposed", len(table))
    files.write_csv(table, snakemake.output.table)
    files.save_figure(
        plots.enrichment_share(proposal.share_before, proposal.share_after, proposal.share_after_fixed_threshold, p.k),
        snakemake.output.share,
    )
    inside = in_support(read_checked(snakemake.input.support))
    files.save_figure(plots.enrichment_map(doe[p.inputs], parts, inside, table[p.inputs], p.seed), snakemake.output.map)


run(snakemake, main)
