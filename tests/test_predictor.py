"""The frozen predictor and the hybridtwin command, fast: questions to a tiny stored run (tests/data/models,
made by tests/data/make_models.py; its extension names the stroke counter, a column the inputs do not hold)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hybridtwin.answers import answer, trust
from hybridtwin.answers.predictor import Predictor
from hybridtwin.cli import main
from hybridtwin.io.errors import InputError
from hybridtwin.models import registry

from .conftest import says

DATA = Path(__file__).resolve().parent / "data"
MODELS = str(DATA / "models")


@pytest.fixture(scope="module")
def predictor():
    return Predictor.load(MODELS)


@pytest.fixture(scope="module")
def parts():
    return pd.read_csv(DATA / "production_head.csv")


def _far(predictor, name: str) -> pd.DataFrame:
    """Typical production but ``name`` at the DoE's maximum plus twice its range."""
    low, high = predictor.doe_range[name]
    return pd.DataFrame([{**predictor.typical, name: high + 2 * (high - low)}])


def test_the_default_answer_has_at_most_12_columns_and_all_models_every_model(predictor, parts):
    short = predictor.predict(parts)
    added = [column for column in short.columns if column not in parts.columns]
    assert added == list(answer.DEFAULT) and len(added) <= 12
    every = predictor.predict(parts, all_models=True)
    assert {model.column for model in registry.MODELS} <= set(every.columns)
    assert {f"beyond_{name}" for name in predictor.inputs} <= set(every.columns)
    # computing only what the recommendation needs changes no answer
    same = ["pred_recommended", "pred_lower", "pred_upper", "recommended_model", "trust"]
    pd.testing.assert_frame_equal(short[same], every[same])


def test_peers_are_computed_only_where_they_are_recommended(predictor, parts):
    short = predictor.predict(parts)
    every = predictor.predict(parts, all_models=True)
    for name in registry.PEER_NAMES:
        needed = predictor.needed(predictor.where(predictor.checked(parts)), parts.columns).get(name)
        values = predictor.values(parts, predictor.checked(parts), predictor.where(predictor.checked(parts)), False, 1)
        rows = np.zeros(len(parts), bool) if needed is None else needed
        assert np.isnan(values[name][~rows]).all()
        np.testing.assert_allclose(values[name][rows], every[f"pred_{name}"].to_numpy()[rows])
    assert short["recommended_model"].isin(registry.RECOMMENDABLE).all()


@pytest.mark.parametrize("name", ["thickness_mm", "die_temp_c", "rm_mpa"])
def test_a_far_setting_is_an_extrapolation_with_no_interval(predictor, name):
    answered = predictor.predict(_far(predictor, name)).iloc[0]
    assert answered["trust"] == trust.EXTRAPOLATION
    assert np.isnan(answered["pred_lower"]) and np.isnan(answered["pred_upper"])
    low, high = predictor.doe_range[name]
    says(
        answered["trust_reason"],
        name,
        f"above the DoE's maximum {high:.3g}",
        "2 times the DoE's range beyond it",
        "no interval",
    )


def test_a_typical_setting_is_validated_with_its_interval(predictor):
    answered = predictor.predict(pd.DataFrame([predictor.typical])).iloc[0]
    assert answered["trust"] == trust.VALIDATED and answered["in_support"]
    assert answered["pred_lower"] < answered["pred_recommended"] < answered["pred_upper"]
    says(answered["trust_reason"], "validated", "within the support's")


def _with_spreads(predictor, region: str, spread: float, ranking=None):
    """``predictor`` with the corrections' disagreement on every part that calibrated ``region`` set to ``spread``
    (and the region's ranking set to ``ranking``)."""
    from hybridtwin.answers.intervals import RegionIntervals

    stored = predictor.intervals.to_dict()
    n = max(len(per_region.get(region, [])) for per_region in stored["calibration"].values())
    stored["calibration_spreads"] = {"regions": {region: [spread] * n}}
    if ranking:
        stored["ranking"][region] = ranking
    predictor.intervals = RegionIntervals.from_dict(stored)
    return predictor


