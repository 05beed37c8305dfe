"""The frozen predictor: what-if questions to the models a workflow run wrote, without the workflow.

    from hybridtwin import Predictor
    predictor = Predictor.load(models_folder)   # a run's <results_dir>/models
    answers = predictor.predict(frame)           # a table with the input columns, by name

Each row gets the recommended prediction, its interval, and a trust verdict with its reason
(:mod:`.trust`). Only the models the recommendation needs in each row's region are computed (a peer only for
the rows it is recommended for), unless ``all_models``. Only JSON files are read, never a pickle; every model
carries the input names it was fitted on and a table's columns are taken by name.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin.answers import answer, intervals, regions, trust
from hybridtwin.answers.novelty import ProductionNeighbourhood
from hybridtwin.answers.trust import numbers
from hybridtwin.diagnosis.extension import Models
from hybridtwin.io import data, files
from hybridtwin.io.errors import InputError
from hybridtwin.io.reading import CsvFormat, checked_numbers
from hybridtwin.models import compose, peers, registry
from hybridtwin.models.batches import available_cores
from hybridtwin.models.stack import members
from hybridtwin.paper import residual
from hybridtwin.paper.gate import KNNSupportGate, input_names
from hybridtwin.paper.surrogate import GPRSurrogate

log = logging.getLogger(__name__)

MANIFEST = "predictor.json"
FORMAT = "hybridtwin.Predictor/2"
# the models whose prediction every row with its inputs has (the extension's needs its causes' columns)
ALWAYS = {registry.SURROGATE.name, registry.HYBRID_GATED.name, registry.HYBRID.name, *registry.PEER_NAMES}


def _xgb(path: Path, inputs: list[str]):
    model = residual.load_model(path)
    names = model.get_booster().feature_names
    if names is not None and list(names) != inputs:
        raise ValueError(f"{path}: fitted on inputs {names}, the predictor's manifest lists {inputs}")
    return model


@dataclass
class Predictor:
    folder: Path
    spec: dict  # predictor.json
    surrogate: GPRSurrogate
    gate: KNNSupportGate
    residual_filtered: object
    residual_unfiltered: object
    extension: Models  # the named causes' terms, the remainder model and the guard's choice
    intervals: intervals.RegionIntervals
    neighbourhood: ProductionNeighbourhood | None = None  # the logged production (novelty of a new setting)
    _peers: dict = field(default_factory=dict)  # loaded on first use: rebuilding co-kriging takes a second

    @classmethod
    def load(cls, models: str | Path) -> "Predictor":
        """Load the models a workflow run wrote to ``models`` (its <results_dir>/models folder)."""
        folder = Path(models)
        if not (folder / MANIFEST).exists():
            raise InputError(
                f"models folder {str(folder)!r} has no {MANIFEST}: point --models at the models folder of a "
                "finished workflow run (<results_dir>/models)"
            )
        try:
            return cls._load(folder, files.read_json(folder / MANIFEST))
        except (OSError, ValueError, KeyError) as error:
            if isinstance(error, InputError):
                raise
            raise InputError(
                f"models folder {str(folder)!r}: {type(error).__name__}: {error}. Point --models at the models "
                "folder of a finished run of this version of the workflow"
            ) from None

    @classmethod
    def _load(cls, folder: Path, spec: dict) -> "Predictor":
        if spec.get("format") != FORMAT:
            raise ValueError(f"{MANIFEST} is {spec.get('format')!r}, this version reads {FORMAT!r}: rerun the workflow")
        inputs = list(spec["inputs"])
        path = {key: folder / name for key, name in spec["files"].items()}
        surrogate = GPRSurrogate.from_dict(files.read_json(path[registry.SURROGATE.name]))
        gate = KNNSupportGate.from_dict(files.read_json(path["gate"]))
        for name, model in ((registry.SURROGATE.name, surrogate), ("gate", gate)):
            if input_names(model) is not None and input_names(model) != inputs:
                raise ValueError(f"{path[name]}: fitted on inputs {input_names(model)}, the manifest lists {inputs}")
        return cls(
            folder,
            spec,
            surrogate,
            gate,
            _xgb(path["residual_filtered"], inputs),
            _xgb(path["residual_unfiltered"], inputs),
            Models.from_stored(files.read_json(path["extension"]), _xgb(path["remainder"], inputs)),
            intervals.RegionIntervals.from_dict(spec["intervals"]),
            ProductionNeighbourhood.from_dict(files.read_json(path["production_reach"])),
        )

    @property
    def inputs(self) -> list[str]:
        return list(self.spec["inputs"])

    @property
    def level(self) -> float:
        return float(self.spec["level"])

    @property
    def csv(self) -> CsvFormat:
        return CsvFormat(**self.spec["csv"])

    @property
    def doe_range(self) -> dict[str, tuple[float, float]]:
        return {name: tuple(bounds) for name, bounds in self.spec["doe_range"].items()}

    @property
    def input_units(self) -> dict[str, str]:
        """Each input's unit ('' where the config gave none; none at all in models stored before units were)."""
        return dict(self.spec.get("units", {}))

    @property
    def logged_range(self) -> dict[str, tuple[float, float]] | None:
        """Each input's lowest and highest setting over the production log (None: models stored before it was)."""
        stored = self.spec.get("logged_range")
        return None if stored is None else {name: tuple(bounds) for name, bounds in stored.items()}

    @property
    def typical(self) -> dict[str, float]:
        """Typical production: the median of the in-support parts, per input (and per numeric cause column)."""
        return dict(self.spec["typical"])

    @property
    def reach(self) -> trust.Reach:
        """How far the log's parts that calibrated and tested the intervals lie: the answers' verdicts."""
        return self._reach(self.intervals.max_distance, self.intervals.reach)

    @property
    def judging_reach(self) -> trust.Reach:
        """How far the calibration parts alone lie: the daily check judges no part beyond (models stored before it:
        the answers' :attr:`reach`)."""
        judging = self.intervals.judging
        return self.reach if judging is None else self._reach(judging["max_distance"], judging["beyond"])

    def _reach(self, max_distance: float | None, ranges: dict) -> trust.Reach:
        ranges = ranges or {name: (0.0, 0.0) for name in self.inputs}
        return trust.Reach(
            float(self.spec["threshold"]),
            max_distance,
            {name: tuple(ranges[name]) for name in self.inputs},
            self.doe_range,
            self.input_units,
            None if self.neighbourhood is None else self.neighbourhood.threshold_,
        )

    def peer(self, name: str):
        """A peer, read on first use (a table whose recommendations need no peer never reads their files)."""
        if name not in self._peers:
            path = self.folder / self.spec["files"][name]
            try:
                self._peers[name] = peers.load_peer(name, files.read_json(path))
            except (OSError, ValueError, KeyError) as error:
                raise InputError(
                    f"{str(path)!r}: {type(error).__name__}: {error}. Rerun the workflow that wrote these models"
                ) from None
        return self._peers[name]

    def checked(self, frame: pd.DataFrame, where: str = "the what-if table") -> pd.DataFrame:
        """The inputs of ``frame`` as numbers, with the workflow's checks: a missing column, text, an empty or an
        infinite cell stops with one line naming the column and the row; so does a table with no rows."""
        if not isinstance(frame, pd.DataFrame):
            raise InputError(
                f"{where} must be a pandas table (DataFrame) of the input columns, not {type(frame).__name__}"
            )
        doubled = sorted({str(name) for name in frame.columns[frame.columns.duplicated()]})
        if doubled:
            raise InputError(f"{where} has the column {', '.join(map(repr, doubled))} twice; every column once")
        data.require_inputs(frame, self.inputs, where)
        if frame.empty:
            raise InputError(f"{where} has no rows: nothing to predict")
        return checked_numbers(frame, self.inputs, where, self.csv)

    def predict(
        self, frame: pd.DataFrame, level: float | None = None, all_models: bool = False, n_jobs: int | None = None
    ) -> pd.DataFrame:
        """The rows of ``frame`` (order and extra columns kept) with the answer columns added
        (:data:`answer.DEFAULT`; ``all_models``: every model's prediction and the regions' bookkeeping too).
        ``n_jobs``: threads for the peers (default: every core this process may use; the answers do not
        depend on it)."""
        level = self.level if level is None else float(level)
        if not 0 < level < 1:
            raise InputError(f"interval level {level} must lie between 0 and 1 (for example 0.9)")
        X = self.checked(frame)
        where = self.where(X)
        values = self.values(frame, X, where, all_models, n_jobs or available_cores())
        picked = intervals.recommended_prediction(self.intervals, values, where.region, level)
        extrapolated = where.trust == trust.EXTRAPOLATION
        picked.loc[extrapolated, ["pred_lower", "pred_upper"]] = np.nan  # nothing checked an interval this far
        self._say_why_wider(where, picked, values, level, frame.columns)
        self._say_recalibrated(where, picked)
        return answer.assemble(frame, where, values, picked, level, all_models, self.inputs)

    def _say_why_wider(self, where: answer.Where, picked: pd.DataFrame, values: dict, level: float, columns) -> None:
        """The reason of a row whose interval the corrections' disagreement widened says by how much and why; of a
        row where it could not (a cause's column missing), that it did not."""
        spread = intervals.disagreement(values)
        if spread is None:
            return
        half = ((picked["pred_upper"] - picked["pred_lower"]) / 2).to_numpy(float)
        models, interval_regions = picked["recommended_model"].to_numpy(object), where.region.interval
        unit, lacking = self.spec.get("unit", ""), ", ".join(self.lacking(columns))
        for model, region in set(zip(models[np.isfinite(half)], interval_regions[np.isfinite(half)])):
            plain = self.intervals.half_width(model, region, level)
            typical = self.intervals.typical_spread(model, region)
            here = (models == model) & (interval_regions == region) & np.isfinite(half)
            if typical is None:
                continue
            unknown = here & np.isnan(spread)
            where.reason[unknown] = where.reason[unknown] + (
                f"; not widened where the models that correct the surrogate part ways: no column {lacking}"
                if lacking
                else "; not widened where the models that correct the surrogate part ways: one has no value here"
            )
            rows = here & (half > plain * (1 + 1e-9))
            if not rows.any():
                continue
            where.reason[rows] = (
                where.reason[rows]
                + "; the interval is "
                + numbers(half[rows] / plain)
                + " times its calibration's: the models that correct the surrogate differ by "
                + numbers(spread[rows])
                + f" {unit} (sd) here, {typical:.3g} {unit} on the parts that calibrated it"
            )

    def _say_recalibrated(self, where: answer.Where, picked: pd.DataFrame) -> None:
        """The reason of a row whose region was calibrated on the log's test parts too says why: the calibration
        parts' interval covered too few of them."""
        has = np.isfinite(picked["pred_lower"].to_numpy(float))
        for region, (covered, n) in self.intervals.recalibrated.items():
            rows = has & (where.region.interval == region)
            where.reason[rows] = where.reason[rows] + (
                f"; calibrated on the log's test parts here too: the calibration parts' interval covered {covered} "
                f"of {n} of them ({covered / n:.0%})"
            )

    def where(self, X: pd.DataFrame) -> answer.Where:
        """Each row's place: distance to the DoE, support, ranges, regions, and the trust verdict."""
        distance = self.gate.distance(X)
        inside = self.gate.within(distance)
        beyond = regions.outside_range(X, self.doe_range)
        outside_range = (beyond != 0).any(axis=1).to_numpy()
        region = regions.Regions.of(inside, outside_range, distance, self.intervals.edges, self.intervals.beyond_region)
        novelty = None
        if self.neighbourhood is not None:  # inside the support too: the residual models learnt only where parts were
            novelty = self.neighbourhood.distance(self.gate.standardizer_.transform(X)) if len(X) else np.zeros(0)
        verdict, reason = trust.verdicts(inside, beyond, distance, self.reach, novelty)
        return answer.Where(distance, inside, beyond, region, verdict, reason, self.doe_range)

    def needed(self, where: answer.Where, columns) -> dict[str, np.ndarray]:
        """Per model, the rows whose recommendation may need it: its region's ranking down to the first model
        every such row has a value of."""
        extension_ok = self.extension.extension.columns <= set(columns)
        needed = {}
        for name, order in self.intervals.ranking.items():
            rows = where.region.choice == name
            for model in order:
                needed[model] = needed.get(model, np.zeros(len(rows), bool)) | rows
                if model == registry.STACK.name:
                    for member in members(self.intervals.weights.get(name, {})):
                        needed[member] = needed.get(member, np.zeros(len(rows), bool)) | rows
                    break
                if model in ALWAYS or extension_ok:
                    break
        return needed

    def values(
        self, frame, X: pd.DataFrame, where: answer.Where, all_models: bool, n_jobs: int, bounds: bool = True
    ) -> dict:
        """Each model's prediction per row: the surrogate and the paper's hybrids always; the others where the
        recommendation needs them (everywhere with ``all_models``), NaN elsewhere; with ``bounds`` (the answer's
        interval) the extended models out of the support too, whose disagreement with the paper's hybrid widens it."""
        n = len(X)
        needed = self.needed(where, frame.columns)
        if all_models:
            needed = {model.name: np.ones(n, bool) for model in registry.MODELS}
        # the surrogate's own standard deviation is bookkeeping: computed only for all_models
        surrogate, std = self.surrogate.predict(X, return_std=True) if all_models else (self.surrogate.predict(X), None)
        unfiltered = self.residual_unfiltered.predict(X) if all_models else None
        out = compose.hybrids(surrogate, self.residual_filtered.predict(X), where.inside, unfiltered)
        if std is not None:
            out[f"{registry.SURROGATE.name}_std"] = std
        widening = bounds and bool(np.any(where.region.interval != regions.IN_SUPPORT))
        out.update(self._extended(frame, X, where, (surrogate, out[registry.HYBRID.name]), needed, widening))
        for name in registry.PEER_NAMES:
            rows = np.flatnonzero(needed.get(name, np.zeros(n, bool)))
            out[name] = np.full(n, np.nan)
            if len(rows):
                at = peers.predictions_at({name: self.peer(name)}, X.iloc[rows], surrogate[rows], n_jobs)
                out[name][rows] = at[name]
        return self.intervals.with_stack(out, where.region)

    def _extended(
        self, frame, X, where: answer.Where, surrogate_hybrid, needed: dict, widening: bool = False
    ) -> dict[str, np.ndarray]:
        """The extended model and the (guarded) extended hybrid, where needed or ``widening`` (rows out of the
        support, whose interval their disagreement with the paper's hybrid widens), and the table has their causes'
        columns; out of the support, where the guard let the paper's hybrid stand, that hybrid."""
        surrogate, hybrid = surrogate_hybrid
        wanted = any(needed.get(m.name, np.zeros(1, bool)).any() for m in (registry.EXTENDED, registry.EXTENDED_HYBRID))
        lacking = self.lacking(frame.columns)
        if lacking and wanted:
            log.warning("no column %s in the table: the extension (whose causes need it) gives no prediction", lacking)
        if lacking or not (wanted or widening):
            extension, remainder = np.full(len(X), np.nan), np.full(len(X), np.nan)
        else:
            extension, remainder = self.extension.extension.predict(frame), self.extension.remainder.predict(X)
        return compose.extended(surrogate, extension, remainder, hybrid, where.inside, self.extension.out_of_support)

    def lacking(self, columns) -> list[str]:
        """The extension's causes that are not among ``columns``: without them it gives no prediction."""
        return sorted(self.extension.extension.columns - set(columns))

    def read(self, path, fmt: CsvFormat | None = None) -> pd.DataFrame:
        """A what-if CSV read and checked as the workflow reads its inputs."""
        return data.load_whatif(path, self.inputs, fmt or self.csv)

    def write(self, answers: pd.DataFrame, path, fmt: CsvFormat | None = None) -> None:
        fmt = fmt or self.csv
        files.write_csv(answers, path, sep=fmt.sep, decimal=fmt.decimal)


def manifest(
    doe: pd.DataFrame, production: pd.DataFrame, calibrated, settings: dict, typical: dict[str, float], units: dict
) -> dict:
    """predictor.json: what the predictor needs besides the model files. ``settings``: inputs, target, unit, csv,
    level, threshold; ``production``: the log's inputs (their range: where a batch goes beyond the whole log)."""
    inputs = list(settings["inputs"])
    csv = settings["csv"]
    return {
        "format": FORMAT,
        "inputs": inputs,
        "target": settings["target"],
        "unit": settings["unit"],
        "units": {name: units.get(name, "") for name in inputs},
        "csv": {
            "sep": csv.get("sep", ","),
            "decimal": csv.get("decimal", "."),
            "encoding": csv.get("encoding", "utf-8"),
        },
        "doe_range": {name: [float(doe[name].min()), float(doe[name].max())] for name in inputs},
        "logged_range": {name: [float(production[name].min()), float(production[name].max())] for name in inputs},
        "typical": {name: float(value) for name, value in typical.items()},
        "files": registry.FILES,
        "level": settings["level"],
        "threshold": settings["threshold"],
        "intervals": calibrated.intervals.to_dict(),
    }
