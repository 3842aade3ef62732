"""GMD-C1…C3 (notebook 03): the Emphasis projection's three analytic claims as experiments
that return their measurements, and the :class:`~repro.claims.result.ClaimResult` each claim
records (GMD appendix C, Eq. 3–4).

- :func:`relative_importance_check` (GMD-C1): Eq. 4's share I(c) = 3c²/(260 + 3c²) against a
  simulation on N(0, 1) vectors, beside the projected share of actual matrices and the share on
  the stand-in frames;
- :func:`distance_inverse_check` (GMD-C2): distance ratios of a pure random projection (c = 1)
  and the round-trip error of the inverse at c = 10, in float64 and float32;
- :func:`unit_variance_check` (GMD-C3): the per-dimension variance with the printed factor
  1/(263−3+3c²) and with GMD's 1/√(263−3+3c²).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from matplotlib.figure import Figure

from repro.claims.result import ClaimResult
from repro.gmd import emphasis_figures
from repro.gmd.emphasis import (
    EmphasisProjection,
    c_for_importance,
    distance_ratios,
    jl_tail_bound,
    normalising_factor,
    per_dimension_variance,
    projected_importance,
    reconstruction_error,
    relative_importance,
    relative_importance_of,
    simulated_relative_importance,
)
from repro.gmd.emphasis_study import ProjectionSettings

__all__ = ["C1_GRID", "C3_GRID", "DistanceInverseCheck", "RelativeImportanceCheck",
           "UnitVarianceCheck", "c1_result", "c2_result", "c3_result", "distance_inverse_check",
           "relative_importance_check", "unit_variance_check"]

#: the values of c at which GMD-C1 simulates Eq. 4 (0.5–20, around c* = √(260/3) ≈ 9.3)
C1_GRID = (0.5, 1, 1.5, 2, 3, 4, 5, 6, 7, 8, 9, 10, 12, 15, 20)
#: the values of c at which GMD-C3 measures the factor that restores unit variance
C3_GRID = (1, 2, 3, 5, 7, 10, 15, 20)


def _key(key: tuple[float, int]) -> str:
    """A (c, matrix seed) pair as the sidecar's ``extra`` names it: "c=10,seed=0"."""
    return f"c={key[0]:g},seed={key[1]}"


# --- GMD-C1: how large should c be? (Eq. 3–4) ----------------------------------------------

@dataclass
class RelativeImportanceCheck:
    """GMD-C1's measurements over ``c_grid``: Eq. 4 (``formula``), its simulation on
    ``samples`` N(0, 1) vectors per c (``simulated``, the rule's input), the projected energy
    share of each matrix seed's Gaussian matrix and of the orthogonal one, and the share on the
    stand-in frames (``on_data``; ½ at ``data_c_star``)."""

    c_grid: np.ndarray
    formula: np.ndarray
    simulated: np.ndarray
    simulation_error: float
    c_star: float
    importance_at_c_star: float
    importance_at_10: float
    projected: dict[int, np.ndarray]
    orthogonal: np.ndarray
    on_data: np.ndarray
    data_c_star: float
    on_data_at_10: float
    samples: int

    def figure(self) -> Figure:
        """Eq. 4 with the simulation and the illustrations (``plot_relative_importance``)."""
        return emphasis_figures.plot_relative_importance(
            self.c_grid, self.simulated, self.projected, self.orthogonal, self.on_data,
            c_star=self.c_star, importance_at_10=self.importance_at_10,
            simulation_error=self.simulation_error)

    def summary(self) -> str:
        """One line: c*, I(c*), I(10), the simulation's error and the stand-in frames' c."""
        return (f"c* = {self.c_star:.4f}, I(c*) = {self.importance_at_c_star:.12f}, I(10) = "
                f"{self.importance_at_10:.4f}; simulation max |error| = "
                f"{self.simulation_error:.2e}; on the stand-in frames I = ½ at "
                f"c ≈ {self.data_c_star:.2f} (I(10) = {self.on_data_at_10:.3f})")


def relative_importance_check(frames: np.ndarray, seeds: Sequence[int],
                              checks: ProjectionSettings, *, seed: int
                              ) -> RelativeImportanceCheck:
    """GMD-C1 (Eq. 3–4): on :data:`C1_GRID` the share I(c) = 3c²/(260 + 3c²) of Eq. 4, its
    simulation (``checks.simulation_samples`` N(0, 1) vectors per c, seed ``seed`` + grid
    index), the projected share of the Gaussian matrix of each of ``seeds`` and of the
    orthogonal matrix (seed ``seed``), and the share on the z-normalised ``frames`` (N, 263)."""
    c_grid = np.array(C1_GRID, dtype=float)
    formula = relative_importance(c_grid)
    simulated = np.array([simulated_relative_importance(c, checks.simulation_samples,
                                                        seed=seed + i)
                          for i, c in enumerate(c_grid)])
    simulation_error = float(np.max(np.abs(simulated - formula)))
    c_star = c_for_importance(0.5)
    importance_at_c_star = relative_importance(c_star)
    importance_at_10 = relative_importance(10.0)
    projected = {s: np.array([projected_importance(EmphasisProjection(c=c, seed=s))
                              for c in c_grid]) for s in seeds}
    orthogonal = np.array([projected_importance(EmphasisProjection(c=c, seed=seed,
                                                                   kind="orthogonal"))
                           for c in c_grid])
    on_data = np.array([relative_importance_of(frames, c) for c in c_grid])
    data_c_star = float(np.interp(0.5, on_data, c_grid))
    return RelativeImportanceCheck(c_grid, formula, simulated, simulation_error, c_star,
                                   importance_at_c_star, importance_at_10, projected,
                                   orthogonal, on_data, data_c_star,
                                   relative_importance_of(frames, 10.0),
                                   checks.simulation_samples)


