"""Notebook 06 (GMD appendix F): guidance strength s and the stop step (claim GMD-F1).

GMD (appendix F; REFERENCE.md "Guidance") guides its ε trajectory model with goal functions
on x̂0, μ̃ = μ − s·Σ_t·∇_{x_t}G(x̂0), with s = 100 ("performs well within the range of 100 to
200"), imputes where feasible, and stops both at t = 20 of T = 1000 "as this led to a slight
improvement in the motion coherence". For obstacle avoidance it drops point-to-point
imputation, which could lead through an obstacle.

This module adds what notebook 06 needs on top of ``repro.gmd.guidance`` (whose sampler and goal
functions it reuses unchanged):

- ``model_stop_step``: GMD's stop step mapped to a model with another T (same fraction of T:
  the identity at GMD's T = 1000; used for quick mode and the T = 100 motion model);
- ``sweep_strengths``: one sampling call for many strengths at once (a per-sample strength is
  exactly a guidance of strength 1 on Σ_b s_b·G_b, because samples do not interact), with
  the same x_T for every strength;
- goal-keypoint and point-to-point imputation targets (GMD's two imputations, absolute root);
- per-sample circular obstacles: a hinge cost, penetration depth, collisions;
- GMD's second stage (``whole_body``): the x0 motion model with a guided trajectory imputed
  into its root channels, for the whole-body coherence of GMD-F1 — run where the scale runs
  that part (``Settings.runs_second_stage``; the standard scale registers it as not run);
- the study: the models, the sweeps over the seeds in the notebook's order, the per-seed lists
  the registered rule reads, GMD-F1's controls, figures and :func:`f1_result`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from repro.claims.result import ClaimResult, Controls
from repro.core.diffusion import Guidance, Imputation
from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    Slot,
    aa_controls,
    aa_readings,
    calibrate_increasing,
    control_seed,
    draw_indices,
    planted_path,
    reference_model,
    scale_world,
)
from repro.gmd.guidance import Clamp, goal_error, goal_reaching_loss, guidance_parameters, sample
from repro.gmd.measurements import (
    foot_skating_of,
    jitter_of,
)
from repro.gmd.models import (
    GUIDANCE_DIFFUSION_STEPS,
    GUIDANCE_STOP_T,
    GMDModelSpec,
    TrainedGMD,
    describe,
    is_cached,
    load_or_train_many,
    schedule_diffusion,
)
from repro.gmd.settings import seeds_of
from repro.gmd.windows import (
    DataDir,
    FeatureSpace,
    MotionWindows,
    goal_targets,
    load_windows,
)
from repro.gmd.x0_vs_eps import Settings as ModelSettings
from repro.infra.context import RunSettings, check_scale

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["GMD_NUM_TIMESTEPS", "ObstacleArm", "ObstacleSet", "ObstacleStudy", "ROOT_CHANNELS",
           "ScheduleModels", "SecondStage", "Settings", "StopReading", "StrengthSweep", "Sweeps",
           "WHOLE_BODY_MEASUREMENTS", "WHOLE_BODY_PART", "WholeBody", "f1_aa_controls",
           "f1_controls", "f1_result", "f1_slots", "goal_keypoint_imputation", "load_models",
           "model_stop_step", "motion_records", "obstacle_cost", "obstacle_experiment",
           "obstacle_study", "obstacles_between", "penetration_depth", "plot_example_paths",
           "plot_guidance_per_step", "plot_obstacles", "plot_stop_sweep", "plot_strength_sweep",
           "plot_whole_body_stop", "point_to_point_imputation", "run_sweeps", "second_stage",
           "shared_start_noise", "strength_key", "sweep_strengths", "trajectory_imputation",
           "trajectory_records", "weighted_guidance", "whole_body"]

#: GMD's number of diffusion steps (Table D.1): its "t = 20" is a step of T = 1000.
GMD_NUM_TIMESTEPS = GUIDANCE_DIFFUSION_STEPS


#: model channels of the world root x and z in the absolute-root trajectory view (angle, x, z, y)
X_CHANNEL, Z_CHANNEL = 1, 2


def model_stop_step(gmd_step: int, num_timesteps: int) -> int:
    """GMD's stop step ``gmd_step`` (of T = 1000) at the same fraction of ``num_timesteps``:
    round(gmd_step · T_model / 1000). The cosine schedule is a function of t/T, so the noise
    level ᾱ at which guidance stops is (nearly) the same; e.g. 20 → 2 at T = 100."""
    if not 0 <= gmd_step <= GMD_NUM_TIMESTEPS:
        raise ValueError(f"gmd_step must be in [0, {GMD_NUM_TIMESTEPS}], got {gmd_step}")
    return int(round(gmd_step * num_timesteps / GMD_NUM_TIMESTEPS))


def strength_key(strength: float) -> str:
    """The key of a strength in the registered measurements: ``str(s)`` of the number as
    written, e.g. 100.0 → "100", 0.5 → "0.5"."""
    return f"{float(strength):g}"


def weighted_guidance(goal_fn: Callable[[Tensor], Tensor], strengths: Tensor | Sequence[float],
                      ) -> Guidance:
    """Guidance with a strength per sample: goal Σ_b s_b·G_b(x̂0) at strength 1.

    The samples of a batch do not interact (the UNet normalises per sample), so
    ∇_{x_t^b} Σ_b' s_b'·G_b' = s_b·∇_{x_t^b} G_b and the shift −Σ_t·s_b·∇G_b is exactly that of
    a separate run with strength s_b (``diffusion.Guidance``)."""
    weights = torch.as_tensor(np.asarray(strengths, dtype=np.float32))

    def goal(pred_x0: Tensor) -> Tensor:
        values = goal_fn(pred_x0)
        if values.shape != (pred_x0.shape[0],):
            raise ValueError(f"goal_fn must return one value per sample, got {values.shape}")
        return weights.to(values.device, values.dtype) * values

    return Guidance(goal, strength=1.0)


def shared_start_noise(trained: TrainedGMD, n: int, groups: int, *, seed: int) -> Tensor:
    """x_T (groups·n, C, frames): n draws (generator seeded with ``seed``) repeated for each of
    ``groups`` groups, so every strength starts sample i from the same x_T."""
    generator = torch.Generator().manual_seed(int(seed))
    x_t = torch.randn((n, trained.space.channels, trained.spec.data.frames),
                      generator=generator)
    return x_t.repeat(groups, 1, 1).to(trained.device)


def _check_absolute(space: FeatureSpace) -> None:
    if space.task != "trajectory" or space.representation != "absolute":
        raise ValueError("location imputation needs the absolute-root trajectory model "
                         f"(got {space.task}, {space.representation}); in the relative "
                         "representation a location is not a feature (GMD appendix B)")


def _normalised_xz(space: FeatureSpace, xz: np.ndarray) -> np.ndarray:
    """World x/z (..., 2) in metres → the model's normalised channels 1 and 2."""
    mean = np.asarray(space.mean, dtype=np.float32)[[X_CHANNEL, Z_CHANNEL]]
    std = np.asarray(space.std, dtype=np.float32)[[X_CHANNEL, Z_CHANNEL]]
    return (np.asarray(xz, dtype=np.float32) - mean) / std


def goal_keypoint_imputation(trained: TrainedGMD, targets_xz: np.ndarray,
                             active: Sequence[bool] | np.ndarray | None = None,
                             frame: int = -1) -> Imputation:
    """Impute the goal (B, 2) as the root x/z of frame ``frame`` (GMD's key-location
    imputation); ``active`` (B,) picks the samples that are imputed (default all)."""
    space = trained.space
    _check_absolute(space)
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    n, frames = len(targets), trained.spec.data.frames
    target = torch.zeros((n, space.channels, frames))
    mask = torch.zeros((n, space.channels, frames), dtype=torch.bool)
    goal = torch.from_numpy(_normalised_xz(space, targets))
    target[:, [X_CHANNEL, Z_CHANNEL], frame] = goal
    mask[:, [X_CHANNEL, Z_CHANNEL], frame] = True
    if active is not None:
        mask &= torch.as_tensor(np.asarray(active, dtype=bool))[:, None, None]
    return Imputation(mask, target)


