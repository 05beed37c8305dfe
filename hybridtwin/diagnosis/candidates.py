"""The candidate causes of a residual: every usable production column, and products of two inputs."""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.diagnosis import forms
from hybridtwin.diagnosis.causes import Cause, parse_timestamps, time_origin
from hybridtwin.diagnosis.settings import Settings

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Candidate:
    """A cause under test, with its values on the diagnosed rows."""

    cause: Cause
    values: np.ndarray

    @classmethod
    def new(cls, name: str, kind: str, values, columns: tuple[str, ...], origin: str | None = None) -> "Candidate":
        return cls(Cause(name, kind, tuple(columns), origin), values)

    @property
    def name(self) -> str:
        return self.cause.name

    @property
    def kind(self) -> str:
        return self.cause.kind

    @property
    def columns(self) -> tuple[str, ...]:
        return self.cause.columns

    @property
    def origin(self) -> str | None:
        return self.cause.origin

    @property
    def form_names(self) -> tuple[str, ...]:
        if self.kind == "group":
            return ("group",)
        if self.kind == "interaction":
            return ("product", "additive")
        if len(np.unique(self.values)) <= 2:
            return ("step",)
        return tuple(cls.name for cls in forms.NUMERIC_FORMS)


def build_candidates(
    frame: pd.DataFrame, inputs, exclude, settings: Settings
) -> tuple[list[Candidate], dict[str, str]]:
    """Candidate causes from every usable column, and the reasons others were skipped."""
    causes, skipped = [], {}
    for column in frame.columns:
        if column in exclude or column in settings.exclude:
            continue
        values = frame[column]
        if values.nunique(dropna=False) < 2:
            skipped[column] = "constant"
            continue
        if pd.api.types.is_numeric_dtype(values):
            if values.isna().any() or not np.isfinite(values.to_numpy(float)).all():
                skipped[column] = "missing or infinite values"
                continue
            causes.append(Cause(column, "input" if column in inputs else "log", (column,)))
        elif parse_timestamps(values) is not None:
            causes.append(Cause(column, "time", (column,), time_origin(values)))
        elif values.nunique() <= settings.max_levels:
            causes.append(Cause(column, "group", (column,)))
        else:
            skipped[column] = f"text with {values.nunique()} distinct values (more than {settings.max_levels})"
    if settings.interactions:
        numeric_inputs = [c for c in causes if c.kind == "input"]
        causes += [
            Cause(f"{a.name}*{b.name}", "interaction", (a.name, b.name))
            for a, b in itertools.combinations(numeric_inputs, 2)
        ]
    # read as the extension and the predictor read them (Cause.values)
    candidates = [Candidate(cause, cause.values(frame)) for cause in causes]
    return candidates, skipped
