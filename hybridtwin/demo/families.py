"""Plant families the demo generator does not draw: other names, rhythms, confounding and numbers of causes.

The demo plant (:mod:`.plant`) runs long shifts with two setting campaigns each and coils of
~1,800 blanks. A method tuned on it can learn its habits. These plants are drawn another
way, with every habit drawn at random per plant:

* column names from several vocabularies (English, German, abbreviations), timestamps
  in ISO or day-first format, coil ids in several styles;
* three 8-hour shifts with breaks and idle days; a die that warms over each shift;
* coils of a few hundred blanks, each with its own material and a logged lubricant
  film (a per-coil property with a mild effect of its own);
* shims set in discrete steps and cushion forces re-adjusted in campaigns that are
  either shorter than a coil or span several coils (and then change at coil changes),
  so that a coil id carries the die temperature, the setting and the material at once.

Each family hides a different discrepancy (:data:`FAMILIES`); what the diagnosis must
report is returned with the data (:class:`Expected`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.stats import qmc

from hybridtwin.demo import plant as demo
from hybridtwin.paper.gate import KNNSupportGate

# canonical (demo) input name -> names a plant might use for it
INPUT_VOCABULARY = {
    "thickness_mm": ("thickness_mm", "t0", "blechdicke", "gauge_mm"),
    "rm_mpa": ("rm_mpa", "Rm", "uts_mpa", "zugfestigkeit"),
    "rp02_mpa": ("rp02_mpa", "Rp02", "ys_mpa", "dehngrenze"),
    "r_n": ("r_n", "rbar", "r_value", "anisotropie"),
    "die_temp_c": ("die_temp_c", "T_die", "werkzeugtemp", "die_temperature"),
    "ambient_temp_c": ("ambient_temp_c", "T_amb", "hallentemp", "air_temp"),
    "shim20_mm": ("shim20_mm", "shim_20", "S20", "distanz20"),
    "shim21_mm": ("shim21_mm", "shim_21", "S21", "distanz21"),
    "cushion_c1_kn": ("cushion_c1_kn", "C1", "kissen1", "pin_force_1"),
    "cushion_c2_kn": ("cushion_c2_kn", "C2", "kissen2", "pin_force_2"),
    "cushion_c3_kn": ("cushion_c3_kn", "C3", "kissen3", "pin_force_3"),
    "cushion_c4_kn": ("cushion_c4_kn", "C4", "kissen4", "pin_force_4"),
}
LOG_VOCABULARY = {
    "target": ("draw_in_mm", "einzug", "drawin_crit", "DI"),
    "time": ("timestamp", "zeitstempel", "datetime", "time"),
    "strokes": ("stroke_counter", "hubzaehler", "press_strokes", "die_hits"),
    "coil": ("coil_id", "bund_nr", "coil", "lot"),
    "shift": ("shift", "schicht", "crew", "team"),
    "lubricant": ("oil_film_g_m2", "beoelung", "lube_gm2", "oil"),
    "copy": ("die_temp_ir", "T_die_2", "werkzeugtemp_ir", "die_temperature_b"),
}

FAMILIES = ("temperature", "shim_step", "coil_property", "coil_itself", "two_causes", "time_drift", "near_copy", "null")


@dataclass(frozen=True)
class Expected:
    """What the diagnosis must report: a cause (or None: nothing significant) and its form family.

    ``also``: further causes that must be among the chosen ones (two-cause plants);
    ``alias``: a column the cause must be reported as not told apart from;
    ``twin``: a column on the same time line that reproduces the cause within the detection limit (a season over a
    few weeks and a parabola in strokes): it may be named in the cause's place, reported beside it or not (the
    data may tell the two apart by the idle spells, or may not).
    """

    cause: str | None
    forms: tuple[str, ...] = ()
    monotone: bool = False  # any form whose fitted term is monotone over the data (a trend)
    also: tuple["Expected", ...] = ()
    alias: str | None = None
    twin: str | None = None


@dataclass
class PlantCase:
    """A generated plant, ready for the method: data, names, the noise-free truth and the right answer."""

    family: str
    description: str
    doe: pd.DataFrame
    production: pd.DataFrame
    truth: np.ndarray
    inputs: list[str]
    target: str
    expected: Expected
    noise: float
    confounding: str = ""
    names: dict[str, str] = field(default_factory=dict)
    hidden_causes: tuple[str, ...] = ()  # every cause put in, those below the detection limit too


DOE_LOW = np.array([v[0] for v in demo.INPUTS.values()])
DOE_HIGH = np.array([v[1] for v in demo.INPUTS.values()])


def _names(rng: np.random.Generator) -> dict[str, str]:
    """Canonical name -> this plant's column name."""
    return {key: str(rng.choice(options)) for key, options in {**INPUT_VOCABULARY, **LOG_VOCABULARY}.items()}


