"""GMD-B2: asking a trajectory model for locations, like for like in both root representations.

GMD appendix B: "imputing specific values becomes ill-posed [in rel] since there are many
possible sets of values that are satisfiable. On the other hand, for abs, the imputation and
optimization of z become straightforward as they only involve replacing or updating z(i)".
So the comparison is made twice, each mechanism against itself (issue #17):

* **imputation** — abs: the world x/z entries at the target frames *are* the locations and
  are replaced (:func:`abs_location_imputation`). rel: no entry holds a location; p_i is a
  cumulative sum of every earlier frame's heading and velocity, so a replacement has to fix
  all of them, and one of the many satisfying sets has to be picked
  (:func:`rel_location_imputation`, the choice and its reason there).
* **guidance** — the same L1 goal on the root recovered from x̂0, the same strength and stop
  step, in both (:func:`location_loss`).

Both mechanisms act while t ≥ the stop step: GMD's trajectory model imputes its key
locations and is guided while t ≥ 20 of T = 1000 (``sample/generate.py``: imputation of the
key points until ``impute_slack`` = 20, guidance until ``cond_until`` = 20). The free steps
after it are where a rel sample's small changes compound into its locations (GMD-B1). Part of
``notebooks/02_root_representation.ipynb``; the figures are in ``repro.gmd.figures``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import Guidance, Imputation
from repro.gmd.guidance import GMD_GUIDANCE_STRENGTH, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import FeatureSpace, MotionWindows
from repro.motion.features import FEATURE_DIM, absolute_to_relative_root

__all__ = [
    "METHODS",
    "REGISTERED_METHODS",
    "ImputationRun",
    "LocationTask",
    "abs_location_imputation",
    "facing_path_root",
    "impute_locations",
    "location_errors",
    "location_loss",
    "location_task",
    "registered_measurements",
    "rel_location_imputation",
]

#: the methods run on every seed: unguided, imputation and guidance in each representation.
METHODS = ("abs_unguided", "abs_imputation", "abs_guidance",
           "rel_unguided", "rel_imputation", "rel_guidance")
#: a method's registered measurement: ``<method>_error`` (the mean location error, m).
REGISTERED_METHODS = ("abs_imputation", "rel_imputation", "abs_guidance", "rel_guidance")


@dataclass(frozen=True)
class LocationTask:
    """Reach a waypoint at ``waypoint_frame`` and a goal at the last frame (GMD-B2).

    ``targets`` (n, 2, 2): for each sample the world x/z at the waypoint and at the goal,
    taken from one test window each (places a motion of the data set does reach in time).
    """

    targets: np.ndarray
    waypoint_frame: int
    goal_frame: int

    @property
    def frames(self) -> tuple[int, int]:
        return (self.waypoint_frame, self.goal_frame)

    @property
    def n(self) -> int:
        return int(self.targets.shape[0])


def location_task(test_windows: MotionWindows, n: int, *, seed: int) -> LocationTask:
    """n waypoint/goal pairs from n test windows drawn with ``seed``: the waypoint frame is
    the middle frame (frames/2 − 1), the goal frame the last."""
    frames = test_windows.frames
    waypoint = frames // 2 - 1
    if n > len(test_windows):
        raise ValueError(f"asked for {n} targets from {len(test_windows)} windows")
    picks = np.random.default_rng(seed).choice(len(test_windows), n, replace=False)
    space = test_windows.space("trajectory")
    with torch.no_grad():
        path = space.root_xz(test_windows.trajectory()[torch.from_numpy(picks)]).numpy()
    targets = path[:, [waypoint, frames - 1]]
    return LocationTask(targets.astype(np.float32), waypoint, frames - 1)


def location_loss(space: FeatureSpace, task: LocationTask) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = Σ_{i ∈ {waypoint, goal}} ‖p_xz(i) − target_i‖₁ (m) per sample: GMD's L1 goal
    function on the un-normalised root of x̂0, summed over the two target frames."""
    frames = list(task.frames)

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)[:, frames]                       # (B, 2, 2)
        target = torch.as_tensor(task.targets, dtype=position.dtype, device=position.device)
        return (position - target).abs().sum(dim=(1, 2))

    return goal


