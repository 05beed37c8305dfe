"""Prediction intervals by region and the recommended model, on constructed cases with known noise."""

import json

import numpy as np
import pandas as pd
import pytest
from scipy.stats import beta

from hybridtwin.answers import coverage, intervals, regions
from hybridtwin.io import files
from hybridtwin.models import stack
from tests.conftest import says

LEVEL = 0.9
Z90 = 1.6449  # two-sided 90% of a standard normal


def plant(n=40_000, seed=11):
    """Rows in time order: a quarter in support (noise 1), the rest out of it at growing distance,
    where the noise grows with the distance (2 to 4)."""
    rng = np.random.default_rng(seed)
    inside = rng.random(n) < 0.25
    distance = np.where(inside, rng.uniform(0, 1, n), rng.uniform(1, 3, n))
    sd = np.where(inside, 1.0, distance + 1.0)
    truth = np.sin(np.arange(n) / 500.0) * 5
    measured = truth + rng.normal(0, sd)
    return inside, distance, sd, truth, measured


def test_calibration_and_test_rows_alternate_in_blocks():
    calibration = regions.calibration_rows(1000, 10)
    assert calibration.sum() == 500
    assert calibration[:100].all() and not calibration[100:200].any() and calibration[200:300].all()


def test_test_rows_never_reach_the_intervals_or_the_choice():
    inside, distance, sd, truth, measured = plant(n=6000)
    region = regions.regions(inside, np.zeros(len(inside), bool), distance, [2.0])
    calibration = regions.calibration_rows(len(measured), 10)
    honest = {"hybrid": truth, "extended": truth + 0.5}
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [2.0], distance)
    spoiled = np.where(calibration, measured, measured + 1000.0)  # only the test rows change
    again = intervals.RegionIntervals.fit(spoiled, honest, region, calibration, [2.0], distance)
    assert again.ranking == fitted.ranking and again.to_dict() == fitted.to_dict()
    # the furthest calibrated distance is that of an out-of-support calibration row
    assert fitted.max_distance == pytest.approx(distance[calibration & ~inside].max())


def test_a_model_without_a_value_on_a_row_gives_way_to_the_next_in_its_regions_ranking():
    fitted = intervals.RegionIntervals(
        {"extended_hybrid": {"in_support": [0.5] * 50}, "hybrid": {"in_support": [0.6] * 50}},
        {"in_support": ["extended_hybrid", "hybrid"]},
        [],
        None,
    )
    predictions = {
        "extended_hybrid": np.array([1.0, np.nan]),
        "hybrid": np.array([1.1, 1.2]),
        "hybrid_gated": np.array([1.1, 1.2]),
    }
    picked = intervals.recommended_prediction(fitted, predictions, np.array(["in_support"] * 2, object), 0.9)
    assert picked["recommended_model"].tolist() == ["extended_hybrid", "hybrid"]
    assert picked["pred_recommended"].tolist() == [1.0, 1.2]
    assert np.isfinite(picked["pred_lower"]).all()
    bare = intervals.recommended_prediction(fitted, predictions, np.array(["in_support"] * 2, object), 0.9, False)
    pd.testing.assert_frame_equal(bare, picked[["pred_recommended", "recommended_model"]])
    unknown = intervals.recommended_prediction(fitted, predictions, np.array(["out_of_support_1"] * 2, object), 0.9)
    assert unknown["recommended_model"].tolist() == ["hybrid_gated"] * 2 and unknown["pred_lower"].isna().all()


def test_a_row_inside_the_gate_but_beyond_the_doe_range_is_out_of_support():
    labels = regions.regions(
        in_support=[True, True, False, False],
        beyond_range=[False, True, False, False],
        distance=[0.5, 0.6, 1.5, 2.5],
        edges=[2.0],
    )
    assert labels.tolist() == ["in_support", "out_of_support_1", "out_of_support_1", "out_of_support_2"]


def test_a_row_beyond_the_doe_range_inside_the_gate_takes_the_supports_model_and_an_outside_interval():
    # in the gate, "hybrid" is exact and "extended" off by 2; outside it the other way round,
    # with noise 1 in the gate and 3 outside
    rng = np.random.default_rng(3)
    n = 8000
    inside = np.arange(n) % 2 == 0
    beyond = inside & (np.arange(n) % 4 == 0)  # half the gate's rows lie beyond the DoE's range
    distance = np.where(inside, 0.5, 1.5)
    truth = np.zeros(n)
    measured = truth + rng.normal(0, np.where(inside, 1.0, 3.0))
    honest = {"hybrid": np.where(inside, 0.0, 2.0), "extended": np.where(inside, 2.0, 0.0)}
    region = regions.Regions.of(inside, beyond, distance, [])
    assert region.choice[beyond].tolist() == ["in_support"] * beyond.sum()
    assert region.interval[beyond].tolist() == ["out_of_support_1"] * beyond.sum()
    calibration = regions.calibration_rows(n, 10)
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [], distance)
    picked = intervals.recommended_prediction(fitted, fitted.with_stack(honest, region), region, LEVEL)
    in_support_model = fitted.recommended["in_support"]
    assert in_support_model in ("hybrid", "stack") and fitted.recommended["out_of_support_1"] in ("extended", "stack")
    assert set(picked.loc[beyond, "recommended_model"]) == {in_support_model}
    # the beyond-range row's interval comes from the out-of-support errors of its model: wider than in support
    width = (picked["pred_upper"] - picked["pred_lower"]).to_numpy()
    within = inside & ~beyond
    assert width[beyond].mean() > 2 * width[within].mean()
    # the intervals are calibrated in the two interval regions, the ranking made in the two choice regions
    assert fitted.regions == ["in_support", "out_of_support_1"] and sorted(fitted.ranking) == fitted.regions


def test_outside_range_is_in_the_inputs_own_unit_and_named():
    frame = pd.DataFrame({"die_temp_c": [40.0, 58.5, 10.0], "shim_mm": [0.2, 0.2, 0.2]})
    doe_range = {"die_temp_c": (15.0, 55.0), "shim_mm": (0.0, 0.6)}
    beyond = regions.outside_range(frame, doe_range)
    assert beyond["die_temp_c"].tolist() == pytest.approx([0.0, 3.5, -5.0])
    texts = regions.describe_outside(beyond, doe_range)
    assert texts == ["", "die_temp_c 3.5 above the DoE's max 55", "die_temp_c 5 below the DoE's min 15"]
    frame.loc[1, "shim_mm"] = 0.75
    assert regions.describe_outside(regions.outside_range(frame, doe_range), doe_range)[1] == (
        "die_temp_c 3.5 above the DoE's max 55; shim_mm 0.15 above the DoE's max 0.6"
    )
    frame.loc[2, "shim_mm"] = np.nan  # a missing value lies beyond nothing
    assert regions.outside_range(frame, doe_range)["shim_mm"].tolist() == pytest.approx([0.0, 0.15, 0.0])


def test_the_calibration_reads_a_long_log_in_parts_with_the_same_reach(monkeypatch):
    rng = np.random.default_rng(3)
    frame = pd.DataFrame({"a": rng.normal(0, 2, 2500), "b": rng.normal(0, 1, 2500)})
    doe_range = {"a": (-1.0, 1.0), "b": (-1.5, 1.5)}
    counted = (rng.random(2500) < 0.5) & (np.arange(2500) >= 700)  # the first part counts nothing
    every = np.ones(2500, bool)
    whole_beyond = coverage.beyond_range(frame, doe_range)
    whole_extremes, _ = coverage.range_extremes(frame, doe_range, counted, every)
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 700)  # four parts, the last short
    beyond = coverage.beyond_range(frame, doe_range)
    extremes, all_rows = coverage.range_extremes(frame, doe_range, counted, every)
    amounts = regions.outside_range(frame, doe_range)
    assert np.array_equal(beyond, (amounts != 0).any(axis=1).to_numpy()) and np.array_equal(beyond, whole_beyond)
    assert extremes.min().tolist() == amounts[counted].min().tolist() == whole_extremes.min().tolist()
    assert extremes.max().tolist() == amounts[counted].max().tolist() == whole_extremes.max().tolist()
    assert all_rows.min().tolist() == amounts.min().tolist() and all_rows.max().tolist() == amounts.max().tolist()


