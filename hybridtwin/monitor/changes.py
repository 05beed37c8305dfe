"""What changed: after an alarm, the residual of the batch's parts goes through the diagnosis, the parts after the
estimated start against those before it.

The diagnosis (:func:`hybridtwin.diagnosis.diagnose`, its public entry point, with its own significance rules)
ranks what explains the residual over the judged parts. The answer is one of three:

* a **known cause that moved**: a column of the models' extension (a cause the workflow's diagnosis named) among
  the causes found: "the die_temp_c effect changed by 3.0 mm";
* a **new candidate**: another logged column explains it, or a setting steps to a level it never had before at
  the part the change starts (a step in time there is the same step: the logged setting is the physical cause):
  "a step in shim21_mm at part 3,012";
* **unexplained**: nothing, or only time (a timestamp, or a counter that only grows), explains it: "a shift of
  +1.5 mm from part 3,012 with no logged column that explains it".
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hybridtwin.answers.trust import VALIDATED
from hybridtwin.monitor.regimes import text_changes

MAX_ROWS = 3000  # parts the diagnosis reads (a seeded sample, in order)
MIN_BEFORE = 30  # parts before the start that make a reference level (fewer: the models' own, zero)
# a cause must explain this much more of the residual (held out) than a step at the start, which is time alone
SHARE_MARGIN = 0.02
BOUNDARY = 10  # parts from the start a new coil must begin at (a setting's step: at most before) to be named with it
LOCAL = 50  # parts either side of the start in which a step, not a trend, must fit
WINDOW = 300  # parts before a setting's step whose levels it must leave (and after it, without the regime charts)
KEPT = 1000  # with the regime charts, parts a stepped setting must keep its new level for (campaigns are shorter)
STAYS = 0.5  # a shift that keeps this share of itself where a stepped setting left its new level is not that setting's
STEPS = ("step", "sigmoid")  # forms that are a step in time when the column is a clock
LEAST_CELL = 10  # judged parts (a tenth of them, thrice) that tell a slope
MOVED_T = 5.0  # a known cause moved: its slope inside the regimes changed by this many standard errors
MOVED_EFFECT = 1.0  # and by at least this many within-regime scatters over the column's range since the start
KNOWN, NEW, UNEXPLAINED = "known cause", "new candidate", "unexplained"


@dataclass(frozen=True)
class Change:
    kind: str  # KNOWN, NEW or UNEXPLAINED
    text: str  # the answer in words
    column: str | None
    shift: float  # mean residual after the start less before it
    start_part: int  # from 1
    n_after: int
    outside_support: float  # share of the parts since the start outside the support
    proposed: dict = field(default_factory=dict)  # a setting to simulate (the changed parts' median), if outside


def _diagnosis_frame(table: pd.DataFrame, added, target: str) -> pd.DataFrame:
    return table[[c for c in table.columns if c not in set(added) | {target}]]


def clocks(frame: pd.DataFrame) -> set[str]:
    """Columns that only tell time: numbers that never go down over the batch (a stroke counter) and timestamps."""
    from hybridtwin.diagnosis.causes import looks_like_timestamps

    found = set()
    for column in frame.columns:
        values = frame[column]
        if pd.api.types.is_numeric_dtype(values):
            numbers = values.to_numpy(float)
            # each part against the one before, not their differences: no column-sized copy of floats
            if len(numbers) > 2 and numbers[-1] > numbers[0] and np.all(numbers[1:] >= numbers[:-1]):
                found.add(column)
        elif looks_like_timestamps(values):
            found.add(column)
    return found


def step_of(values: np.ndarray, start: int, window: int = WINDOW, kept: int | None = None):
    """A step of a numeric column near ``start`` (from BOUNDARY parts before it to LOCAL after it) to a level it
    never had in the ``window`` parts before the step and keeps for the ``kept`` parts after it (default
    ``window``; fewer if the batch ends): (the index it steps at, the level before, the level after), or None."""
    first = max(0, start - LOCAL)  # the split is looked for near the start: campaigns may change further away
    around = values[first : start + LOCAL]
    if len(around) < MIN_BEFORE or not np.isfinite(around).all():
        return None
    split, misfit = two_levels(around)
    # the step is dated where two levels fit best from BOUNDARY parts before the start (a start dated late; a
    # campaign that changed a few dozen parts before is no step at the change) to LOCAL after it (a setting moved
    # after the change began: shift_without_setting judges it); the levels are compared either side of it, not of
    # the start: parts of the new level before a start dated late would make it a level the setting had before
    near = first + split >= start - BOUNDARY
    if not near.any():
        return None
    at = first + int(split[near][np.argmin(misfit[near])])
    before, after = values[max(0, at - window) : at], values[at : at + (kept or window)]
    if len(before) < MIN_BEFORE or len(after) < MIN_BEFORE:
        return None
    if not (np.isfinite(before).all() and np.isfinite(after).all()):  # a setting not logged on every part
        return None
    low, high = np.quantile(before, [0.005, 0.995])
    if np.mean((after < low) | (after > high)) < 0.9:
        return None
    n = len(around)
    # a step, not a trend (a die warming up): two levels fit clearly better than a straight line (it leaves half as
    # much again), and take far the most of the line's misfit beyond the setting's own scatter from part to part
    # (one side of a step may scatter more than the other: a scattered setting set to a steady level)
    line = np.sum((around - np.polyval(np.polyfit(np.arange(n), around, 1), np.arange(n))) ** 2)
    scatter = n * np.sum(np.diff(around) ** 2) / (2 * (n - 1))
    if line < 1.5 * np.min(misfit) or np.min(misfit) - scatter > 0.25 * (line - scatter):
        return None
    return at, float(np.median(before)), float(np.median(after))


def two_levels(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each split of a series into a level before and one after (the index of the first part after, 1 to n - 1)
    and the squared misfit of those two levels."""
    n = len(values)
    total, squares = np.cumsum(values), np.cumsum(values**2)
    split = np.arange(1, n)
    left = squares[:-1] - total[:-1] ** 2 / split
    right = (squares[-1] - squares[:-1]) - (total[-1] - total[:-1]) ** 2 / (n - split)
    return split, left + right


