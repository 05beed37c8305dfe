"""The workflow's steps, one function each, on tables in memory.

The rule scripts read their inputs, call one step and write what it returns; the scenario harness
(:mod:`hybridtwin.demo.scenarios`) calls the same steps on generated plants, so the banks measure the
workflow's own method. Heavy libraries are imported inside the steps that need them: a small rule does
not pay for XGBoost, Optuna or SMT.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hybridtwin.io.files import column_names, in_support, read_checked, read_matrix, side_by_side, table_of
from hybridtwin.models import registry


@dataclass(frozen=True)
class Spec:
    """What every step knows of the run: the inputs, the target, the seed, the CV folds, the threads and the
    seeded row cap of each residual model's fit (``residual_model.max_train_rows``)."""

    inputs: tuple[str, ...]
    target: str = ""
    seed: int = 0
    folds: int = 5
    n_jobs: int = 1
    max_train_rows: int | None = None

    def __post_init__(self):
        object.__setattr__(self, "inputs", tuple(self.inputs))

    @classmethod
    def from_config(cls, config: dict, n_jobs: int = 1) -> "Spec":
        return cls(
            tuple(config["columns"]["inputs"]),
            config["columns"]["target"],
            int(config["seed"]),
            int(config["cv"]["folds"]),
            n_jobs,
            int(config["residual_model"]["max_train_rows"]),
        )


# ---------------------------------------------------------------- the paper's steps


@dataclass
class Support:
    gate: object  # the fitted KNNSupportGate
    table: pd.DataFrame  # knn_distance, in_support per production row


def support(doe: pd.DataFrame, production: pd.DataFrame, spec: Spec, k: int, percentile: float, standardizer=None):
    """Steps 1-2: the kNN support gate in DoE-standardized space, and every production row's distance and verdict."""
    from hybridtwin.paper.gate import KNNSupportGate

    gate = KNNSupportGate(k=k, percentile=percentile, standardizer=standardizer).fit(doe[list(spec.inputs)])
    return Support(gate, gate.support_table(production[list(spec.inputs)]))


def surrogate(doe: pd.DataFrame, spec: Spec, n_restarts: int):
    """Step 3: the GPR surrogate of the simulator, fitted on the whole DoE."""
    from hybridtwin.paper.surrogate import GPRSurrogate

    model = GPRSurrogate(n_restarts=n_restarts, random_state=spec.seed)
    return model.fit(doe[list(spec.inputs)], doe[spec.target])


def residuals(surrogate_model, production: pd.DataFrame, spec: Spec, inside) -> pd.DataFrame:
    """Step 4: surrogate predictions and approximate residuals of every production row, with its verdict."""
    from hybridtwin.paper.residual import approximate_residuals

    table = approximate_residuals(surrogate_model, production, spec.inputs, spec.target)
    table["in_support"] = np.asarray(inside, bool)
    return table


def _training(inputs: np.ndarray, residual_table: pd.DataFrame, training: str, sample=None):
    """The rows a residual model trains on, their inputs' matrix and their residuals (``inputs``: the training
    rows' inputs, :func:`training_inputs`). ``sample(n)``: the positions among those rows that a row-capped model
    fits on (``RowCapped.fit_rows``): a final fit on ten million parts holds half a million of them, not every one."""
    from hybridtwin.paper.residual import training_rows

    rows = training_rows(residual_table["in_support"], training)
    if len(inputs) != len(rows):
        raise ValueError(f"{len(inputs)} rows of inputs for {len(rows)} {training} training rows")
    residual = residual_table["residual_approx"].to_numpy(float)[rows]
    if sample is None:
        return rows, inputs, residual
    kept = sample(len(rows))
    return rows[kept], inputs[kept], residual[kept]


def read_training(production_path, residuals_path, spec: Spec, training: str) -> tuple[np.ndarray, pd.DataFrame]:
    """What the residual model's steps read: the training rows' inputs as one matrix (those rows only, with no
    table beside them: on a long log, 0.9 GB once) and the residual table's residuals and support."""
    from hybridtwin.paper.residual import training_rows

    residuals = read_checked(residuals_path, ["residual_approx", "in_support"])
    rows = training_rows(residuals["in_support"], training)
    return read_matrix(production_path, spec.inputs, rows), residuals


def training_inputs(production: pd.DataFrame, residual_table: pd.DataFrame, spec: Spec, training: str) -> np.ndarray:
    """The inputs' matrix of the rows a residual model trains on (a step reads it with ``files.read_matrix(path,
    inputs, rows)``: only those rows, with no table beside it)."""
    from hybridtwin.paper.residual import training_rows

    rows = training_rows(residual_table["in_support"], training)
    return production[list(spec.inputs)].to_numpy(float)[rows]


