"""Notebook 01 (GMD appendix A, A.1): x0 vs ε prediction (claims GMD-A1…A4).

- GMD-A1, A2: the two forms of the posterior mean and their coefficients (Eq. 1–2, Fig. A.1);
- GMD-A3: under goal guidance, a guided and an unguided run from the same seed (same x_T, same
  per-step noise) give the goal error of the final sample and of x̂0 at every step, and the
  share of the best guided gain that is kept at the end (``best_gain_survival``, GMD-A3's
  registered measurement); its controls are A/A runs (``controls.aa_controls``: the ε model
  against an independently trained copy); the exact and planted models beside them check
  the measurement code;
- GMD-A4: the unguided sample quality (jitter, FID) of x0 and ε models, with A/A controls
  (each task's reference arm against an independently trained copy);
- the results: each ``a*_result`` takes what the notebook measured, runs the claim's controls
  and returns the :class:`~repro.claims.result.ClaimResult` its registered rule reads, with the
  fitness-gate records of the models behind it; the notebook's "Reading" paragraphs.

The guidance experiments' trajectory models run GMD's diffusion, T = 1000 cosine
(``Settings.guidance_trajectory_spec``, read by notebooks 01, 02 and 06).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor, nn

from repro.claims.result import ClaimResult, Controls
from repro.core.diffusion import GaussianDiffusion, SampleTrajectory
from repro.core.tables import render
from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    AAReadings,
    Slot,
    aa_controls,
    aa_readings,
    calibrate_increasing,
    control_seed,
    draw_indices,
    jag,
    offset_unread_features,
    reference_model,
)
from repro.gmd.figures import either
from repro.gmd.guidance import (
    GMD_GUIDANCE_STRENGTH,
    Clamp,
    default_stop_step,
    goal_error,
    goal_guidance,
    guidance_parameters,
    resolve_clamp,
    sample,
)
from repro.gmd.measurements import foot_skating_of, jitter_of, motion_fid
from repro.gmd.models import (
    GUIDANCE_DIFFUSION_STEPS,
    GUIDANCE_SCHEDULE,
    STANDARD_DIFFUSION_STEPS,
    X0_CLAMP,
    GMDModelSpec,
    TrainedGMD,
    describe,
    load_or_train_many,
    longer_run,
    parameter_count,
    training_fields,
)
from repro.gmd.settings import seeds_of
from repro.gmd.windows import (
    DataConfig,
    DataDir,
    FeatureSpace,
    MotionWindows,
    Representation,
    Task,
    goal_targets,
)
from repro.infra.context import RunSettings, check_scale
from repro.models.evaluator import Evaluator, EvaluatorConfig
from repro.motion.features import FEATURE_BLOCKS

__all__ = ["A3Study", "A3_SLOTS", "A4Records", "A4_SLOTS", "CLAMPS", "EpsilonOfX0",
           "ExactGaussianDenoiser", "GoalReachingResult", "LateRevertingDenoiser", "PREDICTIONS",
           "QUICK_GUIDANCE_DIFFUSION_STEPS", "SampleQuality", "Settings", "a1_result", "a2_result",
           "a3_aa_readings", "a3_controls", "a3_model_records", "a3_reading", "a3_result",
           "a3_study", "a4_aa_readings", "a4_budget_markdown", "a4_controls", "a4_model_records",
           "a4_reading", "a4_result", "best_gain_survival", "c_identity_error", "clamp_sensitivity",
           "coefficient_shares", "exact_model", "exact_pair", "finite", "goal_error_kept",
           "goal_reaching_experiment", "goal_reaching_study", "guidance_trajectory_spec",
           "guided_change_survival", "jagged_by", "late_reverting_model", "longer_eps_description",
           "longer_eps_models", "parameter_counts", "peak_fraction", "posterior_mean_forms",
           "printed_c_relative_error", "reading_a3", "reading_clamp", "sample_quality",
           "trajectory_model_values", "trajectory_reference"]


# ------------------------------------------------------------------------------------------------
# GMD appendix A: the two forms of the posterior mean and their coefficients (Eq. 1–2, Fig. A.1).
#
# Eq. 1 writes μ_t = a·x0 + b·x_t; substituting x0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t gives Eq. 2,
# μ_t = c·x_t − d·ε. The coefficients themselves live on ``core.diffusion.GaussianDiffusion``;
# the functions below evaluate the appendix's statements about them (claims GMD-A1, GMD-A2).
# ------------------------------------------------------------------------------------------------

def posterior_mean_forms(diffusion: GaussianDiffusion, *, samples: int = 64,
                         seed: int = 0) -> np.ndarray:
    """max |a·x0 + b·x_t − (c·x_t − d·ε)| per t (T,), float64, for random x_t, ε ~ N(0, I)
    (``samples`` values per t) and x0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t (GMD Eq. 1 vs Eq. 2)."""
    generator = torch.Generator().manual_seed(seed)
    steps = diffusion.num_timesteps
    x_t = torch.randn(steps, samples, generator=generator, dtype=torch.float64)
    eps = torch.randn(steps, samples, generator=generator, dtype=torch.float64)
    t = torch.arange(steps)
    x0 = diffusion.predict_x0_from_eps(x_t, t, eps)
    eq1 = diffusion.q_posterior_mean(x0, x_t, t)
    eq2 = diffusion.posterior_mean_from_eps(x_t, eps, t)
    return (eq1 - eq2).abs().amax(dim=1).numpy()


def printed_c_relative_error(diffusion: GaussianDiffusion) -> np.ndarray:
    """|c_printed − c|/c per t, c_printed = a/ᾱ_t + b (Eq. 2 as printed), c = a/√ᾱ_t + b."""
    c = diffusion.eps_mean_coef_xt
    return np.abs(diffusion.eps_mean_coef_xt_as_printed - c) / c


def c_identity_error(diffusion: GaussianDiffusion) -> float:
    """max_t |c·√α_t − 1|: Eq. 2's c = a/√ᾱ_t + b is 1/√α_t (GMD-A1's derivation)."""
    return float(np.max(np.abs(diffusion.eps_mean_coef_xt * np.sqrt(diffusion.alphas) - 1.0)))


def coefficient_shares(diffusion: GaussianDiffusion) -> dict[str, np.ndarray]:
    """Fig. A.1's curves over t: a, b (Eq. 1), c, d (Eq. 2), the x0 share a/(a+b) and the
    ε share d/(c+d) (the relative shares registered for claim GMD-A2)."""
    a, b = diffusion.posterior_mean_coef_x0, diffusion.posterior_mean_coef_xt
    c, d = diffusion.eps_mean_coef_xt, diffusion.eps_mean_coef_eps
    return {"a": a, "b": b, "c": c, "d": d, "x0_share": a / (a + b), "eps_share": d / (c + d)}


def peak_fraction(values: np.ndarray) -> float:
    """Where a curve over t = 0 … T−1 peaks, as the paper's step (t + 1) divided by T."""
    return float((int(np.argmax(values)) + 1) / len(values))



# --- GMD-A3 and A4: goal reaching under guidance, unguided sample quality ------------------------

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


# ------------------------------------------------------------------------ notebook 01's settings