def point_to_point_imputation(trained: TrainedGMD, targets_xz: np.ndarray,
                              active: Sequence[bool] | np.ndarray | None = None) -> Imputation:
    """Impute the straight line from the start (origin) to the goal at the last frame, evenly
    spaced over all frames, as root x/z (GMD's point-to-point trajectory imputation)."""
    space = trained.space
    _check_absolute(space)
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    n, frames = len(targets), trained.spec.data.frames
    fraction = np.linspace(0.0, 1.0, frames, dtype=np.float32)
    line = targets[:, None, :] * fraction[None, :, None]                   # (B, frames, 2)
    target = torch.zeros((n, space.channels, frames))
    target[:, [X_CHANNEL, Z_CHANNEL], :] = torch.from_numpy(
        _normalised_xz(space, line)).transpose(1, 2)
    mask = torch.zeros((n, space.channels, frames), dtype=torch.bool)
    mask[:, [X_CHANNEL, Z_CHANNEL], :] = True
    if active is not None:
        mask &= torch.as_tensor(np.asarray(active, dtype=bool))[:, None, None]
    return Imputation(mask, target)


@dataclass
class StrengthSweep:
    """One sampling call: ``len(strengths)`` groups of the same n goals, group g guided with
    strength ``strengths[g]``, all stopping at model step ``stop`` (guidance while t ≥ stop).

    ``samples`` (G, n, C, frames) in model space; ``goal_error`` (G, n) in metres;
    ``jerk``/``acceleration`` (G,) the mean root jerk (m/s³) / acceleration (m/s²) of each
    group (``jitter_of``); ``imputed`` whether the goal keypoint was also imputed.
    With ``record_steps``: ``timesteps`` (S,) T−1 … 0, ``shift_size`` (S, G) the mean
    |guidance shift| −s·Σ_t·∇G per entry of each group, ``state_size`` (S, G) the largest
    |x_t| of each group (both in model units, at the input of each step).
    """

    strengths: np.ndarray
    stop: int
    targets: np.ndarray
    samples: Tensor
    goal_error: np.ndarray
    jerk: np.ndarray
    acceleration: np.ndarray
    imputed: bool
    timesteps: np.ndarray | None = None
    shift_size: np.ndarray | None = None
    state_size: np.ndarray | None = None

    def index(self, strength: float) -> int:
        """The group of ``strength``."""
        hits = np.flatnonzero(np.isclose(self.strengths, float(strength)))
        if not len(hits):
            raise KeyError(f"strength {strength} not in the sweep {self.strengths.tolist()}")
        return int(hits[0])

    def mean_goal_error(self, strength: float) -> float:
        return float(self.goal_error[self.index(strength)].mean())

    def mean_jerk(self, strength: float) -> float:
        return float(self.jerk[self.index(strength)])


def sweep_strengths(trained: TrainedGMD, targets_xz: np.ndarray,
                    strengths: Sequence[float], *, seed: int, stop: int,
                    impute_goal: bool = False, frame: int = -1,
                    record_steps: bool = False, clip_x0: Clamp = "gmd") -> StrengthSweep:
    """Sample the goals (n, 2) once per strength in one batch, with GMD's goal guidance
    (``goal_reaching_loss``: ½‖root_xz(x̂0)[frame] − goal‖₁) and, if ``impute_goal``,
    the goal keypoint imputed too; both act while t ≥ ``stop`` (model steps).

    ``clip_x0`` "gmd" (registered): an ε model's x̂0 clamped to GMD's ±6. Same x_T for every
    strength (``shared_start_noise``); the per-step noise comes from
    ``seed`` and the batch position, so two calls with the same strengths, goals and seed but
    another ``stop`` are paired sample by sample (imputation draws extra noise while active,
    which pairs only calls with the same active steps).
    """
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    values = np.asarray(strengths, dtype=np.float64)
    if values.ndim != 1 or not len(values) or np.any(values < 0):
        raise ValueError(f"strengths must be a non-empty list of values >= 0, got {strengths}")
    n, groups = len(targets), len(values)
    all_targets = np.tile(targets, (groups, 1))
    per_sample = np.repeat(values, n)
    guidance = weighted_guidance(goal_reaching_loss(trained.space, all_targets, frame),
                                 per_sample)
    imputation = goal_keypoint_imputation(trained, all_targets, frame=frame) if impute_goal \
        else None
    out = sample(trained, n * groups, seed=seed, guidance=guidance, imputation=imputation,
                 stop_guidance_at=stop, return_trajectory=record_steps, clip_x0=clip_x0,
                 noise=shared_start_noise(trained, n, groups, seed=seed))
    x = (out[0] if record_steps else out).cpu()
    error = goal_error(trained.space, x, all_targets, frame).reshape(groups, n)
    samples = x.reshape(groups, n, *x.shape[1:])
    jitters = [jitter_of(trained.space, samples[g]) for g in range(groups)]
    sweep = StrengthSweep(values, int(stop), targets, samples, error,
                          np.array([j.jerk for j in jitters]),
                          np.array([j.acceleration for j in jitters]), impute_goal)
    if record_steps:
        path = out[1]
        steps = len(path.timesteps)
        shift = path.guidance_shift.reshape(steps, groups, -1)
        state = path.x_t.reshape(steps, groups, -1)
        sweep.timesteps = np.asarray(path.timesteps)
        sweep.shift_size = shift.abs().mean(dim=2).double().numpy()
        sweep.state_size = state.abs().amax(dim=2).double().numpy()
    return sweep


# ---------------------------------------------------------------------------------------------
# GMD's second stage: the whole body under a guided trajectory
# ---------------------------------------------------------------------------------------------

#: the root channels (heading angle, x, z, y) shared by the trajectory and motion features
ROOT_CHANNELS = slice(0, 4)

#: GMD-F1's part that reads the second stage (whole-body coherence), and only that part
WHOLE_BODY_PART = "stop_at_20_more_coherent"

#: the measurements of ``WHOLE_BODY_PART``: joint jerk and foot skating at GMD's stops 0 and 20
WHOLE_BODY_MEASUREMENTS = ("joint_jerk_stop_0", "joint_jerk_stop_20", "foot_skating_stop_0",
                           "foot_skating_stop_20")


def trajectory_imputation(motion: TrainedGMD, trajectory_space: FeatureSpace,
                          trajectories: Tensor) -> Imputation:
    """Impute trajectories (B, 4, T) of ``trajectory_space`` as the root channels (angle, x, z,
    y) of ``motion``'s samples, every frame (GMD's two-stage generation: "generate trajectory
    first, then use it to impute to generate motion", ``gen_two_stages``). Both feature
    spaces must be absolute-root; each normalises with its own statistics."""
    space = motion.space
    if space.task != "motion" or space.representation != "absolute":
        raise ValueError("the second stage needs the absolute-root motion model")
    _check_absolute(trajectory_space)
    root = trajectory_space.unnormalise(trajectories.detach().cpu())           # (B, T, 4)
    features = root.new_zeros(*root.shape[:2], space.channels)
    features[..., ROOT_CHANNELS] = root
    target = space.normalise(features)                                         # (B, C, T)
    mask = torch.zeros_like(target, dtype=torch.bool)
    mask[:, ROOT_CHANNELS, :] = True
    return Imputation(mask, torch.where(mask, target, torch.zeros_like(target)))


@dataclass
class WholeBody:
    """The second stage's motions (B, 263, T) under ``trajectories`` (B, 4, T), with the
    imputation acting while t ≥ ``motion_stop`` (the motion model's steps), and their
    whole-body coherence: mean joint jerk (m/s³) and foot skating (m/s) of the recovered
    joints, and the goal error (m) of the motions' own root at the last frame."""

    motion_stop: int
    trajectories: Tensor
    motions: Tensor
    joint_jerk: float
    foot_skating: float
    goal_error: np.ndarray


