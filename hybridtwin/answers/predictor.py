"""The frozen predictor: what-if questions to the models a workflow run wrote, without the workflow.

    from hybridtwin import Predictor
    predictor = Predictor.load("results/models")
    answers = predictor.predict(frame)          # a table with the input columns, by name

Only JSON files are read (the GPR surrogate and the gate in this package's
format, XGBoost models in XGBoost's own), never a pickle. Every model carries the
input names it was fitted on and the columns of a table are taken by name, so a
table with its columns in another order gives the same answers.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hybridtwin.answers import intervals, regions
from hybridtwin.diagnosis.extension import Models
from hybridtwin.io import data, files
from hybridtwin.io.reading import CsvFormat
from hybridtwin.models import compose, peers, registry
from hybridtwin.models.batches import available_cores
from hybridtwin.paper import residual
from hybridtwin.paper.gate import KNNSupportGate, input_names
from hybridtwin.paper.surrogate import GPRSurrogate

log = logging.getLogger(__name__)

MANIFEST = "predictor.json"
# columns added to each row, in this order (a contract read by outside tools); after outside_doe_range come
# beyond_<input> per input: how far the row lies beyond the DoE's range in that input's unit (0 inside)
ANSWER_COLUMNS = (
    "in_support",
    "knn_distance",
    "outside_doe_range",
    "in_domain",
    "region",
    registry.SURROGATE.column,
    f"{registry.SURROGATE.column}_std",
    *(model.column for model in registry.MODELS if model is not registry.SURROGATE),
    registry.RECOMMENDED_COLUMN,
    "recommended_model",
    "pred_lower",
    "pred_upper",
    "interval_level",
    "model_region",  # where the recommended model was chosen: 'in_support' for a row in the gate beyond the range
)


def manifest(
    inputs,
    target: str,
    unit: str,
    csv: dict,
    doe: pd.DataFrame,
    region_intervals: intervals.RegionIntervals,
    level: float,
    threshold: float,
) -> dict:
    """predictor.json: what the predictor needs besides the model files."""
    return {
        "format": "hybridtwin.Predictor/1",
        "inputs": list(inputs),
        "target": target,
        "unit": unit,
        "csv": {"sep": csv.get("sep", ","), "decimal": csv.get("decimal", ".")},
        "doe_range": {name: [float(doe[name].min()), float(doe[name].max())] for name in inputs},
        "files": registry.FILES,
        "level": level,
        "threshold": threshold,
        "intervals": region_intervals.to_dict(),
    }


def _xgb(path: Path, inputs: list[str]):
    model = residual.load_model(path)
    names = model.get_booster().feature_names
    if names is not None and list(names) != inputs:
        raise ValueError(f"{path}: fitted on inputs {names}, the predictor's manifest lists {inputs}")
    return model


@dataclass
class Predictor:
    inputs: list[str]
    target: str
    unit: str
    csv: CsvFormat
    doe_range: dict[str, tuple[float, float]]
    surrogate: GPRSurrogate
    gate: KNNSupportGate
    residual_filtered: object
    residual_unfiltered: object
    extension: Models  # the named causes' terms, the remainder model and the guard's choice
    intervals: intervals.RegionIntervals
    level: float
    peers: dict  # kind -> fitted peer (GP discrepancy, co-kriging)

    @classmethod
    def load(cls, models: str | Path, with_peers: bool = True) -> "Predictor":
        """Load the models a workflow run wrote to ``models`` (its results/models folder).

        ``with_peers=False`` leaves the peers' files unread (rebuilding SMT's co-kriging takes a second); such a
        predictor answers only ``predict(..., with_peers=False)``.
        """
        try:
            return cls._load(Path(models), with_peers)
        except (OSError, ValueError, KeyError) as error:
            if isinstance(error, data.InputError):
                raise
            raise data.InputError(
                f"models folder {str(models)!r}: {type(error).__name__}: {error}. Point --models at "
                "the results/models folder of a finished run of this version of the workflow"
            ) from None

    @classmethod
    def _load(cls, folder: Path, with_peers: bool) -> "Predictor":
        if not (folder / MANIFEST).exists():
            raise data.InputError(
                f"models folder {str(folder)!r} has no {MANIFEST}: point --models at the "
                "results/models folder of a finished workflow run"
            )
        spec = files.read_json(folder / MANIFEST)
        inputs = list(spec["inputs"])
        model_files = {key: folder / name for key, name in spec["files"].items()}
        surrogate = GPRSurrogate.from_dict(files.read_json(model_files[registry.SURROGATE.name]))
        gate = KNNSupportGate.from_dict(files.read_json(model_files["gate"]))
        for name, model in ((registry.SURROGATE.name, surrogate), ("gate", gate)):
            if input_names(model) is not None and input_names(model) != inputs:
                raise ValueError(
                    f"{model_files[name]}: fitted on inputs {input_names(model)}, the manifest lists {inputs}"
                )
        return cls(
            inputs=inputs,
            target=spec["target"],
            unit=spec["unit"],
            csv=CsvFormat(**spec["csv"]),
            doe_range={name: tuple(bounds) for name, bounds in spec["doe_range"].items()},
            surrogate=surrogate,
            gate=gate,
            residual_filtered=_xgb(model_files["residual_filtered"], inputs),
            residual_unfiltered=_xgb(model_files["residual_unfiltered"], inputs),
            extension=Models.from_stored(
                files.read_json(model_files["extension"]), _xgb(model_files["remainder"], inputs)
            ),
            intervals=intervals.RegionIntervals.from_dict(spec["intervals"]),
            level=float(spec["level"]),
            peers={
                name: peers.load_peer(name, files.read_json(model_files[name]))
                for name in registry.PEER_NAMES
                if with_peers
            },
        )

    def _inputs(self, frame: pd.DataFrame) -> pd.DataFrame:
        missing = [name for name in self.inputs if name not in frame.columns]
        if missing:
            raise data.InputError(
                f"the what-if table has no input column {', '.join(map(repr, missing))}; "
                f"the models need {', '.join(self.inputs)}"
            )
        return frame[self.inputs].astype(float)

    def predictions(
        self, frame: pd.DataFrame, in_support=None, with_peers: bool = True, n_jobs: int | None = None
    ) -> dict[str, np.ndarray]:
        """Every model's prediction per row (the gated hybrid with the workflow's gate).

        The extension needs its causes' columns: where the table lacks one (a stroke counter, a
        coil id), ``extended`` and ``extended_hybrid`` are NaN and the recommendation passes them by;
        out of the support, where the run's guard let the paper's hybrid stand for the extended
        hybrid, ``extended_hybrid`` is the paper's hybrid (which needs no such column). ``n_jobs``: threads
        for the peers (default: every core this process may use; the answers do not depend on it).
        """
        if with_peers and not self.peers:
            raise ValueError("this predictor was loaded without its peers: Predictor.load(models, with_peers=True)")
        X = self._inputs(frame)
        surrogate, std = self.surrogate.predict(X, return_std=True)
        inside = self.gate.predict(X) if in_support is None else np.asarray(in_support, bool)
        filtered = self.residual_filtered.predict(X)
        out = compose.hybrids(surrogate, filtered, inside, self.residual_unfiltered.predict(X))
        lacking = sorted(self.extension.extension.columns - set(frame.columns))
        if lacking:
            log.warning(
                "no column %s in the table: the extension (whose causes need it) gives no prediction",
                ", ".join(lacking),
            )
            extension = np.full(len(frame), np.nan)
        else:
            extension = self.extension.extension.predict(frame)
        out.update(
            compose.extended(
                surrogate,
                extension,
                self.extension.remainder.predict(X),
                out[registry.HYBRID.name],
                inside,
                self.extension.out_of_support,
            )
        )
        out[f"{registry.SURROGATE.name}_std"] = std
        out.update(
            peers.predictions_at(self.peers, X, surrogate, n_jobs or available_cores())
            if with_peers
            else {name: np.full(len(X), np.nan) for name in registry.PEER_NAMES}
        )
        return out

    def predict(
        self, frame: pd.DataFrame, level: float | None = None, with_peers: bool = True, n_jobs: int | None = None
    ) -> pd.DataFrame:
        """The rows of ``frame`` (order and extra columns kept) with the answer columns added.

        ``with_peers=False`` skips the GP discrepancy and co-kriging (most of the time on large tables): their
        columns and the stack are NaN, and where one of them is a region's best the next model is recommended.
        """
        level = self.level if level is None else float(level)
        if not 0 < level < 1:
            raise data.InputError(f"interval level {level} must lie between 0 and 1 (for example 0.9)")
        X = self._inputs(frame)
        distance = self.gate.distance(X)
        in_support = self.gate.within(distance)
        beyond = regions.outside_range(X, self.doe_range)
        beyond_range = (beyond != 0).any(axis=1).to_numpy()
        region = regions.Regions.of(in_support, beyond_range, distance, self.intervals.edges)
        predictions = self.intervals.with_stack(self.predictions(frame, in_support, with_peers, n_jobs), region)
        answers = {
            "in_support": in_support,
            "knn_distance": distance,
            "outside_doe_range": regions.describe_outside(beyond, self.doe_range),
            **{f"beyond_{name}": beyond[name].to_numpy() for name in self.inputs},
            "in_domain": in_support & ~beyond_range,
            "region": region.interval,
            "model_region": region.choice,
            **{f"pred_{model}": value for model, value in predictions.items()},
        }
        recommended = intervals.recommended_prediction(self.intervals, predictions, region, level)
        answers.update({column: recommended[column].to_numpy() for column in recommended})
        answers["interval_level"] = np.full(len(frame), level)
        out = frame.copy()
        for column in [*ANSWER_COLUMNS[:3], *(f"beyond_{name}" for name in self.inputs), *ANSWER_COLUMNS[3:]]:
            if column in out.columns:
                log.warning("the what-if table's column %r is replaced by the predictor's", column)
            out[column] = answers[column]
        uncalibrated = ~np.isin(region.interval, self.intervals.regions)
        if uncalibrated.any():
            log.warning(
                "%d row(s) in a region without calibration rows (the run had no production there): no "
                "interval, the paper's gated hybrid as the prediction",
                int(uncalibrated.sum()),
            )
        if self.intervals.max_distance is not None and np.any(distance > self.intervals.max_distance):
            log.warning(
                "%d row(s) lie further from the DoE (kNN distance up to %.3g) than any production part the "
                "intervals were calibrated on (%.3g): their intervals may be too narrow",
                int(np.sum(distance > self.intervals.max_distance)),
                float(distance.max()),
                self.intervals.max_distance,
            )
        return out

    def read(self, path, fmt: CsvFormat | None = None) -> pd.DataFrame:
        """A what-if CSV read and checked as the workflow reads its inputs."""
        fmt = fmt or self.csv
        return data.load_whatif(path, self.inputs, fmt)

    def write(self, answers: pd.DataFrame, path, fmt: CsvFormat | None = None) -> None:
        fmt = fmt or self.csv
        files.write_csv(answers, path, sep=fmt.sep, decimal=fmt.decimal)
