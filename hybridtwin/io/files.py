"""Atomic, deterministic writing of tables, JSON and figures.

Every file is written to a temporary name beside its target and renamed into
place, so a killed run never leaves a half-written output that a later run
would take as done.
"""

from __future__ import annotations

import json
import os
import re
import socket
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

FLOAT_FORMAT = "%.8g"
LINES_PER_WRITE = 100_000  # quoted tables: lines joined in Python a batch at a time, not a whole log at once
# rows of a long log read, parsed, checked, predicted or written at a time (a dozen float columns: 100 MB): every
# step that goes through a log of millions of parts in pieces takes them this long
ROWS_AT_ONCE = 1_000_000
# of a piece written as CSV, rows whose text is held at once (a million rows' text of 19 columns: 1 GB)
ROWS_PER_TEXT = 250_000


def row_slices(rows: int, at_least_one: bool = False, size: int | None = None) -> list[slice]:
    """The pieces of ``size`` (default :data:`ROWS_AT_ONCE`) rows of a table of ``rows`` rows, in order (one empty
    piece for an empty table if ``at_least_one``)."""
    size = ROWS_AT_ONCE if size is None else size
    return [slice(start, start + size) for start in range(0, max(rows, int(at_least_one)), size)]


# the process of the workflow run that started this job (set by the Snakefile for its jobs): a job whose
# workflow is gone (killed) must not rename its outputs over those of a later run
OWNER_ENVIRONMENT = "HYBRIDTWIN_WORKFLOW_PID"


class OrphanedJob(RuntimeError):
    """The workflow run that started this job is gone; its outputs are not written."""


def process_alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, killed but not yet reaped, does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return True  # no /proc (macOS): the signal check is all there is


def check_owner() -> None:
    owner = os.environ.get(OWNER_ENVIRONMENT)
    host = os.environ.get(OWNER_ENVIRONMENT + "_HOST")
    if host and host != socket.gethostname():
        return  # a cluster job on another machine: the run's process id means nothing here
    if owner and not process_alive(int(owner)):
        raise OrphanedJob(
            f"the workflow run (process {owner}) that started this job is gone: its outputs are "
            "not written, so they cannot overwrite those of a later run"
        )


@contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path in the target's folder; rename it to ``path`` on success (and only while the
    workflow run that started the job still runs)."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=target.parent)
    os.close(handle)
    try:
        yield Path(temporary)
        check_owner()
        os.chmod(temporary, 0o666 & ~_UMASK)  # mkstemp's file is private; an output is as any new file
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _read_umask()  # once, at import: setting it again later would race with threads creating files


def write_csv(
    frame: pd.DataFrame, path, float_format: str | None = FLOAT_FORMAT, sep: str = ",", decimal: str = "."
) -> None:
    """``float_format=None`` writes each float with the digits that read back to the same value.

    A table of numbers, booleans and text is turned into text column by column with Arrow: the same text
    pandas writes (floats with the fewest digits that read back to them, after rounding to ``float_format``'s
    significant digits; text holding the separator, a quote or a line break quoted), ten times faster, which
    a 10-million-row production log needs. Any other table (a lone carriage return in a text, dates,
    categories...), and a decimal comma, take pandas' writer with ``float_format`` as given.
    """
    digits = _significant_digits(float_format)
    with atomic_path(path) as temporary:
        chunks = (frame.iloc[rows] for rows in row_slices(len(frame), at_least_one=True))
        if decimal == "." and _written_by_arrow(chunks, digits, sep, temporary):
            return
        if float_format is not None:
            frame = _floats_as_text(frame, float_format, decimal)
        frame.to_csv(temporary, index=False, lineterminator="\n", sep=sep, decimal=decimal)


def _significant_digits(float_format: str | None) -> int | None:
    if float_format is None:
        return None
    match = re.fullmatch(r"%\.(\d+)g", float_format)
    if match is None:
        raise ValueError(f"float_format {float_format!r}: only '%.<digits>g' is supported")
    digits = int(match.group(1))
    if not 1 <= digits <= 10:
        raise ValueError(f"float_format {float_format!r}: 1 to 10 significant digits are supported")
    return digits


