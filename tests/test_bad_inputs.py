"""Broken inputs and configs: each one must stop (or warn and go on) with a message that says where and what.

Most cases call the validation in :mod:`hybridtwin.data` in-process on small CSVs written to ``tmp_path``
(12 DoE rows x 3 inputs, 30 production rows, 3 matched cases). A handful run the real workflow in a
subprocess on a tiny config; each of those fails at the config check or at rule ``validate_inputs``
and takes a few seconds, none runs the whole workflow.
"""

from __future__ import annotations

import copy
import hashlib
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from hybridtwin.io import files
from hybridtwin.io.config import check
from hybridtwin.io.data import Columns, check_support, load_datasets, warn_matched_outside
from hybridtwin.io.errors import InputError
from hybridtwin.io.reading import CsvFormat, DataWarning, read_csv, require_columns
from hybridtwin.paper.gate import KNNSupportGate

from .conftest import run_command

ROOT = Path(__file__).resolve().parents[1]
INPUTS = ["thickness_mm", "die_temp_c", "cushion_kn"]
TARGET, SIMULATED, MEASURED = "draw_in_mm", "draw_in_sim_mm", "draw_in_meas_mm"
DOE_RANGES = {"thickness_mm": (0.70, 0.90), "die_temp_c": (20.0, 60.0), "cushion_kn": (200.0, 400.0)}


def _draw_in(frame: pd.DataFrame) -> np.ndarray:
    return 40 + 10 * frame["thickness_mm"] - 0.1 * frame["die_temp_c"] + 0.01 * frame["cushion_kn"]


def make_frames(seed: int = 0) -> dict[str, pd.DataFrame]:
    """Clean data: a 12-run DoE, 30 production rows inside its ranges (with a text column), 3 matched cases."""
    rng = np.random.default_rng(seed)

    def inputs(n, shrink):
        return pd.DataFrame(
            {
                name: low + (high - low) * (shrink + (1 - 2 * shrink) * rng.random(n))
                for name, (low, high) in DOE_RANGES.items()
            }
        )

    doe = inputs(12, 0.0)
    doe[TARGET] = _draw_in(doe)
    production = inputs(30, 0.2)
    production[TARGET] = _draw_in(production) + rng.normal(0, 0.3, 30)
    production["coil_id"] = [f"C{100 + i // 10}" for i in range(30)]
    matched = inputs(3, 0.25)
    matched[SIMULATED] = _draw_in(matched)
    matched[MEASURED] = matched[SIMULATED] + 0.5
    return {"doe": doe, "production": production, "matched": matched}


def sha256(paths) -> dict[str, str]:
    return {str(path): hashlib.sha256(Path(path).read_bytes()).hexdigest() for path in paths}


