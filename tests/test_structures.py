"""hybridtwin.demo.structures: the randomized structure generator of the diagnosis bank (no diagnosis is run)."""

from functools import lru_cache

import numpy as np
import pytest

from hybridtwin.demo import quantities, structures
from hybridtwin.io.config import section_defaults
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate, surrogate_latent_std

N = 8_000  # the smallest plant the generator draws: fast enough for a test


@lru_cache(maxsize=None)
def _case(kind: str, seed: int) -> structures.StructureCase:
    return structures.draw_structure_plant(kind, seed, N)


def _runs(labels) -> np.ndarray:
    """Lengths of the runs of equal consecutive labels."""
    labels = np.asarray(labels)
    starts = np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])
    return np.diff(np.r_[starts, len(labels)])


def _expected_columns(expected) -> set[str]:
    columns = set(expected.cause.split("*")) if expected.cause else set()
    columns |= {expected.alias} if expected.alias else set()
    for other in expected.also:
        columns |= _expected_columns(other)
    return columns


def test_the_same_seed_draws_the_same_frames_and_another_seed_others():
    first = structures.draw_structure_plant("two_causes", 3, N)
    again = structures.draw_structure_plant("two_causes", 3, N)
    assert first.production.equals(again.production) and first.doe.equals(again.doe)
    assert np.array_equal(first.truth, again.truth) and first.expected == again.expected
    other = structures.draw_structure_plant("two_causes", 4, N)
    assert not np.array_equal(first.truth[:100], other.truth[:100])


@pytest.mark.parametrize("kind", structures.KINDS)
def test_every_kind_draws_a_plant_with_its_causes_among_the_columns(kind):
    case = _case(kind, 1)
    assert case.family == case.effect_kind == kind and len(case.production) == N
    assert 6 <= case.n_inputs <= 14 and 30 <= case.n_doe <= 120 and len(case.doe) == case.n_doe
    assert set(case.inputs) <= set(case.production.columns) and case.target in case.production.columns
    assert case.support.mean() >= structures.MIN_IN_SUPPORT
    coils = case.production.loc[case.support, case.names["coil"]]
    assert coils.nunique() >= structures.MIN_COILS_IN_SUPPORT
    # every cause put in is a column (or a product of two) of the log, and what is expected is among them
    hidden = {column for cause in case.hidden_causes for column in cause.split("*")}
    assert hidden <= set(case.production.columns)
    assert _expected_columns(case.expected) <= set(case.production.columns)
    assert bool(case.hidden_causes) == (kind != "none")
    assert (case.expected.cause is None) == (max(case.cause_ratios, default=0.0) < structures.DETECTION_LIMIT)


def test_a_per_coil_property_is_constant_within_its_coil_and_a_per_part_one_is_not():
    case = _case("linear", 5)
    by_coil = case.production.groupby(case.names["coil"], sort=False)
    per_part = [
        c for c in ("thickness_mm", "rm_mpa", "rp02_mpa", "r_n", "lubricant") if case.names[c] in case.production
    ]
    per_part = [c for c in per_part if c not in case.per_coil]
    assert case.per_coil and per_part, "a plant with both kinds of property"
    for canonical in case.per_coil:
        column = case.names[canonical]
        within = by_coil[column].std().mean()
        assert within < 0.05 * by_coil[column].mean().std(), canonical
    for canonical in per_part:
        column = case.names[canonical]
        assert by_coil[column].std().mean() > 0.5 * case.production[column].std(), canonical


@pytest.mark.parametrize("relation,seed", [("shorter", 3), ("equal", 1), ("longer", 5)])
def test_coils_are_shorter_than_as_long_as_or_longer_than_the_setting_campaigns(relation, seed):
    case = _case("none", seed)
    assert case.coil_vs_campaign == relation
    coil_length = np.median(_runs(case.production[case.names["coil"]]))
    campaign_length = np.median(_runs(case.campaign))
    if relation == "shorter":
        assert coil_length < campaign_length / 2
    elif relation == "equal":  # the settings are changed at each coil change
        assert np.array_equal(_runs(case.campaign), _runs(case.production[case.names["coil"]]))
    else:
        assert coil_length > 2 * campaign_length
    # the campaigns are the settings': a setting scatters little within one and moves between them
    setting = next(c for c in case.inputs if c in {case.names[s] for s in quantities.of_role(quantities.SETTING)})
    levels = case.production.groupby(case.campaign)[setting]
    assert levels.std().mean() < 0.5 * levels.mean().std()


