"""Reading the user's CSV files: the dialect (separator, decimal mark), the text, the rectangle, the numbers.

Every fault stops with an :class:`InputError` whose message names the file, the column and, where it
applies, the row and the offending value, with the line an editor shows ("row N (line N+1)"), and says
what the fault looks like where it can (a decimal comma, a semicolon-separated export, a unit in a cell).
"""

from __future__ import annotations

import csv
import difflib
import io
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin.io import files
from hybridtwin.io.errors import InputError, other_csvs


class DataWarning(UserWarning):
    """The data are usable but odd; the run goes on."""


# separators the config may name, and how a message (and the command line) calls an export written with them
SEPARATORS = {",": "comma", ";": "semicolon", "\t": "tab", "|": "pipe"}
# the text encodings a file may have (csv.encoding): Python's codec for each; German Excel's CSV is Windows-1252
ENCODINGS = {"utf-8": "utf-8-sig", "windows-1252": "cp1252"}


@dataclass(frozen=True)
class CsvFormat:
    """How the CSV files are written (``csv:`` in the config), and where a user changes it: ``fix`` 'config'
    (the workflow's files) or 'flag' (the command line's)."""

    sep: str = ","
    decimal: str = "."
    encoding: str = "utf-8"
    fix: str = "config"

    @classmethod
    def from_config(cls, config: dict) -> "CsvFormat":
        """From the checked config's ``csv:`` (the schema lists the separators, decimal marks and encodings)."""
        return cls(config["sep"], config["decimal"], config.get("encoding", "utf-8"))

    @property
    def codec(self) -> str:
        return ENCODINGS[self.encoding]

    def setting(self, key: str, value: str) -> str:
        """How the user sets ``key`` (sep, decimal, encoding) to ``value``: in the config, or with a flag."""
        if self.fix == "flag":
            shown = {"sep": SEPARATORS, "decimal": {".": "point", ",": "comma"}}.get(key, {}).get(value, value)
            return f"--{key} {shown}"
        shown = '"\\t"' if value == "\t" else repr(value)
        return f"csv.{key}: {shown} in the config"


# cell texts that mean "no value" (compared in lower case); an empty cell means the same
MISSING_TEXTS = frozenset({"nan", "-nan", "+nan", "na", "n/a", "#n/a", "null", "none", "missing", "<na>"})


def _line(row_index: int) -> str:
    """Data row (0-based) as the line an editor shows, the header being line 1."""
    return f"row {row_index + 1} (line {row_index + 2})"


def _decode(raw: bytes, where: str, fmt: CsvFormat) -> str:
    """The file's text; stop on workbooks, binary content and text that is not in the file's encoding."""
    if raw.startswith(b"PK\x03\x04"):
        raise InputError(
            f"{where} is an Excel workbook (.xlsx) or another zip archive, not a CSV text file: "
            "open it in Excel and save it as 'CSV UTF-8 (comma delimited)'"
        )
    if raw.startswith(b"\xd0\xcf\x11\xe0"):
        raise InputError(
            f"{where} is an old Excel workbook (.xls), not a CSV text file: "
            "open it in Excel and save it as 'CSV UTF-8 (comma delimited)'"
        )
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise InputError(f"{where} is UTF-16 text (Excel's 'Unicode Text'), not UTF-8: save it as 'CSV UTF-8'")
    nul = raw.find(b"\x00")
    if nul >= 0:
        line = raw.count(b"\n", 0, nul) + 1
        raise InputError(
            f"{where} is binary, not a CSV text file: NUL byte at offset {nul} (line {line}); "
            "export the table as 'CSV UTF-8'"
        )
    try:
        return raw.decode(fmt.codec)
    except UnicodeDecodeError as error:
        at = error.start
        line = raw.count(b"\n", 0, at) + 1
        place = "the header (line 1)" if line == 1 else _line(line - 2)
        if fmt.encoding != "utf-8":
            raise InputError(
                f"{where} is not {fmt.encoding} text either: byte 0x{raw[at]:02x} in {place}"
                f"{_column_at(raw, at, fmt)}, offset {at}, means nothing in it; save the file as 'CSV UTF-8'"
            ) from None
        char = bytes([raw[at]]).decode("cp1252", errors="replace")
        raise InputError(
            f"{where} is not UTF-8 text: byte 0x{raw[at]:02x} ({char!r} in Windows-1252) in "
            f"{place}{_column_at(raw, at, fmt)}, offset {at}; an Excel export in Windows-1252 (German Excel's "
            f"'CSV'): set {fmt.setting('encoding', 'windows-1252')}; or save the file as 'CSV UTF-8'"
        ) from None