def whole_body(motion: TrainedGMD, trajectory_space: FeatureSpace, trajectories: Tensor,
               targets_xz: np.ndarray, *, seed: int, gmd_stop: int) -> WholeBody:
    """GMD's second stage for guided trajectories: the motion model samples with the
    trajectories imputed into its root channels (:func:`trajectory_imputation`) while t ≥
    GMD's stop ``gmd_stop`` (of T = 1000) on the motion model's own T (``model_stop_step``:
    the same fraction of its steps; GMD stops guidance and imputation at t = 20 in both
    stages). Same ``seed``, same x_T and per-step noise for every ``gmd_stop``."""
    stop = model_stop_step(gmd_stop, motion.num_timesteps)
    x = sample(motion, len(trajectories), seed=seed, stop_guidance_at=stop,
               imputation=trajectory_imputation(motion, trajectory_space, trajectories)).cpu()
    return WholeBody(stop, trajectories.cpu(), x, float(jitter_of(motion, x).jerk),
                     float(foot_skating_of(motion, x)),
                     goal_error(motion.space, x, np.asarray(targets_xz, dtype=np.float32)))


# ---------------------------------------------------------------------------------------------
# Obstacles
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObstacleSet:
    """One circular obstacle per sample: ``centres`` (B, 2) world x/z and ``radii`` (B,), m."""

    centres: np.ndarray
    radii: np.ndarray

    def __post_init__(self) -> None:
        if self.centres.shape != (len(self.radii), 2):
            raise ValueError(f"centres {self.centres.shape} and radii {self.radii.shape} "
                             "must be (B, 2) and (B,)")

    def tile(self, groups: int) -> ObstacleSet:
        """The same obstacles for ``groups`` consecutive groups of samples."""
        return ObstacleSet(np.tile(self.centres, (groups, 1)), np.tile(self.radii, groups))


def obstacles_between(targets_xz: np.ndarray, *, position: float = 0.5,
                      radius_fraction: float = 0.3, max_radius: float = 0.4) -> ObstacleSet:
    """An obstacle on the straight line from the start (origin) to each goal, at ``position``
    of the way, radius min(``max_radius``, ``radius_fraction``·‖goal‖). With the defaults the
    start and the goal are ≥ 0.2·‖goal‖ outside the circle: it blocks the straight path but
    can be walked around."""
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    distance = np.linalg.norm(targets, axis=1)
    radii = np.minimum(max_radius, radius_fraction * distance).astype(np.float32)
    return ObstacleSet((position * targets).astype(np.float32), radii)


def _signed_clearance(space: FeatureSpace, x: Tensor, obstacles: ObstacleSet) -> Tensor:
    """‖p_xz(t) − c‖ − r (B, T): negative inside the sample's obstacle."""
    position = space.root_xz(x)                                            # (B, T, 2)
    centres = torch.as_tensor(obstacles.centres, dtype=position.dtype, device=position.device)
    radii = torch.as_tensor(obstacles.radii, dtype=position.dtype, device=position.device)
    if len(centres) != len(position):
        raise ValueError(f"{len(centres)} obstacles for {len(position)} samples")
    return (position - centres[:, None, :]).norm(dim=-1) - radii[:, None]


def obstacle_cost(space: FeatureSpace, obstacles: ObstacleSet) -> Callable[[Tensor], Tensor]:
    """G_obs(x̂0) = Σ_t max(0, r − ‖p_xz(t) − c‖) per sample (m): the penetration of the root
    path into its own obstacle, summed over frames (the hinge of ``obstacle_loss``, one
    obstacle per sample)."""

    def cost(pred_x0: Tensor) -> Tensor:
        return torch.relu(-_signed_clearance(space, pred_x0, obstacles)).sum(dim=1)

    return cost


def penetration_depth(space: FeatureSpace, x: Tensor, obstacles: ObstacleSet) -> np.ndarray:
    """The deepest point of each root path inside its obstacle, max_t max(0, r − ‖p − c‖)
    (B,) in metres; > 0 means a collision."""
    with torch.no_grad():
        clearance = _signed_clearance(space, x.detach(), obstacles)
    return torch.relu(-clearance).amax(dim=1).cpu().numpy()


@dataclass
class ObstacleArm:
    """One arm of ``obstacle_experiment``: n samples toward the goals past the obstacles."""

    label: str
    strength: float
    obstacle_weight: float
    point_to_point: bool
    samples: Tensor
    goal_error: np.ndarray
    penetration: np.ndarray
    jerk: float

    @property
    def collision_rate(self) -> float:
        """Fraction of samples whose root path enters its obstacle."""
        return float(np.mean(self.penetration > 0.0))


def obstacle_experiment(trained: TrainedGMD, targets_xz: np.ndarray,
                        obstacles: ObstacleSet, strengths: Sequence[float], *, seed: int,
                        stop: int, obstacle_weight: float = 1.0,
                        frame: int = -1, clip_x0: Clamp = "gmd") -> list[ObstacleArm]:
    """Goal reaching past one obstacle per goal, in one sampling call (same x_T for all arms):

    - "unguided";
    - per strength s: "goal" (goal guidance only), "goal + obstacle" (guidance on
      G = G_goal + ``obstacle_weight``·G_obs, no imputation: GMD's obstacle task) and
      "goal + obstacle + p2p" (the same plus the straight start→goal line imputed, which GMD
      avoids because the line can cross the obstacle).

    Guidance and imputation act while t ≥ ``stop``; ``clip_x0`` as in ``sweep_strengths``.
    """
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    n = len(targets)
    plan = [("unguided", 0.0, 0.0, False)]
    for s in strengths:
        plan += [(f"goal, s={strength_key(s)}", float(s), 0.0, False),
                 (f"goal + obstacle, s={strength_key(s)}", float(s), obstacle_weight, False),
                 (f"goal + obstacle + p2p, s={strength_key(s)}", float(s), obstacle_weight,
                  True)]
    groups = len(plan)
    all_targets = np.tile(targets, (groups, 1))
    all_obstacles = obstacles.tile(groups)
    strength = torch.as_tensor(np.repeat([p[1] for p in plan], n), dtype=torch.float32)
    weight = torch.as_tensor(np.repeat([p[2] for p in plan], n), dtype=torch.float32)
    goal = goal_reaching_loss(trained.space, all_targets, frame)
    avoid = obstacle_cost(trained.space, all_obstacles)

    def combined(pred_x0: Tensor) -> Tensor:
        w = weight.to(pred_x0.device, pred_x0.dtype)
        return goal(pred_x0) + w * avoid(pred_x0)

    imputation = point_to_point_imputation(trained, all_targets,
                                           active=np.repeat([p[3] for p in plan], n))
    x = sample(trained, n * groups, seed=seed, guidance=weighted_guidance(combined, strength),
               imputation=imputation, stop_guidance_at=stop, clip_x0=clip_x0,
               noise=shared_start_noise(trained, n, groups, seed=seed)).cpu()
    error = goal_error(trained.space, x, all_targets, frame).reshape(groups, n)
    depth = penetration_depth(trained.space, x, all_obstacles).reshape(groups, n)
    samples = x.reshape(groups, n, *x.shape[1:])
    return [ObstacleArm(label, s, w, p2p, samples[g], error[g], depth[g],
                        float(jitter_of(trained.space, samples[g]).jerk))
            for g, (label, s, w, p2p) in enumerate(plan)]


