"""Loading and validating the user's three CSV files, in one place.

Every check stops with an :class:`InputError` whose message names the file, the
column and, where it applies, the row (as the line number an editor shows, the
header being line 1) and the offending value. Input files are only read.
"""
from __future__ import annotations

import csv
import io
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd


class InputError(ValueError):
    """Bad input data or configuration; the message says where and what."""


class DataWarning(UserWarning):
    """The data are usable but odd; the run goes on."""


@dataclass(frozen=True)
class Columns:
    """The configured column names (``columns:`` in the config)."""

    inputs: tuple[str, ...]
    target: str
    matched_simulated: str
    matched_measured: str

    @classmethod
    def from_config(cls, columns: dict) -> "Columns":
        inputs = tuple(columns.get("inputs") or ())
        names = cls(inputs, columns.get("target", ""), columns.get("matched_simulated", ""),
                    columns.get("matched_measured", ""))
        names.check()
        return names

    def check(self) -> None:
        if not self.inputs:
            raise InputError("config columns.inputs is empty: list the process and material input columns")
        repeated = sorted({name for name in self.inputs if self.inputs.count(name) > 1})
        if repeated:
            raise InputError(f"config columns.inputs lists {', '.join(map(repr, repeated))} more than once")
        for key in ("target", "matched_simulated", "matched_measured"):
            value = getattr(self, key)
            if not value:
                raise InputError(f"config columns.{key} is empty")
            if value in self.inputs:
                raise InputError(f"config columns.{key} {value!r} is also listed in columns.inputs: "
                                 "a target cannot be an input")


@dataclass(frozen=True)
class CsvFormat:
    """How the CSV files are written (``csv:`` in the config)."""

    sep: str = ","
    decimal: str = "."

    @classmethod
    def from_config(cls, config: dict | None) -> "CsvFormat":
        config = config or {}
        return cls(config.get("sep", ","), config.get("decimal", "."))


def _line(row_index: int) -> str:
    """Data row (0-based) as the line an editor shows, the header being line 1."""
    return f"row {row_index + 1} (line {row_index + 2})"