def _column_at(raw: bytes, at: int, fmt: CsvFormat) -> str:
    """', column NAME' for the byte offset ``at`` (read as Latin-1, which never fails), or ''."""
    try:
        header = next(csv.reader([raw[: raw.find(b"\n")].decode("latin-1")], delimiter=fmt.sep))
        start = raw.rfind(b"\n", 0, at) + 1
        if start == 0:
            return ""
        fields = next(csv.reader([raw[start : at + 1].decode("latin-1")], delimiter=fmt.sep))
    except (csv.Error, StopIteration):
        return ""
    index = len(fields) - 1
    return f", column {header[index].strip()!r}" if 0 <= index < len(header) else ""


def _separator_hint(header: list[str], fmt: CsvFormat) -> str:
    """When the header reads as if written with another separator than csv.sep: name it."""
    for sep, name in SEPARATORS.items():
        if sep == fmt.sep:
            continue
        if (len(header) == 1 and sep in header[0]) or (sep in ";\t|" and any(sep in str(h) for h in header)):
            decimal = f" (and {fmt.setting('decimal', ',')} if its numbers are written like 0,71)" if sep == ";" else ""
            return f" — this looks like a {name}-separated export: set {fmt.setting('sep', sep)}{decimal}"
    return ""


def _ragged_hint(header: list[str], fields: list[str], fmt: CsvFormat) -> str:
    hint = _separator_hint(header, fmt)
    if hint:
        return hint
    cells = [field.strip() for field in fields]
    if (
        fmt.sep == ","
        and sum(bool(re.fullmatch(r"[-+]?\d+", cell)) for cell in cells) >= 2
        and not any(re.fullmatch(r"[-+]?\d*\.\d+([eE][-+]?\d+)?", cell) for cell in cells)
    ):
        return (
            " — this looks like a decimal comma in a comma-separated file: each number splits in two at its "
            f"comma. Export with {fmt.setting('sep', ';')} and {fmt.setting('decimal', ',')} (the European Excel "
            "CSV), or quote the values"
        )
    return (
        f" — a stray {SEPARATORS.get(fmt.sep, repr(fmt.sep))} at the end of the line, or a text value "
        "holding the separator that is not quoted?"
    )


def _config_entry(role: str) -> str:
    return f" (config data.{role})" if role in ("doe", "production", "matched") else ""


def read_csv(path: str | Path, role: str, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    """Read one CSV as text columns, after checking it is a readable, non-empty, rectangular text table.

    Blank lines (or lines of bare separators, as Excel writes empty rows) are skipped, with
    a :class:`DataWarning` when they lie between data rows. The frame's index is each row's
    place in the file (0 for line 2), so that messages name the line an editor shows even
    below a skipped blank line.
    """
    path = Path(path)
    where = f"{role} file {str(path)!r}"
    if not path.exists():
        raise InputError(f"{where} does not exist{_config_entry(role)}{other_csvs(path)}")
    if path.is_dir():
        raise InputError(f"{where} is a folder, not a CSV file{_config_entry(role)}")
    text = _decode(path.read_bytes(), where, fmt)
    if not text.strip():
        raise InputError(f"{where} is empty: no header and no rows")
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=fmt.sep, skipinitialspace=True)
    try:
        rows = list(reader)
    except csv.Error as error:
        raise InputError(f"{where}, line {reader.line_num}: not readable as CSV ({error})") from None
    while rows and not any(field.strip() for field in rows[-1]):
        rows.pop()
    if not any(field.strip() for field in rows[0]):
        raise InputError(f"{where}: line 1 is blank; the header (the column names) must be on line 1")
    header = [name.strip() or f"Unnamed: {i}" for i, name in enumerate(rows[0])]
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        raise InputError(
            f"{where} has duplicated column names: {', '.join(map(repr, duplicated))}; every column needs its own name"
        )
    body = rows[1:]
    if not body:
        raise InputError(f"{where} has a header and no rows")
    width = len(header)
    kept, blank = [], []
    for index, fields in enumerate(body):
        if not any(field.strip() for field in fields):
            blank.append(index)
            continue
        if len(fields) > width:
            if any(field.strip() for field in fields[width:]):
                raise InputError(
                    f"{where}, {_line(index)}: {len(fields)} fields, but the header has {width} "
                    f"column{'s' if width > 1 else ''}{_ragged_hint(header, fields, fmt)}"
                )
            del fields[width:]
        elif len(fields) < width:
            fields.extend([""] * (width - len(fields)))
        kept.append(index)
    if blank:
        lines = ", ".join(str(index + 2) for index in blank[:10]) + (", …" if len(blank) > 10 else "")
        warn(f"{where}: {len(blank)} blank line(s) skipped (line {lines})")
    # the index keeps each row's place in the file, so that messages name the right line
    return pd.DataFrame([body[index] for index in kept], columns=header, index=kept, dtype=str)