def typical_setting(table: pd.DataFrame, inputs, start: int) -> dict[str, float]:
    """The parts' median setting from ``start`` on: what to simulate for them."""
    return {name: float(table[name].iloc[start:].median()) for name in inputs}


def step_share(residual: np.ndarray, after: np.ndarray) -> float:
    """The share of the residual's variance a step at the start explains (a level before, one after): what time
    alone explains."""
    total = np.sum((residual - residual.mean()) ** 2)
    if total <= 0 or after.all() or not after.any():
        return 0.0
    left = np.sum((residual[~after] - residual[~after].mean()) ** 2)
    return float(1.0 - (left + np.sum((residual[after] - residual[after].mean()) ** 2)) / total)


def boundary_of(values: pd.Series, start: int, tolerance: int = BOUNDARY) -> int | None:
    """The part nearest ``start`` (within ``tolerance``) at which a text column (a coil id, a lot) takes a new
    value, or None; a column that changes at more than one part in ten is no such column."""
    if pd.api.types.is_numeric_dtype(values) or len(values) < 2:
        return None
    changes = np.flatnonzero(text_changes(values)) + 1
    if len(changes) > 0.1 * len(values):
        return None
    near = changes[np.abs(changes - start) <= tolerance]
    return int(near[np.argmin(np.abs(near - start))]) if len(near) else None


def slope(x, residual, cells) -> tuple[float, float]:
    """The least-squares slope of ``residual`` on ``x`` and its standard error clustered by ``cells`` (the parts
    of a regime share the models' settled error there, not only the noise)."""
    x, residual = np.asarray(x, float), np.asarray(residual, float)
    xc, yc = x - x.mean(), residual - residual.mean()
    xx = float(np.sum(xc**2))
    if len(x) < 3 or xx <= 0:
        return 0.0, float("inf")
    fitted = float(np.sum(xc * yc) / xx)
    yc -= fitted * xc  # the scores xc * (yc - fitted * xc) in place: ten million parts hold few copies
    yc *= xc
    scores = pd.Series(yc).groupby(np.asarray(cells)).sum().to_numpy()
    return fitted, float(np.sqrt(np.sum(scores**2)) / xx)


