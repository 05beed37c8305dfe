"""Hidden effects in generated plant data: the diagnosis must name them, and the extension must pay off."""
import pytest

from hybridtwin import experiment

from .conftest import SCENARIO_SEED

# kinds whose effect the black-box hybrid cannot carry out of the support (a column it does not
# see, stronger coils, new setting combinations): the extension must be well below it there
EXTRAPOLATING = {"stroke_drift", "rp02_slope", "interaction"}


@pytest.fixture(scope="module", params=experiment.KINDS)
def outcome(request):
    return experiment.run_scenario(request.param, SCENARIO_SEED + experiment.KINDS.index(request.param), n_jobs=2)


def test_names_the_hidden_cause_and_its_form(outcome):
    where = f"{outcome.kind}: {outcome.effect} (seed {SCENARIO_SEED})"
    if outcome.expected.cause is None:
        assert outcome.n_significant == 0, f"{where}: invented {outcome.top_cause}/{outcome.top_form}"
        return
    assert outcome.top_significant, f"{where}: top cause {outcome.top_cause} not significant"
    # naming the cause, or reporting honestly that the data cannot tell it from the top one
    assert outcome.named_or_aliased, f"{where}: named {outcome.top_cause} (aliases {outcome.top_aliases})"
    assert outcome.form_ok, f"{where}: form {outcome.top_form}"


def test_extension_gains_out_of_support(outcome):
    where = (f"{outcome.kind}: {outcome.effect} (seed {SCENARIO_SEED}): hybrid {outcome.rmse_oos_hybrid:.2f}, "
             f"extended {outcome.rmse_oos_extended:.2f}, extended hybrid {outcome.rmse_oos_extended_hybrid:.2f} mm")
    if outcome.kind in EXTRAPOLATING:
        # the surrogate's own error out of the support stays in both; the benchmark reports it against the noise
        assert outcome.rmse_oos_extended < 0.8 * outcome.rmse_oos_hybrid, where
    elif outcome.kind == "coil_offset":
        # an offset is known only for coils seen inside the support
        assert outcome.rmse_oos_known_levels_extended_hybrid < 1.05 * outcome.rmse_oos_known_levels_hybrid, where
    else:
        # a saturating or step change whose plateaus the support already shows, or no effect:
        # trees carry it too, so the extension can only match them; it must not lose
        assert outcome.rmse_oos_extended_hybrid < 1.05 * outcome.rmse_oos_hybrid, where
