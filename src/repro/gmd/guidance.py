"""Tiny GMD's sampling: guided sampling, goal functions and classifier-free guidance.

GMD's goal functions G act on the un-normalised x̂0 — L1 (p = 1), averaged over the target
entries as GMD does — and enter sampling through ``diffusion.Guidance``
(μ̃ = μ − s·Σ_t·∇_{x_t} G(x̂0)); guidance (and imputation) stop at t = 20 of T = 1000
(``models.GUIDANCE_STOP_T``). A model with another T (quick mode, the T = 100 motion
models) stops at the same fraction of its T (``default_stop_step``).

Sampling is ancestral DDPM over every step, as GMD's: its ``create_gaussian_diffusion``
respaces only with ``use_ddim`` (default False), so nothing is respaced here either. GMD
clamps an ε model's x̂0 to ±``clip_range`` = 6 (default of its ``DiffusionOptions``;
``models.X0_CLAMP``): ``clip_x0="gmd"``.

Classifier-free guidance (Ho & Salimans 2022), as GMD samples its motion model, is at the end
(``sample_classifier_free``, scale ``GMD_CFG_SCALE``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor, nn

from repro.core.diffusion import Guidance, Imputation, SampleTrajectory
from repro.gmd.models import GUIDANCE_DIFFUSION_STEPS, GUIDANCE_STOP_T, X0_CLAMP, TrainedGMD
from repro.gmd.windows import FeatureSpace

__all__ = ["Clamp", "ClassifierFreeModel", "GMD_CFG_SCALE", "GMD_GUIDANCE_STRENGTH",
           "GMD_STOP_FRACTION", "classifier_free", "default_stop_step", "goal_error",
           "goal_guidance", "goal_reaching_loss", "guidance_parameters", "obstacle_loss",
           "resolve_clamp", "sample", "sample_classifier_free", "waypoint_loss"]

#: GMD stops guidance at t = 20 of T = 1000 (appendix F): 2 % of the steps.
GMD_STOP_FRACTION = GUIDANCE_STOP_T / GUIDANCE_DIFFUSION_STEPS


#: GMD's guidance strength s (appendix F; REFERENCE.md "Guidance").
GMD_GUIDANCE_STRENGTH = 100.0


#: an x̂0 clamp: a bound, None (never), "auto" (an ε model at ±its x0_bound) or "gmd" (an ε
#: model at GMD's ±6, an x0 model never)
Clamp = float | None | Literal["auto", "gmd"]


def default_stop_step(num_timesteps: int) -> int:
    """GMD's stop step: t = ``GUIDANCE_STOP_T`` = 20 at T = 1000 (guidance acts while t ≥ 20);
    at another T the same fraction of the steps, round(0.02·T) (e.g. 1 at the quick T = 50)."""
    if num_timesteps == GUIDANCE_DIFFUSION_STEPS:
        return GUIDANCE_STOP_T
    return int(round(GMD_STOP_FRACTION * num_timesteps))


def resolve_clamp(trained: TrainedGMD, clip_x0: Clamp) -> float | None:
    """The x̂0 bound ``sample`` uses: "gmd" → ±``X0_CLAMP`` for an ε model (GMD's
    ``process_xstart`` clamps an ε model's x̂0 to ±clip_range = 6), none for an x0 model;
    "auto" → ±``trained.x0_bound`` for an ε model; a number or None as given."""
    if clip_x0 == "gmd":
        return X0_CLAMP if trained.spec.prediction == "epsilon" else None
    if clip_x0 == "auto":
        return trained.x0_bound if trained.spec.prediction == "epsilon" else None
    return None if clip_x0 is None else float(clip_x0)


def guidance_parameters(trained: TrainedGMD, *, stop: int | None = None,
                        clip_x0: Clamp = "gmd") -> dict[str, float | int | None]:
    """The settings a guided run used, for a sidecar's ``extra["parameters"]``:
    ``num_timesteps`` (T), ``guidance_stop_t`` (guidance while t ≥ it) and ``x0_clamp``
    (the bound on an ε model's x̂0, None for none)."""
    return {"num_timesteps": int(trained.num_timesteps),
            "guidance_stop_t": default_stop_step(trained.num_timesteps) if stop is None
            else int(stop),
            "x0_clamp": resolve_clamp(trained, clip_x0)}


def sample(trained: TrainedGMD, n: int, *, seed: int, guidance: Guidance | None = None,
           imputation: Imputation | None = None, stop_guidance_at: int | None = None,
           return_trajectory: bool = False, trajectory_timesteps: Sequence[int] | None = None,
           text: str | Sequence[str] | None = None, noise: Tensor | None = None,
           clip_x0: Clamp = "auto",
           ) -> Tensor | tuple[Tensor, SampleTrajectory]:
    """n samples (n, C, frames) in model space by ancestral sampling (``p_sample_loop``).

    The same ``seed`` gives the same x_T and the same per-step noise whatever the guidance
    (guidance draws nothing), so guided and unguided runs with one seed are paired.
    ``stop_guidance_at`` defaults to GMD's 2 % of T (``default_stop_step``). ``text``: one
    caption or n (text-conditioned models only).

    ``clip_x0`` (``resolve_clamp``): "gmd" clamps an ε model's x̂0 to GMD's ±6, "auto" to
    ±``trained.x0_bound`` (the largest |value| of its training windows); an x0 model is not
    clamped by either, as in GMD. Without a clamp an ε model diverges at the first step of
    the cosine schedule, where x̂0 = (x_T − √(1−ᾱ) ε̂)/√ᾱ multiplies the error of ε̂ by
    1/√ᾱ_{T−1} (≈ 2000 at T = 100). A number clamps any model, None never.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    shape = (n, trained.space.channels, trained.spec.data.frames)
    kwargs: dict[str, Any] = {}
    if text is not None:
        kwargs["cond"] = trained.text_condition(text, n)
    elif trained.vocabulary is not None:
        kwargs["force_unconditional"] = True
    stop = default_stop_step(trained.num_timesteps) if stop_guidance_at is None else int(
        stop_guidance_at)
    return trained.diffusion.p_sample_loop(
        trained.model, shape, model_kwargs=kwargs, seed=seed, guidance=guidance,
        imputation=imputation, stop_guidance_at=stop, clip_x0=resolve_clamp(trained, clip_x0),
        device=trained.device,
        noise=noise, return_trajectory=return_trajectory,
        trajectory_timesteps=trajectory_timesteps)


def _targets(target_xz: Tensor | np.ndarray | Sequence[float], like: Tensor) -> Tensor:
    target = torch.as_tensor(np.asarray(target_xz, dtype=np.float32), device=like.device,
                             dtype=like.dtype)
    if target.shape[-1] != 2 or target.dim() > 2:
        raise ValueError(f"targets must be (2,) or (B, 2) world x/z, got {tuple(target.shape)}")
    return target if target.dim() == 2 else target[None]


def goal_reaching_loss(space: FeatureSpace, target_xz: Tensor | np.ndarray | Sequence[float],
                       frame: int = -1) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = ½‖p_xz(frame) − target‖₁ (m) per sample: GMD's goal reaching, L1 (p = 1) on the
    un-normalised root of x̂0 (model space (B, C, T)), averaged over the target's two
    coordinates as GMD normalises by the number of target entries. ``target_xz`` (2,) or
    (B, 2)."""

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)[:, frame]
        return (position - _targets(target_xz, position)).abs().mean(dim=-1)

    return goal


def waypoint_loss(space: FeatureSpace, target_xz: Tensor | np.ndarray | Sequence[float],
                  frame: int) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = ½‖p_xz(frame) − target‖₁: reach a location at frame ``frame`` (GMD's keyframe
    locations)."""
    return goal_reaching_loss(space, target_xz, frame)


def obstacle_loss(space: FeatureSpace, centres_xz: np.ndarray | Sequence[Sequence[float]],
                  radii: np.ndarray | Sequence[float]) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = Σ_t Σ_k max(0, r_k − ‖p_xz(t) − c_k‖): penetration depth of the root path into
    circular obstacles (our cost; GMD's obstacle avoidance uses a comparable hinge)."""
    centres = np.asarray(centres_xz, dtype=np.float32).reshape(-1, 2)
    radius = np.asarray(radii, dtype=np.float32).reshape(-1)
    if len(radius) != len(centres):
        raise ValueError(f"{len(centres)} centres but {len(radius)} radii")

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)                                # (B, T, 2)
        c = torch.as_tensor(centres, dtype=position.dtype, device=position.device)
        r = torch.as_tensor(radius, dtype=position.dtype, device=position.device)
        distance = (position[:, :, None, :] - c).norm(dim=-1)            # (B, T, K)
        return torch.relu(r - distance).sum(dim=(1, 2))

    return goal


