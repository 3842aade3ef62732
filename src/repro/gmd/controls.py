"""Positive and null controls beside the GMD model-based experiments (issue #13, item 3).

Each function runs the *same measurement code* as its experiment, on the same number of seeds
and items, on inputs whose truth is known: an exact model (GMD-A3) or the stand-in data
themselves (GMD-A4, C4) as the "model" (GMD-A3's, with exact and planted models, are in
``repro.gmd.controls_a3``). The **null** control draws both arms from the same
source with independent randomness per seed (no effect); the **positive** control takes the
null's inputs and plants every part's effect at its registered size δ
(``repro.claims.registry_gmd``), by an exact transformation wherever one exists (radial
scaling about the goal, a world-space scale of the body) and by a measured scale factor on
calibration draws (disjoint from the control's) where none does (FID). ``record_claim(...,
controls=...)`` decides both with the claim's own rule.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor

from repro.claims.result import Controls
from repro.gmd.emphasis_study import coherence
from repro.gmd.guidance import goal_error
from repro.gmd.guidance_schedule import strength_key
from repro.gmd.location_imputation import REGISTERED_METHODS, location_errors
from repro.gmd.measurements import foot_skating_of, jitter_of, motion_fid
from repro.gmd.windows import FeatureSpace, MotionWindows, goal_targets
from repro.motion.features import (
    FEATURE_BLOCKS,
    absolute_to_relative_root,
    relative_to_absolute_root,
)

__all__ = ["CONTROL_SEED_BASE", "a4_controls", "b2_controls", "c4_controls",
           "calibrate_increasing", "control_seed", "f1_controls",
           "scale_world"]

#: control randomness lives far from the experiments' seeds (0, 1, 2, …)
CONTROL_SEED_BASE = 1_000_000
#: a registered δ of "10 % of the reference arm's mean" is planted by dividing the other
#: arm's value by 0.9: then E[reference − other] = 0.1·E[reference] exactly
TENTH_FACTOR = 1 / 0.9
#: the absolute-root model channels of the root's world x and z (``FeatureSpace.root_xz``)
_ROOT_X, _ROOT_Z, _ROOT_Y = 1, 2, 3
_RIC = FEATURE_BLOCKS["ric_positions"]
#: features that no joint position reads (rotations, velocities, contacts): an offset there
#: moves the evaluator's embedding and leaves every joint, hence jitter, exactly unchanged
_NOT_JOINTS = slice(_RIC.stop, None)


def control_seed(seed: int, arm: int, stream: int = 0) -> int:
    """The sampling/draw seed of one control arm (``arm`` < 100, ``seed`` < 1000): distinct
    for every stream, seed and arm, and apart from the experiment's seeds."""
    return CONTROL_SEED_BASE + 100_000 * stream + 100 * int(seed) + arm


def calibrate_increasing(effect: Callable[[float], float], target: float, *, high: float,
                         iterations: int = 30, doublings: int = 20) -> float:
    """The size a ≥ 0 with ``effect(a)`` = ``target`` by bisection on [0, high], for an
    ``effect`` that grows with a (0 when effect(0) ≥ target: nothing left to plant). ``high``
    is doubled until it reaches the target, at most ``doublings`` times (then the largest size
    tried is returned: the caller records the effect it reached)."""
    if effect(0.0) >= target:
        return 0.0
    low = 0.0
    for _ in range(doublings):
        if effect(high) >= target:
            break
        low, high = high, 2 * high
    else:
        return high
    for _ in range(iterations):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if effect(middle) < target else (low, middle)
    return 0.5 * (low + high)


# --- exact planting in the absolute-root representation -----------------------------------

def scale_world(space: FeatureSpace, x: Tensor, factor: float, *,
                horizontal_only: bool = False) -> Tensor:
    """Model-space samples (B, C, T) whose joints are ``factor`` × the original ones.

    Joints are root + q⁻¹·ric with the root's x/z (and y) and the root-relative positions
    ric read directly (``absolute_features_to_joints``); q turns about the vertical, so it
    commutes with a scale. Scaling root x/z/y and ric scales every joint (jitter, a linear
    function of positions, scales by ``factor`` exactly); ``horizontal_only`` scales x and z
    only, so heights and hence foot contacts are kept and the foot speed in contact (foot
    skating) scales by ``factor`` exactly."""
    if space.representation != "absolute":
        raise ValueError("scale_world needs the absolute-root representation")
    features = space.unnormalise(x.detach()).clone()
    features[..., [_ROOT_X, _ROOT_Z]] *= factor
    if not horizontal_only:
        features[..., _ROOT_Y] *= factor
    if space.task == "motion":
        ric = features[..., _RIC].unflatten(-1, (-1, 3))
        axes = [0, 2] if horizontal_only else [0, 1, 2]
        ric[..., axes] *= factor
        features[..., _RIC] = ric.flatten(-2)
    return space.normalise(features)