class Case:
    """Three CSVs in a folder and the settings ``load_datasets`` reads; break them, then load."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.frames = make_frames()
        self.settings = {
            "data": {name: str(folder / f"{name}.csv") for name in self.frames},
            "columns": {
                "inputs": list(INPUTS),
                "target": TARGET,
                "matched_simulated": SIMULATED,
                "matched_measured": MEASURED,
            },
            "csv": {"sep": ",", "decimal": "."},
            "cv": {"folds": 3},
            "gate": {"k": 5},
        }
        self.write()

    def path(self, name: str) -> Path:
        return Path(self.settings["data"][name])

    def write(self, **csv_options) -> dict:
        for name, frame in self.frames.items():
            frame.to_csv(self.path(name), index=False, **csv_options)
        return self.settings

    def set_cell(self, name: str, row: int, column: str, text: str) -> dict:
        """Write ``text`` literally into data row ``row`` (1-based, as messages count) of one file."""
        frame = self.frames[name]
        frame[column] = frame[column].astype(object)
        frame.loc[row - 1, column] = text
        return self.write()

    def write_text(self, name: str, text: str | bytes) -> dict:
        if isinstance(text, bytes):
            self.path(name).write_bytes(text)
        else:
            self.path(name).write_text(text, encoding="utf-8")
        return self.settings

    def load(self):
        """As in the workflow: the config checked against the schema first, then the data."""
        return load_datasets(check(copy.deepcopy(self.settings)))


@pytest.fixture
def case(tmp_path):
    return Case(tmp_path)


def fails(case: Case, *words: str) -> str:
    """load_datasets must raise an InputError whose message holds every one of ``words`` (plain text)."""
    with pytest.raises(InputError) as caught:
        case.load()
    message = str(caught.value)
    for word in words:
        assert word in message, f"{word!r} not in message:\n{message}"
    return message


# --- the clean data load, so that every failure below is due to the one thing broken ----------------------------


def test_clean_data_loads_without_warning(case):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        frames = case.load()
    assert [len(frames[name]) for name in ("doe", "production", "matched")] == [12, 30, 3]
    assert frames["doe"][INPUTS].dtypes.eq(float).all()
    assert frames["production"]["coil_id"].iloc[0] == "C100"


@pytest.mark.parametrize("sep, decimal, chunk", [(",", ".", 1_000_000), (";", ",", 7)])
def test_a_clean_file_read_in_one_pass_is_what_the_careful_reader_gives(case, monkeypatch, sep, decimal, chunk):
    from hybridtwin.io import reading

    monkeypatch.setattr(files, "ROWS_AT_ONCE", chunk)  # 7: the file read in chunks, as a long log is

    production = case.frames["production"]
    production["stamp"] = pd.date_range("2026-01-01", periods=30, freq="min").astype(str)
    production["stroke"] = np.arange(30) * 7
    case.settings["csv"] = {"sep": sep, "decimal": decimal}
    case.write(sep=sep, decimal=decimal)
    numeric = [*INPUTS, TARGET]
    assert reading._read_clean(case.path("production"), numeric, CsvFormat(sep, decimal)) is not None
    fast = case.load()["production"]
    monkeypatch.setattr(reading, "_read_clean", lambda *args: None)
    careful = case.load()["production"]
    pd.testing.assert_frame_equal(fast, careful, check_index_type=False)
    assert fast["stroke"].dtype == careful["stroke"].dtype and fast["stamp"].iloc[0] == "2026-01-01 00:00:00"


@pytest.mark.parametrize("text", ["", "nan", "inf", "1,5", "12 mm"])
def test_the_one_pass_reader_leaves_any_doubtful_number_to_the_careful_reader(case, text):
    from hybridtwin.io import reading

    case.set_cell("production", 4, "die_temp_c", text)
    assert reading._read_clean(case.path("production"), [*INPUTS, TARGET], CsvFormat()) is None


def test_the_one_pass_reader_leaves_wide_and_blank_rows_to_the_careful_reader(case, monkeypatch):
    from hybridtwin.io import reading

    lines = case.path("production").read_text().splitlines()
    numeric = [*INPUTS, TARGET]
    # a short row (its coil id missing) reads as the careful reader reads it: an empty cell
    case.write_text("production", "\n".join([*lines[:3], lines[3].rsplit(",", 1)[0], *lines[4:]]) + "\n")
    assert reading._read_clean(case.path("production"), numeric, CsvFormat())["coil_id"].iloc[2] == ""
    assert read_csv(case.path("production"), "production")["coil_id"].iloc[2] == ""
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 2)  # a broken row in the first chunk or a later one
    for broken in (
        [lines[0], lines[1] + ",extra", *lines[2:]],  # a first row wider than the header
        [*lines[:3], lines[3] + ",extra", *lines[4:]],  # a later row wider than the header
        [*lines[:3], "", *lines[3:]],  # a blank line
        [*lines[:3], lines[3].replace("C10", "C1\x000"), *lines[4:]],  # a NUL byte in a text cell
    ):
        case.write_text("production", "\n".join(broken) + "\n")
        assert reading._read_clean(case.path("production"), numeric, CsvFormat()) is None


# --- files: missing, misspelled, not a file, empty, binary, not UTF-8 -------------------------------------------


def test_misspelled_file_names_the_file_and_suggests_csvs_in_the_folder(case):
    case.settings["data"]["doe"] = str(case.folder / "dose.csv")
    message = fails(
        case, "doe file", "dose.csv", "does not exist", "config data.doe", "'doe.csv'", "did you mean 'doe.csv'"
    )
    assert "'matched.csv'" in message and "'production.csv'" in message


def test_missing_folder(case):
    case.settings["data"]["matched"] = str(case.folder / "no_such_folder" / "matched.csv")
    fails(case, "matched file", "does not exist", "config data.matched", "no_such_folder")


def test_folder_instead_of_file(case):
    case.settings["data"]["production"] = str(case.folder)
    fails(case, "production file", "is a folder, not a CSV file", "config data.production")


@pytest.mark.parametrize("content", ["", "   \n\n"], ids=["zero-bytes", "blank-lines"])
def test_empty_file(case, content):
    case.write_text("doe", content)
    fails(case, "doe file", "doe.csv", "is empty: no header and no rows")


def test_header_and_no_rows(case):
    case.write_text("matched", ",".join([*INPUTS, SIMULATED, MEASURED]) + "\n")
    fails(case, "matched file", "matched.csv", "has a header and no rows")


def test_xlsx_workbook_saved_as_csv(case):
    case.write_text("production", b"PK\x03\x04\x14\x00\x06\x00\x08\x00\x00\x00!\x00[Content_Types].xml" + bytes(200))
    fails(case, "production file", "production.csv", "Excel workbook (.xlsx)", "not a CSV text file", "CSV UTF-8")


def test_nul_bytes(case):
    text = case.path("doe").read_bytes()
    at = text.index(b"\n") + 5
    case.write_text("doe", text[:at] + b"\x00\x00" + text[at:])
    fails(case, "doe file", "doe.csv", "binary", "NUL byte", "line 2")


def test_latin1_text_names_line_column_and_byte(case):
    case.frames["production"]["supplier"] = "Stahlwerk"
    case.frames["production"].loc[6, "supplier"] = "Gie\u00dferei H\u00e4rtel"
    case.write(encoding="latin-1")
    fails(
        case,
        "production file",
        "production.csv",
        "not UTF-8",
        "0xdf",
        "row 7 (line 8)",
        "column 'supplier'",
        "csv.encoding: 'windows-1252'",
        "CSV UTF-8",
    )


def test_a_windows_1252_export_reads_with_its_encoding_and_a_file_that_is_neither_still_stops(case):
    case.frames["production"]["supplier"] = "Stahlwerk"
    case.frames["production"].loc[6, "supplier"] = "Gie\u00dferei H\u00e4rtel \u2013 \u00b0C"  # en dash: 0x96 in 1252
    case.write(encoding="cp1252")
    case.settings["csv"]["encoding"] = "windows-1252"
    assert case.load()["production"].loc[6, "supplier"] == "Gie\u00dferei H\u00e4rtel \u2013 \u00b0C"
    path = case.path("production")
    raw = path.read_bytes()
    path.write_bytes(raw.replace(b"Stahlwerk", b"Stahl\x81werk", 1))  # a byte Windows-1252 leaves undefined
    fails(case, "production file", "not windows-1252 text either", "0x81", "column 'supplier'", "CSV UTF-8")


# --- columns: absent, near misses, duplicated, separator -------------------------------------------------------


def test_column_absent_with_case_near_miss(case):
    case.frames["production"] = case.frames["production"].rename(columns={"die_temp_c": "Die_Temp_C"})
    case.write()
    fails(
        case,
        "production file",
        "production.csv",
        "has no column 'die_temp_c'",
        "the file has 'Die_Temp_C'",
        "columns.inputs",
    )


def test_column_absent_with_typo_near_miss(case):
    case.frames["doe"] = case.frames["doe"].rename(columns={"cushion_kn": "cushon_kn"})
    case.write()
    fails(case, "doe file", "has no column 'cushion_kn'", "did you mean 'cushon_kn'", "its columns are")


def test_matched_column_absent(case):
    case.frames["matched"] = case.frames["matched"].drop(columns=[MEASURED])
    case.write()
    fails(case, "matched file", "matched.csv", f"has no column '{MEASURED}'", "columns.matched_measured")


def test_duplicated_column_names(case):
    header, rest = case.path("doe").read_text().split("\n", 1)
    case.write_text("doe", header.replace("cushion_kn", "die_temp_c") + "\n" + rest)
    fails(case, "doe file", "doe.csv", "duplicated column names", "'die_temp_c'")


def test_semicolon_export_is_named_by_require_columns(case):
    case.write(sep=";")
    message = fails(
        case, "doe file", "has no column 'thickness_mm'", "looks like a semicolon-separated export", "csv.sep: ';'"
    )
    frame = read_csv(case.path("doe"), "doe")
    with pytest.raises(InputError, match="semicolon-separated export.*csv.sep: ';'"):
        require_columns(frame, INPUTS, "doe file 'doe.csv'", "columns.inputs")
    case.settings["csv"]["sep"] = ";"
    assert len(case.load()["doe"]) == 12, message


def test_tab_separated_export(case):
    case.write(sep="\t")
    fails(case, "doe file", "has no column 'thickness_mm'", "looks like a tab-separated export", 'csv.sep: "\\t"')
    case.settings["csv"]["sep"] = "\t"
    assert len(read_csv(case.path("matched"), "matched", CsvFormat(sep="\t")).columns) == 5
    assert len(case.load()["production"]) == 30


def test_european_excel_export_semicolon_and_decimal_comma(case):
    case.write(sep=";", decimal=",")
    fails(case, "semicolon-separated export", "csv.sep: ';'", "csv.decimal: ','")
    case.settings["csv"] = {"sep": ";", "decimal": ","}
    frames = case.load()
    assert frames["doe"]["thickness_mm"].between(0.7, 0.9).all()


# --- values: decimal comma, text, missing, infinite --------------------------------------------------------------


def test_decimal_comma_quoted_in_a_comma_separated_file(case):
    case.write(decimal=",")  # Excel quotes "0,71" when the separator is also a comma
    assert '"0,' in case.path("doe").read_text()
    fails(
        case,
        "doe file",
        "doe.csv",
        "column 'thickness_mm'",
        "row 1 (line 2)",
        "looks like a decimal comma",
        "csv.decimal: ','",
    )
    case.settings["csv"]["decimal"] = ","
    assert case.load()["doe"]["thickness_mm"].between(0.7, 0.9).all()


def test_decimal_comma_unquoted_splits_the_rows(case):
    text = case.path("doe").read_text()
    lines = text.splitlines()
    lines[3] = lines[3].replace(".", ",")
    case.write_text("doe", "\n".join(lines) + "\n")
    fails(
        case,
        "doe file",
        "row 3 (line 4)",
        "fields",
        "the header has 4 columns",
        "decimal comma",
        "csv.sep: ';'",
        "csv.decimal: ','",
    )


def test_stray_separator_in_one_row(case):
    lines = case.path("production").read_text().splitlines()
    lines[10] += ",oops"
    case.write_text("production", "\n".join(lines) + "\n")
    fails(case, "production file", "row 10 (line 11)", "6 fields", "the header has 5 columns")


@pytest.mark.parametrize(
    "value, hint", [("abc", ""), ("0.81 mm", "unit"), ("#DIV/0!", "Excel error"), ("1,234.5", "thousands separator")]
)
def test_text_where_a_number_goes(case, value, hint):
    case.set_cell("doe", 5, "die_temp_c", value)
    fails(case, "doe file", "doe.csv", "column 'die_temp_c'", "row 5 (line 6)", repr(value), "is not a number", hint)


@pytest.mark.parametrize(
    "name, column",
    [
        ("doe", "thickness_mm"),
        ("doe", TARGET),
        ("production", "cushion_kn"),
        ("production", TARGET),
        ("matched", MEASURED),
    ],
)
@pytest.mark.parametrize("value", ["NaN", "nan", "NA"])
def test_nan_text_is_reported_as_missing(case, name, column, value):
    case.set_cell(name, 2, column, value)
    fails(
        case, f"{name} file", f"{name}.csv", f"column '{column}'", "row 2 (line 3)", f"value '{value}' is missing (NaN)"
    )


def test_empty_cell_is_reported_as_missing(case):
    case.set_cell("production", 17, "die_temp_c", "")
    case.set_cell("production", 20, "die_temp_c", "")
    fails(
        case,
        "production file",
        "column 'die_temp_c'",
        "row 17 (line 18)",
        "an empty cell is missing (NaN)",
        "2 missing",
    )


def test_blank_lines_are_skipped_with_a_warning_and_later_rows_keep_their_line(case):
    case.set_cell("production", 20, "die_temp_c", "n/a")
    lines = case.path("production").read_text().splitlines()
    lines.insert(4, "")
    lines.insert(9, ",,,,")  # an empty row as Excel writes it
    case.write_text("production", "\n".join(lines) + "\n\n,,,,\n")  # trailing blank lines: skipped silently
    with pytest.warns(DataWarning, match=r"production file .*: 2 blank line\(s\) skipped \(line 5, 10\)"):
        # data row 20 of the clean file is line 23 now, two blank lines above it
        fails(case, "production file", "column 'die_temp_c'", "row 22 (line 23)", "value 'n/a' is missing (NaN)")
    assert lines[22].split(",")[1] == "n/a"
    case.write_text("production", "\n".join(lines).replace(",n/a,", ",45.0,") + "\n")
    with pytest.warns(DataWarning, match="blank line"):
        assert len(case.load()["production"]) == 30


@pytest.mark.parametrize("value", ["inf", "-inf", "Infinity"])
def test_infinite_values(case, value):
    case.set_cell("production", 9, TARGET, value)
    fails(case, "production file", f"column '{TARGET}'", "row 9 (line 10)", f"value '{value}' is infinite")


# --- DoE shape: constant column, too few rows ----------------------------------------------------------------


def test_constant_doe_column_cannot_be_standardized(case):
    case.frames["doe"]["die_temp_c"] = 40.0
    case.write()
    fails(
        case,
        "doe file",
        "column 'die_temp_c'",
        "constant",
        "standard deviation 0",
        "cannot be standardized",
        "every row is 40",
    )


def test_fewer_doe_rows_than_cv_folds(case):
    case.settings["cv"]["folds"] = 15
    fails(case, "doe file", "12 data rows", "cv.folds: 15 needs at least 15")


def test_fewer_doe_rows_than_the_gate_needs(case):
    case.frames["doe"] = case.frames["doe"].iloc[:5]
    case.write()
    fails(case, "doe file", "5 data rows", "gate.k: 5 needs at least 6")


# --- the configured columns and settings, in-process ------------------------------------------------------------


def test_target_listed_as_input(case):
    case.settings["columns"]["inputs"] = [*INPUTS, TARGET]
    fails(case, "config columns.target", repr(TARGET), "also listed in columns.inputs")


def test_empty_input_list(case):
    case.settings["columns"]["inputs"] = []
    fails(case, "config error: columns.inputs = [], must list at least 1")


def test_inputs_given_as_one_string(case):
    case.settings["columns"]["inputs"] = "thickness_mm"
    fails(case, "config error: columns.inputs = 'thickness_mm', must be a list")


def test_simulated_and_measured_are_the_same_column():
    with pytest.raises(InputError, match="columns.matched_simulated and columns.matched_measured are both"):
        Columns.from_config(
            {"inputs": INPUTS, "target": TARGET, "matched_simulated": MEASURED, "matched_measured": MEASURED}
        )


@pytest.mark.parametrize(
    "section, key, value, words",
    [
        ("cv", "folds", "three", "config error: cv.folds = 'three', must be a whole number"),
        ("gate", "k", 0, "config error: gate.k = 0, must be at least 1"),
        ("csv", "sep", ":", "config error: csv.sep = ':', must be one of ',', ';', '\\t', '|'"),
        ("tuning", "n_trials", 2.5, "config error: tuning.n_trials = 2.5, must be a whole number"),
        ("gate", "percentile", 150, "config error: gate.percentile = 150, must be at most 100"),
    ],
)
def test_config_value_of_wrong_type_or_range_in_process(case, section, key, value, words):
    case.settings.setdefault(section, {})[key] = value
    fails(case, words)


def test_config_data_entry_missing(case):
    del case.settings["data"]["matched"]
    fails(case, "config error: data.matched is missing (under data)")


@pytest.mark.parametrize(
    "key, value, line",
    [
        ("whatif", 5, "config error: whatif = 5, must be text or empty"),
        (
            "results_dir",
            __import__("datetime").date(2024, 6, 7),
            'config error: results_dir = "2024-06-07", must be text',
        ),
    ],
    ids=["number-for-a-path-or-nothing", "unquoted-yaml-date"],
)
def test_config_values_of_any_type_get_one_plain_line(case, key, value, line):
    case.settings[key] = value
    assert fails(case, line) == line


def test_a_blank_column_name_is_a_config_error(case):
    case.settings["columns"]["target"] = "  "
    fails(case, "config error: columns.target = '  ', must not be blank")


def test_a_misspelled_config_key_is_named_with_the_key_it_resembles(case):
    case.settings["tunning"] = {"n_trials": 3}
    fails(case, "config error: tunning is not a known key, did you mean 'tuning'?")


def test_the_schema_fills_in_the_defaults_of_what_the_config_leaves_out(case):
    config = check(copy.deepcopy(case.settings))
    assert config["tuning"]["n_trials"] == 25 and config["gate"]["percentile"] == 95
    assert config["demo"]["hidden_effect"]["form"] == "sigmoid" and config["cv"]["folds"] == 3  # given, kept


# --- the support: stop when no production row is inside, warn when matched cases are outside -------------------


def _support(frames: dict, gate_k: int = 5):
    gate = KNNSupportGate(k=gate_k, percentile=95).fit(frames["doe"][INPUTS])
    return gate, gate.predict(frames["production"][INPUTS]), gate.predict(frames["matched"][INPUTS])


def test_production_in_other_units_has_no_support():
    frames = make_frames()
    frames["production"]["cushion_kn"] *= 1000  # logged in N, the DoE in kN
    gate, production_in, matched_in = _support(frames)
    assert not production_in.any()
    paths = {"production": "prod.csv", "matched": "matched.csv"}
    with pytest.raises(InputError) as caught:
        check_support(production_in, frames["doe"], frames["production"], INPUTS, paths, gate.threshold_)
    message = str(caught.value)
    for word in (
        "production file 'prod.csv'",
        "no row lies inside the DoE support",
        "cushion_kn",
        "100% of rows outside",
        "DoE spans beyond",
        "about 1000 times the DoE values",
        "unit",
    ):
        assert word in message, message
    assert "thickness_mm" not in message and "die_temp_c:" not in message


def test_matched_cases_outside_the_support_warn_and_go_on():
    frames = make_frames()
    frames["matched"].loc[1, "die_temp_c"] = 95.0
    gate, production_in, matched_in = _support(frames)
    assert production_in.any() and not matched_in[1]
    with pytest.warns(
        DataWarning,
        match=r"matched file 'matched.csv': 1 of 3 matched case\(s\) lie outside the DoE "
        r"support \(row 2 \(line 3\)\)",
    ):
        warn_matched_outside(matched_in, {"production": "production.csv", "matched": "matched.csv"})


def test_production_far_outside_the_doe_ranges_warns_and_goes_on(case):
    case.frames["production"].loc[:4, "die_temp_c"] = 95.0
    case.write()
    with pytest.warns(
        DataWarning,
        match=r"(?s)production file .*production.csv.*far outside the DoE ranges.*"
        r"die_temp_c: data .*\.\.95, DoE .*17% of rows outside",
    ):
        frames = case.load()
    assert len(frames["production"]) == 30


# --- inputs are only read ----------------------------------------------------------------------------------------


def test_failed_load_leaves_input_files_unchanged(case):
    case.write(decimal=",")
    before = sha256(case.settings["data"].values())
    with pytest.raises(InputError):
        case.load()
    case.settings["csv"]["decimal"] = ","
    case.load()
    assert sha256(case.settings["data"].values()) == before


# --- the real workflow, up to its config check or its validate_inputs rule ---------------------------------------


def run_workflow(case: Case, **changes) -> subprocess.CompletedProcess:
    """Run the workflow in ``case.folder`` on config/test.yaml pointed at the case's files (relative paths)."""
    config = yaml.safe_load((ROOT / "config" / "test.yaml").read_text())
    config["data"] = {name: f"{name}.csv" for name in ("doe", "production", "matched")}
    config["columns"] = case.settings["columns"]
    config["gate"]["k"], config["cv"]["folds"], config["tuning"]["n_trials"] = 5, 3, 2
    for dotted, value in changes.items():
        section, key = dotted.split("__")
        config.setdefault(section, {})[key] = value
    configfile = case.folder / "config.yaml"
    configfile.write_text(yaml.safe_dump(config))
    environment = {**os.environ, "PYTHONWARNINGS": "ignore"}
    # the targets stop the run after the validate_inputs jobs, should the data pass
    return run_command(
        [
            sys.executable,
            "-m",
            "snakemake",
            *(f"results/data/{role}.parquet" for role in ("doe", "production", "matched")),
            "-s",
            str(ROOT / "Snakefile"),
            "-d",
            str(case.folder),
            "--configfile",
            str(configfile),
            "--cores",
            "1",
            "-q",
        ],
        timeout=300,
        env=environment,
    )


