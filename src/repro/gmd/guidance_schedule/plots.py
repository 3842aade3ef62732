"""The figures of notebook 06 (GMD-F1): the strength sweep and example paths, the guidance
per denoising step, the stop sweep, the second stage's whole-body coherence and the obstacle
extra. matplotlib is imported inside each function."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from repro.gmd.guidance_schedule.obstacles import ObstacleArm, ObstacleSet
from repro.gmd.guidance_schedule.sampling import StrengthSweep, strength_key
from repro.gmd.windows import FeatureSpace

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_example_paths", "plot_guidance_per_step", "plot_obstacles", "plot_stop_sweep",
           "plot_strength_sweep", "plot_whole_body_stop"]


def plot_strength_sweep(goal_by_s: dict[str, list[float]], jerk_by_s: dict[str, list[float]],
                        strengths: Sequence[float], seeds: Sequence[int], *, stop: int,
                        num_timesteps: int, claimed: tuple[float, float] = (100, 200),
                        goal_factor: float = 0.5, jerk_factor: float = 1.5) -> Figure:
    """GMD-F1: goal error and root jerk against s (per seed and their mean), the unguided
    level, the rule's factors of it and the claimed range. ``*_by_s[strength_key(s)]``:
    per-seed values."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12.5, 4.3))
    positions = np.array(strengths, dtype=float)
    for ax, values, label, factor in ((axes[0], goal_by_s, "goal error at the last frame (m)",
                                       goal_factor),
                                      (axes[1], jerk_by_s, "root jerk (m/s³)", jerk_factor)):
        table = np.array([values[strength_key(v)] for v in strengths])   # (strengths, seeds)
        for k, s in enumerate(seeds):
            ax.plot(positions, table[:, k], "o-", lw=0.8, ms=3, alpha=0.6, label=f"seed {s}")
        ax.plot(positions, table.mean(axis=1), "k-", lw=2, label="mean over seeds")
        reference = float(np.mean(values[strength_key(0)]))
        ax.axhline(reference, color="grey", ls="--", lw=1, label="unguided (s = 0)")
        ax.axhline(factor * reference, color="tab:red", ls=":", lw=1.3,
                   label=f"rule: {factor:g} × unguided")
        ax.axvspan(*claimed, color="tab:green", alpha=0.15,
                   label=f"claimed range s = {claimed[0]:g}–{claimed[1]:g}")
        ax.set_xscale("symlog", linthresh=1.0)
        ax.set_yscale("log")
        ax.set(xlabel="guidance strength s", ylabel=label)
        ax.legend(fontsize=7)
    axes[0].set_title(f"goal error vs s (guidance while t ≥ {stop} of T = {num_timesteps})",
                      fontsize=9)
    axes[1].set_title("coherence: mean root jerk vs s", fontsize=9)
    fig.tight_layout()
    return fig


def plot_example_paths(space: FeatureSpace, sweep: StrengthSweep, targets: np.ndarray,
                       picks: Sequence[float], *, seed: int, shown: int = 6) -> Figure:
    """Root paths of the first ``shown`` goals (×) at each strength of ``picks`` (same x_T)."""
    import matplotlib.pyplot as plt

    goals = list(range(min(shown, len(targets))))
    limit = float(np.abs(targets[goals]).max()) + 1.5
    rows = (len(picks) + 2) // 3
    fig, axes = plt.subplots(rows, 3, figsize=(12, 4.1 * rows), squeeze=False)
    for ax, v in zip(axes.ravel(), picks, strict=False):
        paths = space.root_xz(sweep.samples[sweep.index(v)][goals]).numpy()
        for i in goals:
            line, = ax.plot(paths[i, :, 0], paths[i, :, 1], lw=1.3)
            ax.plot(*targets[i], "x", color=line.get_color(), ms=8, mew=2)
        ax.plot(0, 0, "ko", ms=4)
        ax.set(xlim=(-limit, limit), ylim=(-limit, limit), aspect="equal", xlabel="x (m)",
               ylabel="z (m)")
        ax.set_title(f"s = {v}: goal error {sweep.mean_goal_error(v):.2f} m, jerk "
                     f"{sweep.mean_jerk(v):.3g} m/s³", fontsize=8)
    fig.suptitle(f"seed {seed}: root paths toward their goals (×), same x_T for every s; "
                 "paths leaving the frame are cut", fontsize=9)
    fig.tight_layout()
    return fig


