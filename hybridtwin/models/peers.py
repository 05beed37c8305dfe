"""The established alternatives to the paper's hybrid, fitted on the same information (DoE + in-support parts).

Which peers there are, their classes and settings come from :mod:`hybridtwin.models.registry`. Each peer's
class fits (``fit(X, y, X_low=, y_low=)``), predicts parts out of period (``out_of_period``: refitted without
each period's training parts, the hyperparameters held, as the XGBoost residual model keeps its tuned
hyperparameters in its CV folds), predicts, and stores itself as JSON (``to_dict``/``from_dict``, no pickle).
"""

from __future__ import annotations

import importlib
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.crossval import in_support_out_of_period, training_subset
from hybridtwin.io.files import in_support, table_of
from hybridtwin.models import registry
from hybridtwin.models.batches import chunks


def peer_entry(name: str) -> registry.Model:
    if name not in registry.PEER_NAMES:
        raise ValueError(f"unknown peer {name!r}; one of {', '.join(registry.PEER_NAMES)}")
    return registry.model(name)


def estimator_class(name: str):
    """The class a peer's registry entry names (``module:Class``), imported on first use."""
    module, _, attribute = peer_entry(name).estimator.partition(":")
    return getattr(importlib.import_module(module), attribute)


def new_peer(name: str, settings: dict, seed: int):
    """A peer's estimator with its settings from the config's ``peers`` section (a setting not given: the class's
    own default)."""
    arguments = {argument: settings[key] for key, argument in peer_entry(name).settings if key in settings}
    return estimator_class(name)(**arguments, random_state=seed)


def as_target(name: str, value: np.ndarray, surrogate: np.ndarray) -> np.ndarray:
    """A peer that predicts the residual (the surrogate's correction) gives the target with the surrogate added."""
    return surrogate + value if registry.model(name).predicts == "residual" else value


@dataclass
class PeerFit:
    model: object
    # pred_<peer>: the final model; pred_<peer>_oof: the same, but out of period on the in-support parts
    production: pd.DataFrame
    fit_seconds: float
    n_train: int


def fit_peer(
    name: str,
    doe: pd.DataFrame,
    production: pd.DataFrame,
    residuals: pd.DataFrame,
    inputs,
    target: str,
    settings: dict,
    seed: int,
    n_folds: int,
) -> PeerFit:
    """Fit one peer on the DoE and the in-support parts; predict every production row (a seeded sample of
    ``settings["max_predicted"]`` rows on a larger log, NaN elsewhere) and, on those rows in support and the parts
    it trained on, out of period: ``n_folds`` periods of consecutive in-support parts, each predicted by the peer
    refitted without its period's training parts (its hyperparameters held), as the hybrid is scored.

    ``residuals``: measured, pred_surrogate, residual_approx, in_support per production row (the
    residuals rule's table).
    """
    inputs = list(inputs)
    spec = peer_entry(name)
    inside = np.flatnonzero(in_support(residuals))
    surrogate = residuals[registry.SURROGATE.column].to_numpy(float)
    learnt = residuals["residual_approx" if spec.predicts == "residual" else "measured"].to_numpy(float)
    start = time.perf_counter()
    model = new_peer(name, settings, seed)
    # rows by label: ``production`` may hold only the rows a peer reads (:func:`rows_read`), indexed by their rows
    model.fit(production.loc[inside, inputs], learnt[inside], X_low=doe[inputs], y_low=doe[target])
    seconds = time.perf_counter() - start
    predicted = predicted_rows(len(residuals), settings, seed)
    final = np.full(len(residuals), np.nan)
    final[predicted] = as_target(name, model.predict(production.loc[predicted, inputs]), surrogate[predicted])
    # in support, out of period as the hybrid is scored: each part from the peer refitted without its period's
    # training parts (the final model has seen its neighbours in time: its campaign, its coil)
    scored = np.union1d(np.flatnonzero(np.isfinite(final[inside])), model.training_rows_)
    honest = final.copy()
    values = in_support_out_of_period(model, production.loc[inside, inputs], model.training_rows_, n_folds, scored)
    honest[inside[scored]] = as_target(name, values, surrogate[inside[scored]])
    return PeerFit(model, table_of({spec.column: final, spec.oof_column: honest}), seconds, len(model.training_rows_))


def predicted_rows(n_rows: int, settings: dict, seed: int) -> np.ndarray:
    """The log's rows a peer predicts: every one, or on a larger log a seeded sample of ``max_predicted`` (a peer
    predicts row by row against all its training points)."""
    return training_subset(n_rows, settings.get("max_predicted", n_rows), seed + 2)


