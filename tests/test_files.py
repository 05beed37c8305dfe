"""hybridtwin.io.files: the CSV writer (Arrow's text is pandas' text), output modes, orphaned jobs."""

import os

import numpy as np
import pandas as pd
import pytest


def _table_to_write():
    return pd.DataFrame(
        {
            "x": [1.0 / 3, np.nan, 1e-9, -2.5e7, np.inf, 43.4761234567, 0.125, -1.5e-20],
            "n": [1, 2, 3, 4, 5, 6, 7, 8],
            "text": ["a", "b, with a comma", 'a "quote"', "d", "", None, "ä", "h"],
            "flag": [True, False, True, False, True, True, False, False],
        }
    )


def test_csv_writer_with_a_decimal_comma_gives_pandas_float_format_text(tmp_path):
    from hybridtwin.io import files

    frame = _table_to_write()
    files.write_csv(frame, tmp_path / "ours.csv", sep=";", decimal=",")
    frame.to_csv(
        tmp_path / "pandas.csv", index=False, float_format=files.FLOAT_FORMAT, lineterminator="\n", sep=";", decimal=","
    )
    assert (tmp_path / "ours.csv").read_text() == (tmp_path / "pandas.csv").read_text()


@pytest.mark.parametrize("sep", [",", ";"])
def test_csv_writer_gives_the_float_format_values_and_every_other_value_back(tmp_path, sep):
    from hybridtwin.io import files

    frame = _table_to_write()
    files.write_csv(frame, tmp_path / "ours.csv", sep=sep)
    back = pd.read_csv(tmp_path / "ours.csv", sep=sep, keep_default_na=False, na_values=[""])
    expected = frame.assign(x=[float(files.FLOAT_FORMAT % value) for value in frame["x"]])
    expected["text"] = expected["text"].replace("", None)  # an empty text reads back as missing, as with pandas
    pd.testing.assert_frame_equal(back, expected, check_dtype=False)
    assert back["x"].tolist()[5] == 43.476123 and back["flag"].dtype == bool
    # exact digits: every float reads back to itself
    files.write_csv(frame, tmp_path / "exact.csv", float_format=None, sep=sep)
    assert pd.read_csv(tmp_path / "exact.csv", sep=sep)["x"].tolist()[5] == 43.4761234567


@pytest.mark.parametrize("float_format", ["%.8g", "%.3g", None])
def test_a_parquet_table_reads_back_as_its_csv_does(tmp_path, monkeypatch, float_format):
    """A step reads the same values from a per-part table in Parquet as from the same table in CSV: floats
    rounded alike, every other value and type kept (an empty text aside, which CSV cannot tell from missing)."""
    from hybridtwin.io import files

    monkeypatch.setattr(files, "ROWS_AT_ONCE", 3)  # written a few rows at a time, in both formats
    frame = _table_to_write().assign(text=lambda table: table["text"].replace("", "e"))
    files.write_csv(frame, tmp_path / "table.csv", float_format)
    files.write_table(frame, tmp_path / "table.parquet", float_format)
    as_csv, as_parquet = (files.read_checked(tmp_path / f"table.{kind}") for kind in ("csv", "parquet"))
    pd.testing.assert_frame_equal(as_parquet, as_csv)
    if float_format is None:
        assert as_parquet["x"].tolist()[2:] == frame["x"].tolist()[2:]  # every digit
    # only the columns asked for, in the file's order, as with a CSV
    pd.testing.assert_frame_equal(files.read_checked(tmp_path / "table.parquet", ["flag", "x"]), as_csv[["x", "flag"]])
    with pytest.raises(ValueError, match="'missing'"):
        files.read_checked(tmp_path / "table.parquet", ["x", "missing"])
    # only some rows, indexed by their positions, from either format
    for kind in ("csv", "parquet"):
        some = files.read_checked(tmp_path / f"table.{kind}", ["x", "flag"], rows=np.array([1, 4, 6]))
        pd.testing.assert_frame_equal(some, as_csv[["x", "flag"]].iloc[[1, 4, 6]])
    # a matrix of number columns in the order asked for, from either format, with no table beside it
    numbers = ["n", "x"]  # not the file's order
    for kind in ("csv", "parquet"):
        matrix = files.read_matrix(tmp_path / f"table.{kind}", numbers)
        assert np.array_equal(matrix, as_csv[numbers].to_numpy(float), equal_nan=True), kind
        some = files.read_matrix(tmp_path / f"table.{kind}", numbers, np.array([0, 5]))
        assert np.array_equal(some, matrix[[0, 5]], equal_nan=True), kind
    with pytest.raises(ValueError, match="'missing'"):
        files.read_matrix(tmp_path / "table.parquet", ["x", "missing"])


