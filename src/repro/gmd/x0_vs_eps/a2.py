"""GMD-A2 (appendix A, Fig. A.1): the x0 model's influence on x_{t−1} is largest as t→0, the ε
model's as t→T (cosine schedule).

The coefficients themselves live on ``core.diffusion.GaussianDiffusion`` (Eq. 1's a, b and
Eq. 2's c, d; ``x0_vs_eps.a1``). The coefficient curves (:func:`coefficient_shares`), their
peaks (:func:`peak_fraction`) and the claim's result (:func:`a2_result`).

Its registered rule and measurements: the ``GMD-A2`` entry of ``repro.claims.registry_gmd``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from repro.claims.result import ClaimResult
from repro.core.diffusion import GaussianDiffusion
from repro.gmd.x0_vs_eps.common import FigurePath


def coefficient_shares(diffusion: GaussianDiffusion) -> dict[str, np.ndarray]:
    """Fig. A.1's curves over t: a, b (Eq. 1), c, d (Eq. 2), the x0 share a/(a+b) and the
    ε share d/(c+d) (the relative shares registered for claim GMD-A2)."""
    a, b = diffusion.posterior_mean_coef_x0, diffusion.posterior_mean_coef_xt
    c, d = diffusion.eps_mean_coef_xt, diffusion.eps_mean_coef_eps
    return {"a": a, "b": b, "c": c, "d": d, "x0_share": a / (a + b), "eps_share": d / (c + d)}


def peak_fraction(values: np.ndarray) -> float:
    """Where a curve over t = 0 … T−1 peaks, as the paper's step (t + 1) divided by T."""
    return float((int(np.argmax(values)) + 1) / len(values))


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