def rows_read(residuals: pd.DataFrame, settings: dict, seed: int) -> np.ndarray:
    """The log's rows a peer reads: those it learns from (in support) and those it predicts (on a long log, a
    fraction of it: the step reads only these)."""
    return np.union1d(np.flatnonzero(in_support(residuals)), predicted_rows(len(residuals), settings, seed))


def predictions_at(models: dict, X: pd.DataFrame, surrogate: np.ndarray, n_jobs: int = 1) -> dict[str, np.ndarray]:
    """Every peer's prediction of the target at ``X`` (the matched cases, say), given the surrogate there.

    With ``n_jobs`` > 1 the rows are shared among as many threads (numpy's kernels release the GIL; a peer's
    prediction changes nothing in the model).
    """
    stretches = chunks(len(X), n_jobs)
    if len(stretches) <= 1:
        return {name: as_target(name, model.predict(X), surrogate) for name, model in models.items()}
    tasks = [(name, model, part) for name, model in models.items() for part in stretches]
    with ThreadPoolExecutor(min(n_jobs, len(tasks))) as pool:
        parts = list(pool.map(lambda t: as_target(t[0], t[1].predict(X.iloc[t[2]]), surrogate[t[2]]), tasks))
    return {name: np.concatenate([p for (n, _, _), p in zip(tasks, parts) if n == name]) for name in models}


def load_peer(name: str, data: dict):
    """A stored peer (its JSON) rebuilt by its registry entry's class."""
    return estimator_class(name).from_dict(data)


def shared_rows(valued: dict[str, np.ndarray], inside: np.ndarray, test: np.ndarray) -> dict[str, np.ndarray]:
    """Per model, the test rows it is scored on: in support and out of it, the rows where every model that has a
    value on at least half of that side's test rows has one (each part's noise then weighs on them alike); a
    model with fewer (the stack where a far region had too few parts to blend on) on its own rows among those."""
    rows = {model: np.zeros(len(inside), bool) for model in valued}
    for side in (inside, ~inside):
        side_rows = np.asarray(test, bool) & side
        if not side_rows.any():
            continue
        broad = [m for m, finite in valued.items() if finite[side_rows].mean() >= 0.5]
        common = side_rows & np.all([valued[m] for m in broad], axis=0)  # no broad model: all of an empty list
        for model, finite in valued.items():
            rows[model] |= common & finite
    return rows


def comparison_table(
    measured,
    predictions: dict[str, np.ndarray],
    in_support,
    test: np.ndarray,
    matched_measured,
    matched_predictions: dict[str, np.ndarray],
    fits: dict[str, dict],
    truth=None,
    noise: float | None = None,
) -> pd.DataFrame:
    """peer_comparison.csv: every model on the same held-out production rows, in and out of the support.

    ``predictions`` are honest (out-of-fold on a model's training parts, a peer's included, or from models never
    trained on the row); the rows scored are the test blocks' rows every model shares (:func:`shared_rows`).
    ``fits``: per peer, its n_train (the in-support parts it trained on).
    """
    from hybridtwin.diagnosis.extension import gain_table

    names = [m for m in registry.COMPARED if m in predictions]
    matched = {m: np.asarray(matched_predictions.get(m, np.full(len(matched_measured), np.nan)), float) for m in names}
    table = gain_table(
        measured,
        {m: np.asarray(predictions[m], float) for m in names},
        in_support,
        matched_measured,
        matched,
        truth,
        noise,
        scored=shared_rows({m: np.isfinite(predictions[m]) for m in names}, np.asarray(in_support, bool), test),
    )
    # (fit times vary from run to run, so they stay out of the table: results/peers/<peer>.json and the benchmarks)
    table["n_train"] = table["model"].map({k: v["n_train"] for k, v in fits.items()})
    table["evaluated_on"] = (
        "production test rows (odd blocks of consecutive rows; the recommended model and the stack's weights were "
        "chosen on the even blocks), the same rows for every model (a model with values on fewer than half of a "
        "side's rows, on its own among them: n_in_support, n_out_of_support): in support out of period for every "
        "model (K periods of consecutive parts, each from a model that never saw its period); out of support from "
        "models never trained there; matched cases never used for fitting (the stack and the recommended model are "
        "not scored on them)" + ("; truth = the demo's noise-free plant" if truth is not None else "")
    )
    return table
