"""Bad input, and the hint a missing file gets: light (standard library only), so that the Snakefile's
config check (:mod:`hybridtwin.config`) needs nothing that Snakemake's own environment lacks."""

from __future__ import annotations

import difflib
from pathlib import Path


class InputError(ValueError):
    """Bad input data or configuration; the message says where and what."""


def other_csvs(path: Path) -> str:
    """For a missing file: the CSV files that are in its folder, and the closest name."""
    folder = path.parent
    if not folder.is_dir():
        return f"; the folder {str(folder)!r} does not exist either"
    names = sorted(p.name for p in folder.iterdir() if p.suffix.lower() == ".csv" and p.is_file())
    if not names:
        return f"; there is no CSV file in {str(folder)!r}"
    shown = ", ".join(map(repr, names[:20])) + (f", … ({len(names)} in all)" if len(names) > 20 else "")
    close = difflib.get_close_matches(path.name, names, n=1, cutoff=0.6)
    return f"; CSV files in {str(folder)!r}: {shown}" + (f" — did you mean {close[0]!r}?" if close else "")
