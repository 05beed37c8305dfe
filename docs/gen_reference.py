"""Write the configuration reference (configuration.md) from the package's config schema.

    python docs/gen_reference.py > docs/configuration.md

A fast test fails when the committed page differs from what this prints, so the page cannot drift from the
schema: every key, type, default and range comes from `hybridtwin/**/config.schema.yaml`.
Only a key the schema gives no description gets one from FALLBACK below: the schema's own text
always wins. FALLBACK entries the page no longer uses are printed as warnings on stderr, to be
removed; a key missing from the schema never appears, whatever FALLBACK holds.
"""

from __future__ import annotations

import html
import logging
from pathlib import Path

import yaml

log = logging.getLogger("gen_reference")
ROOT = Path(__file__).resolve().parent.parent
PAGE = "configuration.md"

# what a section is for, in plant words (the schema has no text for its sections)
SECTIONS = {
    "": "Keys at the top of the config file.",
    "data": "Where your three files are. Paths are relative to the folder you run from.",
    "columns": "Which columns of your files the models use. "
    "Every other column of the production log is kept and becomes a candidate cause.",
    "csv": "How your CSV files are written. The same settings are used to write what-if answers.",
    "demo": "The built-in demo plant. Used only when `data:` points at `<results_dir>/demo/*.csv`.",
    "gate": "The [support gate](glossary.md#knn-gate): which parts count as inside the simulated region.",
    "surrogate": "The [surrogate](glossary.md#surrogate) of the simulator.",
    "cv": "[Cross-validation](glossary.md#cross-validation).",
    "residual_model": "The [residual model](glossary.md#residual-model).",
    "tuning": "The search for the residual model's settings (Optuna).",
    "synthetic": "Synthetic corrected data (the paper's last step).",
    "peers": "The two [peers](glossary.md#peer) the recommended model is compared with.",
    "enrichment": "The [proposals](glossary.md#proposals-enrichment) for the next simulations.",
    "intervals": "[Prediction intervals](glossary.md#conformal-interval) and the "
    "[recommended model](glossary.md#recommended-model).",
    "units": "Units used in tables, figures and the report. Nothing is converted: they are labels.",
    "diagnosis": "The [diagnosis](method.md#what-the-simulation-gets-wrong-the-diagnosis) of what the "
    "simulation gets wrong.",
}

# descriptions for keys the schema does not describe (yet); the schema's own text always wins
FALLBACK = {
    "columns.inputs": "the process and material inputs, present in all three files with the same names and units",
    "columns.target": "the target column: simulated in the DoE file, measured in the production log",
    "columns.matched_simulated": "the simulated target column of the matched-cases file",
    "columns.matched_measured": "the measured target column of the matched-cases file",
    "csv.sep": "column separator of every CSV file (`;` for a European Excel export)",
    "csv.decimal": "decimal mark (`,` for a European Excel export)",
    "demo.seed": "seed of the demo plant",
    "demo.n_doe": "simulations in the demo DoE (Latin hypercube)",
    "demo.n_production": "parts in the demo production log",
    "demo.n_matched": "matched cases of the demo",
    "demo.noise_mm": "measurement noise of the demo plant [mm]",
    "demo.fe_scatter_mm": "numerical scatter of the demo simulations [mm]",
    "demo.offset_mm": "constant offset of the demo plant over its simulator [mm]",
    "demo.hidden_effect": "the effect the demo simulator lacks, for the diagnosis to find",
    "demo.hidden_effect.form": "shape of the hidden effect",
    "demo.hidden_effect.column": "column the hidden effect acts on",
    "demo.hidden_effect.column_b": "second column of a `product` effect",
    "demo.hidden_effect.amplitude": "size of the effect [mm]",
    "demo.hidden_effect.threshold": "where a `sigmoid` or `step` effect sits, in the column's unit",
    "demo.hidden_effect.width": "width of a `sigmoid` effect, in the column's unit",
    "cv.folds": "folds of every K-fold cross-validation (surrogate, residual model, out-of-fold predictions)",
    "tuning.n_trials": "finished trials (complete or stopped early) the study runs",
    "tuning.search_space.<parameter>.low": "lowest value searched",
    "tuning.search_space.<parameter>.high": "highest value searched",
    "tuning.search_space.<parameter>.type": "integer or real values",
    "tuning.search_space.<parameter>.log": "search on a log scale",
}


def find_schema(root: Path = ROOT) -> Path:
    """The first `hybridtwin/**/config.schema.yaml` under the repository root (the package may move)."""
    found = sorted(root.glob("hybridtwin/**/config.schema.yaml"))
    if not found:
        raise SystemExit(f"no hybridtwin/**/config.schema.yaml under {root}")
    return found[0]