def goal_guidance(trained: TrainedGMD, target_xz: Tensor | np.ndarray | Sequence[float], *,
                  frame: int = -1, strength: float = GMD_GUIDANCE_STRENGTH) -> Guidance:
    """Classifier guidance toward ``target_xz`` at ``frame`` (default the last): μ̃ = μ −
    s·Σ_t·∇_{x_t}½‖p_xz(x̂0) − target‖₁ (GMD, s = 100)."""
    return Guidance(goal_reaching_loss(trained.space, target_xz, frame), strength=strength)


def goal_error(trained: TrainedGMD | FeatureSpace, x: Tensor,
               target_xz: Tensor | np.ndarray | Sequence[float], frame: int = -1) -> np.ndarray:
    """Euclidean distance (m) between the root x/z at ``frame`` and the target, per sample."""
    space = trained.space if isinstance(trained, TrainedGMD) else trained
    with torch.no_grad():
        position = space.root_xz(x.detach())[:, frame]
        return (position - _targets(target_xz, position)).norm(dim=-1).cpu().numpy()



# ------------------------------------------------------------------------------------------------
# Classifier-free guidance at sampling (Ho & Salimans 2022), as GMD samples its motion model.
#
# GMD wraps a model trained with condition dropout (``cond_mask_prob`` > 0; here
# ``GMDModelSpec.cond_dropout``) and returns, at every step,
#
#     out = out_uncond + s · (out_cond − out_uncond),
#
# with s = ``guidance_param`` = 2.5 by default in its sampling and evaluation options (GMD
# ``model/cfg_sampler.py``, ``utils/parser_util.py``). s = 1 is plain conditional sampling,
# s = 0 unconditional. Computed here as (1 − s)·out_uncond + s·out_cond — the same value, and
# exactly the conditional (unconditional) output at s = 1 (s = 0), as 0·a = 0 and 1·b = b.
# ------------------------------------------------------------------------------------------------

