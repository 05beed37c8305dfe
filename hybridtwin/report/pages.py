"""The report's pages: each table and the diagnosis in words as a small HTML page.

Snakemake's HTML report shows images and HTML inside the page and offers any other file (CSV,
Markdown) only for download, so the tables reach the report as these pages. Every value a user
brought (column names, ids, units) is escaped.
"""

from __future__ import annotations

import html

import numpy as np
import pandas as pd

# identifier words, as a reader writes them
WORDS = {
    "rmse": "RMSE",
    "mae": "MAE",
    "r2": "R²",
    "cv": "CV",
    "knn": "kNN",
    "doe": "DoE",
    "oof": "out-of-fold",
    "pred": "predicted",
    "n": "n",
    "std": "std",
    "p": "p",
}
# columns in the target's unit carry it in their header
IN_TARGET_UNIT = ("rmse", "mae", "width", "offset", "effect")

STYLE = """
body { font-family: sans-serif; font-size: 14px; margin: 1em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0; }
th, td { border: 1px solid #ccc; padding: 3px 8px; }
th { background: #f0f0f0; text-align: left; }
td { text-align: right; }
td:first-child { text-align: left; }
p.source { color: #666; font-size: 12px; }
p.note { color: #444; font-size: 13px; max-width: 60em; }
tbody th { text-align: left; font-weight: normal; background: #f7f7f7; }
"""


def header(name, unit: str, verbatim=()) -> str:
    """'rmse_truth_out_of_support' -> 'RMSE truth out of support [mm]'; the user's own column names
    (``verbatim``: inputs, target) are left as they are, units and all."""
    if name in verbatim:
        return str(name)
    words = str(name).split("_")
    text = " ".join(WORDS.get(word, word) for word in words)
    if words[0] not in WORDS:
        text = text[:1].upper() + text[1:]
    if any(word in IN_TARGET_UNIT for word in str(name).lower().split("_")):
        text += f" [{unit}]"
    return text


def cell(value) -> str:
    """A number as a reader reads it: thousands separated, four significant digits below that."""
    if isinstance(value, (bool, np.bool_)):
        return str(value)
    if isinstance(value, (int, np.integer)):
        return f"{value:,}"
    if isinstance(value, (float, np.floating)):
        if np.isnan(value):
            return "–"
        return f"{value:,.0f}" if abs(value) >= 1000 else f"{value:.4g}"
    return "–" if value is None else str(value)


def page(title: str, body: str) -> str:
    return (
        '<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head>\n"
        f"<body><h2>{html.escape(title)}</h2>\n{body}\n</body></html>\n"
    )


# a table wider than this many columns is transposed (few rows) or split into column groups (many rows)
MAX_COLUMNS = 8
MAX_TRANSPOSED_ROWS = 12


def table_page(frame: pd.DataFrame, title: str, source: str, unit: str, verbatim=()) -> str:
    """One table with human headers (the user's own column names kept), fitting a laptop's screen: a note that
    is the same on every row (what the table was computed on) said once above it, a wide table transposed or
    split; the CSV it shows is named under it."""
    notes, frame = _constant_notes(frame)
    shown = frame.rename(columns=lambda name: header(name, unit, verbatim))
    shown = shown.map(cell) if len(shown) else shown
    tables = [part.to_html(index=index, escape=True, border=0, na_rep="–") for part, index in _fitting(shown)]
    said = "".join(f'<p class="note">{html.escape(note)}</p>\n' for note in notes)
    return page(title, f'{said}{"<br>".join(tables)}\n<p class="source">Data: <code>{html.escape(source)}</code></p>')


def _constant_notes(frame: pd.DataFrame) -> tuple[list[str], pd.DataFrame]:
    """Long text columns with one value on every row, as sentences ('Evaluated on: ...'), and the rest."""
    constant = [
        column
        for column in frame.columns
        if len(frame) > 1
        and not pd.api.types.is_numeric_dtype(frame[column])
        and frame[column].nunique(dropna=False) == 1
        and len(str(frame[column].iloc[0])) > 40
    ]
    notes = [f"{header(column, '')}: {frame[column].iloc[0]}" for column in constant]
    return notes, frame.drop(columns=constant)


def _fitting(shown: pd.DataFrame) -> list[tuple[pd.DataFrame, bool]]:
    """The table as parts a laptop's screen shows whole: itself; transposed (a row per column) when it has few
    rows; or groups of columns, each with the first column again."""
    if shown.shape[1] <= MAX_COLUMNS:
        return [(shown, False)]
    if len(shown) <= MAX_TRANSPOSED_ROWS:
        transposed = shown.set_index(shown.columns[0]).T
        transposed.columns = [str(c) for c in transposed.columns]
        return [(transposed, True)]
    first, rest = shown.columns[0], list(shown.columns[1:])
    step = MAX_COLUMNS - 1
    return [(shown[[first, *rest[start : start + step]]], False) for start in range(0, len(rest), step)]


def markdown_page(markdown_text: str, title: str, source: str) -> str:
    """The diagnosis in words (its user-supplied names are escaped when the Markdown is written)."""
    import markdown

    body = markdown.markdown(markdown_text, extensions=["tables"])
    return page(title, f'{body}\n<p class="source">Data: <code>{html.escape(source)}</code></p>')