def residual_model(inputs, residual_table, spec: Spec, training: str, params: dict):
    """Step 6: the residual model retrained on all its training rows ('filtered': in support; 'unfiltered': all);
    ``inputs``: those rows' inputs (:func:`training_inputs`)."""
    from hybridtwin.paper.residual import make_model

    model = make_model(params, spec.seed, spec.n_jobs, spec.max_train_rows)
    _, X, y = _training(inputs, residual_table, training, getattr(model, "fit_rows", None))
    return model.fit(X, y)


@dataclass
class ResidualCV:
    per_fold: pd.DataFrame  # the table's folds
    oof: pd.DataFrame  # row, pred_residual_oof, fold: out of period, the split the extension is scored on too
    table: pd.DataFrame  # Table 3's row (the filtered model)


def residual_cv(inputs, residual_table, spec: Spec, training: str, params: dict) -> ResidualCV:
    """Step 5b: the residual model with the tuned hyperparameters, cross-validated.

    Table 3 is the paper's shuffled K-fold CV, on a split other than the tuning's (so the score is not the winning
    trial's own). The out-of-fold predictions every later step scores on are out of period: K folds of
    consecutive parts, so that a part is predicted by a model that never saw its campaign, its coil or its hour
    (the errors the next production period meets). The model trained on every part has only the latter.
    """
    from hybridtwin.crossval import capped_note, cross_validate, ids_of, period_folds
    from hybridtwin.paper.residual import evaluation_seed, make_model

    rows, X, y = _training(inputs, residual_table, training)
    model = make_model(params, spec.seed, spec.n_jobs, spec.max_train_rows)
    periods = period_folds(len(y), spec.folds)
    per_period, oof = cross_validate(model, X, y, spec.folds, spec.seed, splits=periods)
    if training == "filtered":
        per_fold, shuffled = cross_validate(model, X, y, spec.folds, evaluation_seed(spec.seed))
        split = f"{spec.folds}-fold CV on a split other than the tuning's"
    else:
        per_fold, shuffled, split = per_period, oof, f"{spec.folds} folds of consecutive parts (periods)"
    table = _cv_summary(per_fold, y, shuffled, training, split + capped_note(spec.max_train_rows, len(y)))
    fold = ids_of(periods, len(y))
    return ResidualCV(per_fold, table_of({"row": rows, "pred_residual_oof": oof, "fold": fold}), table)


def _cv_summary(per_fold, y, oof, training: str, split: str) -> pd.DataFrame:
    from hybridtwin.crossval import cv_table

    where = "in support" if training == "filtered" else "all"
    return cv_table(
        per_fold,
        y,
        oof,
        f"XGBoost residual model ({training} train)",
        f"approximate residuals of {len(y)} production rows ({where}), {split}; hyperparameters were tuned by CV on "
        "the in-support rows",
    )


def hybrid_predictions(production, residual_table, support_table, models: dict, oof: dict, spec: Spec):
    """Every production row's surrogate and hybrids (final and out-of-fold), from the two residual models
    (``models``/``oof`` by training set: 'filtered', 'unfiltered')."""
    from hybridtwin.models.batches import by_parts
    from hybridtwin.paper.tables import production_predictions

    return production_predictions(
        residual_table,
        support_table,
        by_parts(models["filtered"].predict, production, spec.inputs),
        by_parts(models["unfiltered"].predict, production, spec.inputs),
        oof["filtered"],
        oof["unfiltered"],
    )


# ---------------------------------------------------------------- beyond the paper


def diagnose(production, residual_table, spec: Spec, settings, surrogate):
    """The diagnosis of the in-support approximate residuals (``production``: the log, or its in-support parts
    read with ``files.read_checked(path, rows=...)``); ``settings``: :class:`diagnosis.Settings`;
    ``surrogate``: the fitted :class:`~hybridtwin.paper.surrogate.GPRSurrogate` (its noise and its correlation)."""
    from hybridtwin import diagnosis
    from hybridtwin.paper.surrogate import surrogate_latent_std

    inside = in_support(residual_table)
    return diagnosis.diagnose(
        # by row labels: ``production`` may hold only the in-support parts, indexed by their rows
        production.loc[np.flatnonzero(inside)].drop(columns=[spec.target]),
        residual_table.loc[inside, "residual_approx"],
        list(spec.inputs),
        [spec.target],
        settings,
        surrogate_std=surrogate_latent_std(residual_table.loc[inside, "pred_surrogate_std"], surrogate.noise_std_),
        input_correlation=surrogate.input_correlation,
    )