def _looks_like(value: str, header: list[str], fmt: CsvFormat) -> str:
    """Name the export dialect (or the slip) a value that is not a number suggests."""
    hint = _separator_hint(header, fmt)
    if hint:
        return hint
    value = value.strip()
    if fmt.decimal == "." and value.count(",") == 1 and "." not in value and _is_number(value.replace(",", ".")):
        return f" — this looks like a decimal comma (European Excel export): set {fmt.setting('decimal', ',')}"
    if fmt.decimal == "." and "," in value and "." in value and _is_number(value.replace(",", "")):
        return " — a thousands separator? export the numbers without digit grouping"
    if fmt.decimal == "," and "." in value and _is_number(value.replace(".", "").replace(",", ".")):
        return " — a thousands separator? export the numbers without digit grouping"
    if value.startswith("#"):
        return " — an Excel error value: fix the formula in the workbook and export again"
    if re.fullmatch(r"[-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?\s*[^\d\s.,].*", value):
        return " — a unit in the cell? keep only the number in the cell (the unit belongs in the column name)"
    return ""


def _is_number(value: str) -> bool:
    try:
        float(value)
    except ValueError:
        return False
    return True


def numeric_column(
    frame: pd.DataFrame, column: str, where: str, fmt: CsvFormat, allow_missing: bool = False
) -> pd.Series:
    """Column as float; stop at the first cell that is missing, not a number, or infinite.

    Missing means an empty cell or a text such as 'NaN', 'nan', 'NA', 'null' (with
    ``allow_missing`` those become NaN instead).
    """
    series = frame[column]
    original = series.astype(str).where(series.notna(), "")
    text = original.str.strip()
    parsed = text.str.replace(fmt.decimal, ".", regex=False) if fmt.decimal != "." else text
    values = pd.to_numeric(parsed, errors="coerce").astype(float)
    missing = (text == "") | text.str.lower().isin(MISSING_TEXTS)
    not_number = values.isna() & ~missing
    infinite = pd.Series(np.isinf(values.to_numpy()), index=values.index)
    if allow_missing:
        values[missing] = np.nan
        missing[:] = False
    bad = (missing | not_number | infinite).to_numpy()
    if not bad.any():
        return values
    row = int(np.flatnonzero(bad)[0])
    value = text.iloc[row]
    counts = [
        f"{int(mask.sum())} {label} cell(s)"
        for mask, label in ((missing, "missing"), (not_number, "non-numeric"), (infinite, "infinite"))
        if mask.any()
    ]
    label = frame.index[row]  # read_csv's frames are indexed by the row's place in the file
    place = f"{where}, column {column!r}, {_line(int(label) if isinstance(label, (int, np.integer)) else row)}"
    tally = f" (this column has {', '.join(counts)})"
    if missing.iloc[row]:
        what = "an empty cell is missing (NaN)" if value == "" else f"value {value!r} is missing (NaN)"
        hint = " — this column needs a number in every row: fill the gap or drop the row"
    elif infinite.iloc[row]:
        what = f"value {value!r} is infinite"
        hint = " — a sensor or export fault? fix or drop the row"
    else:
        what = f"value {value!r} is not a number"
        hint = _looks_like(value, [str(name) for name in frame.columns], fmt)
    raise InputError(f"{place}: {what}{tally}{hint}")


