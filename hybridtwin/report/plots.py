"""Figures. Each function returns a matplotlib Figure; files.save_figure writes it."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybridtwin.crossval import training_subset  # noqa: E402

PCA_ROWS = 200_000  # production parts the enrichment map's axes are fitted on (every part of a shorter log)

plt.rcParams.update(
    {"figure.dpi": 120, "axes.grid": True, "grid.alpha": 0.3, "font.size": 9, "svg.hashsalt": "hybridtwin"}
)


def support_distances(doe_distances, production_distances, threshold, percentile):
    figure, axis = plt.subplots(figsize=(6, 3.5))
    production_distances = np.asarray(production_distances, float)
    bins = np.linspace(0, np.percentile(production_distances, 99.5) * 1.05, 60)
    axis.hist(
        production_distances,
        bins=bins,
        color="0.6",
        label=f"production (n={len(production_distances):,})",
        density=True,
    )
    axis.hist(
        doe_distances,
        bins=bins,
        histtype="step",
        color="C0",
        lw=1.5,
        density=True,
        label=f"DoE leave-one-out (n={len(doe_distances)})",
    )
    axis.axvline(threshold, color="C3", ls="--", label=f"threshold ({percentile:g}th pct) = {threshold:.2f}")
    inside = np.mean(production_distances <= threshold)
    axis.set(
        xlabel="mean distance to k nearest DoE points (DoE-standardized)",
        ylabel="density",
        title=f"kNN support: {inside:.1%} of production in support",
    )
    axis.legend()
    return figure


def parity(reference, prediction, label: str, unit: str, title: str = ""):
    """Predicted against reference with the 1:1 line."""
    figure, axis = plt.subplots(figsize=(4.5, 4.5))
    axis.scatter(reference, prediction, s=14, color="C0", alpha=0.8)
    _one_to_one(axis, reference, prediction)
    axis.set(xlabel=f"{label} [{unit}]", ylabel=f"predicted [{unit}]", title=title)
    return figure


def _one_to_one(axis, *arrays):
    values = np.concatenate([np.asarray(a, float).ravel() for a in arrays])
    low, high = np.nanmin(values), np.nanmax(values)
    pad = 0.05 * (high - low or 1.0)
    axis.plot([low - pad, high + pad], [low - pad, high + pad], color="k", lw=1, label="1:1")
    axis.set_xlim(low - pad, high + pad)
    axis.set_ylim(low - pad, high + pad)


def residual_check(production_target, production_pred, matched_target, matched_pred, matched_scores: dict, unit: str):
    """Figure 2: predicted residual against its target, production cloud and matched cases."""
    figure, axis = plt.subplots(figsize=(5.5, 5))
    axis.scatter(
        production_target,
        production_pred,
        s=3,
        color="0.65",
        alpha=0.35,
        rasterized=True,
        label=f"production in support, out-of-fold (n={len(production_target):,})",
    )
    axis.scatter(
        matched_target,
        matched_pred,
        s=40,
        color="C0",
        edgecolor="k",
        zorder=3,
        label=(
            f"matched cases, true residual (n={len(matched_target)}): R²={matched_scores['r2']:.2f}, "
            f"RMSE={matched_scores['rmse']:.2f} {unit}"
        ),
    )
    _one_to_one(axis, production_target, production_pred, matched_target, matched_pred)
    axis.set(
        xlabel=f"residual target: r_approx (production) / true residual (matched) [{unit}]",
        ylabel=f"predicted residual r_hat [{unit}]",
        title="Residual model: production and matched cases",
    )
    axis.legend(loc="upper left", fontsize=7)
    return figure


def error_distributions(groups: dict[str, dict[str, np.ndarray]], unit: str):
    """Figure 3: error histograms, surrogate against hybrid, one panel per data set."""
    figure, axes = plt.subplots(1, len(groups), figsize=(5 * len(groups), 3.8), squeeze=False)
    for axis, (title, errors) in zip(axes[0], groups.items()):
        values = np.concatenate([np.asarray(e, float) for e in errors.values()])
        bins = np.linspace(np.percentile(values, 0.5), np.percentile(values, 99.5), 50 if len(values) > 50 else 12)
        for index, (name, error) in enumerate(errors.items()):
            error = np.asarray(error, float)
            std = error.std(ddof=1) if len(error) > 1 else 0.0
            axis.hist(
                error,
                bins=bins,
                alpha=0.55,
                color=f"C{index}",
                density=True,
                label=f"{name}: μ={error.mean():.2f}, σ={std:.2f} {unit}",
            )
        axis.axvline(0, color="k", lw=0.8)
        axis.set(xlabel=f"error = measured − predicted [{unit}]", ylabel="density", title=title)
        axis.legend(fontsize=7)
    figure.tight_layout()
    return figure


def cause_profile(profile: dict, rank: int, significant: bool):
    """Residual against a candidate cause, binned, with the fitted form and its 95% band."""
    figure, axis = plt.subplots(figsize=(6.5, 4))
    status = "significant" if significant else "not significant"
    if profile["kind"] == "group":
        positions = np.arange(len(profile["levels"]))
        axis.errorbar(
            positions,
            profile["mean"],
            yerr=2 * profile["se"],
            fmt="o",
            ms=3,
            color="0.3",
            label="residual per level (mean ± 2 SE)",
        )
        axis.scatter(positions, profile["fitted"], marker="_", s=120, color="C3", label="fitted group offset")
        step = max(1, len(positions) // 30)
        axis.set_xticks(positions[::step], [str(v) for v in profile["levels"]][::step], rotation=90, fontsize=6)
        axis.set_xlabel(profile["name"])
    else:
        binned = profile["binned"]
        axis.errorbar(
            binned["center"],
            binned["mean"],
            yerr=2 * binned["se"],
            fmt="o",
            ms=3,
            color="0.3",
            label="binned residual (mean ± 2 SE)",
        )
        axis.plot(profile["grid"], profile["curve"], color="C3", lw=2, label=f"fitted form: {profile['form']}")
        axis.fill_between(
            profile["grid"],
            profile["band_low"],
            profile["band_high"],
            color="C3",
            alpha=0.2,
            label="95% band (bootstrap)",
        )
        axis.set_xlabel(profile["xlabel"])
    axis.axhline(0, color="k", lw=0.6)
    axis.set_ylabel(f"offset-free residual [{profile['unit']}]")
    axis.set_title(f"Cause {rank}: {profile['name']} ({status})\n{profile['description']}", fontsize=8)
    axis.legend(fontsize=7)
    return figure


def placeholder(text: str):
    """A figure that says why there is nothing to show (fewer candidates than figure slots)."""
    figure, axis = plt.subplots(figsize=(6.5, 4))
    axis.text(0.5, 0.5, text, ha="center", va="center", wrap=True)
    axis.set_axis_off()
    return figure


def prediction_intervals(
    distance,
    error,
    region,
    half_width: dict[str, float],
    coverage: dict[str, float],
    threshold: float,
    level: float,
    unit: str,
):
    """Errors of the recommended prediction against the distance to the DoE, with each region's interval."""
    figure, axis = plt.subplots(figsize=(7, 4))
    distance, error, region = np.asarray(distance, float), np.asarray(error, float), np.asarray(region, object)
    for index, name in enumerate(sorted(half_width)):
        rows = region == name
        if not rows.any():
            continue
        low, high = float(distance[rows].min()), float(distance[rows].max())
        color = f"C{index}"
        axis.scatter(distance[rows], error[rows], s=3, alpha=0.25, color=color)
        label = f"{name.replace('_', ' ')}: ±{half_width[name]:.2f} {unit}, covers {coverage.get(name, np.nan):.1%}"
        axis.fill_between([low, high], -half_width[name], half_width[name], color=color, alpha=0.18, label=label)
    axis.axvline(threshold, color="k", ls="--", lw=1, label=f"support threshold {threshold:.2f}")
    axis.set(
        xlabel="mean distance to the k nearest DoE points (DoE-standardized)",
        ylabel=f"measured − recommended prediction [{unit}]",
        title=f"{level:.0%} prediction intervals by region (held-out production rows)",
    )
    axis.legend(fontsize=7, loc="upper left")
    return figure