def extension_fitting(spec: Spec, params: dict):
    """How the extension's models are fitted: the remainder is an XGBoost model with the tuned ``params``."""
    from hybridtwin.diagnosis.extension import Fitting
    from hybridtwin.paper.residual import make_model

    def make_xgb():  # each fit samples its rows itself (Fitting.max_rows), the forms' as the trees'
        return make_model(params, spec.seed, spec.n_jobs)

    return Fitting(tuple(spec.inputs), make_xgb, spec.max_train_rows, spec.seed)


# what the extension reads of the hybrid's predictions (a twelfth of that table: 80 MB of 1 GB on ten million parts)
HYBRID_FOR_EXTENSION = [registry.HYBRID.oof_column]


def extension_parts(production, residual_table, hybrid_table):
    """What the extension learns from: the parts, their residuals and the paper's hybrid (out-of-fold in the
    support, the final model outside; ``hybrid_table`` needs only the columns :data:`HYBRID_FOR_EXTENSION`)."""
    from hybridtwin.diagnosis.extension import Parts

    (hybrid_column,) = HYBRID_FOR_EXTENSION
    return Parts(production, residual_table, hybrid_table[hybrid_column].to_numpy(float))


def extend(parts, terms, fitting, splits, choosing, matched=None):
    """The extension with the named causes, the extended hybrid and the guard; scored out of fold."""
    from hybridtwin.diagnosis.extension import evaluate

    return evaluate(parts, terms, fitting, splits, choosing, matched)


def peer(name: str, doe, production, residual_table, spec: Spec, settings: dict):
    """One peer (:data:`registry.PEERS`) on the DoE and the in-support parts, with its honest values
    (``production``: the log, or only the rows a peer reads, ``models.peers.rows_read``, indexed by their rows)."""
    from hybridtwin.models.peers import fit_peer

    return fit_peer(name, doe, production, residual_table, spec.inputs, spec.target, settings, spec.seed, spec.folds)


def read_predictions(hybrid, extension, peers, columns=None) -> pd.DataFrame:
    """:func:`joined_predictions` of the steps' own files (paths): the table of results/predictions/production.csv,
    which is written for the user, read faster from its parts; only ``columns`` (those of them a file has), if
    given."""
    wanted = None if columns is None else set(columns)

    def read(path):
        return read_checked(path, None if wanted is None else [c for c in column_names(path) if c in wanted])

    return joined_predictions(read(hybrid), read(extension), [read(path) for path in peers])


def joined_predictions(hybrid_table: pd.DataFrame, extension_table: pd.DataFrame, peer_tables) -> pd.DataFrame:
    """results/predictions/production.csv: the hybrids', the extension's and the peers' columns side by side."""
    return side_by_side([hybrid_table, extension_table, *peer_tables])


def calibrate(predictions, production, doe, spec: Spec, threshold: float, settings: dict, truth=None, units=None):
    """Regions, intervals and the recommended model per region (``settings``: the config's ``intervals``)."""
    from hybridtwin.answers import coverage

    doe_range = {name: (float(doe[name].min()), float(doe[name].max())) for name in spec.inputs}
    inputs = production[list(spec.inputs)]
    return coverage.calibrate(predictions, inputs, doe_range, threshold, settings, spec.seed, truth, units)


def _log_columns(path, spec: Spec, causes) -> tuple[list[str], list[str]]:
    """The production log's columns the intervals step reads (:func:`monitor.calibration.log_columns`), and of
    those the ones the answers read (the inputs and the extension's causes), in the file's order."""
    from hybridtwin.diagnosis.causes import LOOK_ROWS
    from hybridtwin.io.files import read_head
    from hybridtwin.monitor.calibration import log_columns

    read = log_columns(read_head(path, LOOK_ROWS), spec.target, [*spec.inputs, *causes])
    return read, [name for name in read if name in {*spec.inputs, *causes}]


def answers_log(path, spec: Spec, causes) -> pd.DataFrame:
    """The production log's columns the answers read: on a long log the ids and counters, which only the
    monitor's calibration reads, come later (:func:`monitor_log`)."""
    return read_checked(path, _log_columns(path, spec, causes)[1])


def monitor_log(path, spec: Spec, causes, log: pd.DataFrame) -> pd.DataFrame:
    """:func:`answers_log`'s ``log`` with the columns only the monitor's calibration reads, in the file's order."""
    read, answered = _log_columns(path, spec, causes)
    rest = [name for name in read if name not in answered]
    return side_by_side([log, read_checked(path, rest)])[read] if rest else log[read]


@dataclass
class Answers:
    calibrated: object  # coverage.Calibration: regions, intervals, the recommended model per region
    reach: object  # answers.novelty.ProductionNeighbourhood: how novel a new period may be
    manifest: dict  # predictor.json: what the predictor and the monitor need besides the model files


