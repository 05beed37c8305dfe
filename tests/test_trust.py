"""The trust verdict by hand: validated, calibrated, extrapolation, at their edges, and the reason's facts."""

import numpy as np
import pandas as pd

from hybridtwin.answers import trust

from .conftest import says

REACH = trust.Reach(
    threshold=1.0,
    max_distance=4.0,
    beyond={"t": (-0.05, 0.10), "T": (0.0, 5.0)},
    doe_range={"t": (0.6, 0.8), "T": (15.0, 55.0)},
    units={"t": "mm", "T": "°C"},
)


def verdicts(rows):
    """rows: (in support, kNN distance, t beyond its range, T beyond its range)."""
    inside, distance, t, T = map(np.array, zip(*rows))
    return trust.verdicts(inside.astype(bool), pd.DataFrame({"t": t, "T": T}), distance.astype(float), REACH)


def test_each_verdict_at_its_edges():
    verdict, _ = verdicts(
        [
            (True, 0.9, 0.0, 0.0),  # in support, in every range
            (True, 0.9, 0.10, 0.0),  # in the gate, beyond t's range exactly as far as calibrated parts were
            (True, 0.9, 0.1000001, 0.0),  # a hair further
            (False, 4.0, 0.0, 0.0),  # out of support, exactly as far as the furthest calibrated part
            (False, 4.01, 0.0, 0.0),  # further
            (False, 2.0, -0.05, 5.0),  # below t's minimum and above T's maximum, both within what calibrated
            (False, 2.0, 0.0, -0.5),  # below T's minimum: no calibration part was
        ]
    )
    assert verdict.tolist() == [
        "validated",
        "calibrated",
        "extrapolation",
        "calibrated",
        "extrapolation",
        "calibrated",
        "extrapolation",
    ]


def test_the_reason_names_the_input_its_value_the_distance_and_the_doe_bound():
    _, reason = verdicts([(False, 2.0, 0.0, 40.0), (False, 6.0, 0.0, 0.0), (True, 0.9, 0.05, 2.0)])
    # T at 95 °C: 40 °C above 55, one DoE range beyond it
    says(reason[0], "T 95", "40 °C above the DoE's maximum 55", "1 times the DoE's range beyond it", "no interval")
    says(reason[1], "kNN distance 6", "up to 4", "no interval")
    # the input furthest beyond its range, in shares of the range: t 0.05 of 0.2 (0.25) against T 2 of 40 (0.05)
    says(reason[2], "inside the support", "t 0.85 is 0.05 mm above the DoE's maximum 0.8")
    says(reason[2], "calibrated or tested the interval")
    says(reason[2], "(kNN distance up to 4)")  # what the number is


def test_no_calibration_part_out_of_the_support_means_every_part_there_is_an_extrapolation():
    reach = trust.Reach.of(
        pd.DataFrame({"t": [0.0, 0.0]}), [0.5, 0.7], [False, False], 1.0, {"t": (0.0, 1.0)}, {"t": "mm"}
    )
    assert reach.max_distance is None and reach.beyond == {"t": (0.0, 0.0)}
    verdict, _ = trust.verdicts(np.array([True, False]), pd.DataFrame({"t": [0.0, 0.0]}), np.array([0.5, 1.5]), reach)
    assert verdict.tolist() == ["validated", "extrapolation"]  # no interval was ever checked out of the support


def test_a_setting_unlike_every_logged_part_is_an_extrapolation_in_the_validated_domain_too():
    from dataclasses import replace

    reach = replace(REACH, novelty=1.5)
    rows = [(True, 0.9, 0.0, 0.0), (True, 0.9, 0.0, 0.0), (False, 2.0, 0.0, 0.0), (False, 2.0, 0.0, 0.0)]
    inside, distance, t, T = map(np.array, zip(*rows))
    frame = pd.DataFrame({"t": t, "T": T})
    novelty = np.array([1.5, 1.51, 1.5, 1.51])  # at the log's own largest novelty, and a hair beyond it
    verdict, reason = trust.verdicts(inside.astype(bool), frame, distance.astype(float), reach, novelty)
    assert verdict.tolist() == ["validated", "extrapolation", "calibrated", "extrapolation"]
    # the simulations back the first: the correction of them was never learnt from a part like it
    says(reason[1], "unlike every logged production part", "1.51", "1.5", "the simulations back it", "no interval")
    says(reason[3], "unlike every logged production part", "the plant was never seen here", "no interval")
    assert "simulations back it" not in reason[3]