def _offset_unread_features(space: FeatureSpace, x: Tensor, size: float,
                            direction: Tensor) -> Tensor:
    """x with the features no joint reads shifted by ``size`` × their std along a fixed unit
    ``direction`` (every frame, every sample)."""
    features = space.unnormalise(x.detach()).clone()
    std = torch.as_tensor(space.std[_NOT_JOINTS], dtype=features.dtype)
    features[..., _NOT_JOINTS] += size * std * direction.to(features.dtype)
    return space.normalise(features)


# --- GMD-A4: the data as the model, jitter and FID planted in the ε arm ---------------------

def _draw(windows: MotionWindows, n: int, seed: int) -> Tensor:
    picks = np.random.default_rng(seed).choice(len(windows), n, replace=len(windows) < n)
    return torch.from_numpy(np.sort(picks))


def _jag(space: FeatureSpace, x: Tensor, amplitude: float, seed: int) -> Tensor:
    """x with white noise of ``amplitude`` metres (a fixed draw of ``seed``) added to every
    position the joints read (root x/z/y and ric): frame-to-frame jaggedness. Relative-root
    windows get it on their root's world x/z (``relative_to_absolute_root`` and back), not on
    its velocity."""
    features = space.unnormalise(x.detach()).clone()
    relative = space.representation == "relative"
    if relative:
        features = relative_to_absolute_root(features)
    generator = torch.Generator().manual_seed(seed)
    for block in (slice(_ROOT_X, _ROOT_Y + 1), _RIC):
        noise = torch.randn(features[..., block].shape, generator=generator)
        features[..., block] += amplitude * noise.to(features.dtype)
    if relative:
        features = absolute_to_relative_root(features)
    return space.normalise(features)


