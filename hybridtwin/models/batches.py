"""Prediction in batches of rows, and threads over stretches of batches: what the peers' predictions share."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from hybridtwin.io.files import row_slices

# rows predicted at a time: the cross-covariances with the training rows (and SMT's per-input differences,
# rows x training rows x inputs) stay in cache; co-kriging predicts 30% faster than with 500 rows at a time
BATCH_ROWS = 100


def batched(predict, X: np.ndarray) -> np.ndarray:
    return (
        np.concatenate([np.ravel(predict(X[start : start + BATCH_ROWS])) for start in range(0, len(X), BATCH_ROWS)])
        if len(X)
        else np.empty(0)
    )


def by_parts(predict, frame: pd.DataFrame, columns) -> np.ndarray:
    """``predict`` of the matrix of ``frame``'s ``columns``, a piece of rows at a time (:func:`files.row_slices`):
    a row's prediction does not depend on the others, and the matrix of a ten-million-part log (0.9 GB beside its
    table) is never whole."""
    columns = list(columns)
    return (
        np.concatenate(
            [np.ravel(predict(frame.iloc[rows][columns].to_numpy(float))) for rows in row_slices(len(frame))]
        )
        if len(frame)
        else np.empty(0)
    )


def available_cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def chunks(n_rows: int, n_jobs: int) -> list[slice]:
    """At most ``n_jobs`` stretches of whole batches: each row is predicted in the same batch as in one
    stretch, so the answer does not depend on the number of threads."""
    if n_rows == 0:
        return []
    batches = -(-n_rows // BATCH_ROWS)
    per_chunk = -(-batches // max(1, min(n_jobs, batches))) * BATCH_ROWS
    return [slice(start, min(start + per_chunk, n_rows)) for start in range(0, n_rows, per_chunk)]