# ---------------------------------------------------------------------------------------------
# Notebook 06's settings
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Settings(RunSettings):
    """Every grid and size of notebook 06, fixed before any verdict was seen.

    The trajectory ε model is notebook 01's guidance model (``x0_vs_eps.Settings.
    guidance_trajectory_spec``: GMD's T = 1000 cosine, one cache key with GMD-A3's), the
    second stage's motion model an x0 motion model with notebook 01's settings on GMD's
    absolute-root windows (``motion_spec``; GMD-A4's own motion models are relative-root, so
    it is not one of theirs; below the paper scale it is notebook 02's text-conditioned B3
    model, sampled with the null condition). ``strengths``
    draw the curve, ``rule_strengths`` are the claimed range the rule reads; ``gmd_stops``
    are GMD's stop steps of T = 1000, which are the model's own at T = 1000 (quick mode's
    T = 50 takes the same fraction, :func:`model_stop_step`); the stop sweep runs at
    ``stop_sweep_strengths``. Quick mode shrinks the model and the goal counts (a test of
    the code, never a result). A scale that registers GMD-F1's whole-body part as not run
    (``gmd.settings.not_run``: the standard scale) runs no second stage
    (``runs_second_stage``): its motion model is neither trained nor loaded.
    """

    scale: str
    seeds: int
    goals: int
    obstacle_goals: int
    model: ModelSettings
    strengths: tuple[int, ...] = (0, 1, 3, 10, 30, 100, 150, 200, 300, 1000)
    rule_strengths: tuple[int, ...] = (100, 150, 200)
    #: GMD's s, at which the rule compares the stop steps.
    gmd_strength: int = 100
    gmd_stops: tuple[int, ...] = (0, 20, 50, 200)
    #: GMD's stop step t = 20 (of 1000).
    gmd_stop: int = GUIDANCE_STOP_T
    stop_sweep_strengths: tuple[int, ...] = (3, 100)
    obstacle_weight: float = 1.0
    #: goals whose guided paths the example figures draw.
    goals_shown: int = 6

    @classmethod
    def for_scale(cls, scale: str, *, seeds: int | None = None) -> Settings:
        """The settings of ``scale`` (``seeds`` None: ``settings.seeds_of("GMD-F1", scale)``).
        At the standard scale the models are notebook 01's at T = 100, and ``stops`` maps
        GMD's {0, 20, 50, 200} of 1000 to {0, 2, 5, 20}."""
        check_scale(scale)
        seeds = seeds_of("GMD-F1", scale) if seeds is None else int(seeds)
        model = ModelSettings.for_scale(scale, seeds=seeds)
        if scale == "quick":
            return cls(scale=scale, seeds=seeds, goals=4, obstacle_goals=4, model=model)
        return cls(scale=scale, seeds=seeds, goals=32, obstacle_goals=16, model=model)

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def num_timesteps(self) -> int:
        """T of the trajectory model (GMD's 1000; standard 100; quick 50)."""
        return self.model.guidance_diffusion_steps

    def spec(self, data_dir: DataDir = None) -> GMDModelSpec:
        """Notebook 01's guidance ε trajectory model (seed 0; ``replace(seed=…)`` per seed)."""
        return self.model.guidance_trajectory_spec("epsilon", self.model.data(data_dir))

    def motion_spec(self, data_dir: DataDir = None) -> GMDModelSpec:
        """GMD's second stage (seed 0): notebook 01's x0 motion spec on its absolute-root
        windows, where the trajectory's root x/z is imputed. Below the paper scale it is
        text-conditioned — at the standard scale exactly notebook 02's GMD-B3 absolute-root
        model (``root_representation.Settings.motion_spec``, one cache key; docs/COMPUTE.md
        §3d) — and ``whole_body`` samples it with the null condition (``guidance.sample``
        without text); the paper scale keeps today's unconditional model."""
        spec = self.model.spec("motion", "x0", self.model.data(data_dir))
        return spec if self.scale == "paper" else spec.replace(text_conditioned=True)

    def stops(self) -> dict[int, int]:
        """{GMD stop step: the trajectory model's stop step} for ``gmd_stops``."""
        return {g: model_stop_step(g, self.num_timesteps) for g in self.gmd_stops}

    @property
    def f1_not_run(self) -> dict[str, str]:
        """GMD-F1's parts this scale does not run, each with why (``gmd.settings.not_run``:
        registered before the run; ``ClaimResult.not_run`` takes it)."""
        return rule_settings.not_run("GMD-F1", self.scale)

    @property
    def runs_second_stage(self) -> bool:
        """Whether this scale runs GMD's second stage (``motion_spec``, ``whole_body``): not
        where the only part that reads it, ``WHOLE_BODY_PART``, is registered as not run."""
        return WHOLE_BODY_PART not in self.f1_not_run

    def second_stage_note(self) -> str:
        """A markdown line for a scale that does not run the second stage: the part it would
        decide and the registered reason, as the ledger records it."""
        if self.runs_second_stage:
            raise ValueError(f"the {self.scale} scale runs the second stage")
        return (f"**Not run at the {self.scale} scale** (GMD-F1's part `{WHOLE_BODY_PART}`): "
                f"{self.f1_not_run[WHOLE_BODY_PART]}.")



# --- GMD-F1's controls: the data as the model, strength and stop effects planted -----------------

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
                goals: int, min_distance: float, margin: float = 1.0,
                whole_body: bool = True) -> Controls:
    """GMD-F1's controls: test trajectories toward the experiment's goals stand in for the
    samples, measured as ``guidance_schedule.sweep_strengths`` measures them (mean goal error
    of the last frame, root jerk).

    Paired as the experiment (``run_sweeps``: the same goals and the same x_T for every
    strength and stop of a seed, the two stops paired sample by sample): one draw of ``goals``
    test windows per seed (:func:`control_seed` with arm 0; another draw per seed) is every
    arm — unguided, each strength, stop 0, stop 20 — toward the seed's goals. The unguided and
    the stop-0 arms are the draw as it is; each other arm is the draw moved by
    :func:`planted_path` (an exact change of its jerk and goal errors, sample by sample).

    Null (every part exactly at its threshold, no effect): each strength's arm with goal
    errors × 0.5 and jerk × 1.5; the stop-20 arm with jerk × 1 and goal errors × 1.2 (every
    log ratio 0). Positive (every part beyond its threshold by δ, exactly): goal errors × 0.45
    (0.5·unguided − guided = 5 % of unguided), jerk × 1.4 (10 %), the stop-20 arm's jerk ×
    0.95 (5 % of stop 0) and goal errors × 1.15 (5 %); every strength carries the same plant,
    so the worst of them is at δ. Whole body: the same windows' motions (``test.x``) as both
    stops (the experiment's two second-stage runs share x_T and noise); the null's stop-20
    arm is the stop-0 arm itself, the positive's the stop-0 arm made smoother by
    :func:`_smoother_body` (joint jerk × 0.95 exactly, foot skating lower by at least as
    much). Tests plant larger effects through ``margin`` (a multiple of every δ).
    ``whole_body`` False (a scale that runs no second stage, ``Settings.runs_second_stage``):
    no whole-body arms, and the controls measure only what the parts that run read (the
    ledger decides them over those parts)."""
    space = test.space("trajectory")
    sizes = {"null": (0.5, 1.5, 1.0, 1.2),
             "positive": (0.5 - 0.05 * margin, 1.5 - 0.1 * margin, 1 - 0.05 * margin,
                          1.2 - 0.05 * margin)}
    out: dict[str, dict[str, Any]] = {
        kind: {"goal_error_unguided": [], "jitter_unguided": [],
               "goal_error_by_strength": {strength_key(v): [] for v in (0, *strengths)},
               "jitter_by_strength": {strength_key(v): [] for v in (0, *strengths)},
               "jitter_stop_0": [], "jitter_stop_20": [], "goal_error_stop_0": [],
               "goal_error_stop_20": [],
               **({key: [] for key in WHOLE_BODY_MEASUREMENTS} if whole_body else {})}
        for kind in sizes}
    motion = test.space("motion")

    def measure(x: Tensor, targets: np.ndarray) -> tuple[float, float]:
        return (float(goal_error(space, x, targets).mean()), float(jitter_of(space, x).jerk))

    for s in seeds:
        targets = goal_targets(test, goals, seed=s, min_distance=min_distance)
        picks = draw_indices(test, goals, control_seed(s, 0, stream=30))
        drawn = test.trajectory()[picks]
        unguided = measure(drawn, targets)
        for kind, (goal_f, jerk_f, stop_jerk_f, stop_goal_f) in sizes.items():
            m = out[kind]
            for name in ("unguided", "stop_0"):
                m[f"goal_error_{name}"].append(unguided[0])
                m[f"jitter_{name}"].append(unguided[1])
            m["goal_error_by_strength"]["0"].append(unguided[0])
            m["jitter_by_strength"]["0"].append(unguided[1])
            g, j = measure(planted_path(space, drawn, targets, jerk_factor=jerk_f,
                                        goal_factor=goal_f), targets)
            for v in strengths:
                m["goal_error_by_strength"][strength_key(v)].append(g)
                m["jitter_by_strength"][strength_key(v)].append(j)
            g, j = measure(planted_path(space, drawn, targets, jerk_factor=stop_jerk_f,
                                        goal_factor=stop_goal_f), targets)
            m["goal_error_stop_20"].append(g)
            m["jitter_stop_20"].append(j)
        if not whole_body:
            continue
        body = test.x[picks]
        for kind, (_, _, stop_jerk_f, _) in sizes.items():
            stop_20 = body if kind == "null" else _smoother_body(motion, body, stop_jerk_f)
            for key, x in (("stop_0", body), ("stop_20", stop_20)):
                coherent = _coherence(motion, x)
                out[kind][f"joint_jerk_{key}"].append(coherent[0])
                out[kind][f"foot_skating_{key}"].append(coherent[1])
    null_f, pos_f = sizes["null"], sizes["positive"]
    body_null = ("; whole body: the same windows' motions at both stops (equal arms)"
                 if whole_body else "; whole body: not run at this scale")
    body_positive = (f"; whole body: the stop-20 arm the stop-0 motions with joint jerk × "
                     f"{pos_f[2]:.3g} (exact), foot skating lower by at least as much"
                     if whole_body else "; whole body: not run at this scale")
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"null": dict(zip(("goal", "jerk", "stop_jerk", "stop_goal"), null_f,
                                              strict=True)),
                             "positive": dict(zip(("goal", "jerk", "stop_jerk", "stop_goal"),
                                                  pos_f, strict=True)),
                             "model": f"{goals} test trajectories per seed, the same in "
                                      f"every arm"},
                    null_text=(f"paired as the experiment: the same {goals} test trajectories "
                               f"toward the same goals in every arm of a seed (another draw "
                               f"per seed), {len(seeds)} seed(s); every part at its threshold: "
                               f"guided goal error × {null_f[0]:g}, jerk × {null_f[1]:g}; stop "
                               f"20: jerk × {null_f[2]:g}, goal error × {null_f[3]:g} (exact)"
                               f"{body_null}"),
                    positive_text=(f"the same paired draws beyond every threshold by δ: guided "
                                   f"goal error × {pos_f[0]:.3g}, jerk × {pos_f[1]:.3g}; stop 20: "
                                   f"jerk × {pos_f[2]:.3g}, goal error × {pos_f[3]:.3g} (exact)"
                                   f"{body_positive}"))



