"""The workflow's config, checked against one JSON schema shipped in this package.

The schema (``config.schema.yaml`` beside this module) is the single source of the
config's keys, types, ranges and defaults: the Snakefile and the tests read the same file.
A bad value stops with one plain line that names the key, the value and the rule it
breaks, for example ``config error: tuning.n_trials = 0, must be at least 1``, instead
of a dump of the validator's state. Only the standard library, jsonschema and PyYAML are
imported here: Snakemake's own environment has them.
"""

from __future__ import annotations

import copy
import difflib
import functools
import json
from pathlib import Path

import jsonschema
import yaml

from hybridtwin.io.errors import InputError, other_csvs

SCHEMA_PATH = Path(__file__).with_name("config.schema.yaml")

TYPE_WORDS = {
    "integer": "a whole number",
    "number": "a number",
    "string": "text",
    "array": "a list",
    "object": "a mapping of keys to values",
    "boolean": "true or false",
    "null": "empty",
}


class ConfigError(InputError):
    """A config value the schema rejects, or a data file the config names that does not exist."""


def schema() -> dict:
    return copy.deepcopy(_schema())


@functools.cache
def _schema() -> dict:
    return yaml.safe_load(SCHEMA_PATH.read_text())


def section_defaults(section: str) -> dict:
    """The defaults of one config section's keys (``peers``: the peers' sizes), as the workflow fills them in:
    the one source of every in-memory settings object's defaults."""
    properties = _schema()["properties"][section]["properties"]
    return {key: copy.deepcopy(spec["default"]) for key, spec in properties.items() if "default" in spec}


def default(key: str):
    """The default of a top-level key (``seed``, ``results_dir``)."""
    return copy.deepcopy(_schema()["properties"][key]["default"])


def _with_defaults(validator_class):
    """A validator that fills in each missing key's default before checking it (as Snakemake's ``validate``)."""
    check_properties = validator_class.VALIDATORS["properties"]

    def properties(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for key, subschema in properties.items():
                if "default" in subschema:
                    instance.setdefault(key, copy.deepcopy(subschema["default"]))
        yield from check_properties(validator, properties, instance, schema)

    return jsonschema.validators.extend(validator_class, {"properties": properties})


def check(config: dict) -> dict:
    """Fill in the schema's defaults in ``config`` (in place) and check it; returns it.

    Raises :class:`ConfigError` with one line about the first bad key.
    """
    rules = schema()
    validator = _with_defaults(jsonschema.validators.validator_for(rules))(rules)
    error = jsonschema.exceptions.best_match(validator.iter_errors(config))
    if error is not None:
        raise ConfigError(describe(error))
    return config


def _as_list(value) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]


def _key(path) -> str:
    return ".".join(str(part) for part in path)


def _value(value) -> str:
    return repr(value) if isinstance(value, str) else json.dumps(value, default=str)


def describe(error: jsonschema.ValidationError) -> str:
    """One line: the key, its value and the rule it breaks."""
    key, rule, limit = _key(error.absolute_path), error.validator, error.validator_value
    if rule == "required":
        missing = [name for name in limit if name not in error.instance]
        where = f"{key}." if key else ""
        return f"config error: {where}{missing[0]} is missing" + (f" (under {key})" if key else "")
    if rule == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        unknown = sorted(set(error.instance) - set(known))
        close = difflib.get_close_matches(unknown[0], known, n=1)
        hint = f", did you mean {close[0]!r}?" if close else f"; known keys: {', '.join(known)}"
        return f"config error: {_key([*error.absolute_path, unknown[0]])} is not a known key{hint}"
    says = {
        "minimum": lambda: f"must be at least {limit}",
        "maximum": lambda: f"must be at most {limit}",
        "exclusiveMinimum": lambda: f"must be more than {limit}",
        "exclusiveMaximum": lambda: f"must be less than {limit}",
        "type": lambda: "must be " + " or ".join(TYPE_WORDS.get(kind, kind) for kind in _as_list(limit)),
        "enum": lambda: "must be one of " + ", ".join(_value(option) for option in limit),
        "minItems": lambda: f"must list at least {limit}",
        "minLength": lambda: "must not be empty",
        "pattern": lambda: "must not be blank",
        "uniqueItems": lambda: "must not list a name twice",
    }.get(rule, lambda: error.message)()
    return f"config error: {key or 'the config'} = {_value(error.instance)}, {says}"


def plant_results_dir(config: dict, configfiles, command_line: dict | None, workflow_config) -> None:
    """A plant's own config file that names no ``results_dir`` writes under ``results/<its file's name>``, never
    into the demo's ``results/`` (``--configfile`` extends the workflow's own config, which names none).

    ``configfiles``: the command line's ``--configfile`` files; ``command_line``: its ``--config`` values.
    """
    own = [Path(path) for path in configfiles or () if Path(path).resolve() != Path(workflow_config).resolve()]
    if not own or "results_dir" in (command_line or {}):
        return
    if any("results_dir" in (yaml.safe_load(path.read_text()) or {}) for path in own):
        return
    config["results_dir"] = f"{default('results_dir')}/{own[-1].stem}"


def missing_data_files(config: dict, made_by_the_workflow=()) -> None:
    """Stop with a :class:`ConfigError` naming the ``data.*`` key whose file does not exist
    (paths under ``made_by_the_workflow``, such as the demo plant's, are written by the run)."""
    for role, path in config.get("data", {}).items():
        if Path(path).exists() or any(Path(path).is_relative_to(folder) for folder in made_by_the_workflow):
            continue
        hint = other_csvs(Path(path))
        if Path(path).parent.name == "demo" and made_by_the_workflow:
            hint += f"; this run makes the demo plant's files under {str(made_by_the_workflow[0])!r}"
        raise ConfigError(f"config error: data.{role} = {path!r}, no such file{hint}")
