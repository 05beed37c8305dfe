"""The workflow's steps on one generated plant, in memory: what the scenario tests and the banks measure.

Each step is the :mod:`hybridtwin.pipeline` function the workflow's rule calls, computed once on first use
and handed on as the rule's output file is; the settings are the config schema's defaults but for a fixed
XGBoost setting in place of the Optuna study (a bank runs hundreds of plants) and one GPR restart.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pandas as pd

from hybridtwin import pipeline
from hybridtwin.io import config as configuration
from hybridtwin.models import registry

# A fixed, moderate XGBoost setting stands in for the tuned one to keep scenarios fast.
SCENARIO_XGB = dict(
    n_estimators=300,
    max_depth=5,
    learning_rate=0.05,
    subsample=0.8,
    colsample_bytree=0.8,
    min_child_weight=5,
    gamma=0.5,
    reg_alpha=0.1,
    reg_lambda=1.0,
)


def default_config(inputs, target: str, seed: int, **sections) -> dict:
    """A checked config with the schema's defaults for a plant's columns; ``sections`` override whole keys."""
    columns = {"inputs": list(inputs), "target": target, "matched_simulated": "_", "matched_measured": "_"}
    config = {"data": {"doe": "_", "production": "_", "matched": "_"}, "columns": columns, "seed": seed}
    return configuration.check({**config, **sections})


@dataclass
class Run:
    """The steps on ``doe`` and ``production``, each computed once; ``params``: the residual models' XGBoost
    hyperparameters (the workflow's tuned ones, or :data:`SCENARIO_XGB`)."""

    doe: pd.DataFrame
    production: pd.DataFrame
    config: dict
    params: dict = field(default_factory=lambda: dict(SCENARIO_XGB))
    n_jobs: int = 1

    @classmethod
    def of(cls, case, seed: int, n_jobs: int = 1, params: dict | None = None, n_restarts: int = 1, **sections) -> "Run":
        """A generated plant (:class:`~hybridtwin.demo.families.PlantCase`), with ``n_restarts`` GPR restarts and
        the config's ``sections`` as given."""
        config = default_config(case.inputs, case.target, seed, surrogate={"n_restarts": n_restarts}, **sections)
        return cls(case.doe, case.production, config, dict(params or SCENARIO_XGB), n_jobs)

    @classmethod
    def of_workflow(cls, config: dict, doe: pd.DataFrame, production: pd.DataFrame, params: dict, n_jobs: int = 2):
        """The steps with a workflow run's own config and tuned ``params``, on its checked data."""
        return cls(doe, production, configuration.check(dict(config)), dict(params), n_jobs)

    @cached_property
    def spec(self) -> pipeline.Spec:
        return pipeline.Spec.from_config(self.config, self.n_jobs)

    @cached_property
    def support(self) -> pipeline.Support:
        gate = self.config["gate"]
        return pipeline.support(self.doe, self.production, self.spec, gate["k"], gate["percentile"])

    @property
    def inside(self) -> np.ndarray:
        return self.support.table["in_support"].to_numpy(bool)

    @cached_property
    def surrogate(self):
        return pipeline.surrogate(self.doe, self.spec, self.config["surrogate"]["n_restarts"])

    @cached_property
    def residuals(self) -> pd.DataFrame:
        return pipeline.residuals(self.surrogate, self.production, self.spec, self.inside)

    @property
    def residual(self) -> np.ndarray:
        """The approximate residual of every part."""
        return self.residuals["residual_approx"].to_numpy(float)

    def residual_model(self, training: str = "filtered"):
        inputs = pipeline.training_inputs(self.production, self.residuals, self.spec, training)
        return pipeline.residual_model(inputs, self.residuals, self.spec, training, self.params)

    @cached_property
    def inputs(self) -> np.ndarray:
        """Every part's inputs as the residual models read them."""
        return self.production[list(self.spec.inputs)].to_numpy(float)

    @cached_property
    def hybrid(self) -> np.ndarray:
        """The paper's hybrid of every part, from the final filtered model (in-sample in the support)."""
        return self.residuals[registry.SURROGATE.column].to_numpy(float) + self.residual_model().predict(self.inputs)

    def diagnose(self, settings):
        return pipeline.diagnose(self.production, self.residuals, self.spec, settings, self.surrogate)

    @cached_property
    def choosing(self) -> np.ndarray:
        """The even blocks of consecutive parts: they choose (the guard, the recommended model); the odd ones score."""
        from hybridtwin.answers.regions import calibration_rows

        return calibration_rows(len(self.production), self.config["intervals"]["blocks"])

    @cached_property
    def fitting(self):
        return pipeline.extension_fitting(self.spec, self.params)

    def extended(self, terms, hybrid: np.ndarray | None = None):
        """The extension's models fitted on every in-support part and their (guarded) predictions of every part."""
        from hybridtwin.diagnosis.extension import fit_guarded

        parts = pipeline.extension_parts(self.production, self.residuals, self.hybrid_table(hybrid))
        return fit_guarded(parts, terms, self.fitting, self.choosing)

    def hybrid_table(self, hybrid: np.ndarray | None = None) -> pd.DataFrame:
        """The columns of the workflow's hybrid table that the extension reads (``hybrid``: its out-of-fold
        values; by default the final model's)."""
        return pd.DataFrame({registry.HYBRID.oof_column: self.hybrid if hybrid is None else hybrid})

    @cached_property
    def residual_cv(self) -> pipeline.ResidualCV:
        inputs = pipeline.training_inputs(self.production, self.residuals, self.spec, "filtered")
        return pipeline.residual_cv(inputs, self.residuals, self.spec, "filtered", self.params)

    @cached_property
    def hybrid_predictions(self) -> pd.DataFrame:
        """The workflow's hybrid table (the paper's filtered model only: the banks do not compare the unfiltered)."""
        from hybridtwin.paper.tables import production_predictions

        final = self.residual_model().predict(self.inputs)
        return production_predictions(self.residuals, self.support.table, final, None, self.residual_cv.oof, None)

    def extension(self, terms):
        """The extension scored out of fold on the hybrid's own split, as rule model_extension does."""
        from hybridtwin.crossval import written_splits

        parts = pipeline.extension_parts(self.production, self.residuals, self.hybrid_predictions)
        splits = written_splits(self.residual_cv.oof, np.flatnonzero(self.inside))
        return pipeline.extend(parts, terms, self.fitting, splits, self.choosing)

    def peer(self, name: str):
        return pipeline.peer(name, self.doe, self.production, self.residuals, self.spec, self.config["peers"])

    def predictions(self, terms) -> pd.DataFrame:
        """predictions/production.csv of the workflow, but for the unfiltered hybrid."""
        peers = [self.peer(name).production for name in registry.PEER_NAMES]
        return pipeline.joined_predictions(self.hybrid_predictions, self.extension(terms).production, peers)

    def calibrate(self, predictions: pd.DataFrame, truth=None):
        return pipeline.calibrate(
            predictions,
            self.production,
            self.doe,
            self.spec,
            self.support.gate.threshold_,
            self.config["intervals"],
            truth,
        )
