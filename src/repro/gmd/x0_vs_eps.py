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

from repro.core import metrics
from repro.core.diffusion import SampleTrajectory
from repro.gmd.guidance import (
    GMD_GUIDANCE_STRENGTH,
    default_stop_step,
    goal_error,
    goal_guidance,
    sample,
)
from repro.gmd.measurements import evaluator_inputs, foot_skating_of, jitter_of
from repro.gmd.models import GMDModelSpec, TrainedGMD, training_fields
from repro.gmd.windows import DataConfig, FeatureSpace, MotionWindows, Task, goal_targets
from repro.models.evaluator import Evaluator, EvaluatorConfig

__all__ = ["CLAMPS", "PREDICTIONS", "GoalReachingResult", "SampleQuality", "Settings",
           "clamp_sensitivity", "goal_error_kept", "goal_reaching_experiment",
           "goal_reaching_study", "guided_change_survival", "motion_fid", "sample_quality"]


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



# ------------------------------------------------------------------------ notebook 01's settings

@dataclass(frozen=True)
class Settings:
    """Every size and step count of notebook 01, fixed before any verdict was seen.

    Full mode: 48-frame windows (stride 24) of the 2000-clip stand-in set, one UNet1D per task
    for x0 and ε (``paper_settings``' architectures), T = 100 cosine, trained to convergence
    up to each family's step cap (``models.training_fields``); 32 goals and
    256 generated windows per seed; the package's evaluator with its default size. Quick mode
    shrinks everything (a test of the code, never a result). ``train_steps`` may be overridden
    (the notebook's papermill parameter; None = the mode's default).
    """

    quick: bool
    seeds: int
    stand_in_clips: int
    frames: int
    #: the step cap; None in full mode: each family's (``models.training_fields``)
    train_steps: int | None
    batch_size: int
    diffusion_steps: int
    goals: int
    generated: int
    #: goals are end positions of test windows whose root travels at least this far (m).
    min_goal_distance: float = 0.5
    #: random draws of x_t and ε per t for the Eq. 1 vs Eq. 2 check (GMD-A1).
    posterior_samples: int = 256

    @classmethod
    def for_mode(cls, quick: bool, *, seeds: int = 3, train_steps: int | None = None
                 ) -> Settings:
        if quick:
            return cls(quick=True, seeds=seeds, stand_in_clips=120, frames=24,
                       train_steps=20 if train_steps is None else int(train_steps),
                       batch_size=32, diffusion_steps=20, goals=4, generated=32)
        return cls(quick=False, seeds=seeds, stand_in_clips=2000, frames=48,
                   train_steps=None if train_steps is None else int(train_steps),
                   batch_size=64, diffusion_steps=100, goals=32, generated=256)

    def data(self, data_dir: str | None = None) -> DataConfig:
        """The absolute-root windows (``data_dir`` or the stand-in set)."""
        if data_dir is not None:
            return DataConfig(data_dir=data_dir, frames=self.frames)
        return DataConfig(stand_in_clips=self.stand_in_clips, frames=self.frames)

    def spec(self, task: Task, prediction: Literal["x0", "epsilon"], data: DataConfig,
             seed: int = 0) -> GMDModelSpec:
        """One of the four models (trajectory/motion × x0/ε): x0 and ε of a task share the
        architecture and the training budget (``models.training_fields``: trained to
        convergence, ``train_steps`` the cap)."""
        fields = {"batch_size": self.batch_size,
                  **training_fields(task, quick=self.quick, step_cap=self.train_steps)}
        return GMDModelSpec(task=task, prediction=prediction, data=data,
                            diffusion_steps=self.diffusion_steps, seed=seed, **fields)

    def evaluator_config(self, data_id: str) -> EvaluatorConfig:
        """The package's evaluator (tiny in quick mode), named after the training windows."""
        if self.quick:
            return EvaluatorConfig(dim=16, hidden=32, steps=30, data_id=data_id)
        return EvaluatorConfig(data_id=data_id)


# ---------------------------------------------------------------------- the GMD-A3/A4 studies

#: the two parametrisations and the short tags of their measurement names.
PREDICTIONS = {"x0": "x0", "epsilon": "eps"}


