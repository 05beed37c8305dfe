"""The monitor's figure: the residual over parts, the statistic with its limit, and the alarm."""

from __future__ import annotations

import numpy as np

from hybridtwin.report.plots import plt


def monitor(watched, title: str = ""):
    """Two panels over the batch's parts: the residual (judged parts, and those not judged in grey) with the
    estimated start and the alarm marked, and the stretch shaded where the batch left what the models can judge;
    below, the statistic against its limit."""
    table, chart = watched.table, watched.chart
    part = table["part"].to_numpy()
    residual = table["residual"].to_numpy(float)
    judged = watched.judged
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, height_ratios=[3, 2])
    top.scatter(part[judged], residual[judged], s=3, color="C0", alpha=0.4, label="residual (judged)")
    if (~judged).any():
        top.scatter(part[~judged], residual[~judged], s=3, color="0.7", alpha=0.4, label="not judged (extrapolation)")
    top.axhline(0, color="k", lw=0.8)
    bottom.plot(part, chart.statistic, color="C3", lw=1.2, label="statistic (CUSUMs, each scaled to the limit)")
    bottom.axhline(chart.limit, color="k", ls="--", lw=1, label=f"limit {chart.limit:g}")
    if chart.alarm_at is not None:
        for axis in (top, bottom):
            axis.axvline(part[chart.alarm_at], color="C3", lw=1.2, label=f"alarm at part {part[chart.alarm_at]:,}")
            axis.axvline(part[chart.start_at], color="C1", ls=":", lw=1.2,
                         label=f"estimated start, part {part[chart.start_at]:,}")  # fmt: skip
            after = judged & (np.arange(len(part)) >= chart.start_at)
            before = judged & (np.arange(len(part)) < chart.start_at)
        for rows in (before, after):
            if rows.any():
                top.hlines(residual[rows].mean(), part[rows][0], part[rows][-1], color="C1", lw=2)
    left = watched.departure
    if left is not None:  # where the batch left what the models can judge: shaded, not an alarm
        for axis, label in ((top, f"left the judged settings, part {left.start_part:,}"), (bottom, None)):
            axis.axvspan(left.start_part, part[-1], color="0.85", alpha=0.5, lw=0, label=label)
    top.set(ylabel=f"measured − predicted [{watched.unit}]", title=title or "Monitor: residual over the batch")
    bottom.set(xlabel="part (row of the batch)", ylabel="statistic")
    top.legend(fontsize=7, loc="upper left")
    bottom.legend(fontsize=7, loc="upper left")
    figure.tight_layout()
    return figure
