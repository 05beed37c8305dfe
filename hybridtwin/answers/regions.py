"""Regions of the input space: in support, and out of support in bins of the kNN distance to the DoE.

Errors grow away from the DoE, so one interval width for every row would be too wide inside the support
and too narrow far outside it. A row inside the gate but beyond the DoE's range in some input takes the
support's model (the models learnt from such parts) and an interval calibrated out of support, nearest bin
(no simulation backs its setting): :class:`Regions`. Calibration and test rows are alternating blocks of
consecutive production rows (a plant's log is in time order), so a test row's neighbours in time are not in
the calibration set.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

IN_SUPPORT = "in_support"
BEYOND_RANGE = "beyond_doe_range"
MIN_CALIBRATION_ROWS = 100


def out_of_support_region(index: int) -> str:
    return f"out_of_support_{index}"


def is_outside(name: str) -> bool:
    """Whether an interval region is one out of the support (a distance bin, or the gate's parts beyond a DoE
    range); the in-support region and one pooled calibration ('all') are not."""
    return name == BEYOND_RANGE or name.startswith(out_of_support_region(""))


def outside_range(frame: pd.DataFrame, doe_range: dict[str, tuple[float, float]]) -> pd.DataFrame:
    """How far each row lies beyond the DoE's range (``doe_range``: each input's DoE minimum and maximum), per
    input, in the input's own unit (0 inside; 0 for a missing value)."""
    beyond = {}
    for name, (low, high) in doe_range.items():
        values = frame[name].to_numpy(float)
        amounts = values - np.clip(values, low, high)
        beyond[name] = np.where(np.isnan(amounts), 0.0, amounts)
    return pd.DataFrame(beyond, index=frame.index)


def outside_range_by_parts(frame: pd.DataFrame, doe_range: dict[str, tuple[float, float]]):
    """:func:`outside_range` of a piece of rows at a time (:func:`files.row_slices`): (the rows' slice, their
    distances)."""
    from hybridtwin.io.files import row_slices

    for rows in row_slices(len(frame)):
        yield rows, outside_range(frame.iloc[rows], doe_range)


def describe_outside(beyond: pd.DataFrame, doe_range: dict[str, tuple[float, float]]) -> list[str]:
    """Per row, e.g. 'die_temp_c 4.2 above the DoE's max 55' ('' when every input is in range)."""
    values = beyond.to_numpy(float)
    texts = np.full(len(values), "", dtype=object)
    for j, name in enumerate(beyond.columns):
        rows = np.flatnonzero(values[:, j] != 0)
        low, high = doe_range[name]
        for side, mask, bound in (
            (" above the DoE's max ", values[rows, j] > 0, high),
            (" below the DoE's min ", values[rows, j] < 0, low),
        ):
            at = rows[mask]
            amounts = np.array([f"{abs(v):.4g}" for v in values[at, j]], dtype=object)
            separator = np.where(texts[at] != "", "; ", "").astype(object)
            texts[at] = texts[at] + separator + f"{name} " + amounts + f"{side}{bound:.6g}"
    return texts.tolist()


def distance_edges(distance_out: np.ndarray, n_bins: int, min_rows: int = MIN_CALIBRATION_ROWS) -> list[float]:
    """Inner edges of equal-count distance bins over the out-of-support calibration rows.

    Fewer bins (merged) when there are too few rows for each to hold ``min_rows``: enough for the level asked
    (:func:`intervals.min_calibration_rows`), and never fewer than ``MIN_CALIBRATION_ROWS``.
    """
    n_bins = max(1, min(n_bins, len(distance_out) // max(min_rows, MIN_CALIBRATION_ROWS)))
    if n_bins == 1:
        return []
    edges = np.quantile(np.asarray(distance_out, float), np.arange(1, n_bins) / n_bins)
    return [float(edge) for edge in np.unique(edges)]


def same_word(n_rows: int, word: str) -> np.ndarray:
    """An object array of ``n_rows`` rows that all hold the one ``word``: numpy's ``full`` makes a Python string
    per row (0.6 GB on a ten-million-part log)."""
    labels = np.empty(n_rows, dtype=object)
    labels[:] = word
    return labels


def regions(in_support, beyond_range, distance, edges, beyond_region: bool = False) -> np.ndarray:
    """Region label per row: 'in_support', 'out_of_support_<bin>' (bins of the distance to the DoE, from 1, nearest
    first), and for a row inside the gate but beyond a DoE range 'beyond_doe_range' (with ``beyond_region``: enough
    such parts calibrated an interval of their own) or else the nearest bin's."""
    inside = np.asarray(in_support, bool)
    beyond = inside & np.asarray(beyond_range, bool)
    bins = np.searchsorted(np.asarray(edges, float), np.asarray(distance, float), side="right")
    names = np.array([out_of_support_region(b) for b in range(1, len(edges) + 2)], dtype=object)
    labels = names[bins]
    labels[inside & ~beyond] = IN_SUPPORT
    labels[beyond] = BEYOND_RANGE if beyond_region else out_of_support_region(1)
    return labels


@dataclass(frozen=True)
class Regions:
    """Two region labels per row: where its model is chosen, and where its interval is calibrated.

    They differ only for a row inside the gate but beyond the DoE's range in some input. Its model is
    chosen among the in-support ranking, because every model saw such parts in training (the row's
    honest errors are out-of-fold ones, like those of the rest of the support); its interval is
    calibrated out of support, because no simulation backs the setting.
    """

    choice: np.ndarray
    interval: np.ndarray

    @classmethod
    def of(cls, in_support, beyond_range, distance, edges, beyond_region: bool = False) -> "Regions":
        return cls(
            regions(in_support, np.zeros(len(distance), bool), distance, edges),
            regions(in_support, beyond_range, distance, edges, beyond_region),
        )

    @classmethod
    def same(cls, labels) -> "Regions":
        """One labelling for both (no row beyond the DoE's range, or a single pooled region)."""
        labels = np.asarray(labels, object)
        return cls(labels, labels)

    def __getitem__(self, rows) -> "Regions":
        return Regions(self.choice[rows], self.interval[rows])


def as_regions(region) -> Regions:
    return region if isinstance(region, Regions) else Regions.same(region)


def calibration_rows(n_rows: int, n_blocks: int) -> np.ndarray:
    """True for calibration rows: the even ones of ``n_blocks`` blocks of consecutive rows."""
    block = np.arange(n_rows) * n_blocks // max(n_rows, 1)
    return block % 2 == 0


def region_label(name: str, edges: list[float], threshold: float) -> str:
    if name == IN_SUPPORT:
        return "in support"
    if name == BEYOND_RANGE:
        return f"inside the gate (distance up to {threshold:.3g}), beyond a DoE range"
    index = int(name.rsplit("_", 1)[1])
    low = edges[index - 2] if index >= 2 else None
    high = edges[index - 1] if index - 1 < len(edges) else None
    if low is None and high is None:
        return "out of support (every distance)"
    if low is None:
        return f"out of support, distance up to {high:.3g} (threshold {threshold:.3g})"
    if high is None:
        return f"out of support, distance above {low:.3g}"
    return f"out of support, distance {low:.3g} to {high:.3g}"
