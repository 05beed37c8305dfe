"""hybridtwin.demo.scenarios: how a plant's diagnosis is judged, on hand-made outcomes."""

from hybridtwin.demo.families import Expected
from hybridtwin.demo.scenarios import Chosen, Outcome

TEMPERATURE = Expected("die_temp", ("sigmoid",))
NEAR_COPY = Expected("die_temp", ("sigmoid",), alias="die_temp_ir")
TWO = Expected("die_temp", ("sigmoid",), also=(Expected("strokes", ("linear",), monotone=True),))


def _outcome(expected: Expected, *chosen: Chosen, n_significant: int | None = None, tolerated=()) -> Outcome:
    top = chosen[0] if chosen else Chosen("", "", False)
    n = len(chosen) if n_significant is None else n_significant
    return Outcome(
        "k", "", expected, top.cause, top.form, bool(chosen), n, 0, *[1.0] * 6, 1.0, 0.0, chosen, tolerated=tolerated
    )


def test_the_cause_first_with_its_form_family():
    assert _outcome(TEMPERATURE, Chosen("die_temp", "sigmoid", False)).answer_ok
    assert not _outcome(TEMPERATURE, Chosen("die_temp", "quadratic", False)).answer_ok
    assert not _outcome(TEMPERATURE, Chosen("coil", "group", False), Chosen("die_temp", "sigmoid", False)).answer_ok


def test_an_alias_counts_only_where_the_data_cannot_tell_the_two_apart():
    # an alias reported beside another column is not the right answer (it was, under diagnosis_ok)
    other = _outcome(TEMPERATURE, Chosen("ambient", "sigmoid", False, aliases=("die_temp",)))
    assert other.diagnosis_ok and not other.answer_ok
    # the near-copy named first passes only with the pair reported
    assert _outcome(NEAR_COPY, Chosen("die_temp_ir", "sigmoid", False, aliases=("die_temp",))).answer_ok
    assert not _outcome(NEAR_COPY, Chosen("die_temp_ir", "sigmoid", False)).answer_ok
    assert not _outcome(NEAR_COPY, Chosen("die_temp", "sigmoid", False)).answer_ok


def test_a_twin_on_the_time_line_may_be_named_in_the_cause_s_place_reported_or_not():
    season = Expected("time", ("linear", "quadratic", "sigmoid"), monotone=True, twin="strokes")
    assert _outcome(season, Chosen("strokes", "quadratic", False)).answer_ok
    assert _outcome(season, Chosen("strokes", "quadratic", False, aliases=("time",))).answer_ok
    assert not _outcome(season, Chosen("coil", "group", False)).answer_ok
    assert not _outcome(Expected("time", ("quadratic",)), Chosen("strokes", "quadratic", False)).answer_ok


def test_two_causes_in_either_order_and_both_needed():
    heat, wear = Chosen("die_temp", "sigmoid", False), Chosen("strokes", "quadratic", True)  # a monotone trend
    assert _outcome(TWO, heat, wear).answer_ok
    assert _outcome(TWO, wear, heat).answer_ok
    assert not _outcome(TWO, heat).answer_ok
    assert not _outcome(TWO, heat, Chosen("strokes", "quadratic", False)).answer_ok  # not monotone over the data


def test_a_null_plant_passes_only_with_nothing_named():
    assert _outcome(Expected(None)).answer_ok
    assert not _outcome(Expected(None), n_significant=1).answer_ok


def test_below_the_detection_limit_a_true_cause_may_be_named_but_nothing_else():
    small = ("ambient_c", "rp02*shim")  # put in, each below the limit
    assert _outcome(Expected(None), tolerated=small).answer_ok
    assert _outcome(Expected(None), Chosen("ambient_c", "linear", True), tolerated=small).answer_ok
    assert _outcome(Expected(None), Chosen("shim*rp02", "product", False), tolerated=small).answer_ok
    assert not _outcome(Expected(None), Chosen("coil", "group", False), tolerated=small).answer_ok
    assert not _outcome(Expected(None), Chosen("ambient_c", "linear", True), n_significant=2, tolerated=small).answer_ok


def test_every_cause_with_a_near_copy_reports_the_pair_whichever_is_named_first():
    drift = Expected("time", ("linear",), alias="strokes")
    both = Expected("die_temp", ("sigmoid",), also=(drift,))
    heat = Chosen("die_temp", "sigmoid", False)
    assert _outcome(both, heat, Chosen("strokes", "linear", True, aliases=("time",))).answer_ok
    assert not _outcome(both, heat, Chosen("strokes", "linear", True)).answer_ok
    first = Expected("time", ("linear",), alias="strokes", also=(Expected("die_temp", ("sigmoid",)),))
    assert _outcome(first, heat, Chosen("time", "linear", True, aliases=("strokes",))).answer_ok