def _warming_plant(n=4000, blocks=8, seed=4):
    """A plant that warms up: t climbs beyond the DoE's 10 over the log, furthest in its last block (a test block),
    whose parts out of the support also lie further from the DoE than any before."""
    table, _, _ = _predictions_table(n=n, seed=seed)
    t = 10.0 + 3.0 * np.arange(n) / n
    latest = np.arange(n) * blocks // n == blocks - 1
    assert not regions.calibration_rows(n, blocks)[latest].any()
    table.loc[latest & ~table["in_support"].to_numpy(), "knn_distance"] += 0.5
    return table, pd.DataFrame({"t": t}), latest


def test_the_logs_latest_block_reaches_as_far_as_its_parts_though_it_only_tests_the_intervals():
    table, inputs, latest = _warming_plant()
    settings = {"level": 0.8, "distance_bins": 3, "blocks": 8}
    calibrated = coverage.calibrate(table, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0)
    t, distance = inputs["t"].to_numpy(), table["knn_distance"].to_numpy()
    outside = ~table["in_support"].to_numpy()
    # the latest part's setting and the latest block's distance, not the last calibration block's
    assert calibrated.intervals.reach["t"][1] == pytest.approx(t.max() - 10.0)
    assert calibrated.intervals.max_distance == pytest.approx(distance[outside].max())
    assert distance[latest & outside].max() > distance[~latest & outside].max()
    # the daily check judges only as far as the calibration parts lie (it compares a part with their errors)
    calibration = regions.calibration_rows(len(t), 8)
    judging = calibrated.intervals.judging
    assert judging["beyond"]["t"][1] == pytest.approx(t[calibration].max() - 10.0)
    assert judging["beyond"]["t"][1] < t.max() - 10.0
    assert judging["max_distance"] == pytest.approx(distance[calibration & outside].max())
    stored = json.loads(json.dumps(calibrated.intervals.to_dict()))
    assert intervals.RegionIntervals.from_dict(stored).judging == stored["monitor_reach"]
    # the plant's settings as it runs now are judged, with an interval; a setting further than the log's, not
    from hybridtwin.answers.trust import Reach, trust_levels

    doe_range = {"t": (0.0, 10.0)}
    reach = Reach(1.0, calibrated.intervals.max_distance, calibrated.intervals.reach, doe_range, {})
    asked = regions.outside_range(pd.DataFrame({"t": [t[-1], t[-1], t[-1] + 0.5]}), doe_range)
    furthest = distance[outside].max()
    verdicts = trust_levels(np.zeros(3, bool), asked, np.array([furthest, furthest + 0.1, 1.5]), reach)
    assert verdicts.tolist() == ["calibrated", "extrapolation", "extrapolation"]


def test_a_region_no_calibration_part_lies_in_reaches_nothing():
    # every calibration block in the support; only the latest block, a test block, leaves it: no interval was
    # calibrated out of the support, so its parts are no reach (an answer there is an extrapolation)
    table, inputs, latest = _warming_plant()
    table["in_support"] = ~latest
    table.loc[~latest, "knn_distance"] = np.minimum(table.loc[~latest, "knn_distance"], 0.9)
    inputs["t"] = np.where(latest, inputs["t"], 5.0)
    settings = {"level": 0.8, "distance_bins": 3, "blocks": 8}
    calibrated = coverage.calibrate(table, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0)
    assert calibrated.intervals.regions == ["in_support"]
    assert calibrated.intervals.max_distance is None and calibrated.intervals.reach["t"] == (0.0, 0.0)


def test_distance_bins_hold_enough_calibration_rows():
    assert regions.distance_edges(np.linspace(1, 2, 250), 4) == pytest.approx([1.5])  # 250 rows: 2 bins of 100+
    assert regions.distance_edges(np.linspace(1, 2, 50), 4) == []
    assert len(regions.distance_edges(np.linspace(1, 2, 4000), 4)) == 3


def test_intervals_by_region_hold_their_level_where_one_pooled_interval_does_not():
    inside, distance, sd, truth, measured = plant()
    edges = regions.distance_edges(distance[~inside], 4)
    region = regions.regions(inside, np.zeros(len(inside), bool), distance, edges)
    calibration = regions.calibration_rows(len(measured), 20)
    table = coverage.coverage_table(measured, {"hybrid": truth}, region, calibration, edges, 1.0, LEVEL, truth=truth)
    by_region = table[(table["model"] == "hybrid") & (table["calibration"] == "by_region") & (table["region"] != "all")]
    assert len(by_region) == 5
    assert by_region["coverage"].between(LEVEL - 0.02, LEVEL + 0.02).all(), by_region
    # in support the noise is 1: the interval is the normal one, not the pooled (wider) one
    in_support = by_region.set_index("region").loc["in_support"]
    assert in_support["mean_width"] == pytest.approx(2 * Z90, rel=0.06)
    pooled = table[(table["model"] == "hybrid") & (table["calibration"] == "pooled") & (table["region"] != "all")]
    assert pooled.set_index("region").loc["in_support", "coverage"] > LEVEL + 0.05
    assert pooled.set_index("region").loc["out_of_support_4", "coverage"] < LEVEL - 0.05


def test_a_long_log_is_scored_on_a_seeded_sample_of_test_rows_per_region_and_says_so(monkeypatch):
    inside, distance, sd, truth, measured = plant()
    edges = regions.distance_edges(distance[~inside], 4)
    region = regions.regions(inside, np.zeros(len(inside), bool), distance, edges)
    assert region[inside].tolist() == ["in_support"] * inside.sum()
    assert set(region[~inside]) == {f"out_of_support_{b}" for b in range(1, 5)}
    assert (region[~inside & (distance > edges[-1])] == "out_of_support_4").all()
    calibration = regions.calibration_rows(len(measured), 20)
    whole = coverage.coverage_table(measured, {"hybrid": truth}, region, calibration, edges, 1.0, LEVEL, seed=3)
    assert "seeded sample" not in whole["evaluated_on"].iloc[0]
    monkeypatch.setattr(coverage, "MAX_TEST_ROWS", 2000)
    sampled = coverage.coverage_table(measured, {"hybrid": truth}, region, calibration, edges, 1.0, LEVEL, seed=3)
    assert (sampled["n_test"] == 2000).all() and (whole["n_test"] > 2000).all()
    assert "a seeded sample of 2,000 test rows per region" in sampled["evaluated_on"].iloc[0]
    # the sample's coverage estimates the whole's
    assert np.abs(sampled["coverage"] - whole["coverage"]).max() < 0.03
    # by hand: the in-support row of the sample
    rows = intervals.subsample(np.flatnonzero(~calibration & inside), 2000, 3)
    fitted = intervals.RegionIntervals.fit(measured, {"hybrid": truth}, region, calibration, edges, seed=3)
    lower, upper = fitted.interval("hybrid", truth[rows], region[rows], LEVEL)
    row = sampled[(sampled["region"] == "in_support") & (sampled["model"] == "hybrid")].iloc[0]
    assert row["coverage"] == np.mean((measured[rows] >= lower) & (measured[rows] <= upper))
    # a model with values on a few rows only (a peer on a long log) is sampled among those rows
    peer = np.where(np.arange(len(truth)) % 2 == 0, truth, np.nan)
    both = coverage.coverage_table(measured, {"hybrid": truth, "peer": peer}, region, calibration, edges, 1, LEVEL)
    scored = both[(both["model"] == "peer") & (both["region"] != "all") & (both["calibration"] == "by_region")]
    valued = [np.sum(~calibration & (region == name) & np.isfinite(peer)) for name in scored["region"]]
    assert scored["n_test"].tolist() == [min(n, 2000) for n in valued] and max(valued) > 2000