def slope_change(x, residual, judged, group, start: int, log=None) -> tuple[float, float]:
    """How differently the residual follows ``x`` since ``start`` than in control: (the change over the range of
    x since the start, in standard errors clustered by regime). In control is the batch's parts before the start,
    pooled with ``log`` (the log's slope, its standard error and its spread between stretches of the log, which
    the batch's slope may move by in control too) if given; (0, 0) without enough parts."""
    after = judged & (np.arange(len(residual)) >= start)
    before = judged & ~after
    if after.sum() < 3 * LEAST_CELL:
        return 0.0, 0.0
    x = np.asarray(x, float)
    slope_after, error_after = slope(x[after], residual[after], group[after])
    known = [tuple(log[:2])] if log is not None else []
    spread = float(log[2]) if log is not None and len(log) > 2 else 0.0
    if before.sum() >= 3 * LEAST_CELL:
        known.append(slope(x[before], residual[before], group[before]))
    weights = np.array([1.0 / error**2 if np.isfinite(error) and error > 0 else 0.0 for _, error in known])
    if not weights.sum() or not np.isfinite(error_after):
        return 0.0, 0.0
    in_control = float(np.sum(weights * [value for value, _ in known]) / weights.sum())
    low, high = np.quantile(x[after], [0.05, 0.95])
    error = float(np.sqrt(error_after**2 + 1.0 / weights.sum() + spread**2))
    return (slope_after - in_control) * (high - low), abs(slope_after - in_control) / error if error > 0 else 0.0


def moved(change: tuple[float, float], scale: float) -> bool:
    """A slope change that counts: MOVED_T standard errors and MOVED_EFFECT within-regime scatters."""
    return change[1] > MOVED_T and abs(change[0]) > MOVED_EFFECT * scale


def moved_cause(frame: pd.DataFrame, residual, judged, group, start: int, reference: dict, scale: float):
    """A known cause (a numeric column of the models' extension) whose effect moved at ``start``: since the start
    the residual follows the column by another slope than in control (the log's, stored with the models in
    ``reference``: column -> (slope, standard error, spread), pooled with the batch's parts before the start).
    (column, the effect's change over the column's range since the start) or None."""
    best = None
    for column, log in reference.items():
        if column in frame:
            change = slope_change(frame[column], residual, judged, group, start, log)
            if moved(change, scale) and (best is None or change[1] > best[2]):
                best = (column, change[0], change[1])
    return None if best is None else best[:2]


def new_form(values: pd.Series, start: int) -> int | None:
    """The part (index) from which a text column's values (coil ids) take a form never seen before in the batch
    (digits aside: a new supplier's ids) and keep it, if that is before ``start`` or within WINDOW parts after it
    (a change that begins with a new regime is found late), else None.

    Only ids have forms: numbers in a form, so that some form holds several values; labels (a shift A, B, C) are
    each their own form. A batch of long coils holds a few ids only (two to eight in 10,000 parts on the
    structures generator's plants, one of them before the change), which is still ids."""
    if pd.api.types.is_numeric_dtype(values) or len(values) < 2:
        return None
    forms = values.astype(str).str.replace(r"\d", "0", regex=True).to_numpy()
    if len(set(forms.tolist())) >= values.nunique():  # labels, not ids
        return None
    seen = pd.Series(forms).groupby(forms).cumcount().to_numpy() == 0  # the first part of each form
    first = np.flatnonzero(seen)[1:]
    for at in first[first >= MIN_BEFORE]:
        if at <= start + WINDOW and np.mean(~np.isin(forms[at:], forms[:at])) >= 0.9:
            return int(at)
    return None


