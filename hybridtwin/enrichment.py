"""The next simulations to run: DoE points that bring the most production parts into the support.

Greedy, one point at a time. Candidates are the k-means centres of the out-of-support parts in
DoE-standardized space (weighted, recent parts more), kept inside the physical limits: the union of
the DoE's and the production's ranges, widened by ``margin`` of that span, never beyond. Each step
takes the candidate that brings the most (weighted) parts into the support of today's gate held (its
standardization and threshold; a part's mean distance to its k nearest DoE points, the points added
so far among them); ties go to the candidate that shortens the parts' distances to the support most,
weighted up where the surrogate is least sure (a point there also teaches the surrogate most). Then
the gate is rebuilt as the workflow would rebuild it on the enlarged DoE (standardization and
threshold refitted), and the parts it brings in, and the share in support, are counted with that
gate; the share under today's gate held is reported beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.spatial.distance import cdist
from sklearn.cluster import KMeans

from hybridtwin.crossval import training_subset
from hybridtwin.diagnosis.causes import parse_timestamps
from hybridtwin.io.config import section_defaults
from hybridtwin.paper.gate import KNNSupportGate

DEFAULTS = section_defaults("enrichment")


@dataclass(frozen=True)
class EnrichmentSettings:
    """The config's ``enrichment:`` (its schema's descriptions say what each is), and the run's seed."""

    n_points: int = DEFAULTS["n_points"]
    recency_weight: float = DEFAULTS["recency_weight"]
    margin: float = DEFAULTS["margin"]
    n_candidates: int = DEFAULTS["n_candidates"]
    seed: int = 0
    max_rows: int | None = DEFAULTS["max_rows"]  # None: every part

    @classmethod
    def from_config(cls, settings: dict, seed: int) -> "EnrichmentSettings":
        return cls(**settings, seed=seed)


def recency_weights(n_rows: int, recency_weight: float) -> np.ndarray:
    """Linear in the row's place in the log (rows in time order): 1 for the oldest, 1 + w for the newest."""
    return 1.0 + recency_weight * np.arange(n_rows) / max(n_rows - 1, 1)


