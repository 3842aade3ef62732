"""GMD's Emphasis projection (GMD appendix C, Eq. 3–4), the measurements around it, and the
sample sizes of notebook 03's checks of it.

Every claim of notebook 03 builds on this module: GMD-C1…C3 check the projection analytically
(``c1``, ``c2``, ``c3``, sized by :class:`ProjectionSettings`), and GMD-C4's Emphasis models
train on projected windows (``experiment``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch
from torch import Tensor

from repro.infra.context import RunSettings, check_scale
from repro.motion.features import EMPHASIS_FEATURES, FEATURE_DIM

__all__ = ["EmphasisProjection", "GMD_C_VALUES", "GMD_EMPHASISED",
           "GMD_RELEASED_CONDITION_NUMBER", "PRECISIONS", "ProjectionSettings",
           "c_for_importance", "condition_number", "distance_ratios", "drowned_directions",
           "gaussian_matrix", "jl_tail_bound", "normalising_factor", "orthogonal_matrix",
           "per_dimension_variance", "projected_importance", "reconstruction_error",
           "relative_importance", "relative_importance_of", "simulated_relative_importance"]


# ------------------------------------------------------------------------------------------------
# GMD's Emphasis projection (GMD appendix C, Eq. 3–4) and the measurements around it.
#
# What GMD builds (GMD appendix C; korrawe/guided-motion-diffusion
# ``Text2MotionDatasetV2.init_random_projection`` / ``random_projection``):
#
#     G ∈ R^{n×n},  G_ij ~ N(0, 1)                      (seeded; not orthogonalised)
#     D = diag(d),  d_i = c for i ∈ E (the emphasised features), 1 otherwise
#     P = D G / s,  s = √(n − k + k c²)                 (k = |E|; a standard-deviation factor)
#     y = x P                                           (x a z-normalised frame, a *row* vector)
#
# GMD multiplies the *rows* 0–2 of the matrix by c and applies it as ``motion @ proj`` with
# frames as row vectors, so y_j = Σ_i x_i d_i G_ij / s: input feature i enters every output
# through row i, i.e. the trajectory features (root angle, x, z) are weighted by c before a
# random rotation-and-mixing. For x ~ N(0, I) and a random G, E[y_j²] = Σ_i d_i² / s² = 1:
# unit variance per output dimension needs the square root in s. The appendix prints the factor
# as 1/(263 − 3 + 3c²) without the root (GMD-C3); ``normaliser="printed"`` builds that version.
#
# The inverse is exact: x = y P⁻¹, with P⁻¹ formed once in float64 (``torch.linalg.inv``). A
# square Gaussian matrix is ill-conditioned: the singular values of G/√n spread from ≈ 2 down to
# ≈ 1/n (Edelman), so κ ≈ 2n with a heavy tail, and in float32 the round trip loses
# ~κ(P)·2⁻²⁴ of relative accuracy.
#
# GMD's released code (``init_random_projection``) differs from this construction in precision
# only — besides drawing G unseeded, once per training run, and saving it beside the model: it
# draws G in float32 (``torch.normal``), scales and normalises it in float32 and forms P⁻¹ with
# ``torch.inverse`` of the float32 matrix, so its inverse carries the float32 error of
# inverting a matrix of condition number κ (≈ κ·2⁻²⁴ relative). ``precision="float32_gmd"``
# builds that: the seed's G, P rounded to float32, P⁻¹ inverted from it in float32.
# The released matrix itself (``dataset/rand_proj.npy``) is a float32 263×263 array whose rows
# 0–2 are ≈ 9.7 times longer than the rest (c = 10 over one draw); its condition number is
# ``GMD_RELEASED_CONDITION_NUMBER`` and its shipped float32 inverse leaves
# max|P⁻¹P − I| = 3.5·10⁻⁵.
#
# ``kind="orthogonal"`` replaces G by √n·Q, Q the (sign-fixed, Haar) orthogonal factor of G's
# QR decomposition: its rows have exactly the norm √n that G's rows have on average, so the same
# s applies; with c = 1 it is an exact isometry and has condition number 1.
#
# Relative importance (Eq. 4): with x ~ N(0, I) the k emphasised features carry the cumulative
# variance k c² against n − k for the rest, a share k c²/(n − k + k c²); 50 % at c = √((n−k)/k)
# (= √(260/3) ≈ 9.31 for HumanML3D).
# ------------------------------------------------------------------------------------------------

Kind = Literal["gaussian", "orthogonal"]


Normaliser = Literal["sqrt", "printed", "none"]


Precision = Literal["float64", "float32_gmd"]


ArrayLike = np.ndarray | Tensor


KINDS = ("gaussian", "orthogonal")


NORMALISERS = ("sqrt", "printed", "none")


PRECISIONS = ("float64", "float32_gmd")


#: GMD's emphasised features: root angle, root x, root z (features 0–2).
GMD_EMPHASISED = tuple(range(EMPHASIS_FEATURES.start, EMPHASIS_FEATURES.stop))


#: κ₂ of GMD's released Emphasis matrix (korrawe/guided-motion-diffusion, commit 2f6264a,
#: ``dataset/rand_proj.npy``, float32, σ_max/σ_min computed in float64): a looked-up fact, one
#: draw; the c = 10 matrices of seeds 0–199 here have median κ ≈ 5.4·10³, and 24 % of them a κ
#: below this one.
GMD_RELEASED_CONDITION_NUMBER = 2997.2


#: the values of c GMD has configs for (``humanml_motion_proj{1,2,5,10}``); 10 is released.
GMD_C_VALUES = (1.0, 2.0, 5.0, 10.0)


# ------------------------------------------------------------------------------ Eq. 3–4

def relative_importance(c: float | np.ndarray, n_emphasised: int = 3,
                        n_total: int = FEATURE_DIM) -> float | np.ndarray:
    """Eq. 4: the emphasised features' share of the cumulative variance, k c²/(n − k + k c²),
    for i.i.d. N(0, 1) features of which k = ``n_emphasised`` are multiplied by c."""
    _check_counts(n_emphasised, n_total)
    c2 = np.square(np.asarray(c, dtype=np.float64))
    share = n_emphasised * c2 / (n_total - n_emphasised + n_emphasised * c2)
    return float(share) if np.ndim(share) == 0 else share


def c_for_importance(p: float, n_emphasised: int = 3, n_total: int = FEATURE_DIM) -> float:
    """Eq. 4 solved for c: c = √(p (n − k) / (k (1 − p))); p = 0.5 gives √(260/3) ≈ 9.31."""
    _check_counts(n_emphasised, n_total)
    if not 0.0 < p < 1.0:
        raise ValueError(f"importance p must lie in (0, 1), got {p}")
    return math.sqrt(p * (n_total - n_emphasised) / (n_emphasised * (1.0 - p)))


def normalising_factor(c: float, n_emphasised: int = 3, n_total: int = FEATURE_DIM,
                       normaliser: Normaliser = "sqrt") -> float:
    """The factor the scaled matrix is multiplied by: 1/√(n − k + k c²) (``"sqrt"``, GMD's
    code), 1/(n − k + k c²) (``"printed"``, the appendix's text) or 1 (``"none"``)."""
    _check_counts(n_emphasised, n_total)
    total = n_total - n_emphasised + n_emphasised * float(c) ** 2
    if normaliser == "sqrt":
        return 1.0 / math.sqrt(total)
    if normaliser == "printed":
        return 1.0 / total
    if normaliser == "none":
        return 1.0
    raise ValueError(f"normaliser must be one of {NORMALISERS}, got {normaliser!r}")


def simulated_relative_importance(c: float, n_samples: int = 20000, seed: int = 0,
                                  n_emphasised: int = 3, n_total: int = FEATURE_DIM) -> float:
    """Eq. 3–4 by simulation: draw ``n_samples`` vectors x ~ N(0, I_n), multiply the first k
    entries by c, and return Σ_{j∈E} Var̂[x_j] / Σ_j Var̂[x_j] (sample variances)."""
    _check_counts(n_emphasised, n_total)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n_samples, n_total))
    x[:, :n_emphasised] *= c
    variance = x.var(axis=0, ddof=1)
    return float(variance[:n_emphasised].sum() / variance.sum())


