"""The figures of the GMD notebooks drawn from shared measurements, and reading helpers.

Each function draws what a notebook measured (nothing is computed here that a verdict reads);
the notebook saves the figure with ``repro.motion.plotting.save_figure``. A figure that reads
a claim module's own types (B1, B2, C1–C4, F1) lives in that claim module.

The "Reading" paragraphs of the notebooks are rendered from the values a run measured: a
sentence whose truth depends on the numbers is chosen by the numbers (:func:`either`); the
numbers enter through ``repro.core.tables.render`` and ``interval_text``, never as typed
text, so a re-run with another seed or more steps rewrites the paragraph.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from repro.gmd.guidance import sample
from repro.gmd.measurements import (
    NOT_MEASURABLE,
    PAPER_TABLE_B1,
    TABLE_METRICS,
    evaluation_set,
    generate_for_captions,
    measurable,
)
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import MotionWindows, short_label
from repro.motion.features import features_to_joints
from repro.motion.plotting import animate_side_by_side, shorten

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["animate_samples", "count_below", "either", "plot_coefficient_shares",
           "plot_filmstrips", "plot_goal_reaching", "plot_posterior_mean_forms",
           "plot_sample_quality", "plot_table_b1"]


# --- reading paragraphs: sentences chosen by the numbers -----------------------------------------

def either(condition: bool, when_true: str, when_false: str) -> str:
    return when_true if condition else when_false


def count_below(values_a: Sequence[float], values_b: Sequence[float]) -> int:
    """How many seeds have a < b."""
    return int(np.sum(np.asarray(values_a) < np.asarray(values_b)))



# --- figures: measured values in, a matplotlib Figure out -----------------------------------------

def plot_table_b1(real: dict[str, float], rows: dict[str, list[dict[str, float]]]) -> Figure:
    """Table B.1 as panels (FID, R@3, Diversity, concept recall): per-seed dots, mean bars,
    the stand-in real row as a dashed line; the paper's Ours rel → abs values in each title
    (HumanML3D, its own evaluator: for the direction only)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(14, 3.8))
    labels = {"fid": "FID ↓", "r_precision_top3": "R-precision top-3 ↑",
              "diversity": "Diversity →", "concept_recall": "concept recall ↑"}
    paper_index = {"fid": 0, "r_precision_top3": 1, "diversity": 2}
    for ax, metric in zip(axes, TABLE_METRICS, strict=True):
        for i, (rep, colour) in enumerate((("relative", "tab:red"), ("absolute", "tab:blue"))):
            values = np.asarray([r[metric] for r in rows[rep]])
            ax.bar(i, values.mean(), color=colour, alpha=0.6, label=f"ours {short_label(rep)}")
            ax.plot(np.full(len(values), i), values, "k.", ms=6)
        ax.axhline(real[metric], color="black", ls="--", lw=1, label="real (stand-in)")
        title = labels[metric]
        if metric in paper_index:
            k = paper_index[metric]
            title += (f"\npaper Ours: rel {PAPER_TABLE_B1['Ours (rel)'][k]:g} → abs "
                      f"{PAPER_TABLE_B1['Ours (abs)'][k]:g} (real {PAPER_TABLE_B1['Real'][k]:g})")
        else:
            title += "\n(not in the paper)"
        if not measurable([r[metric] for per_seed in rows.values() for r in per_seed]):
            title += f"\n{NOT_MEASURABLE}"
        ax.set_xticks([0, 1], ["rel", "abs"])
        ax.set_title(title, fontsize=9)
    axes[0].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------- notebook 01: x0 vs ε

def _step_axis(values: np.ndarray) -> np.ndarray:
    return np.arange(1, len(values) + 1)


def plot_posterior_mean_forms(mu_difference: np.ndarray, printed_error: np.ndarray, *,
                              draws: int, tolerance: float = 1e-10) -> Figure:
    """GMD-A1: max |Eq. 1 − Eq. 2| per step (with the rule's tolerance) and the relative
    error of the printed c = a/ᾱ_t + b against c = a/√ᾱ_t + b."""
    import matplotlib.pyplot as plt

    steps = _step_axis(mu_difference)
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
    axes[0].semilogy(steps, np.maximum(mu_difference, 1e-18), lw=1)
    axes[0].axhline(tolerance, color="tab:red", ls="--", lw=1, label=f"rule: {tolerance:g}")
    axes[0].set(xlabel="step t (1 … T)", ylabel="max |a·x0 + b·x_t − (c·x_t − d·ε)|",
                title=f"Eq. 1 vs Eq. 2 (float64, {draws} draws per t)")
    axes[0].legend(fontsize=8)
    axes[1].semilogy(steps, printed_error, lw=1.2)
    axes[1].set(xlabel="step t (1 … T)", ylabel="|c_printed − c| / c",
                title="printed c = a/ᾱ_t + b vs c = a/√ᾱ_t + b")
    fig.tight_layout()
    return fig