@dataclass(frozen=True)
class Settings(RunSettings):
    """Every size and step count of notebook 01 at one scale, fixed before any verdict was seen.

    Paper scale (today's registered full settings): 48-frame windows (stride 24) of the
    2000-clip stand-in set, one UNet1D per task for x0 and ε (``models``'
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
    HumanML3D's features as they are (GMD-A4's registry entry).
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
    #: the evaluator's training steps at the standard scale (``emphasis_projection``'s and
    #: notebook 02's: one cache key); None: the scale's own evaluator
    shared_evaluator_steps: int | None = None

    @classmethod
    def for_scale(cls, scale: str, *, seeds: int | None = None,
                  train_steps: int | None = None) -> Settings:
        """The settings of ``scale``; ``seeds`` (None: ``settings.seeds_of("GMD-A4", scale)``)
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
    def motion_predictions(self) -> tuple[str, ...]:
        """GMD-A4's motion arms this scale trains: both, or x0 alone where the scale does not
        run the ε motion arm (``settings.not_run``: the standard scale's registered cut)."""
        if set(rule_settings.not_run("GMD-A4", self.scale)) >= set(A4_PARTS):
            return ("x0",)
        return tuple(PREDICTIONS)

    @property
    def a4_not_run(self) -> dict[str, str]:
        """GMD-A4's parts this scale does not run, each with why (``settings.not_run``)."""
        return rule_settings.not_run("GMD-A4", self.scale)

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
        the standard scale notebooks 02's and 03's (``emphasis_projection.window_evaluator``: the
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


#: GMD-A4's registered parts (every one reads the ε motion arm)
A4_PARTS = ("eps_motion_more_jagged", "eps_motion_worse_fid",
            "choice_matters_less_for_trajectories")


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
#: windows and none; the last two are a sensitivity check outside the rule.
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
    models, root jerk of the trajectory models. A motion arm not in ``models`` (a scale that
    does not train it) has no values."""
    names = ("motion_jitter", "motion_fid", "trajectory_jitter", "motion_root_jitter",
             "motion_acceleration", "motion_foot_skating")
    values: dict[str, list[float]] = {f"{name}_{tag}": [] for name in names
                                      for tag in PREDICTIONS.values()}
    examples = {}
    for s in seeds:
        for prediction, tag in PREDICTIONS.items():
            trajectory_model = models[("trajectory", prediction, s)]
            trajectories = sample(trajectory_model, n, seed=s)
            values[f"trajectory_jitter_{tag}"].append(
                float(jitter_of(trajectory_model, trajectories).jerk))
            if ("motion", prediction, s) not in models:
                continue
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
            if s == seeds[0]:
                examples[prediction] = motion_model.space.joints(x[:2]).numpy()
    return SampleQuality({k: v for k, v in values.items() if v}, examples)



def sample_quality_lines(values: Mapping[str, list[float]], seeds: Sequence[int]) -> str:
    """One line per seed: each measurement of :func:`sample_quality` for the arms it has."""
    arms = (("x0", "x0"), ("ε", "eps"))
    lines = []
    for k, s in enumerate(seeds):
        cells = [f"{label} " + " / ".join(f"{arm} {values[f'{key}_{tag}'][k]:.3g}"
                                          for arm, tag in arms if f"{key}_{tag}" in values)
                 for key, label in (("motion_jitter", "motion jerk"), ("motion_fid", "FID"),
                                    ("trajectory_jitter", "trajectory jerk"))]
        lines.append(f"seed {s}: " + "; ".join(cells) + " (jerk m/s³)")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------------
# GMD-A3's exact checks of the measurement code (notebook 01 records the A/A controls,
# :func:`a3_aa_readings`), beside ``repro.gmd.controls``: exact models whose truth is known, run
# through the experiment's own ``x0_vs_eps.goal_reaching_experiment`` (same T, stop step,
# clamp, goals). They cannot fire on between-model noise (there is none), so no claim is
# decided on them.
#
# - **Null**: an exact x0/ε pair — one exact network (:class:`ExactGaussianDenoiser`) read as an
#   x0 model and, through :class:`EpsilonOfX0`, as an ε model. With one seed both sample the
#   same paths up to float rounding, so no part may fire.
# - **Positive**: the x0 arm replaced by the same network made to undo a share of its guided
#   change after guidance stops (:class:`LateRevertingDenoiser`): the paper's mechanism,
#   "undoing … the guidance signal … at the end of the diffusion process", planted.
# ------------------------------------------------------------------------------------------------

#: δ of GMD-A3's survival part (registry_gmd): 0.1 of the best guided gain
SURVIVAL_DELTA = 0.1


#: δ of GMD-A3's goal-error part: 10 % of the x0 arm's goal error
GOAL_ERROR_DELTA_SHARE = 0.1


class ExactGaussianDenoiser(nn.Module):
    """The exact x0 predictor for data whose every channel is ~ N(0, Σ) over frames, Σ the
    squared-exponential kernel exp(−(i−j)²/2ℓ²) (smooth paths, unit variance):
    x̂0 = E[x0 | x_t] = √ᾱ_t Σ (ᾱ_t Σ + (1−ᾱ_t) I)⁻¹ x_t. A goal on one frame then moves every
    frame (as a learned model's does). Its x0 and ε parametrisations are the same model."""

    def __init__(self, diffusion: GaussianDiffusion, frames: int,
                 length_scale: float | None = None) -> None:
        super().__init__()
        scale = frames / 4 if length_scale is None else length_scale
        index = torch.arange(frames, dtype=torch.float64)
        kernel = torch.exp(-0.5 * ((index[:, None] - index[None, :]) / scale) ** 2)
        alpha_bar = torch.as_tensor(diffusion.alphas_cumprod, dtype=torch.float64)
        eye = torch.eye(frames, dtype=torch.float64)
        posterior = torch.stack([a.sqrt() * kernel @ torch.linalg.inv(a * kernel + (1 - a) * eye)
                                 for a in alpha_bar])
        self.register_buffer("posterior", posterior.float())  # (T_diffusion, frames, frames)
        self.unused = nn.Parameter(torch.zeros(1))  # TrainedGMD reads its device from one

    def forward(self, x: Tensor, t: Tensor, **_: Any) -> Tensor:
        return torch.einsum("bij,bcj->bci", self.posterior[t], x)


def exact_model(trained: TrainedGMD) -> TrainedGMD:
    """The exact smooth-Gaussian x0 model (:class:`ExactGaussianDenoiser`) with ``trained``'s
    noise schedule, feature space and window length."""
    frames = trained.spec.data.frames
    diffusion = GaussianDiffusion(trained.diffusion.betas, "x0")
    return TrainedGMD(ExactGaussianDenoiser(diffusion, frames), diffusion, trained.space,
                      trained.spec.replace(prediction="x0"))


class EpsilonOfX0(nn.Module):
    """An x0 network read as an ε network: ε̂ = (x_t/√ᾱ_t − x̂0)/√(1/ᾱ_t − 1), the inverse of
    the sampler's x̂0 = (x_t − √(1−ᾱ_t) ε̂)/√ᾱ_t, so both parametrisations give the same x̂0,
    the same μ_t (GMD Eq. 1 = Eq. 2) and the same guidance gradient, up to float rounding."""

    def __init__(self, x0_model: nn.Module, diffusion: GaussianDiffusion) -> None:
        super().__init__()
        self.x0_model = x0_model
        self.diffusion = diffusion

    def forward(self, x: Tensor, t: Tensor, **kwargs: Any) -> Tensor:
        return self.diffusion.predict_eps_from_x0(x, t, self.x0_model(x, t, **kwargs))


def exact_pair(trained: TrainedGMD) -> dict[str, TrainedGMD]:
    """{"x0": :func:`exact_model`, "epsilon": the same network as an ε model
    (:class:`EpsilonOfX0`)}: an x0/ε pair known to sample identically from one seed."""
    x0 = exact_model(trained)
    eps_diffusion = GaussianDiffusion(x0.diffusion.betas, "epsilon")
    eps = TrainedGMD(EpsilonOfX0(x0.model, eps_diffusion), eps_diffusion, x0.space,
                     x0.spec.replace(prediction="epsilon"))
    return {"x0": x0, "epsilon": eps}


class LateRevertingDenoiser(nn.Module):
    """An x0 network that undoes guidance in the last steps (GMD-A3's positive control): for
    t < ``below`` its x̂0 is moved back toward the unguided run's x̂0 at that step,
    x̂0' = x̂0 − ``share``·(x̂0 − x̂0_U(t)) (``reference``: t → x̂0_U(t), (B, C, T)). On the
    unguided run itself x̂0 = x̂0_U(t), so that run is unchanged; a guided run loses the share
    ``share`` of its guided change in x̂0 at each of those steps."""

    def __init__(self, x0_model: nn.Module, reference: dict[int, Tensor], *, below: int,
                 share: float) -> None:
        super().__init__()
        self.x0_model = x0_model
        self.reference = reference
        self.below = int(below)
        self.share = float(share)

    def forward(self, x: Tensor, t: Tensor, **kwargs: Any) -> Tensor:
        out = self.x0_model(x, t, **kwargs)
        step = int(t[0])
        if step >= self.below:
            return out
        reference = self.reference[step].to(out.device, out.dtype)
        return out - self.share * (out - reference)


def late_reverting_model(x0: TrainedGMD, n: int, *, seed: int, below: int,
                         share: float) -> TrainedGMD:
    """``x0`` (an x0 model) as a :class:`LateRevertingDenoiser` whose reference is its own
    unguided run of ``n`` samples from ``seed`` (the run a paired experiment compares with,
    at the controls' clamp ±``X0_CLAMP``)."""
    with torch.no_grad():
        _, path = sample(x0, n, seed=seed, return_trajectory=True, clip_x0=X0_CLAMP,
                         trajectory_timesteps=range(below))
    reference = {int(t): path.pred_x0[i] for i, t in enumerate(path.timesteps)}
    model = LateRevertingDenoiser(x0.model, reference, below=below, share=share)
    return TrainedGMD(model, x0.diffusion, x0.space, x0.spec)


def _survivals(runs: Sequence[GoalReachingResult]) -> list[float | None]:
    """Per-run best-gain survival; None where it is undefined (no guided gain)."""
    return [float(r.survival) if np.isfinite(r.survival) else None for r in runs]


def _a3_measured(x0: Sequence[GoalReachingResult], eps: Sequence[GoalReachingResult],
                 ) -> dict[str, list[float | None]]:
    """The notebook's GMD-A3 measurements (batch-mean goal error, best-gain survival)."""
    return {"goal_error_x0": [float(r.error_guided.mean()) for r in x0],
            "goal_error_eps": [float(r.error_guided.mean()) for r in eps],
            "best_gain_survival_x0": _survivals(x0), "best_gain_survival_eps": _survivals(eps)}


def _mean_gap(a: Sequence[float | None], b: Sequence[float | None]) -> float:
    """mean(a − b) over the seeds where both are defined (NaN if none)."""
    pairs = [(x, y) for x, y in zip(a, b, strict=True) if x is not None and y is not None]
    return float(np.mean([x - y for x, y in pairs])) if pairs else float("nan")


def a3_controls(trajectory_models: Mapping[tuple[str, int], TrainedGMD], test: MotionWindows,
                seeds: Sequence[int], *, goals: int, min_distance: float,
                revert_share: float = 0.5) -> Controls:
    """GMD-A3's controls toward the experiment's goals per seed (``trajectory_models`` keyed
    (prediction, seed); the exact models take their noise schedule, T and feature space).

    Both arms clamp x̂0 at GMD's ±6 (the ε arm's registered clamp): were only the ε arm
    clamped, the pair would differ wherever guidance pushes x̂0 past ±6 and would no longer
    be exact. Null: :func:`exact_pair` from the same seed in both arms. Positive: the x0 arm
    replaced by :func:`late_reverting_model` — ``revert_share`` of the guided change in x̂0
    undone at every step after guidance stops (t < the stop step) — against the same ε arm.
    What that plants (survival drop, goal-error gap, in units of each part's δ) is measured
    and recorded."""
    x0_runs, eps_runs, planted_runs = [], [], []
    stop = 0
    for s in seeds:
        pair = exact_pair(trajectory_models[("x0", s)])
        targets = goal_targets(test, goals, seed=s, min_distance=min_distance)
        seed = control_seed(s, 0)
        stop = default_stop_step(pair["x0"].num_timesteps)
        eps_runs.append(goal_reaching_experiment(pair["epsilon"], targets, seed=seed,
                                                 clip_x0=X0_CLAMP))
        x0_runs.append(goal_reaching_experiment(pair["x0"], targets, seed=seed,
                                                clip_x0=X0_CLAMP))
        reverting = late_reverting_model(pair["x0"], len(targets), seed=seed, below=stop,
                                         share=revert_share)
        planted_runs.append(goal_reaching_experiment(reverting, targets, seed=seed,
                                                     clip_x0=X0_CLAMP))
    null, positive = _a3_measured(x0_runs, eps_runs), _a3_measured(planted_runs, eps_runs)
    drop = _mean_gap(null["best_gain_survival_x0"], positive["best_gain_survival_x0"])
    goal_gap = _mean_gap(positive["goal_error_x0"], positive["goal_error_eps"])
    goal_delta = GOAL_ERROR_DELTA_SHARE * float(np.mean(positive["goal_error_x0"]))
    return Controls(
        null=null, positive=positive,
        planted={"model": "exact smooth-Gaussian x0 network, also read as an ε model; same "
                          "seed and goals in both arms",
                 "revert_share": revert_share, "revert_below_t": stop,
                 "survival_drop_x0": drop, "survival_drop_in_delta": drop / SURVIVAL_DELTA,
                 "goal_error_gap_m": goal_gap, "goal_error_gap_in_delta": goal_gap / goal_delta},
        null_text=(f"one exact smooth-Gaussian network as the x0 and as the ε model, same seed "
                   f"and goals in both arms (identical samples), {len(seeds)} seed(s)"),
        positive_text=(f"the x0 arm made to undo {revert_share:g} of its guided change in x̂0 "
                       f"at every step t < {stop}: survival {drop:.3g} lower "
                       f"({drop / SURVIVAL_DELTA:.3g} δ), goal error x0 − ε {goal_gap:.3g} m "
                       f"({goal_gap / goal_delta:.3g} δ)"))



# --- GMD-A4's controls: the data as the model, jitter and FID planted in the ε arm ---------------

def jagged_by(space: FeatureSpace, x: Tensor, factor: float, seed: int) -> tuple[Tensor, float]:
    """(x made jagged, amplitude): :func:`jag` with the white-noise draw of ``seed`` at the
    amplitude (m, by bisection) that makes the mean joint jerk of these very samples
    ``factor`` × theirs — an exact plant on them, up to the bisection's 2⁻³⁰ of its bracket."""
    clean = float(jitter_of(space, x).jerk)

    def ratio(amplitude: float) -> float:
        return float(jitter_of(space, jag(space, x, amplitude, seed)).jerk) / clean

    amplitude = calibrate_increasing(ratio, factor, high=1e-3)
    return jag(space, x, amplitude, seed), amplitude


def a4_controls(train: MotionWindows, seeds: Sequence[int], *, n: int, evaluator: Any,
                test_embeddings: np.ndarray, trajectory_train: MotionWindows | None = None,
                factor: float = 1.1) -> Controls:
    """GMD-A4's controls: ``n`` training windows per seed stand in for each model's samples,
    measured with the experiment's code (joint jerk, FID against ``test_embeddings``, root
    jerk of the trajectory channels). ``train``: the motion models' windows;
    ``trajectory_train``: the trajectory models' (default ``train``).

    Paired as the experiment (``sample_quality``: the x0 and the ε model of a seed sample
    from the same noise): one draw of ``n`` motion windows and one of ``n`` trajectory windows
    per seed (:func:`control_seed` with arm 0; another draw per seed) are both arms. Null:
    those draws in both arms (every log ratio 0). Positive: the ε motion arm made jagged —
    white noise (one draw per seed) on every joint position at the amplitude that makes its
    joint jerk exactly ``factor`` × the x0 arm's (:func:`jagged_by`: part 1's δ, log 1.1; with
    the trajectory arms equal, the |log ratio| gap is log 1.1 exactly: part 3's δ) — and its
    non-joint features (which no joint reads: the jerk stays) shifted along a fixed direction
    by the size that makes its FID ``factor`` × the x0 arm's on the same draw (part 2's δ,
    by bisection on the draw itself: an FID of ``n`` samples varies from draw to draw by far
    more than 10 %, so a size calibrated on other draws does not carry over; zero, and
    recorded, where the noise alone raises the FID further). Tests plant a larger effect
    through ``factor`` (both ratios)."""
    trajectory_train = train if trajectory_train is None else trajectory_train
    motion, trajectory = train.space("motion"), trajectory_train.space("trajectory")
    unread = motion.channels - FEATURE_BLOCKS["ric_positions"].stop
    direction = torch.from_numpy(
        np.random.default_rng(control_seed(0, 0, stream=9)).standard_normal(unread)).float()
    direction = direction / direction.norm()

    def fid(x: Tensor) -> float:
        return float(motion_fid(motion, x, evaluator, test_embeddings))

    null: dict[str, list[float]] = {}
    positive: dict[str, list[float]] = {}
    amplitudes, sizes, noise_alone = [], [], []
    for s in seeds:
        drawn = train.x[draw_indices(train, n, control_seed(s, 0, stream=1))]
        track = trajectory_train.trajectory()[draw_indices(trajectory_train, n,
                                                           control_seed(s, 0, stream=2))]
        clean = {"motion_jitter": float(jitter_of(motion, drawn).jerk),
                 "motion_fid": fid(drawn),
                 "trajectory_jitter": float(jitter_of(trajectory, track).jerk)}
        rough, amplitude = jagged_by(motion, drawn, factor, control_seed(s, 0, stream=3))
        size = calibrate_increasing(
            lambda a, x=rough: fid(offset_unread_features(motion, x, a, direction)),
            factor * clean["motion_fid"], high=0.5)
        planted = offset_unread_features(motion, rough, size, direction)
        amplitudes.append(amplitude)
        sizes.append(size)
        noise_alone.append(fid(rough) / clean["motion_fid"])
        for name, value in clean.items():
            for out in (null, positive):
                out.setdefault(f"{name}_x0", []).append(value)
            null.setdefault(f"{name}_eps", []).append(value)
        positive.setdefault("motion_jitter_eps", []).append(float(jitter_of(motion,
                                                                            planted).jerk))
        positive.setdefault("motion_fid_eps", []).append(fid(planted))
        positive.setdefault("trajectory_jitter_eps", []).append(clean["trajectory_jitter"])

    def ratios(name: str) -> np.ndarray:
        return np.asarray(positive[f"{name}_eps"]) / np.asarray(positive[f"{name}_x0"])

    jerk_ratio, fid_ratio = ratios("motion_jitter"), ratios("motion_fid")
    return Controls(null=null, positive=positive,
                    planted={"jitter_noise_amplitude_m": amplitudes,
                             "jerk_ratio": jerk_ratio.tolist(),
                             "unread_feature_offset": sizes,
                             "fid_ratio": fid_ratio.tolist(),
                             "fid_ratio_of_noise_alone": noise_alone,
                             "model": f"{n} training windows per seed, the same in both arms"},
                    null_text=(f"paired as the experiment: the same {n} training windows (and "
                               f"{n} trajectory windows) in both arms of a seed (another draw "
                               f"per seed), {len(seeds)} seed(s); no plant (equal arms)"),
                    positive_text=(f"the same paired draws; the ε motion arm jagged (white "
                                   f"noise of {1000 * float(np.mean(amplitudes)):.3g} mm mean "
                                   f"amplitude on every joint position: jerk × "
                                   f"{jerk_ratio.mean():.3g}) and its non-joint features "
                                   f"shifted (FID × {_span(fid_ratio)}), both sized on each "
                                   f"seed's draw itself"))


def _span(values: np.ndarray) -> str:
    """"a" where every value rounds to a (3 digits), else "a–b": the least and the largest."""
    low, high = f"{values.min():.3g}", f"{values.max():.3g}"
    return low if low == high else f"{low}–{high}"



# --- notebook 01's reading paragraphs ------------------------------------------------------------

def reading_a3(*, stop: int, num_timesteps: int, best_step: dict[str, float],
               survival: dict[str, float], stop_step_survival: dict[str, float]) -> str:
    """How to read GMD-A3's survival, rendered from this run's values (means over seeds):
    ``best_step`` the step t of the closest approach, ``survival`` the registered best-gain
    survival and ``stop_step_survival`` the survival from the stop step, per model ("x0",
    "epsilon")."""
    return render(
        "**Reading GMD-A3.** Guidance acts while t ≥ {stop} of T = {T}. The registered "
        "survival compares the end with the guided x̂0's closest approach to the goal, "
        "wherever in sampling it happens: on average at t ≈ {best_x0:.0f} for the x0 model "
        "and t ≈ {best_eps:.0f} for the ε model. The x0 model keeps {s_x0:.2f} of its best "
        "gain and the ε model {s_eps:.2f}. Counted from the stop step instead (registry v2's "
        "measurement, outside the rule) they keep {v2_x0:.2f} and {v2_eps:.2f}: {v2_reading} "
        "A share is undefined (stored as null) for a seed whose guided x̂0 never came nearer "
        "the goal than the unguided sample.",
        stop=stop, T=num_timesteps, best_x0=best_step["x0"], best_eps=best_step["epsilon"],
        s_x0=survival["x0"], s_eps=survival["epsilon"], v2_x0=stop_step_survival["x0"],
        v2_eps=stop_step_survival["epsilon"],
        v2_reading=either(
            min(best_step.values()) > stop,
            "both closest approaches lie before the stop step, so what is undone there is "
            "outside the v2 measurement.",
            "at least one closest approach lies after the stop step."))


#: the labels of ``x0_vs_eps.CLAMPS`` (registered first)
CLAMP_LABELS = ("GMD's ±6 (registered)", "±max|x| of the training windows", "no clamp")


def reading_clamp(errors: dict[str, list[float]], *, bound: float, unguided_eps: float,
                  guided_x0: float, seeds: Sequence[int]) -> str:
    """The x̂0-clamp sensitivity check of GMD-A3. ``errors``: ``x0_vs_eps.clamp_sensitivity``
    (``CLAMP_LABELS``); ``bound`` the ±max|x| bound; the other values are means over seeds."""
    gmds, ours, none = (float(np.mean(errors[k])) for k in CLAMP_LABELS)
    x0_better_both = guided_x0 < ours and guided_x0 < gmds

    def effect(value: float) -> str:
        return either(value > unguided_eps, "makes the ε model *worse*", "helps the ε model")

    return render(
        "**Reading** (this run, seeds {seeds}). With GMD's ±6 (registered) guidance "
        "{gmd_effect} ({gmds:.3g} m against {unguided:.3g} m unguided); with ± the largest "
        "|value| of the training windows (±{bound:.1f}, registry v2's bound) it {ours_effect} "
        "({ours:.3g} m); without any clamp the guided samples end {none:.3g} m from their "
        "goals. The x0 model's guided error is {x0:.3g} m. {verdict}",
        seeds=list(seeds), bound=bound, ours_effect=effect(ours), ours=ours,
        unguided=unguided_eps, gmd_effect=effect(gmds), gmds=gmds, none=none, x0=guided_x0,
        verdict=either(
            (guided_x0 < ours) == (guided_x0 < gmds),
            either(x0_better_both,
                   "Under both bounds the x0 model reaches the goals better than the ε model: "
                   "the goal-error comparison does not hinge on the bound.",
                   "Under both bounds the ε model reaches the goals at least as well as the "
                   "x0 model: the goal-error comparison does not hinge on the bound."),
            "Which model reaches the goals better depends on the clamp bound here: the "
            "goal-error half of the verdict rests on taking GMD's bound."))



# ------------------------------------------------------------------------------------------------
# Notebook 01's claims as results: GMD-A1…A4, each a :class:`~repro.claims.result.ClaimResult`.
#
# Each ``a*_result`` takes what the notebook measured (the coefficient curves of appendix A's
# Eq. 1–2 and Fig. A.1; the goal-reaching runs of :func:`goal_reaching_study`; the
# sample quality of :func:`sample_quality`), runs the claim's controls, and returns
# the measurements its registered rule reads with the headline, notes and extra values of the
# sidecar; the notebook then calls ``record(ctx, result)``. The fitness-gate records of the
# models behind A3 and A4 (``model_gates``, gates version 3) are built here too, and the
# training-budget table of A4's longer ε run.
# ------------------------------------------------------------------------------------------------

#: a figure's path, as ``ClaimResult.figures`` takes it
FigurePath = str | os.PathLike


def finite(values: Sequence[float]) -> list[float | None]:
    """JSON has no NaN: an undefined share (no guided gain) is stored as null."""
    return [v if np.isfinite(v) else None for v in values]


# ------------------------------------------------------------------------------ GMD-A1, A2

def a1_result(diffusion: GaussianDiffusion, mu_difference: np.ndarray,
              printed_error: np.ndarray, *, figure: FigurePath, seed: int) -> ClaimResult:
    """GMD-A1: the largest |Eq. 1 − Eq. 2| over t (``posterior_mean_forms``) and
    the printed c's relative error (``printed_c_relative_error``) on ``diffusion`` (GMD's
    T = 1000 cosine), with c = 1/√α_t checked (``c_identity_error``)."""
    c_check = c_identity_error(diffusion)
    return ClaimResult(
        "GMD-A1",
        {"max_abs_mu_difference": float(mu_difference.max()),
         "printed_c_max_relative_error": float(printed_error.max())},
        seeds=[seed], figures=[figure],
        headline=(f"max |Δμ| = {mu_difference.max():.1e} over all t; c = a/√ᾱ_t + b = 1/√α_t; "
                  f"printed a/ᾱ_t + b off by {printed_error.min():.1e} (t=1) to "
                  f"{printed_error.max():.1e} (t=T) relative"),
        notes=("Ours: T = 1000 cosine schedule as GMD (max β 0.999); 256 N(0,1) draws of x_t "
               "and ε per t in float64; the PDF's text layer drops the bars over α, read as ᾱ."),
        extra={"parameters": {"num_timesteps": diffusion.num_timesteps, "guidance_stop_t": None,
                              "x0_clamp": None},
               "c_equals_one_over_sqrt_alpha_max_error": c_check,
               "printed_c_relative_error_at_t1": float(printed_error[0]),
               "printed_c_relative_error_at_t500": float(printed_error[499])})


def a2_result(schedules: Mapping[str, Mapping[str, np.ndarray]],
              peaks: Mapping[str, Mapping[str, float]], *, figure: FigurePath,
              seed: int) -> ClaimResult:
    """GMD-A2: where the x0 share a/(a+b) and the ε share d/(c+d) peak (``
    coefficient_shares``, ``peak_fraction``: step / T) on the cosine schedule (Fig. A.1), the
    linear one beside it; ``schedules`` at T = 1000."""
    cos = schedules["cosine"]
    steps = len(cos["x0_share"])
    return ClaimResult(
        "GMD-A2",
        {"cosine_x0_share_argmax_fraction": peaks["cosine"]["x0_share"],
         "cosine_eps_share_argmax_fraction": peaks["cosine"]["eps_share"]},
        seeds=[seed], figures=[figure],
        headline=(f"cosine: x0 share a/(a+b) peaks at t = "
                  f"{peaks['cosine']['x0_share'] * steps:.0f}/{steps} ({cos['x0_share'][0]:.2f}), "
                  f"ε share d/(c+d) at t = {peaks['cosine']['eps_share'] * steps:.0f}/{steps} "
                  f"({cos['eps_share'][-1]:.2f}); linear: "
                  f"{peaks['linear']['x0_share'] * steps:.0f} and "
                  f"{peaks['linear']['eps_share'] * steps:.0f}"),
        notes=("Ours: shares as registered (a/(a+b), d/(c+d)); the paper does not define its "
               "'relative share'. Steps counted 1…T (our index t+1). Both cosine shares are "
               "not monotone: share_x0 rises again in the last ~10 % of steps (to "
               f"{cos['x0_share'][-1]:.3f} at t = T) and share_ε dips after t = 1 "
               f"({cos['eps_share'][0]:.4f}) before rising; the peaks are still at the ends."),
        extra={"parameters": {"num_timesteps": steps, "guidance_stop_t": None, "x0_clamp": None},
               "peaks": peaks,
               **{f"cosine_{key}_at": {str(t): float(cos[key][t - 1])
                                       for t in (1, 10, 500, steps)}
                  for key in ("x0_share", "eps_share")}})


# ----------------------------------------------------------------------------------- GMD-A3

@dataclass(frozen=True)
class A3Study:
    """GMD-A3's goal-reaching runs (:func:`x0_vs_eps.goal_reaching_study`, keyed (prediction,
    seed)), their seeds and the sampling settings (``guidance.guidance_parameters`` of the ε
    model at the runs' stop step)."""

    runs: dict[tuple[str, int], GoalReachingResult]
    seeds: list[int]
    parameters: dict[str, Any]

    def per_seed(self, prediction: str, attribute: str) -> list[float]:
        """A scalar attribute of each seed's run (e.g. ``best_step``, ``survival``)."""
        return [float(getattr(self.runs[(prediction, s)], attribute)) for s in self.seeds]

    def seed_means(self, prediction: str, attribute: str) -> list[float]:
        """The mean over goals of a per-goal attribute (e.g. ``error_unguided``), per seed."""
        return [float(np.mean(getattr(self.runs[(prediction, s)], attribute)))
                for s in self.seeds]

    @property
    def goal_error(self) -> dict[str, list[float]]:
        """The guided final samples' mean goal error (m) per seed: ``goal_error_{x0,eps}``."""
        return {p: [float(self.runs[(p, s)].error_guided.mean()) for s in self.seeds]
                for p in PREDICTIONS}

    @property
    def survival(self) -> dict[str, list[float]]:
        """Best-gain survival per seed (the registered measurement)."""
        return {p: self.per_seed(p, "survival") for p in PREDICTIONS}

    @property
    def stop_survival(self) -> dict[str, list[float]]:
        """The survival of the guided change from the stop step, per seed (outside the rule)."""
        return {p: self.per_seed(p, "stop_step_survival") for p in PREDICTIONS}


def a3_study(guided_models: dict[tuple[str, int], TrainedGMD], test: MotionWindows,
             seeds: Sequence[int], settings: Settings) -> A3Study:
    """The two guidance trajectory models' goal-reaching runs toward ``settings.goals`` test
    goals per seed (:func:`x0_vs_eps.goal_reaching_study`, GMD's guidance, clamp and stop)."""
    runs = goal_reaching_study(guided_models, test, seeds, goals=settings.goals,
                               min_distance=settings.min_goal_distance)
    first = seeds[0]
    parameters = guidance_parameters(guided_models[("epsilon", first)],
                                     stop=runs[("epsilon", first)].stop_guidance_at)
    return A3Study(runs, list(seeds), parameters)


#: each prediction's role in GMD-A3 and A4 (``core.gates.ROLES``): GMD's trajectory model
#: predicts ε and its motion model x0, so those are the reference arms the other is compared
#: against (and the only arms the sample gates judge)
TRAJECTORY_ROLES = {"epsilon": "reference", "x0": "treatment"}


MOTION_ROLES = {"x0": "reference", "epsilon": "treatment"}


def trajectory_reference(test: MotionWindows) -> dict[str, float]:
    """The ``gmd_trajectory`` gates' reference: the test windows' own path length and root
    jerk."""
    return model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())


def trajectory_model_values(model: TrainedGMD, unguided: Any, test: MotionWindows,
                            train: MotionWindows, seed: int) -> dict[str, float]:
    """A trajectory model's ``gmd_trajectory`` gate values: the path length of its unguided
    samples and its held-out x̂0 error over the Gaussian denoiser's."""
    return {**model_gates.trajectory_gate_values(model, unguided),
            **model_gates.denoising_gate_values(model, test, train, seed=seed)}


def a3_model_records(study: A3Study, guided_models: dict[tuple[str, int], TrainedGMD],
                     test: MotionWindows, train: MotionWindows) -> list[dict[str, Any]]:
    """The guidance trajectory models' gate records; GMD-A3's parts all rest on them (reads:
    every part). The unguided samples are the study's own (same noise)."""
    reference = trajectory_reference(test)
    return [model_gates.gmd_model_record(
        guided_models[(p, s)], family="gmd_trajectory", reference=reference,
        role=TRAJECTORY_ROLES[p], arm=PREDICTIONS[p],
        values=trajectory_model_values(guided_models[(p, s)], study.runs[(p, s)].unguided,
                                       test, train, s))
        for p in PREDICTIONS for s in study.seeds]


def _a3_jitter(study: A3Study, guided_models: dict[tuple[str, int], TrainedGMD],
               ) -> dict[str, dict[str, list[float]]]:
    return {p: {kind: [float(jitter_of(guided_models[(p, s)],
                                       getattr(study.runs[(p, s)], kind)).jerk)
                       for s in study.seeds] for kind in ("guided", "unguided")}
            for p in PREDICTIONS}


def a3_reading(model: TrainedGMD, test: MotionWindows, settings: Settings,
               pairing_seed: int) -> dict[str, Any]:
    """One trajectory model's GMD-A3 readings on seed ``pairing_seed``'s pairing (its goals and
    noise, as :func:`goal_reaching_study` draws them): the guided goal error per goal (m) and
    the batch's best-gain survival (None where no guided gain)."""
    targets = goal_targets(test, settings.goals, seed=pairing_seed,
                           min_distance=settings.min_goal_distance)
    return _a3_run_reading(goal_reaching_experiment(model, targets, seed=pairing_seed))


def _a3_run_reading(run: GoalReachingResult) -> dict[str, Any]:
    return {"goal_error": np.asarray(run.error_guided, dtype=np.float64),
            "best_gain_survival": float(run.survival) if np.isfinite(run.survival) else None}


#: GMD-A3's A/A slots: the x0 (treatment) arm's measurements filled by the ε (reference) copy
A3_SLOTS = (Slot("goal_error_x0", "goal_error_eps", "goal_error",
                 part="eps_reaches_goal_better", sign=1),
            Slot("best_gain_survival_x0", "best_gain_survival_eps", "best_gain_survival",
                 part="eps_keeps_more_of_best_gain", sign=-1, scale="difference"))


def a3_aa_readings(study: A3Study, guided_models: Mapping[tuple[str, int], TrainedGMD],
                   test: MotionWindows, settings: Settings) -> AAReadings:
    """GMD-A3's A/A runs (``controls.aa_readings``): the ε trajectory model (the reference arm)
    of seed s and its copy of the next seed toward seed s's goals with seed s's noise; the own
    model's run is the study's where it has one."""
    reference = {s: m for (p, s), m in guided_models.items() if p == "epsilon"}

    def reading(model_seed: int, pairing_seed: int) -> dict[str, Any]:
        if model_seed == pairing_seed and ("epsilon", model_seed) in study.runs:
            return _a3_run_reading(study.runs[("epsilon", model_seed)])
        return a3_reading(reference_model(reference, model_seed), test, settings, pairing_seed)

    return aa_readings(reading, study.seeds)


def a3_result(study: A3Study, guided_models: dict[tuple[str, int], TrainedGMD],
              test: MotionWindows, settings: Settings, *, figure: FigurePath,
              models: Sequence[Mapping[str, Any]]) -> ClaimResult:
    """GMD-A3: goal error and best-gain survival of the x0 and the ε trajectory model under
    GMD's goal guidance, with its A/A controls (:func:`a3_aa_readings`: the ε model against an
    independently trained copy toward the same goals; the positive with 2δ planted)."""
    seeds, a3p = study.seeds, study.parameters
    goal_error, survival, stop_survival = study.goal_error, study.survival, study.stop_survival
    jitter = _a3_jitter(study, guided_models)
    started = time.perf_counter()
    controls = aa_controls("GMD-A3", a3_aa_readings(study, guided_models, test, settings),
                           A3_SLOTS, reference_arm="ε trajectory")
    control_seconds = time.perf_counter() - started
    spec = guided_models[("x0", seeds[0])].spec
    return ClaimResult(
        "GMD-A3",
        {"goal_error_x0": goal_error["x0"], "goal_error_eps": goal_error["epsilon"],
         "best_gain_survival_x0": finite(survival["x0"]),
         "best_gain_survival_eps": finite(survival["epsilon"]),
         "guided_change_survival_x0": finite(stop_survival["x0"]),
         "guided_change_survival_eps": finite(stop_survival["epsilon"])},
        seeds=seeds, settings=rule_settings.a3(settings), figures=[figure], controls=controls,
        models=list(models),
        headline=(f"goal error x0 {np.mean(goal_error['x0']):.2f} m vs ε "
                  f"{np.mean(goal_error['epsilon']):.2f} m (unguided "
                  f"{np.mean(study.seed_means('x0', 'error_unguided')):.2f} / "
                  f"{np.mean(study.seed_means('epsilon', 'error_unguided')):.2f}); best-gain "
                  f"survival x0 {np.nanmean(survival['x0']):.2f} vs ε "
                  f"{np.nanmean(survival['epsilon']):.2f}; T = {a3p['num_timesteps']}, stop "
                  f"t = {a3p['guidance_stop_t']}, ε clamp ±{a3p['x0_clamp']:g}"),
        notes=(f"Ours: tiny UNet1D trajectory models (4 channels, {describe(spec)}), "
               f"T = {a3p['num_timesteps']} cosine (GMD's), ancestral DDPM over every step (GMD "
               "respaces only with use_ddim), GMD's guidance (s = 100, ½·L1 on the last-frame "
               "root x/z of the un-normalised x̂0, μ̃ = μ − s·Σ_t·∇G) while t ≥ "
               f"{a3p['guidance_stop_t']}; ε model's x̂0 clamped to ±{a3p['x0_clamp']:g} (GMD's "
               f"clip_range), x0 model unclamped (as GMD); goals = last-frame root x/z of "
               f"{settings.goals} random test windows travelling ≥ 0.5 m, drawn per seed; same "
               "x_T and per-step noise for guided/unguided and for x0/ε; best-gain survival = "
               "(ē_unguided − ē_guided) / (ē_unguided − min_t ē_guided x̂0(t)), batch means "
               "(registry v3)."),
        extra={"parameters": a3p,
               **{f"goal_error_unguided_{tag}": study.seed_means(p, "error_unguided")
                  for p, tag in PREDICTIONS.items()},
               **{f"goal_error_x0hat_at_stop_{tag}": study.seed_means(p, "error_at_stop")
                  for p, tag in PREDICTIONS.items()},
               **{f"{name}_{tag}": study.per_seed(p, attribute)
                  for name, attribute in (("best_step_goal_error", "best_step_error"),
                                          ("best_step", "best_step"),
                                          ("best_gain_m", "best_gain"),
                                          ("final_gain_m", "final_gain"))
                  for p, tag in PREDICTIONS.items()},
               **{f"root_jerk_{kind}_{tag}": jitter[p][kind]
                  for kind in ("guided", "unguided") for p, tag in PREDICTIONS.items()},
               "strength": 100.0, "goals_per_seed": settings.goals,
               "controls_seconds": round(control_seconds, 1),
               "controls_planted": controls.planted})


# ----------------------------------------------------------------------------------- GMD-A4

def longer_eps_models(settings: Settings, motion_eps: GMDModelSpec, seeds: Sequence[int],
                      windows: MotionWindows, *, device: str) -> dict[int, TrainedGMD]:
    """GMD-A4's longer ε run (outside the rule; ``models.longer_run``: the motion ε model at
    2× the shared cap), one per seed, where ``settings.longer_eps_run``; else none."""
    if not settings.longer_eps_run:
        return {}
    spec = longer_run(motion_eps)
    return dict(zip(seeds, load_or_train_many([spec.replace(seed=s) for s in seeds], windows,
                                              device=device), strict=True))


def longer_eps_description(settings: Settings, motion_eps: GMDModelSpec) -> str:
    """The longer ε run's spec in words, or why it is not run at this scale."""
    if settings.longer_eps_run:
        return describe(longer_run(motion_eps))
    return f"not run at the {settings.scale} scale (paper scale only)"


def parameter_counts(models: Mapping[tuple[str, str, int], TrainedGMD],
                     seeds: Sequence[int]) -> dict[str, int]:
    """Trainable parameters of the first seed's x0 model of each task."""
    return {task: parameter_count(models[(task, "x0", seeds[0])])
            for task in ("trajectory", "motion")}


@dataclass(frozen=True)
class A4Records:
    """The gate records behind GMD-A4 (gates version 3; which parts read which:
    ``x0_vs_eps.A4_READS``): the motion models (``gmd_motion``, keyed (prediction, seed)), A4's
    own trajectory models (``gmd_trajectory``), the evaluator, and the longer ε run's motion
    models (keyed by seed; outside the rule, empty below the paper scale)."""

    motion: dict[tuple[str, int], dict[str, Any]]
    trajectory: dict[tuple[str, int], dict[str, Any]]
    evaluator: dict[str, Any]
    long_eps: dict[int, dict[str, Any]]

    @property
    def models(self) -> list[dict[str, Any]]:
        """What GMD-A4's ``record(models=...)`` takes: every record but the longer run's."""
        return [*self.motion.values(), *self.trajectory.values(), self.evaluator]


def a4_model_records(models: Mapping[tuple[str, str, int], TrainedGMD],
                     long_eps: Mapping[int, TrainedGMD], seeds: Sequence[int], *,
                     motion: tuple[MotionWindows, MotionWindows],
                     trajectory: tuple[MotionWindows, MotionWindows],
                     evaluation: model_gates.MotionEvaluation, settings: Settings,
                     seed: int) -> A4Records:
    """Measure GMD-A4's gates: each motion model's held-out x̂0 error, each trajectory model's
    (and the path length of ``settings.goals`` unguided samples), the evaluator's R@3 and
    trivial-fake FIDs; ``motion`` and ``trajectory`` are each task's (train, test) windows."""
    motion_train, motion_test = motion
    train, test = trajectory
    samples = model_gates.sample_gate_data(motion_test, seed=seed)

    def motion_values(p: str, s: int) -> dict[str, float]:
        model = models[("motion", p, s)]
        values = model_gates.denoising_gate_values(model, motion_test, motion_train, seed=s)
        if MOTION_ROLES[p] == "reference":
            values.update(model_gates.motion_sample_values(model, samples, seed=s))
        return values

    motion_records = {
        (p, s): model_gates.gmd_model_record(
            models[("motion", p, s)], family="gmd_motion", reads=A4_READS[("motion", p)],
            role=MOTION_ROLES[p], arm=PREDICTIONS[p], reference=samples.values,
            values=motion_values(p, s))
        for p in PREDICTIONS for s in seeds if ("motion", p, s) in models}
    reference = trajectory_reference(test)
    trajectory_records = {
        (p, s): model_gates.gmd_model_record(
            models[("trajectory", p, s)], family="gmd_trajectory",
            reads=A4_READS[("trajectory", p)], reference=reference, role=TRAJECTORY_ROLES[p],
            arm=PREDICTIONS[p],
            values=trajectory_model_values(models[("trajectory", p, s)], sample(
                models[("trajectory", p, s)], settings.goals, seed=s), test, train, s))
        for p in PREDICTIONS for s in seeds}
    evaluator_record = model_gates.evaluator_model_record(
        evaluation.evaluator, reads=["eps_motion_worse_fid"],
        values=model_gates.evaluator_gate_values(
            evaluation.evaluator, evaluation.test_features, evaluation.test_lengths,
            motion_test.captions, seed=seed, train_features=evaluation.train_features,
            samples=settings.generated, real_fid=evaluation.reference_fid))
    long_eps_records = {
        s: model_gates.gmd_model_record(
            long_eps[s], family="gmd_motion", label="2× cap", role="treatment", arm="eps",
            values=model_gates.denoising_gate_values(long_eps[s], motion_test, motion_train,
                                                     seed=s))
        for s in long_eps}
    return A4Records(motion_records, trajectory_records, evaluator_record, long_eps_records)


def _longer_eps_extra(long_eps: Mapping[int, TrainedGMD], records: A4Records,
                      scale: str) -> dict[str, Any] | str:
    if not long_eps:
        return f"not run at the {scale} scale (paper scale only)"
    return {"training": [model_gates.training_summary(long_eps[s]) for s in long_eps],
            "gate_values": {m: [records.long_eps[s]["gate"][m]["value"] for s in long_eps]
                            for m in ("x0_error_vs_gaussian",)},
            "passed": [bool(records.long_eps[s]["passed"]) for s in long_eps]}


#: GMD-A4's A/A slots: the ε (treatment) motion arm filled by the x0 (reference) motion copy,
#: the x0 (treatment) trajectory arm by the ε (reference) trajectory copy; the third part's
#: plant is the motion jitter's (its trajectory ratio stays the A/A's)
A4_SLOTS = (Slot("motion_jitter_eps", "motion_jitter_x0", "motion_jitter",
                 part="eps_motion_more_jagged", sign=1),
            Slot("motion_fid_eps", "motion_fid_x0", "motion_fid",
                 part="eps_motion_worse_fid", sign=1),
            Slot("trajectory_jitter_x0", "trajectory_jitter_eps", "trajectory_jitter"))


def a4_reading(motion: TrainedGMD, trajectory: TrainedGMD, pairing_seed: int, *, n: int,
               evaluator: Evaluator, test_embeddings: np.ndarray) -> dict[str, float]:
    """The reference arms' GMD-A4 readings of one seed's x0 motion and ε trajectory models on
    seed ``pairing_seed``'s noise (:func:`sample_quality`'s draws): joint jerk and FID of
    ``n`` unguided motion samples, root jerk of ``n`` trajectories."""
    x = sample(motion, n, seed=pairing_seed)
    trajectories = sample(trajectory, n, seed=pairing_seed)
    return {"motion_jitter": float(jitter_of(motion, x).jerk),
            "motion_fid": motion_fid(motion, x, evaluator, test_embeddings),
            "trajectory_jitter": float(jitter_of(trajectory, trajectories).jerk)}


def a4_aa_readings(quality: SampleQuality, models: Mapping[tuple[str, str, int], TrainedGMD],
                   seeds: Sequence[int], *, n: int, evaluator: Evaluator,
                   test_embeddings: np.ndarray) -> AAReadings:
    """GMD-A4's A/A runs (``controls.aa_readings``): the reference arms — the x0 motion model
    and the ε trajectory model — of seed s and their copies of the next seed, sampled from seed
    s's noise; the own models' readings are the experiment's."""
    motion = {s: m for (task, p, s), m in models.items() if (task, p) == ("motion", "x0")}
    trajectory = {s: m for (task, p, s), m in models.items()
                  if (task, p) == ("trajectory", "epsilon")}
    index = {s: k for k, s in enumerate(seeds)}
    values = quality.values

    def reading(model_seed: int, pairing_seed: int) -> dict[str, float]:
        if model_seed == pairing_seed and model_seed in index:
            k = index[model_seed]
            return {"motion_jitter": values["motion_jitter_x0"][k],
                    "motion_fid": values["motion_fid_x0"][k],
                    "trajectory_jitter": values["trajectory_jitter_eps"][k]}
        return a4_reading(reference_model(motion, model_seed),
                          reference_model(trajectory, model_seed), pairing_seed, n=n,
                          evaluator=evaluator, test_embeddings=test_embeddings)

    return aa_readings(reading, seeds)


def a4_result(quality: SampleQuality, models: Mapping[tuple[str, str, int], TrainedGMD],
              long_eps: Mapping[int, TrainedGMD], records: A4Records, seeds: Sequence[int],
              settings: Settings, *, references: Mapping[str, float],
              evaluation: model_gates.MotionEvaluation, motion_train: MotionWindows,
              train: MotionWindows, figures: Sequence[FigurePath]) -> ClaimResult:
    """GMD-A4: joint jerk and FID of the x0 and the ε motion model's samples and root jerk of
    the trajectory models' (appendix A.1), with its A/A controls (:func:`a4_aa_readings`: each
    task's reference arm against an independently trained copy, the same noise; the positive
    with 2δ planted on the motion arm). ``references``: the
    data's ``motion_jitter``, ``motion_fid`` (train vs test) and ``trajectory_jitter``."""
    a4 = quality.values
    ratio = {k: float(np.mean(a4[f"{k}_eps"]) / np.mean(a4[f"{k}_x0"]))
             for k in ("motion_jitter", "motion_fid", "trajectory_jitter", "motion_root_jitter")
             if f"{k}_eps" in a4}
    # A/A controls on the reference arms: none where the scale runs no part of A4
    runs = set(A4_PARTS) - set(settings.a4_not_run)
    controls = aa_controls(
        "GMD-A4", a4_aa_readings(quality, models, seeds, n=settings.generated,
                                 evaluator=evaluation.evaluator,
                                 test_embeddings=evaluation.test_embeddings),
        A4_SLOTS, reference_arm="x0 motion and ε trajectory") if runs else None
    real_fid = references["motion_fid"]
    first = seeds[0]
    return ClaimResult(
        "GMD-A4",
        {k: a4[k] for k in ("motion_jitter_eps", "motion_jitter_x0", "motion_fid_eps",
                            "motion_fid_x0", "trajectory_jitter_eps", "trajectory_jitter_x0")
         if k in a4},
        seeds=seeds, settings=rule_settings.a4(settings), figures=list(figures),
        controls=controls, models=records.models, not_run=settings.a4_not_run,
        headline=_a4_headline(a4, ratio, references, settings.scale,
                              width=models[("motion", "x0", first)].spec.base_channels),
        notes=(_a4_width_note(models[("motion", "x0", first)].spec, settings.scale)
               + f"Ours: motion {describe(models[('motion', 'x0', first)].spec)}; trajectories "
               f"{describe(models[('trajectory', 'x0', first)].spec)}; x0 and ε of a task "
               "share the architecture and the budget; EMA; "
               f"{settings.generated} unguided samples per model and seed (same "
               "noise for x0 and ε); ε model's x̂0 clamped to ±max|x| of its training windows, "
               "x0 unclamped (as GMD); jitter = mean jerk of the 22 recovered joints (motion) "
               "or of the root (trajectory), m/s³; FID with the package's contrastive "
               "evaluator trained on the training windows, generated windows vs all test "
               "windows (relative representation); trajectory models: the T = 100 ones of "
               "this claim (GMD-A3 uses T = 1000 models)."),
        extra={"ratios_eps_over_x0": ratio,
               "data_joint_jerk": float(references["motion_jitter"]),
               "data_root_jerk": float(references["trajectory_jitter"]),
               "real_fid_train_vs_test": float(real_fid),
               **{k: a4[k] for k in ("motion_root_jitter_x0", "motion_root_jitter_eps",
                                     "motion_acceleration_x0", "motion_acceleration_eps",
                                     "motion_foot_skating_x0", "motion_foot_skating_eps")
                  if k in a4},
               "parameters": {"num_timesteps": settings.diffusion_steps,
                              "guidance_stop_t": None,
                              "x0_clamp": (models[("motion", "epsilon", first)].x0_bound
                                           if ("motion", "epsilon", first) in models
                                           else None)},
               "parameter_counts": parameter_counts(models, seeds),
               "generated_per_seed": settings.generated,
               "motion_budget": {
                   p: [model_gates.training_summary(models[("motion", p, s)]) for s in seeds]
                   for p in settings.motion_predictions},
               "longer_eps_run": _longer_eps_extra(long_eps, records, settings.scale),
               "controls_planted": controls.planted if controls is not None else {}})


def _a4_width_note(spec: GMDModelSpec, scale: str) -> str:
    """Where GMD-A4's motion arms are compared: at the standard scale, at the standard design's
    width (both arms the same UNet and steps), not GMD's widths (the paper scale's)."""
    if scale != "standard":
        return ""
    return (f"The x0 and ε motion arms are compared at width {spec.base_channels} (the "
            f"standard design: the same UNet, {spec.training.steps} steps, the same seeds and "
            "windows for both arms); GMD's widths are the paper scale's. ")


def _a4_headline(a4: Mapping[str, list[float]], ratio: Mapping[str, float],
                 references: Mapping[str, float], scale: str, *,
                 width: int | None = None) -> str:
    """GMD-A4's key numbers: the ε/x0 ratios (at the standard scale, at the motion arms'
    ``width``), or, where a run has no ε motion arm, the x0 arm's samples against the
    data's."""
    real_fid = references["motion_fid"]
    if "motion_jitter_eps" not in a4:
        return (f"ε motion arm not run at the {scale} scale; x0 motion samples: joint jerk "
                f"{np.mean(a4['motion_jitter_x0']):.0f} m/s³ (data "
                f"{references['motion_jitter']:.0f}), FID {np.mean(a4['motion_fid_x0']):.2f} "
                f"(real {real_fid:.2f}); trajectory jerk ε/x0 = "
                f"{ratio['trajectory_jitter']:.2f}")
    at = f" at width {width}" if scale == "standard" and width is not None else ""
    return (f"motion jerk ε/x0{at} = {ratio['motion_jitter']:.2f}, FID ε "
            f"{np.mean(a4['motion_fid_eps']):.2f} vs x0 {np.mean(a4['motion_fid_x0']):.2f} "
            f"(real {real_fid:.2f}); trajectory jerk ε/x0 = {ratio['trajectory_jitter']:.2f}")


def a4_budget_markdown(models: Mapping[tuple[str, str, int], TrainedGMD],
                       long_eps: Mapping[int, TrainedGMD], records: A4Records,
                       seeds: Sequence[int], settings: Settings) -> str:
    """GMD-A4's training budget (``model_gates.budget_markdown``): the x0 and ε
    motion models per seed and, at the paper scale, the ε run at 2× the cap; below it, a line
    saying that run is not trained."""
    arms = {label: p for label, p in (("x0", "x0"), ("ε", "epsilon"))
            if p in settings.motion_predictions}
    budget_models = {label: [models[("motion", p, s)] for s in seeds] for label, p in arms.items()}
    budget_records = {label: [records.motion[(p, s)] for s in seeds] for label, p in arms.items()}
    note = ""
    if long_eps:
        budget_models["ε, 2× cap"] = [long_eps[s] for s in seeds]
        budget_records["ε, 2× cap"] = [records.long_eps[s] for s in seeds]
    else:
        note = (f"*The longer ε run is not trained at the {settings.scale} scale "
                f"(`settings.longer_eps_run` is {settings.longer_eps_run}): paper scale only.*"
                "\n\n")
    if "epsilon" not in settings.motion_predictions:
        note += (f"*Nor is the ε motion arm: {settings.a4_not_run[A4_PARTS[0]]}.*\n\n")
    return note + model_gates.budget_markdown(budget_models, budget_records)
