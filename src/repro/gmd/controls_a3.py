"""GMD-A3's controls (notebook 01), beside ``repro.gmd.controls``: exact models whose truth is
known, run through the experiment's own ``x0_vs_eps.goal_reaching_experiment`` (same T, stop
step, clamp, goals).

- **Null**: an exact x0/ε pair — one exact network (:class:`ExactGaussianDenoiser`) read as an
  x0 model and, through :class:`EpsilonOfX0`, as an ε model. With one seed both sample the
  same paths up to float rounding, so no part may fire.
- **Positive**: the x0 arm replaced by the same network made to undo a share of its guided
  change after guidance stops (:class:`LateRevertingDenoiser`): the paper's mechanism,
  "undoing … the guidance signal … at the end of the diffusion process", planted.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from repro.claims.result import Controls
from repro.core.diffusion import GaussianDiffusion
from repro.gmd.controls import control_seed
from repro.gmd.guidance import default_stop_step, sample
from repro.gmd.models import TrainedGMD
from repro.gmd.paper_settings import X0_CLAMP
from repro.gmd.windows import MotionWindows, goal_targets
from repro.gmd.x0_vs_eps import GoalReachingResult, goal_reaching_experiment

__all__ = ["EpsilonOfX0", "ExactGaussianDenoiser", "LateRevertingDenoiser", "a3_controls",
           "exact_model", "exact_pair", "late_reverting_model"]

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