# --- figures of GMD-F1 ---------------------------------------------------------------------------

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



# ------------------------------------------------------------------------------------------------
# GMD-F1 (notebook 06, GMD appendix F) as an experiment: the models, the strength and stop
# sweeps, GMD's second stage, the obstacle extra, and the result the notebook records.
#
# The samplers above (one batch for many strengths, the second stage, obstacles) run here over
# the seeds in the notebook's order; these gather the
# per-seed lists the registered rule reads (GMD appendix F: s = 100 "performs well within the
# range of 100 to 200"; guidance and imputation stopped at t = 20 "led to a slight improvement
# in the motion coherence"), renders the tables the notebook shows, and builds GMD-F1's
# :class:`~repro.claims.result.ClaimResult` (:func:`f1_result`).
# ------------------------------------------------------------------------------------------------


def trajectory_records(trained: ScheduleModels, sweeps: Sweeps,
                       seeds: Sequence[int]) -> list[dict[str, Any]]:
    """The trajectory ε models' ``gmd_trajectory`` records, each in the reference role (every
    arm of GMD-F1 samples the same model, so the sample gate bounds where all start, not their
    difference): held-out x̂0 error, and the path length and root jerk of its unguided
    samples (the strength sweep's s = 0, same noise) against the test windows'. Every part
    of GMD-F1 rests on them (reads: None)."""
    test, train = trained.test, trained.train
    reference = model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())
    sweep = sweeps.sweep
    return [model_gates.gmd_model_record(
        trained.models[s], family="gmd_trajectory", reference=reference, role="reference",
        arm=None, values={**model_gates.trajectory_gate_values(trained.models[s],
                                                     sweep[s].samples[sweep[s].index(0)]),
                **model_gates.denoising_gate_values(trained.models[s], test, train, seed=s)})
        for s in seeds]


def motion_records(trained: ScheduleModels, seeds: Sequence[int], *,
                   seed: int) -> list[dict[str, Any]]:
    """The second stage's absolute-root x0 motion models' ``gmd_motion`` records, each in the
    reference role (both stop arms sample it): held-out x̂0 error and the sample gates
    against ``model_gates.SAMPLE_GATE_WINDOWS`` test windows (drawn with ``seed``). Only
    the whole-body part reads them."""
    test, train = trained.test, trained.train
    samples = model_gates.sample_gate_data(test, seed=seed)
    return [model_gates.gmd_model_record(
        trained.motion_models[s], family="gmd_motion", reads=[WHOLE_BODY_PART],
        role="reference", arm=None, reference=samples.values,
        values={**model_gates.denoising_gate_values(trained.motion_models[s], test, train,
                                                    seed=s),
                **model_gates.motion_sample_values(trained.motion_models[s], samples, seed=s)})
        for s in seeds]


@dataclass
class ScheduleModels:
    """Notebook 06's data and models: one trajectory ε model and one second-stage motion model
    per seed (none, and ``motion_spec`` None, where the scale runs no second stage), whether
    each was cached, and the stop steps mapped to the trajectory model's T (``stops``: GMD
    step of 1000 → ours) with ᾱ of both schedules."""

    spec: GMDModelSpec
    motion_spec: GMDModelSpec | None
    train: MotionWindows
    test: MotionWindows
    models: dict[int, TrainedGMD]
    motion_models: dict[int, TrainedGMD]
    was_cached: list[bool]
    stops: dict[int, int]
    alpha_bar: Any
    gmd_alpha_bar: Any

    @property
    def num_timesteps(self) -> int:
        """T of the trajectory model."""
        return self.spec.diffusion_steps

    def summary(self) -> str:
        """The specs, the window counts, the cache, and each stop step on both schedules."""
        motion = (describe(self.motion_spec) if self.motion_spec is not None
                  else "second stage: no motion model (not run at this scale)")
        lines = [describe(self.spec), motion,
                 f"{len(self.train)} training / {len(self.test)} test windows; models were "
                 f"cached: {self.was_cached}"]
        lines += [f"GMD t = {g:3d}/1000 (ᾱ = {self.gmd_alpha_bar[g]:.4f}) → our t = {t:3d}/"
                  f"{self.num_timesteps} (ᾱ = {self.alpha_bar[t]:.4f})"
                  for g, t in self.stops.items()]
        return "\n".join(lines)


def load_models(settings: Settings, seeds: Sequence[int], *, data_dir: DataDir = None,
                device: str | torch.device = "cpu") -> ScheduleModels:
    """Load (or train) notebook 01's trajectory ε model and the second stage's motion model
    for each of ``seeds`` (``Settings.spec``, ``Settings.motion_spec``) on their windows; no
    motion model where the scale runs no second stage (``Settings.runs_second_stage``)."""
    spec = settings.spec(data_dir)
    train = load_windows(spec.data)
    test = load_windows(spec.data, "test", statistics=(train.mean, train.std))
    motion_spec = settings.motion_spec(data_dir) if settings.runs_second_stage else None
    specs = [spec.replace(seed=s) for s in seeds]
    if motion_spec is not None:
        specs += [motion_spec.replace(seed=s) for s in seeds]
    was_cached = [is_cached(one, train) for one in specs]
    trained = load_or_train_many(specs, train, device=device)
    models = dict(zip(seeds, trained[:len(seeds)], strict=True))
    motion_models = (dict(zip(seeds, trained[len(seeds):], strict=True))
                     if motion_spec is not None else {})
    return ScheduleModels(spec, motion_spec, train, test, models, motion_models, was_cached,
                          settings.stops(), models[seeds[0]].diffusion.alphas_cumprod,
                          schedule_diffusion("cosine", GMD_NUM_TIMESTEPS).alphas_cumprod)


