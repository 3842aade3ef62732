"""GMD-A3 (appendix A; main-paper Fig. 3): an x0 model can undo guidance late in sampling while
an ε model keeps it.

Under GMD's goal guidance, a guided and an unguided run from the same seed give the goal error
of the final sample and of x̂0 at every step, and the share of the best guided gain that is
kept at the end (``goal_reaching.best_gain_survival``, the registered measurement).

- the study: both guidance trajectory models' goal-reaching runs (:func:`a3_study`, through
  ``x0_vs_eps.goal_reaching``) and the x̂0-clamp sensitivity check beside it
  (:func:`clamp_sensitivity`, outside the rule);
- the exact checks of the measurement code (:func:`a3_controls`: exact and planted models);
- the gate records of the trajectory models, the A/A runs (:func:`a3_aa_readings`: the ε
  model against an independently trained copy), the reading paragraphs and the result
  (:func:`a3_result`).

Its registered rule and measurements: the ``GMD-A3`` entry of ``repro.claims.registry_gmd``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from repro.claims.result import ClaimResult, Controls
from repro.core.diffusion import GaussianDiffusion
from repro.core.tables import render
from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    AAReadings,
    Slot,
    aa_controls,
    aa_readings,
    control_seed,
    reference_model,
)
from repro.gmd.figures import either
from repro.gmd.guidance import (
    Clamp,
    default_stop_step,
    goal_error,
    goal_guidance,
    guidance_parameters,
    sample,
)
from repro.gmd.measurements import jitter_of
from repro.gmd.models import X0_CLAMP, TrainedGMD, describe
from repro.gmd.windows import MotionWindows, goal_targets
from repro.gmd.x0_vs_eps.common import (
    PREDICTIONS,
    TRAJECTORY_ROLES,
    FigurePath,
    Settings,
    trajectory_model_values,
    trajectory_reference,
)
from repro.gmd.x0_vs_eps.goal_reaching import (
    GoalReachingResult,
    goal_reaching_experiment,
    goal_reaching_study,
)

# --- GMD-A3's study: both guidance models' goal-reaching runs, the clamp check beside it ----------

@dataclass(frozen=True)
class A3Study:
    """GMD-A3's goal-reaching runs (:func:`goal_reaching_study`, keyed (prediction,
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
    goals per seed (:func:`goal_reaching_study`, GMD's guidance, clamp and stop)."""
    runs = goal_reaching_study(guided_models, test, seeds, goals=settings.goals,
                               min_distance=settings.min_goal_distance)
    first = seeds[0]
    parameters = guidance_parameters(guided_models[("epsilon", first)],
                                     stop=runs[("epsilon", first)].stop_guidance_at)
    return A3Study(runs, list(seeds), parameters)


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


# ------------------------------------------------------------------------------------------------
# GMD-A3's exact checks of the measurement code (notebook 01 records the A/A controls,
# :func:`a3_aa_readings`), beside ``repro.gmd.controls``: exact models whose truth is known, run
# through the experiment's own ``goal_reaching.goal_reaching_experiment`` (same T, stop step,
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


# --- GMD-A3's reading paragraphs ----------------------------------------------------------------

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


#: the labels of ``CLAMPS`` (registered first)
CLAMP_LABELS = ("GMD's ±6 (registered)", "±max|x| of the training windows", "no clamp")


def reading_clamp(errors: dict[str, list[float]], *, bound: float, unguided_eps: float,
                  guided_x0: float, seeds: Sequence[int]) -> str:
    """The x̂0-clamp sensitivity check of GMD-A3. ``errors``: :func:`clamp_sensitivity`
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


# --- GMD-A3's result: gate records, A/A runs, the ClaimResult -------------------------------------

def finite(values: Sequence[float]) -> list[float | None]:
    """JSON has no NaN: an undefined share (no guided gain) is stored as null."""
    return [v if np.isfinite(v) else None for v in values]


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