def relative_importance_of(frames: ArrayLike, c: float,
                           emphasised: Sequence[int] = GMD_EMPHASISED) -> float:
    """Eq. 3–4's share measured on data: Σ_{j∈E} c² Var̂[x_j] / (Σ_{j∈E} c² Var̂[x_j] +
    Σ_{j∉E} Var̂[x_j]) over the rows of ``frames`` (N, n) — e.g. z-normalised motion frames,
    whose features are not i.i.d. N(0, 1) (HumanML3D's std is averaged within blocks)."""
    x = np.asarray(frames, dtype=np.float64)
    variance = x.reshape(-1, x.shape[-1]).var(axis=0, ddof=1)
    picks = np.zeros(len(variance), dtype=bool)
    picks[list(emphasised)] = True
    scaled = float(c) ** 2 * variance[picks].sum()
    return float(scaled / (scaled + variance[~picks].sum()))


def _check_counts(n_emphasised: int, n_total: int) -> None:
    if not 0 < n_emphasised < n_total:
        raise ValueError(f"need 0 < n_emphasised < n_total, got {n_emphasised}, {n_total}")


# ------------------------------------------------------------------------------ matrices

def gaussian_matrix(dim: int, seed: int) -> Tensor:
    """G (dim, dim) float64 with i.i.d. N(0, 1) entries from ``torch.Generator(seed)``."""
    generator = torch.Generator().manual_seed(int(seed))
    return torch.randn((dim, dim), generator=generator, dtype=torch.float64)