def test_a_distance_on_a_bin_edge_belongs_to_the_nearer_bin():
    labels = regions.regions([True, False, False, False], np.zeros(4, bool), [0.5, 1.0, 2.0, 2.5], [1.0, 2.0])
    assert labels.tolist() == ["in_support", "out_of_support_2", "out_of_support_3", "out_of_support_3"]


def test_the_figure_shows_each_shown_rows_own_error_and_region(monkeypatch):
    inside, distance, sd, truth, measured = plant(n=6000)
    edges = regions.distance_edges(distance[~inside], 3)
    region = regions.Regions.same(regions.regions(inside, np.zeros(len(inside), bool), distance, edges))
    calibration = regions.calibration_rows(len(measured), 20)
    honest = {"hybrid": truth + 0.5}
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, edges, distance, 0)
    table = coverage.coverage_table(measured, honest, region, calibration, edges, 1.0, LEVEL)
    calibrated = coverage.Calibration(fitted, table, region, calibration, fitted.with_stack(honest, region))
    monkeypatch.setattr(coverage, "MAX_TEST_ROWS", 500)  # fewer rows than shown: the shown ones are added
    shown = coverage.figure_data(calibrated, measured, distance, LEVEL, seed=2, n_shown=800)
    test = np.flatnonzero(~calibration)
    rows = np.sort(np.random.default_rng(2).choice(test, 800, replace=False))
    np.testing.assert_allclose(shown["distance"], distance[rows])
    everywhere = intervals.recommended_prediction(fitted, calibrated.honest, region, LEVEL)["pred_recommended"]
    np.testing.assert_allclose(shown["error"], measured[rows] - everywhere.to_numpy()[rows])
    assert shown["region"].tolist() == region.interval[rows].tolist()
    # per region, the interval's median half-width (the shown rows and the sample of MAX_TEST_ROWS) and the
    # recommended model's coverage from the table
    drawn = np.union1d(rows, np.sort(np.random.default_rng(2).choice(len(measured), 500, replace=False)))
    picked = intervals.recommended_prediction(fitted, calibrated.honest, region, LEVEL).iloc[drawn]
    half = ((picked["pred_upper"] - picked["pred_lower"]) / 2).to_numpy()
    for name in fitted.regions:
        assert shown["half_width"][name] == pytest.approx(np.median(half[region.interval[drawn] == name]))
    chosen = table[(table["model"] == "recommended") & (table["calibration"] == "by_region")]
    assert (
        shown["coverage"] == dict(zip(chosen["region"], chosen["coverage"])) and len(shown["coverage"]) == 5
    )  # 4 regions and all


def test_the_recommended_model_is_the_better_one_in_each_region():
    inside, distance, sd, truth, measured = plant()
    rng = np.random.default_rng(5)
    # "hybrid" is good in support and poor outside; "extended" the other way round
    honest = {
        "hybrid": truth + np.where(inside, 0.0, rng.normal(0, 3, len(truth))),
        "extended": truth + np.where(inside, rng.normal(0, 3, len(truth)), 0.0),
        "hybrid_unfiltered": truth,
    }  # perfect, but never recommended (it trained out of support)
    edges = regions.distance_edges(distance[~inside], 2)
    region = regions.regions(inside, np.zeros(len(inside), bool), distance, edges)
    calibration = regions.calibration_rows(len(measured), 20)
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, edges, distance)
    better = {"in_support": "hybrid", "out_of_support_1": "extended", "out_of_support_2": "extended"}
    for name, model in better.items():
        weights = fitted.weights[name]
        # the stack's weights are non-negative and put (almost) everything on the better model
        assert (
            min(weights.values()) >= 0 and weights[model] > 0.95 and sum(weights.values()) == pytest.approx(1, abs=0.05)
        )
        # the recommended model is the better one, or the stack that is all but the better one
        assert fitted.recommended[name] in (model, "stack"), fitted.recommended
    honest = fitted.with_stack(honest, region)
    picked = intervals.recommended_prediction(fitted, honest, region, LEVEL)
    assert picked["recommended_model"].tolist() == [fitted.recommended[r] for r in region]
    assert (picked["pred_lower"] < picked["pred_recommended"]).all()
    assert (picked["pred_upper"] > picked["pred_recommended"]).all()
    # the stored calibration gives the same intervals after a JSON round trip
    again = intervals.RegionIntervals.from_dict(fitted.to_dict())
    repicked = intervals.recommended_prediction(again, honest, region, LEVEL)
    assert np.allclose(repicked["pred_upper"], picked["pred_upper"], atol=1e-5)


def test_a_wider_level_gives_a_wider_interval_and_an_unknown_region_none():
    inside, distance, sd, truth, measured = plant(n=5000)
    region = regions.regions(inside, np.zeros(len(inside), bool), distance, [])
    calibration = regions.calibration_rows(len(measured), 10)
    fitted = intervals.RegionIntervals.fit(measured, {"hybrid": truth}, region, calibration, [], distance)
    narrow = np.subtract(*fitted.interval("hybrid", truth[:5], region[:5], 0.8)[::-1])
    wide = np.subtract(*fitted.interval("hybrid", truth[:5], region[:5], 0.95)[::-1])
    assert (wide > narrow).all()
    lower, upper = fitted.interval("hybrid", truth[:2], np.array(["out_of_support_9", "in_support"], object), 0.9)
    assert np.isnan(lower[0]) and np.isfinite(lower[1])


