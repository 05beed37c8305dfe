"""The config schema: the one source of the config's keys and of every in-memory settings object's defaults."""

from dataclasses import asdict

import pytest

from hybridtwin.demo import DemoPlant
from hybridtwin.diagnosis import Settings
from hybridtwin.enrichment import EnrichmentSettings
from hybridtwin.io import config

KEYWORDS = {
    "$schema", "type", "description", "default", "enum", "minimum", "maximum", "exclusiveMinimum",
    "exclusiveMaximum", "minLength", "pattern", "items", "properties", "additionalProperties", "required",
    "uniqueItems", "minItems", "patternProperties",
}  # fmt: skip


def _nodes(node, path=()):
    yield path, node
    for key in ("properties", "patternProperties"):
        for name, child in node.get(key, {}).items():
            yield from _nodes(child, (*path, name))
    if isinstance(node.get("items"), dict):
        yield from _nodes(node["items"], (*path, "items"))


def test_every_schema_entry_holds_only_schema_keywords():
    # an unquoted comma in a YAML flow mapping ({..., description: a, b}) makes a stray key of "b"
    stray = {".".join(path): sorted(set(node) - KEYWORDS) for path, node in _nodes(config.schema())}
    assert {path: keys for path, keys in stray.items() if keys} == {}


def _as_in(default, value):
    """``value`` as the schema writes it: lists for tuples, and of a nested mapping the keys the schema names."""
    if isinstance(default, dict):
        return {key: _as_in(default[key], value[key]) for key in default}
    return list(value) if isinstance(value, tuple) else value


@pytest.mark.parametrize(
    "made, section",
    [(Settings(), "diagnosis"), (EnrichmentSettings(), "enrichment"), (DemoPlant(), "demo")],
    ids=["diagnosis", "enrichment", "demo"],
)
def test_settings_objects_take_their_defaults_from_the_schema(made, section):
    defaults = config.section_defaults(section)
    defaults.pop("n_figures", None)  # the diagnosis' figures, drawn by the rule, not the diagnosis' own setting
    assert {key: _as_in(default, asdict(made)[key]) for key, default in defaults.items()} == defaults


def test_a_changed_schema_default_reaches_the_settings(monkeypatch):
    schema = config.schema()
    schema["properties"]["diagnosis"]["properties"]["alpha"]["default"] = 0.02
    monkeypatch.setattr(config, "_schema", lambda: schema)
    assert config.section_defaults("diagnosis")["alpha"] == 0.02


def test_a_plants_config_without_results_dir_writes_under_its_own_name(tmp_path):
    workflow_config, plant, named = tmp_path / "config.yaml", tmp_path / "press4.yaml", tmp_path / "named.yaml"
    workflow_config.write_text("seed: 1\n")
    plant.write_text("seed: 2\n")
    named.write_text("results_dir: runs/p4\n")

    def results_dir(files, command_line=None):
        settings = {}
        config.plant_results_dir(settings, files, command_line, workflow_config)
        return settings.get("results_dir")

    assert results_dir([plant]) == "results/press4"  # never into the demo's results/
    assert results_dir([plant, named]) is None  # the plant names its own (kept as it is)
    assert results_dir([plant], {"results_dir": "x"}) is None  # --config results_dir=x
    assert results_dir([workflow_config]) is None and results_dir([]) is None  # the demo's own run
