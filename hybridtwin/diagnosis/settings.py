"""The diagnosis' settings, with the config schema's defaults (``diagnosis:``)."""

from __future__ import annotations

from dataclasses import dataclass

from hybridtwin.io.config import section_defaults

DEFAULTS = section_defaults("diagnosis")


@dataclass(frozen=True)
class Settings:
    """``seed``: the run's seed; ``unit``: the target's, in which the causes' descriptions give effects
    (config ``units.target``); ``input_units``: (column, unit) pairs of config ``units.inputs``."""

    folds: int = section_defaults("cv")["folds"]
    seed: int = 0
    alpha: float = DEFAULTS["alpha"]
    max_causes: int = DEFAULTS["max_causes"]
    max_levels: int = DEFAULTS["max_levels"]
    max_rows: int = DEFAULTS["max_rows"]
    surrogate_margin: float = DEFAULTS["surrogate_margin"]
    interactions: bool = DEFAULTS["interactions"]
    exclude: tuple[str, ...] = tuple(DEFAULTS["exclude"])
    n_blocks: int = DEFAULTS["n_blocks"]
    n_jobs: int = 1
    unit: str = section_defaults("units")["target"]
    input_units: tuple[tuple[str, str], ...] = ()

    @classmethod
    def from_config(
        cls, config: dict | None, folds: int, seed: int, unit: str, n_jobs: int = 1, input_units: dict | None = None
    ) -> "Settings":
        config = dict(config or {})
        config["exclude"] = tuple(config.get("exclude", ()))
        units = tuple(sorted((input_units or {}).items()))
        return cls(folds=folds, seed=seed, unit=unit, n_jobs=n_jobs, input_units=units, **config)