def test_the_choice_compares_models_on_the_same_parts():
    # the peer is worse (1.0 against 0.3 mm), but it has values only on the quiet half of the parts;
    # scored each on its own parts, the noise of those parts would pick it
    rng = np.random.default_rng(0)
    n = 2000
    noise = np.where(np.arange(n) < n // 2, 3.0, 0.5)
    truth = rng.normal(0, 3, n)
    measured = truth + rng.normal(0, 1, n) * noise
    candidates = {
        "hybrid": truth + rng.normal(0, 0.3, n),
        "gp_discrepancy": np.where(np.arange(n) < n // 2, np.nan, truth + rng.normal(0, 1.0, n)),
    }
    assert intervals._ranking(measured, candidates, np.arange(n)) == ["hybrid", "gp_discrepancy"]


def _half_width(errors, level: float, delta: float = 0.1) -> float:
    """Training-conditional split-conformal half-width by hand: the k-th smallest calibration error for the
    smallest k whose coverage, Beta(k, n + 1 - k), falls below ``level`` with probability at most ``delta``."""
    errors = np.sort(np.round(np.asarray(errors, float), 6))
    n = len(errors)
    k = next(k for k in range(1, n + 1) if beta.cdf(level, k, n + 1 - k) <= delta)
    return float(errors[k - 1])


def _predictions_table(n=4000, seed=2):
    """A production predictions table in time order: a third in the gate, 5% of those beyond the DoE's range in
    input t (10 to 12, DoE 0 to 10); each model's honest error of its own size, growing away from the DoE."""
    rng = np.random.default_rng(seed)
    distance = rng.uniform(0, 3, n)
    inside = distance < 1
    t = np.where(inside & (rng.random(n) < 0.05), rng.uniform(10, 12, n), rng.uniform(0, 10, n))
    truth = rng.normal(0, 5, n)
    measured = truth + rng.normal(0, 1, n)
    grow = 1 + distance
    table = pd.DataFrame(
        {
            "in_support": inside,
            "knn_distance": distance,
            "measured": measured,
            "pred_surrogate": truth + rng.normal(0, 4, n),
            "pred_hybrid_oof": truth + rng.normal(0, 1, n) * grow,
            "pred_hybrid_unfiltered_oof": truth,
            "pred_extended_oof": truth + rng.normal(0, 2, n),
            "pred_extended_hybrid_oof": truth + rng.normal(0, 0.5, n) * grow,
        }
    )
    return table, pd.DataFrame({"t": t}), truth


def test_calibrate_by_hand_regions_honest_predictions_and_the_table():
    table, inputs, truth = _predictions_table()
    n, level = len(table), 0.8
    settings = {"level": level, "distance_bins": 3, "blocks": 8}
    calibrated = coverage.calibrate(table, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0, truth=truth)
    inside = table["in_support"].to_numpy()
    beyond = inputs["t"].to_numpy() > 10
    distance, measured = table["knn_distance"].to_numpy(), table["measured"].to_numpy()
    calibration = (np.arange(n) // (n // 8)) % 2 == 0
    assert np.array_equal(calibrated.calibration, calibration)
    # bins: equal-count over the calibration rows out of the support; the gate's rows beyond the DoE's range
    # (too few for a region of their own here) take the nearest bin's interval
    outside = calibration & ~inside
    edges = np.quantile(distance[outside], [1 / 3, 2 / 3])
    region = np.where(
        inside & ~beyond, "in_support", [f"out_of_support_{b}" for b in np.searchsorted(edges, distance, "right") + 1]
    )
    region[inside & beyond] = "out_of_support_1"
    assert 0 < np.sum(calibration & inside & beyond) < 100 and not calibrated.intervals.beyond_region
    assert calibrated.region.interval.tolist() == region.tolist()
    assert calibrated.region.choice.tolist() == np.where(inside, "in_support", region).tolist()
    # the paper's gated hybrid: the residual model in the gate, the surrogate outside it
    honest = calibrated.honest
    gated = np.where(inside, table["pred_hybrid_oof"], table["pred_surrogate"])
    assert np.array_equal(honest["hybrid_gated"], gated)
    for model in ("surrogate", "hybrid", "hybrid_unfiltered", "extended", "extended_hybrid"):
        column = "pred_surrogate" if model == "surrogate" else f"pred_{model}_oof"
        assert np.array_equal(honest[model], table[column].to_numpy()), model
    assert "gp_discrepancy" not in honest and "cokriging" not in honest  # a run without peers
    # every table row by hand for two models: the interval from the region's calibration errors, scored on its test rows
    rows = calibrated.table.set_index(["region", "model", "calibration"])
    assert set(calibrated.table["region"]) == {
        "in_support",
        "out_of_support_1",
        "out_of_support_2",
        "out_of_support_3",
        "all",
    }
    # every logged part lies within the log's own reach: each test row is scored
    # out of the support, widened where the corrections disagree more than on the calibration parts
    corrections = ("pred_hybrid_oof", "pred_extended_oof", "pred_extended_hybrid_oof")
    spread = np.std(table[list(corrections)].to_numpy(), axis=1)
    for name in ("in_support", "out_of_support_1", "out_of_support_3"):
        for model in ("hybrid", "surrogate"):
            prediction = honest[model]
            cal = calibration & (region == name)
            test = ~calibration & (region == name)
            errors = np.abs(measured[cal] - prediction[cal])
            half = _half_width(errors, level)
            if name != "in_support":
                floor = 2 * np.median(spread[cal])
                local = _half_width(errors / (spread[cal] + floor), level) * (spread[test] + floor)
                half = np.maximum(half, local)
                assert (local > _half_width(errors, level)).any() and (local < _half_width(errors, level)).any()
            row = rows.loc[(name, model, "by_region")]
            assert row["n_test"] == test.sum() and row["n_calibration"] == cal.sum()
            assert row["coverage"] == pytest.approx(np.mean(np.abs(measured[test] - prediction[test]) <= half))
            assert row["coverage_truth"] == pytest.approx(np.mean(np.abs(truth[test] - prediction[test]) <= half))
            assert row["mean_width"] == pytest.approx(np.mean(2 * half), abs=1e-5)
            assert row["rmse_test"] == pytest.approx(np.sqrt(np.mean((measured[test] - prediction[test]) ** 2)))
            assert row["rmse_truth_test"] == pytest.approx(np.sqrt(np.mean((truth[test] - prediction[test]) ** 2)))
            assert row["nominal_level"] == level
            covered, n_test = round(row["coverage"] * row["n_test"]), row["n_test"]
            assert row["coverage_low"] == pytest.approx(beta.ppf(0.025, covered, n_test - covered + 1))
            assert row["coverage_high"] == pytest.approx(beta.ppf(0.975, covered + 1, n_test - covered))
            # one pooled calibration: every calibration row's error
            pooled = _half_width(np.abs(measured[calibration] - prediction[calibration]), level)
            assert rows.loc[(name, model, "pooled"), "mean_width"] == pytest.approx(2 * pooled, abs=1e-5)
    assert rows.loc[("in_support", "hybrid", "by_region"), "region_label"] == "in support"
    assert rows.loc[("out_of_support_1", "hybrid", "by_region"), "region_label"] == (
        f"out of support, distance up to {edges[0]:.3g} (threshold 1)"
    )
    assert rows.loc[("out_of_support_3", "hybrid", "by_region"), "region_label"] == (
        f"out of support, distance above {edges[1]:.3g}"
    )
    assert rows.loc[("all", "hybrid", "by_region"), "n_test"] == (~calibration).sum()
    # the recommended model: its flag on its own row and on the 'recommended' rows only
    flagged = calibrated.table[calibrated.table["recommended"]]
    for name, model in calibrated.intervals.recommended.items():
        assert set(flagged[flagged["region"] == name]["model"]) == {model, "recommended"}
    assert "hybrid_unfiltered" not in calibrated.intervals.recommended.values()  # reported, never recommended
    # each region's ranking (the stack aside) by hand: RMSE on the region's calibration rows, chosen as in support
    # for the rows beyond the DoE's range inside the gate
    choice = np.where(inside, "in_support", region)
    for name, ranking in calibrated.intervals.ranking.items():
        cal = calibration & (choice == name)
        scores = {
            m: np.sqrt(np.mean((measured[cal] - honest[m][cal]) ** 2))
            for m in ("surrogate", "hybrid_gated", "hybrid", "extended", "extended_hybrid")
        }
        assert [m for m in ranking if m != "stack"] == sorted(scores, key=scores.get), name
    assert calibrated.intervals.max_distance == pytest.approx(distance[~inside].max())  # test rows too
    assert calibrated.table["evaluated_on"].str.endswith("against the demo's noise-free plant").all()
    assert rows.loc[("out_of_support_2", "hybrid", "by_region"), "region_label"] == (
        f"out of support, distance {edges[0]:.3g} to {edges[1]:.3g}"
    )
    # one distance bin, no truth
    one_bin = coverage.calibrate(table, inputs, {"t": (0.0, 10.0)}, 1.0, {**settings, "distance_bins": 1}, 0).table
    assert set(one_bin["region"]) == {"in_support", "out_of_support_1", "all"}
    labels = dict(zip(one_bin["region"], one_bin["region_label"]))
    assert labels["out_of_support_1"] == "out of support (every distance)"
    assert labels["all"] == "all production rows"
    assert "coverage_truth" not in one_bin and "rmse_truth_test" not in one_bin
    says(one_bin["evaluated_on"].iloc[0], "test rows", "odd blocks", "even blocks", "out of period", "calibrated")


def test_the_stack_is_cross_fitted_on_each_regions_calibration_rows_by_hand():
    from scipy.optimize import nnls

    rng = np.random.default_rng(6)
    n = 3000
    inside = np.arange(n) < 2700  # in support 1,350 calibration rows; out of it 300 rows, 150 of them calibrating
    truth = rng.normal(0, 4, n)
    measured = truth + rng.normal(0, 1, n)
    honest = {
        "hybrid": truth + rng.normal(0, 1.0, n),
        "extended": truth + rng.normal(0, 1.5, n),
        "surrogate": 0.5 * truth,
        "hybrid_unfiltered": truth,  # no stack member: never recommended
    }
    region = regions.regions(inside, np.zeros(n, bool), np.where(inside, 0.5, 2.0), [])
    calibration = regions.calibration_rows(n, 20)
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [], None)
    members = ["extended", "hybrid", "surrogate"]
    rows = np.flatnonzero(calibration & inside)
    X = np.column_stack([honest[m] for m in members])
    weights, _ = nnls(X[rows], measured[rows])
    assert list(fitted.weights) == ["in_support"]  # too few calibration rows outside for a stack
    assert fitted.weights["in_support"] == pytest.approx(dict(zip(members, weights)))
    # cross-fitted on whole choosing blocks: each even block's rows blended with the weights fitted on the other
    # even blocks of the region (20 blocks of 150 rows; in support the even ones of the first 18)
    block = np.arange(n) // 150
    stack = np.empty(n)
    for b in range(0, 18, 2):
        held, rest = rows[block[rows] == b], rows[block[rows] != b]
        stack[held] = X[held] @ nnls(X[rest], measured[rest])[0]
    np.testing.assert_allclose(
        fitted.calibration["stack"]["in_support"], np.round(np.abs(measured[rows] - stack[rows]), 6), atol=2e-6
    )
    assert "stack" not in fitted.ranking["out_of_support_1"] and "stack" in fitted.ranking["in_support"]
    scores = {m: np.sqrt(np.mean((measured[rows] - p[rows]) ** 2)) for m, p in {**honest, "stack": stack}.items()}
    expected = sorted((m for m in scores if m != "hybrid_unfiltered"), key=scores.get)
    assert fitted.ranking["in_support"] == expected
    # the stack's gain over the hybrid is beyond doubt on its nine blocks: it is chosen, the guard let it stand
    gains = [
        np.mean((measured[at] - honest["hybrid"][at]) ** 2) - np.mean((measured[at] - stack[at]) ** 2)
        for at in (rows[block[rows] == b] for b in range(0, 18, 2))
    ]
    assert expected[0] == "stack" and sum(g > 0 for g in gains) >= 8
    # a new row is blended with the weights of all the region's rows; a region without a stack gives NaN
    blended = fitted.with_stack(honest, region)["stack"]
    np.testing.assert_allclose(blended[inside], X[inside] @ weights)
    assert np.isnan(blended[~inside]).all()


@pytest.mark.parametrize("n", [30, 60, 150, 1000])
def test_the_interval_holds_its_level_on_nine_calibration_draws_in_ten_however_few_the_parts(n):
    # normal errors: a half-width h covers 2*Phi(h) - 1 of new parts; over 2,000 seeded calibration draws the
    # rule's intervals cover at least 90% in at least 90% of the draws, and the plain quantile's in about half
    from scipy.stats import norm

    rng = np.random.default_rng(n)
    draws = np.abs(rng.normal(size=(2000, n)))
    rank, plain = intervals.conformal_rank(n, 0.9), int(np.ceil((n + 1) * 0.9))
    sorted_draws = np.sort(draws, axis=1)
    covers = 2 * norm.cdf(sorted_draws[:, rank - 1]) - 1
    plain_covers = 2 * norm.cdf(sorted_draws[:, plain - 1]) - 1
    assert np.mean(covers >= 0.9) >= 0.88
    assert 0.3 < np.mean(plain_covers >= 0.9) < 0.75
    assert intervals.conformal_rank(n, 0.9, delta=0.5) in (plain - 1, plain)  # the median draw: the plain quantile


def test_out_of_support_the_interval_widens_where_the_corrections_disagree_more_than_where_it_was_calibrated():
    # a part's error grows with the corrections' disagreement there (plus the floor: twice its median on the
    # calibration parts); the calibration parts disagree by 0.2 to 1, the parts asked about by 1 to 3: the plain
    # interval covers them far below its level, the widened one at it; where they disagree as little as the
    # calibration parts, it is the plain one
    rng = np.random.default_rng(3)
    calibrating, asked = rng.uniform(0.2, 1.0, 3000), rng.uniform(1.0, 3.0, 3000)
    floor = intervals.SPREAD_FLOOR * np.median(calibrating)
    errors, new_errors = (rng.normal(0, 0.5, 3000) * (spread + floor) for spread in (calibrating, asked))
    region = "out_of_support_1"
    fitted = intervals.RegionIntervals(
        {"m": {region: list(np.abs(errors))}}, {}, [], None, spreads={"regions": {region: list(calibrating)}}
    )
    regions_asked = np.full(3000, region, object)
    lower, upper = fitted.interval("m", np.zeros(3000), regions_asked, 0.9, asked)
    _, plain_upper = fitted.interval("m", np.zeros(3000), regions_asked, 0.9)
    assert np.mean(np.abs(new_errors) <= upper) >= 0.9 > 0.8 > np.mean(np.abs(new_errors) <= plain_upper)
    assert np.all(upper > plain_upper) and np.array_equal(lower, -upper)
    assert fitted.interval("m", [0.0], [region], 0.9, [0.2])[1][0] == plain_upper[0]
    # where a correction has no value on the row, or they agreed on every calibration part, the plain interval
    assert fitted.interval("m", [0.0], [region], 0.9, [np.nan])[1][0] == plain_upper[0]
    agreed = intervals.RegionIntervals(
        {"m": {region: list(np.abs(errors))}}, {}, [], None, spreads={"regions": {region: [0.0] * 3000}}
    )
    assert agreed.interval("m", [0.0], [region], 0.9, [1.0])[1][0] == plain_upper[0]


def test_a_model_scored_on_some_calibration_parts_is_weighted_by_the_disagreement_of_those_parts():
    # model m has a value on every other part; the corrections lack one on a few (not weighted there)
    rng = np.random.default_rng(8)
    n = 4000
    measured = rng.normal(0, 1, n)
    spread_true = rng.uniform(0.1, 2.0, n)
    honest = {
        "hybrid": measured + rng.normal(0, 1, n),
        "extended": measured + rng.normal(0, 1, n),
        "extended_hybrid": measured + rng.normal(0, 1, n),
        "m": np.where(np.arange(n) % 2 == 0, measured + rng.normal(0, 1, n) * spread_true, np.nan),
    }
    honest["extended"][:40] = np.nan
    region = regions.Regions.same(np.full(n, "out_of_support_1", object))
    calibration = regions.calibration_rows(n, 4)
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [], seed=0)
    spread = intervals.disagreement(honest)
    # by hand: m's calibration parts with a disagreement, their errors scaled by it plus twice its median
    rows = np.flatnonzero(calibration & np.isfinite(honest["m"]) & np.isfinite(spread))
    floor = 2 * np.median(np.round(spread[rows], 6))
    scores = np.round(np.abs(measured[rows] - honest["m"][rows]), 6) / (np.round(spread[rows], 6) + floor)
    asked = np.array([0.1, 1.0, 3.0])
    _, upper = fitted.interval("m", np.zeros(3), np.full(3, "out_of_support_1", object), 0.9, asked)
    plain = fitted.half_width("m", "out_of_support_1", 0.9)
    expected = np.maximum(plain, _half_width(scores, 0.9) * (asked + floor))
    np.testing.assert_allclose(upper, expected, rtol=1e-5)
    assert fitted.typical_spread("m", "out_of_support_1") == pytest.approx(floor / 2)
    # a region of too few parts for the level gives no interval, weighted or not
    few = intervals.RegionIntervals({"m": {"r": [1.0] * 10}}, {}, [], None, spreads={"regions": {"r": [0.5] * 10}})
    assert np.isnan(few.interval("m", [0.0], ["r"], 0.9, [1.0])[1][0])


def test_the_disagreement_is_that_of_the_corrections_and_none_without_one():
    predictions = {
        "hybrid": np.array([1.0, 2.0]),
        "extended": np.array([3.0, 2.0]),
        "extended_hybrid": np.array([2.0, 2.0]),
    }
    np.testing.assert_allclose(intervals.disagreement({**predictions, "surrogate": np.zeros(2)}), [np.sqrt(2 / 3), 0])
    assert intervals.disagreement({"hybrid": np.ones(2)}) is None
    assert regions.is_outside("out_of_support_2") and regions.is_outside(regions.BEYOND_RANGE)
    assert not regions.is_outside("in_support") and not regions.is_outside("all")


def test_too_few_calibration_parts_for_the_level_give_no_interval():
    assert intervals.min_calibration_rows(0.9) == 22 and intervals.min_calibration_rows(0.99) == 230
    assert intervals.conformal_rank(21, 0.9) is None and intervals.conformal_rank(22, 0.9) == 22
    fitted = intervals.RegionIntervals({"hybrid": {"in_support": list(np.arange(30.0))}}, {}, [], None)
    assert np.isnan(fitted.interval("hybrid", [1.0], ["in_support"], 0.99)[0][0])  # 30 parts: not for 99%
    lower, upper = fitted.interval("hybrid", [1.0], ["in_support"], 0.9)
    assert upper[0] - 1.0 == 29.0  # the 30th smallest of 30 errors 0..29


def test_gate_rows_beyond_a_doe_range_get_an_interval_region_of_their_own_when_enough_calibrate_it():
    table, inputs, _ = _predictions_table(seed=3)
    inside = table["in_support"].to_numpy()
    t = inputs["t"].to_numpy().copy()
    t[inside & (np.arange(len(t)) % 3 == 0)] = 11.0  # a third of the gate's parts, beyond the DoE's 10
    settings = {"level": 0.8, "distance_bins": 3, "blocks": 8}
    calibrated = coverage.calibrate(table, pd.DataFrame({"t": t}), {"t": (0.0, 10.0)}, 1.0, settings, 0)
    beyond = inside & (t > 10)
    assert calibrated.intervals.beyond_region
    assert set(calibrated.region.interval[beyond]) == {"beyond_doe_range"}  # its interval: from parts like it
    assert set(calibrated.region.choice[beyond]) == {"in_support"}  # its model: the support's, which learnt them
    labels = dict(zip(calibrated.table["region"], calibrated.table["region_label"]))
    says(labels["beyond_doe_range"], "inside the gate", "beyond a DoE range")


def test_the_choice_is_the_lowest_error_on_the_choosing_blocks_however_small_the_margin():
    # ten choosing blocks of 200 parts; the extended hybrid's errors are a little smaller than the GP discrepancy's
    # in total, on two blocks only (a campaign it happens to suit): its lower error on the choosing blocks chooses
    # it (a guard that kept the simpler model within the noise cost up to 3 times the truth-RMSE in support on the
    # bi-fidelity functions: docs, benchmarks)
    rng = np.random.default_rng(5)
    n = 4000
    calibration = regions.calibration_rows(n, 20)
    block = np.arange(n) // 200
    truth = rng.normal(0, 3, n)
    measured = truth + rng.normal(0, 1, n)
    gp = truth + rng.normal(0, 0.4, n)
    lucky = np.isin(block, [0, 2])
    extended = np.where(lucky, truth, gp)  # elsewhere the same errors
    honest = {"gp_discrepancy": gp, "extended_hybrid": extended, "surrogate": 0.5 * truth}
    region = np.full(n, "in_support", dtype=object)
    rows = np.flatnonzero(calibration)
    rmse_of = {m: np.sqrt(np.mean((measured[rows] - p[rows]) ** 2)) for m, p in honest.items()}
    assert rmse_of["extended_hybrid"] < rmse_of["gp_discrepancy"] < rmse_of["surrogate"]
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [])
    # every model (the stack's cross-fitted errors too) ranked by its RMSE on the choosing rows, the lowest chosen
    scored = {m: np.sqrt(np.mean(np.square(e["in_support"]))) for m, e in fitted.calibration.items()}
    assert fitted.ranking["in_support"] == sorted(scored, key=scored.get)
    assert fitted.recommended["in_support"] == min(scored, key=scored.get) != "gp_discrepancy"
    assert fitted.ranking["in_support"].index("extended_hybrid") < fitted.ranking["in_support"].index("gp_discrepancy")
    # the test rows decide nothing: the same choice whatever they hold
    scrambled = {m: np.where(calibration, p, rng.normal(0, 9, n)) for m, p in honest.items()}
    assert intervals.RegionIntervals.fit(measured, scrambled, region, calibration, []).ranking == fitted.ranking
    # in a tie, the order of the registry's models decides
    tie = {"extended_hybrid": gp.copy(), "gp_discrepancy": gp.copy()}
    assert intervals._ranking(measured, tie, rows) == ["extended_hybrid", "gp_discrepancy"]
    assert intervals._ranking(measured, dict(reversed(tie.items())), rows) == ["extended_hybrid", "gp_discrepancy"]
    assert stack.choosing_blocks(calibration)[[0, 199, 200, 400, 3999]].tolist() == [0, 0, -1, 1, -1]