def test_out_of_support_an_interval_widened_by_the_corrections_disagreement_says_by_how_much(parts):
    plain = Predictor.load(MODELS).predict(parts, all_models=True)
    row = plain.index[(plain["trust"] == trust.CALIBRATED) & ~plain["in_support"]][0]
    region = plain.loc[row, "interval_region"]
    # the corrections agreed to 0.01 on every part that calibrated the row's interval; the region recommends the
    # paper's hybrid, so that the default answer computes the extended models for the interval alone
    predictor = _with_spreads(Predictor.load(MODELS), region, 0.01, ["hybrid"])
    answered = predictor.predict(parts.iloc[[row]]).iloc[0]
    every = predictor.predict(parts.iloc[[row]], all_models=True).iloc[0]
    spread = np.std([every[f"pred_{name}"] for name in ("hybrid", "extended", "extended_hybrid")])
    plain_half = predictor.intervals.half_width("hybrid", region, 0.9)
    half = (answered["pred_upper"] - answered["pred_lower"]) / 2
    # equal spreads: the weighted errors keep their order, and the interval scales by (spread + floor) / (0.01 + floor)
    floor = 2 * 0.01
    assert answered["recommended_model"] == "hybrid"
    assert half == pytest.approx(plain_half * (spread + floor) / (0.01 + floor), rel=1e-6) and half > plain_half
    says(answered["trust_reason"], "times its calibration's", f"differ by {spread:.3g} mm", "0.01 mm on the parts")
    # where the corrections disagreed more on the calibration parts than here: the plain interval, no word of it
    calm = _with_spreads(Predictor.load(MODELS), region, 100.0, ["hybrid"]).predict(parts.iloc[[row]]).iloc[0]
    assert (calm["pred_upper"] - calm["pred_lower"]) / 2 == pytest.approx(plain_half)
    assert "calibration's" not in calm["trust_reason"] and "not widened" not in calm["trust_reason"]
    # without the column a cause needs (the extension names the stroke counter) nothing widens, and the reason says so
    lacking = predictor.predict(parts.iloc[[row]].drop(columns="stroke_counter")).iloc[0]
    assert (lacking["pred_upper"] - lacking["pred_lower"]) / 2 == pytest.approx(plain_half)
    says(lacking["trust_reason"], "not widened where the models that correct the surrogate part ways", "stroke_counter")


def test_a_simulated_setting_the_plant_never_ran_is_an_extrapolation_with_no_interval(predictor):
    # both shims at 0.02 mm: inside the support and every DoE range, far from every logged part (0.43 mm and up)
    answered = predictor.predict(pd.DataFrame([{**predictor.typical, "shim20_mm": 0.02, "shim21_mm": 0.02}])).iloc[0]
    assert answered["in_support"] and answered["trust"] == trust.EXTRAPOLATION
    assert np.isnan(answered["pred_lower"]) and np.isnan(answered["pred_upper"])
    says(answered["trust_reason"], "unlike every logged production part", "the simulations back it", "no interval")


def test_without_the_causes_column_the_extension_is_passed_by(predictor, parts):
    lacking = parts.drop(columns=["stroke_counter"])
    every = predictor.predict(lacking, all_models=True)
    inside = every["in_support"].to_numpy(bool)
    assert np.isnan(every["pred_extended"]).all() and np.isnan(every["pred_extended_hybrid"][inside]).all()
    assert not every["recommended_model"][inside].isin(["extended", "extended_hybrid"]).any()


@pytest.mark.parametrize(
    "cell, words",
    [("abc", ["column 'rm_mpa'", "row 3", "'abc' is not a number"]), (np.nan, ["column 'rm_mpa'", "row 3", "missing"])],
)
def test_the_api_checks_a_table_as_the_command_does(predictor, parts, cell, words):
    broken = parts.head(5).astype({"rm_mpa": object})
    broken.loc[2, "rm_mpa"] = cell
    with pytest.raises(InputError) as caught:
        predictor.predict(broken)
    says(str(caught.value), *words)
    with pytest.raises(InputError) as caught:
        predictor.predict(parts.rename(columns={"rm_mpa": "Rm_MPa"}))
    says(str(caught.value), "'rm_mpa'", "the file has 'Rm_MPa'")
    with pytest.raises(InputError) as caught:
        predictor.predict(parts.head(0))
    says(str(caught.value), "no rows")


def test_the_api_refuses_a_doubled_column_and_a_table_that_is_not_one(predictor, parts):
    with pytest.raises(InputError) as caught:
        predictor.predict(pd.concat([parts.head(3), parts.head(3)[["die_temp_c"]]], axis=1))
    says(str(caught.value), "'die_temp_c' twice")
    with pytest.raises(InputError) as caught:
        predictor.predict(dict(predictor.typical))
    says(str(caught.value), "must be a pandas table", "not dict")


def test_set_alone_fills_typical_production_and_says_which(capsys, tmp_path):
    out = tmp_path / "one.csv"
    assert main(["predict", "--models", MODELS, "--set", "die_temp_c=30", "-o", str(out)]) == 0
    row = pd.read_csv(out).iloc[0]
    assert row["die_temp_c"] == 30.0
    assert "die_temp_c" not in row["filled_inputs"] and "rm_mpa" in row["filled_inputs"]
    says(row["filled_inputs"], "from typical production")
    assert main(["predict", "--models", MODELS, "--set", "die_temp_c=30,5"]) == 0  # a decimal comma typed
    says(capsys.readouterr().out, "prediction:", "interval:", "trust:", "die_temp_c=30.5")