@pytest.mark.parametrize("kind,seed", [("sigmoid", 0), ("step", 1), ("quadratic", 1)])
def test_the_size_ratio_is_the_effects_std_over_the_surrogates_uncertainty_in_support(kind, seed):
    case = _case(kind, seed)
    effect = case.truth - case.simulator(case.production) - case.offset
    assert np.allclose(effect, case.effect)
    gate = section_defaults("gate")
    inside = (
        KNNSupportGate(gate["k"], gate["percentile"]).fit(case.doe[case.inputs]).predict(case.production[case.inputs])
    )
    assert np.array_equal(inside, case.support)
    surrogate = GPRSurrogate(n_restarts=1, random_state=seed).fit(case.doe[case.inputs], case.doe[case.target])
    _, std = surrogate.predict(case.production.loc[inside, case.inputs], return_std=True)
    ratio = effect[inside].std() / surrogate_latent_std(std, surrogate.noise_std_)
    # the std the effect was drawn at (a single cause): a scaling by anything but the surrogate's fails here
    assert ratio == pytest.approx(case.size_ratio, rel=1e-6) == pytest.approx(case.cause_ratios[0], rel=1e-6)
    assert structures.SIZE_RANGE[0] <= ratio <= structures.SIZE_RANGE[1]
    below = ratio < structures.DETECTION_LIMIT
    assert case.below_limit == below and (case.expected.cause is None) == below
    assert ("below the detection limit" in case.description) == below


def test_the_size_ratios_drawn_reach_below_the_limit_and_far_above_it():
    ratios = [_case(kind, 1).size_ratio for kind in structures.KINDS[:8]]
    assert min(ratios) < structures.DETECTION_LIMIT and max(ratios) > 3 * structures.DETECTION_LIMIT


def test_a_null_plant_is_the_simulator_plus_an_offset():
    case = _case("none", 1)
    assert np.array_equal(case.truth, case.simulator(case.production) + case.offset)
    assert not np.any(case.effect) and case.size_ratio == 0.0 and case.expected.cause is None
    assert not case.below_limit  # there is nothing to detect, not something too small
    # the DoE is the same simulator, with the FE code's scatter only
    scatter = case.doe[case.target] - case.simulator(case.doe)
    assert scatter.std() < 1.5 and 9 < case.doe[case.target].std() < 30
    measured = case.production[case.target] - case.truth
    assert abs(measured.mean()) < 0.1 and measured.std() == pytest.approx(case.noise, rel=0.05)


def test_a_step_in_time_is_one_in_strokes_and_is_judged_so():
    case = _case("unlogged_shift", 1)
    assert case.expected.cause in (case.names["time"], None)
    if case.expected.cause:
        assert case.expected.alias == case.names["strokes"] and "step" in case.expected.forms


def test_a_twin_column_is_accepted_only_where_it_reproduces_the_cause_within_the_detection_limit():
    rng = np.random.default_rng(0)
    hours, inside = np.sort(rng.uniform(0, 500, 2000)), np.ones(2000, bool)
    strokes = hours + rng.uniform(0, 40, 2000).cumsum() / 10  # idle spells: a time line of its own
    assert structures.twin_misfit((hours - 200) ** 2, hours, inside) < 1e-9  # a parabola is one in itself
    season = np.sin(hours / 500)
    misfit = structures.twin_misfit(season, strokes, inside)
    assert 0 < misfit < 0.2  # a slow season is nearly a parabola in strokes
    assert structures.twin_misfit(rng.normal(size=2000), strokes, inside) > 0.9  # noise is none
    # the twin is accepted where the misfit times the cause's size stays below the detection limit, and never
    # in place of an alias the plant already holds
    cause = structures._Cause(season, structures.Expected("time", ("quadratic",)), "", ("time",), ("strokes", strokes))
    limit = structures.DETECTION_LIMIT / misfit
    assert structures._with_twin(cause, 0.9 * limit, inside).twin == "strokes"
    assert structures._with_twin(cause, 1.1 * limit, inside).twin is None
    aliased = cause._replace(expected=structures.Expected("time", ("quadratic",), alias="hubzaehler"))
    assert structures._with_twin(aliased, 0.1, inside) == aliased.expected
