"""Randomized plant structures for the diagnosis bank (issue 27, item 4): drawn per plant, not hand-picked.

Per plant, from its seed: 6-14 inputs (material, thermal, press settings) named from vocabularies, with the thermal
quantities and the lubricant film that are no input logged beside them; a smooth simulator of its own and a DoE of
30-120 runs (the surrogate's quality); which material properties are constant within a coil; coils shorter than,
as long as or longer than the setting campaigns; rhythms (shifts, idle days, strokes, a warming die and oil, an
ambient with a daily cycle, weather and a seasonal trend, several styles of timestamps and ids); the hidden effect
(:data:`KINDS`) and its std in support as a ratio (log-uniform in :data:`SIZE_RANGE`) of the surrogate's own
uncertainty there, computed as the workflow does.

The judge's convention: a cause below :data:`DETECTION_LIMIT` times the surrogate's uncertainty (the diagnosis'
own bar) cannot be told from the surrogate's error and is not expected; with no cause above it a plant expects
``Expected(None)`` (nothing significant), says "below the detection limit" and has ``StructureCase.below_limit``
(``hidden_causes`` still names every cause put in). ``alias`` is set only where the data cannot tell two columns
apart: a step at some time is one in strokes too, and so is a drift in time on a line never idle in support.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pandas as pd
from scipy.special import expit
from scipy.stats import qmc

from hybridtwin.demo import families
from hybridtwin.demo.families import Expected, PlantCase
from hybridtwin.demo.quantities import (
    COIL_STYLES,
    MATERIAL,
    QUANTITIES,
    RELATIONS,
    SETTING,
    SHIFT_LABELS,
    THERMAL,
    VOCABULARY,
    of_role,
)
from hybridtwin.diagnosis.forms import SIGMOID_SPAN, fit_form
from hybridtwin.io.config import section_defaults
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate, surrogate_latent_std

COLUMN_FORMS = ("linear", "quadratic", "sigmoid", "step")  # a single column's effect of each form
OTHER_KINDS = ("product", "ambient", "seasonal", "wear", "coil", "unlogged_shift")
KINDS = (*COLUMN_FORMS, *OTHER_KINDS, "two_causes", "three_causes", "none")
DETECTION_LIMIT = 1.0  # effect std over the surrogate's latent std below which nothing can be named
SIZE_RANGE = (0.3, 10.0)
MIN_IN_SUPPORT = 0.07
MIN_COILS_IN_SUPPORT = 10


def _simulator(inputs: list[str], names: dict[str, str], rng: np.random.Generator) -> Callable:
    """The plant's simulator on its input columns (plant names): additive with mild curvature and one or two
    interactions on the inputs scaled to [-1, 1] over their DoE ranges, 9-16 mm std over the DoE box."""
    k, columns = len(inputs), [names[c] for c in inputs]
    raw = rng.choice([-1.0, 1.0], k) * rng.uniform(1.0, 10.0, k)
    slopes = raw * rng.uniform(9.0, 16.0) / np.sqrt(np.sum(raw**2) / 3.0)  # std of u @ slopes over the box
    curvatures = rng.choice([-1.0, 1.0], k) * rng.uniform(0.2, 1.2, k)
    pairs = [(i, j, rng.choice([-1, 1]) * rng.uniform(0.5, 2.5)) for i, j in rng.choice(k, (rng.integers(1, 3), 2))]
    low, high = np.array([QUANTITIES[c].low for c in inputs]), np.array([QUANTITIES[c].high for c in inputs])
    nominal = rng.uniform(35, 60)

    def simulate(frame: pd.DataFrame) -> np.ndarray:
        u = (frame[columns].to_numpy(float) - (low + high) / 2) / ((high - low) / 2)
        return nominal + u @ slopes + (u**2) @ curvatures + sum(size * u[:, i] * u[:, j] for i, j, size in pairs)

    return simulate


@dataclass(frozen=True)
class Structure:
    """A plant's drawn structure: sizes, inputs and logged quantities (canonical names), rhythms."""

    n: int
    inputs: tuple[str, ...]
    logged: tuple[str, ...]  # physical quantities logged beside the inputs
    per_coil: tuple[str, ...]
    relation: str
    n_coils: int
    n_campaigns: int
    n_doe: int
    names: dict[str, str]
    physical: tuple[str, ...]  # the inputs and the logged quantities