def test_the_table_says_whether_each_regions_choice_held_on_its_test_blocks():
    rng = np.random.default_rng(2)
    n = 4000
    truth = rng.normal(0, 3, n)
    measured = truth + rng.normal(0, 1, n)
    calibration = regions.calibration_rows(n, 20)
    # the hybrid is better on the choosing blocks only: its choice does not hold on the test blocks
    hybrid = np.where(calibration, truth + rng.normal(0, 0.1, n), truth + rng.normal(0, 1.5, n))
    honest = {"hybrid": hybrid, "gp_discrepancy": truth + rng.normal(0, 0.5, n)}
    region = np.full(n, "in_support", dtype=object)
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [])
    best = coverage.best_on_test(measured, honest, region, calibration, fitted)
    assert fitted.recommended == {"in_support": "hybrid"} and best == {"in_support": "gp_discrepancy"}


def test_stored_intervals_reload_to_the_same_answers_and_older_files_read_as_before_their_keys():
    import json

    from hybridtwin.answers import trust

    inside, distance, _, truth, measured = plant(n=8000, seed=4)
    rng = np.random.default_rng(4)
    beyond_range = inside & (rng.random(len(inside)) < 0.3)  # in the gate, beyond a DoE range
    region = regions.Regions.of(inside, beyond_range, distance, [2.0], beyond_region=True)
    calibration = regions.calibration_rows(len(inside), 40)
    honest = {"hybrid": truth + rng.normal(0, 1.5, len(truth)), "gp_discrepancy": truth + rng.normal(0, 1, len(truth))}
    honest |= {
        "extended": truth + rng.normal(0, 1, len(truth)),
        "extended_hybrid": truth + rng.normal(0, 1, len(truth)),
    }
    reach = trust.Reach(1.0, 2.9, {"t": (-0.5, 0.7)}, {"t": (0.0, 1.0)}, {"t": "mm"})
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [2.0], distance, reach=reach)
    assert fitted.beyond_region and fitted.weights and fitted.max_distance == 2.9 and fitted.reach == reach.beyond
    # the corrections' disagreement on the calibration parts out of the support, stored (what the predictor reads)
    assert set(fitted.spreads["regions"]) == {"out_of_support_1", "out_of_support_2", regions.BEYOND_RANGE}
    stored = json.loads(json.dumps(fitted.to_dict()))
    again = intervals.RegionIntervals.from_dict(stored)
    assert json.loads(json.dumps(again.to_dict())) == stored
    answers, again_answers = (
        intervals.recommended_prediction(model, model.with_stack(honest, region), region, LEVEL)
        for model in (fitted, again)
    )
    pd.testing.assert_frame_equal(answers, again_answers)
    assert answers["pred_lower"].notna().all()
    # a file written before the stack, the calibrated reach and the region beyond the DoE's ranges were stored
    later_keys = ("stack_weights", "calibrated_reach", "beyond_region", "calibration_spreads", "monitor_reach")
    older = intervals.RegionIntervals.from_dict({key: value for key, value in stored.items() if key not in later_keys})
    assert older.weights == {} and older.reach == {} and older.beyond_region is False and older.spreads == {}
    assert older.judging is None