def a4_controls(train: MotionWindows, seeds: Sequence[int], *, n: int, evaluator: Any,
                test_embeddings: np.ndarray, trajectory_train: MotionWindows | None = None,
                calibration_draws: int = 4, factor: float = 1.1) -> Controls:
    """GMD-A4's controls: ``n`` training windows per arm and seed stand in for each model's
    samples, measured with the experiment's code (joint jerk, FID against
    ``test_embeddings``, root jerk of the trajectory channels). ``train``: the motion models'
    windows; ``trajectory_train``: the trajectory models' (default ``train``).

    Null: independent draws for the two arms. Positive: the ε motion arm made jagged — white
    noise on every joint position, of the amplitude that raises the mean joint jerk of
    ``calibration_draws`` further draws by 10 % (part 1's δ; |log ratio| = log 1.1 with the
    trajectories left equal: part 3's δ) — and its non-joint features shifted along a fixed
    direction by the size that raises the FID of those jagged draws to 1.1 × that of the
    clean ones (part 2's δ; zero, and recorded, if the noise alone raises it further). Tests
    plant a larger effect through ``factor`` (both ratios)."""
    trajectory_train = train if trajectory_train is None else trajectory_train
    motion, trajectory = train.space("motion"), trajectory_train.space("trajectory")
    unread = motion.channels - _RIC.stop
    direction = torch.from_numpy(
        np.random.default_rng(control_seed(0, 0, stream=9)).standard_normal(unread)).float()
    direction = direction / direction.norm()
    calibration = [train.x[_draw(train, n, control_seed(k, 0, stream=8))]
                   for k in range(calibration_draws)]
    noise_seeds = [control_seed(k, 1, stream=8) for k in range(calibration_draws)]
    clean_jerk = np.mean([jitter_of(motion, x).jerk for x in calibration])
    clean_fid = np.mean([motion_fid(motion, x, evaluator, test_embeddings) for x in calibration])

    def jerk_ratio(amplitude: float) -> float:
        return float(np.mean([jitter_of(motion, _jag(motion, x, amplitude, k)).jerk
                              for x, k in zip(calibration, noise_seeds, strict=True)])
                     / clean_jerk)

    amplitude = calibrate_increasing(jerk_ratio, factor, high=1e-3)
    jagged = [_jag(motion, x, amplitude, k) for x, k in zip(calibration, noise_seeds,
                                                             strict=True)]

    def fid_ratio(size: float) -> float:
        return float(np.mean([motion_fid(motion, _offset_unread_features(motion, x, size,
                                                                         direction),
                                         evaluator, test_embeddings) for x in jagged])
                     / clean_fid)

    size = calibrate_increasing(fid_ratio, factor, high=0.5)
    null: dict[str, list[float]] = {}
    positive: dict[str, list[float]] = {}
    for s in seeds:
        arms = {tag: train.x[_draw(train, n, control_seed(s, k, stream=1))]
                for k, tag in enumerate(("x0", "eps"))}
        tracks = {tag: trajectory_train.trajectory()[_draw(trajectory_train, n,
                                                           control_seed(s, k, stream=2))]
                  for k, tag in enumerate(("x0", "eps"))}
        planted = _offset_unread_features(
            motion, _jag(motion, arms["eps"], amplitude, control_seed(s, 1, stream=3)), size,
            direction)
        for out, eps_motion in ((null, arms["eps"]), (positive, planted)):
            for tag, x in (("x0", arms["x0"]), ("eps", eps_motion)):
                out.setdefault(f"motion_jitter_{tag}", []).append(float(jitter_of(motion,
                                                                                  x).jerk))
                out.setdefault(f"motion_fid_{tag}", []).append(
                    motion_fid(motion, x, evaluator, test_embeddings))
                out.setdefault(f"trajectory_jitter_{tag}", []).append(
                    float(jitter_of(trajectory, tracks[tag]).jerk))
    return Controls(null=null, positive=positive,
                    planted={"jitter_noise_amplitude_m": amplitude,
                             "calibrated_jerk_ratio": jerk_ratio(amplitude),
                             "unread_feature_offset": size,
                             "calibrated_fid_ratio": fid_ratio(size),
                             "fid_ratio_of_noise_alone": fid_ratio(0.0),
                             "calibration_draws": calibration_draws,
                             "model": f"{n} training windows per arm and seed"},
                    null_text=(f"{n} training windows per arm, independent draws, "
                               f"{len(seeds)} seed(s)"),
                    positive_text=(f"the same draws; the ε motion arm jagged (white noise of "
                                   f"{1000 * amplitude:.3g} mm on every joint position: jerk × "
                                   f"{jerk_ratio(amplitude):.3g}) and its non-joint features "
                                   f"shifted (FID × {fid_ratio(size):.3g}), measured on "
                                   f"{calibration_draws} calibration draws"))


# --- GMD-C4: the data as the model, foot skating planted in the loss-scaling arm -----------

def c4_controls(test: MotionWindows, seeds: Sequence[int], values: Sequence[float], *,
                n: int, factor: float = TENTH_FACTOR) -> Controls:
    """GMD-C4's controls: ``n`` test windows per arm, value and seed stand in for the
    imputed samples, measured with the experiment's ``coherence`` (foot skating).

    Null: independent draws for the two arms. Positive: the loss-scaling arm's joints
    scaled horizontally by 1/0.9 (:func:`scale_world`: heights and contacts kept, foot speed
    × 1/0.9 exactly), so loss − emphasis = 10 % of loss scaling's foot skating (every value's
    δ) in expectation. Tests plant a larger effect through ``factor``."""
    space = test.space("motion")
    null: dict[str, Any] = {"values": [int(v) for v in values],
                            "foot_skating_loss_scaling": {}, "foot_skating_emphasis": {}}
    positive: dict[str, Any] = {"values": [int(v) for v in values],
                                "foot_skating_loss_scaling": {}, "foot_skating_emphasis": {}}
    for k, v in enumerate(values):
        key = f"{v:g}"
        for out in (null, positive):
            out["foot_skating_loss_scaling"][key], out["foot_skating_emphasis"][key] = [], []
        for s in seeds:
            loss = test.x[_draw(test, n, control_seed(s, 0, stream=10 + k))]
            emphasis = test.x[_draw(test, n, control_seed(s, 1, stream=10 + k))]
            skating = coherence(space, emphasis)["foot_skating"]
            for out, x in ((null, loss), (positive, scale_world(space, loss, factor,
                                                                 horizontal_only=True))):
                out["foot_skating_loss_scaling"][key].append(coherence(space, x)["foot_skating"])
                out["foot_skating_emphasis"][key].append(skating)
    return Controls(null=null, positive=positive,
                    planted={"foot_skating_factor_loss_scaling": factor,
                             "model": f"{n} test windows per arm, value and seed"},
                    null_text=(f"{n} test windows per arm, value and seed, independent draws, "
                               f"{len(seeds)} seed(s)"),
                    positive_text=(f"the same draws; the loss-scaling arm's motion stretched "
                                   f"horizontally × {factor:.3g} (foot skating × {factor:.3g}, "
                                   f"exact)"))