def draw_structure(rng: np.random.Generator, n_production: int | None = None) -> Structure:
    """Inputs (at least one material and two settings), per-coil properties, coil and campaign counts, DoE size."""
    n = int(n_production or rng.integers(8_000, 30_001))
    n_inputs = int(rng.integers(6, 15))
    required = [str(rng.choice(of_role(MATERIAL))), *rng.choice(of_role(SETTING), 2, replace=False)]
    rest = [q for q in QUANTITIES if q not in required]
    chosen = {*required, *rng.choice(rest, n_inputs - 3, replace=False)}
    inputs = [q for q in QUANTITIES if q in chosen]
    logged = [q for q in (*of_role(THERMAL), "lubricant") if q not in inputs]
    materials = [q for q in (*of_role(MATERIAL, inputs), *logged) if QUANTITIES[q].role == MATERIAL]
    per_coil = [q for q in materials if rng.random() < 0.6] or [str(rng.choice(materials))]
    relation = str(rng.choice(RELATIONS))
    # 12-30 campaigns of 2.5-5 coils each, as many coils as campaigns (15-100), or 15-40 coils of 2.5-5 campaigns
    few = int(rng.integers(*{"shorter": (12, 31), "equal": (15, 101), "longer": (15, 41)}[relation]))
    many = few if relation == "equal" else int(few * rng.uniform(2.5, 5.0))
    n_coils, n_campaigns = (many, few) if relation == "shorter" else (few, many)
    names = {key: str(rng.choice(options)) for key, options in VOCABULARY.items()}
    n_doe = int(rng.integers(30, 121))
    inputs, logged = tuple(inputs), tuple(logged)
    return Structure(n, inputs, logged, tuple(per_coil), relation, n_coils, n_campaigns, n_doe, names, inputs + logged)


