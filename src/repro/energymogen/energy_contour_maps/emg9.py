"""EMG-9 (app. G.2, Eq. 12: the FID formula as printed); the registered claim is EMG-9 in
``repro.claims.registry_energymogen``.

FID against the Gaussian closed form on random commuting Gaussians
(:func:`fid_formula_errors`) and on fixed cases whose Fréchet distance has a closed form
(:func:`fid_fixed_cases`, no random draw, so no check can flip with a seed), evaluated with
``core.metrics.frechet_distance`` (ours) and with the printed Eq. 12
(``core.metrics.fid_as_printed_in_energymogen``): equal covariances with shifted means (FID =
‖d‖², the trace term Tr(2Σ − 2(Σ²)^½) vanishes); commuting diagonal covariances (FID = ‖Δμ‖² +
Σk (√λ1k − √λ2k)², ``metrics.gaussian_fid_closed_form``); P = P (FID = 0; the printed form
gives −2 Tr(Σ − Σ²) there, zero only for an idempotent Σ, so Σ is fixed with eigenvalues away
from 0 and 1). Relative errors are |value − closed form| / |closed form|; at P = P (closed
form 0) the error is |value| / Tr Σ, the registry's scale for ``printed_self_distance``. The
claim: :func:`emg9_result`; the notebook's tables: :func:`fid_draws_markdown`,
:func:`fid_fixed_cases_markdown`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from repro.claims.result import ClaimResult
from repro.core import metrics
from repro.core.tables import markdown_table

__all__ = ["emg9_result", "fid_draws_markdown", "fid_fixed_cases", "fid_fixed_cases_markdown",
           "fid_formula_errors", "fixed_cases"]


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
