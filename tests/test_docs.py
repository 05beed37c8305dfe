"""The documentation as a reader meets it: README is a front page, user pages carry no development history,
relative links lead somewhere, and the generated reference pages are what their generators print."""

import re
import sys
from pathlib import Path

import pytest

from .conftest import ROOT

sys.path.insert(0, str(Path(ROOT, "docs")))
import gen_reference  # noqa: E402

README = Path(ROOT, "README.md")
# the pages a user reads; benchmarks.md, development.md and CHANGELOG.md carry commits by design
USER_PAGES = [README] + [
    Path(ROOT, "docs", name)
    for name in (
        "index.md",
        "getting-started.md",
        "your-data.md",
        "whatif.md",
        "monitor.md",
        "glossary.md",
        "method.md",
        "plant-scale.md",
        "cluster.md",
        "configuration.md",
        "outputs.md",
    )
]
# a commit hash: 7 to 40 hex digits with at least one letter and one digit
COMMIT = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b")
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)\s]*)?\)")


def test_readme_is_a_front_page_of_at_most_150_lines():
    assert len(README.read_text().splitlines()) <= 150


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: p.name)
def test_a_user_page_names_no_commit(page):
    assert COMMIT.findall(page.read_text()) == []


def test_the_commit_pattern_finds_a_hash_and_leaves_numbers_and_words():
    assert COMMIT.findall("on commit e8cc452, 77.4 s, 2026-11-25, seed 1234567, the word facade") == ["e8cc452"]


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: p.name)
def test_every_relative_link_of_a_user_page_leads_to_a_file(page):
    targets = [target for target in LINK.findall(page.read_text()) if "://" not in target]
    missing = [target for target in targets if not (page.parent / target).exists()]
    assert missing == []


def test_the_configuration_page_is_the_schema_s():
    page = Path(ROOT, "docs", "configuration.md").read_text()
    assert page == gen_reference.text() + "\n", "stale: python docs/gen_reference.py > docs/configuration.md"
