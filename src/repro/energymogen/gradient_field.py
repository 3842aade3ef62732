"""EMG-1's evidence (registry v2, ``_EMG1_NEW``): is ε_θ(·, t, c) a gradient field at each t?

Two measurements on the draws of ``energy.energy_view_study`` (the same noised test latents,
texts and noise):

- **residual Jacobian asymmetry** ‖A − Aᵀ‖_F / ‖A‖_F with A = ∂ε_θ/∂z − I/√(1−ᾱ_t): the
  identity term (the registry's) is symmetric, so it leaves A − Aᵀ = J − Jᵀ alone but no longer
  dominates the denominator at large t (:func:`residual_asymmetry`);
- **relative loop integral** |∮ε_θ·dz| / ∮‖ε_θ‖‖dz‖ around a circle (Stokes: 0 for a gradient
  field, 1 for a field circulating along the loop; :func:`relative_circulation`). Our choices:
  the circle lies in the plane where the antisymmetric part of J at its centre circulates most
  (the top singular pair of J − Jᵀ: the worst case over planes, as a random plane of 160
  dimensions sees almost none of it), radius √(1−ᾱ_t) (the noise's standard deviation at t),
  16 points (the trapezoid rule is spectrally accurate on a periodic integrand). The ratio
  grows with the radius (for a linear field it is r·σ/‖ε‖), so the radius is part of the
  measurement and is stated beside it.

Both conditions of the pooled Jacobian asymmetry (the joined text and ∅) are pooled here too:
per t the median over samples × conditions.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor

from repro.energymogen.data import energy_view_items
from repro.energymogen.energy import conditional_eps
from repro.energymogen.pipeline import EnergyMoGenPipeline

__all__ = ["LOOP_POINTS", "flat_jacobian", "gradient_field_study", "loop_plane",
           "relative_circulation", "residual_asymmetry"]

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


def gradient_field_study(pipe: EnergyMoGenPipeline, seed: int, *, samples: int,
                         timesteps: Sequence[int]) -> dict[str, Any]:
    """EMG-1's two per-t measurements on ``energy_view_study``'s draws (``samples`` ground-truth
    latents of the composition items of ``seed`` noised with noise of ``seed``; the joined
    text and ∅): ``residual_jacobian_asymmetry_by_t`` and ``loop_integral_relative_by_t``
    (str(t) → median over samples × conditions), the per-sample values and the loop radii."""
    items = energy_view_items(pipe.data, seed, pipe.config.items_per_pair)
    z0 = pipe.encode_motion(items.gt_features[:samples])
    condition = pipe.encode(list(items.multi_texts[:samples]))
    noise = torch.randn(z0.shape, generator=torch.Generator().manual_seed(seed))
    asymmetry: dict[str, list[float]] = {}
    circulation: dict[str, list[float]] = {}
    radii: dict[str, float] = {}
    for t in timesteps:
        z_t = pipe.diffusion.q_sample(z0, torch.full((samples,), t, dtype=torch.long), noise)
        one_minus = float(1.0 - pipe.diffusion.alphas_cumprod[t])
        radius = float(np.sqrt(one_minus))
        key = str(t)
        asymmetry[key], circulation[key], radii[key] = [], [], radius
        for cond in (condition, None):
            for b in range(samples):
                eps = conditional_eps(pipe.denoiser, t, cond, b)
                jac = flat_jacobian(eps, z_t[b:b + 1])
                asymmetry[key].append(residual_asymmetry(jac, 1.0 / np.sqrt(one_minus)))
                u, v = loop_plane(jac)
                circulation[key].append(relative_circulation(eps, z_t[b:b + 1], u, v, radius))
    return {"residual_jacobian_asymmetry_by_t": {k: float(np.median(v))
                                                 for k, v in asymmetry.items()},
            "loop_integral_relative_by_t": {k: float(np.median(v))
                                            for k, v in circulation.items()},
            "per_sample": {"residual_jacobian_asymmetry": asymmetry,
                           "loop_integral_relative": circulation},
            "loop_radius_by_t": radii}