def _segments(n: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """Segment index per part: ``count`` consecutive segments of lengths within +-40% of n / count."""
    lengths = rng.uniform(0.6, 1.4, count)
    edges = np.round(np.cumsum(lengths) / lengths.sum() * n).astype(int)
    return np.searchsorted(edges, np.arange(n), side="right")


def _timeline(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Elapsed seconds, shift, seconds into the shift and stroke counter per logged part: parts logged every few
    strokes so that a log spans 6-90 shifts of 8 hours, with breaks and idle spells of half a day to three days."""
    spm = rng.uniform(10, 18)
    strokes_per_shift = 8 * 60 * spm * rng.uniform(0.7, 0.95)
    n_shifts = max(int(np.exp(rng.uniform(np.log(6), np.log(90)))), int(np.ceil(n / strokes_per_shift)))
    every = max(1.0, strokes_per_shift * n_shifts / n)
    step = 1 + rng.poisson(every - 1.0, n)
    cycle = step * 60.0 / spm * (1.0 + rng.exponential(0.05, n))
    shift_of = np.arange(n) * n_shifts // n
    first = np.searchsorted(shift_of, np.arange(n_shifts))
    total = np.cumsum(cycle)
    in_shift = total - total[first][shift_of]
    shift_length = np.r_[in_shift[first[1:] - 1], in_shift[-1]]
    gaps = rng.uniform(0.25, 1.0, n_shifts) * 3600.0
    idle = rng.random(n_shifts) < 1.0 / rng.uniform(3, 6)
    gaps[idle] += rng.uniform(12, 72, idle.sum()) * 3600.0
    gaps[0] = 0.0
    shift_start = np.cumsum(np.r_[0.0, shift_length[:-1]] + gaps)
    set_up = np.cumsum(rng.integers(5, 200, n_shifts))[shift_of]
    strokes = 100_000 + np.cumsum(step) + set_up
    return {"elapsed": shift_start[shift_of] + in_shift, "shift_of": shift_of, "in_shift": in_shift, "strokes": strokes}


def _material(structure: Structure, coil: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Material per part: a per-coil property is its coil's value plus a tiny noise (2% of the coil-to-coil
    spread); a per-part one scatters from part to part. Rm and Rp0.2 share a strength (per coil or per part)."""
    n, n_coils = len(coil), coil.max() + 1
    strength = {True: rng.normal(0, 1, n_coils)[coil], False: rng.normal(0, 1, n)}
    values = {}
    for name in of_role(MATERIAL, structure.physical):
        quantity, by_coil = QUANTITIES[name], name in structure.per_coil
        span = quantity.high - quantity.low
        own = rng.normal(0, 1, n_coils)[coil] if by_coil else rng.normal(0, 1, n)
        z = 0.8 * strength[by_coil] + 0.6 * own if name in ("rm_mpa", "rp02_mpa") else own
        z = z + rng.normal(0, 0.02, n) if by_coil else z
        values[name] = quantity.low + span * rng.uniform(0.25, 0.85) + span * rng.uniform(0.05, 0.15) * z
    return values


def _settings(structure: Structure, campaign: np.ndarray, pull: float, rng: np.random.Generator) -> dict:
    """Settings per campaign, in their steps, in a production window at the upper side of the DoE range and
    partly beyond it (``pull`` in 0..1 moves the windows toward the DoE's centre: a redraw with more support)."""
    n, n_campaigns = len(campaign), campaign.max() + 1
    values = {}
    for name in of_role(SETTING, structure.inputs):
        quantity = QUANTITIES[name]
        span = quantity.high - quantity.low
        centre = quantity.low + span * (0.5 + (1.0 - pull) * rng.uniform(0.2, 0.9))
        levels = centre + span * rng.uniform(0.1, 0.3) * rng.uniform(-1, 1, n_campaigns)
        if quantity.step:
            levels = np.round(levels / quantity.step) * quantity.step
        values[name] = levels[campaign] + rng.normal(0, 0.01 * span, n)
    return values


def make_production(structure: Structure, rng: np.random.Generator, pull: float = 0.0):
    """Parts in production order (canonical names, every physical quantity) and the hidden quantities."""
    n = structure.n
    time = _timeline(n, rng)
    start = pd.Timestamp("2025-01-06 06:00:00") + pd.Timedelta(days=int(rng.integers(0, 365)))
    stamps = start + pd.to_timedelta(np.round(time["elapsed"]), unit="s")
    # ambient: a daily cycle, weather per day and a seasonal trend (kept apart: a cause no column logs)
    hour = stamps.hour.to_numpy() + stamps.minute.to_numpy() / 60.0
    days = ((stamps - pd.Timestamp("2025-01-01")).total_seconds() / 86400.0).to_numpy()
    seasonal = rng.uniform(4, 9) * np.sin(2 * np.pi * (days - 110.0) / 365.25)
    weather = rng.normal(0, 1.5, int(days[-1] - days[0]) + 2)[np.floor(days - days[0]).astype(int)]
    daily = rng.uniform(2, 6) * np.sin(2 * np.pi * (hour - 10.0) / 24.0)
    ambient = rng.uniform(14, 20) + seasonal + daily + weather + rng.normal(0, 0.3, n)
    coil = _segments(n, structure.n_coils, rng)
    campaign = coil if structure.relation == "equal" else _segments(n, structure.n_campaigns, rng)
    settings = _settings(structure, campaign, pull, rng)
    shift_of = time["shift_of"]
    warm = rng.uniform(15, 28, shift_of.max() + 1)[shift_of]
    if "press_speed_spm" in settings:  # a faster press warms its die more
        warm = warm + 0.8 * (settings["press_speed_spm"] - 14.0)
    tau = rng.uniform(40, 120, shift_of.max() + 1)[shift_of] * 60.0
    thermal = {
        "die_temp_c": ambient + 2.0 + warm * (1.0 - np.exp(-time["in_shift"] / tau)) + rng.normal(0, 0.5, n),
        "ambient_temp_c": ambient,
        "oil_temp_c": ambient + 4.0 + 0.6 * warm * (1.0 - np.exp(-time["in_shift"] / (2.5 * tau))),
    }
    physical = {**_material(structure, coil, rng), **thermal, **settings}
    frame = pd.DataFrame({name: physical[name] for name in structure.physical}).round(4)
    hidden = {**time, "stamps": stamps, "seasonal": seasonal, "coil": coil, "campaign": campaign}
    return frame, {**hidden, "elapsed_h": time["elapsed"] / 3600.0}


def make_doe(structure: Structure, simulator: Callable, rng: np.random.Generator) -> pd.DataFrame:
    """A Latin hypercube over the inputs' DoE ranges (plant names), simulated with the FE code's scatter."""
    inputs = list(structure.inputs)
    sampler = qmc.LatinHypercube(d=len(inputs), optimization="random-cd", seed=rng)
    low, high = [QUANTITIES[c].low for c in inputs], [QUANTITIES[c].high for c in inputs]
    doe = pd.DataFrame(
        qmc.scale(sampler.random(structure.n_doe), low, high), columns=[structure.names[c] for c in inputs]
    )
    doe[structure.names["target"]] = simulator(doe) + rng.normal(0.0, rng.uniform(0.3, 1.2), structure.n_doe)
    return doe.round(4)


@dataclass
class StructureCase(PlantCase):
    """A drawn plant with its structure (the effect's kind and size, coils against campaigns, per-coil properties in
    canonical names, DoE size) and its truth taken apart: ``truth == simulator(production) + offset + effect``."""

    effect_kind: str = ""
    size_ratio: float = 0.0
    coil_vs_campaign: str = ""
    per_coil: tuple[str, ...] = ()
    n_doe: int = 0
    n_inputs: int = 0
    cause_ratios: tuple[float, ...] = ()  # each cause's std over the surrogate's uncertainty, in support
    surrogate_std: float = 0.0
    offset: float = 0.0
    simulator: Callable | None = None
    effect: np.ndarray | None = None
    support: np.ndarray | None = None
    campaign: np.ndarray | None = None

    @property
    def below_limit(self) -> bool:
        """No cause above the detection limit: the right answer is that nothing is significant."""
        return self.effect_kind != "none" and self.expected.cause is None


@dataclass
class _Plant:
    """A plant being drawn: its parts (canonical names), hidden quantities, support and column names."""

    frame: pd.DataFrame
    hidden: dict
    inside: np.ndarray
    structure: Structure
    rng: np.random.Generator
    names: dict[str, str]

    def values(self, column: str) -> np.ndarray:
        return self.frame[column].to_numpy(float)


# one hidden cause: its shape (scaled to its size when drawn), its expected report, its words, its columns, and
# the column on the same time line it may not be told from (name, values; wear in strokes, a season in hours)
_Cause = namedtuple("_Cause", "shape expected text columns twin", defaults=(None,))


def _unit(values: np.ndarray, inside: np.ndarray) -> np.ndarray:
    centred = values - values[inside].mean()
    return centred / centred[inside].std()


def _pick_column(plant: _Plant, form: str, exclude: set[str]) -> str:
    """A physical column showing enough levels in support for the form (a parabola or a bend needs more)."""
    needed = 12 if form in ("quadratic", "sigmoid") else 6
    seen = {c: plant.values(c)[plant.inside] for c in plant.structure.physical if c not in exclude}
    # levels: how many of 50 equal bins over its range a column's values occupy
    usable = [c for c, x in seen.items() if len(np.unique(np.round((x - x.min()) / (np.ptp(x) or 1) * 50))) >= needed]
    return str(plant.rng.choice(usable))


def _column_cause(plant: _Plant, form: str, exclude: set[str], column: str | None = None) -> _Cause:
    """A single column's effect of a form: linear, quadratic (vertex inside), sigmoid (its change seen), step."""
    column = column or _pick_column(plant, form, exclude)
    x, name = plant.values(column), plant.names[column]
    seen = x[plant.inside]
    at = float(np.quantile(seen, plant.rng.uniform(0.3, 0.7)))
    spread = float(np.subtract(*np.quantile(seen, [0.95, 0.05]))) or float(np.ptp(seen))
    width = plant.rng.uniform(0.15, 0.4) * spread / SIGMOID_SPAN  # the 10-90% change spans 15-40% of the values
    shapes = {
        "linear": (x, ("linear",), f"linear in {name}"),
        "quadratic": ((x - at) ** 2, ("quadratic",), f"parabola in {name} with its vertex at {at:.4g}"),
        "sigmoid": (expit((x - at) / width), ("sigmoid",), f"saturating change around {name} = {at:.4g}"),
        "step": ((x >= at).astype(float), ("step", "sigmoid"), f"step when {name} >= {at:.4g}"),
    }
    shape, forms, text = shapes[form]
    return _Cause(shape, Expected(name, forms, monotone=form == "linear"), text, (column,))


def _product_cause(plant: _Plant, exclude: set[str]) -> _Cause:
    """A per-coil material input (any material input where none is per coil) times a setting."""
    inputs = [c for c in plant.structure.inputs if c not in exclude]
    materials = [c for c in of_role(MATERIAL, inputs) if c in plant.structure.per_coil] or of_role(MATERIAL, inputs)
    a, b = str(plant.rng.choice(materials)), str(plant.rng.choice(of_role(SETTING, inputs)))
    shape = _unit(plant.values(a), plant.inside) * _unit(plant.values(b), plant.inside)
    name = f"{plant.names[a]}*{plant.names[b]}"
    return _Cause(shape, Expected(name, ("product",)), f"interaction {name}", (a, b))


def _time_line_cause(plant: _Plant, kind: str) -> _Cause:
    """Wear (linear in strokes); a seasonal trend in calendar time that no logged column holds (the ambient's slow
    part alone); an unlogged shift: an offset change at some time, a step in time and so in strokes."""
    names, hours, strokes = plant.names, plant.hidden["elapsed_h"], plant.hidden["strokes"].astype(float)
    # a line that never stands idle in support: strokes are calendar time on another scale (families' rule)
    never_idle = np.corrcoef(hours[plant.inside], strokes[plant.inside])[0, 1] > families.NEVER_IDLE_CORRELATION
    if kind == "wear":
        expected = Expected(names["strokes"], ("linear",), monotone=True, alias=names["time"] if never_idle else None)
        return _Cause(
            strokes, expected, f"tool wear linear in {names['strokes']}", ("strokes",), (names["time"], hours)
        )
    if kind == "seasonal":
        forms, alias = ("linear", "quadratic", "sigmoid"), names["strokes"] if never_idle else None
        shape, text = plant.hidden["seasonal"], "a seasonal trend in calendar time that no logged column holds"
        twin = (names["strokes"], strokes)
    else:
        at = float(np.quantile(hours[plant.inside], plant.rng.uniform(0.3, 0.7)))
        forms, alias, twin = ("step", "sigmoid"), names["strokes"], None
        shape, text = (hours >= at).astype(float), f"an unlogged shift of the offset after {at:.1f} h"
    expected = Expected(names["time"], forms, monotone=kind == "seasonal", alias=alias)
    return _Cause(shape, expected, text, ("time",), twin)


def twin_misfit(shape: np.ndarray, twin: np.ndarray, inside: np.ndarray) -> float:
    """The std of what the diagnosis' parabola in the twin column leaves of a cause's shape in support, per unit of
    the shape's std: times the cause's size (in the surrogate's uncertainty), how far the two columns' fits differ."""
    x, y = twin[inside].astype(float), _unit(shape, inside)[inside]
    return float(np.std(y - fit_form("quadratic", x, y).predict(x)))


def _with_twin(cause: _Cause, ratio: float, inside: np.ndarray) -> Expected:
    """A cause on the time line whose twin column reproduces it within the detection limit (the diagnosis'
    tolerance for two columns that predict the same) may be named by either (``Expected.twin``): a slow season
    over a few weeks is a parabola in strokes too, idle spells or not."""
    if cause.twin is None or cause.expected.alias is not None:
        return cause.expected
    name, values = cause.twin
    indistinct = twin_misfit(cause.shape, values, inside) * ratio < DETECTION_LIMIT
    return replace(cause.expected, twin=name) if indistinct else cause.expected


def _cause(kind: str, plant: _Plant, exclude: set[str]) -> _Cause:
    if kind in COLUMN_FORMS:
        return _column_cause(plant, kind, exclude)
    if kind == "ambient":  # the issue's plant: a parabola in the hall temperature
        return _column_cause(plant, str(plant.rng.choice(["linear", "quadratic"])), exclude, "ambient_temp_c")
    if kind == "product":
        return _product_cause(plant, exclude)
    if kind == "coil":
        coil, name = plant.hidden["coil"], plant.names["coil"]
        text = f"an offset per coil ({name}) that no logged column explains"
        return _Cause(plant.rng.normal(0, 1, coil.max() + 1)[coil], Expected(name, ("group",)), text, ())
    return _time_line_cause(plant, kind)


# causes of several-cause plants, those on a column of their own first so that a column form picks another
SEVERAL_POOL = ("product", "ambient", "wear", "linear", "quadratic", "sigmoid", "step")


def _causes(kind: str, plant: _Plant) -> list[_Cause]:
    """One cause of ``kind``, or two or three of different kinds on different columns (none for a null plant)."""
    kinds = [kind] if kind in COLUMN_FORMS + OTHER_KINDS else []
    if kind in ("two_causes", "three_causes"):
        picked = plant.rng.choice(len(SEVERAL_POOL), 2 if kind == "two_causes" else 3, replace=False)
        kinds = [SEVERAL_POOL[index] for index in sorted(picked)]
    causes, used = [], set()
    for each in kinds:
        causes.append(_cause(each, plant, used))
        used |= set(causes[-1].columns)
    return causes


def _sizes(count: int, rng: np.random.Generator) -> np.ndarray:
    """Each cause's std over the surrogate's uncertainty: a log-uniform total shared out (Dirichlet)."""
    total = float(np.exp(rng.uniform(*np.log(SIZE_RANGE))))
    return total * np.sqrt(rng.dirichlet(np.full(count, 2.0))) if count > 1 else np.array([total])


def _expected(causes: list[_Cause], ratios: np.ndarray, inside: np.ndarray) -> Expected:
    """The causes above the detection limit, the largest first; ``Expected(None)`` where there is none."""
    above = [_with_twin(causes[i], ratios[i], inside) for i in np.argsort(-ratios) if ratios[i] >= DETECTION_LIMIT]
    return replace(above[0], also=tuple(above[1:])) if above else Expected(None)


def _supported(structure: Structure, gate: KNNSupportGate, rng: np.random.Generator):
    """Production with enough parts and coils in support; each redraw pulls the settings toward the DoE's centre."""
    for attempt in range(30):
        frame, hidden = make_production(structure, rng, pull=attempt / 29)
        inside = gate.predict(frame[list(structure.inputs)].rename(columns=structure.names))
        if inside.mean() >= MIN_IN_SUPPORT and len(np.unique(hidden["coil"][inside])) >= MIN_COILS_IN_SUPPORT:
            break
    return frame, hidden, inside


def surrogate_uncertainty(doe, production, inputs, target: str, inside, seed: int) -> float:
    """The surrogate's own uncertainty over the in-support parts, as the workflow computes it."""
    surrogate = GPRSurrogate(n_restarts=1, random_state=seed).fit(doe[inputs], doe[target])
    _, std = surrogate.predict(production.loc[inside, inputs], return_std=True)
    return surrogate_latent_std(std, surrogate.noise_std_)


def _logged(plant: _Plant, measured: np.ndarray) -> pd.DataFrame:
    """The production log: time, strokes, coil, shift, the logged quantities, the inputs, the measured target."""
    names, hidden, rng = plant.names, plant.hidden, plant.rng
    day_first = rng.random() < 0.5
    stamps = hidden["stamps"].strftime("%d.%m.%Y %H:%M:%S" if day_first else "%Y-%m-%d %H:%M:%S")
    shifts = np.array(SHIFT_LABELS[int(rng.integers(0, len(SHIFT_LABELS)))])
    # coil ids in one of several styles, never bare numbers (a number would be read as a quantity)
    numbers = int(rng.integers(1000, 90000)) + np.arange(hidden["coil"].max() + 1) * int(rng.integers(1, 4))
    style = COIL_STYLES[int(rng.integers(0, len(COIL_STYLES)))]
    labels = np.array([style.format(k=int(k), year=2025 + k % 2, lot=k % 97) for k in numbers])
    log = {
        names["time"]: np.asarray(stamps),
        names["strokes"]: hidden["strokes"],
        names["coil"]: labels[hidden["coil"]],
        names["shift"]: shifts[hidden["shift_of"] % 3],
    }
    production = pd.concat([pd.DataFrame(log), plant.frame.rename(columns=names)], axis=1)
    production[names["target"]] = measured
    return production


def draw_structure_plant(kind: str, seed: int, n_production: int | None = None) -> StructureCase:
    """A plant of a randomly drawn structure with a hidden effect of ``kind``, its size drawn against the
    surrogate's uncertainty; the same (kind, seed) gives the same frames."""
    if kind not in KINDS:
        raise ValueError(f"unknown effect kind {kind!r}; kinds: {', '.join(KINDS)}")
    rng = np.random.default_rng([seed, KINDS.index(kind), 27])
    structure = draw_structure(rng, n_production)
    names, inputs = structure.names, [structure.names[c] for c in structure.inputs]
    simulator = _simulator(list(structure.inputs), names, rng)
    doe = make_doe(structure, simulator, rng)
    gate = KNNSupportGate(**section_defaults("gate")).fit(doe[inputs])  # the workflow's gate
    frame, hidden, inside = _supported(structure, gate, rng)
    plant = _Plant(frame, hidden, inside, structure, rng, names)
    production = frame.rename(columns=names)
    latent = surrogate_uncertainty(doe, production, inputs, names["target"], inside, seed)
    causes = _causes(kind, plant)
    ratios = _sizes(len(causes), rng) if causes else np.zeros(0)
    signs = rng.choice([-1.0, 1.0], len(causes))
    effect = sum(
        (_unit(c.shape, inside) * r * s * latent for c, r, s in zip(causes, ratios, signs)), np.zeros(len(frame))
    )
    offset, noise = float(rng.choice([-1.0, 1.0]) * rng.uniform(3, 15)), float(rng.uniform(0.8, 1.6))
    truth = simulator(production) + offset + effect
    measured = np.round(truth + rng.normal(0, noise, len(truth)), 3)
    expected = _expected(causes, ratios, inside)
    size = float(effect[inside].std() / latent)
    return StructureCase(
        kind,
        _description(kind, causes, ratios, latent, expected, size),
        doe,
        _logged(plant, measured),
        truth,
        inputs,
        names["target"],
        expected,
        noise,
        _confounding(structure, hidden),
        dict(names),
        effect_kind=kind,
        size_ratio=size,
        coil_vs_campaign=structure.relation,
        per_coil=structure.per_coil,
        n_doe=structure.n_doe,
        n_inputs=len(inputs),
        cause_ratios=tuple(float(r) for r in ratios),
        hidden_causes=tuple(c.expected.cause for c in causes),
        surrogate_std=latent,
        offset=offset,
        simulator=simulator,
        effect=effect,
        support=inside,
        campaign=hidden["campaign"],
    )


def _description(kind, causes, ratios, latent: float, expected: Expected, size: float) -> str:
    if not causes:
        return "no hidden effect"
    parts = [f"{c.text}: {r * latent:.2f} mm std in support ({r:.2f}x the surrogate's)" for c, r in zip(causes, ratios)]
    text = f"{kind}: " + "; ".join(parts) + f"; the surrogate's own uncertainty {latent:.2f} mm"
    if expected.cause is None:
        text += f"; below the detection limit ({size:.2f}x): nothing can be named"
    return text


def _confounding(structure: Structure, hidden: dict) -> str:
    n, relation = structure.n, "as long as" if structure.relation == "equal" else f"{structure.relation} than"
    return (
        f"coils {relation} the setting campaigns (~{n / structure.n_coils:.0f} vs ~{n / structure.n_campaigns:.0f} "
        f"parts), shifts of ~{n / (hidden['shift_of'].max() + 1):.0f} parts; per coil: {', '.join(structure.per_coil)}"
    )