def test_base_takes_the_other_inputs_from_a_row_of_the_users_own(tmp_path, parts):
    out = tmp_path / "based.csv"
    assert main(["predict", "--models", MODELS, "--base", str(DATA / "production_head.csv"), "--base-row", "3",
                 "--set", "shim20_mm=0.5", "-o", str(out)]) == 0  # fmt: skip
    row = pd.read_csv(out).iloc[0]
    assert row["shim20_mm"] == 0.5 and row["rm_mpa"] == pytest.approx(parts["rm_mpa"].iloc[2])
    says(row["filled_inputs"], "production_head.csv row 3")


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--set", "thickness=0.7"], ["'thickness' is not an input", "did you mean 'thickness_mm'"]),
        (["--set", "rm_mpa=1.234,5"], ["'1.234,5' is not a number"]),
        ([], ["nothing asked", "--set NAME=VALUE"]),
        (["--base", "nowhere.csv"], ["nowhere.csv", "does not exist"]),
        (["--set", "cushion_c1_kn=1,000"], ["'1,000' is ambiguous", "write 1000 or 1.000"]),
        (["--set", "die_temp_c=60", "--set", "die_temp_c=70"], ["die_temp_c is given twice"]),
        (["--set", "die_temp_c=60", "--base-row", "3"], ["--base-row without --base"]),
        (["sweep", "--vary", "die_temp_c=20:80:4", "--set", "die_temp_c=30"], ["the sweep varies it"]),
        (["sweep", "--vary", "die_temp_c=80:20:4"], ["LOW (80) must be below HIGH (20)"]),
        (["sweep", "--vary", "die_temp_c=20:80:1"], ["N (1) must be between 2 and 10000"]),
        (["sweep", "--vary", "die_temp_c=20:80"], ["write NAME=LOW:HIGH:N", "--vary die_temp_c=LOW:HIGH:N"]),
    ],
    ids=[
        "typo",
        "digit-grouping",
        "nothing",
        "base-missing",
        "comma-thousand",
        "twice",
        "base-row",
        "set-varied",
        "reversed",
        "one-value",
        "no-count",
    ],
)
def test_the_commands_mistakes_get_one_line(capsys, argv, words):
    command, argv = (argv[:1], argv[1:]) if argv[:1] == ["sweep"] else (["predict"], argv)
    assert main([*command, "--models", MODELS, *argv]) == 1
    error = capsys.readouterr().err.strip()
    assert error.startswith("error: ") and "\n" not in error
    says(error, *words)


def test_a_missing_input_is_named_as_one_the_models_take_not_as_a_config_key(capsys, tmp_path, parts):
    path = tmp_path / "settings.csv"
    parts.drop(columns="die_temp_c").head(3).to_csv(path, index=False)
    assert main(["predict", "--models", MODELS, str(path)]) == 1
    error = capsys.readouterr().err
    says(error, "no column 'die_temp_c'", "that the models take as an input")
    assert "config" not in error


def test_an_output_named_as_the_input_file_is_refused_and_the_file_kept(capsys, tmp_path, parts):
    path = tmp_path / "settings.csv"
    parts.head(3).to_csv(path, index=False)
    before = path.read_bytes()
    assert main(["predict", "--models", MODELS, str(path), "-o", str(path)]) == 1
    says(capsys.readouterr().err, "is the input file", "another file")
    assert path.read_bytes() == before


def test_help_names_the_separators(capsys):
    with pytest.raises(SystemExit):
        main(["predict", "--help"])
    says(capsys.readouterr().out, "--sep {comma,semicolon,tab,pipe}", "--decimal {point,comma}")


def test_a_predict_users_separator_hint_names_the_flag(tmp_path, parts):
    path = tmp_path / "semicolons.csv"
    parts.head(3).to_csv(path, sep=";", index=False)
    with pytest.raises(InputError) as caught:
        Predictor.load(MODELS).read(path, Predictor.load(MODELS).csv.__class__(fix="flag"))
    says(str(caught.value), "semicolon-separated", "--sep semicolon")


def test_a_sweep_writes_a_row_per_value_and_its_figure(tmp_path):
    out, figure = tmp_path / "sweep.csv", tmp_path / "sweep.png"
    argv = ["sweep", "--models", MODELS, "--vary", "die_temp_c=10:90:9", "-o", str(out), "--plot", str(figure)]
    assert main(argv) == 0
    swept = pd.read_csv(out)
    np.testing.assert_allclose(swept["die_temp_c"], np.linspace(10, 90, 9))
    assert "die_temp_c" not in swept["filled_inputs"].iloc[0]
    assert swept["trust"].iloc[-1] == trust.EXTRAPOLATION and np.isnan(swept["pred_upper"].iloc[-1])
    assert figure.stat().st_size > 10_000