def location_errors(space: FeatureSpace, x: Tensor, task: LocationTask) -> np.ndarray:
    """Euclidean distance (m) of the root x/z to each target, (n, 2): waypoint, goal."""
    with torch.no_grad():
        position = space.root_xz(x.detach())[:, list(task.frames)].cpu().numpy()
    return np.linalg.norm(position - task.targets, axis=-1)


def _normalised(space: FeatureSpace, channel: int, values: np.ndarray) -> np.ndarray:
    return (values - space.mean[channel]) / space.std[channel]


def abs_location_imputation(space: FeatureSpace, task: LocationTask,
                            frames: int) -> Imputation:
    """abs: the root x/z entries (channels 1, 2) at the two target frames *are* the targets —
    replace them (GMD's ε-model imputation: x_{t−1} ← q_sample(target, t−1) on the mask, the
    target itself at t = 0); nothing else is touched."""
    if space.representation != "absolute":
        raise ValueError("abs_location_imputation needs an absolute-root model")
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    target = torch.zeros(task.n, space.channels, frames)
    for k, frame in enumerate(task.frames):
        mask[0, 1:3, frame] = True
        for c in (1, 2):
            target[:, c, frame] = torch.from_numpy(
                _normalised(space, c, task.targets[:, k, c - 1]).astype(np.float32))
    return Imputation(mask, target)


def _facing_half_angle(direction: np.ndarray) -> np.ndarray:
    """The heading half-angle a whose facing frame walks forward (+Z local) along the world
    x/z ``direction`` (..., 2): ``recover_root`` moves a local step (0, 0, v) by R(2a)⁻¹,
    i.e. to (−sin 2a, cos 2a)·v, so 2a = atan2(−d_x, d_z)."""
    return 0.5 * np.arctan2(-direction[..., 0], direction[..., 1])


def facing_path_root(task: LocationTask, frames: int) -> np.ndarray:
    """The rel root entries (n, frames, 3) — half-angle velocity ω and facing-frame x/z
    velocity v — of walking from the origin straight to the waypoint and on to the goal at a
    constant speed per leg, facing the direction of travel (a turn at the first step and at
    the waypoint). Built as an abs path (heading a_t, world p_t) and differenced with
    ``absolute_to_relative_root``, so ``recover_root`` reproduces p_t exactly; the last
    frame's entries repeat the previous frame's (never read)."""
    i, last = task.frames
    waypoint, goal = task.targets[:, 0].astype(np.float64), task.targets[:, 1].astype(np.float64)
    t = np.arange(frames, dtype=np.float64)[None, :, None]
    first_leg = waypoint[:, None, :] * np.minimum(t / i, 1.0)
    second_leg = (goal - waypoint)[:, None, :] * np.clip((t - i) / (last - i), 0.0, 1.0)
    position = first_leg + second_leg                                       # (n, frames, 2)
    heading_first = _facing_half_angle(waypoint)
    # the turn at the waypoint takes the shorter way round (2a unwrapped to within ±π)
    turn = np.angle(np.exp(2j * (_facing_half_angle(goal - waypoint) - heading_first))) / 2
    heading = np.zeros((task.n, frames))
    heading[:, 1:i + 1] = heading_first[:, None]
    heading[:, i + 1:] = (heading_first + turn)[:, None]
    absolute = np.zeros((task.n, frames, FEATURE_DIM))
    absolute[..., 0] = heading
    absolute[..., 1:3] = position
    return np.asarray(absolute_to_relative_root(absolute))[..., :3]


def rel_location_imputation(space: FeatureSpace, task: LocationTask,
                            frames: int) -> Imputation:
    """rel: no entry holds p_i, which depends on ω_s and v_s of every s < i, so an imputation
    that guarantees both locations must fix channels 0–2 of *every* frame (only the root
    height, channel 3, is left to the model) — GMD's code imputes a rel (MDM) model the same
    way, overwriting the root rotation and x/z velocity of all frames with those of a whole
    given trajectory. Two locations leave infinitely many such trajectories; we impute
    :func:`facing_path_root` (straight legs, facing the direction of travel), the one that
    asks nothing the locations do not imply and walks forward as the data do."""
    if space.representation != "relative":
        raise ValueError("rel_location_imputation needs a relative-root model")
    root = facing_path_root(task, frames)
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    mask[0, 0:3, :] = True
    target = torch.zeros(task.n, space.channels, frames)
    for c in range(3):
        target[:, c, :] = torch.from_numpy(_normalised(space, c, root[..., c]).astype(np.float32))
    return Imputation(mask, target)


