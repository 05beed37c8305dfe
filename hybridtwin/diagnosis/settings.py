"""The diagnosis' settings, with the config schema's defaults (``diagnosis:``)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Settings:
    folds: int = 5
    seed: int = 0
    alpha: float = 0.01
    max_causes: int = 3
    max_levels: int = 200
    max_rows: int = 10_000
    surrogate_margin: float = 1.0
    interactions: bool = True
    exclude: tuple[str, ...] = ()
    n_blocks: int = 200
    n_jobs: int = 1
    unit: str = "mm"  # of the target: the causes' descriptions give effects in it (config units.target)
    input_units: tuple[tuple[str, str], ...] = ()  # (column, unit) pairs of config units.inputs

    @classmethod
    def from_config(
        cls, config: dict | None, folds: int, seed: int, unit: str, n_jobs: int = 1, input_units: dict | None = None
    ) -> "Settings":
        config = dict(config or {})
        config["exclude"] = tuple(config.get("exclude", ()))
        units = tuple(sorted((input_units or {}).items()))
        return cls(folds=folds, seed=seed, unit=unit, n_jobs=n_jobs, input_units=units, **config)
