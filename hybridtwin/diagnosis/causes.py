"""A cause of the simulation's error: which production column(s), read how.

The diagnosis chooses causes (:mod:`hybridtwin.diagnosis`), the extension fits their
terms (:mod:`hybridtwin.extension`); both name a cause with :class:`Cause` and read
its values from a table with :meth:`Cause.values`, so the two cannot read a column
differently. A timestamp column is a cause in elapsed hours since a fixed origin
(the earliest stamp of the rows it was chosen on), so new rows are read on the same
clock.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

KINDS = ("input", "log", "time", "group", "interaction")  # model input, other number, timestamp, id, input pair

# a column's unit read from the last part of its name, when the config gives none (units.inputs)
NAME_UNITS = {
    "c": "°C",
    "degc": "°C",
    "mm": "mm",
    "um": "µm",
    "mpa": "MPa",
    "gpa": "GPa",
    "kn": "kN",
    "bar": "bar",
    "pct": "%",
    "percent": "%",
    "deg": "°",
    "s": "s",
    "spm": "strokes/min",
}


def unit_of(column: str, configured: dict | None = None) -> str:
    """The unit of a number column: the configured one, else from its name (die_temp_c: °C, shim20_mm: mm,
    rp02_mpa: MPa), else ''."""
    if configured and column in configured:
        return configured[column]
    return NAME_UNITS.get(str(column).rsplit("_", 1)[-1].lower(), "") if "_" in str(column) else ""


MAX_UNPARSED_STAMPS = 0.01  # a text column is read as timestamps when at most this share fails to parse
LOOK_ROWS = 200  # the values a column is judged by before a whole log is parsed


def looks_like_timestamps(values: pd.Series) -> bool:
    """A text column whose first LOOK_ROWS values read as timestamps (a quick look before parsing a whole log); text
    that reads as numbers is numbers (a stroke counter 130480 read as text would parse as dates, one by one)."""
    if pd.api.types.is_numeric_dtype(values):
        return False
    head = values.iloc[:LOOK_ROWS]
    text = head.astype(str).str.strip()
    numbers = pd.to_numeric(text[text != ""], errors="coerce")  # a blank cell does not make a counter a date
    return not numbers.notna().all() and parse_timestamps(head) is not None


def parse_timestamps(values: pd.Series) -> pd.Series | None:
    """Text as timestamps (ISO first, then day-first formats), or None if they are not timestamps."""
    text = values.astype(str)
    stamps = pd.to_datetime(text, errors="coerce", format="ISO8601")
    if stamps.isna().mean() > MAX_UNPARSED_STAMPS:
        stamps = _day_first(text, stamps)
    return None if stamps.isna().mean() > MAX_UNPARSED_STAMPS else stamps


def _day_first(text: pd.Series, iso: pd.Series) -> pd.Series:
    """Day-first stamps: in the one format pandas infers from the first stamp, read at once, where every stamp
    has it (an Excel export's 04.03.2026 06:00:00: 13 times faster than each stamp on its own on 70,000);
    otherwise each stamp in its own format, those ``iso`` read as ISO as such."""
    with warnings.catch_warnings():  # a column pandas cannot infer one format for is read stamp by stamp below
        warnings.simplefilter("ignore", UserWarning)
        stamps = pd.to_datetime(text, errors="coerce", dayfirst=True)
    if stamps.notna().all():
        return stamps
    # year-first stamps among them are ISO ones (read day-first, 2026-03-06 would be the 3rd of June)
    return iso.fillna(pd.to_datetime(text, errors="coerce", format="mixed", dayfirst=True))


def elapsed_hours(values: pd.Series, origin: str | None = None) -> np.ndarray | None:
    """Timestamps as hours since ``origin`` (default: the earliest), or None if they are not timestamps."""
    stamps = parse_timestamps(values)
    if stamps is None:
        return None
    start = stamps.min() if origin is None else pd.Timestamp(origin)
    return ((stamps - start).dt.total_seconds() / 3600.0).to_numpy(float)


def time_origin(values: pd.Series) -> str:
    """The earliest timestamp, as text: the origin a time cause's elapsed hours count from."""
    return str(parse_timestamps(values).min())


@dataclass(frozen=True)
class Cause:
    name: str
    kind: str  # one of KINDS
    columns: tuple[str, ...]
    origin: str | None = None  # time causes: the timestamp elapsed hours count from

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"cause {self.name!r}: unknown kind {self.kind!r} (one of {', '.join(KINDS)})")

    def values(self, frame: pd.DataFrame) -> np.ndarray:
        """The values a cause's form is fitted on: numbers, elapsed hours, level labels or a column pair."""
        if self.kind == "interaction":
            return np.column_stack([frame[c].to_numpy(float) for c in self.columns])
        if self.kind == "time":
            return elapsed_hours(frame[self.columns[0]], self.origin)
        if self.kind == "group":
            return frame[self.columns[0]].astype(str).to_numpy()
        return frame[self.columns[0]].to_numpy(float)

    def unit(self, configured: dict | None = None) -> str:
        """The unit of the values a form is fitted on ('' for ids and input pairs)."""
        if self.kind == "time":
            return "h"
        if self.kind in ("group", "interaction"):
            return ""
        return unit_of(self.columns[0], configured)

    def to_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "columns": list(self.columns), "origin": self.origin}

    @classmethod
    def from_dict(cls, data: dict) -> "Cause":
        return cls(data["name"], data["kind"], tuple(data["columns"]), data.get("origin"))


@dataclass(frozen=True)
class Term:
    """A cause with the name of the form its effect takes: what the extension fits."""

    cause: Cause
    form: str

    def to_dict(self) -> dict:
        return {**self.cause.to_dict(), "form": self.form}

    @classmethod
    def from_dict(cls, data: dict) -> "Term":
        return cls(Cause.from_dict(data), data["form"])