def answers(predictions, log, doe, gate, spec: Spec, settings: dict, causes, input_units, truth=None) -> Answers:
    """The answers' calibration: the intervals and the recommendation per region, the production's reach and the
    predictor's manifest but its ``monitor`` key (:func:`monitor.calibration.calibrate`). ``log``: the production
    log's inputs and the extension's causes; ``settings``: the config's ``intervals`` plus the manifest's ``unit``
    and ``csv``; ``causes``: the extension's columns; ``input_units``: the config's ``units.inputs``."""
    from hybridtwin.answers import predictor
    from hybridtwin.diagnosis.causes import unit_of

    columns = [*spec.inputs, *sorted(set(causes) - set(spec.inputs))]
    units = {name: unit_of(name, input_units) for name in columns}
    production = log[[name for name in columns if name in log.columns]]  # the columns the answers need
    threshold = float(gate.threshold_)
    calibrated = calibrate(predictions, production, doe, spec, threshold, settings, truth, units)
    shown = {"inputs": list(spec.inputs), "target": spec.target, "threshold": threshold}
    shown |= {key: settings[key] for key in ("unit", "csv", "level")}
    found = typical(production, in_support(predictions), columns)
    manifest = predictor.manifest(doe, production, calibrated, shown, found, units)
    return Answers(calibrated, production_reach(production, gate, spec, settings["blocks"]), manifest)


def matched_predictions(matched, spec: Spec, extension_table, cases, peer_models: dict, surrogate_model) -> dict:
    """Every model at the matched cases: the extension's table (surrogate, hybrid, extended, extended hybrid), the
    gated hybrid from the matched check's ``cases`` and the peers (``peer_models`` by name)."""
    from hybridtwin.models.peers import predictions_at

    inputs = matched[list(spec.inputs)]
    return {
        **extension_table.to_dict("series"),
        registry.HYBRID_GATED.name: cases[registry.HYBRID_GATED.column],
        **predictions_at(peer_models, inputs, surrogate_model.predict(inputs)),
    }


def comparison(
    predictions, calibrated, level: float, matched_measured, matched: dict, fits: dict, truth=None, noise=None
):
    """peer_comparison.csv: every model and the recommended one on the same held-out production rows."""
    from hybridtwin.models.peers import comparison_table

    models = calibrated.held_out(level)  # as the intervals' table tested them: the test parts never chose
    return comparison_table(
        predictions["measured"],
        models,
        in_support(predictions),
        ~calibrated.calibration,
        matched_measured,
        matched,
        fits,
        truth,
        noise,
    )


def production_reach(production: pd.DataFrame, gate, spec: Spec, n_blocks: int):
    """The log's parts, DoE-standardized, and how novel a new period may be (:mod:`answers.novelty`)."""
    from hybridtwin.answers.novelty import ProductionNeighbourhood

    reach = ProductionNeighbourhood(n_blocks=n_blocks, seed=spec.seed)
    # only the parts it keeps are standardized: a ten-million-part log whole took 2 GB
    kept = production.iloc[reach.kept_rows(len(production))]
    return reach.fit(gate.standardizer_.transform(kept[list(spec.inputs)]))


def typical(production: pd.DataFrame, inside, columns) -> dict[str, float]:
    """Typical production: each numeric column's median over the in-support parts (what a one-off question's
    unset inputs take)."""
    parts = production.loc[np.asarray(inside, bool), list(columns)]
    return {name: float(parts[name].median()) for name in columns if pd.api.types.is_numeric_dtype(parts[name])}


def cause_sweeps(predictor, causes: list[dict], production: pd.DataFrame, n_values: int = 61) -> list:
    """Per named cause (diagnosis.json's ``selected``): the answer along its column at typical production, over the
    range of the DoE's and production's values widened by a tenth each side; None for a cause no sweep can show
    (a coil or lot id). Other causes' columns are held at their typical values too."""
    from hybridtwin.answers import whatif

    sweeps = []
    typical = predictor.typical
    for cause in causes:
        column = cause["columns"][0]
        if cause["kind"] == "group" or column not in typical:
            sweeps.append(None)
            continue
        values = production[column].to_numpy(float)
        low, high = np.min(values), np.max(values)
        if column in predictor.doe_range:
            low, high = min(low, predictor.doe_range[column][0]), max(high, predictor.doe_range[column][1])
        low, high = low - 0.1 * (high - low), high + 0.1 * (high - low)
        base = pd.DataFrame([{name: typical[name] for name in typical}])
        frame = whatif.sweep_frame(base, column, np.linspace(low, high, n_values))
        sweeps.append((column, predictor.predict(frame)))
    return sweeps