def rounded_to_significant(values: np.ndarray, digits: int) -> np.ndarray:
    """Each value as ``'%.<digits>g'`` shows it, read back: vectorized where a power of ten is exact.

    Up to ten digits it agreed with ``'%g'`` on every one of a million random values of every magnitude;
    a product that rounds onto an exact tie could still take the other neighbour.
    """
    values = np.asarray(values, float)
    out = values.copy()
    finite = np.flatnonzero(np.isfinite(values) & (values != 0))
    places = digits - 1 - np.floor(np.log10(np.abs(values[finite])))
    exact = np.abs(places) <= 22  # 10**22 is the largest power of ten a double holds exactly
    # multiplying by an exact power of ten, or dividing by one, and rounding the whole number gives the digits
    scale = 10.0 ** np.abs(places[exact])
    value = values[finite[exact]]
    out[finite[exact]] = np.where(places[exact] >= 0, np.round(value * scale) / scale, np.round(value / scale) * scale)
    out[finite[~exact]] = [float(f"%.{digits}g" % value) for value in values[finite[~exact]].tolist()]
    return out


def _as_arrow_text(frame: pd.DataFrame, digits: int | None, sep: str):
    """Each column as Arrow text, as pandas writes it, and whether any text was quoted; None for a table only
    pandas' writer writes right."""
    import pyarrow as pa
    import pyarrow.compute as pc

    names = list(frame.columns)
    # one column: pandas writes a missing value as "" (a blank line would be skipped on reading)
    if len(names) < 2 or len(set(names)) < len(names) or not all(isinstance(name, str) for name in names):
        return None
    if any(_needs_quotes(name, sep) for name in names):
        return None
    columns, quoted = {}, False
    for name in names:
        column = frame[name]
        kind = column.dtype
        if pd.api.types.is_bool_dtype(kind) and not isinstance(kind, pd.CategoricalDtype):
            values = column.to_numpy(bool, na_value=False)
            if column.isna().any():
                return None
            text = pa.array(np.where(values, "True", "False"))
        elif pd.api.types.is_float_dtype(kind):
            values = column.to_numpy(float, na_value=np.nan)
            if digits is not None:
                values = rounded_to_significant(values, digits)
            text = pc.cast(pa.array(values, from_pandas=True), pa.string())
            # a whole number keeps its ".0", as pandas writes it, so that it reads back as a float
            whole = np.isfinite(values) & (values == np.floor(values))
            if whole.any():
                whole = pc.and_(pa.array(whole), pc.invert(pc.match_substring(text, "e")))
                text = pc.if_else(whole, pc.binary_join_element_wise(text, ".0", ""), text)
        elif pd.api.types.is_integer_dtype(kind) and not column.isna().any():
            text = pc.cast(pa.array(column.to_numpy()), pa.string())
        elif pd.api.types.is_string_dtype(kind) and not isinstance(kind, pd.CategoricalDtype):
            if isinstance(kind, pd.StringDtype):
                text = pa.array(column, type=pa.string(), from_pandas=True)  # text or missing by its dtype
            else:
                values = column.to_numpy(object, na_value=None)
                if not all(isinstance(value, str) or value is None for value in values.tolist()):
                    return None
                text = pa.array(values, type=pa.string())
            if pc.any(pc.match_substring(text, "\r")).as_py():
                return None  # whether a lone carriage return is quoted depends on the Python version
            text, needed = _quoted_where_needed(text, sep)
            quoted |= needed
        else:
            return None  # dates, categories, mixed objects...: pandas knows how it writes them
        columns[name] = text
    return columns, quoted


def _quoted_where_needed(text, sep: str):
    """Text holding the separator, a quote or a line break in quotes, its quotes doubled: as pandas writes it;
    and whether any was."""
    import pyarrow.compute as pc

    needs = pc.match_substring_regex(text, _quoted_pattern(sep))
    if not pc.any(needs).as_py():
        return text, False
    quoted = pc.binary_join_element_wise('"', pc.replace_substring(text, '"', '""'), '"', "")
    return pc.if_else(needs, quoted, text), True


def _quoted_pattern(sep: str) -> str:
    return "[" + re.escape(sep) + '"\\r\\n]'


def _needs_quotes(text: str, sep: str) -> bool:
    return re.search(_quoted_pattern(sep), text) is not None


class _OnlyPandasWritesIt(Exception):
    pass


def write_joined_csv(paths, path, float_format: str | None = FLOAT_FORMAT) -> None:
    """The Parquet tables at ``paths`` (the same rows, in the same row groups) side by side in one CSV file, as
    :func:`write_csv` writes their join, a row group at a time: a table of 10 million parts is never whole in
    memory. Tables laid out otherwise, or that only pandas' writer writes right, are joined whole."""
    import pyarrow.parquet as pq

    sources = [pq.ParquetFile(source) for source in paths]
    layouts = {tuple(source.metadata.row_group(i).num_rows for i in range(source.num_row_groups)) for source in sources}
    layout = layouts.pop()
    if not layouts and sum(layout) > 0:
        chunks = (
            pd.concat([source.read_row_group(i).to_pandas() for source in sources], axis=1) for i in range(len(layout))
        )
        try:
            with atomic_path(path) as temporary:
                if not _written_by_arrow(chunks, _significant_digits(float_format), ",", temporary):
                    raise _OnlyPandasWritesIt  # nothing is left at ``path``
            return
        except _OnlyPandasWritesIt:
            pass
    write_csv(side_by_side([read_checked(source) for source in paths]), path, float_format)