def goal_reaching_study(models: dict[tuple[str, str, int], TrainedGMD], test: MotionWindows,
                        seeds: Sequence[int], *, goals: int, min_distance: float,
                        ) -> dict[tuple[str, int], GoalReachingResult]:
    """Per seed, ``goals`` goal locations from the test windows (``goal_targets``) and both
    trajectory models' :func:`goal_reaching_experiment` toward them, keyed (prediction, seed).
    ``models`` keyed (task, prediction, seed)."""
    results = {}
    for s in seeds:
        targets = goal_targets(test, goals, seed=s, min_distance=min_distance)
        for prediction in PREDICTIONS:
            results[(prediction, s)] = goal_reaching_experiment(
                models[("trajectory", prediction, s)], targets, seed=s)
    return results


def clamp_sensitivity(models: dict[tuple[str, str, int], TrainedGMD],
                      results: dict[tuple[str, int], GoalReachingResult], seeds: Sequence[int],
                      ) -> dict[str, list[float]]:
    """The ε trajectory model's guided goal error (m, per seed) with the registered x̂0 clamp
    (± max |x| of its training windows), with GMD's constant ±6 and with none (same goals and
    noise as ``results``): a sensitivity check outside the rule."""
    errors: dict[str, list[float]] = {}
    for s in seeds:
        registered = results[("epsilon", s)]
        for label, bound in CLAMPS.items():
            result = registered if bound == "registered" else goal_reaching_experiment(
                models[("trajectory", "epsilon", s)], registered.targets, seed=s, clip_x0=bound)
            errors.setdefault(label, []).append(float(result.error_guided.mean()))
    return errors


#: the x̂0 clamps of the sensitivity check: ours (registered), GMD's constant, none.
CLAMPS: dict[str, float | None | str] = {"ours: ±max|x|": "registered",
                                         "GMD's constant: ±6": 6.0, "no clamp": None}


def motion_fid(space: TrainedGMD | FeatureSpace, x: Tensor, evaluator: Evaluator,
               test_embeddings: np.ndarray) -> float:
    """FID (``metrics.fid``) of motion-task samples (B, 263, T) against ``test_embeddings``,
    through the evaluator's embedding of their relative-root features."""
    features, lengths = evaluator_inputs(space, x)
    return float(metrics.fid(evaluator.embed_motions(features, lengths), test_embeddings))


@dataclass
class SampleQuality:
    """GMD-A4: per-seed lists ``values[name]`` (names as registered, e.g. ``motion_jitter_eps``)
    and two motion samples of each prediction of the first seed (joints, for filmstrips)."""

    values: dict[str, list[float]]
    examples: dict[str, np.ndarray]


def sample_quality(models: dict[tuple[str, str, int], TrainedGMD], seeds: Sequence[int], *,
                   n: int, evaluator: Evaluator, test_embeddings: np.ndarray) -> SampleQuality:
    """n unguided samples per model and seed (same noise for x0 and ε): joint jerk,
    acceleration, root jerk, FID against ``test_embeddings`` and foot skating of the motion
    models, root jerk of the trajectory models."""
    names = ("motion_jitter", "motion_fid", "trajectory_jitter", "motion_root_jitter",
             "motion_acceleration", "motion_foot_skating")
    values: dict[str, list[float]] = {f"{name}_{tag}": [] for name in names
                                      for tag in PREDICTIONS.values()}
    examples = {}
    for s in seeds:
        for prediction, tag in PREDICTIONS.items():
            motion_model = models[("motion", prediction, s)]
            x = sample(motion_model, n, seed=s)
            jitter = jitter_of(motion_model, x)
            values[f"motion_jitter_{tag}"].append(float(jitter.jerk))
            values[f"motion_acceleration_{tag}"].append(float(jitter.acceleration))
            values[f"motion_root_jitter_{tag}"].append(
                float(jitter_of(motion_model, x, "root").jerk))
            values[f"motion_fid_{tag}"].append(motion_fid(motion_model, x, evaluator,
                                                          test_embeddings))
            values[f"motion_foot_skating_{tag}"].append(float(foot_skating_of(motion_model, x)))
            trajectory_model = models[("trajectory", prediction, s)]
            trajectories = sample(trajectory_model, n, seed=s)
            values[f"trajectory_jitter_{tag}"].append(
                float(jitter_of(trajectory_model, trajectories).jerk))
            if s == seeds[0]:
                examples[prediction] = motion_model.space.joints(x[:2]).numpy()
    return SampleQuality(values, examples)