def orthogonal_matrix(dim: int, seed: int) -> Tensor:
    """√dim · Q with G = QR (G = :func:`gaussian_matrix`), the signs of Q's columns fixed so
    diag(R) > 0 (then Q is Haar-distributed). Rows and columns have norm exactly √dim."""
    q, r = torch.linalg.qr(gaussian_matrix(dim, seed))
    signs = torch.sign(torch.diagonal(r))
    signs[signs == 0] = 1.0
    return math.sqrt(dim) * q * signs[None, :]


def condition_number(matrix: ArrayLike) -> float:
    """κ₂(A) = σ_max(A)/σ_min(A), the 2-norm condition number, from the singular values in
    float64 (∞ for a singular matrix). It bounds the relative error the inverse amplifies:
    ‖δx‖/‖x‖ ≤ κ ‖δy‖/‖y‖ for x = y A⁻¹ (Golub & Van Loan §2.6)."""
    a = torch.as_tensor(np.asarray(matrix) if isinstance(matrix, np.ndarray) else matrix)
    if a.dim() != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"condition number needs a square matrix, got {tuple(a.shape)}")
    sigma = torch.linalg.svdvals(a.to(torch.float64))
    smallest = float(sigma.min())
    return math.inf if smallest == 0.0 else float(sigma.max()) / smallest


# ------------------------------------------------------------------------------ the projection