def read_csv(path: str | Path, role: str, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    """Read one CSV as text columns, after checking it is a readable, non-empty text table."""
    path = Path(path)
    where = f"{role} file {str(path)!r}"
    if not path.exists():
        near = sorted(p.name for p in path.parent.glob("*.csv")) if path.parent.is_dir() else []
        hint = f"; CSV files in {str(path.parent)!r}: {', '.join(near)}" if near else ""
        raise InputError(f"{where} does not exist (config data.{role}){hint}")
    if path.is_dir():
        raise InputError(f"{where} is a folder, not a CSV file (config data.{role})")
    raw = path.read_bytes()
    if b"\x00" in raw[:8192]:
        raise InputError(f"{where} is binary, not a CSV text file (an .xlsx workbook? export it as CSV UTF-8)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise InputError(f"{where} is not UTF-8 text: byte 0x{raw[error.start]:02x} at offset {error.start} "
                         "(save it as 'CSV UTF-8', or convert it from Latin-1/Windows-1252)") from None
    if not text.strip():
        raise InputError(f"{where} is empty: no header and no rows")
    header = next(csv.reader(io.StringIO(text), delimiter=fmt.sep))
    header = [name.strip() for name in header]
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        raise InputError(f"{where} has duplicated column names: {', '.join(map(repr, duplicated))}")
    frame = pd.read_csv(io.StringIO(text), sep=fmt.sep, dtype=str, keep_default_na=False,
                        skipinitialspace=True)
    frame.columns = header
    if frame.empty:
        raise InputError(f"{where} has a header and no rows")
    return frame


def _looks_like(value: str, header: list[str], fmt: CsvFormat) -> str:
    """Name the export dialect a bad value suggests."""
    if ";" in value or any(";" in name for name in header):
        return " — this looks like a semicolon-separated export: set csv.sep: ';' (and csv.decimal: ',') in the config"
    if fmt.decimal == "." and "," in value and _is_number(value.replace(",", ".")):
        return " — this looks like a decimal comma (European Excel export): set csv.decimal: ',' in the config"
    return ""


def _is_number(value: str) -> bool:
    try:
        float(value)
    except ValueError:
        return False
    return True


def numeric_column(frame: pd.DataFrame, column: str, where: str, fmt: CsvFormat,
                   allow_missing: bool = False) -> pd.Series:
    """Column as float; stop at the first value that is not a finite number."""
    text = frame[column].astype(str).str.strip()
    if fmt.decimal != ".":
        text = text.str.replace(fmt.decimal, ".", regex=False)
    values = pd.to_numeric(text, errors="coerce")
    bad = values.isna() & (text != "") if allow_missing else values.isna()
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        value = frame[column].iloc[row]
        shown = "an empty cell" if str(value).strip() == "" else f"value {value!r}"
        hint = _looks_like(str(value), list(frame.columns), fmt)
        raise InputError(f"{where}, column {column!r}, {_line(row)}: {shown} is not a number "
                         f"({int(bad.sum())} such row(s) in this column){hint}")
    infinite = np.isinf(values.to_numpy(float))
    if infinite.any():
        row = int(np.flatnonzero(infinite)[0])
        raise InputError(f"{where}, column {column!r}, {_line(row)}: value {frame[column].iloc[row]!r} "
                         "is infinite (a sensor or export fault?)")
    return values.astype(float)


def require_columns(frame: pd.DataFrame, columns, where: str, config_key: str) -> None:
    missing = [name for name in columns if name not in frame.columns]
    if not missing:
        return
    known = {name.lower().replace(" ", "").replace("_", ""): name for name in frame.columns}
    hints = []
    for name in missing:
        close = known.get(name.lower().replace(" ", "").replace("_", ""))
        hints.append(f"{name!r}" + (f" (the file has {close!r})" if close else ""))
    raise InputError(f"{where} has no column {', '.join(hints)} named in config {config_key}; "
                     f"its columns are: {', '.join(map(repr, frame.columns))}")


def load_table(path, role: str, numeric: list[str], fmt: CsvFormat, config_key: str) -> pd.DataFrame:
    """Read a CSV and convert the configured numeric columns; other columns stay as text."""
    frame = read_csv(path, role, fmt)
    where = f"{role} file {str(path)!r}"
    require_columns(frame, numeric, where, config_key)
    for column in numeric:
        frame[column] = numeric_column(frame, column, where, fmt)
    return frame


def load_doe(path, columns: Columns, fmt: CsvFormat = CsvFormat(), min_rows: int = 2) -> pd.DataFrame:
    doe = load_table(path, "doe", [*columns.inputs, columns.target], fmt, "columns.inputs/target")
    where = f"doe file {str(path)!r}"
    if len(doe) < min_rows:
        raise InputError(f"{where} has {len(doe)} rows, fewer than the {min_rows} needed "
                         "(cv.folds folds and the kNN gate's k neighbours)")
    spread = doe[list(columns.inputs)].std(ddof=1)
    constant = [name for name in columns.inputs if not spread[name] > 0]
    if constant:
        raise InputError(f"{where}: input column(s) {', '.join(map(repr, constant))} are constant over the DoE "
                         "(standard deviation 0), so they cannot be standardized; drop them from columns.inputs")
    return doe


def load_production(path, columns: Columns, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    production = load_table(path, "production", [*columns.inputs, columns.target], fmt,
                            "columns.inputs/target")
    return _numeric_extras(production, [*columns.inputs, columns.target], fmt)


def load_matched(path, columns: Columns, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    numeric = [*columns.inputs, columns.matched_simulated, columns.matched_measured]
    matched = load_table(path, "matched", numeric, fmt, "columns.inputs/matched_simulated/matched_measured")
    return _numeric_extras(matched, numeric, fmt)


def _numeric_extras(frame: pd.DataFrame, done: list[str], fmt: CsvFormat) -> pd.DataFrame:
    """Log columns (counters, temperatures) that read as numbers become numbers; the rest stay text."""
    for column in frame.columns:
        if column in done:
            continue
        text = frame[column].astype(str).str.strip()
        if fmt.decimal != ".":
            text = text.str.replace(fmt.decimal, ".", regex=False)
        values = pd.to_numeric(text, errors="coerce")
        if values.notna().all() and np.isfinite(values.to_numpy(float)).all():
            frame[column] = values
    return frame


def range_report(reference: pd.DataFrame, frame: pd.DataFrame, inputs) -> pd.DataFrame:
    """Per input: the reference (DoE) range, the frame's range, and how far the frame lies outside."""
    rows = []
    for name in inputs:
        low, high = float(reference[name].min()), float(reference[name].max())
        values = frame[name].to_numpy(float)
        span = high - low
        below = max(0.0, low - float(values.min()))
        above = max(0.0, float(values.max()) - high)
        outside = float(np.mean((values < low) | (values > high)))
        rows.append({"column": name, "doe_min": low, "doe_max": high,
                     "min": float(values.min()), "max": float(values.max()),
                     "share_outside": outside,
                     "beyond_range_in_spans": max(below, above) / span if span > 0 else math.inf})
    return pd.DataFrame(rows)


def describe_out_of_range(report: pd.DataFrame, limit: float = 0.0) -> str:
    """One line per input that lies outside the DoE range by more than ``limit`` DoE spans."""
    lines = []
    for row in report.itertuples():
        if row.beyond_range_in_spans > limit:
            ratio = max(abs(row.min), abs(row.max)) / max(abs(row.doe_min), abs(row.doe_max), 1e-12)
            units = " — a unit mix-up?" if ratio > 5 or ratio < 0.2 else ""
            lines.append(f"  {row.column}: data {row.min:.4g}..{row.max:.4g}, DoE {row.doe_min:.4g}..{row.doe_max:.4g}, "
                         f"{row.share_outside:.0%} of rows outside, up to {row.beyond_range_in_spans:.2f} DoE spans beyond{units}")
    return "\n".join(lines)


def warn(message: str) -> None:
    warnings.warn(message, DataWarning, stacklevel=2)


def load_datasets(config: dict) -> dict[str, pd.DataFrame]:
    """Read and check the three configured files; warn on usable oddities."""
    columns = Columns.from_config(config["columns"])
    fmt = CsvFormat.from_config(config.get("csv"))
    folds = int(config.get("cv", {}).get("folds", 5))
    k = int(config.get("gate", {}).get("k", 5))
    doe = load_doe(config["data"]["doe"], columns, fmt, min_rows=max(folds, k + 1))
    production = load_production(config["data"]["production"], columns, fmt)
    matched = load_matched(config["data"]["matched"], columns, fmt)
    far = describe_out_of_range(range_report(doe, production, columns.inputs), limit=0.5)
    if far:
        warn(f"production file {config['data']['production']!r}: columns lie far outside the DoE ranges "
             f"(more than half a DoE span):\n{far}")
    return {"doe": doe, "production": production, "matched": matched}


def read_checked(path) -> pd.DataFrame:
    """Read a checked copy written by the workflow's validation step."""
    return pd.read_csv(path, keep_default_na=False, na_values=[""])


def check_support(production_in: np.ndarray, matched_in: np.ndarray, doe: pd.DataFrame, production: pd.DataFrame,
                  matched: pd.DataFrame, inputs, paths: dict, threshold: float) -> None:
    """Stop when no production row is in support; warn for matched cases outside it."""
    if not production_in.any():
        report = describe_out_of_range(range_report(doe, production, inputs))
        raise InputError(
            f"production file {paths['production']!r}: no row lies inside the DoE support "
            f"(kNN distance threshold {threshold:.3g} in DoE-standardized units), so no residual can be learned."
            + (f" Columns outside the DoE ranges:\n{report}" if report else
               " Every column is inside the DoE ranges, but the combinations are far from every DoE point.")
            + "\nCheck units and column mapping, or enrich the DoE towards the production window.")
    if not matched_in.all():
        outside = matched.index[~matched_in].tolist()
        warn(f"matched file {paths['matched']!r}: {len(outside)} of {len(matched)} matched case(s) lie outside the "
             f"DoE support (rows {', '.join(str(i + 1) for i in outside)}); the gated hybrid reverts to the "
             "surrogate there")
