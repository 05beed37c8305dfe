"""The monitor, fast: the CUSUM by hand, and `hybridtwin monitor` on the tiny stored run (tests/data/models) with
the head of its production log as the batch (in control), with a step added, and with bad input."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hybridtwin.answers.predictor import Predictor
from hybridtwin.cli import main
from hybridtwin.io.errors import InputError
from hybridtwin.monitor import calibration, chart, watch, words
from hybridtwin.monitor.changes import NEW, UNEXPLAINED, boundary_of, clocks, step_of

from .conftest import says

DATA = Path(__file__).resolve().parent / "data"
MODELS = str(DATA / "models")


@pytest.fixture(scope="module")
def predictor():
    return Predictor.load(MODELS)


@pytest.fixture(scope="module")
def parts():
    return pd.read_csv(DATA / "production_head.csv")


@pytest.fixture(scope="module")
def stepped(predictor, parts):
    """The head with the plant 3 expected errors higher from part 201 on."""
    batch = parts.copy()
    batch.loc[200:, "draw_in_mm"] += 3 * 2.41
    return watch.watch(predictor, batch)


def test_one_side_is_the_cusum_recursion_by_hand():
    statistic, start = chart.one_side(np.array([1.0, -2.0, 0.5, 0.5, -0.2, 3.0]))
    # S: max(0, 0+1)=1, max(0, 1-2)=0, 0.5, 1.0, 0.8, 3.8; the excursion began after the zero at index 1
    np.testing.assert_allclose(statistic, [1.0, 0.0, 0.5, 1.0, 0.8, 3.8])
    assert start.tolist() == [0, 2, 2, 2, 2, 2]


def test_cusum_alarms_at_the_first_part_over_the_limit_and_dates_the_start():
    z = np.r_[np.zeros(50), np.full(30, 3.0)]  # each changed part adds 3 - k = 2
    result = chart.cusum(z, reference=1.0, limit=20.0)
    assert result.alarm_at == 60 and result.start_at == 50 and result.direction == 1  # 11 parts: 22 > 20
    assert not result.alarm[:60].any() and result.alarm[60:].all()
    down = chart.cusum(-z, reference=1.0, limit=20.0)
    assert down.alarm_at == 60 and down.direction == -1
    assert chart.cusum(np.full(1000, 0.99), 1.0, 20.0).alarm_at is None  # within the allowance: never


def test_parts_not_judged_leave_the_statistic_as_it_was():
    z = np.r_[np.full(5, 2.0), np.full(100, np.nan), np.full(5, 2.0)]
    result = chart.cusum(z, reference=1.0, limit=8.0)
    assert result.statistic[104] == result.statistic[4] == 5.0
    assert result.alarm_at == 108 and result.start_at == 0
    assert chart.cusum(np.r_[np.zeros(10), 100.0], 1.0, 8.0).alarm_at is None  # one wild part is clipped at 4


def test_the_allowance_is_the_least_that_keeps_the_logs_own_excursions_under_half_the_limit():
    assert calibration.allowance(np.zeros(500)) == chart.REFERENCE
    settled = np.r_[np.zeros(300), np.full(200, 1.5), np.zeros(300)]  # a campaign 1.5 expected errors off
    k = calibration.allowance(settled, limit=20.0)
    assert k == pytest.approx(1.45, abs=0.002)  # 200 * (1.5 - k) = 10
    assert calibration.log_peak(settled, k) < 10.0 <= calibration.log_peak(settled, k - 0.01)


def test_expected_error_is_the_root_mean_square_of_the_regions_calibration(predictor):
    model, errors = next((m, r) for m, per in predictor.intervals.calibration.items() for r in per.items())
    region, values = errors
    got = chart.expected_error(predictor.intervals, [model, "no_model"], [region, region])
    assert got[0] == pytest.approx(np.sqrt(np.mean(np.square(values)))) and np.isnan(got[1])


def test_the_logs_own_parts_are_in_control(predictor, parts):
    watched = watch.watch(predictor, parts)
    assert watched.chart.alarm_at is None and watched.change is None
    assert not watched.table["alarm"].any() and watched.table["change_start"].isna().all()
    says(words.summary(watched), "in control", "400 parts")


def test_parts_unlike_every_logged_part_are_not_judged(predictor, parts):
    batch = parts.copy()
    batch.loc[200:, "shim21_mm"] += 0.3  # far beyond the log: trust 'extrapolation', and no error is expected there
    batch.loc[200:, "draw_in_mm"] += 10.0
    watched = watch.watch(predictor, batch)
    far = watched.table["trust"].to_numpy() == "extrapolation"
    assert far[200:].all() and not far[:200].any() and watched.table["expected_error"][far].isna().all()
    assert watched.chart.alarm_at is None and watched.judged.sum() == 200
    says(words.summary(watched), "in control", "200 parts judged", "200 parts were not judged")


def test_a_step_alarms_soon_after_it_starts_and_is_unexplained(stepped):
    assert 200 <= stepped.chart.alarm_at <= 215 and abs(stepped.chart.start_at - 200) <= 3
    assert stepped.table["change_start"].iloc[-1] == stepped.chart.start_at + 1
    assert stepped.change.kind == UNEXPLAINED and stepped.change.shift == pytest.approx(7.2, abs=1.5)
    says(words.summary(stepped), "ALARM at part", "more than the models expect", "unexplained", "append the batch")


def test_a_setting_that_steps_to_a_new_level_is_named_and_a_warming_trend_is_not():
    rng = np.random.default_rng(0)
    values = np.r_[np.full(400, 0.45), np.full(400, 0.55)] + rng.normal(0, 0.004, 800)
    at, low, high = step_of(values, 402)
    assert abs(at - 400) <= 2 and low == pytest.approx(0.45, abs=0.01) and high == pytest.approx(0.55, abs=0.01)
    assert step_of(np.linspace(20, 60, 800) + rng.normal(0, 0.3, 800), 400) is None
    frame = pd.DataFrame({"strokes": np.arange(10), "t": pd.date_range("2026-01-01", periods=10).astype(str)})
    assert clocks(frame.assign(x=rng.normal(size=10))) == {"strokes", "t"}


def test_a_new_coil_that_begins_where_the_change_starts_is_found_and_an_id_per_part_is_not():
    coils = pd.Series(np.repeat(["K1", "K2", "K3"], [150, 200, 150]))
    assert boundary_of(coils, 345) == 350 and boundary_of(coils, 335) is None
    assert boundary_of(pd.Series([f"P{i}" for i in range(500)]), 350) is None
    assert boundary_of(pd.Series(np.arange(500.0)), 350) is None


def test_what_changed_names_a_stepped_setting(predictor, parts):
    batch = parts.copy()
    batch.loc[200:, "cushion_c4_kn"] = batch["cushion_c4_kn"].iloc[:200].max() + 8.0
    batch.loc[200:, "draw_in_mm"] += 3 * 2.41
    watched = watch.watch(predictor, batch)
    assert watched.change.kind == NEW and watched.change.column == "cushion_c4_kn", watched.change.text
    says(watched.change.text, "a step in cushion_c4_kn at part")


def test_the_command_writes_the_table_and_monitor_md_and_leaves_the_batch(tmp_path, parts, capsys):
    batch = parts.copy()
    batch.loc[200:, "draw_in_mm"] += 3 * 2.41
    path = tmp_path / "batch.csv"
    batch.to_csv(path, index=False)
    before = path.read_bytes()
    assert main(["monitor", str(path), "--models", MODELS, "-o", str(tmp_path / "out.csv")]) == 0
    out = pd.read_csv(tmp_path / "out.csv")
    assert list(out.columns) == [*parts.columns, *watch.COLUMNS] and len(out) == len(parts)
    assert out["alarm"].iloc[-1] and not out["alarm"].iloc[0] and path.read_bytes() == before
    says((tmp_path / "monitor.md").read_text(), "# Monitor: batch.csv", "ALARM", "What changed")
    says(capsys.readouterr().out, "ALARM at part", "what changed")


@pytest.mark.parametrize(
    "change, expected",
    [
        (lambda b: b.drop(columns="draw_in_mm"), ("no column 'draw_in_mm'", "cannot be monitored")),
        (lambda b: b.rename(columns={"draw_in_mm": "draw_in"}), ("did you mean 'draw_in'?", "cannot be monitored")),
        (lambda b: b.drop(columns="rm_mpa"), ("no column 'rm_mpa'",)),
        (lambda b: b.drop(columns="stroke_counter"), ("no column 'stroke_counter'", "extension")),
        (lambda b: b.iloc[[0, 2, 1, *range(3, 400)]], ("column 'timestamp', row 3 (line 4)", "time order")),
        (lambda b: b.assign(draw_in_mm=b["draw_in_mm"].where(b.index != 9)), ("'draw_in_mm'", "row 10 (line 11)")),
    ],
)
def test_bad_batches_stop_with_one_line(predictor, parts, tmp_path, capsys, change, expected):
    path = tmp_path / "batch.csv"
    change(parts).to_csv(path, index=False)
    with pytest.raises(InputError) as error:
        watch.load_batch(path, predictor)
    says(str(error.value), *expected)
    assert main(["monitor", str(path), "--models", MODELS, "-o", str(tmp_path / "out.csv")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: batch file") and err.count("\n") == 1 and not (tmp_path / "out.csv").exists()
