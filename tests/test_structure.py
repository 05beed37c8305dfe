"""The house's structure, checked on the package: short functions, small modules, model names in one place, and
no results folder written into the code (a plant's run names its own, config results_dir)."""

import ast
import re
from pathlib import Path

import pytest

from hybridtwin.models import registry

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = sorted((ROOT / "hybridtwin").rglob("*.py"))
MAX_FUNCTION_LINES = 60
MAX_MODULE_LINES = 500


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text())


def _docstrings(tree: ast.Module) -> set[int]:
    """The ids of the docstring constants: words about the code, not the code."""
    nodes = [tree, *(n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)))]
    return {id(node.body[0].value) for node in nodes if node.body and isinstance(node.body[0], ast.Expr)}


def _config_keys(tree: ast.Module) -> set[int]:
    """The ids of the constants that index a config (``config["surrogate"]``: a section, not a model)."""
    return {
        id(node.slice)
        for node in ast.walk(tree)
        if isinstance(node, ast.Subscript)
        and (getattr(node.value, "id", None) == "config" or getattr(node.value, "attr", None) == "config")
    }


def _strings(path: Path) -> list[str]:
    tree = _tree(path)
    skip = _docstrings(tree) | _config_keys(tree)
    return [
        n.value
        for n in ast.walk(tree)
        if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in skip
    ]


@pytest.mark.parametrize("path", PACKAGE, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_function_is_longer_than_60_lines_and_no_module_than_500(path):
    long = [
        f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
        for node in ast.walk(_tree(path))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert not long, f"{path.name}: {long}"
    assert len(path.read_text().splitlines()) <= MAX_MODULE_LINES


def test_model_names_are_spelled_in_the_registry_alone():
    names = {model.name for model in registry.MODELS} | {registry.RECOMMENDED}
    spelled = names | {f"pred_{name}" for name in names} | {f"pred_{name}_oof" for name in names}
    sources = [*PACKAGE, *(ROOT / "scripts").glob("*.py")]
    found = {
        str(path.relative_to(ROOT)): sorted(set(_strings(path)) & spelled)
        for path in sources
        if set(_strings(path)) & spelled
    }
    # the workflow's rule files are Snakemake, not Python: their quoted words, but for config sections
    for path in [ROOT / "Snakefile", *(ROOT / "workflow" / "rules").glob("*.smk")]:
        words = set(re.findall(r'(?<!config\[)["\']([a-z_]+)["\']', path.read_text())) & spelled
        if words:
            found[str(path.relative_to(ROOT))] = sorted(words)
    assert set(found) <= {"hybridtwin/models/registry.py"}, found


@pytest.mark.parametrize("path", PACKAGE, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_results_folder_is_written_into_the_package(path):
    assert not [text for text in _strings(path) if re.search(r"(^|/)results(/|$)", text)]