def plot_coefficient_shares(schedules: dict[str, dict[str, np.ndarray]],
                            peaks: dict[str, dict[str, float]]) -> Figure:
    """GMD-A2 (Fig. A.1 redrawn): per schedule the coefficients a, b, c, d and the x0 and ε
    shares over t, their peaks marked. ``schedules[name]``: ``coefficient_shares``."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(schedules), figsize=(11, 6.5), sharex=True, squeeze=False)
    for col, (name, curves) in enumerate(schedules.items()):
        steps = _step_axis(curves["a"])
        ax = axes[0, col]
        for key, style in (("a", "-"), ("b", "-"), ("c", "--"), ("d", "--")):
            ax.semilogy(steps, curves[key], style, lw=1.2, label=key)
        ax.set(title=f"{name}: coefficients of Eq. 1 (a, b) and Eq. 2 (c, d)", ylabel="value")
        ax.legend(fontsize=8, ncol=4)
        ax = axes[1, col]
        ax.plot(steps, curves["x0_share"], label="x0 share a/(a+b)")
        ax.plot(steps, curves["eps_share"], label="ε share d/(c+d)")
        for key, colour in (("x0_share", "tab:blue"), ("eps_share", "tab:orange")):
            k = int(np.argmax(curves[key]))
            ax.plot(steps[k], curves[key][k], "o", color=colour, ms=6)
        ax.set_yscale("log")
        ax.set(xlabel="step t (1 … T)", ylabel="relative share",
               title=f"{name}: peaks at t = {int(peaks[name]['x0_share'] * len(steps))} (x0) "
                     f"and {int(peaks[name]['eps_share'] * len(steps))} (ε)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _prediction_name(prediction: str) -> str:
    return "x0" if prediction == "x0" else "ε"


def plot_goal_reaching(results: dict, spaces: dict, seeds: list[int], *,
                       paths_shown: int = 5) -> Figure:
    """GMD-A3: the first seed's guided (solid) and unguided (dotted) root paths of both
    trajectory models toward their goals (×), and the goal error of x̂0 over sampling for
    every seed (the stop step dashed; the closest approach ● and the final sample ■ are
    what the best-gain survival compares). ``results[(prediction, seed)]``:
    ``GoalReachingResult``; ``spaces[prediction]``: the first seed's model's feature space."""
    import matplotlib.pyplot as plt

    first = seeds[0]
    fig = plt.figure(figsize=(13, 4.4))
    grid = fig.add_gridspec(1, 3, width_ratios=[1, 1, 1.25])
    for col, prediction in enumerate(("x0", "epsilon")):
        ax = fig.add_subplot(grid[0, col])
        result = results[(prediction, first)]
        guided = spaces[prediction].root_xz(result.guided).numpy()
        unguided = spaces[prediction].root_xz(result.unguided).numpy()
        for i in range(min(paths_shown, len(result.targets))):
            line, = ax.plot(guided[i, :, 0], guided[i, :, 1], lw=1.5)
            ax.plot(unguided[i, :, 0], unguided[i, :, 1], ls=":", lw=1, color=line.get_color())
            ax.plot(*result.targets[i], "x", color=line.get_color(), ms=8, mew=2)
        ax.plot(0, 0, "ko", ms=4)
        ax.set(xlabel="x (m)", ylabel="z (m)", aspect="equal",
               title=f"{_prediction_name(prediction)} model, seed {first}: guided (solid), "
                     "unguided (dotted), goal ×")
        ax.title.set_fontsize(8)
    ax = fig.add_subplot(grid[0, 2])
    for prediction, colour in (("x0", "tab:blue"), ("epsilon", "tab:orange")):
        for s in seeds:
            result = results[(prediction, s)]
            label = _prediction_name(prediction) if s == first else None
            ax.plot(result.timesteps, result.x0_error_guided.mean(axis=1), color=colour,
                    lw=1.4, label=label)
            ax.plot(result.timesteps, result.x0_error_unguided.mean(axis=1), color=colour,
                    lw=0.8, ls=":")
            ax.plot(result.best_step, result.best_step_error, "o", color=colour, ms=4)
            ax.plot(0, result.error_guided.mean(), "s", color=colour, ms=4)
    ax.axvline(results[("x0", first)].stop_guidance_at, color="grey", lw=0.8, ls="--")
    ax.set_xscale("symlog", linthresh=10)
    ax.set(xlabel="denoising step t (T−1 → 0, log beyond 10)", ylabel="goal error of x̂0 (m)",
           yscale="log", title="goal error over sampling (solid guided, dotted unguided; ● "
                               "closest approach, ■ final; dashed: stop step)")
    ax.title.set_fontsize(8)
    ax.invert_xaxis()
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_sample_quality(values: dict[str, list[float]], references: dict[str, float]) -> Figure:
    """GMD-A4: x0 vs ε bars (mean over seeds, dots: seeds) of joint jerk, FID and root jerk,
    with the data's value dashed; an arm without values (not trained at the run's scale) has
    no bar. ``references``: {"motion_jitter", "motion_fid", "trajectory_jitter"} of the
    data."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for ax, key, title in ((axes[0], "motion_jitter", "motion: joint jerk (m/s³)"),
                           (axes[1], "motion_fid", "motion: FID (stand-in evaluator)"),
                           (axes[2], "trajectory_jitter", "trajectory: root jerk (m/s³)")):
        for i, (tag, colour) in enumerate((("x0", "tab:blue"), ("eps", "tab:orange"))):
            if f"{key}_{tag}" not in values:
                continue
            per_seed = values[f"{key}_{tag}"]
            ax.bar(i, np.mean(per_seed), color=colour, alpha=0.6, width=0.6)
            ax.plot(np.full(len(per_seed), i), per_seed, "ko", ms=4)
        ax.axhline(references[key], color="grey", ls="--", lw=1, label="data")
        ax.set_xticks([0, 1], ["x0", "ε"])
        ax.set_yscale("log")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle("same UNet, same budget: bars = mean over seeds, dots = seeds", fontsize=9)
    fig.tight_layout()
    return fig


