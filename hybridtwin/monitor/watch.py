"""Check a batch of new production against the frozen models: read it, predict it, chart it, say what changed.

    from hybridtwin.answers.predictor import Predictor
    from hybridtwin.monitor import watch
    predictor = Predictor.load(models_folder)
    result = watch.watch(predictor, watch.load_batch(path, predictor))

A batch is new production in the production log's format, in time order: the models' inputs, the measured target
and the log's other columns (those the extension's causes need among them). Bad input stops with one line
naming the file, the column and the row.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.answers import intervals
from hybridtwin.answers.trust import EXTRAPOLATION, trust_levels
from hybridtwin.io.data import MODEL_INPUT
from hybridtwin.io.errors import InputError
from hybridtwin.io.reading import CsvFormat, _numeric_extras, load_table, numeric_column, require_columns
from hybridtwin.models.batches import available_cores
from hybridtwin.models.registry import RECOMMENDED_COLUMN
from hybridtwin.monitor import chart
from hybridtwin.monitor.changes import Change, what_changed
from hybridtwin.monitor.departure import Departure, departure
from hybridtwin.monitor.regimes import Regimes, labels

# the columns the monitor adds to the batch's own (a contract: docs/monitor.md)
COLUMNS = (
    "part",
    RECOMMENDED_COLUMN,
    "residual",
    "expected_error",
    "trust",
    "interval_region",
    "statistic",
    "limit",
    "alarm",
    "change_start",
)


def _header(path, fmt: CsvFormat) -> list[str]:
    try:
        with open(path, encoding=fmt.codec, newline="") as handle:
            first = handle.readline()
    except (OSError, UnicodeDecodeError):
        return []  # the careful reader says what is wrong with the file
    return [name.strip().strip('"') for name in first.rstrip("\r\n").split(fmt.sep)]


def no_target(where: str, target: str, present: list[str]) -> InputError:
    close = difflib.get_close_matches(target, present, n=1, cutoff=0.6)
    near = f" (did you mean {close[0]!r}?)" if close else ""
    return InputError(
        f"{where} has no column {target!r}{near}, the measured target the models were built for: a batch "
        "without measured parts cannot be monitored (the monitor compares each measured part with its "
        "prediction); to predict settings without measurements use 'hybridtwin predict'"
    )


def load_batch(path, predictor, fmt: CsvFormat | None = None) -> pd.DataFrame:
    """The batch as the workflow reads a production log: inputs and target as numbers, other number columns as
    numbers, text kept; checked for the target, the extension's cause columns and time order."""
    fmt = fmt or predictor.csv
    where = f"batch file {str(path)!r}"
    target, inputs = predictor.spec["target"], predictor.inputs
    header = _header(path, fmt)
    if header and set(inputs) <= set(header) and target not in header:
        raise no_target(where, target, header)
    batch = load_table(path, "batch", inputs, fmt, MODEL_INPUT)
    if target not in batch.columns:
        raise no_target(where, target, [str(name) for name in batch.columns])
    batch[target] = numeric_column(batch, target, where, fmt)
    check_columns(batch, predictor, where)
    check_time_order(batch, where)
    batch = _numeric_extras(batch, [*inputs, target], fmt).reset_index(drop=True)
    check_counters(batch, predictor.spec.get("monitor", {}).get("counters", []), where)
    return batch


def check_columns(batch: pd.DataFrame, predictor, where: str) -> None:
    """The columns the extension's causes need (log columns such as a stroke counter) must be there too."""
    needed = sorted(predictor.extension.extension.columns - set(predictor.inputs))
    require_columns(batch, needed, where, "that the models' extension uses as a cause (a production log column)")


def check_time_order(batch: pd.DataFrame, where: str) -> None:
    """Every timestamp column must never go back: the statistic runs part after part."""
    from hybridtwin.diagnosis.causes import looks_like_timestamps, parse_timestamps

    for column in batch.columns:
        values = batch[column]
        if not looks_like_timestamps(values):
            continue
        stamps = parse_timestamps(values)
        if stamps is not None:
            _in_order(stamps.to_numpy("datetime64[ns]").astype("int64"), values, column, where, "earlier than")


def check_counters(batch: pd.DataFrame, counters, where: str) -> None:
    """The columns that never went down over the production log (a stroke counter) must not go down over the
    batch: without a timestamp, they are what says the batch runs in time order."""
    for column in counters:
        if column in batch and pd.api.types.is_numeric_dtype(batch[column]):
            values = batch[column]
            _in_order(
                values.to_numpy(float),
                values,
                column,
                where,
                "below",
                " (if the counter was reset, start a new batch there)",
            )