# --- the strength and stop sweeps -----------------------------------------------------------

@dataclass
class StopReading:
    """Per arm of the stop sweep ({arm: {GMD stop: per seed}}): mean goal error and root jerk;
    ``rule_arm`` is the one the rule reads (guidance only at GMD's s)."""

    goal: dict[str, dict[int, list[float]]]
    jerk: dict[str, dict[int, list[float]]]
    rule_arm: str

    def table(self, stops: Mapping[int, int]) -> str:
        """Each arm at each stop: goal error, root jerk and the paired jerk ratio to stop 0."""
        rows = ["| arm | GMD stop t (ours) | goal error (m), per seed | mean | root jerk (m/s³), "
                "per seed | mean | jerk ÷ stop 0, per seed |", "|---|---|---|---|---|---|---|"]
        for arm in self.goal:
            for g in self.goal[arm]:
                goal, jerk = self.goal[arm][g], self.jerk[arm][g]
                ratio = [j / j0 for j, j0 in zip(jerk, self.jerk[arm][0], strict=True)]
                rows.append(f"| {arm} | {g} ({stops[g]}) | {', '.join(f'{e:.3g}' for e in goal)} "
                            f"| {np.mean(goal):.3g} | {', '.join(f'{j:.4g}' for j in jerk)} | "
                            f"{np.mean(jerk):.4g} | {', '.join(f'{r:.3f}' for r in ratio)} |")
        return "\n".join(rows)


@dataclass
class Sweeps:
    """Per seed: the goals, the strength sweep at GMD's stop (``sweep``; the first seed's with
    the per-step record), and per (seed, GMD stop) the stop sweep (guidance only) and the
    sweep with the goal keypoint imputed too; the per-seed lists of the strength sweep
    ({strength key: per seed}: mean goal error, mean root jerk, mean acceleration)."""

    seeds: list[int]
    targets: dict[int, np.ndarray]
    sweep: dict[int, StrengthSweep]
    stop_sweep: dict[tuple[int, int], StrengthSweep]
    imputed: dict[tuple[int, int], StrengthSweep]
    goal_by_s: dict[str, list[float]]
    jerk_by_s: dict[str, list[float]]
    accel_by_s: dict[str, list[float]]

    def per_seed(self, value: Callable[[int], Any]) -> list[float]:
        """[value(s) for each seed] as floats."""
        return [float(value(s)) for s in self.seeds]

    @property
    def unguided_goal(self) -> float:
        return np.mean(self.goal_by_s["0"])

    @property
    def unguided_jerk(self) -> float:
        return np.mean(self.jerk_by_s["0"])

    def strength_table(self, settings: Settings) -> str:
        """Each strength's goal error and root jerk per seed, their means and ratios to the
        unguided sample, the claimed range marked."""
        rows = ["| s | goal error (m), per seed | mean | ÷ unguided | root jerk (m/s³), per "
                "seed | mean | ÷ unguided |", "|---|---|---|---|---|---|---|"]
        for v in settings.strengths:
            goal, jerk = self.goal_by_s[strength_key(v)], self.jerk_by_s[strength_key(v)]
            mark = " **(claimed range)**" if v in settings.rule_strengths else ""
            rows.append(f"| {v}{mark} | {', '.join(f'{e:.2f}' for e in goal)} | "
                        f"{np.mean(goal):.2f} | {np.mean(goal) / self.unguided_goal:.2f} | "
                        f"{', '.join(f'{j:.4g}' for j in jerk)} | {np.mean(jerk):.4g} | "
                        f"{np.mean(jerk) / self.unguided_jerk:.3g} |")
        return "\n".join(rows)

    def stop_reading(self, settings: Settings) -> StopReading:
        """The stop sweep's per-seed goal error and jerk per arm: guidance only at each of
        ``stop_sweep_strengths``, and guidance + goal imputation at GMD's s."""
        gmd_s = settings.gmd_strength
        arms: dict[str, tuple[Callable[[int, int], StrengthSweep], int]] = {
            f"guidance, s = {v}": (lambda s, g: self.stop_sweep[(s, g)], v)
            for v in settings.stop_sweep_strengths}
        arms[f"guidance + goal imputation, s = {gmd_s}"] = (lambda s, g: self.imputed[(s, g)],
                                                            gmd_s)
        goal = {arm: {g: self.per_seed(lambda s, g=g, f=f, v=v: f(s, g).mean_goal_error(v))
                      for g in settings.gmd_stops} for arm, (f, v) in arms.items()}
        jerk = {arm: {g: self.per_seed(lambda s, g=g, f=f, v=v: f(s, g).mean_jerk(v))
                      for g in settings.gmd_stops} for arm, (f, v) in arms.items()}
        return StopReading(goal, jerk, f"guidance, s = {gmd_s}")


def run_sweeps(m: ScheduleModels, settings: Settings, seeds: Sequence[int], *,
               log: Callable[[str], None] = print) -> Sweeps:
    """Per seed: ``settings.goals`` goals (``goal_targets``), the strength sweep over
    ``settings.strengths`` stopping at GMD's t = 20 (the first seed recording every step), and
    at each GMD stop step the stop sweep (``stop_sweep_strengths``, guidance only) and GMD's s
    with the goal keypoint imputed; same x_T for every strength and stop of a seed."""
    seeds = list(seeds)
    targets, sweep, stop_sweep, imputed = {}, {}, {}, {}
    gmd_s, stops = settings.gmd_strength, m.stops
    for s in seeds:
        model = m.models[s]
        targets[s] = goal_targets(m.test, settings.goals, seed=s,
                                  min_distance=settings.model.min_goal_distance)
        sweep[s] = sweep_strengths(model, targets[s], list(settings.strengths), seed=s,
                                   stop=stops[settings.gmd_stop], record_steps=s == seeds[0])
        for g, step in stops.items():
            stop_sweep[(s, g)] = sweep_strengths(model, targets[s],
                                                 list(settings.stop_sweep_strengths),
                                                 seed=s, stop=step)
            imputed[(s, g)] = sweep_strengths(model, targets[s], [gmd_s], seed=s, stop=step,
                                              impute_goal=True)
        log(f"seed {s}: goal error unguided {sweep[s].mean_goal_error(0):.2f} m, s = {gmd_s} "
            f"{sweep[s].mean_goal_error(gmd_s):.2f} m; root jerk unguided "
            f"{sweep[s].mean_jerk(0):.4g}, s = {gmd_s} {sweep[s].mean_jerk(gmd_s):.4g} m/s³")

    def per_seed(value: Callable[[int], Any]) -> list[float]:
        return [float(value(s)) for s in seeds]

    strengths = settings.strengths
    return Sweeps(
        seeds, targets, sweep, stop_sweep, imputed,
        {strength_key(v): per_seed(lambda s, v=v: sweep[s].mean_goal_error(v)) for v in strengths},
        {strength_key(v): per_seed(lambda s, v=v: sweep[s].mean_jerk(v)) for v in strengths},
        {strength_key(v): per_seed(lambda s, v=v: sweep[s].acceleration[sweep[s].index(v)])
         for v in strengths})


# --- GMD's second stage ---------------------------------------------------------------------