# --- GMD-B2: constructed samples with known location errors -------------------------------

#: E‖d‖ of d ~ N(0, σ²I₂) is σ·√(π/2): the σ that gives a mean location error r̄ is r̄/√(π/2)
_RAYLEIGH_MEAN = float(np.sqrt(np.pi / 2))


def _located(space: FeatureSpace, x: Tensor, frames: Sequence[int], targets: np.ndarray,
             offsets: np.ndarray) -> Tensor:
    """x with its root x/z at ``frames`` set to ``targets`` + ``offsets`` (n, len(frames), 2)."""
    features = space.unnormalise(x.detach()).clone()
    placed = torch.as_tensor(targets + offsets, dtype=features.dtype)
    for k, f in enumerate(frames):
        features[:, f, [_ROOT_X, _ROOT_Z]] = placed[:, k]
    return space.normalise(features)


def b2_controls(test: MotionWindows, tasks: Mapping[int, Any], seeds: Sequence[int], *,
                mean_error: float = 0.1, abs_factor: float = 0.9) -> Controls:
    """GMD-B2's controls: constructed samples whose location errors are known, measured with
    the experiment's ``location_imputation.location_errors`` (mean over samples and the two
    target frames). Each arm (``location_imputation.REGISTERED_METHODS``: imputation and
    guidance in each representation) is a draw of test trajectories (as many as the seed's
    task has targets) with the root at the waypoint and goal frames placed at the target plus
    a Gaussian offset d ~ N(0, σ²I₂), σ = ``mean_error``/√(π/2), so E‖d‖ = ``mean_error``.

    Null: every arm at 0.1 m (equal arms; abs imputation exactly at the 10 cm threshold).
    Positive: the same draws with both abs arms' offsets × 0.9 — abs error 0.09 m: rel − abs =
    0.01 m = 10 % of rel's (the δ of both difference parts) and 0.1 m − abs = 1 cm (the
    threshold part's δ), in expectation. Tests plant larger effects through ``abs_factor``.
    v1's names are filled as the experiment fills them (rel guidance, abs imputation)."""
    space = test.space("trajectory")
    sigma = mean_error / _RAYLEIGH_MEAN
    null: dict[str, list[float]] = {f"{m}_error": [] for m in REGISTERED_METHODS}
    positive: dict[str, list[float]] = {f"{m}_error": [] for m in REGISTERED_METHODS}
    for s in seeds:
        task = tasks[s]
        frames = list(task.frames)
        for k, method in enumerate(REGISTERED_METHODS):
            x = test.trajectory()[_draw(test, task.n, control_seed(s, k, stream=20))]
            offsets = sigma * np.random.default_rng(control_seed(s, k, stream=21)).standard_normal(
                (task.n, len(frames), 2))
            for out, factor in ((null, 1.0), (positive, abs_factor)):
                scale = factor if method.startswith("abs") else 1.0
                placed = _located(space, x, frames, task.targets, scale * offsets)
                out[f"{method}_error"].append(float(location_errors(space, placed, task).mean()))
    for out in (null, positive):
        out["rel_location_error"] = out["rel_guidance_error"]
        out["abs_location_error"] = out["abs_imputation_error"]
    return Controls(null=null, positive=positive,
                    planted={"mean_location_error_m": mean_error, "abs_offset_factor": abs_factor},
                    null_text=(f"test trajectories placed at the targets + Gaussian offsets of "
                               f"mean length {mean_error:g} m in all four arms, independent "
                               f"draws, {len(seeds)} seed(s)"),
                    positive_text=(f"the same draws; both abs arms' offsets × {abs_factor:g} "
                                   f"(mean {abs_factor * mean_error:.3g} m)"))


