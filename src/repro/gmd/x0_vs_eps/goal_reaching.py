"""GMD-A3's experiment: goal reaching under guidance, a guided and an unguided run from one seed.

A guided and an unguided run from the same seed (same x_T, same per-step noise) give the goal
error of the final sample and of x̂0 at every step (:func:`goal_reaching_experiment`,
:class:`GoalReachingResult`), and the share of the best guided gain that is kept at the end
(:func:`best_gain_survival`, GMD-A3's registered measurement); :func:`goal_reaching_study` runs
it per seed for both parametrisations. GMD-A3's controls run their exact and planted models
through the same experiment (``x0_vs_eps.a3``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import SampleTrajectory
from repro.gmd.guidance import (
    GMD_GUIDANCE_STRENGTH,
    Clamp,
    default_stop_step,
    goal_error,
    goal_guidance,
    resolve_clamp,
    sample,
)
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import FeatureSpace, MotionWindows, goal_targets
from repro.gmd.x0_vs_eps.common import PREDICTIONS


def best_gain_survival(unguided_final_error: np.ndarray | Sequence[float],
                       guided_x0_error: np.ndarray | Sequence[Sequence[float]],
                       guided_final_error: np.ndarray | Sequence[float]) -> float:
    """The share of the best guided gain kept at the end (GMD-A3's registered measurement).

    Two runs from the same seed (same x_T, same per-step noise), one guided (G), one not (U);
    goal errors are distances (m) of the last-frame root x/z to the goal, averaged over the
    batch's goals (ē). With ē_U the unguided final sample's, ē_G(t) the guided x̂0's at each
    sampling step t = T−1 … 0 (``guided_x0_error`` (S, n)) and ē_G the guided final sample's:

        best gain  = ē_U − min_t ē_G(t)     (the closest approach of x̂0 to the goal)
        final gain = ē_U − ē_G
        survival   = final gain / best gain

    1 = the final sample is as near the goal as x̂0 ever came; 0 = it ends where the unguided
    sample does (all the guided gain undone); < 0 = guidance left it farther away. NaN when
    the best gain is ≤ 0 (x̂0 never came nearer than the unguided sample: nothing to keep).
    The minimum is over the batch-mean curve, not per goal, so the noise of single goals does
    not pull the best gain up.
    """
    unguided = float(np.mean(unguided_final_error))
    curve = np.asarray(guided_x0_error, dtype=np.float64)
    best = unguided - float(curve.reshape(curve.shape[0], -1).mean(axis=1).min())
    if not best > 0.0:
        return float("nan")
    return (unguided - float(np.mean(guided_final_error))) / best


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

    clip_x0: float | None = None

    @property
    def survival(self) -> float:
        """``best_gain_survival`` of this pair of runs (the registered measurement, v3)."""
        return best_gain_survival(self.error_unguided, self.x0_error_guided, self.error_guided)

    @property
    def best_gain(self) -> float:
        """ē_U − min_t ē_G(t) (m): how much nearer the goal the guided x̂0 came at its best."""
        return float(self.error_unguided.mean() - self.best_step_error)

    @property
    def final_gain(self) -> float:
        """ē_U − ē_G (m): how much nearer the goal the guided final sample is."""
        return float(self.error_unguided.mean() - self.error_guided.mean())

    @property
    def best_step(self) -> int:
        """The step t at which the guided x̂0's batch-mean goal error is lowest."""
        return int(self.timesteps[int(np.argmin(self.x0_error_guided.mean(axis=1)))])

    @property
    def stop_step_survival(self) -> float:
        """``guided_change_survival`` from the stop step (outside the rule)."""
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
                             clip_x0: Clamp = "gmd") -> GoalReachingResult:
    """Sample len(targets) motions toward their targets (one per sample) with goal guidance
    and without, from the same seed, recording x̂0's goal error at every step. ``clip_x0``
    "gmd" (registered): an ε model's x̂0 clamped to GMD's ±6, an x0 model's not."""
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
        x0_guided_at_stop=guided_path.pred_x0[k], x0_unguided_at_stop=unguided_path.pred_x0[k],
        clip_x0=resolve_clamp(trained, clip_x0))


def goal_reaching_study(trajectory_models: dict[tuple[str, int], TrainedGMD],
                        test: MotionWindows, seeds: Sequence[int], *, goals: int,
                        min_distance: float, clip_x0: Clamp = "gmd",
                        ) -> dict[tuple[str, int], GoalReachingResult]:
    """Per seed, ``goals`` goal locations from the test windows (``goal_targets``) and both
    guidance trajectory models' :func:`goal_reaching_experiment` toward them, keyed
    (prediction, seed) like ``trajectory_models``."""
    results = {}
    for s in seeds:
        targets = goal_targets(test, goals, seed=s, min_distance=min_distance)
        for prediction in PREDICTIONS:
            results[(prediction, s)] = goal_reaching_experiment(
                trajectory_models[(prediction, s)], targets, seed=s, clip_x0=clip_x0)
    return results
