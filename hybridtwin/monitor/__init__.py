"""Watching the plant: does a new batch of production still behave as the models expect, since when not, and why.

:mod:`.chart` turns each measured part's residual into the monitoring statistic (two-sided CUSUMs inside the
regimes of :mod:`.regimes` and over their levels, whose constants :mod:`.calibration` sets on the production log);
:mod:`.watch` reads and checks a batch and runs the chart;
:mod:`.changes` asks the diagnosis what changed after an alarm; :mod:`.words` says it (the summary, monitor.md and
what to do next); :mod:`.figure` draws it.
"""