def test_models_without_a_row_in_common_are_each_ranked_on_their_own_rows():
    from hybridtwin.models import registry

    rng = np.random.default_rng(6)
    truth = rng.normal(0, 3, 400)
    measured = truth + rng.normal(0, 1, 400)
    first_half = np.arange(400) < 200
    early, late = registry.RECOMMENDABLE[0], registry.RECOMMENDABLE[1]
    candidates = {
        early: np.where(first_half, truth + rng.normal(0, 2, 400), np.nan),  # the worse, first in the registry
        late: np.where(first_half, np.nan, truth),
    }
    assert intervals._ranking(measured, candidates, np.arange(400)) == [late, early]


def test_a_region_with_fewer_parts_than_two_stack_fits_gets_no_stack_but_its_intervals():
    from hybridtwin.answers.regions import MIN_CALIBRATION_ROWS

    rng = np.random.default_rng(7)
    n = 4 * MIN_CALIBRATION_ROWS - 2  # half of it calibrates: one part short of the stack's two fits
    truth = rng.normal(0, 3, n)
    measured = truth + rng.normal(0, 1, n)
    honest = {"hybrid": truth + rng.normal(0, 0.5, n), "gp_discrepancy": truth + rng.normal(0, 0.8, n)}
    region = np.full(n, "in_support", dtype=object)
    calibration = np.arange(n) % 2 == 0
    assert calibration.sum() == 2 * MIN_CALIBRATION_ROWS - 1
    fitted = intervals.RegionIntervals.fit(measured, honest, region, calibration, [])
    assert fitted.weights == {} and "stack" not in fitted.calibration
    assert set(fitted.calibration) == {"hybrid", "gp_discrepancy"} and fitted.ranking["in_support"][0] == "hybrid"
    one_more = np.r_[calibration, True]
    grown_honest = {m: np.r_[p, 0.0] for m, p in honest.items()}
    grown_region = np.append(region, "in_support")
    grown = intervals.RegionIntervals.fit(np.r_[measured, 0.0], grown_honest, grown_region, one_more, [])
    assert set(grown.weights) == {"in_support"}  # at twice the least calibration, the stack is fitted