def _timeline(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Elapsed seconds per part, the shift each part belongs to, seconds since its shift started, and strokes.

    Three 8-hour shifts with a break at each change; after every few shifts the line
    stands idle for half a day to a few days; set-up strokes between shifts.
    """
    spm = rng.uniform(10, 18)
    cycle = 60.0 / spm * (1.0 + rng.exponential(0.05, n))
    per_shift = int(8 * 3600 / cycle.mean() * rng.uniform(0.7, 0.95))
    shift_of = np.arange(n) // per_shift
    n_shifts = shift_of[-1] + 1
    gaps = rng.uniform(0.25, 1.0, n_shifts) * 3600.0
    idle = rng.random(n_shifts) < 1.0 / rng.uniform(3, 6)
    gaps[idle] += rng.uniform(12, 72, idle.sum()) * 3600.0
    gaps[0] = 0.0
    in_shift = np.concatenate([np.cumsum(cycle[shift_of == s]) - cycle[shift_of == s][0] for s in range(n_shifts)])
    shift_length = np.array([in_shift[shift_of == s].max() for s in range(n_shifts)])
    shift_start = np.cumsum(np.r_[0.0, shift_length[:-1]] + gaps)
    elapsed = shift_start[shift_of] + in_shift
    strokes = 100_000 + np.arange(n) + np.cumsum(rng.integers(5, 200, n_shifts))[shift_of]
    return elapsed, shift_of, in_shift, strokes


def _coils(n: int, rng: np.random.Generator) -> np.ndarray:
    """Coil index per part: coils of a few hundred blanks each."""
    lengths = rng.integers(150, 600, n // 150 + 2)
    return np.repeat(np.arange(len(lengths)), lengths)[:n]


def _campaigns(n: int, coil: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, str]:
    """Campaign index per part: either shorter than a coil, or spanning several coils (changed at coil changes)."""
    if rng.random() < 0.5:
        lengths = rng.integers(60, 250, n // 60 + 2)
        return np.repeat(np.arange(len(lengths)), lengths)[:n], "setting campaigns shorter than a coil"
    coils_per_campaign = rng.integers(2, 6, coil.max() + 2)
    campaign_of_coil = np.repeat(np.arange(len(coils_per_campaign)), coils_per_campaign)[: coil.max() + 1]
    return campaign_of_coil[coil], "coils shorter than a setting campaign (settings changed at coil changes)"


def make_production(n: int, rng: np.random.Generator) -> tuple[pd.DataFrame, dict]:
    """Parts with canonical column names, plus the hidden per-part quantities the effects use."""
    elapsed, shift_of, in_shift, strokes = _timeline(n, rng)
    start = pd.Timestamp("2025-01-06 06:00:00") + pd.Timedelta(days=int(rng.integers(0, 300)))
    stamps = start + pd.to_timedelta(np.round(elapsed), unit="s")
    hour = stamps.hour.to_numpy() + stamps.minute.to_numpy() / 60.0
    day = ((stamps - stamps[0]).days).to_numpy()
    ambient = (
        rng.uniform(17, 24)
        + rng.uniform(3, 7) * np.sin(2 * np.pi * (hour - 10.0) / 24.0)
        + rng.normal(0, 2.0, day.max() + 1)[day]
        + rng.normal(0, 0.3, n)
    )
    coil = _coils(n, rng)
    material, lubricant = _material(n, coil, rng)
    campaign, confounding = _campaigns(n, coil, rng)
    settings = _settings(n, campaign, rng)
    warm = rng.uniform(15, 30, shift_of.max() + 1)[shift_of] + 0.15 * (settings[:, 2:].mean(axis=1) - 300.0)
    tau = rng.uniform(40, 120, shift_of.max() + 1)[shift_of] * 60.0
    die = ambient + 2.0 + warm * (1.0 - np.exp(-in_shift / tau)) + rng.normal(0, 0.5, n)
    frame = pd.DataFrame(
        {**material, "die_temp_c": die, "ambient_temp_c": ambient, **dict(zip(demo.INPUT_NAMES[6:], settings.T))}
    ).round(4)
    hidden = {
        "elapsed_h": elapsed / 3600.0,
        "stamps": stamps,
        "strokes": strokes,
        "coil": coil,
        "shift_of": shift_of,
        "hour": hour,
        "lubricant": lubricant,
        "confounding": confounding,
    }
    return frame, hidden


def _material(n: int, coil: np.ndarray, rng: np.random.Generator) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Each coil's own material (some coils stronger) and lubricant film, per part."""
    n_coils = coil.max() + 1
    stronger = rng.random(n_coils) < rng.uniform(0.1, 0.35)
    coil_rm = rng.normal(rng.uniform(325, 345), 9, n_coils) + 25.0 * stronger
    coil_rp = rng.uniform(200, 215) + 0.8 * (coil_rm - coil_rm.mean()) + rng.normal(0, 4.0, n_coils)
    rm = coil_rm[coil] + rng.normal(0, 2.0, n)
    rp = coil_rp[coil] + rng.normal(0, 1.8, n)
    thickness = rng.normal(rng.uniform(0.70, 0.76), 0.01, n_coils)[coil] + rng.normal(0, 0.003, n)
    r_n = rng.normal(rng.uniform(1.55, 1.8), 0.05, n_coils)[coil] + rng.normal(0, 0.01, n)
    lubricant = np.round(rng.uniform(0.8, 2.2, n_coils), 2)[coil]
    return {"thickness_mm": thickness, "rm_mpa": rm, "rp02_mpa": rp, "r_n": r_n}, lubricant


def _settings(n: int, campaign: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Shims (in 0.05 mm steps) and cushion forces per part: one setting per campaign, with scatter."""
    n_campaigns = campaign.max() + 1
    shim_low = rng.uniform(0.35, 0.55, 2)
    shims = shim_low + 0.05 * rng.integers(0, 7, (n_campaigns, 2))
    cushion_center = rng.uniform(330, 360)
    cushions = cushion_center + rng.uniform(-40, 40, (n_campaigns, 4))
    return np.column_stack([shims, cushions])[campaign] + rng.normal(0, [0.004, 0.004, 2, 2, 2, 2], (n, 6))


def make_doe(n: int, rng: np.random.Generator, fe_scatter: float) -> pd.DataFrame:
    sampler = qmc.LatinHypercube(d=len(demo.INPUTS), optimization="random-cd", seed=rng)
    doe = pd.DataFrame(qmc.scale(sampler.random(n), DOE_LOW, DOE_HIGH), columns=demo.INPUT_NAMES)
    doe["__target"] = demo.simulator(doe) + rng.normal(0.0, fe_scatter, n)
    return doe.round(4)


def _coil_labels(n_coils: int, rng: np.random.Generator) -> np.ndarray:
    style = int(rng.integers(0, 3))
    first = int(rng.integers(1000, 90000))
    numbers = first + np.arange(n_coils) * int(rng.integers(1, 4))
    if style == 0:
        return np.array([f"K{k:05d}" for k in numbers])
    if style == 1:
        return np.array([f"C-{2025 + k % 2}-{k:05d}" for k in numbers])
    return np.array([f"{k:06d}-B" for k in numbers])


def _timestamps(stamps: pd.DatetimeIndex, rng: np.random.Generator) -> np.ndarray:
    if rng.random() < 0.5:
        return np.asarray(stamps.strftime("%Y-%m-%d %H:%M:%S"))
    return np.asarray(stamps.strftime("%d.%m.%Y %H:%M:%S"))


def _scaled(values: np.ndarray, inside: np.ndarray, target_std: float) -> np.ndarray:
    """A linear effect in ``values`` whose signed spread over the in-support rows is ``target_std``."""
    centred = values - values[inside].mean()
    return centred * target_std / centred[inside].std()


# elapsed hours and strokes this correlated over the in-support parts: the line stood idle too little
# for a drift in one to differ from a drift in the other by more than ~5% of its size
NEVER_IDLE_CORRELATION = 0.999


def _never_idle(hours: np.ndarray, strokes: np.ndarray) -> bool:
    return float(np.corrcoef(hours, strokes.astype(float))[0, 1]) > NEVER_IDLE_CORRELATION


def draw_plant(
    family: str, seed: int, n_production: int | None = None, min_in_support: float = 0.07, n_doe: int = 67
) -> PlantCase:
    """A plant of ``family`` with its hidden effect, magnitudes and habits drawn from ``seed``."""
    if family not in FAMILIES:
        raise ValueError(f"unknown plant family {family!r}; families: {', '.join(FAMILIES)}")
    rng = np.random.default_rng([seed, FAMILIES.index(family), 11])
    n = int(n_production or rng.integers(20_000, 40_000))
    fe_scatter, noise = rng.uniform(1.0, 1.5), rng.uniform(1.0, 1.8)
    doe = make_doe(n_doe, rng, fe_scatter)
    gate = KNNSupportGate().fit(doe[demo.INPUT_NAMES])
    for _ in range(30):  # a plant whose support holds enough parts and coils to learn from
        frame, hidden = make_production(n, rng)
        inside = gate.predict(frame[demo.INPUT_NAMES])
        if inside.mean() >= min_in_support and len(np.unique(hidden["coil"][inside])) >= 10:
            break
    draw = _Draw(frame, hidden, inside, _names(rng), float(rng.choice([-1.0, 1.0])), rng)
    # a mild effect of the per-coil lubricant film, below what can be told from the surrogate's error
    background = _scaled(hidden["lubricant"], inside, rng.uniform(0.2, 0.5)) if family != "null" else np.zeros(n)
    hidden_effect = EFFECTS[family](draw)
    if hidden_effect.background is not None:
        background = hidden_effect.background
    truth = demo.simulator(frame) + draw.sign * rng.uniform(5, 20) + hidden_effect.effect + background
    measured = np.round(truth + rng.normal(0, noise, n), 3)
    names = draw.names
    doe = doe.rename(columns={**{c: names[c] for c in demo.INPUT_NAMES}, "__target": names["target"]})
    return PlantCase(
        family,
        hidden_effect.text,
        doe,
        _logged(draw, measured, hidden_effect.copy),
        truth,
        [names[c] for c in demo.INPUT_NAMES],
        names["target"],
        hidden_effect.expected,
        float(noise),
        hidden["confounding"],
        names,
    )


@dataclass
class _Draw:
    """A plant being drawn: its parts, hidden quantities, support, column names, the effect's sign, the draws."""

    frame: pd.DataFrame
    hidden: dict
    inside: np.ndarray
    names: dict[str, str]
    sign: float
    rng: np.random.Generator

    def column(self, name: str) -> np.ndarray:
        return self.frame[name].to_numpy(float)


@dataclass
class _Effect:
    """A family's hidden effect per part, what the diagnosis must report, its words, and a near-copy sensor
    or a background effect where the family has its own."""

    effect: np.ndarray
    expected: Expected
    text: str
    copy: np.ndarray | None = None
    background: np.ndarray | None = None


def _sigmoid(draw: _Draw, column: str) -> tuple[np.ndarray, str]:
    x, rng = draw.column(column), draw.rng
    threshold = float(np.quantile(x[draw.inside], rng.uniform(0.35, 0.75)))
    amplitude, width = draw.sign * rng.uniform(8, 20), rng.uniform(2.0, 3.5)
    text = f"saturating change of {amplitude:+.1f} mm around {draw.names[column]} = {threshold:.1f} (width {width:.1f})"
    return amplitude / (1.0 + np.exp(-(x - threshold) / width)), text


def _temperature(draw: _Draw) -> _Effect:
    effect, text = _sigmoid(draw, "die_temp_c")
    return _Effect(effect, Expected(draw.names["die_temp_c"], ("sigmoid",)), text)


def _near_copy(draw: _Draw) -> _Effect:
    effect, text = _sigmoid(draw, "die_temp_c")
    names = draw.names
    copy = draw.column("die_temp_c") + draw.rng.normal(0, 0.1, len(effect))
    text += f"; {names['copy']} is a second sensor reading the same within 0.1"
    return _Effect(effect, Expected(names["die_temp_c"], ("sigmoid",), alias=names["copy"]), text, copy)


def _two_causes(draw: _Draw) -> _Effect:
    effect, text = _sigmoid(draw, "die_temp_c")
    names, inside = draw.names, draw.inside
    wear = _scaled(draw.hidden["strokes"].astype(float), inside, draw.sign * draw.rng.uniform(1.8, 3.0))
    wear_expected = Expected(names["strokes"], ("linear",), monotone=True)
    text += f", and a wear drift of {wear[inside].std():.1f} mm (std in support) along {names['strokes']}"
    return _Effect(effect + wear, Expected(names["die_temp_c"], ("sigmoid",), also=(wear_expected,)), text)


def _shim_step(draw: _Draw) -> _Effect:
    column = str(draw.rng.choice(["shim20_mm", "shim21_mm"]))
    x, inside, name = draw.column(column), draw.inside, draw.names[column]
    levels = np.unique(np.round(x[inside], 2))
    threshold = float(np.quantile(x[inside], draw.rng.uniform(0.3, 0.7)))
    amplitude = draw.sign * draw.rng.uniform(5, 8)
    text = f"step of {amplitude:+.1f} mm when {name} >= {threshold:.3f} ({len(levels)} levels in support)"
    return _Effect(np.where(x >= threshold, amplitude, 0.0), Expected(name, ("step", "sigmoid")), text)


def _coil_property(draw: _Draw) -> _Effect:
    effect = _scaled(draw.hidden["lubricant"], draw.inside, draw.sign * draw.rng.uniform(1.8, 3.0))
    name = draw.names["lubricant"]
    text = f"linear effect of the per-coil {name}, {effect[draw.inside].std():.1f} mm std in support"
    return _Effect(effect, Expected(name, ("linear",), monotone=True), text, background=np.zeros(len(effect)))


def _coil_itself(draw: _Draw) -> _Effect:
    coil = draw.hidden["coil"]
    offsets = draw.rng.normal(0.0, draw.rng.uniform(2.5, 4.0), coil.max() + 1)
    text = f"an offset per coil that no logged quantity explains, sd {offsets.std():.1f} mm"
    return _Effect(offsets[coil], Expected(draw.names["coil"], ("group",)), text)


def _time_drift(draw: _Draw) -> _Effect:
    hidden, inside, names = draw.hidden, draw.inside, draw.names
    effect = _scaled(hidden["elapsed_h"], inside, draw.sign * draw.rng.uniform(1.8, 3.0))
    text = (
        f"a drift in calendar time (also while the line stands idle), {effect[inside].std():.1f} mm std "
        "in support, that no logged quantity explains"
    )
    if not _never_idle(hidden["elapsed_h"][inside], hidden["strokes"][inside]):
        return _Effect(effect, Expected(names["time"], ("linear",), monotone=True), text)
    # without idle time the stroke counter is calendar time on another scale: no data can tell them apart
    text += f"; the line never stands idle in support, so {names['strokes']} is time on another scale"
    return _Effect(effect, Expected(names["time"], ("linear",), monotone=True, alias=names["strokes"]), text)


def _null(draw: _Draw) -> _Effect:
    return _Effect(np.zeros(len(draw.inside)), Expected(None), "no hidden effect")


EFFECTS = {
    "temperature": _temperature,
    "shim_step": _shim_step,
    "coil_property": _coil_property,
    "coil_itself": _coil_itself,
    "two_causes": _two_causes,
    "time_drift": _time_drift,
    "near_copy": _near_copy,
    "null": _null,
}


def _logged(draw: _Draw, measured: np.ndarray, copy: np.ndarray | None) -> pd.DataFrame:
    """The production log as the plant writes it: its log columns, then the inputs, then the measured target."""
    names, hidden = draw.names, draw.hidden
    production = draw.frame.rename(columns={c: names[c] for c in demo.INPUT_NAMES})
    coil_labels = _coil_labels(hidden["coil"].max() + 1, draw.rng)
    log_columns = {
        names["time"]: _timestamps(hidden["stamps"], draw.rng),
        names["strokes"]: hidden["strokes"],
        names["coil"]: coil_labels[hidden["coil"]],
        names["shift"]: np.array(["A", "B", "C"])[hidden["shift_of"] % 3],
        names["lubricant"]: hidden["lubricant"],
    }
    if copy is not None:
        log_columns[names["copy"]] = np.round(copy, 3)
    order = list(log_columns) + list(production.columns)
    production = pd.concat([pd.DataFrame(log_columns), production], axis=1)[order]
    production[names["target"]] = measured
    return production