@dataclass
class SecondStage:
    """The second stage under the s = GMD's trajectories, per (seed, GMD stop ∈ {0, 20}):
    ``bodies``, and per stop the per-seed joint jerk and foot skating (``coherence``) and the
    mean goal error of the body's own root (``goal``)."""

    bodies: dict[tuple[int, int], WholeBody]
    coherence: dict[str, dict[int, list[float]]]
    goal: dict[int, list[float]]

    def table(self, m: ScheduleModels, seeds: Sequence[int]) -> str:
        """Each stop's motion-model stop step, joint jerk and foot skating per seed, and the
        body root's goal error."""
        first = seeds[0]
        rows = ["| second stage under the s = 100 trajectories | motion model stop (of its T) | "
                "joint jerk (m/s³), per seed | foot skating (m/s), per seed | body root goal "
                "error (m) |", "|---|---|---|---|---|"]
        for g in self.goal:
            rows.append(f"| stop at t = {m.stops[g]} of {m.num_timesteps} | "
                        f"{self.bodies[(first, g)].motion_stop} of "
                        f"{m.motion_models[first].num_timesteps} | "
                        f"{', '.join(f'{v:.4g}' for v in self.coherence['joint_jerk'][g])} | "
                        f"{', '.join(f'{v:.3g}' for v in self.coherence['foot_skating'][g])} | "
                        f"{np.mean(self.goal[g]):.3g} |")
        return "\n".join(rows)


def second_stage(m: ScheduleModels, sweeps: Sweeps, settings: Settings) -> SecondStage | None:
    """GMD's ``gen_two_stages`` per seed: the motion model with the stop sweep's s = GMD's
    trajectories imputed into its root channels (``guidance_schedule.whole_body``), the
    imputation stopped at GMD's 0 and 20 (same fraction of its T; same seed for both).
    None where the scale runs no second stage (``Settings.runs_second_stage``)."""
    if not settings.runs_second_stage:
        return None
    gmd_s, stop = settings.gmd_strength, settings.gmd_stop
    bodies = {(s, g): whole_body(m.motion_models[s], m.models[s].space,
                                 sweeps.stop_sweep[(s, g)].samples[
                                     sweeps.stop_sweep[(s, g)].index(gmd_s)],
                                 sweeps.targets[s], seed=s, gmd_stop=g)
              for s in sweeps.seeds for g in (0, stop)}
    coherence = {metric: {g: sweeps.per_seed(lambda s, g=g, n=metric: getattr(bodies[(s, g)], n))
                          for g in (0, stop)} for metric in ("joint_jerk", "foot_skating")}
    goal = {g: sweeps.per_seed(lambda s, g=g: bodies[(s, g)].goal_error.mean())
            for g in (0, stop)}
    return SecondStage(bodies, coherence, goal)


# --- the obstacle extra ---------------------------------------------------------------------

@dataclass
class ObstacleStudy:
    """The obstacle extra (outside the rule): the sweep's strength with the lowest mean goal
    error (``s_lowest``, from ``sweep_goal_mean``), the strengths run, per seed the obstacles
    and the arms, and per arm label the per-seed collision rate, penetration, goal error and
    root jerk (``summary``)."""

    sweep_goal_mean: dict[int, float]
    s_lowest: int
    strengths: list[int]
    sets: dict[int, ObstacleSet]
    runs: dict[int, list[ObstacleArm]]
    summary: dict[str, dict[str, list[float]]]

    def table(self) -> str:
        """Each arm's collisions per seed, mean penetration, goal error and root jerk."""
        rows = ["| arm | collisions, per seed | mean penetration (m) | goal error (m) | root "
                "jerk (m/s³) |", "|---|---|---|---|---|"]
        for label, m in self.summary.items():
            rows.append(f"| {label} | {', '.join(f'{c:.2f}' for c in m['collision_rate'])} | "
                        f"{np.mean(m['penetration_m']):.3f} | {np.mean(m['goal_error_m']):.2f} | "
                        f"{np.mean(m['root_jerk']):.4g} |")
        return "\n".join(rows)


def obstacle_study(m: ScheduleModels, sweeps: Sweeps, settings: Settings) -> ObstacleStudy:
    """``guidance_schedule.obstacle_experiment`` per seed on the first
    ``settings.obstacle_goals`` goals, one obstacle each (``obstacles_between``), at GMD's s and
    at the guided strength with the lowest mean goal error of the sweep."""
    sweep_goal_mean = {v: float(np.mean(sweeps.goal_by_s[strength_key(v)]))
                       for v in settings.strengths if v > 0}
    s_lowest = min(sweep_goal_mean, key=sweep_goal_mean.get)
    strengths = sorted({settings.gmd_strength, s_lowest})
    runs, sets = {}, {}
    for s in sweeps.seeds:
        goals = sweeps.targets[s][:settings.obstacle_goals]
        sets[s] = obstacles_between(goals)
        runs[s] = obstacle_experiment(m.models[s], goals, sets[s], strengths, seed=s,
                                      stop=m.stops[settings.gmd_stop],
                                      obstacle_weight=settings.obstacle_weight)
    per_seed = sweeps.per_seed
    summary = {label: {
        "collision_rate": per_seed(lambda s, i=i: runs[s][i].collision_rate),
        "penetration_m": per_seed(lambda s, i=i: runs[s][i].penetration.mean()),
        "goal_error_m": per_seed(lambda s, i=i: runs[s][i].goal_error.mean()),
        "root_jerk": per_seed(lambda s, i=i: runs[s][i].jerk)}
        for i, label in enumerate(arm.label for arm in runs[sweeps.seeds[0]])}
    return ObstacleStudy(sweep_goal_mean, s_lowest, strengths, sets, runs, summary)


# --- the claim ------------------------------------------------------------------------------

def f1_slots(settings: Settings) -> list[Slot]:
    """GMD-F1's A/A slots. Every arm samples one trajectory model, so the reference arm of a
    part is its baseline condition: the unguided sample (parts 1–2: each rule strength's goal
    error and root jerk filled by the copy's unguided ones at the rule's threshold, × 0.5 and
    × 1.5) and stop 0 (part 4: the stop-20 goal error filled by the copy's stop-0 one × 1.2).
    The positive lowers each treatment reading by 2δ (the claim: guidance halves the error
    without the jitter growing by half; stopping at 20 keeps the goal)."""
    slots = []
    for v in settings.rule_strengths:
        key = strength_key(v)
        slots.append(Slot(("goal_error_by_strength", key), "goal_error_unguided",
                          "goal_error_unguided", factor=0.5,
                          part="s_100_200_halves_goal_error", sign=-1))
        slots.append(Slot(("jitter_by_strength", key), "jitter_unguided", "jitter_unguided",
                          factor=1.5, part="s_100_200_keeps_jitter", sign=-1))
    slots.append(Slot("goal_error_stop_20", "goal_error_stop_0", "goal_error_stop_0",
                      factor=1.2, part="stop_at_20_keeps_goal", sign=-1))
    return slots


def f1_aa_controls(m: ScheduleModels, sweeps: Sweeps, settings: Settings) -> Controls:
    """GMD-F1's A/A controls (``controls.aa_controls``, :func:`f1_slots`): the trajectory model
    of seed s against an independently trained copy (the next seed's; for a one-seed run one
    more, trained here), both sampling seed s's goals with seed s's noise in the experiment's
    sweeps (the strength sweep at GMD's stop for the unguided arm, the stop sweep's stop 0 at
    GMD's s); the own model's readings are the experiment's. The whole-body part (the second
    stage) has no A/A arms: its measurements are left out of the controls."""
    gmd_s, stops = settings.gmd_strength, m.stops

    def of(strength: StrengthSweep, stop: StrengthSweep) -> dict[str, Any]:
        return {"goal_error_unguided": strength.goal_error[strength.index(0)].astype(float),
                "jitter_unguided": strength.mean_jerk(0),
                "goal_error_stop_0": stop.goal_error[stop.index(gmd_s)].astype(float)}

    def reading(model_seed: int, pairing_seed: int) -> dict[str, Any]:
        if model_seed == pairing_seed and model_seed in sweeps.sweep:
            return of(sweeps.sweep[model_seed], sweeps.stop_sweep[(model_seed, 0)])
        model = reference_model(m.models, model_seed)
        targets = goal_targets(m.test, settings.goals, seed=pairing_seed,
                               min_distance=settings.model.min_goal_distance)
        return of(sweep_strengths(model, targets, list(settings.strengths), seed=pairing_seed,
                                  stop=stops[settings.gmd_stop]),
                  sweep_strengths(model, targets, list(settings.stop_sweep_strengths),
                                  seed=pairing_seed, stop=stops[0]))

    return aa_controls("GMD-F1", aa_readings(reading, sweeps.seeds), f1_slots(settings),
                       reference_arm="trajectory (unguided / stop-0 arm)")


