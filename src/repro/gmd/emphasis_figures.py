"""The figures of notebook 03 (GMD appendix C, C.1: Emphasis projection): values in, a Figure out.

Each function draws what the notebook measured (nothing here feeds a verdict); the notebook
saves the figure with ``repro.motion.plotting.save_figure``. Kept apart from ``figures``
(notebooks 01, 02, 06) so that neither module outgrows the size limit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from repro.core.stats import t_interval
from repro.gmd.emphasis import GMD_RELEASED_CONDITION_NUMBER, relative_importance
from repro.gmd.emphasis_study import Results
from repro.gmd.models import TrainedGMD

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["COHERENCE_PANELS", "plot_coherence", "plot_distances_and_inverse",
           "plot_relative_importance", "plot_skating_against_kappa", "plot_training_losses",
           "plot_unit_variance"]


def plot_relative_importance(c_grid: np.ndarray, simulated: np.ndarray,
                             projected: dict[int, np.ndarray], orthogonal: np.ndarray,
                             on_data: np.ndarray, *, c_star: float, importance_at_10: float,
                             simulation_error: float) -> Figure:
    """GMD-C1: Eq. 4 over c, the simulation (the rule's input), the projected energy share of
    Gaussian (per matrix seed) and orthogonal matrices, and the share on the stand-in frames."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    fine = np.linspace(0.3, 21, 400)
    ax.plot(fine, relative_importance(fine), "k-", lw=2, label="Eq. 4: 3c²/(260+3c²)")
    ax.plot(c_grid, simulated, "o", color="tab:orange", ms=6,
            label=f"simulation, N(0,1) (max |error| {simulation_error:.1e})")
    for i, values in enumerate(projected.values()):
        ax.plot(c_grid, values, "x", color="tab:blue", ms=5,
                label="projected energy share, Gaussian P (per matrix seed)" if i == 0 else None)
    ax.plot(c_grid, orthogonal, "+", color="tab:green", ms=8,
            label="projected energy share, orthogonal P")
    ax.plot(c_grid, on_data, "s--", color="tab:purple", ms=4, lw=1,
            label="stand-in test frames (z-normalised)")
    ax.axhline(0.5, color="grey", lw=0.8, ls=":")
    ax.axvline(c_star, color="grey", lw=0.8, ls=":")
    ax.plot([c_star], [0.5], "k*", ms=12)
    ax.annotate(f"c* = √(260/3) = {c_star:.3f}", (c_star, 0.5), (11.5, 0.3), fontsize=8,
                arrowprops={"arrowstyle": "->", "lw": 0.8})
    ax.annotate(f"c = 10: {importance_at_10:.1%}", (10, importance_at_10), (12.5, 0.62),
                fontsize=8, arrowprops={"arrowstyle": "->", "lw": 0.8})
    ax.set_xlabel("c")
    ax.set_ylabel("relative importance of features 0–2")
    ax.set_title("GMD-C1: relative importance of the trajectory elements", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig


def plot_distances_and_inverse(ratios: dict, errors: dict, kappa: dict,
                               scan: dict[float, list[tuple[float, float]]],
                               seeds: Sequence[int], *, n_pairs: int, jl_bound: float,
                               scan_frames: int) -> Figure:
    """GMD-C2: distance ratios at c = 1 and 10 (pooled over matrix seeds) against
    √(χ²₂₆₃/263), the inverse's round-trip errors at c = 10 in float64/float32, and the
    float32 error against κ over more matrix seeds. ``ratios``/``errors``/``kappa`` keyed
    (c, seed); ``scan[c]``: (κ, max error) per scanned seed."""
    import matplotlib.pyplot as plt
    from scipy import stats

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    ax = axes[0]
    bins = np.linspace(0.0, 3.0, 121)
    for c, colour in ((1.0, "tab:blue"), (10.0, "tab:red")):
        pooled = np.concatenate([ratios[(c, s)] for s in seeds])
        ax.hist(pooled, bins=bins, density=True, alpha=0.5, color=colour,
                label=f"c = {c:g}: {np.mean(np.abs(pooled - 1) <= 0.2):.1%} within ±20 %")
    r = np.linspace(0.6, 1.4, 400)
    ax.plot(r, stats.chi2.pdf(263 * r**2, 263) * 2 * 263 * r, "k-", lw=1,
            label="√(χ²₂₆₃/263): one pair, random G")
    ax.axvspan(0.8, 1.2, color="grey", alpha=0.12,
               label=f"±20 % (JL bound: P(out) ≤ {jl_bound:.1e})")
    ax.set_xlabel("‖xP − yP‖ / ‖x − y‖")
    ax.set_ylabel("density")
    ax.set_title(f"distance ratios, {n_pairs} frame pairs × {len(seeds)} matrices", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1]
    edges = np.logspace(-17, -2, 61)
    for (name, colour) in (("float64", "tab:blue"), ("float32", "tab:orange"),
                           ("float32_gmd", "tab:red")):
        pooled = np.concatenate([errors[(10.0, s)][name] for s in seeds])
        ax.hist(np.maximum(pooled, 1e-17), bins=edges, alpha=0.55, color=colour,
                label=f"{name.replace('_gmd', ', inverse in float32 (GMD)')}: max "
                      f"{pooled.max():.1e}")
    for threshold in (1e-8, 1e-4):
        ax.axvline(threshold, color="grey", ls=":", lw=1)
    ax.set_xscale("log")
    ax.set_xlabel("‖P⁻¹(xP) − x‖ / ‖x‖ per frame (c = 10)")
    ax.set_ylabel("frames")
    ax.set_title(f"inverse round trip; κ(P) at c = 10: "
                 f"{', '.join(f'{kappa[(10.0, s)]:.0f}' for s in seeds)}", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[2]
    for c, colour in ((1.0, "tab:blue"), (10.0, "tab:red")):
        k, e = np.array(scan[c]).T
        ax.loglog(k, e, "o", color=colour, ms=5, label=f"c = {c:g}")
    k_line = np.logspace(2, 5, 10)
    ax.loglog(k_line, k_line * 2.0**-24, "k--", lw=0.8, label="κ · 2⁻²⁴")
    ax.axhline(1e-4, color="grey", ls=":", lw=1, label="rule: 1e-4")
    ax.set_xlabel("condition number κ(P)")
    ax.set_ylabel("max float32 round-trip error")
    ax.set_title(f"{len(next(iter(scan.values())))} matrix seeds, {scan_frames} frames each",
                 fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_unit_variance(c_grid: np.ndarray, unscaled: np.ndarray, sqrt_factor: np.ndarray,
                       printed_factor: np.ndarray, variance_sqrt_all: np.ndarray,
                       variance_orthogonal_all: np.ndarray,
                       variance_on_frames: np.ndarray) -> Figure:
    """GMD-C3: the variance of y with GMD's code's factor and with the printed one over c, the
    factor that actually gives unit variance, and the spread over the output dimensions at
    c = 10. ``unscaled``: mean Var[x D G] per c."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    ax = axes[0]
    ax.semilogy(c_grid, unscaled * sqrt_factor**2, "o-", color="tab:blue",
                label="× 1/√(260+3c²)  (GMD's code)")
    ax.semilogy(c_grid, unscaled * printed_factor**2, "s-", color="tab:red",
                label="× 1/(260+3c²)  (as printed)")
    ax.axhline(1.0, color="black", lw=0.8, ls=":")
    ax.set_xlabel("c")
    ax.set_ylabel("mean per-dimension variance of y")
    ax.set_title("N(0,1) inputs, Gaussian P", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1]
    ax.loglog(c_grid, 1.0 / np.sqrt(unscaled), "ko", ms=7, label="measured: 1/√(mean Var[xDG])")
    ax.loglog(c_grid, sqrt_factor, "-", color="tab:blue", label="1/√(263−3+3c²)")
    ax.loglog(c_grid, printed_factor, "-", color="tab:red", label="1/(263−3+3c²) (printed)")
    ax.set_xlabel("c")
    ax.set_ylabel("normalising factor")
    ax.set_title("the factor that gives unit variance", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[2]
    bins = np.linspace(0.0, 2.5, 76)
    ax.hist(variance_sqrt_all, bins=bins, alpha=0.6, color="tab:blue",
            label=f"Gaussian P: mean {variance_sqrt_all.mean():.3f}, range "
                  f"{variance_sqrt_all.min():.2f}–{variance_sqrt_all.max():.2f}")
    ax.hist(variance_orthogonal_all, bins=bins, alpha=0.6, color="tab:green",
            label=f"orthogonal P: mean {variance_orthogonal_all.mean():.3f}")
    ax.hist(variance_on_frames, bins=bins, alpha=0.4, color="tab:purple",
            label=f"stand-in frames, Gaussian P: mean {variance_on_frames.mean():.3f}")
    ax.set_xlabel("per-dimension variance of y (c = 10, √ factor)")
    ax.set_ylabel("dimensions")
    ax.set_title("spread over the 263 output dimensions", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


#: the GMD-C4 panels: (measurement, title); foot skating is the rule's.
COHERENCE_PANELS = (("foot_skating", "foot skating (m/s) ↓ — the rule"),
                    ("foot_skating_ratio", "GMD skating ratio ↓"),
                    ("root_velocity_disagreement", "root path vs velocity features (m/s) ↓"),
                    ("acceleration", "joint acceleration (m/s²)"),
                    ("trajectory_error", "trajectory error (m) ↓"),
                    ("fid", "FID ↓"), ("r_precision_top3", "R-precision top-3 ↑"))
#: panels drawn on a log axis (the Emphasis models span orders of magnitude).
_LOG_PANELS = ("foot_skating", "root_velocity_disagreement", "acceleration", "trajectory_error")


def plot_coherence(results: Results, values: Sequence[float], *, samples: int) -> Figure:
    """GMD-C4: every coherence measurement against k = c, loss scaling vs Emphasis (mean and
    95 % t-interval over seeds, dots: seeds), the test windows' value dashed, and the
    load/train time of each variant."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 4, figsize=(17, 7.5))
    for ax, (metric, title) in zip(axes.ravel(), COHERENCE_PANELS, strict=False):
        for method, colour, marker in (("loss_scaling", "tab:red", "s"),
                                       ("emphasis", "tab:blue", "o")):
            per_value = results.per_value(method, metric)
            means, lows, highs = [], [], []
            for v in values:
                interval = t_interval(per_value[f"{v:g}"])
                means.append(interval.mean)
                lows.append(interval.mean - interval.low)
                highs.append(interval.high - interval.mean)
                shift = 0.95 if method == "loss_scaling" else 1.05
                ax.plot(np.full(len(per_value[f"{v:g}"]), v) * shift, per_value[f"{v:g}"], ".",
                        color=colour, alpha=0.4)
            label = "loss scaling k" if method == "loss_scaling" else "Emphasis c"
            ax.errorbar(values, means, yerr=[lows, highs], color=colour, marker=marker,
                        capsize=3, label=label)
        if metric in results.ground_truth and metric != "root_velocity_disagreement":
            ax.axhline(np.mean(results.ground_truth[metric]), color="black", ls="--", lw=0.8,
                       label="test windows (ground truth)")
        ax.set_xscale("log")
        if metric in _LOG_PANELS:
            ax.set_yscale("log")
        ax.set_xticks(values, [f"{v:g}" for v in values])
        ax.set_xlabel("k = c")
        ax.set_title(title, fontsize=9)
    axes[0, 0].legend(fontsize=7)
    ax = axes[1, 3]
    ax.axis("off")
    ax.text(0, 1, "\n".join(f"{v.label:>27}: {np.mean(results.train_seconds[v.label]):5.1f} s "
                            f"to load/train" for v in results.variants + results.outside_rule),
            va="top", family="monospace", fontsize=7)
    fig.suptitle(f"GMD-C4: trajectory-conditioned samples, {samples} per seed, mean and 95 % "
                 f"t-interval over seeds {results.seeds} (dots: seeds; log axes clip intervals "
                 f"below 0)", fontsize=10)
    fig.tight_layout()
    return fig


def plot_skating_against_kappa(results: Results) -> Figure:
    """GMD-C4: foot skating of every Emphasis model against κ(P) of its matrix, per seed (log
    axes): the rule's Gaussian matrices at each c, and outside the rule the orthogonal matrix
    (κ = c) and GMD's float32 construction (the Gaussian models, GMD's float32 P⁻¹); loss
    scaling k = c as a dotted line at its mean over seeds, the test windows' skating dashed,
    κ of GMD's released matrix as a vertical line."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.6))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    arms = [v for v in results.variants + results.outside_rule if v.method == "emphasis"]
    markers = {("gaussian", "float64"): "o", ("orthogonal", "float64"): "s",
               ("gaussian", "float32_gmd"): "x"}
    values = sorted({v.value for v in arms})
    for variant in arms:
        colour = colours[values.index(variant.value) % len(colours)]
        ax.plot(results.condition_numbers[variant.label],
                results.imputed[variant.label]["foot_skating"],
                markers[(variant.kind, variant.precision)], color=colour, ms=7,
                mfc="none" if variant.precision == "float32_gmd" else colour,
                label=f"{variant.label} ({len(results.seeds)} seeds)")
    for variant in results.variants:
        if variant.method == "loss_scaling" and variant.value in values:
            colour = colours[values.index(variant.value) % len(colours)]
            ax.axhline(float(np.mean(results.imputed[variant.label]["foot_skating"])),
                       color=colour, ls=":", lw=1.2, label=f"{variant.label}: mean")
    ax.axhline(float(np.mean(results.ground_truth["foot_skating"])), color="black", ls="--",
               lw=0.8, label="test windows (ground truth)")
    ax.axvline(GMD_RELEASED_CONDITION_NUMBER, color="grey", ls="-.", lw=1,
               label=f"κ of GMD's released matrix ({GMD_RELEASED_CONDITION_NUMBER:.0f})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("condition number κ(P) of the model's Emphasis matrix")
    ax.set_ylabel("foot skating of imputed samples (m/s)")
    ax.set_title("GMD-C4: skating against the conditioning of P (matrix seed = model seed)",
                 fontsize=9)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def plot_training_losses(models: dict[str, TrainedGMD], *, window: int = 10) -> Figure:
    """The (weighted) x0 MSE during training of each model ({label: model}), a ``window``-step
    running mean; loss scaling solid, Emphasis dashed."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.8))
    for label, model in models.items():
        curve = np.asarray(model.metrics.get("losses", []), dtype=float)
        if len(curve) >= window:
            smooth = np.convolve(curve, np.ones(window) / window, mode="valid")
            ax.plot(np.arange(len(smooth)) + window, smooth, lw=1.2, label=label,
                    ls="-" if label.startswith("loss") else "--")
    ax.set_xlabel("training step")
    ax.set_ylabel(f"training loss ({window}-step mean)")
    ax.set_yscale("log")
    ax.set_title("GMD-C4 models, first seed: (weighted) x0 MSE during training", fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return fig
