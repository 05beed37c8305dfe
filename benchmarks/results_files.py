"""A benchmark's results: its table as CSV and its summary as Markdown under the command that made them."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd


def write_results(folder: Path, stem: str, title: str, table: pd.DataFrame, summary: str) -> str:
    """``folder/stem.csv`` (a row per plant) and ``folder/stem.md`` (title, command, summary); returns the text."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    table.to_csv(folder / f"{stem}.csv", index=False)
    text = f"# {title}\n\n`{' '.join(sys.argv)}`\n\n{summary}\n"
    (folder / f"{stem}.md").write_text(text)
    return text