def _squash(name: str) -> str:
    return re.sub(r"[^0-9a-z]", "", str(name).lower())


def require_columns(
    frame: pd.DataFrame, columns, where: str, config_key: str | dict, fmt: CsvFormat = CsvFormat()
) -> None:
    """Stop when a configured column is absent; name near misses and a wrong separator.

    ``config_key`` is the config entry naming the columns, or a mapping column -> entry; an entry that is not a
    config key (``columns.*``) says in words why the column is needed (a what-if user has no config).
    """
    missing = [name for name in columns if name not in frame.columns]
    if not missing:
        return
    present = [str(name) for name in frame.columns]
    squashed = {_squash(name): name for name in present}
    groups: dict[str, list[str]] = {}
    for name in missing:
        key = config_key.get(name, "columns") if isinstance(config_key, dict) else config_key
        close = squashed.get(_squash(name))
        if close:
            near = f" (the file has {close!r})"
        else:
            match = difflib.get_close_matches(name, present, n=1, cutoff=0.75)
            near = f" (did you mean {match[0]!r}?)" if match else ""
        groups.setdefault(key, []).append(f"{name!r}{near}")
    absent = " and no column ".join(f"{', '.join(names)} {_needed_as(key)}" for key, names in groups.items())
    shown = ", ".join(map(repr, present[:30])) + (f", … ({len(present)} in all)" if len(present) > 30 else "")
    raise InputError(f"{where} has no column {absent}; its columns are: {shown}{_separator_hint(present, fmt)}")


def _needed_as(key: str) -> str:
    return f"named in config {key}" if key.startswith("columns") else key


def load_table(path, role: str, numeric: list[str], fmt: CsvFormat, config_key: str | dict) -> pd.DataFrame:
    """Read a CSV and convert the configured numeric columns; other columns stay as text.

    A clean file is read in one pass of pandas' C parser; any other goes through the careful reader,
    which finds the first problem and names its file, column and row.
    """
    clean = _read_clean(path, numeric, fmt)
    if clean is not None:
        return clean
    frame = read_csv(path, role, fmt)
    where = f"{role} file {str(path)!r}"
    require_columns(frame, numeric, where, config_key, fmt)
    for column in numeric:
        frame[column] = numeric_column(frame, column, where, fmt)
    return frame


def _joined(chunks) -> pd.DataFrame:
    """The chunks of a CSV as one table, joined column by column: each chunk's columns are copied out of its blocks
    and the chunk let go, and each column's pieces let go once joined, so that the log is never held twice (the
    numbers of a ten-million-part log are 1 GB)."""
    pieces: dict = {}
    for chunk in chunks:
        for name in chunk.columns:
            pieces.setdefault(name, []).append(chunk[name].copy())
    return pd.DataFrame({name: pd.concat(pieces.pop(name)) for name in list(pieces)}, copy=False)


def _read_clean(path, numeric: list[str], fmt: CsvFormat) -> pd.DataFrame | None:
    """The table, when the file is clean: UTF-8, a rectangle with a unique header and no blank line, every
    configured column a finite number in every row. None otherwise (the careful reader then says why).

    What it returns is what the careful reader returns for the same file: text columns as text,
    numbers parsed exactly (round trip), each row indexed by its place in the file.
    """
    try:
        with open(path, encoding=fmt.codec, newline="") as handle:
            first = handle.readline()
        header = next(csv.reader([first], delimiter=fmt.sep, skipinitialspace=True))
        names = [name.strip() for name in header]
        if any(name == "" for name in names) or len(set(names)) < len(names) or not set(numeric) <= set(names):
            return None
        # a million rows at a time, each chunk's text then held by Arrow: pandas' C parser makes a Python string per
        # text cell, and a ten-million-part log's timestamps, coils and shifts held so took 2 GB at once
        chunks = pd.read_csv(
            path,
            sep=fmt.sep,
            decimal=fmt.decimal,
            header=0,
            names=names,
            dtype={name: float if name in numeric else str for name in names},
            na_filter=False,
            skip_blank_lines=False,
            skipinitialspace=True,
            encoding=fmt.codec,  # pandas >= 3.1 parses every number exactly (the round-trip converter)
            engine="c",
            chunksize=files.ROWS_AT_ONCE,
        )
        frame = _joined(chunks)
    except (OSError, ValueError, UnicodeDecodeError, StopIteration, csv.Error, pd.errors.ParserError):
        return None
    if frame.empty or not isinstance(frame.index, pd.RangeIndex):  # a wide first row became an index
        return None
    # a column at a time: a copy of every column at once held 1.2 GB more on a log of 10 million parts
    if any(frame[name].isna().any() for name in names):  # a short row, or a number that reads as NaN
        return None
    text = [name for name in names if name not in numeric]
    if any(frame[name].str.contains("\x00", regex=False).any() for name in text):  # binary content
        return None
    if not all(np.isfinite(frame[name].to_numpy(float)).all() for name in numeric):
        return None
    return frame


