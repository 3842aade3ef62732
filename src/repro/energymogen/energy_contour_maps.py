"""Notebook 04: the energy view of EnergyMoGen's latent diffusion and the composition it
licenses, checked on the pipeline — the settings are ``EnergyViewSettings``.

- **EMG-1** (Sec. 3.2, Eq. 5–7: "diffusion models can be interpreted as EBMs under the
  gradient descent step η = 1") — a DDPM or DDIM step is a Langevin step on an energy
  (:func:`langevin_step_errors`); Eq. 7 is a sum of energies (line-integral energies,
  :func:`energy_linearity_error`); is ε_θ a gradient field at all (:func:`jacobian_asymmetry`,
  :func:`denoiser_jacobian_asymmetry`)? All three on the pipeline: :func:`energy_view_study`.
  Per t (:func:`gradient_field_study`, on the same draws): the **residual Jacobian
  asymmetry** ‖A − Aᵀ‖_F / ‖A‖_F with A = ∂ε_θ/∂z − I/√(1−ᾱ_t) (the identity term is
  symmetric, so it leaves A − Aᵀ = J − Jᵀ alone but does not dominate the denominator at
  large t; :func:`residual_asymmetry`) and the **relative loop integral** |∮ε_θ·dz| /
  ∮‖ε_θ‖‖dz‖ around a circle (Stokes: 0 for a gradient field, 1 for a field circulating along
  the loop; :func:`relative_circulation`). Our choices: the circle lies in the plane where the
  antisymmetric part of J at its centre circulates most (the top singular pair of J − Jᵀ: the
  worst case over planes, as a random plane of 160 dimensions sees almost none of it), radius
  √(1−ᾱ_t) (the noise's standard deviation at t), :data:`LOOP_POINTS` points (the trapezoid
  rule is spectrally accurate on a periodic integrand). The ratio grows with the radius (for a
  linear field it is r·σ/‖ε‖), so the radius is part of the measurement and is stated beside
  it. Both conditions (the joined text and ∅) are pooled: per t the median over samples ×
  conditions. Its controls at the same points (:func:`planted_fields`,
  :func:`gradient_field_controls`): the model's field made a gradient (its Jacobian's
  symmetric part, linearly about each point) must pass; the same with the model's own
  antisymmetric part at twice the tolerance in both readings must fail. The claim:
  :func:`emg1_result`.
- **EMG-2 / EMG-3** (Sec. 3.2 ❶ Eq. 7–8, ❷ Eq. 9: latent- and semantic-aware conjunction and
  negation), oracle-measured (:func:`composition_study`) and recorded by
  :func:`emg23_results`; the guidance-scale check beside them (paper scale only, not
  recorded): :func:`guidance_scale_check`; their controls: :func:`composition_controls`
  (A/A runs: the baselines sampled from an independently trained copy,
  :func:`composition_reference_rates`).
- **EMG-6** (Sec. 5.5 Q3, Fig. 5–6: composed and multi-concept maps "demonstrate consistent
  high- and low-energy regions") — denoising-loss energy maps on a 2-D slice of latent space
  (:func:`latent_plane`, :func:`energy_landscape`, :func:`smooth_energy_map`,
  :func:`map_similarity`; one conjunction or negation case: :func:`energy_map_case`, every
  case of a seed: :func:`energy_map_cases`, the per-seed numbers between floor and ceiling:
  :func:`map_similarities`); controls: :func:`energy_map_controls` (A/A runs: the floor read on
  an independently trained copy); the claim:
  :func:`emg6_result`.
- **EMG-9** (app. G.2, Eq. 12: the FID formula as printed) — FID against the Gaussian closed
  form on random commuting Gaussians (:func:`fid_formula_errors`) and on fixed cases whose
  Fréchet distance has a closed form (:func:`fid_fixed_cases`, no random draw, so no check can
  flip with a seed), evaluated with ``core.metrics.frechet_distance`` (ours) and with the
  printed Eq. 12 (``core.metrics.fid_as_printed_in_energymogen``): equal covariances with
  shifted means (FID = ‖d‖², the trace term Tr(2Σ − 2(Σ²)^½) vanishes); commuting diagonal
  covariances (FID = ‖Δμ‖² + Σk (√λ1k − √λ2k)², ``metrics.gaussian_fid_closed_form``); P = P
  (FID = 0; the printed form gives −2 Tr(Σ − Σ²) there, zero only for an idempotent Σ, so Σ
  is fixed with eigenvalues away from 0 and 1). Relative errors are |value − closed form| /
  |closed form|; at P = P (closed form 0) the error is |value| / Tr Σ, the registry's scale
  for ``printed_self_distance``. The claim: :func:`emg9_result`.

Each ``emg*_result`` takes what the experiment measured and returns the
:class:`~repro.claims.result.ClaimResult` the notebook records: the measurements the
registered rule reads, headline, notes and the values kept beside them; the markdown helpers
and figures render what the notebook shows beside them.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import textwrap
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import matplotlib.pyplot as plt
import numpy as np
import scipy.ndimage
import torch
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from torch import Tensor, nn

from repro.claims.registry import get_claim
from repro.claims.registry_energymogen import EMG1_LIMIT
from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core import metrics
from repro.core.diffusion import GaussianDiffusion
from repro.core.tables import interval_text, markdown_table, render
from repro.energymogen import settings as rule_settings
from repro.energymogen.compose import Condition, make_composed_eps_fn
from repro.energymogen.data import (
    NotMeasurable,
    composition_items,
    concept_text,
    energy_view_items,
    negation_items,
    not_measurable_reason,
    pair_caption,
)
from repro.energymogen.figures import Figures
from repro.energymogen.harness import (
    KINDS,
    AASlot,
    aa_controls,
    copy_seed,
    copy_source,
    oracle_presence,
    pair_index,
    per_pair_mean,
)
from repro.energymogen.model_gates import Models
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    PipelineSource,
    Sampler,
    denoiser_kwargs,
    pipeline_for,
)
from repro.energymogen.settings import (
    ARM_CONCEPTS,
    HELD_OUT_PAIRS,
    LOWER_CONCEPTS,
    NEGATION_CASES,
    NotebookSettings,
    PipelineConfig,
    TrainingPlan,
    pipeline_config,
    seeds_of,
)
from repro.infra.context import check_scale
from repro.models.latent_denoiser import LatentDenoiser
from repro.motion.plotting import filmstrip, save_figure
from repro.standin.oracles import GLIDE_NOTE, TRAVEL_CONCEPTS

__all__ = [
    "EnergyViewSettings",
    "EMG1_NULL_READING",
    "EpsFn",
    "LOOP_POINTS",
    "LatentPlane",
    "MAP_KINDS",
    "by_pair_markdown",
    "case_similarities",
    "composition_controls",
    "composition_reference_rates",
    "composition_examples_figure",
    "composition_oracle_figure",
    "composition_study",
    "composition_study_text",
    "conditional_eps",
    "denoiser_jacobian_asymmetry",
    "emg1_result",
    "emg23_results",
    "emg6_result",
    "emg9_result",
    "energy_landscape",
    "energy_linearity_error",
    "energy_map_case",
    "energy_map_cases",
    "energy_map_controls",
    "energy_map_study",
    "energy_maps_figure",
    "energy_view_study",
    "fid_draws_markdown",
    "fid_fixed_cases",
    "fid_fixed_cases_markdown",
    "fid_formula_errors",
    "fixed_cases",
    "flat_jacobian",
    "float64_copy",
    "field_readings",
    "gradient_field_controls",
    "gradient_field_study",
    "guidance_scale_check",
    "jacobian_asymmetry",
    "jacobian_asymmetry_figure",
    "langevin_step_errors",
    "latent_plane",
    "line_integral_energy",
    "linear_field",
    "loop_plane",
    "map_cases_markdown",
    "map_similarities",
    "map_similarity",
    "map_similarity_figure",
    "map_similarity_markdown",
    "planted_fields",
    "raw_maps_markdown",
    "relative_circulation",
    "residual_asymmetry",
    "save_composition_figures",
    "save_energy_map_figures",
    "smooth_energy_map",
]


@dataclass(frozen=True)
class EnergyViewSettings(NotebookSettings):
    """Notebook 04 (EMG-1, 2, 3, 6, 9). On a data folder (real data, no concept labels):
    EMG-1 (model identities on the folder's test windows and captions) and EMG-9 (no data)
    are measured; EMG-2, 3 and 6, which compose the stand-in's labelled concepts, are
    recorded as not measurable on real data (docs/RUNNING.md "The real HumanML3D").

    ``emg1_samples`` noised test latents for EMG-1's identities; ``negation_items_per_case``
    items per ``NEGATION_CASES`` case (EMG-2/3); the guidance-scale check (paper scale
    only: its cost at standard was not measured below a CPU-minute; not recorded) reruns
    EMG-2/3 at ``scale_check_scales`` on the first ``scale_check_seeds`` seeds with fewer
    items; EMG-6's maps: a ``map_grid``² grid, ``map_noise_draws`` noise draws (standard 2,
    paper 4), ``map_samples`` generated latents per row (the paper values are
    ``energy_contour_maps.energy_map_case``'s defaults), ``map_cases`` cases per kind and seed
    (None: every held-out pair and every negation case; quick runs take the
    first two). ``plan``: the training plan of every EnergyMoGen notebook (the same trained
    pipeline as 05, 07 and 08).
    """

    NOTEBOOK: ClassVar[str] = "04_energy_contour_maps"
    scale: str
    pipeline: PipelineConfig
    plan: TrainingPlan
    seeds: int
    emg1_samples: int
    negation_items_per_case: int
    scale_check: bool
    map_grid: int
    map_noise_draws: int
    map_samples: int
    map_cases: int | None = None
    jacobian_timesteps: tuple[int, ...] = (100, 300, 500, 700, 900)
    linearity_timesteps: tuple[int, ...] = (100, 500, 900)
    scale_check_scales: tuple[float, ...] = (1.5, 5.0)
    scale_check_seeds: int = 3
    scale_check_items_per_pair: int = 4
    scale_check_items_per_case: int = 8

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @classmethod
    def for_scale(cls, scale: str) -> EnergyViewSettings:
        scale = check_scale(scale)
        common = {"scale": scale, "pipeline": pipeline_config(scale),
                  "plan": TrainingPlan.for_scale(scale), "seeds": seeds_of("EMG-2", scale)}
        if scale == "quick":
            return cls(**common, emg1_samples=3, negation_items_per_case=6, scale_check=False,
                       map_grid=6, map_noise_draws=1, map_samples=6, map_cases=2)
        return cls(**common, emg1_samples=8, negation_items_per_case=16,
                   scale_check=scale == "paper", map_grid=16,
                   map_noise_draws=2 if scale == "standard" else 4, map_samples=16)


def langevin_step_errors(diffusion: GaussianDiffusion, eps_fn: Callable[[Tensor, Tensor], Tensor],
                         z: Tensor, timesteps: Sequence[int], seed: int = 0,
                         ddim_steps: int = 50) -> dict[str, float]:
    """Max |sampler step − Langevin step| over ``timesteps`` (float64), DDPM and DDIM.

    With ∇E_t(z) := ε_θ(z, t)/√(1 − ᾱ_t) (= −∇ log p_t, the energy whose gradient is ε_θ up to
    a positive scale) both samplers are a Langevin step z − η_t ∇F_t(z) + σ_t ξ on
    F_t = E_t − κ_t ½‖z‖²:

    - DDPM (μ_t = (z − β_t ε/√(1−ᾱ_t))/√α_t): η_t = β_t/√α_t, κ_t = (1 − √α_t)/β_t, σ_t² = β̃_t;
    - DDIM (η = 0) from t to t': z' = a z − b ε with a = √ᾱ_{t'}/√ᾱ_t,
      b = a√(1−ᾱ_t) − √(1−ᾱ_{t'}): η = b√(1−ᾱ_t), κ = (a − 1)/η, σ = 0.

    Eq. 5–6 of the paper is the small-β reading κ → 0 with the ε coefficient set to 1; the
    exact coefficient on ε, η_t/√(1−ᾱ_t), is returned as ``ddpm_eps_coefficient_min/max``.
    """
    z = z.double()
    generator = torch.Generator().manual_seed(seed)
    ddim = diffusion.ddim_timesteps(ddim_steps)
    worst = {"ddpm": 0.0, "ddim": 0.0}
    coefficient = []
    for step in timesteps:
        t = torch.full((z.shape[0],), int(step), dtype=torch.long)
        with torch.no_grad():
            eps = eps_fn(z.float(), t).double()
        xi = torch.randn(z.shape, generator=generator, dtype=torch.float64)
        beta, alpha = diffusion.betas[step], diffusion.alphas[step]
        abar = diffusion.alphas_cumprod[step]
        sigma = np.sqrt(diffusion.posterior_variance[step]) * (step > 0)
        sampler = diffusion.posterior_mean_from_eps(z, eps, t) + sigma * xi
        eta, kappa = beta / np.sqrt(alpha), (1.0 - np.sqrt(alpha)) / beta
        grad_f = eps / np.sqrt(1.0 - abar) - kappa * z
        langevin = z - eta * grad_f + sigma * xi
        worst["ddpm"] = max(worst["ddpm"], float((sampler - langevin).abs().max()))
        coefficient.append(eta / np.sqrt(1.0 - abar))
        position = np.searchsorted(ddim, step)
        if position < len(ddim) and ddim[position] == step and position > 0:
            prev = int(ddim[position - 1])
            z_prev = diffusion.ddim_step(z, t, torch.full_like(t, prev), eps)
            abar_p = diffusion.alphas_cumprod[prev]
            a = np.sqrt(abar_p / abar)
            b = a * np.sqrt(1.0 - abar) - np.sqrt(1.0 - abar_p)
            eta_d = b * np.sqrt(1.0 - abar)
            langevin_d = z - eta_d * (eps / np.sqrt(1.0 - abar) - (a - 1.0) / eta_d * z)
            worst["ddim"] = max(worst["ddim"], float((z_prev - langevin_d).abs().max()))
    return {"ddpm_max_abs_error": worst["ddpm"], "ddim_max_abs_error": worst["ddim"],
            "max_abs_error": max(worst.values()),
            "ddpm_eps_coefficient_min": float(min(coefficient)),
            "ddpm_eps_coefficient_max": float(max(coefficient))}


def _gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(nodes)
    return 0.5 * (x + 1.0), 0.5 * w


def line_integral_energy(eps_fn: Callable[[Tensor], Tensor], z: Tensor,
                         nodes: int = 16) -> Tensor:
    """E(z) = ∫₀¹ ε(s·z)·z ds (Gauss–Legendre), the energy of ε along the ray from 0: if ε
    is a gradient field, ∇E = ε; otherwise E depends on the path. z (B, ...) → (B,)."""
    s, w = _gauss_legendre(nodes)
    total = torch.zeros(z.shape[0], dtype=z.dtype, device=z.device)
    for s_k, w_k in zip(s, w, strict=True):
        total = total + float(w_k) * (eps_fn(float(s_k) * z) * z).flatten(1).sum(1)
    return total


class _AsDouble(nn.Module):
    """Casts its input to float64 (the sinusoidal time embedding is always float32)."""

    def forward(self, x: Tensor) -> Tensor:
        return x.double()


def float64_copy(denoiser: LatentDenoiser) -> LatentDenoiser:
    """A float64 copy of the denoiser for exact checks (eval mode)."""
    model = copy.deepcopy(denoiser).double().eval()
    model.time_mlp = nn.Sequential(_AsDouble(), *model.time_mlp)
    return model


def energy_linearity_error(denoiser: LatentDenoiser, z: Tensor, t: int,
                           concepts: Sequence[Condition], weights: Sequence[float],
                           nodes: int = 16) -> dict[str, float]:
    """Eq. 7 as a sum of energies, in float64 on a copy of the denoiser.

    E_comp is the line integral of the composed ε (``make_composed_eps_fn``, mode "latent");
    the sum is E(∅) + Σ w_i (E(c_i) − E(∅)) of separately integrated models. Returns
    ``max_abs_error`` |E_comp − sum| and ``max_energy`` (the scale), and the conservativeness
    diagnostic ``gradient_relative_error`` = ‖∇E_comp − ε_comp‖/‖ε_comp‖ (0 iff the
    composed ε is a gradient field along these rays).
    """
    model = float64_copy(denoiser)
    z = z.double()
    conds = [(tok.double(), mask) for tok, mask in concepts]
    tt = torch.full((z.shape[0],), int(t), dtype=torch.long)

    def each(cond: Condition | None) -> Callable[[Tensor], Tensor]:
        if cond is None:
            return lambda x: model(x, tt, *model.null_text(x.shape[0]))
        return lambda x: model(x, tt, cond[0].expand(x.shape[0], -1, -1),
                               cond[1].expand(x.shape[0], -1))

    composed = make_composed_eps_fn(model, conds, mode="latent", weights=list(weights))
    with torch.no_grad():
        e_comp = line_integral_energy(lambda x: composed(x, tt), z, nodes)
        e_null = line_integral_energy(each(None), z, nodes)
        summed = e_null.clone()
        for w_i, cond in zip(weights, conds, strict=True):
            summed = summed + float(w_i) * (line_integral_energy(each(cond), z, nodes) - e_null)
    zg = z.clone().requires_grad_(True)
    energy = line_integral_energy(lambda x: composed(x, tt), zg, nodes)
    (grad,) = torch.autograd.grad(energy.sum(), zg)
    with torch.no_grad():
        eps = composed(z, tt)
    rel = ((grad - eps).flatten(1).norm(dim=1) / eps.flatten(1).norm(dim=1)).max()
    return {"max_abs_error": float((e_comp - summed).abs().max()),
            "max_energy": float(e_comp.abs().max()), "gradient_relative_error": float(rel)}


def jacobian_asymmetry(eps_fn: Callable[[Tensor], Tensor], z: Tensor) -> np.ndarray:
    """‖J − Jᵀ‖_F / ‖J‖_F of J = ∂ε/∂z (flattened) at each sample of z (B, ...) → (B,).

    A gradient field has a symmetric Jacobian (0); a random matrix gives ≈ √2. ``eps_fn``
    maps a batch (D, ...) to ε of the same shape, row r only depending on input row r.
    """
    out = []
    dim = int(np.prod(z.shape[1:]))
    eye = torch.eye(dim, dtype=z.dtype, device=z.device)
    for b in range(z.shape[0]):
        rep = z[b:b + 1].detach().expand(dim, *z.shape[1:]).clone().requires_grad_(True)
        eps = eps_fn(rep).reshape(dim, dim)
        (jac,) = torch.autograd.grad((eps * eye).sum(), rep)
        jac = jac.reshape(dim, dim)             # row i: ∂ε_i/∂z
        out.append(float((jac - jac.T).norm() / jac.norm().clamp_min(1e-30)))
    return np.asarray(out)


def conditional_eps(denoiser: LatentDenoiser, t: int, condition: Condition | None,
                    b: int) -> Callable[[Tensor], Tensor]:
    """x ↦ ε_θ(x, t, c_b): the denoiser at step ``t`` under the ``b``-th text of ``condition``
    (tokens (B, L, D), mask (B, L)), or under ∅ when ``condition`` is None."""
    def eps(x: Tensor) -> Tensor:
        tt = torch.full((x.shape[0],), int(t), dtype=torch.long, device=x.device)
        if condition is None:
            return denoiser(x, tt, *denoiser.null_text(x.shape[0]))
        tokens, mask = condition
        return denoiser(x, tt, tokens[b:b + 1].expand(x.shape[0], -1, -1),
                        mask[b:b + 1].expand(x.shape[0], -1))
    return eps


def denoiser_jacobian_asymmetry(denoiser: LatentDenoiser, z_t: Tensor, t: int,
                                condition: Condition | None) -> np.ndarray:
    """:func:`jacobian_asymmetry` of z ↦ ε_θ(z, t, c) at each latent of ``z_t`` (B, N, d);
    ``condition`` is (tokens (B, L, D), mask (B, L)), one text per latent, or None for ∅."""
    out = []
    for b in range(z_t.shape[0]):
        out.append(jacobian_asymmetry(conditional_eps(denoiser, t, condition, b), z_t[b:b + 1])[0])
    return np.asarray(out)


def energy_view_study(pipe: EnergyMoGenPipeline, seed: int, *, samples: int,
                      linearity_timesteps: Sequence[int],
                      jacobian_timesteps: Sequence[int]) -> dict[str, Any]:
    """EMG-1 on the pipeline: ``samples`` ground-truth latents of the composition items of
    ``seed`` (``data.energy_view_items``: on a data folder, test windows and their captions),
    noised with noise of ``seed``.

    - ``langevin``: :func:`langevin_step_errors` of the denoiser with the joined text at the
      mid-timestep latents, every timestep (DDIM with the pipeline's steps);
    - ``linearity``: :func:`energy_linearity_error` of Eq. 7 with w = (s, s) (s the pipeline's
      guidance scale) at each of ``linearity_timesteps``; ``sum_error`` the largest;
    - ``asymmetry``: name → (timesteps, samples) :func:`denoiser_jacobian_asymmetry` at the
      latents noised to each of ``jacobian_timesteps``, for the trained denoiser with the
      joined text and with ∅, and a randomly initialised one (``torch.manual_seed(seed)``);
      ``jacobian_median``: the median of the trained model's, both conditions pooled.
    """
    items = energy_view_items(pipe.data, seed, pipe.config.items_per_pair)
    z0 = pipe.encode_motion(items.gt_features[:samples])
    condition = pipe.encode(list(items.multi_texts[:samples]))
    noise = torch.randn(z0.shape, generator=torch.Generator().manual_seed(seed))
    steps = pipe.config.num_timesteps
    z_mid = pipe.diffusion.q_sample(z0, torch.full((samples,), steps // 2, dtype=torch.long),
                                    noise)
    langevin = langevin_step_errors(
        pipe.diffusion, lambda x, t: pipe.denoiser(x, t, *condition), z_mid,
        timesteps=range(steps), seed=seed, ddim_steps=pipe.config.ddim_steps)
    concepts = [pipe.encode(list(texts[:samples])) for texts in items.concept_texts]
    s = pipe.config.guidance_scale
    linearity = [energy_linearity_error(pipe.denoiser, z_mid, t, concepts, [s, s])
                 for t in linearity_timesteps]
    torch.manual_seed(seed)
    random_init = LatentDenoiser(**denoiser_kwargs(pipe.config)).eval()
    asymmetry: dict[str, list[np.ndarray]] = {"trained, text": [], "trained, ∅": [],
                                              "random init, text": []}
    for t in jacobian_timesteps:
        z_t = pipe.diffusion.q_sample(z0, torch.full((samples,), t, dtype=torch.long), noise)
        asymmetry["trained, text"].append(
            denoiser_jacobian_asymmetry(pipe.denoiser, z_t, t, condition))
        asymmetry["trained, ∅"].append(denoiser_jacobian_asymmetry(pipe.denoiser, z_t, t, None))
        asymmetry["random init, text"].append(
            denoiser_jacobian_asymmetry(random_init, z_t, t, condition))
    stacked = {name: np.stack(values) for name, values in asymmetry.items()}
    trained = np.concatenate([stacked["trained, text"].ravel(), stacked["trained, ∅"].ravel()])
    out = {"langevin": langevin, "linearity": linearity,
           "sum_error": max(x["max_abs_error"] for x in linearity), "asymmetry": stacked,
           "jacobian_median": float(np.median(trained))}
    if not pipe.data.labelled:   # a data folder: its test windows and captions (no concepts)
        out["data_dir"] = pipe.data.data_dir
    return out


@dataclass(frozen=True)
class LatentPlane:
    """A 2-D slice: z(u, v) = center + u·basis[0] + v·basis[1], the grid spanning ±extent."""

    center: Tensor
    basis: Tensor
    extent: tuple[float, float]
    scores: np.ndarray

    def grid(self, size: int) -> tuple[np.ndarray, np.ndarray, Tensor]:
        """(u (G,), v (G,), latents (G·G, N, d)) with row-major (v, u) order."""
        u = np.linspace(-self.extent[0], self.extent[0], size)
        v = np.linspace(-self.extent[1], self.extent[1], size)
        uu, vv = np.meshgrid(u, v)
        coords = torch.tensor(np.stack([uu.ravel(), vv.ravel()], 1), dtype=self.basis.dtype)
        flat = self.center.reshape(1, -1) + coords @ self.basis
        return u, v, flat.reshape(-1, *self.center.shape)


def latent_plane(latents: Tensor, margin: float = 1.25) -> LatentPlane:
    """The plane of the first two principal components of ``latents`` (B, N, d), centred at
    their mean, spanning ``margin`` × the largest |score| on each axis (our choice)."""
    flat = latents.reshape(latents.shape[0], -1).double()
    center = flat.mean(0)
    _, _, vt = torch.linalg.svd(flat - center, full_matrices=False)
    basis = vt[:2]
    scores = ((flat - center) @ basis.T).numpy()
    extent = tuple(float(margin * np.abs(scores[:, k]).max()) for k in range(2))
    return LatentPlane(center.float().reshape(latents.shape[1:]), basis.float(), extent, scores)


def energy_landscape(denoiser: LatentDenoiser, diffusion: GaussianDiffusion,
                     latents: Tensor, conditions: Mapping[str, Condition | None],
                     combinations: Mapping[str, Mapping[str, float]], *,
                     timesteps: Sequence[int], n_noise: int, seed: int,
                     chunk: int = 4096) -> dict[str, np.ndarray]:
    """Denoising-loss energies at every latent z of ``latents`` (M, N, d) (our definition):

        E_k(z) = mean over (t, ε) of ‖ε̂_k(√ᾱ_t z + √(1−ᾱ_t) ε, t) − ε‖² / dim,

    the Monte-Carlo form of the training loss (Eq. 2), itself a bound on −log p(z|·) up to
    weights and constants. ε̂_k = Σ_j w_kj ε(c_j) for ``combinations[k]`` = {condition: w}
    over ``conditions`` (None = ∅), e.g. Eq. 7 with unit weights: {∅: −1, c1: 1, c2: 1}.
    The same (t, ε) draws are used for every z and every k (common random numbers).
    Returns k → (M,).
    """
    generator = torch.Generator().manual_seed(seed)
    draws = [(int(t), torch.randn(latents.shape[1:], generator=generator))
             for t in timesteps for _ in range(n_noise)]
    dim = int(np.prod(latents.shape[1:]))
    totals = {k: torch.zeros(latents.shape[0], dtype=torch.float64) for k in combinations}
    with torch.no_grad():
        for t, noise in draws:
            tt = torch.full((latents.shape[0],), t, dtype=torch.long)
            z_t = diffusion.q_sample(latents, tt, noise.expand_as(latents))
            eps = {}
            for name, cond in conditions.items():
                parts = []
                for start in range(0, latents.shape[0], chunk):
                    x = z_t[start:start + chunk]
                    tokens, mask = cond if cond is not None else denoiser.null_text(1)
                    parts.append(denoiser(x, tt[start:start + chunk],
                                          tokens.expand(x.shape[0], -1, -1),
                                          mask.expand(x.shape[0], -1)))
                eps[name] = torch.cat(parts)
            for key, weights in combinations.items():
                pred = sum(float(w) * eps[name] for name, w in weights.items())
                totals[key] += ((pred - noise).pow(2).flatten(1).sum(1) / dim).double()
    return {k: (v / len(draws)).numpy() for k, v in totals.items()}


def smooth_energy_map(grid_values: np.ndarray, upsample: int = 4,
                      sigma: float = 2.0) -> np.ndarray:
    """Interpolate a (G, G) map by ``upsample`` (cubic spline, ``scipy.ndimage.zoom``) and
    Gaussian-smooth it (``scipy.ndimage.gaussian_filter``, σ in fine pixels), as Fig. 5/6."""
    fine = scipy.ndimage.zoom(np.asarray(grid_values, dtype=np.float64), upsample, order=3)
    return scipy.ndimage.gaussian_filter(fine, sigma)


def map_similarity(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two maps (flattened)."""
    a, b = np.ravel(a), np.ravel(b)
    if a.shape != b.shape:
        raise ValueError(f"maps differ in size: {a.shape} vs {b.shape}")
    return float(np.corrcoef(a, b)[0, 1])


def _control_pair(pair: tuple[str, str], start: int) -> tuple[str, str]:
    """The next held-out pair (cyclically from ``start``) sharing no concept with ``pair``."""
    for k in range(len(HELD_OUT_PAIRS)):
        other = HELD_OUT_PAIRS[(start + k) % len(HELD_OUT_PAIRS)]
        if not set(other) & set(pair):
            return other
    raise ValueError(f"no held-out pair is disjoint from {pair}")


def _control_concept(kept: str, pair: tuple[str, str], start: int) -> str:
    """A concept of the kept concept's group (lower/arms) outside ``pair`` (cyclic)."""
    group = LOWER_CONCEPTS if kept in LOWER_CONCEPTS else ARM_CONCEPTS
    options = [c for c in group if c not in pair]
    return options[start % len(options)]


def case_similarities(smooth: Mapping[str, np.ndarray],
                      kind: Literal["conjunction", "negation"]) -> dict[str, float]:
    """Pearson r of the maps of one case (``smooth``: "composed", "concept 1", "concept 2",
    "multi-concept", "paraphrase", "control"): composed ~ multi; the floor, one concept alone
    ~ multi (conjunction: the better of the two concepts; negation: concept 1, c_i before
    negating); the ceiling, the paraphrase ~ multi; composed ~ control; each concept ~ multi."""
    to_multi = {name: map_similarity(smooth[name], smooth["multi-concept"])
                for name in ("composed", "concept 1", "concept 2", "paraphrase")}
    floor = (max(to_multi["concept 1"], to_multi["concept 2"]) if kind == "conjunction"
             else to_multi["concept 1"])
    return {"similarity_to_multi": to_multi["composed"], "similarity_floor": floor,
            "similarity_ceiling": to_multi["paraphrase"],
            "similarity_concept_1_to_multi": to_multi["concept 1"],
            "similarity_concept_2_to_multi": to_multi["concept 2"],
            "similarity_to_control": map_similarity(smooth["composed"], smooth["control"])}


def _paraphrase(text: str, draw: Callable[[], str], tries: int = 50) -> str:
    """Another wording of ``text``: the first of ``draw()``'s texts that differs from it."""
    for _ in range(tries):
        other = draw()
        if other != text:
            return other
    raise ValueError(f"no paraphrase of {text!r} in {tries} draws")


def energy_map_case(pipe: EnergyMoGenPipeline, kind: Literal["conjunction", "negation"],
                    case_index: int, seed: int, *, grid: int = 16, n_noise: int = 4,
                    timesteps: Sequence[int] = (100, 300, 500, 700, 900), samples: int = 16,
                    upsample: int = 4, sigma: float = 2.0) -> dict[str, Any]:
    """One EMG-6 case: energy maps of concept 1, concept 2, their composition, the single
    multi-concept text and an unrelated control, on one 2-D latent slice.

    - conjunction: a held-out pair (``case_index`` cyclic); composed = Eq. 7 with unit weights
      {∅: −1, c1: 1, c2: 1} (the product p(z|c1)p(z|c2)/p(z)); multi = the joined text;
      control = the joined text of a held-out pair sharing no concept.
    - negation: a :data:`NEGATION_CASES` entry; c1 = the pair's text (c_i), c2 = the negated
      concept's text (c_j); composed = Eq. 8 with w = 1 {∅: 1, c1: 1, c2: −1}; multi = the
      kept concept's own text (as "walking to the right" in Fig. 5b); control = another
      concept of the kept concept's group.
    - slice (our choice): the plane of the first two principal components of generated
      latents — ``samples`` each from c1, c2, the composition (guided with s) and multi.
    - energy: :func:`energy_landscape` on a ``grid``² grid, smoothed by
      :func:`smooth_energy_map`; the maps compared are the *conditional part* E_k − E_∅
      (``smooth``), which removes the noise floor and the distance from the data that every
      condition shares (in the quick test run, an untrained model, raw maps correlated
      ≥ 0.999 whatever the text; we fixed this measure then, before any full run); raw-map
      similarities are returned too (``raw_similarity_*``, ``smooth_raw``).
    - similarity: Pearson correlation of the smoothed conditional maps; ``similarity_to_multi``
      (composed ~ multi) sits between a **floor**, one concept alone ~ multi (conjunction: the
      better of concept 1 and concept 2; negation: c_i, the text before negating), and a
      **ceiling**, a paraphrase of the multi-concept text ~ multi (another caption of the
      pair; negation: another wording of the kept concept) — how alike two texts of one
      meaning are on this slice; ``similarity_to_control`` (an unrelated text)
      is context.
    """
    rng = np.random.default_rng([seed, 606, 0 if kind == "conjunction" else 1])
    s = pipe.config.guidance_scale
    data = pipe.data
    if kind == "conjunction":
        pair = HELD_OUT_PAIRS[case_index % len(HELD_OUT_PAIRS)]
        control_pair = _control_pair(pair, case_index + 1)

        def caption(p: tuple[str, str]) -> str:
            clips = [i for i, c in enumerate(data.test_concepts) if tuple(c) == p]
            i = clips[int(rng.integers(len(clips)))]
            return data.test_captions[i][int(rng.integers(len(data.test_captions[i])))]

        texts = {"c1": concept_text(pair[0], rng), "c2": concept_text(pair[1], rng),
                 "multi": caption(pair), "control": caption(control_pair)}
        texts["ceiling"] = _paraphrase(texts["multi"], lambda: caption(pair))
        composed = {"∅": -1.0, "c1": 1.0, "c2": 1.0}
        sampler = Sampler("latent")
        label = {"case": "/".join(pair), "control": "/".join(control_pair)}
    else:
        pair, negated = NEGATION_CASES[case_index % len(NEGATION_CASES)]
        kept = pair[0] if pair[1] == negated else pair[1]
        control = _control_concept(kept, pair, case_index)
        texts = {"c1": pair_caption(pair, rng), "c2": concept_text(negated, rng),
                 "multi": concept_text(kept, rng), "control": concept_text(control, rng)}
        texts["ceiling"] = _paraphrase(texts["multi"], lambda: concept_text(kept, rng))
        composed = {"∅": 1.0, "c1": 1.0, "c2": -1.0}
        sampler = Sampler("latent", weights=(s, -s))
        label = {"case": f"{'/'.join(pair)} not {negated}", "control": control}
    rows = {"concept 1": (Sampler("single"), [], [texts["c1"]] * samples),
            "concept 2": (Sampler("single"), [], [texts["c2"]] * samples),
            "composed": (sampler, [[texts["c1"]] * samples, [texts["c2"]] * samples], None),
            "multi-concept": (Sampler("single"), [], [texts["multi"]] * samples)}
    generated = {name: pipe.sample(spec, concepts, multi, seed, batch=samples)
                 for name, (spec, concepts, multi) in rows.items()}
    plane = latent_plane(torch.cat(list(generated.values())))
    u, v, grid_latents = plane.grid(grid)
    conditions: dict[str, Condition | None] = {"∅": None}
    conditions.update({k: pipe.encode([t]) for k, t in texts.items()})
    combinations = {"concept 1": {"c1": 1.0}, "concept 2": {"c2": 1.0}, "composed": composed,
                    "multi-concept": {"multi": 1.0}, "control": {"control": 1.0},
                    "paraphrase": {"ceiling": 1.0}, "unconditional": {"∅": 1.0}}
    energies = energy_landscape(pipe.denoiser, pipe.diffusion, grid_latents.to(pipe.device),
                                conditions, combinations, timesteps=timesteps,
                                n_noise=n_noise, seed=seed)
    raw = {k: e.reshape(grid, grid) for k, e in energies.items()}
    smooth_raw = {k: smooth_energy_map(m, upsample, sigma) for k, m in raw.items()}
    smooth = {k: m - smooth_raw["unconditional"] for k, m in smooth_raw.items()
              if k != "unconditional"}
    flat = plane.center.reshape(1, -1).double()
    scores = {name: ((z.reshape(z.shape[0], -1).double().cpu() - flat) @ plane.basis.double().T
                     ).numpy() for name, z in generated.items()}
    return {"kind": kind, "texts": texts, **label, "u": u, "v": v, "raw": raw,
            "smooth_raw": smooth_raw, "smooth": smooth, "scores": scores,
            "extent": plane.extent, **case_similarities(smooth, kind),
            "raw_similarity_to_multi": map_similarity(smooth_raw["composed"],
                                                      smooth_raw["multi-concept"]),
            "raw_similarity_to_control": map_similarity(smooth_raw["composed"],
                                                        smooth_raw["control"])}


MAP_KINDS: tuple[str, str] = ("conjunction", "negation")


def energy_map_cases(pipe: EnergyMoGenPipeline, kind: Literal["conjunction", "negation"],
                     seed: int, *, count: int | None = None, **kwargs: Any
                     ) -> list[dict[str, Any]]:
    """:func:`energy_map_case` for every held-out pair (conjunction) or every
    :data:`NEGATION_CASES` entry (negation) of one seed — or the first ``count`` of them (a
    quick run) — on that seed's model, noise and texts."""
    total = len(HELD_OUT_PAIRS) if kind == "conjunction" else len(NEGATION_CASES)
    return [energy_map_case(pipe, kind, k, seed, **kwargs)
            for k in range(total if count is None else min(count, total))]


#: what :func:`map_similarities` averages per seed: measurement suffix → case key
_SIMILARITIES = {"similarity_to_multi": "similarity_to_multi",
                 "similarity_floor": "similarity_floor",
                 "similarity_ceiling": "similarity_ceiling",
                 "similarity_to_control": "similarity_to_control"}


def energy_map_study(source: PipelineSource, seeds: Sequence[int], *, count: int | None = None,
                     **kwargs: Any) -> dict[str, list[list[dict[str, Any]]]] | NotMeasurable:
    """EMG-6's cases: kind (:data:`MAP_KINDS`) → one :func:`energy_map_cases` list per seed
    (seed s on ``pipeline_for(source, s)``, ``count`` and ``kwargs`` passed on). On a data
    folder a ``data.NotMeasurable``: the maps compare composed concepts of the stand-in (held-out
    pairs, negation cases and their concept texts) with their joined text, which real captions
    do not decompose into."""
    first = pipeline_for(source, seeds[0])
    if not first.data.labelled:
        return NotMeasurable(not_measurable_reason(first.data))
    return {kind: [energy_map_cases(pipeline_for(source, sd), kind, sd, count=count, **kwargs)
                   for sd in seeds]
            for kind in MAP_KINDS}


def map_similarities(cases_by_seed: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                     | NotMeasurable) -> dict[str, list[float]] | NotMeasurable:
    """EMG-6's measurements: per kind and seed, the mean over that seed's cases of composed ~
    multi, the floor, the ceiling and composed ~ control (``{kind}_{suffix}`` → per-seed
    list). ``cases_by_seed``: kind → one list of :func:`energy_map_case` results per seed
    (:func:`energy_map_study`; a ``NotMeasurable`` is passed on)."""
    if isinstance(cases_by_seed, NotMeasurable):
        return cases_by_seed
    return {f"{kind}_{suffix}": [float(np.mean([c[key] for c in cases])) for cases in per_seed]
            for kind, per_seed in cases_by_seed.items() for suffix, key in _SIMILARITIES.items()}


def fid_formula_errors(seed: int, dim: int = 16, draws: int = 20) -> dict[str, Any]:
    """Relative errors of ``metrics.frechet_distance`` and of the printed Eq. 12 against the
    closed form ‖Δμ‖² + Σ(√λ1 − √λ2)² for Gaussians with commuting covariances
    Σ_i = Q diag(λ_i) Qᵀ (random orthogonal Q, λ ∈ [0.1, 3], μ ~ N(0, I)), and the per-draw
    values. Ours: the largest error over draws; the printed form: the smallest (it is off by
    at least that much in every draw)."""
    rng = np.random.default_rng(seed)
    ours, printed, rows = [], [], []
    for _ in range(draws):
        q, _ = np.linalg.qr(rng.normal(size=(dim, dim)))
        lam1, lam2 = rng.uniform(0.1, 3.0, dim), rng.uniform(0.1, 3.0, dim)
        mu1, mu2 = rng.normal(size=dim), rng.normal(size=dim)
        s1, s2 = q @ np.diag(lam1) @ q.T, q @ np.diag(lam2) @ q.T
        closed = metrics.gaussian_fid_closed_form(mu1, lam1, mu2, lam2)
        value = metrics.frechet_distance(mu1, s1, mu2, s2)
        as_printed = metrics.fid_as_printed_in_energymogen(mu1, s1, mu2, s2)
        ours.append(abs(value - closed) / abs(closed))
        printed.append(abs(as_printed - closed) / abs(closed))
        rows.append({"closed_form": closed, "ours": value, "printed_eq12": as_printed})
    return {"fid_vs_closed_form_relative_error": float(max(ours)),
            "printed_vs_closed_form_relative_error": float(min(printed)), "draws": rows}


LOOP_POINTS = 16
EpsFn = Callable[[Tensor], Tensor]


def flat_jacobian(eps_fn: EpsFn, z: Tensor) -> Tensor:
    """J = ∂ε/∂z (D, D) of one sample ``z`` (1, ...), flattened; row i is ∂ε_i/∂z. ``eps_fn``
    maps a batch (D, ...) to ε of the same shape, row r depending on input row r only."""
    dim = int(np.prod(z.shape[1:]))
    rep = z.detach().expand(dim, *z.shape[1:]).clone().requires_grad_(True)
    eps = eps_fn(rep).reshape(dim, dim)
    eye = torch.eye(dim, dtype=z.dtype, device=z.device)
    (jac,) = torch.autograd.grad((eps * eye).sum(), rep)
    return jac.reshape(dim, dim).detach()


def residual_asymmetry(jac: Tensor, identity_coefficient: float) -> float:
    """‖A − Aᵀ‖_F / ‖A‖_F for A = J − c·I (c = 1/√(1−ᾱ_t) in EMG-1)."""
    residual = jac - identity_coefficient * torch.eye(jac.shape[0], dtype=jac.dtype,
                                                      device=jac.device)
    return float((residual - residual.T).norm() / residual.norm().clamp_min(1e-30))


def loop_plane(jac: Tensor) -> tuple[Tensor, Tensor]:
    """Orthonormal (u, v) spanning the plane of largest circulation of the linear field J z:
    the top singular pair of J − Jᵀ (for an antisymmetric K, K u = σ v)."""
    u_mat, _, vh = torch.linalg.svd(jac - jac.T)
    u, v = vh[0], u_mat[:, 0]
    v = v - (v @ u) * u
    return u, v / v.norm().clamp_min(1e-30)


def relative_circulation(eps_fn: EpsFn, centre: Tensor, u: Tensor, v: Tensor, radius: float,
                         points: int = LOOP_POINTS) -> float:
    """|∮ε·dz| / ∮‖ε‖‖dz‖ on z(θ) = centre + r(cos θ u + sin θ v), trapezoid rule on
    ``points`` angles; ``centre`` (1, ...), ``u``/``v`` flattened orthonormal directions."""
    theta = torch.arange(points, dtype=centre.dtype, device=centre.device) * (2 * np.pi / points)
    offsets = radius * (torch.cos(theta)[:, None] * u + torch.sin(theta)[:, None] * v)
    tangents = radius * (-torch.sin(theta)[:, None] * u + torch.cos(theta)[:, None] * v)
    z = centre.reshape(1, -1) + offsets
    with torch.no_grad():
        eps = eps_fn(z.reshape(points, *centre.shape[1:])).reshape(points, -1)
    work = (eps * tangents).sum(dim=1).sum()
    path = (eps.norm(dim=1) * tangents.norm(dim=1)).sum()
    return float(work.abs() / path.clamp_min(1e-30))


def field_readings(eps: EpsFn, centre: Tensor, identity_coefficient: float, radius: float,
                   jac: Tensor | None = None) -> tuple[float, float]:
    """EMG-1's two readings of a field at one point ``centre`` (1, ...): the residual Jacobian
    asymmetry (:func:`residual_asymmetry` of the Jacobian ``jac``, by default
    :func:`flat_jacobian`'s, identity coefficient c) and the relative loop integral on a circle
    of ``radius`` in the plane of :func:`loop_plane`."""
    jac = flat_jacobian(eps, centre) if jac is None else jac
    u, v = loop_plane(jac)
    return (residual_asymmetry(jac, identity_coefficient),
            relative_circulation(eps, centre, u, v, radius))


def linear_field(eps0: Tensor, centre: Tensor, matrix: Tensor) -> EpsFn:
    """z ↦ ε₀ + M (z − z₀), flattened: the field whose Jacobian is M everywhere. With M
    symmetric it is the gradient of E(z) = ε₀·(z − z₀) + ½ (z − z₀)ᵀ M (z − z₀)."""
    origin, offset = centre.reshape(-1), eps0.reshape(-1)

    def eps(z: Tensor) -> Tensor:
        return (offset + (z.reshape(z.shape[0], -1) - origin) @ matrix.T).reshape(z.shape)
    return eps


#: EMG-1's null control: a field twice the rule's tolerance in both readings
EMG1_NULL_READING = 2 * EMG1_LIMIT


def planted_fields(eps: EpsFn, centre: Tensor, jac: Tensor, identity_coefficient: float,
                   radius: float, reading: float = EMG1_NULL_READING
                   ) -> dict[str, tuple[float, float, float]]:
    """EMG-1's two controls at one of the experiment's points (its ``centre``, the model's
    ``eps`` and Jacobian ``jac`` there, its c and radius), each read by :func:`field_readings`:

    - **positive** (a gradient field): ε₀ + S (z − z₀), ε₀ = ε_θ(z₀) and S = (J + Jᵀ)/2 the
      model's own symmetric part — the gradient of a quadratic energy, so both readings are 0
      up to rounding;
    - **null** (no gradient field): ε₀ + (S + k K̂)(z − z₀), K̂ = (J − Jᵀ)/‖J − Jᵀ‖_F the
      model's own antisymmetric direction, k the smallest that brings both readings to
      ``reading``: the asymmetry in closed form (with M = S − cI, ‖A − Aᵀ‖ = 2k and ‖A‖² =
      ‖M‖² + k², so k = r‖M‖/√(4 − r²)), the loop integral by bisection on k above it.

    Returns kind → (residual asymmetry, relative loop integral, k; 0 for the positive)."""
    eps0 = eps(centre).detach()
    symmetric = 0.5 * (jac + jac.T)
    turning = jac - jac.T
    turning = turning / turning.norm().clamp_min(1e-30)
    residual = symmetric - identity_coefficient * torch.eye(jac.shape[0], dtype=jac.dtype,
                                                            device=jac.device)
    positive = field_readings(linear_field(eps0, centre, symmetric), centre,
                              identity_coefficient, radius)

    def loop(k: float) -> float:
        field = linear_field(eps0, centre, symmetric + k * turning)
        return field_readings(field, centre, identity_coefficient, radius)[1]

    low = reading * float(residual.norm()) / float(np.sqrt(4.0 - reading ** 2))
    high = low
    if loop(low) < reading:
        for _ in range(60):
            high *= 2.0
            if loop(high) >= reading:
                break
        else:
            raise ValueError(f"the null field's loop integral does not reach {reading}")
        for _ in range(40):
            mid = float(np.sqrt(low * high))
            low, high = (mid, high) if loop(mid) < reading else (low, mid)
    null = field_readings(linear_field(eps0, centre, symmetric + high * turning), centre,
                          identity_coefficient, radius)
    return {"positive": (*positive, 0.0), "null": (*null, high)}


def gradient_field_study(pipe: EnergyMoGenPipeline, seed: int, *, samples: int,
                         timesteps: Sequence[int]) -> dict[str, Any]:
    """EMG-1's two per-t measurements on ``energy_view_study``'s draws (``samples`` ground-truth
    latents of the composition items of ``seed`` noised with noise of ``seed``; the joined
    text and ∅): ``residual_jacobian_asymmetry_by_t`` and ``loop_integral_relative_by_t``
    (str(t) → median over samples × conditions), the per-sample values and the loop radii; and
    its two controls at the same points (:func:`planted_fields`), read the same way
    (``controls``: kind → the two by-t medians, the pooled residual asymmetry and the null's
    k per t)."""
    items = energy_view_items(pipe.data, seed, pipe.config.items_per_pair)
    z0 = pipe.encode_motion(items.gt_features[:samples])
    condition = pipe.encode(list(items.multi_texts[:samples]))
    noise = torch.randn(z0.shape, generator=torch.Generator().manual_seed(seed))
    names = ("residual_jacobian_asymmetry", "loop_integral_relative")
    readings: dict[str, dict[str, dict[str, list[float]]]] = {
        kind: {name: {} for name in names} for kind in ("experiment", *KINDS)}
    scale: dict[str, list[float]] = {}
    radii: dict[str, float] = {}
    for t in timesteps:
        z_t = pipe.diffusion.q_sample(z0, torch.full((samples,), t, dtype=torch.long), noise)
        one_minus = float(1.0 - pipe.diffusion.alphas_cumprod[t])
        radius, c = float(np.sqrt(one_minus)), 1.0 / np.sqrt(one_minus)
        key = str(t)
        radii[key] = radius
        for cond in (condition, None):
            for b in range(samples):
                eps = conditional_eps(pipe.denoiser, t, cond, b)
                jac = flat_jacobian(eps, z_t[b:b + 1])
                measured = {"experiment": field_readings(eps, z_t[b:b + 1], c, radius, jac)}
                planted = planted_fields(eps, z_t[b:b + 1], jac, c, radius)
                measured.update({kind: planted[kind][:2] for kind in KINDS})
                scale.setdefault(key, []).append(planted["null"][2])
                for kind, values in measured.items():
                    for name, value in zip(names, values, strict=True):
                        readings[kind][name].setdefault(key, []).append(value)

    def by_t(kind: str) -> dict[str, Any]:
        return {f"{name}_by_t": {k: float(np.median(v)) for k, v in readings[kind][name].items()}
                for name in names}

    return {**by_t("experiment"), "per_sample": readings["experiment"],
            "loop_radius_by_t": radii,
            "controls": {kind: {**by_t(kind), "pooled_residual_asymmetry": float(np.median(
                [v for values in readings[kind][names[0]].values() for v in values]))}
                for kind in KINDS},
            "null_scale_by_t": scale}


_DIM = 6
#: eigenvalues of the fixed covariances: none is 0 or 1 (no idempotent Σ), spread over [0.2, 3]
_LAMBDA_1 = np.array([0.2, 0.5, 0.9, 1.4, 2.0, 3.0])
_LAMBDA_2 = np.array([1.5, 0.3, 2.5, 0.7, 1.1, 0.4])


def _fixed_rotation(dim: int) -> np.ndarray:
    """A fixed orthogonal matrix (QR of a deterministic matrix, no random draw)."""
    grid = np.add.outer(np.arange(dim), 2 * np.arange(dim)).astype(np.float64)
    q, _ = np.linalg.qr(np.cos(grid) + np.eye(dim))
    return q


def fixed_cases() -> list[dict[str, Any]]:
    """The fixed cases: name, μ1, Σ1, μ2, Σ2 and the closed-form FID."""
    q = _fixed_rotation(_DIM)
    sigma = q @ np.diag(_LAMBDA_1) @ q.T
    mu = np.linspace(-1.0, 1.0, _DIM)
    shift = np.array([0.5, -1.0, 0.25, 0.0, 2.0, -0.75])
    mu2 = np.linspace(0.5, -0.5, _DIM)
    return [
        {"name": "equal covariances, shifted means", "mu1": mu, "sigma1": sigma,
         "mu2": mu + shift, "sigma2": sigma, "closed_form": float(shift @ shift)},
        {"name": "commuting diagonal covariances", "mu1": mu, "sigma1": np.diag(_LAMBDA_1),
         "mu2": mu2, "sigma2": np.diag(_LAMBDA_2),
         "closed_form": metrics.gaussian_fid_closed_form(mu, _LAMBDA_1, mu2, _LAMBDA_2)},
        {"name": "P = P", "mu1": mu, "sigma1": sigma, "mu2": mu, "sigma2": sigma,
         "closed_form": 0.0},
    ]


def _relative_error(value: float, case: dict[str, Any]) -> float:
    scale = abs(case["closed_form"]) if case["closed_form"] != 0 else float(
        np.trace(case["sigma1"]))
    return abs(value - case["closed_form"]) / scale


def fid_fixed_cases() -> dict[str, Any]:
    """EMG-9's three draw-independent measurements and the per-case values.

    ``fid_fixed_cases_max_relative_error``: ours against the closed form, the largest over the
    cases (P = P included); ``printed_self_distance``: |printed Eq. 12 at P = P| / Tr Σ;
    ``printed_fixed_cases_min_relative_error``: the printed form against the closed form, the
    smallest over the two cases with a non-zero closed form.
    """
    rows, ours, printed = [], [], []
    self_distance = float("nan")
    for case in fixed_cases():
        args = (case["mu1"], case["sigma1"], case["mu2"], case["sigma2"])
        value = metrics.frechet_distance(*args)
        as_printed = metrics.fid_as_printed_in_energymogen(*args)
        ours.append(_relative_error(value, case))
        if case["closed_form"] == 0:
            self_distance = abs(as_printed) / float(np.trace(case["sigma1"]))
        else:
            printed.append(_relative_error(as_printed, case))
        rows.append({"case": case["name"], "closed_form": case["closed_form"], "ours": value,
                     "printed_eq12": as_printed})
    return {"fid_fixed_cases_max_relative_error": float(max(ours)),
            "printed_self_distance": self_distance,
            "printed_fixed_cases_min_relative_error": float(min(printed)), "cases": rows}


def composition_study(source: PipelineSource, seeds: Sequence[int], *, per_case: int,
                      log: Callable[[str], None] | None = None
                      ) -> dict[str, Any] | NotMeasurable:
    """EMG-2 (latent-aware, Eq. 7/8) and EMG-3 (semantic-aware, Eq. 9), oracle-measured.

    Seed s uses the model ``pipeline_for(source, s)`` (one pipeline for every seed, or one
    trained model per seed: :class:`SeedPipelines`). Per seed, on the composition items
    (held-out pairs):
    conjunction = Eq. 7 with w_i = s (latent) / Eq. 9 with w^s = (1, 1) guided with s
    (semantic); baselines: each concept's text alone (guided with s), the unconditional
    model, and the joined single text. "best single concept" is, per held-out pair, the better
    of the two single-concept generations' both-present rates, averaged over pairs.
    Negation on :data:`NEGATION_CASES` (``per_case`` items each): Eq. 8 with w = s, i.e.
    ε(∅) + s(ε(c_i) − ε(c_j)) (latent), Eq. 9 with w^s = (1, −0.5), i.e. ẑ' = 2z'_i − z'_j,
    guided with s (semantic; our choice of weights); baseline: c_i alone (guided with s).

    Returns ``{"latent": measured, "semantic": measured, "extra": {...}, "examples": {...}}``
    where ``measured`` has the six registry names of EMG-2/3 as per-seed lists; on a data
    folder (no concepts to compose, no oracle labels) a ``data.NotMeasurable``.
    """
    if not pipeline_for(source, seeds[0]).data.labelled:
        return NotMeasurable(not_measurable_reason(pipeline_for(source, seeds[0]).data))
    names = ("conjunction_both_present", "best_single_concept_both_present",
             "negation_negated_present", "baseline_negated_present", "negation_kept_present",
             "baseline_kept_present")
    measured: dict[str, dict[str, list[float]]] = {m: {n: [] for n in names}
                                                  for m in ("latent", "semantic")}
    extra: dict[str, Any] = {k: [] for k in (
        "unconditional_both_present", "multi_text_both_present", "ground_truth_both_present",
        "single_concept_1_present", "single_concept_2_present")}
    extra["by_pair"] = {m: {"/".join(p): [] for p in HELD_OUT_PAIRS}
                        for m in ("latent", "semantic", "best_single", "multi_text")}
    # which concept a conjunction keeps: items list (lower, arm) in that order
    extra["conjunction_concept_present"] = {m: {"lower": [], "arm": []}
                                            for m in ("latent", "semantic", "multi_text")}
    examples: dict[str, np.ndarray] = {}
    for index, seed in enumerate(seeds):
        start = time.perf_counter()
        pipe = pipeline_for(source, seed)
        s = pipe.config.guidance_scale
        items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
        c1, c2 = items.concept_texts
        pairs = pair_index(items)

        def presence(sampler: Sampler, concept_texts: Sequence[Sequence[str]],
                     multi: Sequence[str] | None, concepts: Sequence[Sequence[str]],
                     batch: int, tag: str, seed: int = seed, keep: bool = index == 0,
                     pipe: EnergyMoGenPipeline = pipe) -> np.ndarray:
            joints = pipe.joints(pipe.decode(pipe.sample(sampler, concept_texts, multi, seed,
                                                         batch=batch)))
            if keep:
                examples[tag] = joints[0]
            return oracle_presence(joints, concepts)

        b = len(items)
        single1 = presence(Sampler("single"), [], c1, items.concepts, b, "concept 1")
        single2 = presence(Sampler("single"), [], c2, items.concepts, b, "concept 2")
        uncond = presence(Sampler("unconditional"), [], None, items.concepts, b, "∅")
        multi = presence(Sampler("single"), [], items.multi_texts, items.concepts, b, "multi")
        conj = {"latent": presence(Sampler("latent"), [c1, c2], None, items.concepts, b,
                                   "latent conjunction"),
                "semantic": presence(Sampler("semantic"), [c1, c2], None, items.concepts, b,
                                     "semantic conjunction")}
        best_pairs = np.maximum(per_pair_mean(single1.all(1), pairs),
                                per_pair_mean(single2.all(1), pairs))
        neg = negation_items(seed, per_case)
        neg_concepts = list(zip(neg.kept, neg.negated, strict=True))
        nb = len(neg)
        base = presence(Sampler("single"), [], neg.pair_texts, neg_concepts, nb, "c_i")
        negs = {"latent": presence(Sampler("latent", weights=(s, -s)),
                                   [neg.pair_texts, neg.negated_texts], None, neg_concepts, nb,
                                   "latent negation"),
                "semantic": presence(Sampler("semantic", semantic_weights=(1.0, -0.5)),
                                     [neg.pair_texts, neg.negated_texts], None, neg_concepts,
                                     nb, "semantic negation")}
        for mode in ("latent", "semantic"):
            m = measured[mode]
            m["conjunction_both_present"].append(float(conj[mode].all(1).mean()))
            m["best_single_concept_both_present"].append(float(best_pairs.mean()))
            m["negation_negated_present"].append(float(negs[mode][:, 1].mean()))
            m["baseline_negated_present"].append(float(base[:, 1].mean()))
            m["negation_kept_present"].append(float(negs[mode][:, 0].mean()))
            m["baseline_kept_present"].append(float(base[:, 0].mean()))
        gt = oracle_presence(items.gt_joints, items.concepts)
        extra["unconditional_both_present"].append(float(uncond.all(1).mean()))
        extra["multi_text_both_present"].append(float(multi.all(1).mean()))
        extra["ground_truth_both_present"].append(float(gt.all(1).mean()))
        extra["single_concept_1_present"].append(float(single1[:, 0].mean()))
        extra["single_concept_2_present"].append(float(single2[:, 1].mean()))
        for mode, found in (("latent", conj["latent"]), ("semantic", conj["semantic"]),
                            ("multi_text", multi)):
            extra["conjunction_concept_present"][mode]["lower"].append(float(found[:, 0].mean()))
            extra["conjunction_concept_present"][mode]["arm"].append(float(found[:, 1].mean()))
        per_pair = {"latent": per_pair_mean(conj["latent"].all(1), pairs),
                    "semantic": per_pair_mean(conj["semantic"].all(1), pairs),
                    "best_single": best_pairs,
                    "multi_text": per_pair_mean(multi.all(1), pairs)}
        for mode, values in per_pair.items():
            for p, value in zip(np.unique(pairs), values, strict=True):
                extra["by_pair"][mode]["/".join(HELD_OUT_PAIRS[p])].append(float(value))
        if log is not None:
            log(f"seed {seed}: {time.perf_counter() - start:.1f} s")
    return {"latent": measured["latent"], "semantic": measured["semantic"], "extra": extra,
            "examples": examples}


def composition_reference_rates(pipe: EnergyMoGenPipeline, seed: int, per_case: int
                                ) -> dict[str, float]:
    """The reference arms of ``composition_study`` at ``seed`` sampled from ``pipe``: the best
    single concept's both-present rate (per held-out pair the better of the two single-concept
    generations, averaged over pairs) and the negation baseline's (c_i alone) negated- and
    kept-concept rates — the same items, texts, noise and batches as the study's, so on the
    study's own pipeline the same numbers, and on another training the A/A copy's."""
    items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
    c1, c2 = items.concept_texts
    pairs = pair_index(items)

    def presence(texts: Sequence[str], concepts: Sequence[Sequence[str]]) -> np.ndarray:
        motion = pipe.decode(pipe.sample(Sampler("single"), [], texts, seed, batch=len(texts)))
        return oracle_presence(pipe.joints(motion), concepts)

    single1, single2 = presence(c1, items.concepts), presence(c2, items.concepts)
    best = np.maximum(per_pair_mean(single1.all(1), pairs), per_pair_mean(single2.all(1), pairs))
    neg = negation_items(seed, per_case)
    base = presence(neg.pair_texts, list(zip(neg.kept, neg.negated, strict=True)))
    return {"best_single_concept_both_present": float(best.mean()),
            "baseline_negated_present": float(base[:, 1].mean()),
            "baseline_kept_present": float(base[:, 0].mean())}


def composition_controls(source: PipelineSource, study: Mapping[str, Any] | NotMeasurable,
                         seeds: Sequence[int], *, per_case: int) -> dict[str, Controls] | None:
    """EMG-2/3's controls as A/A runs (``harness.aa_controls``). The reference arms are the
    study's baselines (the best single concept for conjunction, c_i alone for negation); the
    null is seed s's baselines (the study's) against the same baselines sampled, with seed
    s's items, texts and noise, from the pipeline of seed s' = ``copy_seed(seeds, s)`` (the
    run's next seed, cyclic, already trained; one seed: s + 1) in the compared arms' places:
    conjunction = the copy's best single concept, negation's negated rate = the copy's
    baseline negated rate, its kept rate = half the copy's baseline kept rate (the rule reads
    2·kept / baseline: the null sits on its threshold). Positive: the same A/A with twice each
    part's δ planted on the compared arm in the paper's direction. One copy per seed serves
    both claims (their baselines are the same samples). Returns ``{"EMG-2": controls,
    "EMG-3": controls}``; None on a data folder (``composition_study`` not measurable)."""
    if isinstance(study, NotMeasurable):
        return None
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    copy: dict[str, list[float]] = {}
    for seed, other in copies.items():
        rates = composition_reference_rates(pipeline_for(source, other), seed, per_case)
        for name, value in rates.items():
            copy.setdefault(name, []).append(value)
    slots = [AASlot(("conjunction_both_present",), ("best_single_concept_both_present",)),
             AASlot(("negation_negated_present",), ("baseline_negated_present",)),
             AASlot(("negation_kept_present",), ("baseline_kept_present",), factor=0.5)]
    targets = {"conjunction_carries_both": [("conjunction_both_present",)],
               "negation_removes_concept": [("negation_negated_present",)],
               "negation_keeps_other": [("negation_kept_present",)]}
    return {claim_id: aa_controls(claim_id, study[mode], copy, slots, targets, copies=copies,
                                  what="the baselines (best single concept, c_i alone)")
            for claim_id, mode in (("EMG-2", "latent"), ("EMG-3", "semantic"))}


def energy_map_controls(source: PipelineSource,
                        measured: Mapping[str, Sequence[float]] | NotMeasurable,
                        seeds: Sequence[int], *, count: int | None = None, **kwargs: Any
                        ) -> Controls | None:
    """EMG-6's controls as A/A runs (``harness.aa_controls``). The reference arm is the floor,
    r(one concept alone's map, the multi-concept map), a reading that lives in one pipeline's
    latent plane (maps of two trainings are on different latent coordinates, so a reading is
    compared, never a map). The null: seed s's floor against the floor read the same way
    (:func:`energy_map_study` with ``count`` and ``kwargs``: seed s's cases, noise draws and
    grid) on the pipeline of seed s' = ``copy_seed(seeds, s)`` (the run's next seed, cyclic;
    one seed: s + 1), in the composed arm's place, per case kind. Positive: the same A/A with
    twice δ (0.2 in r) added to the composed arm. None for a ``NotMeasurable`` (a data
    folder: no maps, no claim to control)."""
    if isinstance(measured, NotMeasurable):
        return None
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    copy = map_similarities(energy_map_study(copy_source(source, copies), seeds, count=count,
                                             **kwargs))
    if isinstance(copy, NotMeasurable):
        return None
    slots = [AASlot((f"{kind}_similarity_to_multi",), (f"{kind}_similarity_floor",))
             for kind in MAP_KINDS]
    return aa_controls("EMG-6", measured, copy, slots,
                       {kind: [(f"{kind}_similarity_to_multi",)] for kind in MAP_KINDS},
                       copies=copies, what="the floor (one concept alone's map ~ multi)")


#: the per-case values EMG-6 keeps beside its per-seed measurements
_CASE_KEYS = ("case", "control", "texts", "similarity_to_multi", "similarity_floor",
              "similarity_ceiling", "similarity_concept_1_to_multi",
              "similarity_concept_2_to_multi", "similarity_to_control", "raw_similarity_to_multi",
              "raw_similarity_to_control")


def emg1_result(energy_view: Mapping[str, Any], field: Mapping[str, Any],
                settings: EnergyViewSettings, seed: int, *,
                models: Sequence[Mapping[str, Any]], figures: Sequence[str | os.PathLike]
                ) -> ClaimResult:
    """EMG-1 from ``energy_view_study`` (``energy_view``: the Langevin-step and
    sum-of-energies errors, the Jacobian asymmetry) and ``gradient_field_study``
    (``field``: the residual asymmetry and loop integrals by t), both at ``seed``."""
    langevin, linearity = energy_view["langevin"], energy_view["linearity"]
    sum_error, jacobian_median = energy_view["sum_error"], energy_view["jacobian_median"]
    asym, jac_timesteps = energy_view["asymmetry"], settings.jacobian_timesteps
    measured = {"langevin_step_max_abs_error": langevin["max_abs_error"],
                "sum_of_energies_max_abs_error": sum_error,
                "jacobian_relative_asymmetry": jacobian_median,
                "residual_jacobian_asymmetry_by_t": field["residual_jacobian_asymmetry_by_t"],
                "loop_integral_relative_by_t": field["loop_integral_relative_by_t"]}
    headline = (f"Langevin form exact (|Δ| ≤ {langevin['max_abs_error']:.1e}); energies add "
                f"(|Δ| ≤ {sum_error:.1e}); Jacobian asymmetry of ε_θ {jacobian_median:.2f} "
                f"(random init {np.median(asym['random init, text']):.2f})")
    notes = ("Energy with ∇E_t = ε_θ/√(1−ᾱ_t); DDPM and DDIM steps are exact Langevin steps on "
             "E_t − κ_t‖z‖²/2 with step η_t (float64, all 1000 t); Eq. 5's η = 1 is the "
             "small-β reading (exact coefficient on ε in "
             f"[{langevin['ddpm_eps_coefficient_min']:.1e}, "
             f"{langevin['ddpm_eps_coefficient_max']:.1e}]). Sum of energies: line-integral "
             "energies (16-node Gauss–Legendre from 0, float64 copy of the denoiser) of the "
             f"Eq. 7 sampler (w = s = {settings.pipeline.guidance_scale}) vs E∅ + Σ w(E_i − E∅), "
             f"t ∈ {set(settings.linearity_timesteps)}. Jacobian: "
             f"{settings.emg1_samples} noised test latents × t ∈ {list(jac_timesteps)}, with the "
             "joined text and ∅; median pooled.")
    if "data_dir" in energy_view:
        notes += (f" Data folder {energy_view['data_dir']} (real data): the test latents are its "
                  "test windows, the joined text one of each window's captions and the two "
                  "summed conditions two captions of different windows (Eq. 5–7's identities "
                  "hold for any conditions; nothing composed is read).")
    extra = {"ddpm_max_abs_error": langevin["ddpm_max_abs_error"],
             "ddim_max_abs_error": langevin["ddim_max_abs_error"],
             "eps_coefficient_range": [langevin["ddpm_eps_coefficient_min"],
                                       langevin["ddpm_eps_coefficient_max"]],
             "line_integral_gradient_relative_error": [x["gradient_relative_error"]
                                                       for x in linearity],
             "loop_radius_by_t": field["loop_radius_by_t"],
             "residual_and_loop_per_sample": field["per_sample"],
             "jacobian_asymmetry_by_t": {name: dict(zip(map(str, jac_timesteps),
                                                        np.median(v, axis=1).tolist(),
                                                        strict=True))
                                         for name, v in asym.items()}}
    return ClaimResult("EMG-1", measured, seeds=[seed], settings=rule_settings.emg1(settings),
                       controls=gradient_field_controls(measured, field), models=models,
                       figures=figures, headline=headline, notes=notes, extra=extra)


def gradient_field_controls(measured: Mapping[str, Any], field: Mapping[str, Any]) -> Controls:
    """EMG-1's controls as the rule reads them: the experiment's algebra (the sampler's and the
    composition's identities hold for any field: the controls replace the field only) with
    each control field's readings at the experiment's points (``field["controls"]``,
    :func:`planted_fields`)."""
    algebra = {name: measured[name] for name in ("langevin_step_max_abs_error",
                                                 "sum_of_energies_max_abs_error")}
    arms = {kind: {**algebra, "residual_jacobian_asymmetry_by_t":
                   readings["residual_jacobian_asymmetry_by_t"],
                   "loop_integral_relative_by_t": readings["loop_integral_relative_by_t"],
                   "jacobian_relative_asymmetry": readings["pooled_residual_asymmetry"]}
            for kind, readings in field["controls"].items()}
    return Controls(null=arms["null"], positive=arms["positive"],
                    planted={"null_reading": EMG1_NULL_READING,
                             "null_scale_by_t": field["null_scale_by_t"]},
                    null_text=(f"at every point of the experiment, the model's field with its "
                               f"own antisymmetric part at the smallest size that brings both "
                               f"readings to {EMG1_NULL_READING:g} (twice the tolerance): "
                               f"ε₀ + (S + kK̂)"
                               f"(z − z₀)"),
                    positive_text=("at every point of the experiment, the model's field made a "
                                   "gradient: ε₀ + S(z − z₀), S the symmetric part of its "
                                   "Jacobian there"))


def map_cases_markdown(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                       | NotMeasurable, seeds: Sequence[int]) -> str:
    """Notebook 04's table of EMG-6's cases (``energy_map_study``): per kind, seed and
    case the floor, composed, ceiling and control similarities and the raw maps'; on a data
    folder the reason it is not measurable."""
    if isinstance(cases, NotMeasurable):
        return f"**EMG-6 energy maps**: {cases.reason}."
    rows = [[kind, sd, case["case"], f"{case['similarity_floor']:.3f}",
             f"{case['similarity_to_multi']:.3f}", f"{case['similarity_ceiling']:.3f}",
             f"{case['similarity_to_control']:.3f}",
             f"{case['raw_similarity_to_multi']:.4f} / {case['raw_similarity_to_control']:.4f}"]
            for kind, per_seed in cases.items() for sd, found in zip(seeds, per_seed, strict=True)
            for case in found]
    return markdown_table(
        ["kind", "seed", "case", "floor (one concept)", "composed", "ceiling (paraphrase)",
         "control", "raw maps: composed~multi / ~control"], rows)


def map_similarity_markdown(measured: Mapping[str, Sequence[float]] | NotMeasurable) -> str:
    """Notebook 04's table of EMG-6's similarities per kind (mean ± 95 % half-width over
    seeds): the floor, composed ~ multi, the ceiling and the unrelated control."""
    if isinstance(measured, NotMeasurable):
        return f"**EMG-6 map similarities**: {measured.reason}."
    return markdown_table(
        ["kind", "floor: one concept ~ multi", "composed ~ multi", "ceiling: paraphrase ~ multi",
         "composed ~ unrelated control"],
        [[kind] + [interval_text(measured[f"{kind}_similarity_{what}"])
                   for what in ("floor", "to_multi", "ceiling", "to_control")]
         for kind in MAP_KINDS])


def emg6_result(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]] | NotMeasurable,
                measured: Mapping[str, Sequence[float]] | NotMeasurable,
                settings: EnergyViewSettings, seeds: Sequence[int], *, controls: Controls | None,
                models: Sequence[Mapping[str, Any]], figures: Sequence[str | os.PathLike]
                ) -> ClaimResult:
    """EMG-6 from ``map_similarities`` (``measured``: per kind and seed, composed ~
    multi, the floor, the ceiling and the control) and the cases behind it (``cases``: kind →
    one list of ``energy_map_case`` results per seed); on a data folder (``cases`` a
    ``NotMeasurable``) not measurable on real data (``claims.result.not_measurable_result``)."""
    if isinstance(cases, NotMeasurable):
        return not_measurable_result("EMG-6", cases.reason, seeds,
                                     settings=rule_settings.emg6(settings), models=models)
    headline = ("Pearson r with the multi-concept map, floor / composed / ceiling: " + "; ".join(
        f"{kind} " + "/".join(f"{np.mean(measured[f'{kind}_similarity_{what}']):.3f}"
                              for what in ("floor", "to_multi", "ceiling"))
        for kind in MAP_KINDS))
    notes = ("Energy = denoising loss E_t,ε‖ε̂(z_t,t) − ε‖²/dim (t ∈ {100,…,900}, "
             f"{settings.map_noise_draws} draws, common "
             "random numbers); maps compared: the conditional part E_k − E_∅ (fixed after the "
             "quick test, where raw maps of an untrained model correlated ≥ 0.999 for any texts, "
             "before any full run; raw-map similarities in extra); composed "
             "= Eq. 7 unit weights / Eq. 8 w = 1; slice = PC1–PC2 of generated latents; 16×16 "
             "grid, cubic ×4, Gaussian σ = 2; similarity = Pearson r. "
             "Floor: one concept alone ~ multi (conjunction: the better concept; negation: c_i); "
             "ceiling: a paraphrase of the multi-concept text ~ multi; context: composed ~ "
             "unrelated control (conjunction — joined text of a disjoint held-out pair; "
             "negation — another concept of the kept concept's group). Every held-out pair and "
             "negation case per seed (mean per seed), each seed on its own trained model "
             "(training seed data_seed + s for seed s).")
    extra = {"cases": {kind: [[{k: c[k] for k in _CASE_KEYS} for c in found]
                              for found in per_seed] for kind, per_seed in cases.items()},
             "control_calibration": controls.planted}
    return ClaimResult("EMG-6", dict(measured), seeds=seeds,
                       settings=rule_settings.emg6(settings), controls=controls, models=models,
                       figures=figures, headline=headline, notes=notes, extra=extra)


def raw_maps_markdown(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                      | NotMeasurable) -> str:
    """EMG-6's sentence on the raw maps (E_k itself) against the conditional ones the rule
    compares: the range of each over every case of this run (none on a data folder)."""
    if isinstance(cases, NotMeasurable):
        return ""
    raw = [c[f"raw_similarity_to_{what}"] for per_seed in cases.values() for found in per_seed
           for c in found for what in ("multi", "control")]
    conditional = [c[key] for per_seed in cases.values() for found in per_seed for c in found
                   for key in ("similarity_to_multi", "similarity_floor")]
    return render(
        "In this run the raw maps (E_k itself, before subtracting E_∅) correlate {low:.4f} to "
        "{high:.4f} over every case, composed~multi and composed~control alike; the "
        "conditional maps that the rule compares (composed ~ multi and the floor), {clow:.3f} "
        "to {chigh:.3f}.",
        low=min(raw), high=max(raw), clow=min(conditional), chigh=max(conditional))


def emg9_result(fid_check: Mapping[str, Any], fixed: Mapping[str, Any], seed: int
                ) -> ClaimResult:
    """EMG-9 from ``fid_formula_errors`` (``fid_check``, random commuting Gaussians of
    ``seed``) and ``fid_fixed_cases`` (``fixed``, no random draw)."""
    measured = {
        "fid_vs_closed_form_relative_error": fid_check["fid_vs_closed_form_relative_error"],
        "printed_vs_closed_form_relative_error":
            fid_check["printed_vs_closed_form_relative_error"],
        **{k: fixed[k] for k in ("fid_fixed_cases_max_relative_error", "printed_self_distance",
                                 "printed_fixed_cases_min_relative_error")}}
    headline = (f"ours vs closed form ≤ {fid_check['fid_vs_closed_form_relative_error']:.1e} "
                f"relative; printed Eq. 12 off by ≥ "
                f"{fid_check['printed_vs_closed_form_relative_error']:.2f} relative")
    notes = ("20 random pairs of 16-d Gaussians with commuting covariances (λ ∈ [0.1, 3]); ours: "
             "the largest relative error; printed: the smallest (it is off in every draw).")
    return ClaimResult("EMG-9", measured, seeds=[seed], headline=headline, notes=notes,
                       extra={"draws": fid_check["draws"][:5], "fixed_cases": fixed["cases"]})


def fid_draws_markdown(fid_check: Mapping[str, Any], shown: int = 5) -> str:
    """The first ``shown`` random draws of ``fid_formula_errors``: the closed form, ours
    and the printed Eq. 12."""
    lines = ["| draw | closed form | ours (Eq. with √ and +Tr) | printed Eq. 12 |",
             "|---|---|---|---|"]
    for k, row in enumerate(fid_check["draws"][:shown]):
        lines.append(f"| {k} | {row['closed_form']:.6g} | {row['ours']:.6g} | "
                     f"{row['printed_eq12']:.6g} |")
    return "\n".join(lines)


def fid_fixed_cases_markdown(fixed: Mapping[str, Any]) -> str:
    """``fid_fixed_cases``'s cases: the closed form, ours and the printed Eq. 12."""
    return "**Fixed cases (no random draw)**\n\n" + markdown_table(
        ["case", "closed form", "ours", "printed Eq. 12"],
        [[r["case"], f"{r['closed_form']:.6g}", f"{r['ours']:.6g}", f"{r['printed_eq12']:.6g}"]
         for r in fixed["cases"]])


def composition_study_text(study: Mapping[str, Any] | NotMeasurable) -> str:
    """The lines notebook 04 prints for ``composition_study``: each mode's six rates
    (mean ± 95 % half-width, per seed), the baselines and which concept a conjunction keeps;
    on a data folder the study's reason (``data.NotMeasurable``)."""
    if isinstance(study, NotMeasurable):
        return f"EMG-2/3: {study.reason}."
    lines, extra23 = [], study["extra"]
    for mode in ("latent", "semantic"):
        lines.append(f"--- {mode}")
        for name, values in study[mode].items():
            lines.append(f"{name:36s} {interval_text(values)}   "
                         f"per seed {np.round(values, 3).tolist()}")
    for name in ("unconditional_both_present", "multi_text_both_present",
                 "ground_truth_both_present", "single_concept_1_present",
                 "single_concept_2_present"):
        lines.append(f"{name:36s} {interval_text(extra23[name])}")
    for mode, rates in extra23["conjunction_concept_present"].items():
        lines.append(f"which concept survives ({mode}): leg/locomotion concept "
                     f"{interval_text(rates['lower'])}, arm concept {interval_text(rates['arm'])}")
    return "\n".join(lines)


def by_pair_markdown(study: Mapping[str, Any] | NotMeasurable) -> str:
    """Notebook 04's table of both-concepts-found rates by held-out pair (mean over seeds)."""
    if isinstance(study, NotMeasurable):
        return f"**Both concepts found, by held-out pair**: {study.reason}."
    by_pair = study["extra"]["by_pair"]
    rows = [[pair] + [f"{np.mean(by_pair[m][pair]):.2f}" if by_pair[m][pair] else "—"
                      for m in ("best_single", "multi_text", "latent", "semantic")]
            for pair in by_pair["latent"]]
    return ("**Both concepts found, by held-out pair (mean over seeds)**\n\n"
            + markdown_table(["held-out pair", "best single", "joined text", "latent Eq. 7",
                              "semantic Eq. 9"], rows))


def emg23_results(study: Mapping[str, Any] | NotMeasurable,
                  controls: Mapping[str, Controls] | None,
                  settings: EnergyViewSettings, seeds: Sequence[int], *, models: Models,
                  figures: Figures) -> tuple[ClaimResult, ClaimResult]:
    """EMG-2 (latent Eq. 7/8) and EMG-3 (semantic Eq. 9) from ``composition_study``
    (``study``) and ``composition_controls`` (``controls``: claim → its controls),
    with the study's baselines and per-pair rates beside them. On a data folder (``study`` a
    ``data.NotMeasurable``) both are not measurable on real data: nothing is recorded as
    measured (``claims.result.not_measurable_result``)."""
    if isinstance(study, NotMeasurable):
        used = rule_settings.emg23(settings)
        return (not_measurable_result("EMG-2", study.reason, seeds, settings=used, models=models),
                not_measurable_result("EMG-3", study.reason, seeds, settings=used, models=models))
    config, per_case, extra23 = settings.pipeline, settings.negation_items_per_case, study["extra"]
    choice_note = (f"Guidance s = {config.guidance_scale}; Eq. 7 w_i = s; Eq. 8 w = s; Eq. 9 "
                   "conjunction w^s = (1, 1), negation w^s = (1, −0.5), guided with s. "
                   f"Conjunction on the {len(HELD_OUT_PAIRS)} held-out pairs "
                   f"({config.items_per_pair} items each per seed); negation on "
                   f"{len(NEGATION_CASES)} trained pairs ({per_case} items each). Oracles: "
                   "repro.oracles.detect_concepts on the decoded joints. One trained model per "
                   "seed (VAE and denoiser trained with training seed data_seed + s for seed s; "
                   "data, frozen text encoder and evaluator fixed); seeds also vary items and "
                   "noise. Stand-in captions are complete (a single-concept clip keeps its "
                   "other body parts idle), so the product of single-concept conditionals "
                   "behind Eq. 7 is narrow; the joined-text rate is in extra.")
    read = {c for pair in HELD_OUT_PAIRS for c in pair} | {
        c for pair, _ in NEGATION_CASES for c in pair}
    if read & set(TRAVEL_CONCEPTS):
        choice_note += " " + GLIDE_NOTE
    emg_extra = {"conjunction_concept_present": extra23["conjunction_concept_present"],
                 "unconditional_both_present": extra23["unconditional_both_present"],
                 "multi_text_both_present": extra23["multi_text_both_present"],
                 "ground_truth_both_present": extra23["ground_truth_both_present"],
                 "by_pair": extra23["by_pair"]}

    def result(claim_id: str, mode: str, form: str) -> ClaimResult:
        m = study[mode]
        headline = (f"{form}: both concepts {np.mean(m['conjunction_both_present']):.2f} vs "
                    f"best single {np.mean(m['best_single_concept_both_present']):.2f}; negated "
                    f"concept {np.mean(m['negation_negated_present']):.2f} vs "
                    f"{np.mean(m['baseline_negated_present']):.2f}; kept "
                    f"{np.mean(m['negation_kept_present']):.2f} vs "
                    f"{np.mean(m['baseline_kept_present']):.2f}")
        return ClaimResult(claim_id, m, seeds=seeds, settings=rule_settings.emg23(settings),
                           controls=controls[claim_id], models=models,
                           figures=figures, headline=headline, notes=choice_note,
                           extra={**emg_extra,
                                  "control_calibration": controls[claim_id].planted})

    return (result("EMG-2", "latent", "latent Eq. 7/8"),
            result("EMG-3", "semantic", "semantic Eq. 9"))


def guidance_scale_check(pipes: Callable[[int], EnergyMoGenPipeline],
                         settings: EnergyViewSettings, seeds: Sequence[int], *,
                         log: Callable[[str], None] = print) -> None:
    """Does EMG-2/3's verdict hinge on the guidance scale s? Their rules applied at each of
    ``settings.scale_check_scales`` on the first ``scale_check_seeds`` seeds (each its own
    model, ``pipes(seed)``) with fewer items; logged, not recorded, paper scale only."""
    if not settings.scale_check:
        log(f"{settings.scale} run: scale check skipped (paper scale only)")
        return
    if not pipes(seeds[0]).data.labelled:
        log(f"scale check: {not_measurable_reason(pipes(seeds[0]).data)}")
        return
    start = time.perf_counter()
    for other in settings.scale_check_scales:
        other_config = dataclasses.replace(settings.pipeline, guidance_scale=other,
                                           items_per_pair=settings.scale_check_items_per_pair)

        def other_pipe(sd: int, other_config: Any = other_config) -> EnergyMoGenPipeline:
            return dataclasses.replace(pipes(sd), config=other_config)

        other_study = composition_study(other_pipe, seeds[:settings.scale_check_seeds],
                                        per_case=settings.scale_check_items_per_case)
        for claim_id, mode in (("EMG-2", "latent"), ("EMG-3", "semantic")):
            decision = get_claim(claim_id).decide(other_study[mode])
            means = {k: round(float(np.mean(v)), 2) for k, v in other_study[mode].items()}
            log(f"s = {other}: {claim_id} {decision.verdict} — {means}")
    log(f"scale check took {time.perf_counter() - start:.1f} s")


def jacobian_asymmetry_figure(asymmetry: Mapping[str, np.ndarray], timesteps: Sequence[int],
                              diffusion: GaussianDiffusion) -> Figure:
    """EMG-1: ‖J − Jᵀ‖/‖J‖ by timestep (``asymmetry``: name → (timesteps, samples)) beside the
    exact DDPM coefficient on ε_θ that Eq. 5–6 writes as 1."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    positions = np.arange(len(timesteps))
    for k, (name, values) in enumerate(asymmetry.items()):
        axes[0].boxplot(values.T, positions=positions + 0.25 * (k - 1), widths=0.22,
                        patch_artist=True, boxprops={"facecolor": f"C{k}", "alpha": 0.6},
                        medianprops={"color": "black"}, showfliers=False)
        axes[0].plot([], [], color=f"C{k}", lw=6, alpha=0.6, label=name)
    axes[0].axhline(0.1, color="grey", ls="--", lw=1, label="rule: ≤ 0.1")
    axes[0].axhline(np.sqrt(2), color="grey", ls=":", lw=1, label="random matrix ≈ √2")
    axes[0].set_yscale("log")
    axes[0].set_xticks(positions, [str(t) for t in timesteps])
    axes[0].set_xlabel("timestep t")
    axes[0].set_ylabel("‖J − Jᵀ‖ / ‖J‖")
    axes[0].set_title("Is ε_θ a gradient field? (J = ∂ε_θ/∂z_t)", fontsize=10)
    axes[0].legend(fontsize=7)
    steps = np.arange(diffusion.num_timesteps)
    beta, alpha = diffusion.betas, diffusion.alphas
    coefficient = beta / np.sqrt(alpha) / np.sqrt(1 - diffusion.alphas_cumprod)
    axes[1].semilogy(steps, coefficient, label="exact DDPM coefficient on ε_θ")
    axes[1].axhline(1.0, color="C3", ls="--", label="Eq. 5–6: η = 1")
    axes[1].set_xlabel("timestep t")
    axes[1].set_title("Step size of the Langevin reading", fontsize=10)
    axes[1].legend(fontsize=8)
    return fig


def _bar_panel(ax: Axes, labels: Sequence[str], series: Sequence[Sequence[float]], title: str,
               ylabel: str) -> None:
    """Bars of the per-seed means with the seeds as dots."""
    for k, values in enumerate(series):
        values = np.asarray(values)
        ax.bar(k, values.mean(), color=f"C{k}", alpha=0.7)
        ax.plot(np.full(len(values), k) + np.linspace(-0.15, 0.15, len(values)), values, "k.",
                ms=4)
    ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right", fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)


def composition_oracle_figure(study: Mapping[str, Any], seeds: Sequence[int],
                              guidance_scale: float) -> Figure:
    """EMG-2/3 (``composition_study``): conjunction both-present rates beside the
    baselines, and negation's negated and kept concepts."""
    lat, sem, extra = study["latent"], study["semantic"], study["extra"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    _bar_panel(axes[0], ["best single\nconcept", "∅", "joined text", "latent\nEq. 7",
                         "semantic\nEq. 9", "ground truth"],
               [lat["best_single_concept_both_present"], extra["unconditional_both_present"],
                extra["multi_text_both_present"], lat["conjunction_both_present"],
                sem["conjunction_both_present"], extra["ground_truth_both_present"]],
               "Conjunction (held-out pairs): both concepts found", "fraction of samples")
    _bar_panel(axes[1], ["c_i alone", "latent\nEq. 8", "semantic\nEq. 9"],
               [lat["baseline_negated_present"], lat["negation_negated_present"],
                sem["negation_negated_present"]], "Negation: negated concept still found", "")
    _bar_panel(axes[2], ["c_i alone", "latent\nEq. 8", "semantic\nEq. 9"],
               [lat["baseline_kept_present"], lat["negation_kept_present"],
                sem["negation_kept_present"]], "Negation: kept concept found", "")
    fig.suptitle(f"Dots: seeds {list(seeds)} (one trained model each); s = {guidance_scale}",
                 fontsize=9)
    return fig


def composition_examples_figure(examples: Mapping[str, np.ndarray]) -> Figure:
    """One filmstrip per sampler of ``composition_study``'s first item."""
    fig, axes = plt.subplots(len(examples), 1, figsize=(10, 1.9 * len(examples)))
    for ax, (name, joints) in zip(axes, examples.items(), strict=True):
        filmstrip(joints, frames=8, ax=ax, title=name)
    fig.suptitle("First item of the first seed, default model (conjunction: "
                 + " + ".join(HELD_OUT_PAIRS[0]) + "; negation: "
                 + " not ".join([" & ".join(NEGATION_CASES[0][0]), NEGATION_CASES[0][1]])
                 + ")", fontsize=9)
    return fig


_MAP_COLUMNS = ("concept 1", "concept 2", "composed", "multi-concept", "paraphrase",
                "control")


def save_composition_figures(study: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int],
                             scale: float, figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 04's EMG-2/3 figures saved under ``figure_path(name)``:
    :func:`composition_oracle_figure` and :func:`composition_examples_figure` (their paths, in
    that order); none for a ``NotMeasurable`` study (a data folder)."""
    if isinstance(study, NotMeasurable):
        return []
    return [save_figure(composition_oracle_figure(study, seeds, scale),
                        figure_path("emg2_emg3_composition_oracles.png")),
            save_figure(composition_examples_figure(study["examples"]),
                        figure_path("emg2_emg3_examples.png"))]


def save_energy_map_figures(cases: Mapping[str, Any] | NotMeasurable,
                            measured: Mapping[str, Sequence[float]] | NotMeasurable,
                            seeds: Sequence[int], figure_path: Callable[[str], Path]
                            ) -> list[Path]:
    """Notebook 04's EMG-6 figures saved under ``figure_path(name)``: the first case of each
    kind on the first seed (:func:`energy_maps_figure`) and :func:`map_similarity_figure`
    (their paths, in that order); none when not measurable (a data folder)."""
    if isinstance(cases, NotMeasurable) or isinstance(measured, NotMeasurable):
        return []
    return [save_figure(energy_maps_figure({kind: per_seed[0][0]
                                            for kind, per_seed in cases.items()}, seeds[0]),
                        figure_path("emg6_energy_contour_maps.png")),
            save_figure(map_similarity_figure(measured), figure_path("emg6_map_similarity.png"))]


def energy_maps_figure(cases: Mapping[str, Mapping[str, Any]], seed: int) -> Figure:
    """EMG-6 as Fig. 5/6: one row per kind (``energy_map_case`` results of one seed),
    the smoothed conditional maps of every condition with that row's samples."""
    fig, axes = plt.subplots(2, len(_MAP_COLUMNS), figsize=(20, 6.6))
    for row, kind in enumerate(("conjunction", "negation")):
        case = cases[kind]
        extent = [-case["extent"][0], case["extent"][0], -case["extent"][1], case["extent"][1]]
        levels = np.linspace(min(case["smooth"][c].min() for c in _MAP_COLUMNS),
                             max(case["smooth"][c].max() for c in _MAP_COLUMNS), 14)
        if levels[0] == levels[-1]:
            levels = np.linspace(levels[0] - 1e-9, levels[0] + 1e-9, 3)
        for col, name in enumerate(_MAP_COLUMNS):
            ax = axes[row, col]
            ax.contourf(case["smooth"][name], levels=levels, cmap="viridis", extent=extent,
                        origin="lower")
            ax.contour(case["smooth"][name], levels=levels, colors="k", linewidths=0.3,
                       extent=extent, origin="lower")
            key = {"concept 1": "c1", "concept 2": "c2", "multi-concept": "multi",
                   "paraphrase": "ceiling", "control": "control"}.get(name)
            text = case["texts"][key] if key else (
                "Eq. 7 (unit weights)" if kind == "conjunction" else "Eq. 8 (w = 1)")
            if name in case["scores"]:
                pts = case["scores"][name]
                ax.plot(pts[:, 0], pts[:, 1], "w.", ms=3)
            ax.set_title(f"{name}\n" + "\n".join(textwrap.wrap(text, 34)), fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
        axes[row, 0].set_ylabel(f"{kind}: {case['case']}", fontsize=8)
    fig.suptitle("Conditional part of the denoising-loss energy, E_k − E_∅, on the PC1–PC2 "
                 "slice of generated latents (dark = low energy; white dots: that row's "
                 f"samples). Seed {seed} (default model).", fontsize=9)
    return fig


def map_similarity_figure(measured: Mapping[str, Sequence[float]]) -> Figure:
    """EMG-6's numbers (``map_similarities``): per kind, the floor (one concept alone ~
    multi), composed ~ multi and the ceiling (a paraphrase ~ multi), one line per seed (each
    seed the mean over its cases); composed ~ unrelated control as grey crosses."""
    fig, ax = plt.subplots(figsize=(8, 3.8))
    ticks, labels = [], []
    for k, kind in enumerate(("conjunction", "negation")):
        x = 4 * k + np.arange(3)
        values = np.array([measured[f"{kind}_similarity_{what}"]
                           for what in ("floor", "to_multi", "ceiling")])      # (3, seeds)
        for seed_values in values.T:
            ax.plot(x, seed_values, "-", color="grey", lw=0.8)
        for xi, row, marker, colour in zip(x, values, ("v", "o", "^"), ("C3", "C0", "C2"),
                                           strict=True):
            ax.plot(np.full(row.size, xi), row, marker, color=colour)
        control = measured[f"{kind}_similarity_to_control"]
        ax.plot(np.full(len(control), x[1] + 0.25), control, "x", color="0.5")
        ticks += list(x)
        labels += [f"{kind[:4]}.: floor\n(one concept)", f"{kind[:4]}.: composed",
                   f"{kind[:4]}.: ceiling\n(paraphrase)"]
    ax.set_xticks(ticks, labels, fontsize=8)
    ax.set_ylabel("Pearson r with the multi-concept map")
    ax.set_title("EMG-6: one line per seed (mean over its cases); grey ×: composed ~ unrelated "
                 "control", fontsize=9)
    return fig