# --- GMD-F1: the data as the model, strength and stop effects planted ----------------------

def _planted_path(space: FeatureSpace, x: Tensor, targets: np.ndarray, *, jerk_factor: float,
                  goal_factor: float) -> Tensor:
    """Trajectories (B, 4, T) whose root jerk is ``jerk_factor`` × theirs (the root path
    scaled: jerk is linear in positions) and whose goal errors are ``goal_factor`` × theirs
    (the whole path then translated so its last frame lies at g + goal_factor·(p_last − g);
    a translation leaves the jerk unchanged)."""
    with torch.no_grad():
        last = space.root_xz(x)[:, -1].double()
        scaled = scale_world(space, x, jerk_factor)
        goal = torch.as_tensor(targets, dtype=torch.float64)
        shift = goal + goal_factor * (last - goal) - space.root_xz(scaled)[:, -1].double()
        features = space.unnormalise(scaled).clone()
        features[..., [_ROOT_X, _ROOT_Z]] += shift[:, None, :].to(features.dtype)
    return space.normalise(features)


def _coherence(space: FeatureSpace, x: Tensor) -> tuple[float, float]:
    """(mean joint jerk m/s³, foot skating m/s) of motion-task samples, as ``whole_body``."""
    return float(jitter_of(space, x).jerk), float(foot_skating_of(space, x))


def _smoother_body(space: FeatureSpace, x: Tensor, jerk_factor: float) -> Tensor:
    """Motions whose joint jerk is ``jerk_factor`` × theirs, by a horizontal scale of the
    body (:func:`scale_world`, heights and contacts kept) of the size that gives that ratio
    (bisection: a horizontal scale f lowers the jerk by less than f, so f ≤ ``jerk_factor``
    and the foot skating, × f exactly, falls at least as much)."""
    target = _coherence(space, x)[0] * jerk_factor

    def jerk_drop(shrink: float) -> float:
        return -_coherence(space, scale_world(space, x, 1 - shrink, horizontal_only=True))[0]

    shrink = calibrate_increasing(jerk_drop, -target, high=1 - jerk_factor, iterations=40)
    return scale_world(space, x, 1 - shrink, horizontal_only=True)


