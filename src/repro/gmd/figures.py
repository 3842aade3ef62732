"""The figures of the GMD notebooks (01, 02, 03, 06): measured values in, a matplotlib Figure out.

Each function draws what a notebook measured (nothing is computed here that a verdict reads);
the notebook saves the figure with ``repro.motion.plotting.save_figure``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from repro.gmd.guidance import sample
from repro.gmd.guidance_schedule import ObstacleArm, ObstacleSet, StrengthSweep, strength_key
from repro.gmd.location_imputation import METHODS, ImputationRun, LocationTask
from repro.gmd.models import TrainedGMD
from repro.gmd.root_representation import (
    ROOT_PARAMETERS,
    SensitivityResult,
    SensitivitySetup,
    global_root_xz,
    root_jacobian,
)
from repro.gmd.table_b1 import (
    NOT_MEASURABLE,
    PAPER_TABLE_B1,
    TABLE_METRICS,
    evaluation_set,
    generate_for_captions,
    measurable,
)
from repro.gmd.windows import FeatureSpace, MotionWindows, short_label
from repro.motion.features import features_to_joints, relative_to_absolute_root
from repro.motion.plotting import animate_side_by_side, shorten

if TYPE_CHECKING:
    from matplotlib.figure import Figure


# ----------------------------------------------------------- notebook 02: root representation

def plot_representations(clip: np.ndarray, setup: SensitivitySetup, title: str) -> Figure:
    """One clip in both representations (root channels over time) and its top-down path
    after the early-frame perturbation of :class:`SensitivitySetup`, rel vs abs."""
    import matplotlib.pyplot as plt

    rel = np.asarray(clip, dtype=np.float64)[: setup.window]
    absolute = relative_to_absolute_root(rel)
    frames = np.arange(len(rel))
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    axes[0].plot(frames, rel[:, 0], label="ω (half-angle/frame)")
    axes[0].plot(frames, rel[:, 1], label="v_x (m/frame)")
    axes[0].plot(frames, rel[:, 2], label="v_z (m/frame)")
    axes[0].set_title("rel: root entries 0–2", fontsize=9)
    axes[1].plot(frames, absolute[:, 0], label="a (half-angle)")
    axes[1].plot(frames, absolute[:, 1], label="x (m)")
    axes[1].plot(frames, absolute[:, 2], label="z (m)")
    axes[1].set_title("abs: root entries 0–2", fontsize=9)
    for ax in axes[:2]:
        ax.axvline(setup.early_frame, color="grey", ls=":", lw=1)
        ax.set_xlabel("frame")
        ax.legend(fontsize=7)
    delta = np.asarray(setup.deltas()["both"])
    path = global_root_xz(torch.from_numpy(rel), "relative").numpy()
    moved_rel = rel.copy()
    moved_rel[setup.early_frame, ROOT_PARAMETERS] += delta
    moved_abs = absolute.copy()
    moved_abs[setup.early_frame, ROOT_PARAMETERS] += delta
    path_rel = global_root_xz(torch.from_numpy(moved_rel), "relative").numpy()
    path_abs = global_root_xz(torch.from_numpy(moved_abs), "absolute").numpy()
    ax = axes[2]
    ax.plot(path[:, 0], path[:, 1], "k-", lw=2, label="original")
    ax.plot(path_rel[:, 0], path_rel[:, 1], "-", color="tab:red", label="perturbed, rel")
    ax.plot(path_abs[:, 0], path_abs[:, 1], "--", color="tab:blue", label="perturbed, abs")
    ax.plot(*path[setup.early_frame], "o", color="grey", ms=5, label=f"frame {setup.early_frame}")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=7)
    ax.set_title("top-down root path", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_sensitivity(result: SensitivityResult, clip: np.ndarray,
                     real: SensitivityResult | None = None) -> Figure:
    """(a) mean displacement against the frame gap, rel (rotation, linear, both) and abs;
    (b, c) ‖∂p_t/∂(root entries of frame s)‖_F for one clip, rel and abs."""
    import matplotlib.pyplot as plt

    setup = result.setup
    gaps = setup.gaps
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    ax = axes[0]
    styles = {"rotation": ("tab:orange", "-"), "linear": ("tab:green", "-"),
              "both": ("tab:red", "-")}
    for name, (colour, style) in styles.items():
        ax.plot(gaps, result.displacement["relative"][name].mean(axis=0), style, color=colour,
                label=f"rel, {name}")
    ax.plot(gaps, result.displacement["absolute"]["both"].mean(axis=0), "o--", color="tab:blue",
            ms=3, label="abs, both")
    if real is not None:
        ax.plot(gaps, real.displacement["relative"]["both"][0], ":", color="black",
                label="rel, both (real clip 012314)")
    ax.axvspan(setup.late_gaps[0], setup.late_gaps[-1], color="grey", alpha=0.15,
               label="late frames")
    ax.set_xlabel(f"frame gap t − {setup.early_frame}")
    ax.set_ylabel("root displacement (m)")
    ax.set_title(f"δω = {setup.delta_rotation}, δv = {setup.delta_linear} at frame "
                 f"{setup.early_frame} (mean of {len(result.clip_ids)} clips)", fontsize=9)
    ax.legend(fontsize=7)
    rel = np.asarray(clip, dtype=np.float64)[: setup.window]
    for ax, rep, x in ((axes[1], "relative", rel),
                       (axes[2], "absolute", relative_to_absolute_root(rel))):
        jacobian = np.linalg.norm(root_jacobian(x, rep), axis=(1, 3))
        image = ax.imshow(jacobian, origin="lower", cmap="magma", aspect="auto")
        fig.colorbar(image, ax=ax, fraction=0.046)
        ax.set_xlabel("perturbed frame s")
        ax.set_ylabel("position frame t")
        ax.grid(False)
        ax.set_title(f"{short_label(rep)}: ‖∂p_t / ∂(entries 0–2 of frame s)‖_F", fontsize=9)
    fig.tight_layout()
    return fig


def plot_imputation(models: dict[str, TrainedGMD], runs: dict[str, ImputationRun],
                    task: LocationTask, samples: int = 4) -> Figure:
    """Top-down root paths of a few samples of every method, the targets marked."""
    import matplotlib.pyplot as plt

    by_short_label = {short_label(rep): rep for rep in models}
    fig, axes = plt.subplots(2, 3, figsize=(13, 8.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, method in zip(axes.ravel(), METHODS, strict=True):
        trained = models[by_short_label[method.split("_")[0]]]
        with torch.no_grad():
            paths = trained.space.root_xz(runs[method].samples[:samples]).numpy()
        for k, path in enumerate(paths):
            colour = colours[k % len(colours)]
            ax.plot(path[:, 0], path[:, 1], "-", color=colour, lw=1.3)
            ax.plot(*path[task.waypoint_frame], "o", color=colour, ms=4)
            ax.plot(*path[-1], ">", color=colour, ms=5)
            for target, marker in zip(task.targets[k], ("x", "*"), strict=True):
                ax.plot(*target, marker, color=colour, ms=10, mew=2)
        error = runs[method].mean_error
        ax.set_title(f"{method.replace('_', ' ')}: error {error:.3f} m", fontsize=9)
        ax.set_aspect("equal", adjustable="datalim")
    for ax in axes[-1]:
        ax.set_xlabel("x (m)")
    for ax in axes[:, 0]:
        ax.set_ylabel("z (m)")
    fig.suptitle(f"waypoint (×, frame {task.waypoint_frame}) and goal (*, last frame); "
                 "dots/arrows: where the samples are at those frames", fontsize=10)
    fig.tight_layout()
    return fig


def plot_method_errors(per_seed: dict[str, list[float]], ylabel: str, title: str) -> Figure:
    """Per-method bars (mean over seeds) with every seed's value as a dot."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6))
    names = list(per_seed)
    for i, name in enumerate(names):
        values = np.asarray(per_seed[name])
        ax.bar(i, values.mean(), color="tab:blue" if name.startswith("abs") else "tab:red",
               alpha=0.6)
        ax.plot(np.full(len(values), i), values, "k.", ms=6)
    ax.set_xticks(range(len(names)), [n.replace("_", "\n") for n in names], fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_yscale("log")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


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
    with the data's value dashed. ``references``: {"motion_jitter", "motion_fid",
    "trajectory_jitter"} of the data."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for ax, key, title in ((axes[0], "motion_jitter", "motion: joint jerk (m/s³)"),
                           (axes[1], "motion_fid", "motion: FID (stand-in evaluator)"),
                           (axes[2], "trajectory_jitter", "trajectory: root jerk (m/s³)")):
        for i, (tag, colour) in enumerate((("x0", "tab:blue"), ("eps", "tab:orange"))):
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


# ------------------------------------------------------------- notebook 06: guidance schedule

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