def table_of(columns: dict) -> pd.DataFrame:
    """A table of one row per part from its columns as they are: pandas would stack columns of one type into a
    block, a copy of them all at once (0.8 GB more for the hybrid's table of ten million parts)."""
    return pd.DataFrame(columns, copy=False)


def side_by_side(tables) -> pd.DataFrame:
    """Tables of the same rows, their columns side by side."""
    lengths = {len(table) for table in tables}
    if len(lengths) != 1:
        raise RuntimeError(f"tables of different lengths: {sorted(lengths)}")
    return pd.concat([table.reset_index(drop=True) for table in tables], axis=1)


def _written_by_arrow(chunks, digits: int | None, sep: str, path) -> bool:
    """Write the tables ``chunks`` (the rows of one table, in order, the first for the header) to ``path`` with
    Arrow, a chunk at a time (the text of a whole log at once took gigabytes); False where only pandas' writer
    writes a chunk right (the file then holds nothing usable)."""
    with open(path, "wb") as handle:
        for number, chunk in enumerate(_pieces(chunks)):
            as_text = _as_arrow_text(chunk, digits, sep)
            if as_text is None:
                return False
            if number == 0:
                handle.write((sep.join(as_text[0]) + "\n").encode())  # Arrow would quote the names
            _write_text_rows(*as_text, handle, sep)
    return True


def _pieces(chunks):
    """Each table of ``chunks`` in pieces of at most ROWS_PER_TEXT rows (an empty one as it is)."""
    for chunk in chunks:
        for rows in row_slices(len(chunk), at_least_one=True, size=ROWS_PER_TEXT):
            yield chunk.iloc[rows]


def _write_text_rows(columns: dict, quoted: bool, handle, sep: str) -> None:
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.csv as arrow_csv

    if not quoted:
        options = arrow_csv.WriteOptions(include_header=False, delimiter=sep, quoting_style="none")
        arrow_csv.write_csv(pa.table(columns), handle, options)
        return
    # quoted text, which Arrow's writer refuses unquoted: the lines joined here, a batch at a time
    lines = pc.binary_join_element_wise(*columns.values(), sep, null_handling="replace")
    for start in range(0, len(lines), LINES_PER_WRITE):
        batch = lines.slice(start, LINES_PER_WRITE).to_pylist()
        handle.write(("\n".join(batch) + "\n").encode())


def write_table(frame: pd.DataFrame, path, float_format: str | None = FLOAT_FORMAT) -> None:
    """A table one step writes for the next: Parquet where ``path`` ends in ``.parquet``, CSV otherwise.

    Floats are rounded as :func:`write_csv` rounds them, so a step reads the same values from either format.
    Parquet is for the per-part tables between steps: on a log of 10 million parts a CSV took 20-40 s to
    write and 5-18 s to read, a Parquet file a few seconds, and a step reads only its columns' bytes.
    """
    if Path(path).suffix != ".parquet":
        write_csv(frame, path, float_format)
        return
    digits = _significant_digits(float_format)
    floats = [name for name in frame.columns if pd.api.types.is_float_dtype(frame[name].dtype)]
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.Schema.from_pandas(frame, preserve_index=False)
    with atomic_path(path) as temporary, pq.ParquetWriter(temporary, schema) as writer:
        # ROWS_AT_ONCE rows at a time (a row group each), rounded as they go: Arrow's copy and the rounded values
        # of a chunk, not of the whole table
        for rows in row_slices(len(frame)):
            chunk = frame.iloc[rows]
            if digits is not None:
                rounded = {name: rounded_to_significant(chunk[name].to_numpy(float), digits) for name in floats}
                chunk = chunk.assign(**rounded)
            writer.write_table(pa.Table.from_pandas(chunk, schema=schema, preserve_index=False))


def read_checked(path, columns=None, rows=None) -> pd.DataFrame:
    """Read a table the workflow wrote (a checked copy, say), CSV or Parquet; only ``columns``, in the file's
    order, if given: on a log of millions of parts a rule holds the columns it uses, not every one; only ``rows``
    (row positions, in order), if given, indexed by their positions: a column at a time is read whole."""
    if Path(path).suffix == ".parquet":
        return _read_parquet(path, columns, rows)
    table = pd.read_csv(path, keep_default_na=False, na_values=[""], usecols=None if columns is None else list(columns))
    return table if rows is None else table.iloc[rows]


