"""Notebook 01 (GMD appendix A, A.1): x0 vs ε prediction under goal guidance (GMD-A3, A4).

A guided and an unguided run from the same seed (same x_T, same per-step noise) give the goal
error of the final sample and of x̂0 at every step, and the share of the best guided gain that
is kept at the end (``best_gain_survival``, the registered GMD-A3 measurement of registry v3).
The guidance experiments' trajectory models run GMD's diffusion, T = 1000 cosine
(``Settings.guidance_trajectory_spec``, read by notebooks 01, 02 and 06).
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
    Clamp,
    default_stop_step,
    goal_error,
    goal_guidance,
    resolve_clamp,
    sample,
)
from repro.gmd.measurements import foot_skating_of, jitter_of, motion_fid
from repro.gmd.models import GMDModelSpec, TrainedGMD, training_fields
from repro.gmd.paper_settings import (
    GUIDANCE_DIFFUSION_STEPS,
    GUIDANCE_SCHEDULE,
    STANDARD_DIFFUSION_STEPS,
)
from repro.gmd.run_seeds import seeds_of
from repro.gmd.windows import (
    DataConfig,
    DataDir,
    FeatureSpace,
    MotionWindows,
    Representation,
    Task,
    goal_targets,
)
from repro.infra.context import check_scale
from repro.models.evaluator import Evaluator, EvaluatorConfig

__all__ = ["CLAMPS", "PREDICTIONS", "QUICK_GUIDANCE_DIFFUSION_STEPS", "GoalReachingResult",
           "SampleQuality", "Settings", "best_gain_survival", "clamp_sensitivity",
           "goal_error_kept", "goal_reaching_experiment", "goal_reaching_study",
           "guidance_trajectory_spec", "guided_change_survival", "sample_quality"]


def best_gain_survival(unguided_final_error: np.ndarray | Sequence[float],
                       guided_x0_error: np.ndarray | Sequence[Sequence[float]],
                       guided_final_error: np.ndarray | Sequence[float]) -> float:
    """The share of the best guided gain kept at the end (GMD-A3, registry v3).

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
        """``guided_change_survival`` from the stop step (registry v2's measurement, kept
        outside the rule)."""
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


# ------------------------------------------------------------------------ notebook 01's settings

