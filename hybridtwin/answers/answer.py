"""The answer table: the user's columns with the answer columns added, and how a terminal shows it.

By default a row gets :data:`DEFAULT` (a contract read by outside tools): the recommended prediction and its
interval, the trust verdict and its reason, the model it came from, the support's verdict and the distance
to the simulations, the surrogate and the paper's gated hybrid. ``all_models`` adds every model's prediction
and the regions' bookkeeping (:data:`BOOKKEEPING`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.answers import regions
from hybridtwin.models import registry

log = logging.getLogger(__name__)

DEFAULT = (
    registry.RECOMMENDED_COLUMN,
    "pred_lower",
    "pred_upper",
    "trust",
    "trust_reason",
    "recommended_model",
    "interval_level",
    "in_support",
    "knn_distance",
    registry.SURROGATE.column,
    registry.HYBRID_GATED.column,
)
# with all_models, before every model's prediction: beyond_<input> per input after outside_doe_range (how far the
# row lies beyond the DoE's range in the input's unit, 0 inside)
BOOKKEEPING = ("outside_doe_range", "in_domain", "interval_region", "model_region", f"{registry.SURROGATE.column}_std")
# the columns a one-off question adds: which inputs were filled from typical production or a base row
FILLED = "filled_inputs"


@dataclass(frozen=True)
class Where:
    """Each row's place: kNN distance to the DoE, the support's verdict, how far beyond each DoE range
    (signed, per input), its regions, and the trust verdict with its reason."""

    distance: np.ndarray
    inside: np.ndarray
    beyond: pd.DataFrame
    region: regions.Regions
    trust: np.ndarray
    reason: np.ndarray
    doe_range: dict

    def bookkeeping(self, inputs) -> dict[str, np.ndarray]:
        beyond_range = (self.beyond != 0).any(axis=1).to_numpy()
        return {
            "outside_doe_range": np.asarray(regions.describe_outside(self.beyond, self.doe_range), object),
            **{f"beyond_{name}": self.beyond[name].to_numpy() for name in inputs},
            "in_domain": self.inside & ~beyond_range,
            "interval_region": self.region.interval,
            "model_region": self.region.choice,  # 'in_support' for a row in the gate beyond a range
        }


def columns(inputs, all_models: bool) -> list[str]:
    """The answer columns, in order."""
    if not all_models:
        return list(DEFAULT)
    every = [m.column for m in registry.MODELS if m.column not in DEFAULT]
    return [*DEFAULT, BOOKKEEPING[0], *(f"beyond_{name}" for name in inputs), *BOOKKEEPING[1:], *every]


def assemble(frame, where: Where, values: dict, picked: pd.DataFrame, level: float, all_models: bool, inputs):
    """``frame`` (its order and columns kept) with the answer columns."""
    answers = {
        **{f"pred_{model}": value for model, value in values.items()},
        **{column: picked[column].to_numpy() for column in picked},
        "trust": where.trust,
        "trust_reason": where.reason,
        "interval_level": np.full(len(frame), level),
        "in_support": where.inside,
        "knn_distance": where.distance,
    }
    if all_models:
        answers.update(where.bookkeeping(inputs))
    out = frame.reset_index(drop=True).copy()
    for column in columns(inputs, all_models):
        if column in out.columns:
            log.warning("the what-if table's column %r is replaced by the predictor's", column)
        out[column] = answers[column]
    return out


def on_screen(answers: pd.DataFrame, inputs, unit: str, limit: int = 30, varied: tuple[str, ...] = ()) -> str:
    """What a terminal shows: one row as a list, the answer first; several as a short table (with the ``varied``
    inputs' values: a sweep's), then why each row that is not validated is so."""
    if len(answers) == 1:
        return _one(answers.iloc[0], inputs, unit)
    shown = answers.head(limit)
    table = pd.DataFrame(
        {
            "row": np.arange(1, len(shown) + 1),
            **{name: shown[name].map(lambda value: f"{value:g}") for name in varied},
            f"prediction [{unit}]": shown[registry.RECOMMENDED_COLUMN].map(_number),
            "interval": [_interval(row) for _, row in shown.iterrows()],
            "trust": shown["trust"],
            "model": shown["recommended_model"],
        }
    ).to_string(index=False)
    notes = [
        f"row {i + 1}: {reason}"
        for i, (reason, verdict) in enumerate(zip(shown["trust_reason"], shown["trust"]))
        if verdict != "validated" and reason
    ]
    more = f"\n… {len(answers) - limit} more row(s): write them with -o FILE.csv" if len(answers) > limit else ""
    return table + ("\n\n" + "\n".join(notes) if notes else "") + more


def _number(value) -> str:
    return "—" if pd.isna(value) else f"{value:.2f}"


def _interval(row) -> str:
    if pd.isna(row["pred_lower"]):
        return "none"
    return f"{row['pred_lower']:.2f} to {row['pred_upper']:.2f} ({row['interval_level']:.0%})"


def _one(row, inputs, unit: str) -> str:
    lines = [
        f"prediction:  {_number(row[registry.RECOMMENDED_COLUMN])} {unit}  ({row['recommended_model']})",
        f"interval:    {_interval(row)}",
        f"trust:       {row['trust']}: {row['trust_reason']}",
        f"surrogate:   {_number(row[registry.SURROGATE.column])} {unit};  the paper's gated hybrid: "
        f"{_number(row[registry.HYBRID_GATED.column])} {unit}",
        "settings:    " + ", ".join(f"{name}={row[name]:.6g}" for name in inputs),
    ]
    if row.get(FILLED):
        lines.append(f"filled:      {row[FILLED]}")
    return "\n".join(lines)