class EmphasisProjection:
    """P = D G / s applied to row-vector frames, y = x P, with the exact inverse x = y P⁻¹.

    Args:
        dim: features per frame n (263 for HumanML3D).
        emphasised: indices E whose rows of G are multiplied by c (GMD: 0, 1, 2).
        c: the emphasis constant (GMD: 10).
        seed: seed of the N(0, 1) matrix.
        kind: ``"gaussian"`` (GMD) or ``"orthogonal"`` (√n·Q, for comparison).
        normaliser: ``"sqrt"`` (GMD's code, 1/√(n − k + k c²)), ``"printed"`` (the
            appendix, 1/(n − k + k c²)) or ``"none"``.
        precision: ``"float64"`` (P and P⁻¹ formed in float64) or ``"float32_gmd"`` (GMD's
            released code: P rounded to float32, P⁻¹ inverted from it in float32).

    ``matrix`` and ``inverse`` are float64 (dim, dim); ``project``/``unproject`` take numpy
    or torch arrays (..., dim) and compute in the input's dtype (torch: differentiable, on the
    input's device; numpy integers are promoted to float64).
    """

    def __init__(self, dim: int = FEATURE_DIM, emphasised: Sequence[int] = GMD_EMPHASISED,
                 c: float = 10.0, seed: int = 0, kind: Kind = "gaussian",
                 normaliser: Normaliser = "sqrt", precision: Precision = "float64") -> None:
        if dim < 2:
            raise ValueError(f"dim must be at least 2, got {dim}")
        emphasised = tuple(int(i) for i in emphasised)
        if len(set(emphasised)) != len(emphasised) or not all(0 <= i < dim for i in emphasised):
            raise ValueError(f"emphasised must be distinct indices in [0, {dim}), got "
                             f"{emphasised}")
        if not emphasised or len(emphasised) >= dim:
            raise ValueError(f"need 1 ≤ len(emphasised) < dim, got {len(emphasised)}")
        if not (math.isfinite(c) and c > 0):
            raise ValueError(f"c must be a positive number, got {c}")
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        if precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {PRECISIONS}, got {precision!r}")
        self.dim, self.emphasised, self.c = int(dim), emphasised, float(c)
        self.seed, self.kind, self.normaliser = int(seed), kind, normaliser
        self.precision = precision
        self.scale = normalising_factor(c, len(emphasised), dim, normaliser)
        base = gaussian_matrix(dim, seed) if kind == "gaussian" else orthogonal_matrix(dim, seed)
        matrix = self.weights[:, None] * base * self.scale
        if precision == "float32_gmd":
            rounded = matrix.to(torch.float32)
            self.matrix: Tensor = rounded.to(torch.float64)
            self.inverse: Tensor = torch.linalg.inv(rounded).to(torch.float64)
        else:
            self.matrix = matrix
            self.inverse = torch.linalg.inv(matrix)
        self._cache: dict[tuple[torch.dtype, torch.device], tuple[Tensor, Tensor]] = {}

    def __repr__(self) -> str:
        return (f"EmphasisProjection(dim={self.dim}, emphasised={self.emphasised}, c={self.c}, "
                f"seed={self.seed}, kind={self.kind!r}, normaliser={self.normaliser!r}, "
                f"precision={self.precision!r})")

    def as_config(self) -> dict[str, object]:
        """Everything that determines the matrix (for cache keys); ``precision`` only where it
        is not the default, so the keys of float64 projections are those they always were."""
        config: dict[str, object] = {"dim": self.dim, "emphasised": list(self.emphasised),
                                     "c": self.c, "seed": self.seed, "kind": self.kind,
                                     "normaliser": self.normaliser}
        if self.precision != "float64":
            config["precision"] = self.precision
        return config

    @property
    def weights(self) -> Tensor:
        """d (dim,) float64: c on the emphasised features, 1 elsewhere (D = diag(d))."""
        d = torch.ones(self.dim, dtype=torch.float64)
        d[list(self.emphasised)] = self.c
        return d

    @property
    def singular_values(self) -> Tensor:
        """σ_1 ≥ … ≥ σ_n of P (float64): data direction v_i (a right-singular vector of Pᵀ,
        i.e. ‖v_i P‖ = σ_i) is scaled by σ_i in the projected space."""
        return torch.linalg.svdvals(self.matrix)

    @property
    def condition_number(self) -> float:
        """κ₂(P) = σ_max/σ_min in float64 (:func:`condition_number`; the scale s cancels,
        D and G set it; for the orthogonal kind κ = κ(D) = max(c, 1/c))."""
        return condition_number(self.matrix)

    def _matrices(self, like: Tensor) -> tuple[Tensor, Tensor]:
        key = (like.dtype, like.device)
        if key not in self._cache:
            self._cache[key] = (self.matrix.to(dtype=like.dtype, device=like.device),
                                self.inverse.to(dtype=like.dtype, device=like.device))
        return self._cache[key]

    def _apply(self, x: ArrayLike, which: int) -> ArrayLike:
        if x.shape[-1] != self.dim:
            raise ValueError(f"last axis must have {self.dim} features, got shape "
                             f"{tuple(x.shape)}")
        if isinstance(x, np.ndarray):
            array = x if np.issubdtype(x.dtype, np.floating) else x.astype(np.float64)
            return self._apply(torch.from_numpy(np.ascontiguousarray(array)), which).numpy()
        if not torch.is_floating_point(x):
            x = x.to(torch.float64)
        return x @ self._matrices(x)[which]

    def project(self, x: ArrayLike) -> ArrayLike:
        """y = x P for z-normalised frames x (..., dim) (GMD ``random_projection``)."""
        return self._apply(x, 0)

    def unproject(self, y: ArrayLike) -> ArrayLike:
        """x = y P⁻¹ (GMD ``inv_random_projection``), P⁻¹ formed in float64."""
        return self._apply(y, 1)

    def project_channels_first(self, x: ArrayLike) -> ArrayLike:
        """:meth:`project` for channels-first (B, dim, T) tensors (the UNet's layout)."""
        return _channels_first(self.project, x)

    def unproject_channels_first(self, y: ArrayLike) -> ArrayLike:
        """:meth:`unproject` for channels-first (B, dim, T) tensors."""
        return _channels_first(self.unproject, y)


