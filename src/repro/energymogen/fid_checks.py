"""EMG-9's draw-independent checks (registry v2, ``_EMG9_NEW``): fixed Gaussian cases whose
Fréchet distance has a closed form, evaluated with ``core.metrics.frechet_distance`` (ours)
and with the printed Eq. 12 (``core.metrics.fid_as_printed_in_energymogen``).

Fixed cases (no random draw, so no check can flip with a seed):

- **equal covariances, shifted means**: Σ1 = Σ2 = Σ, μ2 = μ1 + d → FID = ‖d‖² (the trace
  term Tr(2Σ − 2(Σ²)^½) vanishes);
- **commuting diagonal covariances**: Σi = diag(λi) → FID = ‖Δμ‖² + Σk (√λ1k − √λ2k)²
  (``metrics.gaussian_fid_closed_form``);
- **P = P**: FID(N(μ, Σ), N(μ, Σ)) = 0. The printed form gives −2 Tr(Σ − Σ²) there, zero only
  for an idempotent Σ, so Σ is fixed with eigenvalues away from 0 and 1.

Relative errors are |value − closed form| / |closed form|; at P = P (closed form 0) the error
is |value| / Tr Σ, the registry's scale for ``printed_self_distance``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from repro.core import metrics

__all__ = ["fid_fixed_cases", "fixed_cases"]

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
