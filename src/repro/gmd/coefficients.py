"""GMD appendix A: the two forms of the posterior mean and their coefficients (Eq. 1–2, Fig. A.1).

Eq. 1 writes μ_t = a·x0 + b·x_t; substituting x0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t gives Eq. 2,
μ_t = c·x_t − d·ε. The coefficients themselves live on ``core.diffusion.GaussianDiffusion``;
this module evaluates the appendix's statements about them (claims GMD-A1, GMD-A2).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import torch

from repro.core.diffusion import GaussianDiffusion, cosine_betas, linear_betas

__all__ = ["c_identity_error", "coefficient_shares", "peak_fraction", "posterior_mean_forms",
           "printed_c_relative_error", "schedule_diffusion"]


def schedule_diffusion(schedule: Literal["cosine", "linear"], num_timesteps: int = 1000,
                       prediction: Literal["x0", "epsilon"] = "epsilon") -> GaussianDiffusion:
    """The diffusion of a named schedule (GMD: cosine, T = 1000)."""
    if schedule not in ("cosine", "linear"):
        raise ValueError(f"schedule must be 'cosine' or 'linear', got {schedule!r}")
    betas = (cosine_betas if schedule == "cosine" else linear_betas)(num_timesteps)
    return GaussianDiffusion(betas, prediction)


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