@dataclass(frozen=True)
class Settings:
    """Every size and step count of notebook 01 at one scale, fixed before any verdict was seen.

    Paper scale (today's registered full settings): 48-frame windows (stride 24) of the
    2000-clip stand-in set, one UNet1D per task for x0 and ε (``paper_settings``'
    architectures), T = 100 cosine, trained to convergence up to each family's step cap
    (``models.training_fields``); 32 goals and 256 generated windows per seed; the package's
    evaluator with its default size; the guidance experiments' trajectory models (GMD-A3, B2,
    F1) the same trajectory specs with ``guidance_diffusion_steps`` = GMD's T = 1000; and
    GMD-A4's longer ε run (``longer_eps_run``). Standard scale (``make reproduce``,
    docs/COMPUTE.md §3): the same windows, the standard architectures at a fixed step count
    (``models.training_fields``), T = 100 for every model — so A4's trajectory models *are*
    A3's guidance models (one cache key) — 128 generated windows per seed, the evaluator of
    notebooks 02 and 03 (one key), no longer ε run. Quick scale shrinks everything (a test of
    the code, never a result; guidance T = ``QUICK_GUIDANCE_DIFFUSION_STEPS``, 50).
    ``train_steps`` may be overridden (the notebook's papermill parameter; None = the scale's).

    The trajectory models train on absolute-root windows (GMD's trajectory model: root x/z in
    the world); GMD-A4's motion models on ``motion_representation``, HumanML3D's relative root
    (:meth:`motion_data`): the claim is about MDM's ε model of ε ∈ R^{263×M}, and MDM models
    HumanML3D's features as they are (registry v3 changelog, GMD-A4).
    """

    scale: str
    seeds: int
    stand_in_clips: int
    frames: int
    #: the step cap (quick) or count (standard); None: each family's (``training_fields``)
    train_steps: int | None
    batch_size: int
    diffusion_steps: int
    goals: int
    generated: int
    #: goals are end positions of test windows whose root travels at least this far (m).
    min_goal_distance: float = 0.5
    #: random draws of x_t and ε per t for the Eq. 1 vs Eq. 2 check (GMD-A1).
    posterior_samples: int = 256
    #: T of the guidance experiments' trajectory models (GMD's 1000; standard 100; quick 50).
    guidance_diffusion_steps: int = GUIDANCE_DIFFUSION_STEPS
    #: the root representation of GMD-A4's motion windows (MDM's: HumanML3D's relative root)
    motion_representation: Representation = "relative"
    #: the evaluator's training steps at the standard scale (``emphasis_study``'s and
    #: notebook 02's: one cache key); None: the scale's own evaluator
    shared_evaluator_steps: int | None = None

    @classmethod
    def for_scale(cls, scale: str, *, seeds: int | None = None,
                  train_steps: int | None = None) -> Settings:
        """The settings of ``scale``; ``seeds`` (None: ``run_seeds.seeds_of("GMD-A4", scale)``)
        and ``train_steps`` (None: the scale's) override."""
        check_scale(scale)
        seeds = seeds_of("GMD-A4", scale) if seeds is None else int(seeds)
        steps = None if train_steps is None else int(train_steps)
        if scale == "quick":
            return cls(scale=scale, seeds=seeds, stand_in_clips=120, frames=24,
                       train_steps=20 if steps is None else steps,
                       batch_size=32, diffusion_steps=20, goals=4, generated=32,
                       guidance_diffusion_steps=QUICK_GUIDANCE_DIFFUSION_STEPS)
        if scale == "standard":
            return cls(scale=scale, seeds=seeds, stand_in_clips=2000, frames=48,
                       train_steps=steps, batch_size=32,
                       diffusion_steps=STANDARD_DIFFUSION_STEPS, goals=32, generated=128,
                       guidance_diffusion_steps=STANDARD_DIFFUSION_STEPS,
                       shared_evaluator_steps=500)
        return cls(scale=scale, seeds=seeds, stand_in_clips=2000, frames=48,
                   train_steps=steps, batch_size=64, diffusion_steps=100, goals=32,
                   generated=256)

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def longer_eps_run(self) -> bool:
        """Whether GMD-A4's longer ε run (``models.longer_run``, 2× the motion budget; outside
        the rule) is trained: at the paper scale (docs/COMPUTE.md §3d), and in quick runs as a
        test of that code; not at the standard scale."""
        return self.scale != "standard"

    def data(self, data_dir: DataDir = None,
             representation: Representation = "absolute") -> DataConfig:
        """The windows (``data_dir`` or the stand-in set) in ``representation``: absolute
        root by default, the trajectory models'."""
        if data_dir is not None:
            return DataConfig(data_dir=data_dir, frames=self.frames,
                              representation=representation)
        return DataConfig(stand_in_clips=self.stand_in_clips, frames=self.frames,
                          representation=representation)

    def motion_data(self, data_dir: DataDir = None) -> DataConfig:
        """GMD-A4's motion windows: :meth:`data` in ``motion_representation``."""
        return self.data(data_dir, self.motion_representation)

    def spec(self, task: Task, prediction: Literal["x0", "epsilon"], data: DataConfig,
             seed: int = 0) -> GMDModelSpec:
        """One of the four models (trajectory/motion × x0/ε): x0 and ε of a task share the
        architecture and the training budget (``models.training_fields``: trained to
        convergence, ``train_steps`` the cap). Below the paper scale the motion models are
        text-conditioned, so that A4's x0 model *is* GMD-B3's relative-root model
        (``root_representation.Settings.motion_spec``, one cache key; docs/COMPUTE.md §3d) and
        its ε model the same spec predicting ε; A4 samples both with the null condition
        (``guidance.sample`` without text: the unconditional model that classifier-free
        training keeps). The paper scale keeps today's unconditional models."""
        fields = training_fields(task, scale=self.scale, step_cap=self.train_steps, seed=seed)
        spec = GMDModelSpec(task=task, prediction=prediction, data=data,
                            diffusion_steps=self.diffusion_steps, **fields)
        return spec.replace(batch_size=self.batch_size,
                            text_conditioned=task == "motion" and self.scale != "paper")

    def guidance_trajectory_spec(self, prediction: Literal["x0", "epsilon"], data: DataConfig,
                                 seed: int = 0) -> GMDModelSpec:
        """The trajectory model of the guidance experiments (GMD-A3 in notebook 01, GMD-F1 in
        06, GMD-B2 in 02: one cache key): ``spec("trajectory", …)`` with GMD's diffusion,
        T = ``guidance_diffusion_steps`` (1000) and the ``GUIDANCE_SCHEDULE`` (cosine)."""
        return self.spec("trajectory", prediction, data, seed).replace(
            diffusion_steps=self.guidance_diffusion_steps, schedule=GUIDANCE_SCHEDULE)

    def evaluator_config(self, data_id: str) -> EvaluatorConfig:
        """The package's evaluator (tiny in quick mode), named after the training windows; at
        the standard scale notebooks 02's and 03's (``emphasis_study.window_evaluator``: the
        same relative-root windows, no name, so one cache key)."""
        if self.quick:
            return EvaluatorConfig(dim=16, hidden=32, data_id=data_id).replace(steps=30)
        if self.shared_evaluator_steps is not None:
            return EvaluatorConfig().replace(steps=self.shared_evaluator_steps)
        return EvaluatorConfig(data_id=data_id)