def f1_controls(test: MotionWindows, seeds: Sequence[int], strengths: Sequence[float], *,
                goals: int, min_distance: float, margin: float = 1.0) -> Controls:
    """GMD-F1's controls: test trajectories toward the experiment's goals stand in for the
    samples, measured as ``guidance_schedule.sweep_strengths`` measures them (mean goal error
    of the last frame, root jerk). Every arm is an independent draw; the unguided and the
    stop-0 arms are left as drawn, each other arm is built by :func:`_planted_path`.

    Null (every part exactly at its threshold, no effect): each strength's arm with goal
    errors × 0.5 and jerk × 1.5; the stop-20 arm with jerk × 1 and goal errors × 1.2.
    Positive (every part beyond its threshold by δ): goal errors × 0.45 (0.5·unguided −
    guided = 5 % of unguided), jerk × 1.4 (10 %), the stop-20 arm's jerk × 0.95 (5 % of stop
    0) and goal errors × 1.15 (5 %). Whole body (test motion windows): the null's stop-0 and
    stop-20 arms are two independent draws; the positive's stop-20 arm is the stop-0 draw
    itself made smoother by :func:`_smoother_body` (joint jerk × 0.95 exactly, foot skating
    lower by at least as much), paired as the experiment's two stops are (same x_T and
    noise). The worst of the three strengths is taken over
    independent arms, so the planted effect on "worst" is at most δ. Tests plant larger
    effects through ``margin`` (a multiple of every δ)."""
    space = test.space("trajectory")
    sizes = {"null": (0.5, 1.5, 1.0, 1.2),
             "positive": (0.5 - 0.05 * margin, 1.5 - 0.1 * margin, 1 - 0.05 * margin,
                          1.2 - 0.05 * margin)}
    out: dict[str, dict[str, Any]] = {
        kind: {"goal_error_unguided": [], "jitter_unguided": [],
               "goal_error_by_strength": {strength_key(v): [] for v in (0, *strengths)},
               "jitter_by_strength": {strength_key(v): [] for v in (0, *strengths)},
               "jitter_stop_0": [], "jitter_stop_20": [], "goal_error_stop_0": [],
               "goal_error_stop_20": [], "joint_jerk_stop_0": [], "joint_jerk_stop_20": [],
               "foot_skating_stop_0": [], "foot_skating_stop_20": []} for kind in sizes}
    motion = test.space("motion")

    def measure(x: Tensor, targets: np.ndarray) -> tuple[float, float]:
        return (float(goal_error(space, x, targets).mean()), float(jitter_of(space, x).jerk))

    for s in seeds:
        targets = goal_targets(test, goals, seed=s, min_distance=min_distance)
        arm = {name: test.trajectory()[_draw(test, goals, control_seed(s, k, stream=30))]
               for k, name in enumerate(("unguided", "stop_0", "stop_20",
                                         *(strength_key(v) for v in strengths)))}
        unguided, stop_0 = measure(arm["unguided"], targets), measure(arm["stop_0"], targets)
        for kind, (goal_f, jerk_f, stop_jerk_f, stop_goal_f) in sizes.items():
            m = out[kind]
            for key, (g, j) in (("unguided", unguided), ("stop_0", stop_0)):
                m["goal_error_unguided" if key == "unguided" else "goal_error_stop_0"].append(g)
                m["jitter_unguided" if key == "unguided" else "jitter_stop_0"].append(j)
            m["goal_error_by_strength"]["0"].append(unguided[0])
            m["jitter_by_strength"]["0"].append(unguided[1])
            for v in strengths:
                g, j = measure(_planted_path(space, arm[strength_key(v)], targets,
                                             jerk_factor=jerk_f, goal_factor=goal_f), targets)
                m["goal_error_by_strength"][strength_key(v)].append(g)
                m["jitter_by_strength"][strength_key(v)].append(j)
            g, j = measure(_planted_path(space, arm["stop_20"], targets, jerk_factor=stop_jerk_f,
                                         goal_factor=stop_goal_f), targets)
            m["goal_error_stop_20"].append(g)
            m["jitter_stop_20"].append(j)
        bodies = [test.x[_draw(test, goals, control_seed(s, k, stream=31))] for k in (0, 1)]
        for kind, (_, _, stop_jerk_f, _) in sizes.items():
            stop_20 = bodies[1] if kind == "null" else _smoother_body(motion, bodies[0],
                                                                       stop_jerk_f)
            for key, x in (("stop_0", bodies[0]), ("stop_20", stop_20)):
                coherent = _coherence(motion, x)
                out[kind][f"joint_jerk_{key}"].append(coherent[0])
                out[kind][f"foot_skating_{key}"].append(coherent[1])
    null_f, pos_f = sizes["null"], sizes["positive"]
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"null": dict(zip(("goal", "jerk", "stop_jerk", "stop_goal"), null_f,
                                              strict=True)),
                             "positive": dict(zip(("goal", "jerk", "stop_jerk", "stop_goal"),
                                                  pos_f, strict=True)),
                             "model": f"{goals} test trajectories per arm and seed"},
                    null_text=(f"{goals} test trajectories per arm (independent draws, "
                               f"{len(seeds)} seed(s)), every part at its threshold: guided "
                               f"goal error × {null_f[0]:g}, jerk × {null_f[1]:g}; stop 20: jerk "
                               f"× {null_f[2]:g}, goal error × {null_f[3]:g} (exact); whole "
                               f"body: {goals} test motion windows per stop, independent draws"),
                    positive_text=(f"the same draws beyond every threshold by δ: guided goal "
                                   f"error × {pos_f[0]:.3g}, jerk × {pos_f[1]:.3g}; stop 20: "
                                   f"jerk × {pos_f[2]:.3g}, goal error × {pos_f[3]:.3g} (exact); "
                                   f"whole body: the stop-0 motion windows, joint jerk × "
                                   f"{pos_f[2]:.3g} (exact), foot skating lower by at least as "
                                   f"much"))

