"""GMD-C2 (notebook 03, GMD appendix C): a random projection keeps distances with high
probability and has an exact inverse.

Distance ratios of a pure random projection (c = 1) and the round-trip error of the inverse at
c = 10 in float64 and float32, with κ(P) of each matrix (:func:`distance_inverse_check`), its
figure (:func:`plot_distances_and_inverse`) and the :class:`~repro.claims.result.ClaimResult` it
records (:func:`c2_result`). Its registry entry: ``GMD-C2`` in ``repro.claims.registry_gmd``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from matplotlib.figure import Figure

from repro.claims.registry_gmd import float32_round_trip_bound
from repro.claims.result import ClaimResult
from repro.gmd.emphasis_projection.projection import (
    EmphasisProjection,
    ProjectionSettings,
    distance_ratios,
    jl_tail_bound,
    reconstruction_error,
)

__all__ = ["DistanceInverseCheck", "c2_result", "distance_inverse_check",
           "plot_distances_and_inverse"]


def _key(key: tuple[float, int]) -> str:
    """A (c, matrix seed) pair as the sidecar's ``extra`` names it: "c=10,seed=0"."""
    return f"c={key[0]:g},seed={key[1]}"


@dataclass
class DistanceInverseCheck:
    """GMD-C2's measurements per (c, matrix seed), c ∈ {1, 10}: distance ratios of
    ``n_pairs`` frame pairs and the fraction ``within`` ±20 %, κ(P), and the inverse's
    round-trip errors on ``inverse_frames`` frames (float64, float32 = matrices rounded with
    P⁻¹ in float64, float32_gmd = GMD's float32 ``torch.inverse``); the rule's worst-seed
    fraction at c = 1 and largest errors at c = 10; the κ scan over ``scan_seeds``."""

    seeds: list[int]
    n_pairs: int
    ratios: dict[tuple[float, int], np.ndarray]
    within: dict[tuple[float, int], float]
    errors: dict[tuple[float, int], dict[str, np.ndarray]]
    kappa: dict[tuple[float, int], float]
    inverse_frames: int
    fraction_within: float
    inverse64: float
    inverse32: float
    inverse32_gmd: float
    inverse32_over_bound: float
    inverse32_bound: float
    jl_bound: float
    scan_seeds: list[int]
    scan_frames: int
    scan: dict[float, list[tuple[float, float]]]

    def figure(self) -> Figure:
        """Distance ratios, inverse errors and κ (``plot_distances_and_inverse``)."""
        return plot_distances_and_inverse(
            self.ratios, self.errors, self.kappa, self.scan, self.seeds, n_pairs=self.n_pairs,
            jl_bound=self.jl_bound, scan_frames=self.scan_frames)

    def summary(self) -> str:
        """One line per (c, matrix seed): κ, the fraction within ±20 %, the inverse's errors."""
        return "\n".join(
            f"c = {key[0]:>4g}, matrix seed {key[1]}: κ = {self.kappa[key]:8.0f}, within ±20 %: "
            f"{self.within[key]:.4f}, inverse max error float64 "
            f"{self.errors[key]['float64'].max():.1e}, float32 "
            f"{self.errors[key]['float32'].max():.1e} (GMD-style "
            f"{self.errors[key]['float32_gmd'].max():.1e})" for key in self.ratios)