def c1_result(check: RelativeImportanceCheck, *, seed: int,
              figures: Sequence[str | Path] = ()) -> ClaimResult:
    """GMD-C1's result: the simulation's largest error from Eq. 4 and c* = √(260/3) with
    I(c*) (the rule's inputs; one run, ``seed``), the illustrations in ``extra``."""
    return ClaimResult(
        "GMD-C1",
        {"simulation_max_abs_error": check.simulation_error, "c_star": check.c_star,
         "importance_at_c_star": check.importance_at_c_star},
        seeds=[seed], figures=list(figures),
        headline=(f"c* = √(260/3) = {check.c_star:.3f}; I(10) = {check.importance_at_10:.1%}; "
                  f"simulation matches Eq. 4 to {check.simulation_error:.1e}"),
        notes=(f"Simulation: {check.samples} N(0,1) vectors per c on a grid of "
               f"{len(check.c_grid)} "
               f"values 0.5–20, sample-variance shares. Illustration (not in the rule): the "
               f"projected energy share of Gaussian matrices scatters around Eq. 4 "
               f"(finite-matrix row norms), the orthogonal variant gives Eq. 4 exactly; on the "
               f"z-normalised stand-in frames (block-averaged std, so not unit variance) I = ½ "
               f"at c ≈ {check.data_c_star:.2f}."),
        extra={"c_grid": check.c_grid.tolist(), "simulated": check.simulated.tolist(),
               "formula": check.formula.tolist(), "importance_at_10": check.importance_at_10,
               "projected_gaussian": {str(s): v.tolist() for s, v in check.projected.items()},
               "projected_orthogonal": check.orthogonal.tolist(),
               "stand_in_frames": check.on_data.tolist(),
               "stand_in_c_for_half": check.data_c_star})


# --- GMD-C2: distances and the exact inverse -----------------------------------------------

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
    jl_bound: float
    scan_seeds: list[int]
    scan_frames: int
    scan: dict[float, list[tuple[float, float]]]

    def figure(self) -> Figure:
        """Distance ratios, inverse errors and κ (``plot_distances_and_inverse``)."""
        return emphasis_figures.plot_distances_and_inverse(
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
    jl_bound = jl_tail_bound(0.8, 1.2, 263)   # the window ±20 %
    scan_seeds = list(range(seed, seed + checks.kappa_scan_seeds))
    scan_frames = inverse_frames[:checks.kappa_scan_frames]
    scan = {c: [(EmphasisProjection(c=c, seed=s).condition_number,
                 float(reconstruction_error(EmphasisProjection(c=c, seed=s), scan_frames,
                                            torch.float32).max())) for s in scan_seeds]
            for c in (1.0, 10.0)}
    return DistanceInverseCheck(seeds, checks.distance_pairs, ratios, within, errors, kappa,
                                len(inverse_frames), fraction_within, inverse64, inverse32,
                                inverse32_gmd, jl_bound, scan_seeds, len(scan_frames), scan)


def c2_result(check: DistanceInverseCheck, *, figures: Sequence[str | Path] = ()
              ) -> ClaimResult:
    """GMD-C2's result: the worst seed's fraction of pairs within ±20 % at c = 1 and the
    largest inverse errors at c = 10 in float64 and float32 (the rule's inputs)."""
    seeds = check.seeds
    return ClaimResult(
        "GMD-C2",
        {"fraction_pairs_within_20_percent": check.fraction_within,
         "inverse_relative_error_float64": check.inverse64,
         "inverse_relative_error_float32": check.inverse32},
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
               f"{len(check.scan_seeds)} matrix seeds (right panel)."),
        extra={"within_20_percent": {_key(k): v for k, v in check.within.items()},
               "condition_number": {_key(k): v for k, v in check.kappa.items()},
               "inverse_max_error": {_key(k): {n: float(e.max()) for n, e in errs.items()}
                                     for k, errs in check.errors.items()},
               "inverse_relative_error_float32_gmd_style": check.inverse32_gmd,
               "jl_bound_outside_20_percent": check.jl_bound,
               "kappa_scan": {f"c={c:g}": check.scan[c] for c in check.scan}})


# --- GMD-C3: the factor that restores unit variance ----------------------------------------

