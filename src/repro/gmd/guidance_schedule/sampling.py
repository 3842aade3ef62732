"""Notebook 06's samplers, on top of ``repro.gmd.guidance`` (whose sampler and goal functions
they reuse unchanged):

- ``model_stop_step``: GMD's stop step mapped to a model with another T (same fraction of T:
  the identity at GMD's T = 1000; used for quick mode and the T = 100 motion model);
- ``sweep_strengths``: one sampling call for many strengths at once (a per-sample strength is
  exactly a guidance of strength 1 on Σ_b s_b·G_b, because samples do not interact), with
  the same x_T for every strength;
- goal-keypoint and point-to-point imputation targets (GMD's two imputations, absolute root);
- GMD's second stage (``whole_body``): the x0 motion model with a guided trajectory imputed
  into its root channels, for the whole-body coherence of GMD-F1.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import Guidance, Imputation
from repro.gmd.guidance import Clamp, goal_error, goal_reaching_loss, sample
from repro.gmd.measurements import foot_skating_of, jitter_of
from repro.gmd.models import GUIDANCE_DIFFUSION_STEPS, TrainedGMD
from repro.gmd.windows import FeatureSpace

__all__ = ["GMD_NUM_TIMESTEPS", "ROOT_CHANNELS", "StrengthSweep", "WholeBody",
           "goal_keypoint_imputation", "model_stop_step", "point_to_point_imputation",
           "shared_start_noise", "strength_key", "sweep_strengths", "trajectory_imputation",
           "weighted_guidance", "whole_body"]

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