def _found_causes(frame: pd.DataFrame, residual: np.ndarray, inputs, unit: str, seed: int) -> list:
    from hybridtwin.diagnosis import Settings, diagnose

    n = len(residual)
    settings = Settings(seed=seed, unit=unit, interactions=False, max_causes=2, max_rows=MAX_ROWS, n_blocks=50)
    if n < 4 * settings.n_blocks:
        settings = Settings(seed=seed, unit=unit, interactions=False, max_causes=2, max_rows=MAX_ROWS, n_blocks=10)
    return list(diagnose(frame, residual, inputs, (), settings).selected)


def what_changed(table: pd.DataFrame, residual, result, predictor, seed: int = 0, added=()) -> "Change":
    """What changed from the chart's estimated start on (``table``: the batch with the monitor's columns
    ``added``; ``residual``: measured less predicted per part; ``result``: the chart, in alarm)."""
    residual = np.asarray(residual, float)
    judged = ~np.isnan(result.z)
    start = int(result.start_at)
    after, before = judged & (np.arange(len(residual)) >= start), judged & (np.arange(len(residual)) < start)
    reference = float(residual[before].mean()) if before.sum() >= MIN_BEFORE else 0.0
    shift = float(residual[after].mean()) - reference
    shifted = (residual - reference, judged)
    unit, target = predictor.spec["unit"], predictor.spec["target"]
    frame = _diagnosis_frame(table, added, target)
    rows = np.flatnonzero(judged & (np.arange(len(residual)) >= start - (WINDOW if before.any() else 0)))
    found = _found_causes(frame.iloc[rows].reset_index(drop=True), residual[rows], predictor.inputs, unit, seed)
    found = [fit for fit in found if fit.explained_share > step_share(residual[rows], rows >= start) + SHARE_MARGIN]
    not_validated = table["trust"].to_numpy() != VALIDATED
    outside = float(np.mean(not_validated[start:]))
    common = {"shift": shift, "start_part": start + 1, "n_after": int(after.sum()), "outside_support": outside}
    gap = start - (int(np.flatnonzero(judged[:start])[-1]) + 1 if judged[:start].any() else 0)
    moved_known, regime = None, None
    if getattr(result, "group", None) is not None:  # the regime charts
        regime = (residual, judged, result.group, result.scale)
        slopes = predictor.spec.get("monitor", {}).get("slopes", {})
        moved_known = moved_cause(frame, residual, judged, result.group, start, slopes, result.scale)
    kind, column, text = _named(found, frame, start, predictor, shift, unit, gap, moved_known, regime, shifted)
    proposed = {}
    # the change comes with settings outside the support: more of the parts since the start lie there than before
    if outside > 0.5 and outside - (float(np.mean(not_validated[:start])) if start >= MIN_BEFORE else 0.0) > 0.25:
        proposed = typical_setting(table, predictor.inputs, start)
    return Change(kind, text, column, proposed=proposed, **common)


