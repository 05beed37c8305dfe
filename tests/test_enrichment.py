"""Proposed simulations: where production runs outside the support, on constructed plants."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from hybridtwin import enrichment
from hybridtwin.config import ConfigError, check
from hybridtwin.gate import KNNSupportGate

from .conftest import ROOT


def plant(seed=0):
    """A DoE in the unit box of 4 inputs; production in two tight clusters beyond it, the later one larger."""
    rng = np.random.default_rng(seed)
    doe = rng.random((40, 4))
    early = rng.normal([1.6, 0.5, 0.5, 0.5], 0.05, (300, 4))
    late = rng.normal([0.5, 1.7, 0.5, 0.5], 0.05, (700, 4))
    inside = rng.random((200, 4)) * 0.6 + 0.2
    return doe, np.vstack([early, inside, late])


def test_proposals_go_where_production_runs_outside_and_the_share_is_the_rebuilt_gates():
    doe, production = plant()
    settings = enrichment.EnrichmentSettings(n_points=6, n_candidates=50, seed=1)
    proposal = enrichment.propose(doe, production, 5, 95, settings)
    assert proposal.share_before < 0.3
    assert len(proposal.points) >= 2
    # each point sits at one of the two clusters, and both clusters get points
    near_early = np.linalg.norm(proposal.points - [1.6, 0.5, 0.5, 0.5], axis=1) < 0.3
    near_late = np.linalg.norm(proposal.points - [0.5, 1.7, 0.5, 0.5], axis=1) < 0.3
    assert (near_early | near_late).all() and near_early.any() and near_late.any()
    # the recent, larger cluster first
    assert near_late[0]
    # the share after each point is the share of a gate fitted from scratch on the enlarged DoE
    for j, share in enumerate(proposal.share_after, start=1):
        rebuilt = KNNSupportGate(k=5, percentile=95).fit(np.vstack([doe, proposal.points[:j]]))
        assert share == pytest.approx(rebuilt.predict(production).mean())
    assert proposal.share_after[-1] > 0.9
    assert sum(len(rows) for rows in proposal.brought_in) == pytest.approx(
        (proposal.share_after[-1] - proposal.share_before) * len(production), abs=len(production) * 0.05
    )


def test_proposals_counted_in_chunks_of_parts_are_the_same(monkeypatch):
    doe, production = plant()
    settings = enrichment.EnrichmentSettings(n_points=3, n_candidates=50, seed=1)
    whole = enrichment.propose(doe, production, 5, 95, settings)
    monkeypatch.setattr(enrichment, "GAIN_ROWS", 97)  # many chunks, the last one short
    chunked = enrichment.propose(doe, production, 5, 95, settings)
    np.testing.assert_array_equal(chunked.points, whole.points)
    assert chunked.share_after == whole.share_after


def test_proposals_on_a_sample_of_a_long_log_count_its_parts_and_scale_them_to_the_log():
    doe, production = plant()
    settings = enrichment.EnrichmentSettings(n_points=3, n_candidates=50, seed=1, max_rows=400)
    sampled = enrichment.propose(doe, production, 5, 95, settings)
    counted = np.sort(np.random.default_rng(1).choice(len(production), 400, replace=False))
    assert sampled.n_counted == 400 and sampled.n_production == 1200 and sampled.parts_per_counted_part == 3.0
    # shares and the parts brought in are those of the rebuilt gates on the sampled parts, as rows of the log
    before = KNNSupportGate(k=5, percentile=95).fit(doe).predict(production[counted])
    assert sampled.share_before == before.mean()
    for j, rows in enumerate(sampled.brought_in, start=1):
        now = KNNSupportGate(k=5, percentile=95).fit(np.vstack([doe, sampled.points[:j]])).predict(production[counted])
        assert sampled.share_after[j - 1] == pytest.approx(now.mean())
        np.testing.assert_array_equal(rows, counted[now & ~before])
        before = now
    assert sum(map(len, sampled.brought_in)) > 100
    table = enrichment.proposals_table(sampled, pd.DataFrame(production, columns=list("abcd")), list("abcd"))
    assert table["parts_brought_in"].tolist() == [3 * len(rows) for rows in sampled.brought_in]
    assert table["counted_on"].iloc[0].startswith("a seeded sample of 400 of the 1,200 production parts")
    # a cap above the log's length counts every part
    whole = enrichment.propose(doe, production, 5, 95, enrichment.EnrichmentSettings(3, 1.0, 0.05, 50, 1, 5000))
    table = enrichment.proposals_table(whole, pd.DataFrame(production, columns=list("abcd")), list("abcd"))
    assert table["counted_on"].iloc[0] == "all 1,200 production parts"
    assert table["parts_brought_in"].tolist() == [len(rows) for rows in whole.brought_in]


def test_proposals_stay_inside_the_physical_limits():
    doe, production = plant(2)
    low, high = enrichment.physical_limits(doe, production, 0.05)
    proposal = enrichment.propose(doe, production, 5, 95, enrichment.EnrichmentSettings(n_points=4, seed=3))
    assert ((proposal.points >= low) & (proposal.points <= high)).all()


def test_nothing_to_propose_when_every_part_is_in_support_gives_an_empty_table_with_its_header():
    doe, _ = plant()
    production = doe[:30] + 0.001
    proposal = enrichment.propose(doe, production, 5, 95, enrichment.EnrichmentSettings(n_points=5))
    table = enrichment.proposals_table(proposal, pd.DataFrame(production, columns=list("abcd")), list("abcd"))
    assert len(table) == 0
    assert list(table.columns[:5]) == ["proposal", "a", "b", "c", "d"] and "parts_brought_in" in table


@pytest.mark.parametrize("n_points", [0, 201, 2.5])
def test_n_points_out_of_range_is_a_config_error(n_points):
    config = yaml.safe_load((Path(ROOT) / "config/config.yaml").read_text())
    config["enrichment"] = {"n_points": n_points}
    rule = {0: "must be at least 1", 201: "must be at most 200", 2.5: "must be a whole number"}[n_points]
    with pytest.raises(ConfigError, match=f"^config error: enrichment.n_points = {n_points}, {rule}$"):
        check(config)