def _channels_first(fn, x: ArrayLike) -> ArrayLike:
    if x.ndim < 2:
        raise ValueError(f"channels-first input needs at least 2 axes (C, T), got {x.shape}")
    if isinstance(x, np.ndarray):
        return np.swapaxes(fn(np.swapaxes(x, -1, -2)), -1, -2)
    return fn(x.transpose(-1, -2)).transpose(-1, -2)


# ------------------------------------------------------------------------------ measurements

def projected_importance(projection: EmphasisProjection) -> float:
    """Share of the projected energy E‖yx‖² that comes from the emphasised inputs, for
    x ~ N(0, I): Σ_{i∈E} ‖P_i‖² / ‖P‖²_F (exact for the given matrix; Eq. 4 in expectation
    over G, and exactly Eq. 4 for the orthogonal kind)."""
    rows = projection.matrix.pow(2).sum(dim=1)
    return float(rows[list(projection.emphasised)].sum() / rows.sum())


def per_dimension_variance(projection: EmphasisProjection, x: ArrayLike | None = None, *,
                           n_samples: int = 20000, seed: int = 0) -> np.ndarray:
    """Var̂[y_j] (dim,) of y = x P over the rows of ``x`` (N, dim) — by default
    ``n_samples`` draws of N(0, I) (float64, ``np.random.default_rng(seed)``)."""
    if x is None:
        x = np.random.default_rng(seed).standard_normal((n_samples, projection.dim))
    y = np.asarray(projection.project(np.asarray(x, dtype=np.float64)))
    return y.reshape(-1, projection.dim).var(axis=0, ddof=1)


def distance_ratios(projection: EmphasisProjection, frames: ArrayLike, *, n_pairs: int,
                    seed: int = 0) -> np.ndarray:
    """‖Px − Py‖/‖x − y‖ for ``n_pairs`` random pairs of distinct rows of ``frames``
    (N, dim), in float64; pairs with x = y are skipped (so fewer may come back)."""
    frames = np.asarray(frames, dtype=np.float64).reshape(-1, projection.dim)
    rng = np.random.default_rng(seed)
    first = rng.integers(len(frames), size=n_pairs)
    second = rng.integers(len(frames), size=n_pairs)
    difference = frames[first] - frames[second]
    norm = np.linalg.norm(difference, axis=1)
    keep = norm > 0
    projected = np.linalg.norm(np.asarray(projection.project(difference[keep])), axis=1)
    return projected / norm[keep]