def _named(found, frame, start, predictor, shift, unit, gap=0, known_moved=None, regime=None, shifted=None):
    """(kind, column, text) from the causes the diagnosis found; ``gap``: parts right before the start that were
    not judged (the change began during them: no setting or coil can be dated to the start); ``shifted``: (the
    residual less its level before the start, the judged parts), to drop a setting that stepped where the change
    began but whose new level the shift does not follow (:func:`shift_without_setting`).

    With the regime charts, ``known_moved``: a known cause whose slope changed (:func:`moved_cause`; a new
    supplier's ids, :func:`new_form`, go before it and before every other cause); ``regime``:
    (residual, judged, group, scale). The settled levels of the regimes are the models' own error, which a coil id
    or a setting of the campaigns "explains" before the start as well as after it: a cause the diagnosis found
    must then follow the residual by another slope since the start than before it (a coil id cannot), and a coil
    that begins near the start is no cause (the charts begin a regime there and see no change at it)."""
    timing = clocks(frame) - set(predictor.inputs)  # a setting stepped up once never goes down, yet is no clock
    supplier = _new_form_column(frame, start, timing)
    if supplier is not None:  # ids of a form never seen, from where it began: a new supplier, before any other cause
        column, at = supplier
        text = f"a change with {column}: since part {at + 1:,} its values take a new form ({frame[column].iloc[at]})"
        return NEW, column, text + f"; the parts since part {start + 1:,} sit {shift:+.1f} {unit} off"
    if known_moved is not None:
        name, change = known_moved
        return KNOWN, name, f"the {name} effect changed by {change:+.1f} {unit} over its range since part {start + 1:,}"
    known = predictor.extension.extension.columns
    if regime is not None:
        found = _slope_changed(found, frame, start, timing, regime)
    physical = [fit for fit in found if fit.candidate.kind != "time" and not set(fit.candidate.columns) & timing]
    for fit in found:  # a known cause, a wear drift along a counter among them (a trend: not a step in time)
        if set(fit.candidate.columns) & known and (fit in physical or fit.form.name not in STEPS):
            name = fit.candidate.name
            return KNOWN, name, f"the {name} effect changed by {fit.effect_range:.1f} {unit} over the batch"
    physical = physical if physical and found[0] is physical[0] else []  # time came first: it is time
    # a step where the change began: at the start, or where the parts not judged right before it began (a setting
    # unlike every logged part is not judged); with the regime charts a campaign's settings and a coil's
    # properties change at every regime, in control: the new level must last KEPT parts
    steps = _dated_steps(frame, start, gap, timing, regime is not None, shifted, shift)
    if physical:
        fit = physical[0]
        name = fit.candidate.name
        if name in steps:
            return NEW, name, _step_text(name, steps[name])
        if fit.candidate.kind == "group":
            return NEW, name, f"a change with {name}: the parts since part {start + 1:,} sit {shift:+.1f} {unit} off"
        return NEW, name, f"a new effect of {name}, {fit.effect_range:.1f} {unit} over its range in the batch"
    if steps:  # time alone explains it, and a setting stepped to a new level where it started: that setting
        name = max(steps, key=lambda c: abs(steps[c][2] - steps[c][1]) / (np.std(frame[c].to_numpy(float)) + 1e-12))
        return NEW, name, _step_text(name, steps[name])
    for column in frame.columns if gap < BOUNDARY and regime is None else []:  # a new coil began where it started
        at = boundary_of(frame[column], start) if column not in timing else None
        if at is not None:
            text = f"a change with {column}: since part {at + 1:,} ({frame[column].iloc[at]}) the parts sit "
            return NEW, column, text + f"{shift:+.1f} {unit} off"
    during = f" (it began during the {gap:,} parts before, which were not judged)" if gap >= BOUNDARY else ""
    text = f"a shift of {shift:+.1f} {unit} from part {start + 1:,}{during} with no logged column"
    return UNEXPLAINED, None, text + " that explains it"


def _new_form_column(frame: pd.DataFrame, start: int, timing: set) -> tuple[str, int] | None:
    """The first column (not a clock) whose values take a form never seen before where the change began
    (:func:`new_form`: a new supplier's coil ids), and the part from which they do; None if none does."""
    for column in frame.columns:
        at = new_form(frame[column], start) if column not in timing else None
        if at is not None:
            return str(column), at
    return None


def _slope_changed(found: list, frame: pd.DataFrame, start: int, timing: set, regime) -> list:
    """The causes found that time explains, or a numeric column the residual follows by a changed slope since
    the start (``regime``: residual, judged, group, scale): no group, whose levels are the regimes' own."""
    residual, judged, group, scale = regime

    def holds(fit) -> bool:
        columns = fit.candidate.columns
        if fit.candidate.kind == "time" or set(columns) & timing:
            return True
        if len(columns) != 1 or fit.candidate.kind == "group" or not pd.api.types.is_numeric_dtype(frame[columns[0]]):
            return False
        return moved(slope_change(frame[columns[0]], residual, judged, group, start), scale)

    return [fit for fit in found if holds(fit)]