def test_a_sweep_figure_names_the_inputs_unit(predictor):
    from hybridtwin.answers import whatif
    from hybridtwin.report import plots

    frame = whatif.sweep_frame(pd.DataFrame([predictor.typical]), "die_temp_c", np.linspace(10, 90, 5))
    answers = predictor.predict(frame)
    figure = plots.sweep(answers, "die_temp_c", predictor.doe_range["die_temp_c"], "draw_in_mm", "mm", "°C")
    assert figure.axes[0].get_xlabel() == "die_temp_c [°C]"
    assert plots.sweep(answers, "die_temp_c", (20, 50), "draw_in_mm", "mm").axes[0].get_xlabel() == "die_temp_c"
    # the recommended line is solid only where the answer is not an extrapolation, dashed beyond
    lines = {line.get_label(): line.get_ydata() for line in figure.axes[0].get_lines()}
    far = (answers["trust"] == trust.EXTRAPOLATION).to_numpy()
    assert far.any() and not far.all()
    assert np.isnan(lines["recommended model"][far]).all() and np.isfinite(lines["recommended model"][~far]).all()
    assert np.isfinite(lines["recommended, extrapolation"][far]).all()


def test_a_sweep_on_screen_shows_the_varied_input_and_why_rows_are_not_validated(capsys):
    assert main(["sweep", "--models", MODELS, "--vary", "die_temp_c=10:90:3"]) == 0
    shown = capsys.readouterr().out
    header, *rows = shown.splitlines()[:4]
    says(header, "row", "die_temp_c", "prediction", "trust")
    assert [row.split()[1] for row in rows] == ["10", "50", "90"]
    says(shown, "row 3: die_temp_c 90")  # the extrapolation's reason, numbered by its own row


def test_a_reader_that_stops_early_is_no_error_of_the_answer():
    # `hybridtwin ... | head -1` on an answer longer than the pipe holds: the rest unread is not a traceback
    argv = ["predict", "--models", MODELS, "--set", "die_temp_c=30"]
    long_answer = (
        "import sys; from hybridtwin import cli; cli.run = lambda args: print('row\\n' * 10**6); "
        f"sys.exit(cli.main({argv!r}))"
    )
    command = [sys.executable, "-c", long_answer]
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as process:
        first = process.stdout.readline()
        process.stdout.close()  # the command's next write breaks the pipe
        errors = process.stderr.read().decode()
    assert first == b"row\n"
    assert process.returncode == 0 and "Traceback" not in errors and "BrokenPipe" not in errors


def test_base_checks_only_the_row_asked_about(tmp_path, capsys):
    text = (DATA / "production_head.csv").read_text().splitlines()
    header = text[0].split(",")
    cells = text[5].split(",")
    cells[header.index("rm_mpa")] = "n/a"  # row 5 of the user's file has a text cell
    path = tmp_path / "base.csv"
    path.write_text("\n".join([*text[:5], ",".join(cells), *text[6:]]) + "\n")
    assert main(["predict", "--models", MODELS, "--base", str(path), "--base-row", "3", "--set", "die_temp_c=30"]) == 0
    assert main(["predict", "--models", MODELS, "--base", str(path), "--base-row", "5", "--set", "die_temp_c=30"]) == 1
    says(capsys.readouterr().err, "base file", "'rm_mpa'", "row 5")
    assert main(["predict", "--models", MODELS, "--base", str(path), "--base-row", "999"]) == 1
    says(capsys.readouterr().err, "no row 999", "400 data row(s)")


def test_a_row_of_a_region_recalibrated_on_its_test_parts_says_why(parts):
    from hybridtwin.answers.intervals import RegionIntervals

    plain = Predictor.load(MODELS).predict(parts, all_models=True)
    row = plain.index[(plain["trust"] == trust.CALIBRATED) & ~plain["in_support"]][0]
    region = plain.loc[row, "interval_region"]
    predictor = Predictor.load(MODELS)
    stored = predictor.intervals.to_dict()
    stored["recalibrated"] = {region: [32, 66]}
    predictor.intervals = RegionIntervals.from_dict(stored)
    answered = predictor.predict(parts)
    here = (plain["interval_region"] == region) & answered["pred_lower"].notna()
    says(
        answered.loc[row, "trust_reason"],
        "calibrated on the log's test parts here too",
        "covered 32 of 66 of them (48%)",
    )
    assert answered.loc[here, "trust_reason"].str.contains("covered 32 of 66").all()
    assert not answered.loc[~here, "trust_reason"].str.contains("covered 32 of 66").any()