def plot_filmstrips(strips: dict[str, np.ndarray], *, frames: int = 8,
                    height: float = 2.5) -> Figure:
    """One filmstrip per title: ``strips[title]`` joints (T, 22, 3)."""
    import matplotlib.pyplot as plt

    from repro.motion.plotting import filmstrip

    fig, axes = plt.subplots(len(strips), 1, figsize=(11, height * len(strips)), squeeze=False)
    for ax, (title, joints) in zip(axes[:, 0], strips.items(), strict=True):
        filmstrip(joints, frames=frames, ax=ax, title=title)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------- every notebook: samples move

def animate_samples(models: Mapping[str, TrainedGMD], test: MotionWindows,
                    path: str | os.PathLike, *, seed: int, count: int = 2) -> Path:
    """A GIF of ``count`` test windows (drawn with ``seed``, one caption each, as the sample
    gates draw theirs: ``model_gates.sample_gate_data``) beside each model's sample for the
    same caption (``model_gates.motion_sample_values``' sampler: classifier-free guidance at
    GMD's scale for a text-conditioned model, else unconditional with ``seed``), each in its
    own world frame (``motion.plotting.animate_side_by_side``): a reader sees whether a
    model's bodies move as the data's do before reading any number."""
    evaluation = evaluation_set(test, count, seed=seed)
    count = len(evaluation)
    captions = evaluation.captions[:count]
    clips = {f"data: {shorten(c)}": features_to_joints(evaluation.features[k].astype(np.float64))
             for k, c in enumerate(captions)}
    for label, model in models.items():
        if model.vocabulary is not None:
            features = generate_for_captions(model, captions, seed=seed)
        else:
            with torch.no_grad():
                features = model.space.relative_features(
                    sample(model, count, seed=seed)).numpy()
        for k, c in enumerate(captions):
            clips[f"{label}: {shorten(c)}"] = features_to_joints(features[k].astype(np.float64))
    return animate_side_by_side(clips, path, columns=count)
