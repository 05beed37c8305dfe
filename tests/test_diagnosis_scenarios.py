"""Hidden effects in generated plants: the diagnosis must name them, and the extension must not lose.

The draws are fixed and committed, so two CI runs of one commit give one verdict: two draws
per demo kind (seed 1 and the draws of seed 12345, where a shim step once was taken for a slope; the demo bank
counts many more), one draw of
each other plant family, one of each kind of the structures generator the others do not draw, and bank draws
the method once got wrong. ``HYBRIDTWIN_TEST_SEED=<n>``
replaces them by the draws of seed n (one per kind and family), to replay a bank's draw or to try new ones.
What is asked of each plant lives in ``scenarios.Outcome`` (``answer_ok``, ``gain_ok``), so
that ``benchmarks/diagnosis_bank.py`` counts the same thing over many more draws.
"""

import os

import pytest

from hybridtwin import diagnosis
from hybridtwin.demo import bifidelity, families, harness, scenarios

pytestmark = pytest.mark.scenario
REPLAY = os.environ.get("HYBRIDTWIN_TEST_SEED")
# under pytest-xdist (CI: -n 2 --dist loadgroup) a plant's fits take one core, so that two plants run at once: the
# diagnosis' joblib fits use two cores at about 70%, and a plant's outcome does not depend on its number of jobs
N_JOBS = 1 if os.environ.get("PYTEST_XDIST_WORKER") else 2


def _draws():
    if REPLAY:
        seed = int(REPLAY)
        return [("demo", kind, seed + i) for i, kind in enumerate(scenarios.KINDS)] + [
            ("families", family, seed) for family in families.FAMILIES
        ]
    demo = [("demo", kind, 1) for kind in scenarios.KINDS]
    demo += [("demo", kind, 12345 + i) for i, kind in enumerate(scenarios.KINDS)]
    # two-cause draws of the families bank beside draw 1 (a generic second one, 2404, left for CI's 15 minutes):
    # the coil id once named in place of a saturation and a wear (1484);
    # a cushion product that gave way to its shim, named in place of the wear (1420); a plant of the structures
    # bank where the lot id was named for the slope of a per-lot yield strength (40065)
    extra = [("families", "two_causes", draw) for draw in (1484, 1420)] + [("structures", "linear", 40065)]
    return demo + [("families", family, 1) for family in families.FAMILIES] + extra + STRUCTURES


# one draw of the structures bank (seed 4) per kind the demo and the families do not hold, and the draws a change
# of the method got right: a season over three weeks that is a parabola in strokes too (40019); a lot once named
# for a per-lot oil film's step (40081)
STRUCTURES = [
    ("structures", kind, draw)
    for kind, draw in (
        ("product", 40043),
        ("ambient", 40057),
        ("seasonal", 40019),
        ("wear", 40046),
        ("coil", 40021),
        ("unlogged_shift", 40074),
        ("two_causes", 40075),
        ("three_causes", 40050),
        ("step", 40081),
    )
]


DRAWS = _draws()

# Known misses, kept in view: a strict xfail turns red once the method gets them right.
KNOWN_MISSES: set[tuple[str, str, int, str]] = set()


def _named(draws):
    """The draws as parameters, each of a group of its own: ``--dist loadgroup`` sends a plant's tests to one worker,
    which draws and fits it once."""
    return [
        pytest.param(draw, id="-".join(map(str, draw)), marks=pytest.mark.xdist_group("-".join(map(str, draw))))
        for draw in draws
    ]


@pytest.fixture(scope="module", params=_named(DRAWS))
def outcome(request):
    generator, kind, seed = request.param
    # the tests judge the diagnosis and the extension; TreeSHAP's top column is the banks' baseline
    return scenarios.run_scenario(kind, seed, n_jobs=N_JOBS, generator=generator, baseline=False)


@pytest.fixture(autouse=True)
def known_miss(request):
    if "outcome" not in request.node.callspec.params:  # a test of its own plants
        return
    generator, kind, seed = request.node.callspec.params["outcome"]
    if (generator, kind, seed, request.node.originalname) in KNOWN_MISSES and not REPLAY:
        request.applymarker(pytest.mark.xfail(strict=True, reason="known miss, counted by the bank"))


def _where(outcome) -> str:
    return f"{outcome.generator} {outcome.kind}: {outcome.effect}"


def test_names_the_hidden_cause_and_its_form(outcome):
    chosen = [(c.cause, c.form, c.aliases) for c in outcome.chosen]
    if outcome.expected.cause is None:
        assert outcome.n_significant == 0, f"{_where(outcome)}: invented {chosen}"
        return
    assert outcome.top_significant, f"{_where(outcome)}: nothing significant; top {outcome.top_cause}"
    assert outcome.alias_reported, f"{_where(outcome)}: {outcome.expected.alias} not reported as an alias: {chosen}"
    assert outcome.others_found, f"{_where(outcome)}: second cause {outcome.expected.also} missing from {chosen}"
    # the cause (or the column the data cannot tell from it) first, with its form family
    assert outcome.answer_ok, f"{_where(outcome)}: named {chosen}, expected {outcome.expected}"


def test_extension_never_loses_to_the_hybrid_out_of_support(outcome):
    assert outcome.gain_ok, (
        f"{_where(outcome)}: out of support against the truth: hybrid {outcome.rmse_oos_hybrid_truth:.2f}, "
        f"extended {outcome.rmse_oos_extended_truth:.2f}, "
        f"extended hybrid {outcome.rmse_oos_extended_hybrid_truth:.2f}; "
        f"measured: hybrid {outcome.rmse_oos_hybrid:.2f}, extended hybrid {outcome.rmse_oos_extended_hybrid:.2f}"
    )


# bi-fidelity functions as simulation and plant (hybridtwin.demo.bifidelity, a lot per campaign): the lot was named
# over a discrepancy of the inputs alone before its level means were judged against a smooth function of them;
# on Branin (seed 12) after a parabola in x1, until the parabola was put back for that judgement; on Booth (seed 12) a
# parabola in the stroke counter followed the campaigns' offsets until a trend had to show between parts run at the
# same settings (the lot was named after it)
BIFIDELITY = [("hartmann6", 13), ("currin", 11), ("branin", 12), ("booth", 12)]


@pytest.mark.parametrize("function, seed", BIFIDELITY)
def test_no_id_or_time_is_named_for_a_discrepancy_of_the_inputs_alone(function, seed):
    case = bifidelity.plant(function, seed)
    result = harness.Run.of(case, seed, N_JOBS).diagnose(diagnosis.Settings(seed=seed, n_jobs=N_JOBS))
    named = [fit.candidate.name for fit in result.selected]
    assert named and not set(named) & set(bifidelity.LOG_COLUMNS), named