# the texts a CSV reader takes for booleans (pandas' own)
_FLAGS = {"True": True, "TRUE": True, "true": True, "False": False, "FALSE": False, "false": False}


def _numeric_extras(frame: pd.DataFrame, done: list[str], fmt: CsvFormat) -> pd.DataFrame:
    """The other columns (counters, temperatures, flags, ids) typed as a CSV reader types them, so that every step
    and the predictor see one type: numbers become numbers (an empty cell missing), True/False texts booleans,
    an empty text missing; the rest stay text."""
    for column in frame.columns:
        if column in done:
            continue
        text = frame[column]
        empty = text == ""
        filled = text[~empty] if empty.any() else text  # no copy of a full column (10 million parts)
        numbers = (
            _numbers(text, fmt) if len(filled) and _all_numbers(filled.iloc[:100], fmt) else None
        )  # text shows early
        if numbers is not None and _finite(numbers[~empty.to_numpy()]):  # parsed once, kept
            frame[column] = numbers
        elif len(filled) and filled.iloc[:100].isin(_FLAGS).all() and filled.isin(_FLAGS).all():
            flags = text.map(_FLAGS)
            frame[column] = flags.astype(bool) if not empty.any() else flags
        elif empty.any():
            frame[column] = text.mask(empty)
    return frame


def _numbers(series: pd.Series, fmt: CsvFormat) -> pd.Series:
    """A text column's values as numbers (NaN where one is not), a piece of rows at a time
    (:func:`files.row_slices`): parsing makes a Python string per value, 0.6 GB for a whole column of a
    ten-million-part log."""
    pieces = files.row_slices(len(series))
    if len(pieces) <= 1:
        return _parsed(series, fmt)
    return pd.concat([_parsed(series.iloc[rows], fmt) for rows in pieces])


def _parsed(series: pd.Series, fmt: CsvFormat) -> pd.Series:
    text = series.astype(str).str.strip()
    if fmt.decimal != ".":
        text = text.str.replace(fmt.decimal, ".", regex=False)
    return pd.to_numeric(text, errors="coerce")


def _all_numbers(series: pd.Series, fmt: CsvFormat) -> bool:
    return _finite(_numbers(series, fmt))


def _finite(values: pd.Series) -> bool:
    return bool(values.notna().all() and np.isfinite(values.to_numpy(float)).all())


def warn(message: str) -> None:
    warnings.warn(message, DataWarning, stacklevel=2)


def checked_numbers(frame: pd.DataFrame, columns, where: str, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    """The ``columns`` of a table in memory as floats, with the checks a CSV's get: the first empty, non-numeric
    or infinite cell stops with one line naming the column and the row (rows counted from 1)."""
    out = {}
    for column in columns:
        values = frame[column]
        if pd.api.types.is_numeric_dtype(values) and not pd.api.types.is_bool_dtype(values):
            numbers = values.to_numpy(float)
            if np.isfinite(numbers).all():
                out[column] = numbers
                continue
        text = frame[[column]].astype(object).where(frame[[column]].notna(), "").astype(str)
        text.index = np.arange(len(frame))
        out[column] = numeric_column(text, column, where, fmt).to_numpy(float)
    return pd.DataFrame(out, index=frame.index)
