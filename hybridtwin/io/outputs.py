"""The catalogue of the workflow's outputs (``outputs.yaml``): every file a rule writes, and every column.

The documentation's outputs page is generated from it, and the tests hold the workflow to it: a file a rule
declares, or a column a run writes, that the catalogue does not describe fails them. Model columns are
expanded from the model registry, so a new peer needs no entry here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import yaml

from hybridtwin.models import registry

CATALOGUE = Path(__file__).with_name("outputs.yaml")
INPUTS = "<inputs>"  # stands for the run's input columns
TUNING_SETTINGS = "<tuning settings>"  # stands for the tuned XGBoost settings


@dataclass(frozen=True)
class Output:
    path: str  # under the results folder; {name} is any one path part
    rule: str
    what: str
    columns: tuple[tuple[str, str], ...] | None  # (column, meaning), templates expanded; None: not a table
    section: str

    def matches(self, relative: str) -> bool:
        return re.fullmatch(path_pattern(self.path), relative) is not None


def path_pattern(path: str) -> str:
    parts = re.split(r"(\{\w+\})", path)
    return "".join("[^/]+" if re.fullmatch(r"\{\w+\}", part) else re.escape(part) for part in parts)


@cache
def raw() -> dict:
    return yaml.safe_load(CATALOGUE.read_text(encoding="utf-8"))


def shared_columns() -> dict[str, dict]:
    """Column sets several files share (CV summaries, comparisons, ...), by name."""
    return {name: spec for section in raw()["sections"] for name, spec in (section.get("columns") or {}).items()}


def resolve(spec, shared: dict[str, dict]) -> list[tuple[str, str]]:
    """A file's columns: a shared set's name, or a mapping whose ``+name`` keys take in a shared set."""
    if spec is None:
        return []
    if isinstance(spec, str):
        return resolve(shared[spec], shared)
    columns = []
    for name, meaning in spec.items():
        columns += resolve(shared[name[1:]], shared) if name.startswith("+") else [(name, meaning)]
    return columns


def expand(columns: list[tuple[str, str]]) -> tuple[tuple[str, str], ...]:
    """Templates filled from the registry: {peer} and {peer_label} per peer, {models} the list of models."""
    models = ", ".join(f"`{model.name}`" for model in registry.MODELS)
    out = []
    for name, meaning in columns:
        meaning = meaning.replace("{models}", models)
        if "{peer}" not in name:
            out.append((name, meaning))
            continue
        for peer in registry.PEERS:
            out.append((name.replace("{peer}", peer.name), meaning.replace("{peer_label}", peer.label)))
    return tuple(out)


def catalogue() -> list[Output]:
    shared = shared_columns()
    return [
        Output(
            entry["path"],
            entry["rule"],
            entry["what"].strip(),
            expand(resolve(entry["columns"], shared)) if "columns" in entry else None,
            section["title"],
        )
        for section in raw()["sections"]
        for entry in section.get("files", ())
    ]


def entry_for(relative: str) -> Output | None:
    """The catalogue's entry for a file under the results folder (a path with ``/``), or None; a path named in
    full goes before a wildcard's (``residual_xgb_extended.json`` before ``residual_xgb_{training}.json``), and of
    two wildcards' the longer named part (``cv_folds_{training}.csv`` before ``cv_{training}.csv``)."""
    matching = [entry for entry in catalogue() if entry.matches(relative)]
    return min(
        matching, key=lambda entry: (entry.path.count("{"), -len(re.sub(r"\{\w+\}", "", entry.path))), default=None
    )


def undescribed_columns(entry: Output, header, inputs, tuning_settings=()) -> list[str]:
    """The columns of a written file's ``header`` that its entry does not describe."""
    described = {name for name, _ in entry.columns or ()}
    stand_ins = {INPUTS: set(inputs), TUNING_SETTINGS: set(tuning_settings)}
    for name, names in stand_ins.items():
        if name in described:
            described |= names
    return [column for column in header if column not in described]