@dataclass
class ImputationRun:
    """One method on one model: the samples (model space) and what was measured."""

    method: str
    samples: Tensor
    location_error: np.ndarray        # (n, 2) m: waypoint, goal
    root_acceleration: float          # m/s², mean over frames (jitter_of, root)
    path_change: float                # m, mean ‖p_t − p_t(unguided, same seed)‖ over all t
    path_change_off_target: float     # m, the same over frames ≥ 3 away from both targets

    @property
    def mean_error(self) -> float:
        return float(self.location_error.mean())

    def summary(self) -> dict[str, float]:
        return {"location_error": self.mean_error,
                "waypoint_error": float(self.location_error[:, 0].mean()),
                "goal_error": float(self.location_error[:, 1].mean()),
                "root_acceleration": self.root_acceleration, "path_change": self.path_change,
                "path_change_off_target": self.path_change_off_target}


def impute_locations(models: dict[str, TrainedGMD], task: LocationTask, *, seed: int,
                     stop_t: int, clip_x0: float | None,
                     strength: float = GMD_GUIDANCE_STRENGTH) -> dict[str, ImputationRun]:
    """Every method of :data:`METHODS` from the same seed (same x_T and per-step noise);
    imputation and guidance act while t ≥ ``stop_t`` (GMD: 20 of 1000), an ε model's x̂0 is
    clamped to ±``clip_x0`` (GMD: 6).

    ``models``: {"absolute": absolute-root trajectory model, "relative": relative-root one};
    a method's name starts with the short label of its model's representation.
    *_imputation: :func:`abs_location_imputation` / :func:`rel_location_imputation`;
    *_guidance: :func:`location_loss` with strength s (GMD: 100).
    """
    runs: dict[str, ImputationRun] = {}
    for rep, label, imputation in (("absolute", "abs", abs_location_imputation),
                                   ("relative", "rel", rel_location_imputation)):
        trained = models[rep]
        frames = trained.spec.data.frames
        hooks = {f"{label}_unguided": {},
                 f"{label}_imputation": {"imputation": imputation(trained.space, task, frames)},
                 f"{label}_guidance": {"guidance": Guidance(location_loss(trained.space, task),
                                                            strength=strength)}}
        unguided_path = None
        for method, hook in hooks.items():
            x = sample(trained, task.n, seed=seed, stop_guidance_at=stop_t, clip_x0=clip_x0,
                       **hook)
            with torch.no_grad():
                path = trained.space.root_xz(x).cpu().numpy()
            if unguided_path is None:
                unguided_path = path
            change = np.linalg.norm(path - unguided_path, axis=-1)          # (n, T)
            away = np.ones(frames, dtype=bool)
            for frame in task.frames:
                away[max(frame - 2, 0):frame + 3] = False
            runs[method] = ImputationRun(
                method, x.cpu(), location_errors(trained.space, x, task),
                float(jitter_of(trained, x, part="root").acceleration),
                float(change.mean()), float(change[:, away].mean()))
    return runs


def registered_measurements(runs: dict[int, dict[str, ImputationRun]]) -> dict[str, list[float]]:
    """GMD-B2's measured values: per seed (in ``runs``' order) the mean location error (m) of
    each registered method, named ``<method>_error``, and v1's two names."""
    measured = {f"{method}_error": [per_seed[method].mean_error for per_seed in runs.values()]
                for method in REGISTERED_METHODS}
    # v1's names and meanings (rel guidance vs abs imputation), which its frozen rule reads
    measured["rel_location_error"] = measured["rel_guidance_error"]
    measured["abs_location_error"] = measured["abs_imputation_error"]
    return measured
