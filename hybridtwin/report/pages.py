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


def table_page(frame: pd.DataFrame, title: str, source: str, unit: str, verbatim=()) -> str:
    """One table with human headers (the user's own column names kept); the CSV it shows is named under it."""
    shown = frame.rename(columns=lambda name: header(name, unit, verbatim))
    shown = shown.map(cell) if len(shown) else shown
    table = shown.to_html(index=False, escape=True, border=0, na_rep="–")
    return page(title, f'{table}\n<p class="source">Data: <code>{html.escape(source)}</code></p>')


def markdown_page(markdown_text: str, title: str, source: str) -> str:
    """The diagnosis in words (its user-supplied names are escaped when the Markdown is written)."""
    import markdown

    body = markdown.markdown(markdown_text, extensions=["tables"])
    return page(title, f'{body}\n<p class="source">Data: <code>{html.escape(source)}</code></p>')