def cell(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return text.replace("|", "&#124;").replace("\n", " ")


def code(value) -> str:
    """A YAML value as inline code, safe in a table cell."""
    shown = yaml.safe_dump(value, default_flow_style=True, allow_unicode=True, sort_keys=False).strip()
    shown = shown.removesuffix("...").strip()
    return f"<code>{cell(html.escape(shown))}</code>"


def type_of(spec: dict) -> str:
    kinds = spec.get("type", "")
    kinds = kinds if isinstance(kinds, list) else [kinds]
    words = []
    for kind in kinds:
        if kind == "array":
            item = spec.get("items", {}).get("type", "value")
            words.append(f"list of {item}s")
        elif kind == "object" and "additionalProperties" in spec and isinstance(spec["additionalProperties"], dict):
            value = spec["additionalProperties"].get("type", "value")
            words.append(f"map of name → {value}")
        elif kind:
            words.append(kind)
    return " or ".join(words) or "—"


def allowed(spec: dict) -> str:
    parts = []
    if "enum" in spec:
        parts.append("one of " + ", ".join(code(value) for value in spec["enum"]))
    bounds = (
        ("minimum", "≥"),
        ("exclusiveMinimum", ">"),
        ("maximum", "≤"),
        ("exclusiveMaximum", "<"),
    )
    for key, sign in bounds:
        if key in spec:
            parts.append(f"{sign} {spec[key]}")
    if spec.get("minLength"):
        parts.append("not empty")
    if spec.get("minItems"):
        parts.append(f"at least {spec['minItems']} item{'s' if spec['minItems'] > 1 else ''}")
    if spec.get("uniqueItems"):
        parts.append("no repeats")
    if spec.get("pattern") == "\\S" or spec.get("items", {}).get("pattern") == "\\S":
        parts.append("not blank")
    return ", ".join(parts) or "—"


def default_of(key: str, spec: dict, required: bool) -> str:
    if required:
        return "**required**"
    if "default" not in spec:
        return "—"
    value = spec["default"]
    if value is None:
        return "<code>null</code> (none)"
    if value == {} and spec.get("type") == "object":
        return "—"
    return code(value)


# JSON Schema words the schema uses; any other key with no value is a piece of a description that an
# unquoted comma cut off in YAML's {...} form (`description: a, b` reads as `description: a` and a key `b`)
KEYWORDS = set(
    "type default description enum minimum maximum exclusiveMinimum exclusiveMaximum minLength minItems "
    "uniqueItems pattern items properties patternProperties additionalProperties required".split()
)


def description(key: str, spec: dict, used: set[str]) -> str:
    text = spec.get("description")
    cut = [name for name, value in spec.items() if name not in KEYWORDS and value is None]
    if text and cut:
        log.warning("gen_reference: %s: description cut at a comma in the schema (quote it there); rejoined", key)
        text = ", ".join([text, *map(str, cut)])
    if text:
        return cell(html.escape(text, quote=False))
    if key in FALLBACK:
        used.add(key)
        return cell(FALLBACK[key])
    return ""


def rows(prefix: str, spec: dict, used: set[str], required=()) -> list[tuple[str, ...]]:
    """(key, type, default, allowed, description) for each key under `spec`, nested keys flattened."""
    out = []
    for name, child in spec.get("properties", {}).items():
        key = f"{prefix}.{name}" if prefix else name
        out.append(
            (
                f"`{key}`",
                type_of(child),
                default_of(key, child, name in required),
                allowed(child),
                description(key, child, used),
            )
        )
        if "properties" in child or "patternProperties" in child:
            out.extend(rows(key, child, used, child.get("required", ())))
    for pattern, child in spec.get("patternProperties", {}).items():
        names = pattern.strip("^$()").split("|")
        key = f"{prefix}.<parameter>"
        out.append(
            (
                f"`{key}`",
                type_of(child),
                "—",
                "`<parameter>` one of " + ", ".join(f"`{name}`" for name in names),
                "a range to search instead of the default one",
            )
        )
        out.extend(rows(key, child, used, child.get("required", ())))
    return out


def table(section_rows: list[tuple[str, ...]]) -> list[str]:
    lines = ["| key | type | default | allowed | what it does |", "|---|---|---|---|---|"]
    lines += ["| " + " | ".join(row) + " |" for row in section_rows]
    return lines


def page(schema: dict, source: Path) -> str:
    used: set[str] = set()
    relative = source.relative_to(ROOT).as_posix()
    lines = [
        "# Configuration reference",
        "",
        f"<!-- generated by docs/gen_reference.py from {relative}: edit the schema, not this page -->",
        "",
        f"Every key the workflow reads, made from the schema file `{relative}` (a test keeps them equal).",
        "The workflow checks your config against the same file before anything runs. A wrong value stops",
        "the run with one line that names the key, the value and the rule, for example",
        "`config error: tuning.n_trials = 0, must be at least 1`.",
        "",
        "Only `data` and `columns` must be set. Set `results_dir` too, one per plant or panel, so that runs",
        "do not overwrite each other; a config file without it writes under `results/<the file's name>/`",
        "(`my_plant.yaml`: `results/my_plant/`). Everything else has a default. See [Your data](your-data.md)",
        "for an example file.",
        "",
    ]
    top = {name: spec for name, spec in schema["properties"].items() if "properties" not in spec}
    required = set(schema.get("required", ()))
    lines += ["## Top-level keys", "", SECTIONS[""], ""]
    lines += table(rows("", {"properties": top}, used, required))
    lines.append("")
    for name, spec in schema["properties"].items():
        if name in top:
            continue
        lines += [f"## `{name}`", "", SECTIONS.get(name, ""), ""]
        if name in required:
            lines += ["This section is required.", ""]
        lines += table(rows(name, spec, used, spec.get("required", ())))
        lines.append("")
    for key in sorted(set(FALLBACK) - used):
        log.warning("gen_reference: FALLBACK[%r] is not used (the schema describes it, or has no such key)", key)
    for name in SECTIONS:
        if name and name not in schema["properties"]:
            log.warning("gen_reference: SECTIONS[%r]: the schema has no such section", name)
    return "\n".join(lines)


def text() -> str:
    """The page, from the package's schema."""
    source = find_schema()
    return page(yaml.safe_load(source.read_text(encoding="utf-8")), source)


if __name__ == "__main__":
    print(text())
