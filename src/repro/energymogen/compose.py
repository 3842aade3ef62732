"""Energy-based composition of text concepts in latent motion diffusion (EnergyMoGen Sec. 3.2).

Operators, each on ε predictions of one shape (B, N, d):

- latent-aware (Eq. 7, 8): ε^l = ε(∅) + Σ_i w_i (ε(c_i) − ε(∅)); negation
  ε^l = ε(∅) + w (ε(c_i) − ε(c_j)), which is Eq. 7 with weights (w, −w);
- semantic-aware (Eq. 9): every cross-attention layer averages the concepts' outputs with
  weights w^s normalised by their signed sum (``repro.models.latent_denoiser``);
- AGD (Eq. 3–4): the text embedding moves down the cross-attention energies layer by layer;
- SEF (Eq. 10): ε̂ = λ_l ε^l + λ_s ε^s + λ_m ε(c_{1,n}), λ_l + λ_s + λ_m = 1.

``make_composed_eps_fn`` builds ``eps_fn(z_t, t)`` for
``GaussianDiffusion.ddim_sample_loop(None, shape, steps=50, model_fn=eps_fn)``.

Our choices where the paper is silent (REFERENCE.md: "the guidance scale for each SEF term"):

- ε^s and ε(c_{1,n}) enter Eq. 10 classifier-free guided with the same scale s,
  ε(∅) + s(ε(c) − ε(∅)); ε^l is Eq. 7, whose w_i play that role (default w_i = s for every
  concept, as in Liu et al.'s Composable Diffusion);
- AGD acts on every conditional evaluation (ε(c_i), ε^s, ε(c_{1,n})), never on ε(∅);
- a term with λ = 0 is not evaluated.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Literal, get_args

import torch
from torch import Tensor

from repro.models.latent_denoiser import CrossAttentionControl, LatentDenoiser

__all__ = [
    "Condition",
    "MODES",
    "Mode",
    "adaptive_gradient_descent",
    "classifier_free_guidance",
    "latent_conjunction",
    "latent_negation",
    "make_composed_eps_fn",
    "semantic_composition",
    "stack_conditions",
    "synergistic_energy_fusion",
]

#: one text: (tokens (B or 1, L, D), mask (B or 1, L) bool)
Condition = tuple[Tensor, Tensor]
#: the composition modes of :func:`make_composed_eps_fn` (``pipeline.SamplerMode`` adds the
#: unconditional model to them)
Mode = Literal["single", "latent", "semantic", "sef"]
MODES: tuple[str, ...] = get_args(Mode)


def _check_weights(weights: Sequence[float] | Tensor, n: int, name: str) -> list[float]:
    values = [float(w) for w in torch.as_tensor(weights, dtype=torch.float64).reshape(-1)]
    if len(values) != n:
        raise ValueError(f"{name} needs {n} weights (one per concept), got {len(values)}")
    if not all(math.isfinite(w) for w in values):
        raise ValueError(f"{name} must be finite, got {values}")
    return values


# ----------------------------------------------------------------------------------------------
# Operators on ε
# ----------------------------------------------------------------------------------------------


def classifier_free_guidance(eps_uncond: Tensor, eps_cond: Tensor, scale: float) -> Tensor:
    """ε(∅) + s (ε(c) − ε(∅))  (Ho & Salimans; Eq. 7 with one concept)."""
    if eps_uncond.shape != eps_cond.shape:
        raise ValueError(f"ε shapes differ: {tuple(eps_uncond.shape)} vs {tuple(eps_cond.shape)}")
    return eps_uncond + scale * (eps_cond - eps_uncond)


def latent_conjunction(eps_uncond: Tensor, eps_conds: Sequence[Tensor] | Tensor,
                       weights: Sequence[float] | Tensor) -> Tensor:
    """ε^l = ε(∅) + Σ_i w_i (ε(c_i) − ε(∅))   (Eq. 7).

    ``eps_conds``: n tensors shaped like ``eps_uncond`` (or one (n, …) tensor). A negative
    w_i negates concept i (Liu et al.'s form; Eq. 8 is weights (w, −w)).
    """
    eps_conds = list(eps_conds)
    if not eps_conds:
        raise ValueError("latent_conjunction needs at least one conditional ε")
    w = _check_weights(weights, len(eps_conds), "weights")
    result = eps_uncond
    for w_i, eps_i in zip(w, eps_conds, strict=True):
        if eps_i.shape != eps_uncond.shape:
            raise ValueError(f"ε(c_i) shape {tuple(eps_i.shape)} != ε(∅) shape "
                             f"{tuple(eps_uncond.shape)}")
        result = result + w_i * (eps_i - eps_uncond)
    return result


def latent_negation(eps_uncond: Tensor, eps_keep: Tensor, eps_neg: Tensor, weight: float,
                    neg_weight: float | None = None) -> Tensor:
    """ε^l = ε(∅) + w (ε(c_i) − ε(c_j))   (Eq. 8, p(z|c_i, not c_j) ∝ p(z) p(c_i|z)/p(c_j|z)).

    Eq. 8 has no separate positive term: it equals ε(∅) + w(ε(c_i) − ε(∅)) − w(ε(c_j) − ε(∅)).
    ``neg_weight`` w_j ≠ w gives Liu et al.'s general form with that second weight.
    """
    for name, eps in (("eps_keep", eps_keep), ("eps_neg", eps_neg)):
        if eps.shape != eps_uncond.shape:
            raise ValueError(f"{name} shape {tuple(eps.shape)} != ε(∅) shape "
                             f"{tuple(eps_uncond.shape)}")
    if neg_weight is None:
        return eps_uncond + weight * (eps_keep - eps_neg)
    return latent_conjunction(eps_uncond, [eps_keep, eps_neg], [weight, -neg_weight])


def synergistic_energy_fusion(eps_latent: Tensor | None, eps_semantic: Tensor | None,
                              eps_multi: Tensor | None,
                              lambdas: Sequence[float]) -> Tensor:
    """ε̂ = λ_l ε^l + λ_s ε^s + λ_m ε(c_{1,n}),  λ_l + λ_s + λ_m = 1   (Eq. 10).

    A term may be None only when its λ is 0 (it is then not needed). The paper's best
    λ = (λ_l, λ_s, λ_m) = (0.1, 0.7, 0.2).
    """
    lam = _check_weights(lambdas, 3, "lambdas (λ_l, λ_s, λ_m)")
    if abs(sum(lam) - 1.0) > 1e-6:
        raise ValueError(f"SEF weights must sum to 1 (Eq. 10), got {lam} (sum {sum(lam)})")
    terms = []
    for name, lam_k, eps in (("eps_latent", lam[0], eps_latent),
                             ("eps_semantic", lam[1], eps_semantic),
                             ("eps_multi", lam[2], eps_multi)):
        if lam_k == 0:
            continue
        if eps is None:
            raise ValueError(f"{name} is None but its λ is {lam_k}")
        terms.append(lam_k * eps)
    shapes = {tuple(term.shape) for term in terms}
    if len(shapes) > 1:
        raise ValueError(f"SEF terms have different shapes: {sorted(shapes)}")
    result = terms[0]
    for term in terms[1:]:
        result = result + term
    return result


# ----------------------------------------------------------------------------------------------
# Evaluating the denoiser
# ----------------------------------------------------------------------------------------------


def stack_conditions(conditions: Sequence[Condition], batch: int) -> tuple[Tensor, Tensor]:
    """n texts → (tokens (B, n, L, D), mask (B, n, L)), padded to the longest L, batch-1
    conditions broadcast to ``batch``."""
    if not conditions:
        raise ValueError("need at least one condition")
    length = max(tokens.shape[-2] for tokens, _ in conditions)
    all_tokens, all_masks = [], []
    for i, (tokens, mask) in enumerate(conditions):
        if tokens.dim() == 2:
            tokens, mask = tokens[None], mask[None]
        if tokens.dim() != 3 or mask.shape != tokens.shape[:2] or mask.dtype != torch.bool:
            raise ValueError(f"condition {i}: need tokens (B, L, D) and a bool mask (B, L), got "
                             f"{tuple(tokens.shape)} and {tuple(mask.shape)} {mask.dtype}")
        if tokens.shape[0] not in (1, batch):
            raise ValueError(f"condition {i} has batch {tokens.shape[0]}, expected 1 or {batch}")
        pad = length - tokens.shape[1]
        tokens = torch.nn.functional.pad(tokens, (0, 0, 0, pad))
        mask = torch.nn.functional.pad(mask, (0, pad), value=False)
        all_tokens.append(tokens.expand(batch, -1, -1))
        all_masks.append(mask.expand(batch, -1))
    return torch.stack(all_tokens, dim=1), torch.stack(all_masks, dim=1)


def _eps_uncond(denoiser: LatentDenoiser, z_t: Tensor, t: Tensor) -> Tensor:
    return denoiser(z_t, t, *denoiser.null_text(z_t.shape[0]))


def _eps_each(denoiser: LatentDenoiser, z_t: Tensor, t: Tensor, conditions: Sequence[Condition],
              control: CrossAttentionControl | None) -> list[Tensor]:
    """[ε(c_1), …, ε(c_m)] in one batched call (B·m rows)."""
    b = z_t.shape[0]
    tokens, mask = stack_conditions(conditions, b)
    m = tokens.shape[1]
    t = torch.as_tensor(t, device=z_t.device).reshape(-1).expand(b)
    eps = denoiser(z_t.repeat(m, 1, 1), t.repeat(m), tokens.transpose(0, 1).flatten(0, 1),
                   mask.transpose(0, 1).flatten(0, 1), composition=control)
    return list(eps.unflatten(0, (m, b)))


def _control(gamma_attn: float, gamma_reg: float) -> CrossAttentionControl | None:
    control = CrossAttentionControl(gamma_attn=gamma_attn, gamma_reg=gamma_reg)
    return control if control.agd else None


def semantic_composition(denoiser: LatentDenoiser, z_t: Tensor, t: Tensor,
                         concepts: Sequence[Condition], weights: Sequence[float], *,
                         guidance_scale: float | None = None, gamma_attn: float = 0.0,
                         gamma_reg: float = 0.0, eps_uncond: Tensor | None = None) -> Tensor:
    """ε^s: the denoiser with ẑ' = Σ_i w^s_i z'_i / Σ_i w^s_i in every cross-attention layer
    (Eq. 9; w^s_i < 0 negates concept i). ``guidance_scale`` None returns the composed
    conditional ε^s itself, a number s returns ε(∅) + s(ε^s − ε(∅)) (our choice for Eq. 10).
    """
    w = _check_weights(weights, len(concepts), "semantic weights w^s")
    tokens, mask = stack_conditions(concepts, z_t.shape[0])
    control = CrossAttentionControl(concept_weights=w, gamma_attn=gamma_attn,
                                    gamma_reg=gamma_reg)
    eps_s = denoiser(z_t, t, tokens, mask, composition=control)
    if guidance_scale is None:
        return eps_s
    if eps_uncond is None:
        eps_uncond = _eps_uncond(denoiser, z_t, t)
    return classifier_free_guidance(eps_uncond, eps_s, guidance_scale)


def adaptive_gradient_descent(denoiser: LatentDenoiser, z_t: Tensor, t: Tensor,
                              condition: Condition, *, gamma_attn: float, gamma_reg: float,
                              guidance_scale: float | None = None,
                              eps_uncond: Tensor | None = None) -> Tensor:
    """ε(c) with the text embedding refined by AGD in every cross-attention layer, restarting
    from ``condition`` at this call (Eq. 3–4); γ = 0 gives the plain ε(c). With a guidance
    scale s: ε(∅) + s(ε(c) − ε(∅)), ε(∅) without AGD (our choice)."""
    (eps_c,) = _eps_each(denoiser, z_t, t, [condition], _control(gamma_attn, gamma_reg))
    if guidance_scale is None:
        return eps_c
    if eps_uncond is None:
        eps_uncond = _eps_uncond(denoiser, z_t, t)
    return classifier_free_guidance(eps_uncond, eps_c, guidance_scale)


def make_composed_eps_fn(denoiser: LatentDenoiser, concepts: Sequence[Condition], *,
                         mode: Mode = "sef", multi: Condition | None = None,
                         weights: Sequence[float] | None = None,
                         semantic_weights: Sequence[float] | None = None,
                         lambdas: Sequence[float] = (0.1, 0.7, 0.2),
                         guidance_scale: float = 7.5,
                         gammas: tuple[float, float] = (0.0, 0.0),
                         ) -> Callable[[Tensor, Tensor], Tensor]:
    """``eps_fn(z_t, t) -> ε̂`` for ``ddim_sample_loop(model_fn=…)``.

    - ``mode="single"``: ε(∅) + s(ε(c_{1,n}) − ε(∅)) on ``multi`` (AGD if γ > 0; Table 3
      "Ours + AGD"); ``concepts`` may be empty;
    - ``"latent"``: Eq. 7 with ``weights`` w^l (default s for each; negative = negation, Eq. 8);
    - ``"semantic"``: Eq. 9 with ``semantic_weights`` w^s (default 1 each), guided with s;
    - ``"sef"``: Eq. 10 with ``lambdas`` (λ_l, λ_s, λ_m) over the three above.

    ``gammas`` = (γ_attn, γ_reg) of Eq. 4, applied to every conditional evaluation. The
    denoiser must be in eval mode (dropout would make sampling non-deterministic).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be 'single', 'latent', 'semantic' or 'sef', got {mode!r}")
    if denoiser.training:
        raise ValueError("the denoiser is in training mode; call denoiser.eval() first")
    if len(gammas) != 2:
        raise ValueError(f"gammas must be (γ_attn, γ_reg), got {gammas!r}")
    concepts = list(concepts)
    n = len(concepts)
    if mode != "single" and n == 0:
        raise ValueError(f"mode {mode!r} needs at least one concept")
    lam = (0.0, 0.0, 1.0) if mode == "single" else (
        (1.0, 0.0, 0.0) if mode == "latent" else (0.0, 1.0, 0.0) if mode == "semantic"
        else tuple(_check_weights(lambdas, 3, "lambdas")))
    if abs(sum(lam) - 1.0) > 1e-6:
        raise ValueError(f"SEF weights must sum to 1 (Eq. 10), got {list(lam)}")
    if lam[2] != 0 and multi is None:
        raise ValueError(f"mode {mode!r} with λ_m = {lam[2]} needs the multi-concept text "
                         "`multi`")
    w_l = _check_weights(weights, n, "weights w^l") if weights is not None else [
        float(guidance_scale)] * n
    w_s = (_check_weights(semantic_weights, n, "semantic weights w^s")
           if semantic_weights is not None else [1.0] * n)
    if lam[1] != 0 and abs(sum(w_s)) < 1e-8:
        raise ValueError("the signed sum of semantic weights is 0; Eq. 9 divides by it")
    gamma_attn, gamma_reg = float(gammas[0]), float(gammas[1])
    control = _control(gamma_attn, gamma_reg)

    def eps_fn(z_t: Tensor, t: Tensor) -> Tensor:
        eps_uncond = _eps_uncond(denoiser, z_t, t)
        conditional = (concepts if lam[0] != 0 else []) + ([multi] if lam[2] != 0 else [])
        eps_cond = _eps_each(denoiser, z_t, t, conditional, control) if conditional else []
        eps_latent = eps_semantic = eps_multi = None
        if lam[0] != 0:
            eps_latent = latent_conjunction(eps_uncond, eps_cond[:n], w_l)
        if lam[2] != 0:
            eps_multi = classifier_free_guidance(eps_uncond, eps_cond[-1], guidance_scale)
        if lam[1] != 0:
            eps_semantic = semantic_composition(
                denoiser, z_t, t, concepts, w_s, guidance_scale=guidance_scale,
                gamma_attn=gamma_attn, gamma_reg=gamma_reg, eps_uncond=eps_uncond)
        return synergistic_energy_fusion(eps_latent, eps_semantic, eps_multi, lam)

    return eps_fn
