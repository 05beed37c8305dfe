"""Seeded demo plant: an AutoForm-like simulator, a production line and matched trials.

The demo stands in for a real plant so the workflow can run end to end and so
the diagnosis can be tested against a known answer. Three data sets come out,
each with the same 12 process and material inputs as the paper:

* ``doe``: a Latin-hypercube DoE over broad ranges, the *simulated* draw-in
  ``simulator(x)`` plus the FE code's numerical scatter;
* ``production``: parts as a press line makes them: runs (shifts) separated by
  gaps, a die that warms up within each run, a daily ambient cycle, coils with
  correlated Rm/Rp0.2, press-setting campaigns (some outside the DoE ranges),
  a die stroke counter, and the *measured* draw-in
  ``plant(x) = simulator(x) + offset + hidden_effect + measurement noise``;
* ``matched``: trials where the simulator was run at the trial's exact inputs.

The noise-free plant truth is returned beside the data so that benchmarks can
score predictions against the truth and the noise floor.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.stats import qmc

from hybridtwin.io.config import section_defaults

TARGET = "draw_in_mm"
MATCHED_SIMULATED = "draw_in_sim_mm"
MATCHED_MEASURED = "draw_in_meas_mm"

# name: (DoE low, DoE high, simulator sensitivity in mm over the DoE half-range)
INPUTS: dict[str, tuple[float, float, float]] = {
    "thickness_mm": (0.62, 0.78, 5.0),
    "rm_mpa": (280.0, 360.0, -3.0),
    "rp02_mpa": (160.0, 230.0, -4.0),
    "r_n": (1.45, 2.15, 3.0),
    "die_temp_c": (15.0, 52.0, -2.5),
    "ambient_temp_c": (10.0, 35.0, -0.8),
    "shim20_mm": (0.0, 0.6, 8.0),
    "shim21_mm": (0.0, 0.6, 6.5),
    "cushion_c1_kn": (150.0, 350.0, -7.0),
    "cushion_c2_kn": (150.0, 350.0, -5.5),
    "cushion_c3_kn": (150.0, 350.0, -5.0),
    "cushion_c4_kn": (150.0, 350.0, -4.0),
}
INPUT_NAMES = list(INPUTS)
NOMINAL_DRAW_IN_MM = 48.0
SENSITIVITY_SCALE = 1.4
STROKES_PER_MINUTE = 16.0


@dataclass(frozen=True)
class HiddenEffect:
    """A discrepancy the FE model lacks, added to the plant on top of the offset.

    form: ``none``; ``sigmoid`` (saturating: amplitude * logistic((x - threshold)/width));
    ``step`` (amplitude once x >= threshold); ``linear`` (amplitude per unit of x,
    centred on the column's mean); ``group`` (an offset per level with standard
    deviation ``amplitude``); ``product`` (amplitude * z(a) * z(b), z standardised
    over the DoE ranges).
    """

    form: str = "none"
    column: str = ""
    amplitude: float = 0.0
    threshold: float = 0.0
    width: float = 1.0
    column_b: str = ""

    def describe(self) -> str:
        if self.form == "none":
            return "no hidden effect"
        if self.form == "sigmoid":
            return (
                f"saturating change of {self.amplitude:+.1f} mm in {self.column} "
                f"around {self.threshold:g} (width {self.width:g})"
            )
        if self.form == "step":
            return f"step of {self.amplitude:+.1f} mm when {self.column} >= {self.threshold:g}"
        if self.form == "linear":
            return f"linear drift of {self.amplitude:+.3g} mm per unit of {self.column}"
        if self.form == "group":
            return f"random offset per {self.column} level, sd {self.amplitude:.1f} mm"
        if self.form == "product":
            return f"interaction {self.amplitude:+.1f} mm * z({self.column}) * z({self.column_b})"
        raise ValueError(f"unknown hidden-effect form {self.form!r}")


DEFAULTS = section_defaults("demo")


@dataclass(frozen=True)
class DemoPlant:
    """The demo plant's settings: the config's ``demo:`` (its defaults are the schema's)."""

    seed: int = DEFAULTS["seed"]
    n_doe: int = DEFAULTS["n_doe"]
    n_production: int = DEFAULTS["n_production"]
    n_matched: int = DEFAULTS["n_matched"]
    fe_scatter_mm: float = DEFAULTS["fe_scatter_mm"]
    noise_mm: float = DEFAULTS["noise_mm"]
    offset_mm: float = DEFAULTS["offset_mm"]
    blanks_per_coil: int = 1800
    hidden_effect: HiddenEffect = field(default_factory=lambda: HiddenEffect(**DEFAULTS["hidden_effect"]))


def _unit(frame: pd.DataFrame, name: str) -> np.ndarray:
    """Input scaled to [-1, 1] over the DoE range."""
    low, high, _ = INPUTS[name]
    return (frame[name].to_numpy(float) - (low + high) / 2) / ((high - low) / 2)


def simulator(frame: pd.DataFrame) -> np.ndarray:
    """Noise-free simulated draw-in: smooth, mostly additive, mildly nonlinear."""
    u = {name: _unit(frame, name) for name in INPUT_NAMES}
    y = np.full(len(frame), NOMINAL_DRAW_IN_MM)
    for name, (_, _, sensitivity) in INPUTS.items():
        y += SENSITIVITY_SCALE * sensitivity * u[name]
    cushion = (u["cushion_c1_kn"] + u["cushion_c2_kn"] + u["cushion_c3_kn"] + u["cushion_c4_kn"]) / 4
    y += 1.0 * cushion**2  # restraint saturates at high force
    y += 0.8 * u["shim20_mm"] * u["cushion_c1_kn"]  # shim relieves the cushion locally
    y -= 0.6 * u["thickness_mm"] * u["rp02_mpa"]
    return y


def effect(hidden: HiddenEffect, frame: pd.DataFrame, seed: int = 0) -> np.ndarray:
    """The hidden effect evaluated on a frame that holds its column(s)."""
    if hidden.form == "none":
        return np.zeros(len(frame))
    values = frame[hidden.column]
    if hidden.form == "group":
        levels = sorted(values.astype(str).unique())
        rng = np.random.default_rng([seed, 7])
        offsets = dict(zip(levels, rng.normal(0.0, hidden.amplitude, len(levels))))
        return values.astype(str).map(offsets).to_numpy(float)
    x = _as_number(values)
    if hidden.form == "sigmoid":
        return hidden.amplitude / (1.0 + np.exp(-(x - hidden.threshold) / hidden.width))
    if hidden.form == "step":
        return np.where(x >= hidden.threshold, hidden.amplitude, 0.0)
    if hidden.form == "linear":
        return hidden.amplitude * (x - hidden.threshold)
    if hidden.form == "product":
        return hidden.amplitude * _unit(frame, hidden.column) * _unit(frame, hidden.column_b)
    raise ValueError(f"unknown hidden-effect form {hidden.form!r}")


def _as_number(values: pd.Series) -> np.ndarray:
    if pd.api.types.is_datetime64_any_dtype(values) or values.dtype == object or pd.api.types.is_string_dtype(values):
        stamps = pd.to_datetime(values)
        return ((stamps - stamps.min()).dt.total_seconds() / 3600.0).to_numpy(float)
    return values.to_numpy(float)


def make_doe(plant: DemoPlant) -> pd.DataFrame:
    """Latin hypercube over the DoE ranges, simulated with numerical scatter."""
    rng = np.random.default_rng([plant.seed, 1])
    sampler = qmc.LatinHypercube(d=len(INPUTS), optimization="random-cd", seed=rng)
    lows = np.array([v[0] for v in INPUTS.values()])
    highs = np.array([v[1] for v in INPUTS.values()])
    doe = pd.DataFrame(qmc.scale(sampler.random(plant.n_doe), lows, highs), columns=INPUT_NAMES)
    doe[TARGET] = simulator(doe) + rng.normal(0.0, plant.fe_scatter_mm, plant.n_doe)
    return doe.round(4)


# Press-setting campaigns: one per run, shims and cushion forces set independently
# around a production window that lies at the edge of the DoE box and beyond it
# (the line was re-tuned after the DoE was planned).
CAMPAIGN_LOW = np.array([0.46, 0.44, 302, 297, 304, 300])
CAMPAIGN_HIGH = np.array([0.72, 0.70, 372, 372, 376, 372])


def campaign_settings(n_runs: int, rng: np.random.Generator) -> np.ndarray:
    """One setting per run: a fixed space-filling design over the campaign window (so every plant
    has a similar share of parts in support), perturbed and shuffled per plant."""
    design = qmc.scale(
        qmc.LatinHypercube(d=6, seed=np.random.default_rng(17)).random(n_runs), CAMPAIGN_LOW, CAMPAIGN_HIGH
    )
    jitter = rng.normal(0.0, 0.03, (n_runs, 6)) * (CAMPAIGN_HIGH - CAMPAIGN_LOW)
    return np.clip(design + jitter, CAMPAIGN_LOW, CAMPAIGN_HIGH)[rng.permutation(n_runs)]


def make_production(plant: DemoPlant) -> pd.DataFrame:
    """Parts in production order with inputs, plant log columns and no target yet."""
    rng = np.random.default_rng([plant.seed, 2])  # drawn from in this order: timeline, ambient, coils, settings
    run, in_run_s, stamps = _timeline(plant.n_production, rng)
    n, n_runs = len(run), run.max() + 1
    hour = stamps.hour.to_numpy() + stamps.minute.to_numpy() / 60
    ambient = (
        21.0 + 6.0 * np.sin(2 * np.pi * (hour - 9.0) / 24.0) + rng.normal(0, 3.0, n_runs)[run] + rng.normal(0, 0.3, n)
    )
    coil, material = _coils(n, plant.blanks_per_coil, rng)
    # settings are re-tuned twice per run (after the warm-up and mid-run)
    segment = 2 * run + (in_run_s > np.array([np.median(in_run_s[run == r]) for r in range(n_runs)])[run])
    campaigns = campaign_settings(2 * n_runs, rng)
    settings = campaigns[segment] + rng.normal(0, [0.01, 0.01, 3, 3, 3, 3], (n, 6))
    # the die warms up within each run, more under higher blank-holder (cushion) forces
    warm = rng.uniform(18, 30, n_runs)[run] + 0.22 * (settings[:, 2:].mean(axis=1) - 290.0)
    tau_s = rng.uniform(30, 60, n_runs)[run] * 60
    die = ambient + 2.0 + warm * (1 - np.exp(-in_run_s / tau_s)) + rng.normal(0, 0.6, n)
    strokes = 250_000 + np.arange(n) + np.cumsum(rng.integers(20, 400, n_runs))[run]  # set-up strokes between runs
    shift = np.select([(hour >= 6) & (hour < 14), (hour >= 14) & (hour < 22)], ["A", "B"], "C")
    production = pd.DataFrame(
        {
            "timestamp": stamps.strftime("%Y-%m-%d %H:%M:%S"),
            "stroke_counter": strokes,
            "coil_id": [f"K{26000 + c:05d}" for c in coil],
            "shift": shift,
            **material,
            "die_temp_c": die,
            "ambient_temp_c": ambient,
            **dict(zip(INPUT_NAMES[6:], settings.T)),
        }
    )
    return production.round({name: 4 for name in INPUT_NAMES})


def _timeline(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, pd.DatetimeIndex]:
    """Each part's run, seconds since its run started, and timestamp: 14 runs of parts every ~3.75 s, gaps of
    8 h to 3 days between them."""
    parts_per_run = max(200, n // 14)
    run = np.minimum(np.arange(n) // parts_per_run, (n - 1) // parts_per_run)
    n_runs = run.max() + 1
    cycle_s = 60.0 / STROKES_PER_MINUTE * (1.0 + rng.exponential(0.08, n))
    run_start = np.r_[0.0, np.cumsum(rng.uniform(8, 72, n_runs - 1) * 3600.0)]
    first = np.searchsorted(run, np.arange(n_runs))
    in_run_s = np.concatenate([np.cumsum(cycle_s[run == r]) - cycle_s[first[r]] for r in range(n_runs)])
    run_offsets = np.zeros(n_runs)
    for r in range(1, n_runs):
        run_offsets[r] = run_offsets[r - 1] + in_run_s[run == r - 1].max() + run_start[r] - run_start[r - 1]
    stamps = pd.Timestamp("2026-03-02 06:00:00") + pd.to_timedelta(np.round(run_offsets[run] + in_run_s), unit="s")
    return run, in_run_s, stamps


def _coils(n: int, blanks_per_coil: float, rng: np.random.Generator) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Each part's coil (~``blanks_per_coil`` blanks each) and material: Rm and Rp0.2 move together from coil to
    coil, and supplier B's coils are stronger, beyond the DoE's material ranges."""
    coil = np.cumsum(rng.random(n) < 1 / blanks_per_coil)
    n_coils = coil.max() + 1
    supplier_b = rng.random(n_coils) < 0.25
    coil_rm = rng.normal(345, 12, n_coils) + 30.0 * supplier_b
    coil_rp = 215 + 0.85 * (coil_rm - 345) + rng.normal(0, 4.0, n_coils)
    along = rng.normal(0, 2.5, n)
    rm = coil_rm[coil] + along + rng.normal(0, 1.5, n)
    rp = coil_rp[coil] + 0.85 * along + rng.normal(0, 1.5, n)
    thickness = rng.normal(0.74, 0.012, n_coils)[coil] + rng.normal(0, 0.003, n)
    r_n = rng.normal(1.60, 0.06, n_coils)[coil] + rng.normal(0, 0.01, n)
    return coil, {"thickness_mm": thickness, "rm_mpa": rm, "rp02_mpa": rp, "r_n": r_n}


def plant_truth(plant: DemoPlant, frame: pd.DataFrame) -> np.ndarray:
    """Noise-free plant draw-in."""
    return simulator(frame) + plant.offset_mm + effect(plant.hidden_effect, frame, plant.seed)


def generate(plant: DemoPlant) -> dict[str, pd.DataFrame]:
    """All demo data: doe, production, matched and the noise-free truth of each."""
    rng = np.random.default_rng([plant.seed, 3])
    # matched trials: parts inside the DoE box, re-simulated at exactly their inputs (as a
    # plant trial would be); they are taken out of the production log, so no model trains on them
    parts = make_production(replace(plant, n_production=plant.n_production + plant.n_matched))
    inside = np.ones(len(parts), bool)
    for name, (low, high, _) in INPUTS.items():
        inside &= parts[name].between(low, high).to_numpy()
    pool = np.flatnonzero(inside) if inside.sum() >= plant.n_matched else np.arange(len(parts))
    picks = np.sort(rng.choice(pool, plant.n_matched, replace=False))
    matched = parts.iloc[picks].reset_index(drop=True)
    production = parts.drop(index=picks).reset_index(drop=True)
    truth = plant_truth(plant, production)
    production[TARGET] = np.round(truth + rng.normal(0, plant.noise_mm, len(production)), 3)
    matched_truth = plant_truth(plant, matched)
    matched.insert(0, "case", [f"M{i + 1}" for i in range(plant.n_matched)])
    matched[MATCHED_SIMULATED] = np.round(simulator(matched) + rng.normal(0, plant.fe_scatter_mm, plant.n_matched), 3)
    matched[MATCHED_MEASURED] = np.round(matched_truth + rng.normal(0, plant.noise_mm, plant.n_matched), 3)

    return {
        "doe": make_doe(plant),
        "production": production,
        "matched": matched,
        "production_truth": pd.DataFrame({"truth_mm": truth, "simulator_mm": simulator(production)}),
        "matched_truth": pd.DataFrame(
            {"case": matched["case"], "truth_mm": matched_truth, "simulator_mm": simulator(matched)}
        ),
    }


def plant_from_config(config: dict) -> DemoPlant:
    """DemoPlant from the config's ``demo:`` block (missing keys keep their defaults)."""
    config = dict(config or {})
    hidden = config.pop("hidden_effect", None)
    if hidden is not None:
        config["hidden_effect"] = HiddenEffect(**hidden)
    return DemoPlant(**config)


def describe_plant(plant: DemoPlant) -> dict:
    """The demo's settings and hidden effect, as written beside the data."""
    from dataclasses import asdict

    spec = asdict(plant)
    spec["hidden_effect_text"] = plant.hidden_effect.describe()
    spec["inputs"] = {name: {"doe_low": low, "doe_high": high} for name, (low, high, _) in INPUTS.items()}
    return spec
