"""The data behind a cause's figure: its partial residual, binned, with the fitted form and a bootstrap band.

Kept apart from :mod:`hybridtwin.diagnosis`, which chooses the causes; this module only shows them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hybridtwin.diagnosis import forms
from hybridtwin.diagnosis.forms import fit_form
from hybridtwin.diagnosis.selection import Diagnosis


def partial_residual(result: Diagnosis, y: np.ndarray, index: int) -> np.ndarray:
    """The offset-free residual less every chosen term but the ``index``-th."""
    others = [f for j, f in enumerate(result.selected) if j != index]
    return y - sum((f.form.predict(f.candidate.values) for f in others), np.zeros_like(y))


def cause_profile(
    result: Diagnosis,
    name: str,
    unit: str,
    seed: int = 0,
    n_bins: int = 20,
    n_boot: int = 30,
    input_units: dict | None = None,
) -> dict:
    """Data for a cause's figure: binned residual, the fitted form on a grid and a bootstrap 95% band.

    A chosen cause is shown against its partial residual (the other chosen terms
    removed); any other candidate against the residual left by all chosen terms.
    """
    candidate = result.candidates[name]
    chosen = [f.candidate.name for f in result.selected]
    if name in chosen:
        index = chosen.index(name)
        y, form = partial_residual(result, result.y, index), result.selected[index].form
    else:
        y = partial_residual(result, result.y, -1)
        form_name = str(result.table.set_index("cause").loc[name, "form"])
        form = fit_form(form_name, candidate.values, y)
    profile = {
        "name": name,
        "kind": candidate.kind,
        "form": form.name,
        "description": form.describe(name, unit, candidate.cause.unit(input_units)),
        "selected": name in chosen,
        "unit": unit,
    }
    if candidate.kind == "group":
        return {**profile, **_group_profile(candidate.values, y, form)}
    x = candidate.values if candidate.kind != "interaction" else form.predict(candidate.values)
    if candidate.kind == "interaction":
        form = Identity()
    profile.update(_curve_profile(x, y, form, n_bins, n_boot, seed))
    profile["xlabel"] = (
        _axis(name, candidate.cause.unit(input_units))
        if candidate.kind != "interaction"
        else f"fitted interaction term {name} [{unit}]"
    )
    if candidate.kind == "time":
        profile["xlabel"] = f"{name}: hours since {candidate.origin}"
    return profile


def _group_profile(levels, y, form) -> dict:
    """Each level's mean residual with its standard error, and the fitted offsets."""
    stats_ = pd.DataFrame({"level": levels, "y": y}).groupby("level")["y"].agg(["mean", "count", "std"]).sort_index()
    return {
        "levels": stats_.index.tolist(),
        "mean": stats_["mean"].to_numpy(),
        "se": (stats_["std"].fillna(0) / np.sqrt(stats_["count"])).to_numpy(),
        "fitted": form.predict(np.asarray(stats_.index)),
    }


def _curve_profile(x, y, form, n_bins: int, n_boot: int, seed: int) -> dict:
    """The residual binned by quantiles of ``x``, the fitted form on a grid and a bootstrap 95% band."""
    edges = np.unique(np.percentile(x, np.linspace(0, 100, n_bins + 1)))
    which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
    binned = (
        pd.DataFrame({"bin": which, "x": x, "y": y})
        .groupby("bin")
        .agg(center=("x", "mean"), mean=("y", "mean"), std=("y", "std"), count=("y", "size"))
    )
    binned["se"] = binned["std"].fillna(0) / np.sqrt(binned["count"])
    grid = np.linspace(x.min(), x.max(), 200)
    rng = np.random.default_rng(seed)
    curves = []
    for _ in range(n_boot if not isinstance(form, Identity) else 0):
        pick = rng.choice(len(y), min(len(y), 4000), replace=True)
        curves.append(fit_form(form.name, x[pick], y[pick]).predict(grid))
    curve = form.predict(grid)
    low, high = np.percentile(curves, [2.5, 97.5], axis=0) if curves else (curve, curve)
    return {"binned": binned, "grid": grid, "curve": curve, "band_low": low, "band_high": high}


def _axis(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name


class Identity(forms.Form):
    """The fitted term against itself, for plotting interactions."""

    name = "identity"

    def predict(self, x):
        return np.asarray(x, float)
