"""GMD-A1 (appendix A, Eq. 1–2): the posterior mean's two forms, μ_t = a·x0 + b·x_t (Eq. 1) and
μ_t = c·x_t − d·ε (Eq. 2), beside Eq. 2's printed c = a/ᾱ_t + b.

The measurements (:func:`posterior_mean_forms`, :func:`printed_c_relative_error`,
:func:`c_identity_error`) and the claim's result (:func:`a1_result`).

Its registered rule and measurements: the ``GMD-A1`` entry of ``repro.claims.registry_gmd``.
"""

from __future__ import annotations

import numpy as np
import torch

from repro.claims.result import ClaimResult
from repro.core.diffusion import GaussianDiffusion
from repro.gmd.x0_vs_eps.common import FigurePath

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