@pytest.mark.parametrize("rows_per_group", [3, 100])
def test_parquet_tables_joined_into_one_csv_a_row_group_at_a_time_are_their_join(tmp_path, monkeypatch, rows_per_group):
    from hybridtwin.io import files

    monkeypatch.setattr(files, "ROWS_AT_ONCE", rows_per_group)
    monkeypatch.setattr(files, "ROWS_PER_TEXT", 2)  # a row group's text in pieces
    table = _table_to_write().drop(columns="text")
    parts = [table[["x"]], table[["n", "flag"]], table[["x"]].rename(columns={"x": "y"}) * 2]
    paths = [tmp_path / f"part_{i}.parquet" for i in range(len(parts))]
    for part, path in zip(parts, paths):
        files.write_table(part, path)
    whole = []
    monkeypatch.setattr(files, "read_checked", lambda *args: whole.append(1) or pd.read_parquet(*args))
    files.write_joined_csv(paths, tmp_path / "joined.csv")
    assert not whole  # joined a row group at a time, never read whole
    files.write_csv(files.side_by_side(parts), tmp_path / "expected.csv")
    assert (tmp_path / "joined.csv").read_bytes() == (tmp_path / "expected.csv").read_bytes()


def test_parquet_tables_laid_out_otherwise_or_with_text_only_pandas_writes_are_joined_whole(tmp_path, monkeypatch):
    from hybridtwin.io import files

    table = pd.DataFrame({"x": [1.5, 2.5, 3.5, 4.5], "text": ["a", "b", "c\rd", "e"]})
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 2)
    files.write_table(table[["text"]], tmp_path / "text.parquet")  # a lone carriage return in the second group
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 3)
    files.write_table(table[["x"]], tmp_path / "x.parquet")  # row groups of 3 and 1 rows against 2 and 2
    files.write_table(table[["x"]].rename(columns={"x": "y"}), tmp_path / "y.parquet")
    for paths in (["x.parquet", "text.parquet"], ["y.parquet", "text.parquet"][::-1]):
        files.write_joined_csv([tmp_path / name for name in paths], tmp_path / "joined.csv")
        expected = files.side_by_side([pd.read_parquet(tmp_path / name) for name in paths])
        files.write_csv(expected, tmp_path / "expected.csv")
        assert (tmp_path / "joined.csv").read_bytes() == (tmp_path / "expected.csv").read_bytes()
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 2)  # the same layout, but the text is for pandas' writer
    files.write_table(table[["x"]], tmp_path / "x2.parquet")
    files.write_joined_csv([tmp_path / "x2.parquet", tmp_path / "text.parquet"], tmp_path / "joined.csv")
    files.write_csv(table, tmp_path / "expected.csv")
    assert (tmp_path / "joined.csv").read_bytes() == (tmp_path / "expected.csv").read_bytes()
    assert sorted(path.name for path in tmp_path.iterdir() if path.name.startswith(".")) == []  # no leftovers
    files.write_table(table.iloc[:3], tmp_path / "short.parquet")
    with pytest.raises(RuntimeError, match="different lengths"):
        files.write_joined_csv([tmp_path / "x.parquet", tmp_path / "short.parquet"], tmp_path / "bad.csv")


def test_the_loader_types_other_columns_as_a_csv_reader_does_and_a_parquet_copy_keeps_them(tmp_path):
    """Every step and the predictor see one type per column: the loader's. The checked copies were CSV files, whose
    reader typed True/False texts, numbers with blanks and empty texts; the loader types them so itself."""
    from hybridtwin.io import data, files

    text = "t,y,flag,counter,coil,shift,big\n1.0,2,True,1.5,K1,A,7\n2.0,3,False,,,B,\n3.0,4,True,2,K3,A,12\n"
    (tmp_path / "log.csv").write_text(text)
    columns = data.Columns(("t",), "y", "sim", "meas")
    loaded = data.load_production(tmp_path / "log.csv", columns)
    files.write_table(loaded, tmp_path / "copy.parquet", float_format=None)
    as_parquet = files.read_checked(tmp_path / "copy.parquet")
    as_csv = pd.read_csv(tmp_path / "log.csv", keep_default_na=False, na_values=[""])
    pd.testing.assert_frame_equal(as_parquet, as_csv, check_dtype=False)
    assert [str(as_parquet[name].dtype) for name in ("flag", "counter", "big")] == ["bool", "float64", "float64"]
    assert as_parquet["coil"].isna().tolist() == [False, True, False] and as_parquet["shift"].notna().all()


