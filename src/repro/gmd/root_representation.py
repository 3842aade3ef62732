"""Relative vs absolute root representation (GMD appendix B; claims GMD-B1…B3).

Notation. A clip has T frames of HumanML3D features f_t (relative root, "rel") or of GMD's
absolute-root features g_t = rel→abs(f)_t ("abs"; REFERENCE.md "Absolute root"):

    rel:  f_t[0] = half-angle velocity ω_t,   f_t[1:3] = root x/z velocity v_t (facing frame)
    abs:  g_t[0] = accumulated half-angle a_t, g_t[1:3] = world root x/z p_t

and the global root path is (``features.recover_root``)

    a_t = Σ_{s<t} ω_s,    p_t = Σ_{s<t} R(2·a_{s+1})⁻¹ v_s        (rel; R = rotation about +Y)
    p_t = g_t[1:3]                                               (abs)

So in rel every p_t depends on all earlier ω_s and v_s, non-linearly through R(2a): a change
δω at frame i turns the whole remaining path about p_i by 2δω (a_{i+1} onward change, and
the step i → i+1 is taken in the facing frame of i+1), a change δv at frame i
shifts every later frame by δv. In abs p_t depends on g_t alone.

This module holds the logic of ``notebooks/02_root_representation.ipynb``, on top of the tiny-GMD
modules of ``repro.gmd``: the exact round trip and the sensitivity study (GMD-B1),
location imputation with both representations (GMD-B2) and the notebook's fixed settings
(:class:`Settings`). Table B.1 (GMD-B3) is ``repro.gmd.table_b1``; the figures are in
``repro.gmd.figures``. Representations are named as ``motion.humanml3d.REPRESENTATIONS``
("relative", "absolute"); "rel"/"abs" (``windows.short_label``) only name measurements.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import Guidance, Imputation
from repro.gmd.guidance import GMD_GUIDANCE_STRENGTH, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import (
    MOTION_TRAINING,
    TRAJECTORY_TRAINING,
    GMDModelSpec,
    TrainedGMD,
    training_fields,
)
from repro.gmd.windows import REPRESENTATIONS, DataConfig, FeatureSpace, MotionWindows, short_label
from repro.models.evaluator import EvaluatorConfig
from repro.motion.features import (
    absolute_features_to_joints,
    absolute_to_relative_root,
    features_to_joints,
    recover_root,
    relative_to_absolute_root,
)

if TYPE_CHECKING:
    pass

__all__ = [
    "METHODS",
    "MOTION_STEPS",
    "ROOT_PARAMETERS",
    "ImputationRun",
    "LocationTask",
    "RoundTrip",
    "SensitivityResult",
    "SensitivitySetup",
    "Settings",
    "abs_location_imputation",
    "global_root_xz",
    "impute_locations",
    "linearisation_error",
    "load_clips",
    "location_errors",
    "location_loss",
    "location_task",
    "perturbation_displacement",
    "rel_velocity_replacement",
    "root_jacobian",
    "round_trip",
    "sensitivity_study",
    "straight_line_velocities",
]

#: the root entries a perturbation touches: [0] rotation (ω or a), [1:3] linear (v or p).
ROOT_PARAMETERS = slice(0, 3)
#: training steps of the GMD-B3 motion models (full mode): ``GMDModelSpec``'s default step count.
#: A probe model (relative root, seed 99 — not a verdict seed; no verdict was computed) had a
#: training loss of 1.58 → 0.81 (step 500) → 0.55 (1000) → 0.47 (1500): still falling at 1000,
#: but 1500 would cost another ~50 % of the notebook's largest item; 1000 is the compromise.
MOTION_STEPS = 1000


# ------------------------------------------------------------------------------- round trip

@dataclass(frozen=True)
class RoundTrip:
    """Errors of the exact conversions on one clip (float64).

    ``rel_abs_rel``: max |abs→rel(rel→abs(f)) − f| over every entry except the last frame's
    dims 0–2 (not determined by abs and never read by ``recover_root``; GMD repeats the
    previous frame's values there). ``abs_rel_abs``: max |rel→abs(abs→rel(g)) − g| over all
    entries. ``joints``: max |features_to_joints(f) − absolute_features_to_joints(g)| (m).
    ``last_frame_velocity``: the (irrelevant) change of the last frame's dims 0–2, for the
    record.
    """

    rel_abs_rel: float
    abs_rel_abs: float
    joints: float
    last_frame_velocity: float
    frames: int

    @property
    def max_error(self) -> float:
        """The registered ``round_trip_max_error``: the larger of the two feature round trips."""
        return max(self.rel_abs_rel, self.abs_rel_abs)


def round_trip(features: np.ndarray) -> RoundTrip:
    """Both round trips of one relative-root clip (T, 263), computed in float64."""
    rel = np.asarray(features, dtype=np.float64)
    absolute = relative_to_absolute_root(rel)
    back = absolute_to_relative_root(absolute)
    determined = np.ones_like(rel, dtype=bool)
    determined[-1, ROOT_PARAMETERS] = False
    again = relative_to_absolute_root(absolute_to_relative_root(absolute))
    joints = np.abs(features_to_joints(rel) - absolute_features_to_joints(absolute)).max()
    return RoundTrip(
        rel_abs_rel=float(np.abs(back - rel)[determined].max()),
        abs_rel_abs=float(np.abs(again - absolute).max()),
        joints=float(joints),
        last_frame_velocity=float(np.abs(back - rel)[-1, ROOT_PARAMETERS].max()),
        frames=int(len(rel)),
    )


# ------------------------------------------------------------------------------ sensitivity

def global_root_xz(features: Tensor, representation: str) -> Tensor:
    """Global root x/z (..., T, 2): accumulated ("relative", ``recover_root``) or read
    ("absolute")."""
    if representation == "relative":
        return recover_root(features)[1][..., [0, 2]]
    if representation == "absolute":
        return features[..., 1:3]
    raise ValueError(f"representation must be one of {REPRESENTATIONS}, got {representation!r}")


def _with_root(features: Tensor, root: Tensor) -> Tensor:
    return torch.cat((root, features[..., 3:]), dim=-1)


def root_jacobian(features: np.ndarray | Tensor, representation: str) -> np.ndarray:
    """J[t, :, s, :] = ∂p_t / ∂(root entries 0:3 of frame s), shape (T, 2, T, 3), float64.

    rel: lower-triangular in (t, s) — p_t depends on every frame s < t; abs: J[t, :, t, 1:3]
    = I and zero elsewhere. Computed with ``torch.autograd.functional.jacobian``.
    """
    x = torch.as_tensor(np.asarray(features), dtype=torch.float64)
    root = x[:, ROOT_PARAMETERS].clone()

    def path(r: Tensor) -> Tensor:
        return global_root_xz(_with_root(x, r), representation)

    return torch.autograd.functional.jacobian(path, root).numpy()


def perturbation_displacement(features: np.ndarray | Tensor, representation: str, frame: int,
                              delta: Sequence[float]) -> np.ndarray:
    """‖p_t(f + δ·e_frame) − p_t(f)‖ for every t (T,), in metres: the exact (not linearised)
    change of the global root path when the root entries 0:3 of ``frame`` change by ``delta``.
    """
    x = torch.as_tensor(np.asarray(features), dtype=torch.float64)
    if not 0 <= frame < x.shape[-2]:
        raise ValueError(f"frame {frame} outside the clip's {x.shape[-2]} frames")
    step = torch.zeros_like(x)
    step[frame, ROOT_PARAMETERS] = torch.as_tensor(np.asarray(delta, dtype=np.float64))
    before = global_root_xz(x, representation)
    after = global_root_xz(x + step, representation)
    return (after - before).norm(dim=-1).numpy()


@dataclass(frozen=True)
class SensitivitySetup:
    """The sensitivity experiment, fixed before it ran (GMD-B1).

    Every clip is cut to its first ``window`` frames; the perturbed frame is ``early_frame``;
    the gap of frame t is t − ``early_frame`` (0 … window − 1 − early_frame; rel moves p_t
    only from gap 1 on, abs only at gap 0); *late frames* are the last ``late_frames`` frames
    of the window. The growth is the mean displacement at the largest gap over that at gap 1
    (the smallest gap at which rel is affected at all). Perturbations: ``delta_rotation`` on
    entry 0 (rel: the half-angle velocity ω, i.e. a heading change of 2·δ; abs: the
    accumulated half-angle a) and ``delta_linear`` on entries 1 and 2 (rel: the x/z velocity
    in m/frame; abs: the world x/z in m). The registered measurement uses all three at once.
    """

    window: int = 60
    early_frame: int = 5
    late_frames: int = 20
    delta_rotation: float = 0.01
    delta_linear: float = 0.01

    def __post_init__(self) -> None:
        if not 0 <= self.early_frame < self.window - self.late_frames:
            raise ValueError("the early frame must come before the late frames")

    @property
    def gaps(self) -> np.ndarray:
        return np.arange(0, self.window - self.early_frame)

    @property
    def late_gaps(self) -> np.ndarray:
        """Gaps of the late frames (frames window − late_frames … window − 1)."""
        first = self.window - self.late_frames - self.early_frame
        return np.arange(first, self.window - self.early_frame)

    def deltas(self) -> dict[str, tuple[float, float, float]]:
        r, v = self.delta_rotation, self.delta_linear
        return {"rotation": (r, 0.0, 0.0), "linear": (0.0, v, v), "both": (r, v, v)}


@dataclass
class SensitivityResult:
    """Displacements (clips, gaps) per representation and perturbation, and the summary."""

    setup: SensitivitySetup
    clip_ids: list[str]
    #: displacement[representation][perturbation]: (clips, gaps) in metres, gap = 0 … .
    displacement: dict[str, dict[str, np.ndarray]]
    #: travelled path length of each clip from the pivot p_i to the window's end (m).
    path_length: np.ndarray

    def late_mean(self, representation: str, perturbation: str = "both") -> float:
        """Mean displacement over clips and late frames (m): ``{rel,abs}_late_displacement``."""
        index = self.setup.late_gaps
        return float(self.displacement[representation][perturbation][:, index].mean())

    def growth(self, representation: str = "relative", perturbation: str = "both") -> float:
        """Mean displacement at the largest gap / at gap 1 (over clips); ``inf`` when nothing
        moves at gap 1 but something does later, ``nan`` when nothing moves at all."""
        curve = self.displacement[representation][perturbation].mean(axis=0)
        if curve[1] > 0:
            return float(curve[-1] / curve[1])
        return float("inf") if curve[-1] > 0 else float("nan")

    def measurements(self) -> dict[str, float]:
        """Exactly the names GMD-B1's rule reads (besides ``round_trip_max_error``)."""
        return {"rel_late_displacement": self.late_mean("relative"),
                "abs_late_displacement": self.late_mean("absolute"),
                "rel_sensitivity_growth": self.growth("relative")}

    def summary(self) -> dict[str, object]:
        """Every curve's mean at the smallest, a middle and the largest gap, and the setup."""
        out: dict[str, object] = {"setup": asdict(self.setup), "clips": len(self.clip_ids)}
        for rep, curves in self.displacement.items():
            for name, values in curves.items():
                mean = values.mean(axis=0)
                middle = len(mean) // 2
                out[f"{short_label(rep)}_{name}"] = {
                    "gap_0": float(mean[0]), "gap_1": float(mean[1]),
                    f"gap_{middle}": float(mean[middle]), f"gap_{len(mean) - 1}": float(mean[-1]),
                    "late_mean": self.late_mean(rep, name)}
        return out


def sensitivity_study(clips: Sequence[np.ndarray], setup: SensitivitySetup,
                      clip_ids: Sequence[str] | None = None) -> SensitivityResult:
    """Perturb the early frame's root entries of every clip (relative features (T ≥ window,
    263)) in both representations and record the exact displacement of every later frame."""
    clips = [np.asarray(c, dtype=np.float64)[: setup.window] for c in clips]
    if not clips or any(len(c) < setup.window for c in clips):
        raise ValueError(f"every clip needs at least {setup.window} frames")
    ids = list(clip_ids) if clip_ids is not None else [str(i) for i in range(len(clips))]
    later = slice(setup.early_frame, setup.window)
    displacement: dict[str, dict[str, np.ndarray]] = {r: {} for r in REPRESENTATIONS}
    for name, delta in setup.deltas().items():
        for rep in REPRESENTATIONS:
            rows = []
            for clip in clips:
                x = clip if rep == "relative" else relative_to_absolute_root(clip)
                rows.append(perturbation_displacement(x, rep, setup.early_frame, delta)[later])
            displacement[rep][name] = np.stack(rows)
    lengths = []
    for clip in clips:
        p = global_root_xz(torch.from_numpy(clip), "relative").numpy()[setup.early_frame:]
        lengths.append(float(np.linalg.norm(np.diff(p, axis=0), axis=-1).sum()))
    return SensitivityResult(setup, ids, displacement, np.asarray(lengths))


def linearisation_error(features: np.ndarray, frame: int, deltas: Sequence[float]) -> np.ndarray:
    """Non-linearity of rel: for each rotation perturbation δ, max_t ‖Δp_t − J·δ‖ / max_t ‖J·δ‖,
    the relative error of the first-order (Jacobian) prediction of the displaced path.
    Zero for abs (linear: p_t = g_t), and for rel's linear velocities (p is linear in v)."""
    x = np.asarray(features, dtype=np.float64)
    jacobian = root_jacobian(x, "relative")[:, :, frame, 0]           # (T, 2)
    errors = []
    for delta in deltas:
        base = global_root_xz(torch.from_numpy(x), "relative").numpy()
        moved = x.copy()
        moved[frame, 0] += delta
        exact = global_root_xz(torch.from_numpy(moved), "relative").numpy() - base
        linear = jacobian * delta
        errors.append(np.linalg.norm(exact - linear, axis=-1).max()
                      / max(np.linalg.norm(linear, axis=-1).max(), 1e-300))
    return np.asarray(errors)


# ------------------------------------------------------------------ GMD-B2: location imputation

#: the location-imputation methods compared in GMD-B2 (see :func:`impute_locations`).
METHODS = ("abs_unguided", "abs_imputation", "abs_guidance",
           "rel_unguided", "rel_guidance", "rel_velocity_replacement")


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
    replace them (GMD's ε-model imputation: x_{t−1} ← q_sample(target, t−1) on the mask)."""
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


def straight_line_velocities(task: LocationTask, frames: int) -> np.ndarray:
    """One of the infinitely many rel root-velocity sets whose cumulative sum hits both
    targets: no turning (ω_s = 0, so the facing frame is the world frame) and a constant x/z
    velocity per leg, v_s = w/i for s < i and (g − w)/(T−1 − i) for i ≤ s < T−1 (the last
    frame's velocity is never used; it repeats the previous one). Returns (n, frames, 3)."""
    i, last = task.frames
    velocity = np.zeros((task.n, frames, 3), dtype=np.float64)
    waypoint, goal = task.targets[:, 0].astype(np.float64), task.targets[:, 1].astype(np.float64)
    velocity[:, :i, 1:3] = (waypoint / i)[:, None, :]
    velocity[:, i:last, 1:3] = ((goal - waypoint) / (last - i))[:, None, :]
    velocity[:, last:, 1:3] = velocity[:, last - 1:last, 1:3]
    return velocity


def rel_velocity_replacement(space: FeatureSpace, task: LocationTask,
                             frames: int) -> Imputation:
    """rel: there is no entry holding p_i. A replacement that guarantees p_i must fix every
    entry p_i depends on — ω_s and v_s for all s < i — so here channels 0–2 of *every* frame
    are imputed with :func:`straight_line_velocities` (one arbitrary choice among infinitely
    many); only the root height (channel 3) is left to the model."""
    if space.representation != "relative":
        raise ValueError("rel_velocity_replacement needs a relative-root model")
    velocity = straight_line_velocities(task, frames)
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    mask[0, 0:3, :] = True
    target = torch.zeros(task.n, space.channels, frames)
    for c in range(3):
        target[:, c, :] = torch.from_numpy(
            _normalised(space, c, velocity[..., c]).astype(np.float32))
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
                     strength: float = GMD_GUIDANCE_STRENGTH) -> dict[str, ImputationRun]:
    """Every method of :data:`METHODS` from the same seed (same x_T and per-step noise), with
    GMD's stop step (guidance and imputation act while t ≥ 2 % of T).

    ``models``: {"absolute": absolute-root trajectory model, "relative": relative-root one};
    a method's name starts with the short label of its model's representation.
    abs_imputation: :func:`abs_location_imputation`; *_guidance: :func:`location_loss` with
    strength s (GMD: 100); rel_velocity_replacement: :func:`rel_velocity_replacement`.
    """
    runs: dict[str, ImputationRun] = {}
    for rep in ("absolute", "relative"):
        trained = models[rep]
        frames = trained.spec.data.frames
        if rep == "absolute":
            hooks = {"abs_unguided": {},
                     "abs_imputation": {"imputation": abs_location_imputation(
                         trained.space, task, frames)},
                     "abs_guidance": {"guidance": Guidance(location_loss(trained.space, task),
                                                           strength=strength)}}
        else:
            hooks = {"rel_unguided": {},
                     "rel_guidance": {"guidance": Guidance(location_loss(trained.space, task),
                                                           strength=strength)},
                     "rel_velocity_replacement": {"imputation": rel_velocity_replacement(
                         trained.space, task, frames)}}
        unguided_path = None
        for method, hook in hooks.items():
            x = sample(trained, task.n, seed=seed, **hook)
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


# ------------------------------------------------------------------ the notebook's settings

@dataclass(frozen=True)
class Settings:
    """Every size and step count of notebook 02, fixed before any verdict was seen.

    Full mode: GMD-B2 uses the trajectory ε model of notebook 01 (T = 100 cosine, 48-frame
    windows, ``paper_settings.TRAJECTORY_ARCHITECTURE`` trained to convergence,
    ``models.training_fields``) so the absolute-root models are the ones the other GMD
    notebooks train (shared through ``repro.infra.cache``); GMD-B3 a text-conditioned x0
    motion model (GMD's motion model predicts x0; ``paper_settings.MOTION_ARCHITECTURE``);
    ``trajectory_steps``/``motion_steps`` are the step caps. Quick mode shrinks everything
    (a test of the code, never a result).
    """

    quick: bool
    seeds: int
    stand_in_clips: int
    stride: int
    diffusion_steps: int
    trajectory_steps: int
    motion_steps: int
    sensitivity_clips: int
    targets: int
    evaluation_windows: int
    evaluator_steps: int

    @classmethod
    def for_mode(cls, quick: bool) -> Settings:
        if quick:
            return cls(quick=True, seeds=1, stand_in_clips=120, stride=8, diffusion_steps=20,
                       trajectory_steps=20, motion_steps=20, sensitivity_clips=8, targets=8,
                       evaluation_windows=96, evaluator_steps=30)
        return cls(quick=False, seeds=3, stand_in_clips=2000, stride=24, diffusion_steps=100,
                   trajectory_steps=TRAJECTORY_TRAINING.step_cap,
                   motion_steps=MOTION_TRAINING.step_cap, sensitivity_clips=64,
                   targets=64, evaluation_windows=256, evaluator_steps=500)

    def data(self, representation: str, data_dir: str | None = None) -> DataConfig:
        """48-frame windows in ``representation`` (one of ``REPRESENTATIONS``)."""
        return DataConfig(data_dir=data_dir, stand_in_clips=self.stand_in_clips,
                          stride=self.stride, representation=representation)

    def evaluator_config(self) -> EvaluatorConfig:
        """The package's evaluator with ``evaluator_steps`` (full mode: its default, 500)."""
        return EvaluatorConfig(steps=self.evaluator_steps)

    def trajectory_spec(self, representation: str, seed: int,
                        data_dir: str | None = None) -> GMDModelSpec:
        return GMDModelSpec(task="trajectory", prediction="epsilon",
                                data=self.data(representation, data_dir), seed=seed,
                                diffusion_steps=self.diffusion_steps,
                                **training_fields("trajectory", quick=self.quick,
                                                  step_cap=self.trajectory_steps))

    def motion_spec(self, representation: str, seed: int,
                    data_dir: str | None = None) -> GMDModelSpec:
        return GMDModelSpec(task="motion", prediction="x0", text_conditioned=True,
                                data=self.data(representation, data_dir), seed=seed,
                                diffusion_steps=self.diffusion_steps,
                                **training_fields("motion", quick=self.quick,
                                                  step_cap=self.motion_steps))


def load_clips(root: Path, split: str, *, min_frames: int, n: int) -> tuple[list[str],
                                                                            list[np.ndarray]]:
    """The first n clips of ``split`` with at least ``min_frames`` frames (relative features,
    unnormalised, as ``MotionDataset`` keeps them)."""
    from repro.motion.humanml3d import MotionDataset

    dataset = MotionDataset(root, split, normalise=False)
    ids, clips = [], []
    for index in range(len(dataset)):
        item = dataset[index]
        if item["length"] >= min_frames:
            ids.append(item["id"])
            clips.append(item["motion"][:item["length"]].numpy())
        if len(clips) == n:
            break
    return ids, clips