def f1_result(m: ScheduleModels, sweeps: Sweeps, stop: StopReading, body: SecondStage | None,
              obstacles: ObstacleStudy, settings: Settings, *, controls: Controls,
              first_step: Mapping[float, float], peak_state: Mapping[float, float],
              timings: Mapping[str, float], model_records: Sequence[Mapping[str, Any]],
              figures: Sequence[str | Path] = ()) -> ClaimResult:
    """GMD-F1's result (appendix F): per seed the goal error and root jerk of the unguided
    sample and of every strength (the rule reads s ∈ {100, 150, 200}), and at GMD's s the
    stop-0 against stop-20 goal error, root jerk and the second stage's joint jerk and foot
    skating; the settings the run used (``guidance_parameters``), the stop sweep's other
    arms, the per-step diagnostic (``first_step``, ``peak_state`` of the first seed), the
    obstacle extra and the ``timings`` (s) so far in ``extra``.

    Where the scale runs no second stage (``Settings.runs_second_stage``; ``body`` None) the
    whole-body part is recorded as not run with its registered reason (``Settings.f1_not_run``),
    without its measurements, and the headline and notes say so."""
    if (body is not None) != settings.runs_second_stage:
        raise ValueError(f"the {settings.scale} scale "
                         f"{'runs' if settings.runs_second_stage else 'does not run'} GMD's "
                         f"second stage; got {'a' if body is not None else 'no'} second stage")
    first, T, stops = sweeps.seeds[0], m.num_timesteps, m.stops
    stop_at, rule_arm = settings.gmd_stop, stop.rule_arm
    goal_by_s, jerk_by_s = sweeps.goal_by_s, sweeps.jerk_by_s
    parameters = guidance_parameters(m.models[first], stop=stops[stop_at])
    measured = {
        "goal_error_unguided": goal_by_s["0"],
        "jitter_unguided": jerk_by_s["0"],
        "goal_error_by_strength": goal_by_s,
        "jitter_by_strength": jerk_by_s,
        "jitter_stop_0": stop.jerk[rule_arm][0],
        "jitter_stop_20": stop.jerk[rule_arm][stop_at],
        "goal_error_stop_0": stop.goal[rule_arm][0],
        "goal_error_stop_20": stop.goal[rule_arm][stop_at],
    }
    if body is not None:
        coherent = body.coherence
        measured.update({
            "joint_jerk_stop_0": coherent["joint_jerk"][0],
            "joint_jerk_stop_20": coherent["joint_jerk"][stop_at],
            "foot_skating_stop_0": coherent["foot_skating"][0],
            "foot_skating_stop_20": coherent["foot_skating"][stop_at]})
        whole = (f"whole-body joint jerk {np.mean(coherent['joint_jerk'][stop_at]):.4g} vs "
                 f"{np.mean(coherent['joint_jerk'][0]):.4g} m/s³, foot skating "
                 f"{np.mean(coherent['foot_skating'][stop_at]):.3g} vs "
                 f"{np.mean(coherent['foot_skating'][0]):.3g} m/s, ")
        second = f"and its x0 motion model ({describe(m.motion_spec)}) as GMD's second stage"
    else:
        whole = ""
        second = (f"the whole-body part ({WHOLE_BODY_PART}) not run at the {settings.scale} "
                  f"scale: {settings.f1_not_run[WHOLE_BODY_PART]}")
    in_range = " / ".join(f"{np.mean(goal_by_s[strength_key(v)]):.2f}"
                          for v in settings.rule_strengths)
    jerk_range = " / ".join(f"{np.mean(jerk_by_s[strength_key(v)]) / sweeps.unguided_jerk:.3g}"
                            for v in settings.rule_strengths)
    s_lowest = obstacles.s_lowest
    headline = (f"goal error unguided {sweeps.unguided_goal:.2f} m → s = 100/150/200: "
                f"{in_range} m (best s = {s_lowest}: {obstacles.sweep_goal_mean[s_lowest]:.2f} "
                f"m); root jerk × {jerk_range} of unguided; stop at t = {stops[stop_at]} vs 0 "
                f"of {T} at s = 100: {whole}goal error "
                f"{np.mean(stop.goal[rule_arm][stop_at]):.2f} vs "
                f"{np.mean(stop.goal[rule_arm][0]):.2f} m")
    if body is None:
        headline += f"; whole body: not run at the {settings.scale} scale"
    gmd_stops = list(settings.gmd_stops)
    notes = (
        f"Ours: notebook 01's guidance trajectory ε model ({describe(m.spec)}), one per seed, "
        f"{second}; "
        f"{settings.goals} goals per seed = last-frame root x/z of random test windows "
        "travelling ≥ 0.5 m; GMD's guidance (½·L1 on the last-frame root x/z of the "
        "un-normalised x̂0, "
        f"μ̃ = μ − s·Σ_t·∇_{{x_t}}G, ε model's x̂0 clamped to ±{parameters['x0_clamp']:g}), "
        f"T = {T} cosine, ancestral sampling over every step (GMD respaces only with use_ddim); "
        "all strengths in one batch with the same x_T (per-sample strength = separate run); "
        f"stop steps {gmd_stops} of {T}; the rule's arm is guidance only (imputing the goal "
        "keypoint down to t = 0 makes the final goal error exactly 0); the stop comparison at "
        "s = 100 is paired (same x_T and per-step noise); strength jitter = mean root jerk "
        "(m/s³); "
        + ("whole-body coherence = joint jerk and foot skating of the second stage's "
           "motion (the guided trajectory imputed into the motion model's root channels while "
           "t ≥ the stop at the same fraction of its T, same seed for both stops). "
           if body is not None else "")
        + "s = 1 and 3 and "
        "the per-step diagnostic were added after a pilot (seed 0, s = 10, 100, at T = 100) "
        "showed guidance raising the goal error; the rule's inputs were not changed by it.")
    extra = {
        "parameters": parameters,
        **({"motion_stop_steps": {str(g): body.bodies[(first, g)].motion_stop
                                  for g in (0, stop_at)},
            "whole_body_goal_error": {str(g): v for g, v in body.goal.items()}}
           if body is not None else {}),
        "strengths": list(settings.strengths),
        "stop_steps_gmd": gmd_stops,
        "stop_steps_ours": [stops[g] for g in gmd_stops],
        "num_timesteps": T,
        "alpha_bar_at_stop_ours": {str(g): float(m.alpha_bar[stops[g]]) for g in gmd_stops},
        "alpha_bar_at_stop_gmd": {str(g): float(m.gmd_alpha_bar[g]) for g in gmd_stops},
        "acceleration_by_strength": sweeps.accel_by_s,
        "stop_sweep_goal_error": {arm: {str(g): v for g, v in d.items()}
                                  for arm, d in stop.goal.items()},
        "stop_sweep_jitter": {arm: {str(g): v for g, v in d.items()}
                              for arm, d in stop.jerk.items()},
        "guidance_shift_at_first_step_seed0": {str(v): x for v, x in first_step.items()},
        "largest_state_seed0": {str(v): x for v, x in peak_state.items()},
        "lowest_goal_error_strength": s_lowest,
        "obstacles": obstacles.summary,
        "obstacle_strengths": obstacles.strengths,
        "goals_per_seed": settings.goals,
        "obstacle_goals_per_seed": settings.obstacle_goals,
        "models_were_cached": m.was_cached,
        "timings_s": {k: round(v, 1) for k, v in timings.items()},
        "controls_planted": controls.planted,
    }
    return ClaimResult("GMD-F1", measured, seeds=sweeps.seeds,
                       settings=rule_settings.f1(settings), controls=controls,
                       models=list(model_records), figures=list(figures), headline=headline,
                       notes=notes, extra=extra, not_run=settings.f1_not_run)
