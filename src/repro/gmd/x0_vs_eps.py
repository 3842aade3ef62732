"""Notebook 01 (GMD appendix A, A.1): x0 vs ε prediction under goal guidance (GMD-A3, A4).

A guided and an unguided run from the same seed (same x_T, same per-step noise) give the goal
error of the final sample and of x̂0 at every step, and the *survival* of the guided change
after the stop step (``guided_change_survival``, the registered GMD-A3 measurement).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import SampleTrajectory
from repro.gmd.guidance import (
    GMD_GUIDANCE_STRENGTH,
    default_stop_step,
    goal_error,
    goal_guidance,
    sample,
)
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import FeatureSpace

__all__ = ["GoalReachingResult", "goal_error_kept", "goal_reaching_experiment",
           "guided_change_survival"]


def guided_change_survival(space: TrainedGMD | FeatureSpace, x0_guided_at_stop: Tensor,
                           x0_unguided_at_stop: Tensor, final_guided: Tensor,
                           final_unguided: Tensor) -> float:
    """Fraction of the guided change in x̂0 at the stop step still present in the final sample.

    With g(·) the world root x/z path (B, T, 2) in metres and two runs from the same seed
    (same x_T, same per-step noise), one guided (G) and one not (U):

        Δ_stop  = g(x̂0^G at the last guided step t = stop) − g(x̂0^U at that step)
        Δ_final = g(final sample^G) − g(final sample^U)
        survival = Σ Δ_final·Δ_stop / Σ Δ_stop·Δ_stop      (sums over samples, frames, x/z)

    i.e. the least-squares share of the change the guidance had made by the stop step that the
    remaining (unguided) steps leave in place: 1 = all kept, 0 = all undone.
    """
    space = space.space if isinstance(space, TrainedGMD) else space
    with torch.no_grad():
        stop = (space.root_xz(x0_guided_at_stop) - space.root_xz(x0_unguided_at_stop)).double()
        final = (space.root_xz(final_guided) - space.root_xz(final_unguided)).double()
    norm = float((stop * stop).sum())
    if norm == 0.0:
        return float("nan")
    return float((final * stop).sum()) / norm


def goal_error_kept(unguided_error: np.ndarray | Sequence[float],
                    reference_error: np.ndarray | Sequence[float] | float,
                    final_error: np.ndarray | Sequence[float]) -> float:
    """The goal-error reduction kept at the end relative to a reference (batch means ē):
    (ē_unguided − ē_final) / (ē_unguided − ē_reference); NaN when ē_reference ≥ ē_unguided."""
    unguided = float(np.mean(unguided_error))
    reference = float(np.mean(reference_error))
    final = float(np.mean(final_error))
    if not unguided > reference:
        return float("nan")
    return (unguided - final) / (unguided - reference)


@dataclass
class GoalReachingResult:
    """A guided and an unguided run with the same seed (same x_T, same per-step noise).

    ``timesteps`` run from T−1 down to 0; ``x0_error_*`` (S, n) is the goal error of the
    model's x̂0 at each of them; ``error_at_stop`` (n,) that of the guided x̂0 at the last
    guided step t = stop, whose x̂0 in both runs are ``x0_*_at_stop``.
    """

    targets: np.ndarray
    stop_guidance_at: int
    strength: float
    space: FeatureSpace
    guided: Tensor
    unguided: Tensor
    error_guided: np.ndarray
    error_unguided: np.ndarray
    error_at_stop: np.ndarray
    timesteps: np.ndarray
    x0_error_guided: np.ndarray
    x0_error_unguided: np.ndarray
    x0_guided_at_stop: Tensor
    x0_unguided_at_stop: Tensor

    @property
    def survival(self) -> float:
        """``guided_change_survival`` of this pair of runs (the registered measurement)."""
        return guided_change_survival(self.space, self.x0_guided_at_stop,
                                      self.x0_unguided_at_stop, self.guided, self.unguided)

    @property
    def best_step_error(self) -> float:
        """The lowest batch-mean goal error of the guided x̂0 over all steps (m)."""
        return float(self.x0_error_guided.mean(axis=1).min())

    @property
    def error_kept_from_stop(self) -> float:
        """``goal_error_kept`` relative to the guided x̂0 at the stop step."""
        return goal_error_kept(self.error_unguided, self.error_at_stop, self.error_guided)

    @property
    def error_kept_from_best(self) -> float:
        """``goal_error_kept`` relative to the guided x̂0's best step."""
        return goal_error_kept(self.error_unguided, self.best_step_error, self.error_guided)


def _x0_errors(space: FeatureSpace, trajectory: SampleTrajectory, targets: np.ndarray,
               frame: int) -> np.ndarray:
    return np.stack([goal_error(space, x0, targets, frame) for x0 in trajectory.pred_x0])


def goal_reaching_experiment(trained: TrainedGMD, targets_xz: np.ndarray, *, seed: int,
                             strength: float = GMD_GUIDANCE_STRENGTH,
                             stop_guidance_at: int | None = None, frame: int = -1,
                             clip_x0: float | None | Literal["auto"] = "auto",
                             ) -> GoalReachingResult:
    """Sample len(targets) motions toward their targets (one per sample) with goal guidance
    and without, from the same seed, recording x̂0's goal error at every step."""
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    stop = default_stop_step(trained.num_timesteps) if stop_guidance_at is None else int(
        stop_guidance_at)
    guidance = goal_guidance(trained, targets, frame=frame, strength=strength)
    guided, guided_path = sample(trained, len(targets), seed=seed, guidance=guidance,
                                 stop_guidance_at=stop, return_trajectory=True, clip_x0=clip_x0)
    unguided, unguided_path = sample(trained, len(targets), seed=seed, return_trajectory=True,
                                     clip_x0=clip_x0)
    steps = np.asarray(guided_path.timesteps)
    x0_guided = _x0_errors(trained.space, guided_path, targets, frame)
    x0_unguided = _x0_errors(trained.space, unguided_path, targets, frame)
    # the last guided step is t = stop (guidance acts while t ≥ stop); none at all if stop = T
    k = int(np.flatnonzero(steps == min(stop, trained.num_timesteps - 1))[0])
    return GoalReachingResult(
        targets=targets, stop_guidance_at=stop, strength=float(strength), space=trained.space,
        guided=guided.cpu(), unguided=unguided.cpu(),
        error_guided=goal_error(trained, guided, targets, frame),
        error_unguided=goal_error(trained, unguided, targets, frame), error_at_stop=x0_guided[k],
        timesteps=steps, x0_error_guided=x0_guided, x0_error_unguided=x0_unguided,
        x0_guided_at_stop=guided_path.pred_x0[k], x0_unguided_at_stop=unguided_path.pred_x0[k])