def reconstruction_error(projection: EmphasisProjection, frames: ArrayLike,
                         dtype: torch.dtype = torch.float64,
                         inverse_in_dtype: bool = False) -> np.ndarray:
    """‖P⁻¹(Px) − x‖/‖x‖ per row of ``frames`` (N, dim), both maps computed in ``dtype``
    (the matrices rounded to it; the error is measured in float64 against x in ``dtype``).

    By default P⁻¹ is formed in float64 and then rounded (this package); with
    ``inverse_in_dtype`` it is inverted from the rounded P in ``dtype`` itself (GMD's
    ``torch.inverse`` of a float32 matrix)."""
    x = torch.as_tensor(np.asarray(frames)).reshape(-1, projection.dim).to(dtype)
    if inverse_in_dtype:
        matrix = projection.matrix.to(dtype)
        back = (x @ matrix) @ torch.linalg.inv(matrix)
    else:
        back = projection.unproject(projection.project(x))
    x64, back64 = x.to(torch.float64), back.to(torch.float64)
    return ((back64 - x64).norm(dim=1) / x64.norm(dim=1)).numpy()


def drowned_directions(projection: EmphasisProjection, alpha_bar: float) -> int:
    """How many data-space directions a diffusion on the *projected* data cannot see at
    noise level ᾱ: unit-variance signal along data direction v_i appears in the projected
    space scaled by σ_i (``singular_values``), against isotropic noise of variance 1 − ᾱ,
    so its signal-to-noise ratio is σ_i² ᾱ/(1 − ᾱ); counted are those with SNR < 1. The
    projected MSE weighs an error along v_i by σ_i² as well."""
    if not 0.0 < alpha_bar < 1.0:
        raise ValueError(f"alpha_bar must lie in (0, 1), got {alpha_bar}")
    snr = projection.singular_values.pow(2) * alpha_bar / (1.0 - alpha_bar)
    return int((snr < 1.0).sum())


def jl_tail_bound(low: float, high: float, k: int) -> float:
    """Johnson–Lindenstrauss tail bound for one fixed vector v and a k×k-output projection with
    i.i.d. N(0, 1/k) entries, where ‖vP‖²/‖v‖² ~ χ²_k/k. The Chernoff bound (Dasgupta & Gupta
    2003, Lemma 2.2) for a squared-length ratio β:

        P[‖vP‖² ≤ β‖v‖²] ≤ exp(k/2 · (1 − β + ln β))   (β < 1),
        P[‖vP‖² ≥ β‖v‖²] ≤ exp(k/2 · (1 − β + ln β))   (β > 1).

    Returns the sum for β = low² and β = high²: a bound on the probability that a pair's
    distance ratio ‖Px − Py‖/‖x − y‖ leaves the window [low, high]."""
    if not 0 < low < 1 < high:
        raise ValueError(f"need 0 < low < 1 < high, got {low}, {high}")

    def tail(beta: float) -> float:
        return math.exp(k / 2.0 * (1.0 - beta + math.log(beta)))

    return min(1.0, tail(low**2) + tail(high**2))


# ------------------------------------------------------------------------ the checks' sizes

@dataclass(frozen=True)
class ProjectionSettings(RunSettings):
    """The sample sizes of notebook 03's projection checks (GMD-C1…C3), fixed before the run:
    N(0, 1) vectors per simulated point, frame pairs for the distance ratios and frames for
    the inverse's round trip (per matrix), and the κ scan (matrix seeds, frames per seed).
    Quick mode shrinks them (a test of the code, never a result); standard and paper scales
    share the full sizes (analytic checks, seconds)."""

    simulation_samples: int
    distance_pairs: int
    inverse_frames: int
    kappa_scan_seeds: int
    kappa_scan_frames: int

    @classmethod
    def for_scale(cls, scale: str) -> ProjectionSettings:
        if check_scale(scale) == "quick":
            return cls(simulation_samples=2000, distance_pairs=2000, inverse_frames=1000,
                       kappa_scan_seeds=5, kappa_scan_frames=500)
        return cls(simulation_samples=10000, distance_pairs=10000, inverse_frames=5000,
                   kappa_scan_seeds=20, kappa_scan_frames=1000)