def plot_guidance_per_step(record: StrengthSweep, shown: Sequence[float], *,
                           alpha_bar: np.ndarray, x0_bound: float, stop: int,
                           seed: int) -> Figure:
    """The mean |guidance shift| and the largest |x_t| per denoising step of a sweep run with
    ``record_steps``, for the strengths ``shown``, with 1/√ᾱ_t and the training data's range."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12.5, 4.2))
    for v in shown:
        g = record.index(v)
        size = np.where(record.shift_size[:, g] > 0, record.shift_size[:, g], np.nan)
        axes[0].semilogy(record.timesteps, size, lw=1.3, label=f"s = {v}")
        axes[1].semilogy(record.timesteps, record.state_size[:, g], lw=1.3, label=f"s = {v}")
    axes[1].semilogy(record.timesteps, record.state_size[:, record.index(0)], "k--", lw=1.2,
                     label="unguided")
    axes[1].axhline(x0_bound, color="tab:red", ls=":", lw=1,
                    label="max |x| of the training windows")
    twin = axes[0].twinx()
    twin.semilogy(np.arange(len(alpha_bar)), 1.0 / np.sqrt(alpha_bar), color="grey", ls=":",
                  lw=1.2)
    twin.set_ylabel("1/√ᾱ_t", color="grey")
    axes[0].set(xlabel="denoising step t (T−1 → 0)", ylabel="mean |guidance shift| (model units)",
                title=f"seed {seed}: guidance shift per step (guidance while t ≥ {stop})")
    axes[1].set(xlabel="denoising step t (T−1 → 0)", ylabel="largest |x_t| (model units)",
                title="the state being denoised")
    for ax in axes:
        ax.invert_xaxis()
        ax.legend(fontsize=7)
        ax.title.set_fontsize(9)
    fig.tight_layout()
    return fig


def plot_stop_sweep(stop_goal: dict[str, dict[int, list[float]]],
                    stop_jerk: dict[str, dict[int, list[float]]], stops: dict[int, int],
                    seeds: Sequence[int]) -> Figure:
    """Goal error, root jerk and the paired jerk ratio to stop 0 against the stop step, per
    arm. ``stop_*[arm][gmd stop]``: per-seed values; ``stops``: GMD stop → ours."""
    import matplotlib.pyplot as plt

    gmd_stops = list(stops)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    where = np.arange(len(gmd_stops))
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:red")
    for arm, colour in zip(stop_goal, colours, strict=False):
        for ax, values in ((axes[0], stop_goal[arm]), (axes[1], stop_jerk[arm])):
            table = np.array([values[g] for g in gmd_stops])           # (stops, seeds)
            ax.plot(where, table.mean(axis=1), "o-", color=colour, lw=1.6, label=arm)
            ax.plot(np.repeat(where, len(seeds)), table.ravel(), ".", color=colour, alpha=0.5)
        ratios = np.array([[j / j0 for j, j0 in zip(stop_jerk[arm][g], stop_jerk[arm][0],
                                                    strict=True)] for g in gmd_stops])
        for k in range(len(seeds)):
            axes[2].plot(where, ratios[:, k], "o-", color=colour, lw=0.8, ms=3, alpha=0.7,
                         label=arm if k == 0 else None)
    labels = [f"{g}\n(ours {stops[g]})" for g in gmd_stops]
    for ax, ylabel in ((axes[0], "goal error (m)"), (axes[1], "root jerk (m/s³)"),
                       (axes[2], "root jerk ÷ jerk with stop 0 (per seed)")):
        ax.set_xticks(where, labels)
        ax.set(xlabel="stop step: GMD's t of 1000 (ours of T)", ylabel=ylabel)
        ax.legend(fontsize=7)
    axes[0].set_yscale("symlog", linthresh=0.01)   # imputing down to t = 0 gives exactly 0
    axes[1].set_yscale("log")
    axes[2].axhline(1.0, color="grey", lw=0.8)
    axes[0].set_title("goal error vs stop step (mean; dots: seeds)", fontsize=9)
    axes[1].set_title("coherence vs stop step", fontsize=9)
    axes[2].set_title("paired: jerk relative to guiding down to t = 0", fontsize=9)
    fig.tight_layout()
    return fig


def plot_whole_body_stop(coherence: dict[str, dict[int, list[float]]], seeds: Sequence[int], *,
                         stops: dict[int, int], num_timesteps: int = 1000) -> Figure:
    """GMD-F1's whole-body coherence: joint jerk and foot skating of the second stage's motions
    per seed (lines join a seed's paired stops), ``coherence[metric][gmd stop]`` per-seed
    values for metrics "joint_jerk" (m/s³) and "foot_skating" (m/s); ``stops``: GMD's stop
    (of 1000) → the trajectory model's (of ``num_timesteps``)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
    where = np.arange(len(stops))
    for ax, (metric, ylabel) in zip(axes, (("joint_jerk", "joint jerk (m/s³)"),
                                           ("foot_skating", "foot skating (m/s)")), strict=True):
        table = np.array([coherence[metric][g] for g in stops])          # (stops, seeds)
        for k, s in enumerate(seeds):
            ax.plot(where, table[:, k], "o-", lw=1, ms=4, alpha=0.8, label=f"seed {s}")
        ax.plot(where, table.mean(axis=1), "k_", ms=20, mew=2, label="mean")
        ax.set_xticks(where, [f"stop at t = {t}\nof {num_timesteps}" for t in stops.values()])
        ax.set(ylabel=ylabel, title=f"whole body (second stage): {ylabel.split(' (')[0]}")
        ax.title.set_fontsize(9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_obstacles(space: FeatureSpace, arms: Sequence[ObstacleArm], obstacles: ObstacleSet,
                   goals: np.ndarray, per_arm: dict[str, dict[str, list[float]]], *,
                   strength: float, seed: int, seeds: Sequence[int], shown: int = 4) -> Figure:
    """Top: the first seed's root paths around their obstacles for the unguided arm and the
    arms at ``strength``; bottom: collision rate, penetration and goal error of every arm
    (bars: mean over seeds, dots: seeds). ``per_arm[label][metric]``: per-seed values."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    labels = [arm.label for arm in arms]
    fig = plt.figure(figsize=(14, 8.5))
    grid = fig.add_gridspec(2, 12)
    shown_arms = ["unguided"] + [label for label in labels
                                 if label.endswith(f"s={strength_key(strength)}")]
    picked = list(range(min(shown, len(goals))))
    limit = float(np.abs(goals[picked]).max()) + 1.0
    for k, label in enumerate(shown_arms):
        ax = fig.add_subplot(grid[0, 3 * k:3 * k + 3])
        arm = arms[labels.index(label)]
        paths = space.root_xz(arm.samples[picked]).numpy()
        for i in picked:
            line, = ax.plot(paths[i, :, 0], paths[i, :, 1], lw=1.3)
            colour = line.get_color()
            ax.plot(*goals[i], "x", color=colour, ms=8, mew=2)
            ax.add_patch(Circle(obstacles.centres[i], obstacles.radii[i], color=colour,
                                alpha=0.25))
        ax.plot(0, 0, "ko", ms=4)
        ax.set(xlim=(-limit, limit), ylim=(-limit, limit), aspect="equal", xlabel="x (m)")
        ax.set_title(f"{label}\ncollisions {arm.collision_rate:.2f}, goal error "
                     f"{arm.goal_error.mean():.2f} m", fontsize=8)
    where = np.arange(len(labels))
    for k, (metric, ylabel) in enumerate((("collision_rate", "collision rate"),
                                          ("penetration_m", "mean penetration (m)"),
                                          ("goal_error_m", "goal error (m)"))):
        ax = fig.add_subplot(grid[1, 4 * k:4 * k + 4])
        ax.bar(where, [np.mean(per_arm[label][metric]) for label in labels], color="tab:blue",
               alpha=0.5)
        for j, label in enumerate(labels):
            ax.plot(np.full(len(seeds), j), per_arm[label][metric], "k.", ms=5)
        ax.set_xticks(where, labels, rotation=60, ha="right", fontsize=7)
        ax.set_ylabel(ylabel)
    fig.suptitle(f"obstacle avoidance, {len(goals)} goals × {len(seeds)} seed(s); top: seed "
                 f"{seed}, s = {strength:g}; bars: mean over seeds, dots: seeds", fontsize=9)
    fig.tight_layout()
    return fig