@dataclass
class UnitVarianceCheck:
    """GMD-C3's measurements at c = 10 (matrix seed ``seed``): the mean per-dimension variance
    with the printed and the √ factor (the rule's inputs), the √ factor's per-dimension
    variances for the Gaussian and the orthogonal matrix and on the stand-in frames; over
    ``c_grid`` the unscaled variance and the factors (measured, √, printed)."""

    seed: int
    samples: int
    variance_printed: float
    variance_sqrt: float
    variance_sqrt_all: np.ndarray
    variance_orthogonal_all: np.ndarray
    variance_on_frames: np.ndarray
    c_grid: np.ndarray
    unscaled: np.ndarray
    measured_factor: np.ndarray
    sqrt_factor: np.ndarray
    printed_factor: np.ndarray
    frames_variance: float

    def figure(self) -> Figure:
        """The factors over c and the per-dimension variances (``plot_unit_variance``)."""
        return emphasis_figures.plot_unit_variance(
            self.c_grid, self.unscaled, self.sqrt_factor, self.printed_factor,
            self.variance_sqrt_all, self.variance_orthogonal_all, self.variance_on_frames)

    def summary(self) -> str:
        """One line: the variance with each factor at c = 10 and the frames' own variance."""
        return (f"c = 10: mean per-dimension variance with the printed factor "
                f"{self.variance_printed:.5f} (1/560 = {1 / 560:.5f}), with the √ factor "
                f"{self.variance_sqrt:.4f}; z-normalised stand-in frames have mean variance "
                f"{self.frames_variance:.3f} before projection")


def unit_variance_check(frames: np.ndarray, checks: ProjectionSettings, *, seed: int
                        ) -> UnitVarianceCheck:
    """GMD-C3: Var[y_j] of y = x D G · f has expectation f²(260 + 3c²) for x ~ N(0, I), so unit
    variance needs f = 1/√(260 + 3c²), not the printed 1/(263−3+3c²). Measured on
    ``checks.simulation_samples`` N(0, 1) vectors (matrix and draw seed ``seed``), and on the
    z-normalised ``frames``; over :data:`C3_GRID` the factor 1/√(mean Var[x D G])."""

    def mean_variance(c: float, normaliser: str, kind: str = "gaussian",
                      x: np.ndarray | None = None) -> np.ndarray:
        projection = EmphasisProjection(c=c, seed=seed, kind=kind, normaliser=normaliser)
        return per_dimension_variance(projection, x, n_samples=checks.simulation_samples,
                                      seed=seed)

    variance_printed = float(mean_variance(10.0, "printed").mean())
    variance_sqrt_all = mean_variance(10.0, "sqrt")
    variance_orthogonal_all = mean_variance(10.0, "sqrt", kind="orthogonal")
    variance_on_frames = mean_variance(10.0, "sqrt", x=frames)
    c_grid = np.array(C3_GRID, dtype=float)
    unscaled = np.array([mean_variance(c, "none").mean() for c in c_grid])
    return UnitVarianceCheck(
        seed, checks.simulation_samples, variance_printed, float(variance_sqrt_all.mean()),
        variance_sqrt_all, variance_orthogonal_all, variance_on_frames, c_grid, unscaled,
        1.0 / np.sqrt(unscaled), np.array([normalising_factor(c) for c in c_grid]),
        np.array([normalising_factor(c, normaliser="printed") for c in c_grid]),
        float(frames.var(axis=0, ddof=1).mean()))


def c3_result(check: UnitVarianceCheck, *, figures: Sequence[str | Path] = ()) -> ClaimResult:
    """GMD-C3's result: the mean per-dimension variance at c = 10 with the printed factor and
    with the √ factor (the rule's inputs), the factors over c in ``extra``."""
    all_sqrt = check.variance_sqrt_all
    return ClaimResult(
        "GMD-C3",
        {"variance_with_printed_factor": check.variance_printed,
         "variance_with_sqrt_factor": check.variance_sqrt},
        seeds=[check.seed], figures=list(figures),
        headline=(f"c = 10: variance {check.variance_printed:.4f} with the printed "
                  f"1/(263−3+3c²), {check.variance_sqrt:.3f} with 1/√(263−3+3c²) (GMD's code)"),
        notes=(f"{check.samples} N(0,1) vectors, Gaussian matrix (seed {check.seed}), "
               "mean of the 263 "
               f"per-dimension sample variances. With one fixed Gaussian matrix the "
               f"per-dimension variances spread {all_sqrt.min():.2f}–{all_sqrt.max():.2f} "
               f"around 1 (column norms); the orthogonal variant is exact only at c = 1. On "
               f"the z-normalised stand-in frames the projected variance averages "
               f"{check.variance_on_frames.mean():.3f} (their features are not unit-variance: "
               f"block-averaged std)."),
        extra={"c_grid": check.c_grid.tolist(), "measured_factor": check.measured_factor.tolist(),
               "sqrt_factor": check.sqrt_factor.tolist(),
               "printed_factor": check.printed_factor.tolist(),
               "per_dimension_variance_range_sqrt": [float(all_sqrt.min()),
                                                     float(all_sqrt.max())],
               "orthogonal_mean_variance": float(check.variance_orthogonal_all.mean()),
               "stand_in_frames_projected_mean_variance": float(
                   check.variance_on_frames.mean())})