def test_write_table_writes_csv_unless_the_path_says_parquet(tmp_path):
    from hybridtwin.io import files

    files.write_table(_table_to_write(), tmp_path / "table.csv")
    assert (tmp_path / "table.csv").read_text().startswith("x,n,text,flag\n")


def test_a_plain_table_is_written_by_arrow_with_the_text_pandas_writes(tmp_path, monkeypatch):
    from hybridtwin.io import files

    frame = pd.DataFrame(
        {
            "x": [1.0 / 3, np.nan, 2.0, -0.0, np.inf, 123456789.0, 0.1],
            "n": [1, 2, 3, 4, 5, 6, -7],
            "text": ["a", None, "K26000", "", "ä", "2026-03-02 06:00:00", "b"],
            "flag": [True, False, True, False, True, True, False],
        }
    )
    arrow_writer, arrow_used = files._write_text_rows, []
    monkeypatch.setattr(files, "_write_text_rows", lambda *args: arrow_used.append(1) or arrow_writer(*args))
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 3)  # rows turned into text in chunks join up
    monkeypatch.setattr(files, "ROWS_PER_TEXT", 2)  # and a chunk's text in pieces
    for float_format, pandas_format in ((None, None), ("%.3g", "%.3g")):
        files.write_csv(frame, tmp_path / "ours.csv", float_format=float_format)
        expected = frame.assign(x=[float(pandas_format % v) for v in frame["x"]]) if pandas_format else frame
        expected.to_csv(tmp_path / "pandas.csv", index=False, lineterminator="\n")
        assert (tmp_path / "ours.csv").read_text() == (tmp_path / "pandas.csv").read_text()
    assert len(arrow_used) == 2 * 5  # two formats, three chunks each, in pieces of two rows (3 = 2 + 1)
    back = pd.read_csv(tmp_path / "ours.csv")
    assert back["x"].dtype == float and back["x"].tolist()[2] == 2.0  # a whole float stays a float


@pytest.mark.parametrize("sep", [",", ";", "\t"])
def test_text_with_separators_quotes_or_line_breaks_is_quoted_by_arrow_as_pandas_quotes_it(tmp_path, monkeypatch, sep):
    from hybridtwin.io import files

    frame = pd.DataFrame(
        {
            "x": [1.5, 2.5, np.nan, 4.0, 5.0],
            "reason": ["a, b; c", 'say "c"', None, "two\nlines", "tab\there"],
            "plain": ["a", "b", "c", "d", ""],
        }
    )
    arrow_writer, arrow_used = files._write_text_rows, []
    monkeypatch.setattr(files, "_write_text_rows", lambda *args: arrow_used.append(1) or arrow_writer(*args))
    monkeypatch.setattr(files, "LINES_PER_WRITE", 2)  # lines written in batches join up
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 4)  # and so do chunks of rows
    files.write_csv(frame, tmp_path / "ours.csv", float_format=None, sep=sep)
    frame.to_csv(tmp_path / "pandas.csv", index=False, lineterminator="\n", sep=sep)
    assert (tmp_path / "ours.csv").read_bytes() == (tmp_path / "pandas.csv").read_bytes()
    assert arrow_used == [1, 1]
    back = pd.read_csv(tmp_path / "ours.csv", sep=sep, keep_default_na=False, na_values=[""])
    assert back["reason"].tolist()[:2] == ["a, b; c", 'say "c"'] and back["reason"].tolist()[3] == "two\nlines"


@pytest.mark.parametrize(
    "frame",
    [
        pd.DataFrame({"x": [1.0, np.nan, 3.0]}),  # one column: pandas writes "" where Arrow would leave a blank line
        pd.DataFrame({"x": [1, "a"], "y": [1.0, 2.0]}),  # numbers and text in one column
        pd.DataFrame({"t": pd.to_datetime(["2020-01-01 10:00", "2020-01-02 00:00"]), "y": [1.0, 2.0]}),
        pd.DataFrame([[1.0, 2.0]], columns=["a", "a"]),  # the same name twice
        pd.DataFrame({1: [1.0], "1": [2.0]}),  # names that are not text
        pd.DataFrame({"x": [1.5, 2.5], "y": pd.Categorical(["a", "b"])}),
        pd.DataFrame({"x": [1.5, 2.5], "n": pd.array([1, None], dtype="Int64")}),
        pd.DataFrame({"x": [1.5, 2.5], "text": ["a\rb", "c"]}),  # a lone carriage return: quoted or not by version
        pd.DataFrame({"x, y": [1.5], "z": [2.5]}),
    ],
)
def test_any_other_table_is_written_by_pandas(tmp_path, frame):
    from hybridtwin.io import files

    files.write_csv(frame, tmp_path / "ours.csv", float_format=None)
    frame.to_csv(tmp_path / "pandas.csv", index=False, lineterminator="\n")
    assert (tmp_path / "ours.csv").read_text() == (tmp_path / "pandas.csv").read_text()