def _dated_steps(frame, start: int, gap: int, timing: set, charts: bool, shifted, shift: float) -> dict:
    """The settings that step where the change began (:func:`_steps`; with the regime ``charts``, to a level they
    keep KEPT parts), less those whose new level the shift does not follow (:func:`shift_without_setting`). After
    a longer stretch not judged (a setting stepped beyond every logged part: its parts cannot be judged until the
    batch comes back near the log), where the residual itself steps inside it (:func:`_dated_inside`)."""
    began = start if gap < BOUNDARY else start - gap
    if gap > WINDOW:
        began = _dated_inside(shifted, start - gap, start, shift) if shifted is not None else None
        if began is None:
            return {}
    steps = _steps(frame, began, timing, KEPT if charts else None)
    if shifted is None:
        return steps
    return {
        name: step
        for name, step in steps.items()
        if not shift_without_setting(frame[name], step, *shifted, shift, began)
    }


def _dated_inside(shifted, first: int, last: int, shift: float) -> int | None:
    """Where the residual steps by the shift's sign inside the parts ``first`` to ``last - 1``, which were not
    judged (the residual is there, without an error to compare it with): the likeliest start of a shift from its
    level before the change (:func:`chart.likeliest_start`), if the parts from there sit off the stretch's parts
    before it (or off zero, the level before the change, where none are) by three standard errors; else None.
    ``shifted``: (the residual less its level before the change, the judged parts)."""
    from hybridtwin.monitor.chart import likeliest_start

    residual = np.asarray(shifted[0], float)
    at = likeliest_start(residual, first, last - 1, 1 if shift >= 0 else -1)
    before, after = residual[first:at], residual[at:last]
    before, after = before[np.isfinite(before)], after[np.isfinite(after)]
    if len(after) < MIN_BEFORE:
        return None
    error = np.var(after) / len(after)
    reference = 0.0
    if len(before) >= MIN_BEFORE:
        reference, error = float(np.mean(before)), error + np.var(before) / len(before)
    return at if (np.mean(after) - reference) * np.sign(shift) > 3 * np.sqrt(error) else None


def _steps(frame: pd.DataFrame, start: int, timing: set, kept: int | None = None) -> dict:
    """The numeric columns (not clocks) that step to a new level at ``start`` (and keep it ``kept`` parts):
    column -> (index, before, after)."""
    steps = {}
    for column in frame.columns:
        values = frame[column]
        if column not in timing and pd.api.types.is_numeric_dtype(values):
            step = step_of(values.to_numpy(float), start, kept=kept)
            if step is not None:
                steps[column] = step
    return steps


def shift_without_setting(values: pd.Series, step: tuple, shifted, judged, shift: float, start: int) -> bool:
    """Whether the shift shows on the parts since ``start`` at which the setting is not at its new level: before
    it stepped (a setting that moved some parts after the change began), or after it went back (a campaign that
    ended: more than half the step back towards the old level). There the setting cannot explain it: it is time,
    or another cause. ``shifted``: the residual less its level before the start. False with fewer than LEAST_CELL
    such parts, or a shift there not clearly above their scatter (a setting that steps where the change starts
    and keeps its new level, or steps on the same way, cannot be told from time)."""
    _, old, new = step
    x = values.to_numpy(float)
    not_new = (x - new) * np.sign(new - old) < -abs(new - old) / 2
    left = judged & not_new & (np.arange(len(x)) >= start)
    if left.sum() < LEAST_CELL or shift == 0:
        return False
    stays = shifted[left] * np.sign(shift)  # and clearly so, beyond the parts' scatter
    return float(np.mean(stays)) / abs(shift) > STAYS and np.mean(stays) > 3 * np.std(stays) / np.sqrt(left.sum())


def _step_text(name: str, step: tuple[int, float, float]) -> str:
    at, low, high = step
    return f"a step in {name} at part {at + 1:,} (from {low:.4g} to {high:.4g})"
