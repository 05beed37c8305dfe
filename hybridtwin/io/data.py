"""Loading and validating the user's three CSV files, in one place.

Every check stops with an :class:`InputError` whose message names the file, the
column and, where it applies, the row and the offending value. Data rows are
counted from 1 below the header and shown with the line an editor shows:
"row N (line N+1)". A message also says what the fault looks like where it can
(a decimal comma, a semicolon-separated export, a unit in a cell, a column name
that differs only in case). Usable oddities (blank lines, production far outside
the DoE ranges, matched cases outside the support) give a :class:`DataWarning`
and the run goes on. Input files are only read.

``tests/test_bad_inputs.py`` holds a corpus of broken inputs and the messages they give.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.io.errors import InputError
from hybridtwin.io.files import read_checked
from hybridtwin.io.reading import (
    CsvFormat,
    _line,
    _numeric_extras,
    load_table,
    numeric_column,
    read_csv,
    require_columns,
    warn,
)


@dataclass(frozen=True)
class Columns:
    """The configured column names (``columns:`` in the config)."""

    inputs: tuple[str, ...]
    target: str
    matched_simulated: str
    matched_measured: str

    @classmethod
    def from_config(cls, columns: dict) -> "Columns":
        """From the checked config (types, empty and repeated names are the schema's checks)."""
        names = cls(
            tuple(columns["inputs"]), columns["target"], columns["matched_simulated"], columns["matched_measured"]
        )
        names.check()
        return names

    def check(self) -> None:
        """What the schema cannot say: a target is not an input, and simulated and measured differ."""
        for key in ("target", "matched_simulated", "matched_measured"):
            value = getattr(self, key)
            if value in self.inputs:
                raise InputError(
                    f"config columns.{key} {value!r} is also listed in columns.inputs: a target cannot be an input"
                )
        if self.matched_simulated == self.matched_measured:
            raise InputError(
                f"config columns.matched_simulated and columns.matched_measured are both "
                f"{self.matched_simulated!r}: name the simulated and the measured column"
            )


def _config_keys(columns: Columns, *keys: str) -> dict[str, str]:
    """Configured column -> the config entry that names it."""
    names = {name: "columns.inputs" for name in columns.inputs}
    names.update({getattr(columns, key): f"columns.{key}" for key in keys})
    return names


def load_doe(
    path,
    columns: Columns,
    fmt: CsvFormat = CsvFormat(),
    min_rows: int = 2,
    folds: int | None = None,
    k: int | None = None,
) -> pd.DataFrame:
    doe = load_table(path, "doe", [*columns.inputs, columns.target], fmt, _config_keys(columns, "target"))
    where = f"doe file {str(path)!r}"
    needs = []
    if folds is not None and len(doe) < folds:
        needs.append(f"cv.folds: {folds} needs at least {folds}")
    if k is not None and len(doe) < k + 1:
        needs.append(f"gate.k: {k} needs at least {k + 1} (k neighbours besides each DoE point itself)")
    if not needs and len(doe) < min_rows:
        needs.append(f"at least {min_rows} are needed")
    if needs:
        raise InputError(
            f"{where} has {len(doe)} data rows, too few: {'; '.join(needs)}. "
            "Add DoE runs, or lower cv.folds / gate.k in the config"
        )
    spread = doe[list(columns.inputs)].std(ddof=1)
    constant = [name for name in columns.inputs if not spread[name] > 0]
    if constant:
        values = ", ".join(f"{name!r} (every row is {doe[name].iloc[0]:g})" for name in constant)
        one = len(constant) == 1
        raise InputError(
            f"{where}: input column{'' if one else 's'} {values} {'is' if one else 'are'} constant "
            f"over the DoE (standard deviation 0), so {'it' if one else 'they'} cannot be standardized; "
            f"drop {'it' if one else 'them'} from columns.inputs, or use a DoE that varies "
            f"{'it' if one else 'them'}"
        )
    return _numeric_extras(doe, [*columns.inputs, columns.target], fmt)


def load_production(path, columns: Columns, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    production = load_table(path, "production", [*columns.inputs, columns.target], fmt, _config_keys(columns, "target"))
    return _numeric_extras(production, [*columns.inputs, columns.target], fmt)


def load_matched(path, columns: Columns, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    numeric = [*columns.inputs, columns.matched_simulated, columns.matched_measured]
    matched = load_table(path, "matched", numeric, fmt, _config_keys(columns, "matched_simulated", "matched_measured"))
    return _numeric_extras(matched, numeric, fmt)


# why a table asked about must hold a column, in words for a user of the stored models (who has no config)
MODEL_INPUT = "that the models take as an input"


def require_inputs(frame: pd.DataFrame, inputs, where: str) -> None:
    """Stop when a table asked about lacks one of the models' inputs; name near misses."""
    require_columns(frame, list(inputs), where, MODEL_INPUT)


def load_whatif(path, inputs, fmt: CsvFormat = CsvFormat()) -> pd.DataFrame:
    """Settings to ask the frozen models about: the configured inputs, any other columns kept."""
    inputs = list(inputs)
    whatif = load_table(path, "what-if", inputs, fmt, MODEL_INPUT)
    return _numeric_extras(whatif, inputs, fmt)


def load_row(path, row: int, inputs, fmt: CsvFormat = CsvFormat()) -> dict[str, float]:
    """Row ``row`` (from 1) of a table of the user's own: its inputs, checked in that row only (a blank or a
    text cell elsewhere in the file is not the question's)."""
    frame = read_csv(path, "base", fmt)
    where = f"base file {str(path)!r}"
    require_columns(frame, list(inputs), where, MODEL_INPUT, fmt)
    if not 1 <= row <= len(frame):
        raise InputError(f"{where}: no row {row}; it has {len(frame)} data row(s)")
    asked = frame.iloc[[row - 1]]
    return {name: float(numeric_column(asked, name, where, fmt).iloc[0]) for name in inputs}


def range_report(reference: pd.DataFrame, frame: pd.DataFrame, inputs) -> pd.DataFrame:
    """Per input: the reference (DoE) range, the frame's range, how far the frame lies outside, and
    ``scale``, the ratio of the frame's typical magnitude to the DoE's (about 1000 for mm logged as µm)."""
    rows = []
    for name in inputs:
        low, high = float(reference[name].min()), float(reference[name].max())
        values = frame[name].to_numpy(float)
        span = high - low
        below = max(0.0, low - float(values.min()))
        above = max(0.0, float(values.max()) - high)
        outside = float(np.mean((values < low) | (values > high)))
        typical = float(np.median(np.abs(reference[name].to_numpy(float))))
        rows.append(
            {
                "column": name,
                "doe_min": low,
                "doe_max": high,
                "min": float(values.min()),
                "max": float(values.max()),
                "share_outside": outside,
                "beyond_range_in_spans": max(below, above) / span if span > 0 else math.inf,
                "scale": float(np.median(np.abs(values))) / typical if typical > 0 else math.nan,
            }
        )
    return pd.DataFrame(rows)


def _unit_hint(scale: float) -> str:
    """' — about 1000 times the DoE values: a unit mix-up …?' when the magnitudes differ by more than 5x."""
    if not (np.isfinite(scale) and scale > 0) or 0.2 <= scale <= 5:
        return ""
    factor = scale if scale > 1 else 1 / scale
    exponent = round(math.log10(factor))
    shown = str(10**exponent) if abs(math.log10(factor) - exponent) < 0.1 else f"{factor:.3g}"
    times = f"about {shown} times the DoE values" if scale > 1 else f"about 1/{shown} of the DoE values"
    return f" — {times}: a unit mix-up (mm vs µm or m, kN vs N, MPa vs Pa, °C vs K)?"


def describe_out_of_range(report: pd.DataFrame, limit: float = 0.0) -> str:
    """One line per input that lies outside the DoE range by more than ``limit`` DoE spans."""
    lines = []
    for row in report.itertuples():
        if row.beyond_range_in_spans > limit:
            scale = getattr(row, "scale", math.nan)
            lines.append(
                f"  {row.column}: data {row.min:.4g}..{row.max:.4g}, "
                f"DoE {row.doe_min:.4g}..{row.doe_max:.4g}, {row.share_outside:.0%} of rows outside, "
                f"up to {row.beyond_range_in_spans:.2f} DoE spans beyond{_unit_hint(scale)}"
            )
    return "\n".join(lines)


ROLES = ("doe", "production", "matched")


def load_datasets(config: dict, roles=ROLES) -> dict[str, pd.DataFrame]:
    """Read and check the configured files of ``roles``; warn on usable oddities.

    ``config`` is checked against the schema (:func:`hybridtwin.config.check`): here only what needs the data.

    Each file is checked with what it needs besides itself: production against the DoE's ranges,
    matched cases against the production log (a matched case must not be a training part). A file named in
    ``config["checked_copies"]`` (role -> path of its checked copy, as the workflow writes it) is not checked
    again where it is only what another file is checked against: its copy's input columns are read.
    """
    columns = Columns.from_config(config["columns"])
    fmt = CsvFormat.from_config(config["csv"])
    paths = config["data"]
    needed = (
        set(roles) | ({"doe"} if "production" in roles else set()) | ({"production"} if "matched" in roles else set())
    )
    frames = {}
    if "doe" in needed:
        frames["doe"] = load_doe(paths["doe"], columns, fmt, folds=config["cv"]["folds"], k=config["gate"]["k"])
    copies = config.get("checked_copies", {})
    if "production" in needed and "production" not in roles and "production" in copies:
        frames["production"] = read_checked(copies["production"], columns.inputs)
    elif "production" in needed:
        frames["production"] = load_production(paths["production"], columns, fmt)
    if "matched" in needed:
        frames["matched"] = load_matched(paths["matched"], columns, fmt)
        warn_matched_in_production(frames["matched"], frames["production"], columns.inputs, config["data"])
    if "production" in roles:
        far = describe_out_of_range(range_report(frames["doe"], frames["production"], columns.inputs), limit=0.5)
        if far:
            warn(
                f"production file {str(paths['production'])!r}: columns lie far outside the DoE ranges "
                f"(more than half a DoE span):\n{far}"
            )
    return {role: frames[role] for role in roles}


def check_support(
    production_in: np.ndarray, doe: pd.DataFrame, production: pd.DataFrame, inputs, paths: dict, threshold: float
) -> None:
    """Stop when no production row is in support."""
    production_in = np.asarray(production_in, bool)
    if not production_in.any():
        report = describe_out_of_range(range_report(doe, production, inputs))
        raise InputError(
            f"production file {str(paths['production'])!r}: no row lies inside the DoE support "
            f"(kNN distance threshold {threshold:.3g} in DoE-standardized units), so no residual can be learned."
            + (
                f" Columns outside the DoE ranges:\n{report}"
                if report
                else " Every column is inside the DoE ranges, but the combinations are far from every DoE point."
            )
            + "\nCheck the units and the column mapping (columns.inputs), or enrich the DoE towards the "
            "production window."
        )


def warn_matched_outside(matched_in: np.ndarray, paths: dict) -> None:
    """Matched cases outside the support are usable, but the gated hybrid reverts to the surrogate there."""
    matched_in = np.asarray(matched_in, bool)
    if not matched_in.all():
        outside = np.flatnonzero(~matched_in)
        warn(
            f"matched file {str(paths['matched'])!r}: {len(outside)} of {len(matched_in)} matched case(s) lie "
            f"outside the DoE support ({', '.join(_line(int(i)) for i in outside)}); the gated hybrid reverts to "
            "the surrogate there"
        )


def warn_matched_in_production(matched: pd.DataFrame, production: pd.DataFrame, inputs, paths: dict) -> None:
    """Matched cases must stay out of training: warn when one also stands in the production log."""
    inputs = list(inputs)
    # the few production rows that share a matched case's first input, before the merge: on 10 million rows a
    # merge on every row took 15 s
    candidates = production.loc[production[inputs[0]].isin(matched[inputs[0]]), inputs]
    shared = matched[inputs].reset_index().merge(candidates, on=inputs, how="inner")["index"].unique()
    if len(shared):
        rows = ", ".join(_line(int(i)) for i in sorted(shared))
        warn(
            f"matched file {paths['matched']!r}: {len(shared)} matched case(s) ({rows}) also stand in the production "
            f"file {paths['production']!r} with the same inputs; the residual model trains on those production rows, "
            "so the matched check is not external for them: remove them from the production file"
        )
