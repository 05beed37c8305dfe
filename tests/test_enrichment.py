"""Proposed simulations: where production runs outside the support, on constructed plants."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from hybridtwin import enrichment
from hybridtwin.io.config import ConfigError, check
from hybridtwin.paper.gate import KNNSupportGate
from tests.conftest import says

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
    says(table["counted_on"].iloc[0], "sample", "400", "1,200 production parts")
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


def test_what_a_point_serves_by_hand():
    production = pd.DataFrame(
        {
            "a": np.arange(10.0),
            "timestamp": [f"2026-01-01 {h:02d}:{m:02d}:00" for h, m in zip(range(10), range(0, 50, 5))],
            "coil_id": ["C1", "C1", "C2", "C1", "C3", "C1", "C2", "C2", "C1", "C1"],
            "shift": ["A"] * 10,
            "serial": [f"S{i}" for i in range(10)],  # a level per part: no main level to name
            "strokes": np.arange(10) * 100,  # a number, not an id
        }
    )
    production["grade"] = ["DC04", "DC05", "DC06", "DC04", "DC04", "DC05", "DC06", "DC06", "DC04", "DC04"]
    production["die"] = ["p"] * 10  # an input given as text: an input, not an id
    rows = np.array([2, 3, 5, 9])
    served = enrichment._served(production, rows, ["a", "die"])
    assert served == (
        "rows 3-10; timestamp 2026-01-01 02:10 to 2026-01-01 09:45; coil_id C1 (75%) and 1 more; shift A (100%); "
        "grade DC04 (50%) and 2 more"
    )  # 3 levels among 4 rows are named; the serials (a level each) are not
    # on more rows, a column is named while it has at most half as many levels as rows
    production["grade"] = ["G1", "G2", "G3", "G4", "G1", "G1", "G1", "G1", "G1", "G5"]
    assert "grade G1 (62%) and 3 more" in enrichment._served(production, np.arange(8), ["a"])
    assert "grade" not in enrichment._served(production, np.array([0, 1, 2, 3, 4, 5, 6, 9]), ["a"])  # 5 levels
    assert enrichment._served(production, np.array([], int), ["a"]).startswith("no part on its own")


def test_the_proposals_table_by_hand():
    proposal = enrichment.Proposal(
        points=np.array([[1.0, 2.0], [3.0, 4.0]]),
        brought_in=[np.array([0, 1, 2]), np.array([], int)],
        share_after=[0.5, 0.6],
        share_before=0.4,
        surrogate_std=np.array([0.3, 0.2]),
        share_after_fixed_threshold=[0.55, 0.65],
        n_counted=4,
        n_production=10,
    )
    production = pd.DataFrame({"x": [0.0] * 10, "y": [0.0] * 10, "coil": ["K"] * 10})
    table = enrichment.proposals_table(proposal, production, ["x", "y"])
    assert table.columns.tolist() == [
        "proposal", "x", "y", "parts_brought_in", "share_in_support_after", "share_within_todays_threshold",
        "surrogate_std_here", "serves", "counted_on",
    ]  # fmt: skip
    assert table["proposal"].tolist() == [1, 2] and table[["x", "y"]].to_numpy().tolist() == [[1, 2], [3, 4]]
    assert table["parts_brought_in"].tolist() == [8, 0]  # 3 of 4 counted parts, scaled to the 10 of the log
    assert table["share_in_support_after"].tolist() == [0.5, 0.6]
    assert table["share_within_todays_threshold"].tolist() == [0.55, 0.65]
    assert table["surrogate_std_here"].tolist() == [0.3, 0.2]
    assert table["serves"].tolist() == [
        "rows 1-3; coil K (100%)",
        "no part on its own (prepares a neighbourhood for the next points)",
    ]
    assert table["counted_on"].iloc[0] == (
        "a seeded sample of 4 of the 10 production parts (enrichment.max_rows); "
        "parts_brought_in scaled to the whole log"
    )
    assert table.attrs["share_before"] == 0.4
    # the same from only the text columns at the rows served, indexed by their rows (as a long log is read)
    later = enrichment.Proposal(**{**proposal.__dict__, "brought_in": [np.array([5, 7, 8]), np.array([7], int)]})
    log = production.assign(coil=[f"K{i // 7}" for i in range(10)])
    served = enrichment.served_rows(later)
    assert served.tolist() == [5, 7, 8] and enrichment.served_columns(log, ["x", "y"]) == ["coil"]
    from_part = enrichment.proposals_table(later, log.loc[served, ["coil"]], ["x", "y"])
    pd.testing.assert_frame_equal(from_part, enrichment.proposals_table(later, log, ["x", "y"]))
    assert from_part["serves"].tolist() == ["rows 6-9; coil K1 (67%) and 1 more", "rows 8-8; coil K1 (100%)"]
    whole = enrichment.proposals_table(
        enrichment.Proposal(
            proposal.points, proposal.brought_in, [0.5, 0.6], 0.4, proposal.surrogate_std, [0.5, 0.6], 10, 10
        ),
        production,
        ["x", "y"],
    )
    assert whole["parts_brought_in"].tolist() == [3, 0] and whole["counted_on"].iloc[0] == "all 10 production parts"


def test_weights_limits_and_gains_by_hand():
    np.testing.assert_allclose(enrichment.recency_weights(5, 2.0), [1.0, 1.5, 2.0, 2.5, 3.0])
    assert enrichment.recency_weights(1, 2.0).tolist() == [1.0]
    assert enrichment.recency_weights(2, 2.0).tolist() == [1.0, 3.0]
    low, high = enrichment.physical_limits(np.array([[0.0, 5.0], [2.0, 6.0]]), np.array([[1.0, 4.0], [3.0, 5.0]]), 0.1)
    np.testing.assert_allclose(low, [-0.3, 3.8])
    np.testing.assert_allclose(high, [3.3, 6.2])
    # two parts with their 3 nearest DoE distances, two candidates; threshold 1
    nearest = np.array([[0.5, 1.0, 2.1], [1.0, 1.5, 2.0]])  # means 1.2 and 1.5: both outside
    candidate_distance = np.array([[0.2, 3.0], [0.8, 0.1]])
    weights = np.array([1.0, 3.0])
    count, shortened = enrichment._gain(nearest, candidate_distance, 1.0, weights)
    # with candidate 1: (0.5 + 1.0 + 0.2) / 3 = 0.567 in, (1.0 + 1.5 + 0.8) / 3 = 1.1 still out;
    # candidate 2: part 1 keeps 1.2 (3.0 is farther than its 3rd), part 2 (1.0 + 1.5 + 0.1) / 3 = 0.867 in
    np.testing.assert_allclose(count, [1.0, 3.0])
    np.testing.assert_allclose(shortened, [(1.2 - 1.7 / 3) + 3 * (1.5 - 1.1), 3 * (1.5 - 2.6 / 3)])
    # on the threshold: a part already at it is in (brought by nobody); one brought exactly to it counts
    at = np.array([[0.5, 1.0, 1.5], [1.0, 1.5, 2.0]])
    count, _ = enrichment._gain(at, np.array([[0.1], [0.5]]), 1.0, np.array([1.0, 1.0]))
    assert count.tolist() == [1.0]


def test_gains_summed_over_chunks_of_parts_are_those_of_one_chunk(monkeypatch):
    rng = np.random.default_rng(4)
    reference, parts, candidates = rng.random((20, 2)), rng.random((7, 2)) + 0.5, rng.random((4, 2)) + 0.5
    nearest = enrichment._nearest(reference, parts, 3)
    weights = rng.random(7) + 1
    whole = enrichment._gain(nearest, enrichment.cdist(parts, candidates), 0.3, weights)
    monkeypatch.setattr(enrichment, "GAIN_ROWS", 3)  # chunks of 3, 3 and 1 parts
    chunked = enrichment._chunked_gain(parts, nearest, candidates, 0.3, weights)
    np.testing.assert_allclose(chunked[0], whole[0])
    np.testing.assert_allclose(chunked[1], whole[1])
    assert whole[0].sum() > 0 and whole[1].sum() > 0


def test_each_point_is_counted_with_the_rebuilt_gate_and_with_todays_threshold():
    doe, production = plant()
    k, percentile = 3, 90  # not the gate's defaults
    settings = enrichment.EnrichmentSettings(n_points=3, n_candidates=40, seed=2)
    std = lambda points: points[:, 0] + 1.0  # noqa: E731 (the surrogate's std, known here)
    proposal = enrichment.propose(doe, production, k, percentile, settings, surrogate_std=std)
    today = KNNSupportGate(k=k, percentile=percentile).fit(doe)
    before = today.predict(production)
    assert proposal.share_before == before.mean() and len(proposal.points) == 3
    for j in range(3):
        rebuilt = KNNSupportGate(k=k, percentile=percentile).fit(np.vstack([doe, proposal.points[: j + 1]]))
        now = rebuilt.predict(production)
        assert proposal.share_after[j] == pytest.approx(now.mean())
        # today's gate held: its standardization and threshold, the points added so far among its reference
        held_gate = KNNSupportGate(k=k, percentile=percentile, standardizer=today.standardizer_)
        held = held_gate.fit(np.vstack([doe, proposal.points[: j + 1]])).distance(production) <= today.threshold_
        assert proposal.share_after_fixed_threshold[j] == pytest.approx(held.mean())
        np.testing.assert_array_equal(proposal.brought_in[j], np.flatnonzero(now & ~before))
        before = now
    np.testing.assert_allclose(proposal.surrogate_std, std(proposal.points))
    assert len(np.unique(proposal.points, axis=0)) == 3  # a candidate is taken once


def test_parts_brought_in_decide_and_the_surrogates_doubt_breaks_a_tie():
    # two equal, equally recent clusters beyond the DoE: either point brings as many parts; the surrogate is
    # less sure at one of them, and that one comes first
    rng = np.random.default_rng(0)
    doe = rng.random((40, 2))
    production = np.vstack([rng.normal([2.0, 0.5], 0.02, (100, 2)), rng.normal([0.5, 2.0], 0.02, (100, 2))])
    settings = enrichment.EnrichmentSettings(n_points=1, n_candidates=2, recency_weight=0.0, seed=0)
    for unsure_at, where in ((0, [2.0, 0.5]), (1, [0.5, 2.0])):
        std = lambda points, axis=unsure_at: points[:, axis]  # noqa: E731
        first = enrichment.propose(doe, production, 5, 95, settings, surrogate_std=std).points[0]
        np.testing.assert_allclose(first, where, atol=0.05)
    # with one neighbour, a point brings a whole cluster in: the one of more parts wins over the surrogate's
    # doubt and over the larger distance the other one would remove
    near_many = rng.normal([1.4, 0.5], 0.02, (100, 2))
    far_few = rng.normal([3.0, 3.0], 0.02, (60, 2))
    chosen = enrichment.propose(doe, np.vstack([near_many, far_few]), 1, 95, settings, surrogate_std=lambda p: p[:, 1])
    np.testing.assert_allclose(chosen.points[0], [1.4, 0.5], atol=0.05)
    assert chosen.brought_in[0].tolist() == list(range(100))
    assert enrichment.propose(doe, production, 5, 95, enrichment.EnrichmentSettings(n_points=0)).points.shape == (0, 2)


def test_a_day_first_timestamp_is_read_as_day_first():
    # German Excel writes 04.03.2026 for the 4th of March: read as the 3rd of April, the span was a month off
    production = pd.DataFrame({"a": [0.0, 1.0], "zeit": ["04.03.2026 06:00:00", "05.03.2026 14:30:00"]})
    says(enrichment._served(production, np.array([0, 1]), ["a"]), "zeit 2026-03-04 06:00 to 2026-03-05 14:30")