def test_a_subsample_is_distinct_sorted_calibration_rows_and_the_seed_s():
    rows = np.arange(0, 300, 3)
    drawn = intervals.subsample(rows, 60, seed=2)
    assert len(np.unique(drawn)) == 60 and np.isin(drawn, rows).all() and (np.diff(drawn) > 0).all()
    assert np.array_equal(intervals.subsample(rows, 60, seed=2), drawn)
    assert np.array_equal(intervals.subsample(rows, 100, seed=2), rows)


def test_a_blend_takes_the_members_of_non_zero_weight_whatever_their_weight():
    assert stack.members({"hybrid": 1.0, "gp_discrepancy": 0.0, "cokriging": -0.2}) == ["hybrid", "cokriging"]
    predictions = {"hybrid": np.array([1.0, 2.0]), "cokriging": np.array([10.0, 20.0])}  # no GP value needed
    blended = stack.blend({"hybrid": 1.0, "gp_discrepancy": 0.0, "cokriging": -0.2}, predictions, np.array([1]))
    assert blended.tolist() == pytest.approx([2.0 - 4.0])


def test_the_answers_read_only_their_columns_of_the_step_files_with_the_same_calibration(tmp_path):
    from hybridtwin import pipeline

    table, inputs, truth = _predictions_table()
    # columns of the steps' files that the answers never read: they are left on disk
    unread = pd.DataFrame({"row": np.arange(len(table)), "pred_hybrid": 0.0, "residual_approx": 1.0})
    hybrid, extension = tmp_path / "hybrid.parquet", tmp_path / "extension.parquet"
    extended = ["pred_extended_oof", "pred_extended_hybrid_oof"]
    pd.concat([unread, table.drop(columns=extended)], axis=1).to_parquet(hybrid)
    table[extended].assign(pred_extended=0.0).to_parquet(extension)
    peer = tmp_path / "peer.parquet"
    honest_peer = table["measured"] + np.random.default_rng(3).normal(0, 0.7, len(table))
    pd.DataFrame({"pred_gp_discrepancy": 0.0, "pred_gp_discrepancy_oof": honest_peer}).to_parquet(peer)
    table["pred_gp_discrepancy_oof"] = honest_peer
    read = pipeline.read_predictions(hybrid, extension, [peer], intervals.answer_columns())
    assert sorted(read.columns) == sorted(table.columns)
    settings = {"level": 0.8, "distance_bins": 3, "blocks": 8}
    expected = coverage.calibrate(table, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0, truth=truth).table
    got = coverage.calibrate(read, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0, truth=truth).table
    pd.testing.assert_frame_equal(got, expected)


def test_the_production_reach_standardizes_only_the_parts_it_keeps_with_the_same_fit():
    from hybridtwin import pipeline
    from hybridtwin.answers.novelty import ProductionNeighbourhood
    from hybridtwin.paper.gate import KNNSupportGate

    rng = np.random.default_rng(5)
    doe = pd.DataFrame(rng.normal(size=(40, 3)), columns=["a", "b", "c"])
    log = pd.DataFrame(rng.normal(size=(6000, 3)) * [1, 2, 3], columns=["a", "b", "c"])
    gate = KNNSupportGate().fit(doe)
    spec = pipeline.Spec(inputs=("a", "b", "c"), seed=7)
    reach = pipeline.production_reach(log, gate, spec, n_blocks=10)
    whole = ProductionNeighbourhood(n_blocks=10, seed=7).fit(gate.standardizer_.transform(log))
    assert len(reach.parts_) == 2000 < len(log)
    assert np.array_equal(reach.parts_, whole.parts_) and reach.threshold_ == whole.threshold_


def test_the_intervals_step_reads_the_answers_columns_then_the_monitors_in_the_files_order(tmp_path):
    from hybridtwin import pipeline

    stamps = pd.date_range("2026-01-01", periods=300, freq="min").strftime("%Y-%m-%d %H:%M:%S")
    log = pd.DataFrame(
        {
            "timestamp": stamps,
            "coil": np.repeat(["c1", "c2", "c3"], 100),
            "a": np.arange(300.0),
            "stroke": np.arange(300),
            "b": np.linspace(0, 1, 300),
            "y": 1.0,
        }
    )
    path = tmp_path / "production.parquet"
    log.to_parquet(path)
    spec = pipeline.Spec(inputs=("a",), target="y")
    answered = pipeline.answers_log(path, spec, ["b"])
    assert list(answered.columns) == ["a", "b"]
    monitored = pipeline.monitor_log(path, spec, ["b"], answered)
    # every column but the target and the timestamps, in the file's order, as read whole
    pd.testing.assert_frame_equal(monitored, files.read_checked(path, ["coil", "a", "stroke", "b"]))
    for bare in (tmp_path / "bare.parquet", tmp_path / "bare.csv"):  # nothing but what the answers read
        files.write_table(log[["a", "b", "y"]], bare)
        got = pipeline.monitor_log(bare, spec, ["b"], pipeline.answers_log(bare, spec, ["b"]))
        assert list(got.columns) == ["a", "b"] and len(got) == 300