def distance_inverse_check(frames: np.ndarray, seeds: Sequence[int],
                           checks: ProjectionSettings, *, seed: int) -> DistanceInverseCheck:
    """GMD-C2: for c ∈ {1, 10} and each matrix seed of ``seeds``, the distance ratios of
    ``checks.distance_pairs`` pairs of ``frames`` (the squared ratio is χ²₂₆₃/263 for a pure
    random projection; JL/Chernoff bound ``jl_tail_bound``) and the inverse's round-trip error
    on ``checks.inverse_frames`` frames drawn with ``seed`` (≈ κ(P)·ε); then κ and the float32
    error over ``checks.kappa_scan_seeds`` more matrices (the error follows κ)."""
    seeds = list(seeds)
    projections = {(c, s): EmphasisProjection(c=c, seed=s) for c in (1.0, 10.0) for s in seeds}
    ratios = {key: distance_ratios(p, frames, n_pairs=checks.distance_pairs, seed=key[1])
              for key, p in projections.items()}
    within = {key: float(np.mean(np.abs(r - 1.0) <= 0.2)) for key, r in ratios.items()}
    rng = np.random.default_rng(seed)
    inverse_frames = frames[np.sort(rng.choice(len(frames),
                                               min(checks.inverse_frames, len(frames)),
                                               replace=False))]
    errors = {}
    for key, p in projections.items():
        errors[key] = {"float64": reconstruction_error(p, inverse_frames, torch.float64),
                       "float32": reconstruction_error(p, inverse_frames, torch.float32),
                       "float32_gmd": reconstruction_error(p, inverse_frames, torch.float32,
                                                           inverse_in_dtype=True)}
    kappa = {key: p.condition_number for key, p in projections.items()}
    fraction_within = min(within[(1.0, s)] for s in seeds)
    inverse64 = max(float(errors[(10.0, s)]["float64"].max()) for s in seeds)
    inverse32 = max(float(errors[(10.0, s)]["float32"].max()) for s in seeds)
    inverse32_gmd = max(float(errors[(10.0, s)]["float32_gmd"].max()) for s in seeds)
    bounds = {s: float32_round_trip_bound(kappa[(10.0, s)]) for s in seeds}
    inverse32_over_bound = max(float(errors[(10.0, s)]["float32"].max()) / bounds[s]
                               for s in seeds)
    jl_bound = jl_tail_bound(0.8, 1.2, 263)   # the window ±20 %
    scan_seeds = list(range(seed, seed + checks.kappa_scan_seeds))
    scan_frames = inverse_frames[:checks.kappa_scan_frames]
    scan = {c: [(EmphasisProjection(c=c, seed=s).condition_number,
                 float(reconstruction_error(EmphasisProjection(c=c, seed=s), scan_frames,
                                            torch.float32).max())) for s in scan_seeds]
            for c in (1.0, 10.0)}
    return DistanceInverseCheck(seeds, checks.distance_pairs, ratios, within, errors, kappa,
                                len(inverse_frames), fraction_within, inverse64, inverse32,
                                inverse32_gmd, inverse32_over_bound, max(bounds.values()),
                                jl_bound, scan_seeds, len(scan_frames), scan)


def c2_result(check: DistanceInverseCheck, *, figures: Sequence[str | Path] = ()
              ) -> ClaimResult:
    """GMD-C2's result: the worst seed's fraction of pairs within ±20 % at c = 1 and the
    largest inverse errors at c = 10 in float64 and float32 (the rule's inputs)."""
    seeds = check.seeds
    return ClaimResult(
        "GMD-C2",
        {"fraction_pairs_within_20_percent": check.fraction_within,
         "inverse_relative_error_float64": check.inverse64,
         "inverse_relative_error_float32": check.inverse32,
         "inverse_float32_error_over_bound": check.inverse32_over_bound,
         "inverse_float32_bound": check.inverse32_bound},
        seeds=seeds, figures=list(figures),
        headline=(f"c = 1: {check.fraction_within:.2%} of pairs within ±20 %; inverse at "
                  f"c = 10: float64 {check.inverse64:.1e}, float32 {check.inverse32:.1e} (κ up "
                  f"to {max(check.kappa[(10.0, s)] for s in seeds):.0f})"),
        notes=(f"Distances at c = 1 (the pure random projection; c = 10 deliberately stretches "
               f"trajectory differences: {min(check.within[(10.0, s)] for s in seeds):.1%} "
               f"within ±20 %), "
               f"{check.n_pairs} random pairs of z-normalised stand-in test frames per "
               "matrix seed, the "
               f"worst seed's fraction. Inverse at c = 10 (GMD's released value), max over "
               f"{check.inverse_frames} stand-in test frames and {len(seeds)} matrix seeds; "
               f"float32 = matrices rounded to "
               f"float32 with P⁻¹ formed in float64; GMD's own float32 torch.inverse gives "
               f"{check.inverse32_gmd:.1e}. The float32 error tracks κ(P)·2⁻²⁴ over "
               f"{len(check.scan_seeds)} matrix seeds (right panel); the rule holds it to "
               f"what float32 can deliver for each matrix, (2 + 2√263)·κ(P)·2⁻²⁴ (at most "
               f"{check.inverse32_bound:.1e} here): the largest error is "
               f"{check.inverse32_over_bound:.2f} of its matrix's bound."),
        extra={"within_20_percent": {_key(k): v for k, v in check.within.items()},
               "condition_number": {_key(k): v for k, v in check.kappa.items()},
               "inverse_max_error": {_key(k): {n: float(e.max()) for n, e in errs.items()}
                                     for k, errs in check.errors.items()},
               "inverse_relative_error_float32_gmd_style": check.inverse32_gmd,
               "jl_bound_outside_20_percent": check.jl_bound,
               "kappa_scan": {f"c={c:g}": check.scan[c] for c in check.scan}})


