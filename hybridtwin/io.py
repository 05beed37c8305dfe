"""Atomic, deterministic writing of tables, JSON and figures.

Every file is written to a temporary name beside its target and renamed into
place, so a killed run never leaves a half-written output that a later run
would take as done.
"""
from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

FLOAT_FORMAT = "%.8g"


@contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path in the target's folder; rename it to ``path`` on success."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=target.parent)
    os.close(handle)
    try:
        yield Path(temporary)
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_csv(frame: pd.DataFrame, path, float_format: str | None = FLOAT_FORMAT, sep: str = ",",
              decimal: str = ".") -> None:
    """``float_format=None`` writes each float with the digits that read back to the same value."""
    if float_format is not None:
        frame = _floats_as_text(frame, float_format, decimal)
    with atomic_path(path) as temporary:
        frame.to_csv(temporary, index=False, lineterminator="\n", sep=sep, decimal=decimal)


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


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_json(data, path) -> None:
    with atomic_path(path) as temporary:
        temporary.write_text(json.dumps(_plain(data), indent=1, sort_keys=True) + "\n")


def read_json(path):
    return json.loads(Path(path).read_text())


def save_figure(figure, path) -> None:
    """PNG without a timestamp in its metadata, so reruns give the same bytes."""
    import matplotlib.pyplot as plt

    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120, bbox_inches="tight", metadata={"Software": None}, format="png")
    plt.close(figure)