def enrichment_share(share_before: float, shares, shares_fixed, k: int):
    """Share of production in support against the number of added simulations."""
    figure, axis = plt.subplots(figsize=(6, 3.5))
    steps = np.arange(len(shares) + 1)
    axis.plot(steps, [share_before, *shares], "o-", color="C0", label="gate rebuilt on the enlarged DoE")
    axis.plot(
        steps, [share_before, *shares_fixed], "s--", color="C1", ms=4, label="today's threshold held (coverage alone)"
    )
    axis.set(
        xlabel="proposed simulations added",
        ylabel="production parts in support",
        ylim=(0, 1.02),
        title=f"What the proposals bring (kNN gate, k={k})",
    )
    axis.yaxis.set_major_formatter(matplotlib.ticker.PercentFormatter(1.0))
    axis.legend()
    return figure


def enrichment_map(doe, production, inside, proposals, seed: int = 0):
    """DoE, production (in and out of support) and the proposals on the DoE-standardized inputs' first two
    principal axes."""
    from sklearn.decomposition import PCA

    doe, production, proposals = (np.asarray(a, float) for a in (doe, production, proposals))
    mean, scale = doe.mean(axis=0), doe.std(axis=0, ddof=1)
    shown = np.random.default_rng(seed).choice(len(production), min(len(production), 4000), replace=False)
    # the axes of the DoE and the production (a seeded sample of a log of millions of parts: it adds nothing)
    fitted_on = np.vstack([doe, production[training_subset(len(production), PCA_ROWS, seed)]])
    pca = PCA(n_components=2, random_state=seed).fit((fitted_on - mean) / scale)
    project = lambda X: pca.transform((X - mean) / scale)  # noqa: E731
    inside = np.asarray(inside, bool)[shown]
    figure, axis = plt.subplots(figsize=(6, 5))
    points = project(production[shown])
    axis.scatter(*points[~inside].T, s=3, color="0.7", label="production, out of support")
    axis.scatter(*points[inside].T, s=3, color="C2", label="production, in support")
    axis.scatter(*project(doe).T, s=25, marker="x", color="C0", label=f"DoE ({len(doe)})")
    if len(proposals):
        placed = project(proposals)
        axis.scatter(*placed.T, s=60, marker="*", color="C3", label=f"proposed ({len(proposals)})")
        for number, (x, y) in enumerate(placed, start=1):
            axis.annotate(str(number), (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7, color="C3")
    ratio = pca.explained_variance_ratio_
    axis.set(
        xlabel=f"principal axis 1 ({ratio[0]:.0%})",
        ylabel=f"principal axis 2 ({ratio[1]:.0%})",
        title="DoE, production and proposed simulations (DoE-standardized inputs)",
    )
    axis.legend(fontsize=7)
    return figure


def cause_sweeps(
    sweeps: list, n_causes: int, n_figures: int, doe_range: dict, target: str, unit: str, input_units=None
) -> list:
    """One figure per rank (``n_figures`` of them): the sweep along the rank-th named cause (``sweeps``, from
    :func:`hybridtwin.pipeline.cause_sweeps`: (column, answers), or None for an id), or why there is none;
    ``input_units``: each input's unit, for the x axis."""
    figures = []
    for rank in range(1, n_figures + 1):
        shown = sweeps[rank - 1] if rank <= len(sweeps) else None
        if shown is None:
            why = f"no cause {rank}" if rank > n_causes else f"cause {rank} is an id: no sweep can show it"
            figures.append(placeholder(why))
            continue
        column, answers = shown
        span = doe_range.get(column, (float("nan"), float("nan")))
        figures.append(sweep(answers, column, span, target, unit, (input_units or {}).get(column, "")))
    return figures


TRUST_COLORS = {"validated": "#2a9d3f", "calibrated": "#e08a1e", "extrapolation": "#c8302c"}


def sweep(answers, name: str, doe_range: tuple[float, float], target: str, unit: str, input_unit: str = ""):
    """The answer along one input (in ``input_unit``): the recommended prediction with its interval (where one was
    calibrated), the paper's gated hybrid and the surrogate as lines, the DoE's range shaded, the in-support
    stretch marked and each value's trust verdict as the marker's colour."""
    from hybridtwin.answers.trust import EXTRAPOLATION
    from hybridtwin.models.registry import HYBRID_GATED, RECOMMENDED_COLUMN, SURROGATE

    x = answers[name].to_numpy(float)
    figure, axis = plt.subplots(figsize=(8.5, 4.2))
    axis.axvspan(*doe_range, color="0.85", alpha=0.6, lw=0, label="DoE range (simulations)")
    lower, upper = answers["pred_lower"].to_numpy(float), answers["pred_upper"].to_numpy(float)
    level = float(answers["interval_level"].iloc[0])
    axis.fill_between(x, lower, upper, where=np.isfinite(lower), color="C0", alpha=0.2, label=f"{level:.0%} interval")
    # the surrogate drawn over the gated hybrid: outside the support the two are the same line
    axis.plot(x, answers[SURROGATE.column], color="0.3", lw=1.2, ls=":", label="surrogate (simulations)", zorder=2.5)
    axis.plot(x, answers[HYBRID_GATED.column], color="C1", lw=1, ls="--", label="paper's gated hybrid")
    recommended = answers[RECOMMENDED_COLUMN].to_numpy(float)
    # solid where an answer can be trusted, thin and dashed where it is an extrapolation (joined at the edges)
    far = (answers["trust"] == EXTRAPOLATION).to_numpy()
    near_far = far | np.convolve(far, [1, 1, 1], mode="same").astype(bool)
    axis.plot(x, np.where(far, np.nan, recommended), color="C0", lw=1.5, label="recommended model")
    if far.any():
        axis.plot(x, np.where(near_far, recommended, np.nan), color="C0", lw=1, ls=(0, (4, 2)),
                  label="recommended, extrapolation")  # fmt: skip
    for verdict, color in TRUST_COLORS.items():
        rows = (answers["trust"] == verdict).to_numpy()
        if rows.any():
            axis.scatter(x[rows], recommended[rows], s=12, color=color, zorder=3, label=verdict)
    inside = answers["in_support"].to_numpy(bool)
    if inside.any():
        axis.scatter(x[inside], np.full(inside.sum(), 0.02), s=8, marker="s", color="k",
                     transform=axis.get_xaxis_transform(), label="in the support")  # fmt: skip
    xlabel = f"{name} [{input_unit}]" if input_unit else name
    axis.set(xlabel=xlabel, ylabel=f"{target} [{unit}]", title=f"{target} along {name}, the other inputs held")
    axis.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    figure.tight_layout()
    return figure