def plot_distances_and_inverse(ratios: dict, errors: dict, kappa: dict,
                               scan: dict[float, list[tuple[float, float]]],
                               seeds: Sequence[int], *, n_pairs: int, jl_bound: float,
                               scan_frames: int) -> Figure:
    """GMD-C2: distance ratios at c = 1 and 10 (pooled over matrix seeds) against
    √(χ²₂₆₃/263), the inverse's round-trip errors at c = 10 in float64/float32, and the
    float32 error against κ over more matrix seeds. ``ratios``/``errors``/``kappa`` keyed
    (c, seed); ``scan[c]``: (κ, max error) per scanned seed."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    _plot_distance_ratios(axes[0], ratios, seeds, n_pairs=n_pairs, jl_bound=jl_bound)
    _plot_round_trip(axes[1], errors, kappa, seeds)
    _plot_kappa_scan(axes[2], scan, scan_frames=scan_frames)
    fig.tight_layout()
    return fig


def _plot_distance_ratios(ax: Any, ratios: dict, seeds: Sequence[int], *, n_pairs: int,
                          jl_bound: float) -> None:
    """The distance ratios at c = 1 and 10 against √(χ²₂₆₃/263) and the ±20 % window."""
    from scipy import stats

    bins = np.linspace(0.0, 3.0, 121)
    for c, colour in ((1.0, "tab:blue"), (10.0, "tab:red")):
        pooled = np.concatenate([ratios[(c, s)] for s in seeds])
        ax.hist(pooled, bins=bins, density=True, alpha=0.5, color=colour,
                label=f"c = {c:g}: {np.mean(np.abs(pooled - 1) <= 0.2):.1%} within ±20 %")
    r = np.linspace(0.6, 1.4, 400)
    ax.plot(r, stats.chi2.pdf(263 * r**2, 263) * 2 * 263 * r, "k-", lw=1,
            label="√(χ²₂₆₃/263): one pair, random G")
    ax.axvspan(0.8, 1.2, color="grey", alpha=0.12,
               label=f"±20 % (JL bound: P(out) ≤ {jl_bound:.1e})")
    ax.set_xlabel("‖xP − yP‖ / ‖x − y‖")
    ax.set_ylabel("density")
    ax.set_title(f"distance ratios, {n_pairs} frame pairs × {len(seeds)} matrices", fontsize=9)
    ax.legend(fontsize=7)


def _plot_round_trip(ax: Any, errors: dict, kappa: dict, seeds: Sequence[int]) -> None:
    """The inverse's round-trip errors at c = 10 and the rule's float32 bound per matrix."""
    edges = np.logspace(-17, -2, 61)
    for (name, colour) in (("float64", "tab:blue"), ("float32", "tab:orange"),
                           ("float32_gmd", "tab:red")):
        pooled = np.concatenate([errors[(10.0, s)][name] for s in seeds])
        ax.hist(np.maximum(pooled, 1e-17), bins=edges, alpha=0.55, color=colour,
                label=f"{name.replace('_gmd', ', inverse in float32 (GMD)')}: max "
                      f"{pooled.max():.1e}")
    ax.axvline(1e-8, color="grey", ls=":", lw=1)
    for s in seeds:   # the rule's float32 bound for each matrix drawn
        ax.axvline(float32_round_trip_bound(kappa[(10.0, s)]), color="tab:orange", ls=":",
                   lw=1)
    ax.set_xscale("log")
    ax.set_xlabel("‖P⁻¹(xP) − x‖ / ‖x‖ per frame (c = 10)")
    ax.set_ylabel("frames")
    ax.set_title(f"inverse round trip; κ(P) at c = 10: "
                 f"{', '.join(f'{kappa[(10.0, s)]:.0f}' for s in seeds)}", fontsize=9)
    ax.legend(fontsize=7)


def _plot_kappa_scan(ax: Any, scan: dict[float, list[tuple[float, float]]], *,
                     scan_frames: int) -> None:
    """The float32 error against κ over the scanned matrix seeds, with κ·2⁻²⁴ and the rule."""
    for c, colour in ((1.0, "tab:blue"), (10.0, "tab:red")):
        k, e = np.array(scan[c]).T
        ax.loglog(k, e, "o", color=colour, ms=5, label=f"c = {c:g}")
    k_line = np.logspace(2, 5, 10)
    ax.loglog(k_line, k_line * 2.0**-24, "k--", lw=0.8, label="κ · 2⁻²⁴")
    ax.loglog(k_line, float32_round_trip_bound(k_line), ":", color="grey", lw=1,
              label="rule: (2 + 2√263) κ · 2⁻²⁴")
    ax.set_xlabel("condition number κ(P)")
    ax.set_ylabel("max float32 round-trip error")
    ax.set_title(f"{len(next(iter(scan.values())))} matrix seeds, {scan_frames} frames each",
                 fontsize=9)
    ax.legend(fontsize=7)