@pytest.mark.workflow
@pytest.mark.parametrize(
    "changes, line",
    [
        ({"tuning__n_trials": 0}, "config error: tuning.n_trials = 0, must be at least 1"),
        ({"gate__percentile": 150}, "config error: gate.percentile = 150, must be at most 100"),
        ({"cv__folds": "three"}, "config error: cv.folds = 'three', must be a whole number"),
        (
            {"data__doe": "doee.csv"},
            "config error: data.doe = 'doee.csv', no such file; CSV files in '.': "
            "'doe.csv', 'matched.csv', 'production.csv' — did you mean 'doe.csv'?",
        ),
    ],
    ids=["n_trials-0", "percentile-150", "folds-text", "data-file-missing"],
)
def test_workflow_stops_on_a_bad_config_with_one_plain_line(case, changes, line):
    result = run_workflow(case, **changes)
    assert result.returncode != 0, result.stderr
    assert line in result.stderr.splitlines(), result.stderr
    for noise in ("Traceback", "jsonschema", "MissingInputException", "Failed validating"):
        assert noise not in result.stderr, result.stderr
    assert not (case.folder / "results").exists()


@pytest.mark.workflow
def test_workflow_stops_on_a_decimal_comma_export_and_leaves_no_output(case):
    case.write(decimal=",")
    before = sha256(case.settings["data"].values())
    result = run_workflow(case)
    assert result.returncode != 0, result.stderr
    # All three files are comma exports; which one the scheduler checks first is not fixed.
    assert any(f"{role} file '{role}.csv'" in result.stderr for role in ("doe", "production", "matched")), result.stderr
    for word in ("column 'thickness_mm'", "row 1 (line 2)", "looks like a decimal comma", "csv.decimal: ','"):
        assert word in result.stderr, result.stderr
    assert "Traceback" not in result.stderr.split("RuleException")[0]
    assert sha256(case.settings["data"].values()) == before
    assert list((case.folder / "results").glob("data/*.parquet")) == []


@pytest.mark.workflow
def test_workflow_stops_on_a_missing_value(case):
    case.set_cell("production", 12, TARGET, "nan")
    result = run_workflow(case)
    assert result.returncode != 0, result.stderr
    for word in (
        "production file 'production.csv'",
        f"column '{TARGET}'",
        "row 12 (line 13)",
        "value 'nan' is missing (NaN)",
    ):
        assert word in result.stderr, result.stderr
    # Files are checked one by one: the bad file leaves no checked copy, and a good file checked
    # in the same run (whether it ran first depends on the scheduler) is complete.
    checked = case.folder / "results" / "data"
    assert not (checked / "production.parquet").exists()
    for role in ("doe", "matched"):
        if (checked / f"{role}.parquet").exists():
            assert len(pd.read_parquet(checked / f"{role}.parquet")) == len(pd.read_csv(case.settings["data"][role]))
    assert list(checked.glob(".*")) == []