#: GMD's classifier-free guidance scale s (``guidance_param`` default 2.5).
GMD_CFG_SCALE = 2.5


class ClassifierFreeModel(nn.Module):
    """``model``'s output mixed with its unconditional output: (1 − s)·ε(x, t, ∅) + s·ε(x, t, c).

    Without a condition (or with ``force_unconditional``) it is the unconditional output.
    The two passes are separate calls of the same batch size as plain sampling's, so s = 1
    and s = 0 reproduce conditional and unconditional sampling bit for bit.
    """

    def __init__(self, model: nn.Module, scale: float) -> None:
        super().__init__()
        self.model = model
        self.scale = float(scale)

    def forward(self, x: Tensor, t: Tensor, cond: Tensor | None = None,
                force_unconditional: bool = False) -> Tensor:
        unconditional = self.model(x, t, force_unconditional=True)
        if cond is None or force_unconditional:
            return unconditional
        conditional = self.model(x, t, cond=cond)
        return (1.0 - self.scale) * unconditional + self.scale * conditional


def classifier_free(trained: TrainedGMD, scale: float = GMD_CFG_SCALE) -> TrainedGMD:
    """The same trained model sampled with classifier-free guidance at ``scale``: a copy whose
    network is :class:`ClassifierFreeModel` (weights shared, nothing retrained)."""
    if trained.vocabulary is None:
        raise ValueError("classifier-free guidance needs a text-conditioned model")
    if not trained.spec.training.cond_dropout > 0:
        raise ValueError("classifier-free guidance needs a model trained with condition "
                         "dropout (cond_dropout > 0)")
    return dataclasses.replace(trained, model=ClassifierFreeModel(trained.model, scale).eval())


def sample_classifier_free(trained: TrainedGMD, n: int, *, seed: int,
                           text: str | Sequence[str], scale: float = GMD_CFG_SCALE,
                           **kwargs: object) -> Tensor:
    """``guidance.sample`` of :func:`classifier_free` (``trained``, ``scale``) with ``text``;
    the same seed gives the same x_T and per-step noise as plain sampling."""
    return sample(classifier_free(trained, scale), n, seed=seed, text=text,
                  **kwargs)  # type: ignore[arg-type]