def _cell(value) -> str:
    return repr(value) if isinstance(value, str) else f"{value:g}"


def _in_order(keys: np.ndarray, values: pd.Series, column: str, where: str, going_back: str, hint: str = "") -> None:
    """Stop at the first row whose ``keys`` go back, with the file, column, row and both cells."""
    back = np.flatnonzero(np.diff(keys) < 0)
    if len(back):
        row = int(back[0]) + 1
        cell, previous = _cell(values.iloc[row]), _cell(values.iloc[row - 1])
        raise InputError(
            f"{where}, column {column!r}, row {row + 1} (line {row + 2}): {cell} is {going_back} the row before "
            f"({previous}); a batch must be in time order: sort it by {column!r}{hint}"
        )


@dataclass
class Watched:
    """A batch checked: its table with the monitor's columns, the chart, and what changed (after an alarm)."""

    table: pd.DataFrame
    chart: chart.Chart
    change: Change | None
    target: str
    unit: str
    log_rows: int | None = None  # the production log's parts the charts' limits were set on (None: not stored)
    departure: Departure | None = None  # where the batch left what the models can judge (None: it did not)

    @property
    def judged(self) -> np.ndarray:
        return ~np.isnan(self.chart.z)


def charted(stored: dict, batch: pd.DataFrame, residual, z, region, models) -> chart.Chart:
    """The chart over the batch: the regime charts with the constants the log set (predictor.json, key
    ``monitor``); models written before them, the plain CUSUM of z with their allowance (or the floor)."""
    if "regimes" in stored:
        group = labels(Regimes.from_dict(stored["regimes"]).starts(batch), models)
        return chart.regime_chart(residual, z, region, group, chart.Constants.from_dict(stored))
    return chart.cusum(z, stored.get("allowance", chart.REFERENCE), stored.get("limit", chart.LIMIT))


def watch(predictor, batch: pd.DataFrame, seed: int = 0, explain: bool = True) -> Watched:
    """Chart ``batch`` against the models; after an alarm (``explain``), say what changed."""
    target = predictor.spec["target"]
    X = predictor.checked(batch, "the batch")
    where = predictor.where(X)
    # the residual's chart reads the recommended prediction alone, not its interval
    values = predictor.values(batch, X, where, False, available_cores(), bounds=False)
    answers = intervals.recommended_prediction(predictor.intervals, values, where.region, predictor.level, bounds=False)
    measured = batch[target].to_numpy(float)
    residual = measured - answers[RECOMMENDED_COLUMN].to_numpy(float)
    expected = chart.expected_error(predictor.intervals, answers["recommended_model"], where.region.interval)
    # judged only as far as the calibration parts lie: the expected error was calibrated there
    within = trust_levels(where.inside, where.beyond, where.distance, predictor.judging_reach) != EXTRAPOLATION
    judged = (np.asarray(where.trust) != EXTRAPOLATION) & within & np.isfinite(expected) & (expected > 0)
    z = np.where(judged, residual / np.where(judged, expected, 1.0), np.nan)
    models = answers["recommended_model"].to_numpy(object)
    result = charted(predictor.spec.get("monitor", {}), batch, residual, z, where.region.interval, models)
    table = batch.reset_index(drop=True).copy()
    added = {
        "part": np.arange(1, len(batch) + 1),
        RECOMMENDED_COLUMN: answers[RECOMMENDED_COLUMN].to_numpy(float),
        "residual": residual,
        "expected_error": np.where(judged, expected, np.nan),
        "trust": where.trust,
        "interval_region": where.region.interval,
        "statistic": result.statistic,
        "limit": np.full(len(batch), result.limit),
        "alarm": result.alarm,
        "change_start": np.where(result.alarm, (result.start_at or 0) + 1, np.nan),
    }
    for column in COLUMNS:
        table[column] = added[column]
    change = None
    if explain and result.alarm_at is not None:
        change = what_changed(table, residual, result, predictor, seed, COLUMNS)
    log_rows = predictor.spec.get("monitor", {}).get("log_rows")
    left = departure(table, ~np.isnan(result.z), residual, predictor)
    return Watched(table, result, change, target, predictor.spec["unit"], log_rows, left)