def physical_limits(doe: np.ndarray, production: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    low = np.minimum(doe.min(axis=0), production.min(axis=0))
    high = np.maximum(doe.max(axis=0), production.max(axis=0))
    span = high - low
    return low - margin * span, high + margin * span


def _nearest(reference: np.ndarray, points: np.ndarray, k: int) -> np.ndarray:
    """Each point's k smallest distances to the reference rows, sorted."""
    from hybridtwin.paper.gate import nearest_index

    distances, _ = nearest_index(reference, k).kneighbors(points)
    return distances


def _gain(nearest: np.ndarray, candidate_distance: np.ndarray, threshold: float, weights: np.ndarray):
    """Weighted parts each candidate brings under the threshold, and the weighted distance it removes.

    ``nearest``: (parts, k) current nearest distances; ``candidate_distance``: (parts, candidates), overwritten.
    """
    k = nearest.shape[1]
    current = nearest.mean(axis=1)[:, None]
    # with the candidate among the reference points the k nearest lose their farthest one if it is nearer; each
    # (parts x candidates) array made in place of ``candidate_distance``, which is the caller's to give up
    new = np.add(candidate_distance, nearest.sum(axis=1)[:, None] - nearest[:, -1:], out=candidate_distance)
    new = np.minimum(current, np.divide(new, k, out=new), out=new)
    brought = (((new <= threshold) & (current > threshold)) * weights[:, None]).sum(axis=0)
    shortened = np.multiply(np.subtract(current, new, out=new), weights[:, None], out=new)
    return brought, shortened.sum(axis=0)


GAIN_ROWS = 100_000  # parts per chunk: the (parts x candidates) arrays stay near 0.4 GB at any plant size


def _chunked_gain(z_out, nearest, z_candidates, threshold: float, weights):
    """``_gain`` summed over chunks of parts (a single chunk up to GAIN_ROWS parts)."""
    count, shortened = np.zeros(len(z_candidates)), np.zeros(len(z_candidates))
    for start in range(0, len(z_out), GAIN_ROWS):
        rows = slice(start, start + GAIN_ROWS)
        part = _gain(nearest[rows], cdist(z_out[rows], z_candidates), threshold, weights[rows])
        count, shortened = count + part[0], shortened + part[1]
    return count, shortened


@dataclass
class Proposal:
    points: np.ndarray  # (n, inputs) in the DoE's units
    brought_in: list[np.ndarray]  # per point, the production rows it brings into the support
    share_after: list[float]  # share of production in support after points 1..j
    share_before: float
    surrogate_std: np.ndarray
    share_after_fixed_threshold: list[float]  # the same with today's threshold held
    n_counted: int  # the parts counted (a seeded sample of n_production on a larger log)
    n_production: int

    @property
    def parts_per_counted_part(self) -> float:
        return self.n_production / self.n_counted if self.n_counted else 1.0


def propose(
    doe: np.ndarray, production: np.ndarray, k: int, percentile: float, settings: EnrichmentSettings, surrogate_std=None
) -> Proposal:
    """``surrogate_std(points) -> std`` (optional) ranks candidates that tie on the parts they bring in."""
    doe, production = np.asarray(doe, float), np.asarray(production, float)
    weights = recency_weights(len(production), settings.recency_weight)
    low, high = physical_limits(doe, production, settings.margin)
    # on a long log, a seeded sample of parts (in time order, each with its recency weight) stands for it
    counted = training_subset(len(production), settings.max_rows or len(production), settings.seed)
    n_production, production, weights = len(production), production[counted], weights[counted]
    gate = KNNSupportGate(k=k, percentile=percentile).fit(doe)
    inside = gate.predict(production)
    share_before = float(inside.mean())
    points, brought, shares, stds, held_shares = [], [], [], [], []
    if inside.all() or settings.n_points == 0:
        return Proposal(np.empty((0, doe.shape[1])), [], [], share_before, np.empty(0), [], len(counted), n_production)
    outside = ~inside
    # points far from the DoE raise the rebuilt gate's threshold (a percentile of the DoE's own distances) and
    # widen its standardization: candidates are chosen, and also counted, with today's gate held (its
    # standardization and threshold, the new points among its reference), so a point earns its place by coverage
    today = held_gate = gate
    threshold = today.threshold_
    held = inside.copy()
    z = today.standardizer_.transform(production[outside])
    clusters = min(settings.n_candidates, int(outside.sum()))
    centres = (
        KMeans(n_clusters=clusters, n_init=1, random_state=settings.seed)
        .fit(z, sample_weight=weights[outside])
        .cluster_centers_
    )
    candidates = np.clip(centres * today.standardizer_.scale_ + today.standardizer_.mean_, low, high)
    raw_std = np.asarray(surrogate_std(candidates), float) if surrogate_std is not None else np.zeros(len(candidates))
    uncertainty = 1.0 + raw_std / raw_std.max() if raw_std.max() > 0 else np.ones(len(candidates))
    available = np.ones(len(candidates), bool)
    current_doe = doe
    for _ in range(settings.n_points):
        if held.all() or not available.any():
            break
        out_rows = np.flatnonzero(~held)
        z_out = today.standardizer_.transform(production[out_rows])
        nearest = _nearest(held_gate.reference_, z_out, k)
        z_candidates = today.standardizer_.transform(candidates[available])
        count, shortened = _chunked_gain(z_out, nearest, z_candidates, threshold, weights[out_rows])
        order = np.lexsort((-shortened * uncertainty[available], -count))
        pick = np.flatnonzero(available)[order[0]]
        available[pick] = False
        current_doe = np.vstack([current_doe, candidates[pick]])
        gate = KNNSupportGate(k=k, percentile=percentile).fit(current_doe)  # as the workflow would rebuild it
        held_gate = KNNSupportGate(k=k, percentile=percentile, standardizer=today.standardizer_).fit(current_doe)
        now_inside, now_held = gate.predict(production), held_gate.distance(production) <= threshold
        points.append(candidates[pick])
        brought.append(counted[np.flatnonzero(now_inside & ~inside)])
        shares.append(float(now_inside.mean()))
        held_shares.append(float(now_held.mean()))
        stds.append(raw_std[pick])
        inside, held = now_inside, now_held
    return Proposal(
        np.array(points), brought, shares, share_before, np.array(stds), held_shares, len(counted), n_production
    )


def served_columns(head: pd.DataFrame, inputs) -> list[str]:
    """The log's columns a proposal's ``serves`` reads besides the inputs, from its first rows (``head``): the text
    ones (ids, lots, timestamps); a step on a long log reads only these, at :func:`served_rows`."""
    return [c for c in head.columns if c not in set(inputs) and not pd.api.types.is_numeric_dtype(head[c])]


def served_rows(proposal: Proposal) -> np.ndarray:
    """The production rows the proposals bring into the support, in order: all of the log ``serves`` reads."""
    return np.unique(np.concatenate([np.asarray(rows, int) for rows in proposal.brought_in] or [np.empty(0, int)]))


def _served(production: pd.DataFrame, rows: np.ndarray, inputs) -> str:
    """The production cluster a point serves: its rows, time span, and the main level of each id column."""
    if not len(rows):
        return "no part on its own (prepares a neighbourhood for the next points)"
    parts = [f"rows {rows.min() + 1}-{rows.max() + 1}"]
    for column in production.columns:
        if column in inputs:
            continue
        values = production[column].loc[rows]  # by row label: ``production`` may hold only the served rows
        if values.dtype.kind in "OUT" or str(values.dtype) in ("string", "str"):
            as_time = parse_timestamps(values)  # ISO, else day-first (04.03.2026 is the 4th of March)
            if as_time is not None and as_time.notna().all():
                parts.append(f"{column} {as_time.min():%Y-%m-%d %H:%M} to {as_time.max():%Y-%m-%d %H:%M}")
                continue
            counts = values.value_counts()
            if len(counts) <= max(3, len(rows) // 2):
                parts.append(
                    f"{column} {counts.index[0]} ({counts.iloc[0] / len(rows):.0%})"
                    + (f" and {len(counts) - 1} more" if len(counts) > 1 else "")
                )
    return "; ".join(parts)


def counted_on(proposal: Proposal) -> str:
    if proposal.n_counted >= proposal.n_production:
        return f"all {proposal.n_production:,} production parts"
    return (
        f"a seeded sample of {proposal.n_counted:,} of the {proposal.n_production:,} production parts "
        "(enrichment.max_rows); parts_brought_in scaled to the whole log"
    )


def proposals_table(proposal: Proposal, production: pd.DataFrame, inputs) -> pd.DataFrame:
    """proposed_simulations.csv: the points in the DoE's columns, with what each brings."""
    table = pd.DataFrame(proposal.points.reshape(-1, len(inputs)), columns=list(inputs))
    table.insert(0, "proposal", np.arange(1, len(table) + 1))
    scale = proposal.parts_per_counted_part
    table["parts_brought_in"] = [int(round(len(rows) * scale)) for rows in proposal.brought_in]
    table["share_in_support_after"] = proposal.share_after
    table["share_within_todays_threshold"] = proposal.share_after_fixed_threshold
    table["surrogate_std_here"] = proposal.surrogate_std
    table["serves"] = [_served(production, rows, inputs) for rows in proposal.brought_in]
    table["counted_on"] = counted_on(proposal)
    table.attrs["share_before"] = proposal.share_before
    return table
