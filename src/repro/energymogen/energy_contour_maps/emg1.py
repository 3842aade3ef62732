"""EMG-1 (Sec. 3.2, Eq. 5–7: "diffusion models can be interpreted as EBMs under the gradient
descent step η = 1"), checked on the pipeline; the registered claim is EMG-1 in
``repro.claims.registry_energymogen``.

A DDPM or DDIM step is a Langevin step on an energy (:func:`langevin_step_errors`); Eq. 7 is a
sum of energies (line-integral energies, :func:`energy_linearity_error`); is ε_θ a gradient
field at all (:func:`jacobian_asymmetry`, :func:`denoiser_jacobian_asymmetry`)? All three on
the pipeline: :func:`energy_view_study`. Per t (:func:`gradient_field_study`, on the same
draws): the **residual Jacobian asymmetry** ‖A − Aᵀ‖_F / ‖A‖_F with A = ∂ε_θ/∂z − I/√(1−ᾱ_t)
(the identity term is symmetric, so it leaves A − Aᵀ = J − Jᵀ alone but does not dominate the
denominator at large t; :func:`residual_asymmetry`) and the **relative loop integral**
|∮ε_θ·dz| / ∮‖ε_θ‖‖dz‖ around a circle (Stokes: 0 for a gradient field, 1 for a field
circulating along the loop; :func:`relative_circulation`). Our choices: the circle lies in the
plane where the antisymmetric part of J at its centre circulates most (the top singular pair
of J − Jᵀ: the worst case over planes, as a random plane of 160 dimensions sees almost none of
it), radius √(1−ᾱ_t) (the noise's standard deviation at t), :data:`LOOP_POINTS` points (the
trapezoid rule is spectrally accurate on a periodic integrand). The ratio grows with the
radius (for a linear field it is r·σ/‖ε‖), so the radius is part of the measurement and is
stated beside it. Both conditions (the joined text and ∅) are pooled: per t the median over
samples × conditions. Its controls at the same points (:func:`planted_fields`,
:func:`gradient_field_controls`): the model's field made a gradient (its Jacobian's symmetric
part, linearly about each point) must pass; the same with the model's own antisymmetric part
at twice the tolerance in both readings must fail. The claim: :func:`emg1_result` (the
:class:`~repro.claims.result.ClaimResult` the notebook records); its figure:
:func:`jacobian_asymmetry_figure`.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.figure import Figure
from torch import Tensor, nn

from repro.claims.registry_energymogen import EMG1_LIMIT
from repro.claims.result import ClaimResult, Controls
from repro.core.diffusion import GaussianDiffusion
from repro.energymogen import settings as rule_settings
from repro.energymogen.compose import Condition, make_composed_eps_fn
from repro.energymogen.data import energy_view_items
from repro.energymogen.energy_contour_maps.notebook_settings import EnergyViewSettings
from repro.energymogen.harness import KINDS
from repro.energymogen.pipeline import EnergyMoGenPipeline, denoiser_kwargs
from repro.models.latent_denoiser import LatentDenoiser

__all__ = ["EMG1_NULL_READING", "EpsFn", "LOOP_POINTS", "conditional_eps",
           "denoiser_jacobian_asymmetry", "emg1_result", "energy_linearity_error",
           "energy_view_study", "field_readings", "flat_jacobian", "float64_copy",
           "gradient_field_controls", "gradient_field_study", "jacobian_asymmetry",
           "jacobian_asymmetry_figure", "langevin_step_errors", "line_integral_energy",
           "linear_field", "loop_plane", "planted_fields", "relative_circulation",
           "residual_asymmetry"]


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