def test_a_region_whose_interval_fell_short_on_its_test_parts_is_named_with_its_counts():
    def recommended(region, covered, n, model="recommended", calibration="by_region"):
        high = coverage.clopper_pearson(covered, n)[1]  # as the table writes it
        row = {"region": region, "model": model, "calibration": calibration, "coverage": covered / n}
        return row | {"n_test": n, "coverage_high": high}

    table = pd.DataFrame(
        [
            recommended("out_of_support_4", 32, 66),  # 48%: its 95% interval reaches 61%
            recommended("out_of_support_1", 59, 66),  # 89.4%: it reaches 95.6%, no shortfall beyond doubt
            recommended("in_support", 6_230, 7_000),  # 89.0% of many: its 95% interval ends at 89.7%
            recommended("out_of_support_2", 100, 100),
            recommended("out_of_support_3", 10, 66, model="hybrid"),  # not the recommended model's
            recommended("out_of_support_3", 10, 66, calibration="pooled"),
            recommended("all", 10, 66),
        ]
    )
    assert coverage.short_regions(table, 0.9) == {"out_of_support_4": [32, 66], "in_support": [6230, 7000]}
    assert coverage.short_regions(table, 0.5) == {}


def test_a_short_region_is_chosen_and_calibrated_on_its_test_parts_too_and_no_other_region_moves():
    # the calibration blocks' errors are small, the test blocks' large (other coils); rows 0, 3, 6, ... are in
    # support, the others out of it; half of those (the gate's parts beyond a DoE range) choose in support
    n = 4_000
    calibration = regions.calibration_rows(n, 20)
    rng = np.random.default_rng(8)
    measured = rng.normal(0, 5, n)
    scale = np.where(calibration, 0.5, 3.0)
    honest = {model: measured + rng.normal(0, sd, n) * scale for model, sd in (("hybrid", 1.0), ("extended", 1.2))}
    interval = np.where(np.arange(n) % 3 == 0, "in_support", np.where(np.arange(n) % 3 == 1, "out_of_support_1", "x"))
    interval = np.where(interval == "x", regions.BEYOND_RANGE, interval).astype(object)
    region = regions.Regions(
        np.where(interval == regions.BEYOND_RANGE, "in_support", interval).astype(object), interval
    )
    plain = intervals.RegionIntervals.fit(measured, honest, region, calibration, [])
    short = ~calibration & (interval != "in_support")  # the test parts of the two regions out of the support
    again = intervals.RegionIntervals.fit(measured, honest, region, calibration, [], also=short)
    # the support's choice and interval as before; its stack's weights too (the gate's parts never choose)
    assert again.weights["in_support"] == plain.weights["in_support"]
    assert again.ranking["in_support"] == plain.ranking["in_support"]
    for model in plain.calibration:
        assert again.calibration[model]["in_support"] == plain.calibration[model]["in_support"]
    # out of the support the test parts choose too: the stack's weights on all its parts
    choosing = np.flatnonzero((calibration | short) & (interval == "out_of_support_1"))
    members = stack.stack_members(honest)
    assert again.weights["out_of_support_1"] == pytest.approx(stack.stack_weights(measured, members, choosing))
    assert again.weights["out_of_support_1"] != plain.weights["out_of_support_1"]
    # every interval there and beyond the DoE's range from the errors of all its parts: several times wider
    final = again.with_stack(honest, region)
    for name in ("out_of_support_1", regions.BEYOND_RANGE):
        for model in ("hybrid", "extended", "stack"):
            rows = (calibration | short) & (interval == name)
            errors = np.abs(measured - final[model])[rows]
            if model == "stack":  # cross-fitted where it chose; with the support's weights beyond the DoE's range
                errors = np.sort(again.calibration["stack"][name])
                if name == regions.BEYOND_RANGE:
                    expected = np.abs(measured - final["stack"])[short & (interval == name)]
                    assert np.isin(np.round(expected, 6), np.round(errors, 6)).all()
            assert again.half_width(model, name, LEVEL) == pytest.approx(_half_width(errors, LEVEL))
            assert again.half_width(model, name, LEVEL) > 2 * plain.half_width(model, name, LEVEL)


def test_the_intervals_step_recalibrates_a_short_region_on_its_test_parts_and_says_so():
    table, inputs, truth = _predictions_table()
    settings = {"level": 0.8, "distance_bins": 3, "blocks": 8}
    calibrated = coverage.calibrate(table, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0, truth=truth)
    assert not calibrated.intervals.recalibrated and not calibrated.table["recalibrated"].any()
    # the test blocks of the farthest region measure 5 further off than its calibration blocks
    n = len(table)
    test = (np.arange(n) // (n // 8)) % 2 == 1
    far = (calibrated.region.interval == "out_of_support_3") & test
    shifted = table.assign(measured=np.where(far, table["measured"] + 5, table["measured"]))
    again = coverage.calibrate(shifted, inputs, {"t": (0.0, 10.0)}, 1.0, settings, 0, truth=truth)
    rows = again.table.set_index(["region", "model", "calibration"])
    short = rows.loc[("out_of_support_3", "recommended", "by_region")]
    assert short["recalibrated"] and short["coverage_high"] < 0.8
    assert again.intervals.recalibrated == {
        "out_of_support_3": [round(short["coverage"] * short["n_test"]), short["n_test"]]
    }
    assert set(again.table.loc[again.table["recalibrated"], "region"]) == {"out_of_support_3"}
    model = again.intervals.recommended["out_of_support_3"]
    for name in ("in_support", "out_of_support_1", "out_of_support_2"):  # the other regions' choice as before
        assert again.intervals.ranking[name] == calibrated.intervals.ranking[name]
    # the table is the tested intervals' (on the calibration parts), the same choice and flags
    tested = again.table.drop(columns="recalibrated")
    assert tested["recommended"].equals(calibrated.table["recommended"].loc[tested.index])
    wider = again.intervals.half_width(model, "out_of_support_3", 0.8)
    assert wider > calibrated.intervals.half_width(model, "out_of_support_3", 0.8) + 2
    for name in ("in_support", "out_of_support_1", "out_of_support_2"):  # the others as before
        assert again.intervals.calibration[model][name] == calibrated.intervals.calibration[model][name]
    stored = intervals.RegionIntervals.from_dict(again.intervals.to_dict())
    assert stored.recalibrated == again.intervals.recalibrated
    # the peer comparison scores the test parts as the table tested them: the calibration parts' stack and choice,
    # which never read the test parts (the same as without the shift of the test parts)
    assert again.tested[0].to_dict() == calibrated.intervals.to_dict()
    for name, values in calibrated.held_out(0.8).items():
        np.testing.assert_array_equal(again.held_out(0.8)[name], values, err_msg=name)
    # and the figure draws the held-out parts' errors against the intervals they tested
    drawn = [
        coverage.figure_data(c, frame["measured"], frame["knn_distance"], 0.8, 0)["half_width"]
        for c, frame in ((calibrated, table), (again, shifted))
    ]
    assert drawn[0] == drawn[1]