def read_head(path, rows: int) -> pd.DataFrame:
    """The first ``rows`` rows of a table the workflow wrote (CSV or Parquet): a look at what its columns hold
    before a step reads only those it needs."""
    if Path(path).suffix == ".parquet":
        import pyarrow.parquet as pq

        source = pq.ParquetFile(path)
        first = next(source.iter_batches(batch_size=rows), None)
        return source.schema_arrow.empty_table().to_pandas() if first is None else first.to_pandas()
    return pd.read_csv(path, keep_default_na=False, na_values=[""], nrows=rows)


def read_matrix(path, columns, rows=None) -> np.ndarray:
    """The ``columns`` of a table the workflow wrote, as one float matrix in that order, filled a column at a time
    (only ``rows``, positions, if given): a step that reads only a matrix of the inputs holds it once, not beside a
    table of the same numbers (0.9 GB each on ten million parts)."""
    columns = list(columns)
    if Path(path).suffix != ".parquet":
        return read_checked(path, columns, rows)[columns].to_numpy(float)
    import pyarrow.parquet as pq

    source = pq.ParquetFile(path)
    missing = [name for name in columns if name not in source.schema_arrow.names]
    if missing:
        raise ValueError(f"{str(path)!r} has no column {', '.join(map(repr, missing))}")
    matrix = np.empty((source.metadata.num_rows if rows is None else len(rows), len(columns)))
    for j, name in enumerate(columns):
        values = source.read(columns=[name]).column(0).to_numpy()
        matrix[:, j] = values if rows is None else values[rows]
    return matrix


def column_names(path) -> list[str]:
    """The columns of a table the workflow wrote (CSV or Parquet), read from its header or schema alone."""
    if Path(path).suffix == ".parquet":
        import pyarrow.parquet as pq

        return list(pq.read_schema(path).names)
    return list(pd.read_csv(path, nrows=0).columns)


def _read_parquet(path, columns=None, rows=None) -> pd.DataFrame:
    import pyarrow.parquet as pq

    source = pq.ParquetFile(path)
    names = source.schema_arrow.names
    if columns is not None:
        missing = [name for name in columns if name not in names]
        if missing:
            raise ValueError(f"{str(path)!r} has no column {', '.join(map(repr, missing))}")
        wanted = set(columns)
        names = [name for name in names if name in wanted]
    index = pd.RangeIndex(source.metadata.num_rows)
    if rows is not None:
        index = index[rows]
    if not names:
        return pd.DataFrame(index=index)

    def column(name):
        values = source.read(columns=[name]).to_pandas(self_destruct=True)[name]
        return values if rows is None else values.iloc[rows]

    # a column at a time, each handed over to pandas as it is read: the 10-million-part checked copy (1.6 GB in
    # pandas) read with a peak of 1.9 GB, against 3.7 GB with pandas.read_parquet and 3.0 GB converted whole
    return pd.concat([column(name) for name in names], axis=1)


def in_support(table: pd.DataFrame) -> np.ndarray:
    """A workflow table's ``in_support`` column as booleans."""
    return table["in_support"].astype(bool).to_numpy()


def _floats_as_text(frame: pd.DataFrame, float_format: str, decimal: str) -> pd.DataFrame:
    """Float columns formatted up front: the same text as to_csv's float_format, in half the time."""
    out = frame.copy(deep=False)
    for column in frame.columns:
        if pd.api.types.is_float_dtype(frame[column].dtype):
            values = frame[column].to_numpy(float, na_value=np.nan)
            texts = np.array([float_format % value for value in values.tolist()], dtype=object)
            if decimal != ".":
                texts = np.array([text.replace(".", decimal) for text in texts], dtype=object)
            texts[np.isnan(values)] = ""
            out[column] = texts
    return out


def json_safe(value):
    """Numpy arrays and scalars, tuples and dict keys as plain JSON values."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_json(data, path) -> None:
    with atomic_path(path) as temporary:
        temporary.write_text(json.dumps(json_safe(data), indent=1, sort_keys=True) + "\n")


def read_json(path):
    return json.loads(Path(path).read_text())


def save_figure(figure, path) -> None:
    """PNG without a timestamp in its metadata, so reruns give the same bytes."""
    import matplotlib.pyplot as plt

    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120, bbox_inches="tight", metadata={"Software": None}, format="png")
    plt.close(figure)