def test_a_chunk_only_pandas_writes_right_hands_the_whole_table_to_pandas(tmp_path, monkeypatch):
    from hybridtwin.io import files

    monkeypatch.setattr(files, "ROWS_AT_ONCE", 2)  # the first chunk is written by Arrow before the third is seen
    frame = pd.DataFrame({"x": [1.5, 2.5, 3.5, 4.5, 5.5], "text": ["a", "b", "c", "d\re", "f"]})
    files.write_csv(frame, tmp_path / "ours.csv", float_format=None)
    frame.to_csv(tmp_path / "pandas.csv", index=False, lineterminator="\n")
    assert (tmp_path / "ours.csv").read_bytes() == (tmp_path / "pandas.csv").read_bytes()


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_an_output_gets_the_mode_of_any_new_file(tmp_path, monkeypatch, mask):
    from hybridtwin.io import files

    monkeypatch.setattr(files, "_UMASK", mask)
    files.write_json({"a": 1}, tmp_path / "out.json")
    assert (tmp_path / "out.json").stat().st_mode & 0o777 == 0o666 & ~mask


def test_rounding_to_significant_digits_agrees_with_percent_g(tmp_path):
    from hybridtwin.io import files

    rng = np.random.default_rng(0)
    values = np.concatenate(
        [
            rng.normal(0, 1, 20_000) * 10.0 ** rng.integers(-300, 300, 20_000),
            rng.normal(0, 1, 20_000) * 10.0 ** rng.integers(-6, 7, 20_000),  # the sizes of measured values
            [0.0, -0.0, np.nan, np.inf, -np.inf, 5e-324, 1.7976931348623157e308, 0.125, 0.135, 999.99999999, 9.5],
        ]
    )
    for digits in (1, 2, 8, 10):
        expected = np.array([float(f"%.{digits}g" % value) for value in values])
        np.testing.assert_array_equal(files.rounded_to_significant(values, digits), expected)
    with pytest.raises(ValueError, match="1 to 10 significant"):
        files.write_csv(pd.DataFrame({"x": [1.0]}), tmp_path / "unused.csv", float_format="%.11g")
    assert not list(tmp_path.iterdir())


def test_a_job_whose_workflow_is_gone_writes_nothing(tmp_path, monkeypatch):
    import subprocess
    import sys

    from hybridtwin.io import files

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()  # reaped: its pid no longer runs
    target = tmp_path / "best_params.json"
    target.write_text("the later run's\n")
    monkeypatch.setenv(files.OWNER_ENVIRONMENT, str(gone.pid))
    with pytest.raises(files.OrphanedJob, match="cannot overwrite"):
        files.write_json({"params": 1}, target)
    assert target.read_text() == "the later run's\n"
    assert [p.name for p in tmp_path.iterdir()] == ["best_params.json"]  # no temporary file left either
    monkeypatch.setenv(files.OWNER_ENVIRONMENT, str(os.getpid()))  # a running workflow: written
    files.write_json({"params": 1}, target)
    assert "params" in target.read_text()


def test_a_cluster_job_on_another_machine_is_not_taken_for_an_orphan(tmp_path, monkeypatch):
    from hybridtwin.io import files

    monkeypatch.setenv(files.OWNER_ENVIRONMENT, "999999999")  # no such process here
    monkeypatch.setenv(files.OWNER_ENVIRONMENT + "_HOST", "another-node")
    files.write_json({"params": 1}, tmp_path / "best.json")
    assert (tmp_path / "best.json").exists()


def test_a_table_without_rows_is_written_with_its_header(tmp_path):
    from hybridtwin.io import files

    empty = pd.DataFrame({"x": pd.Series([], dtype=float), "text": pd.Series([], dtype=str)})
    files.write_csv(empty, tmp_path / "empty.csv")
    assert (tmp_path / "empty.csv").read_text() == "x,text\n"
    assert files.row_slices(0) == [] and files.row_slices(0, at_least_one=True) == [slice(0, files.ROWS_AT_ONCE)]