#: the quick mode's T for the guidance trajectory models (a test of the code, never a result)
QUICK_GUIDANCE_DIFFUSION_STEPS = 50


def guidance_trajectory_spec(scale: str, prediction: Literal["x0", "epsilon"] = "epsilon",
                             data_dir: DataDir = None, seed: int = 0) -> GMDModelSpec:
    """``Settings.for_scale(scale).guidance_trajectory_spec`` on the scale's windows: the
    trajectory model every guidance experiment shares (GMD's trajectory model predicts ε;
    T = 1000 at the paper scale, 100 at standard)."""
    settings = Settings.for_scale(scale)
    return settings.guidance_trajectory_spec(prediction, settings.data(data_dir), seed)


# ---------------------------------------------------------------------- the GMD-A3/A4 studies

#: the two parametrisations and the short tags of their measurement names.
PREDICTIONS = {"x0": "x0", "epsilon": "eps"}

#: GMD-A4's parts that rest on each of its models' fitness gates, (task, prediction) → the
#: record's ``reads`` (None: every part), as gates version 3 registered them: the motion
#: models every part, A4's own T = 100 trajectory models the trajectory part only.
A4_READS: dict[tuple[str, str], list[str] | None] = {
    ("motion", "x0"): None,
    ("motion", "epsilon"): None,
    ("trajectory", "epsilon"): ["choice_matters_less_for_trajectories"],
    ("trajectory", "x0"): ["choice_matters_less_for_trajectories"],
}


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


#: the x̂0 clamps of the ε model: GMD's ±6 (registered), ± the largest |value| of the training
#: windows (registry v2's) and none; the last two are a sensitivity check outside the rule.
CLAMPS: dict[str, Clamp] = {"GMD's ±6 (registered)": "gmd", "±max|x| of the training windows":
                            "auto", "no clamp": None}


def clamp_sensitivity(trajectory_models: dict[tuple[str, int], TrainedGMD],
                      results: dict[tuple[str, int], GoalReachingResult], seeds: Sequence[int],
                      ) -> dict[str, list[float]]:
    """The ε trajectory model's guided goal error (m, per seed) under each of ``CLAMPS`` (same
    goals, noise, strength and stop as ``results``, which used the registered "gmd"; only the
    guided run is repeated)."""
    errors: dict[str, list[float]] = {}
    for s in seeds:
        registered = results[("epsilon", s)]
        model = trajectory_models[("epsilon", s)]
        for label, bound in CLAMPS.items():
            if bound == "gmd":
                error = registered.error_guided
            else:
                guided = sample(model, len(registered.targets), seed=s, clip_x0=bound,
                                guidance=goal_guidance(model, registered.targets,
                                                       strength=registered.strength),
                                stop_guidance_at=registered.stop_guidance_at)
                error = goal_error(model, guided, registered.targets)
            errors.setdefault(label, []).append(float(np.mean(error)))
    return errors


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
