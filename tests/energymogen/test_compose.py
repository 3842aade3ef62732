"""Composition operators (EnergyMoGen Eq. 3–4, 7–10) with hand-computed answers, and DDIM."""

from __future__ import annotations

import pytest
import torch
from torch import Tensor

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.energymogen.compose import (
    adaptive_gradient_descent,
    classifier_free_guidance,
    latent_conjunction,
    latent_negation,
    make_composed_eps_fn,
    semantic_composition,
    stack_conditions,
    synergistic_energy_fusion,
)
from repro.models.latent_denoiser import (
    CrossAttentionControl,
    LatentDenoiser,
    normalised_concept_weights,
)

torch.set_num_threads(1)
N, D_LATENT, D_TEXT, B = 3, 4, 4, 2


def _const(value: float) -> Tensor:
    return torch.full((B, N, D_LATENT), float(value))


class ConstantDenoiser(LatentDenoiser):
    """A toy whose ε(c) is the constant c[0, 0] (the text's first token's first number), with
    ε(∅) = 0, and Eq. 9 as Σ w_i ε(c_i)/Σ w_i — so every composed ε is computable by hand."""

    def __init__(self) -> None:
        super().__init__(D_LATENT, N, D_TEXT, width=8, layers=1, heads=1)
        with torch.no_grad():
            self.null_token.zero_()

    def forward(self, z_t, t, text_tokens, text_mask, *, cond_keep=None, composition=None):
        value = text_tokens[..., 0, 0]                                   # (B,) or (B, n)
        if composition is not None and composition.concept_weights is not None:
            w = normalised_concept_weights(composition.concept_weights, *value.shape)
            value = (w * value).sum(dim=1)
        return value[:, None, None].expand(-1, N, D_LATENT).clone()


def _concept(value: float, length: int = 2) -> tuple[Tensor, Tensor]:
    tokens = torch.zeros(1, length, D_TEXT)
    tokens[0, 0, 0] = value
    return tokens, torch.ones(1, length, dtype=torch.bool)


def _real_denoiser() -> LatentDenoiser:
    torch.manual_seed(0)
    return LatentDenoiser(D_LATENT, N, D_TEXT, width=16, layers=2, heads=2).eval()


def _text(seed: int, length: int = 3) -> tuple[Tensor, Tensor]:
    g = torch.Generator().manual_seed(seed)
    return torch.randn(1, length, D_TEXT, generator=g), torch.ones(1, length, dtype=torch.bool)


def _z_t() -> tuple[Tensor, Tensor]:
    return torch.randn(B, N, D_LATENT, generator=torch.Generator().manual_seed(7)), torch.tensor(
        [10, 600])


# -- latent-aware (Eq. 7, 8) ---------------------------------------------------------------------


def test_conjunction_by_hand():
    # ε(∅) = 1, ε(c_1) = 3, ε(c_2) = −2, w = (2, 0.5):  1 + 2·2 + 0.5·(−3) = 3.5
    out = latent_conjunction(_const(1), [_const(3), _const(-2)], [2.0, 0.5])
    torch.testing.assert_close(out, _const(3.5))
    # weights summing to 1 cancel ε(∅): the weighted mean of the ε(c_i)
    out = latent_conjunction(_const(100), [_const(3), _const(-2)], [0.25, 0.75])
    torch.testing.assert_close(out, _const(0.25 * 3 + 0.75 * -2))
    torch.testing.assert_close(latent_conjunction(_const(1), torch.stack([_const(3)]), [1.0]),
                               _const(3))
    with pytest.raises(ValueError, match="needs 2 weights"):
        latent_conjunction(_const(1), [_const(3), _const(-2)], [1.0])
    with pytest.raises(ValueError, match="shape"):
        latent_conjunction(_const(1), [torch.zeros(1, N, D_LATENT)], [1.0])


def test_negation_sign_by_hand():
    # ε(∅) = 0.5, keep = 1, neg = 3, w = 2:  0.5 + 2·(1 − 3) = −3.5 — pushed away from c_j
    out = latent_negation(_const(0.5), _const(1), _const(3), 2.0)
    torch.testing.assert_close(out, _const(-3.5))
    # Eq. 8 is Eq. 7 with weights (w, −w); a separate negative weight is Liu et al.'s form
    torch.testing.assert_close(
        out, latent_conjunction(_const(0.5), [_const(1), _const(3)], [2.0, -2.0]))
    torch.testing.assert_close(latent_negation(_const(0.5), _const(1), _const(3), 2.0, 1.0),
                               _const(0.5 + 2 * 0.5 - 1 * 2.5))
    torch.testing.assert_close(classifier_free_guidance(_const(1), _const(2), 7.5), _const(8.5))


# -- SEF (Eq. 10) --------------------------------------------------------------------------------


def test_sef_by_hand_and_lambda_checks():
    out = synergistic_energy_fusion(_const(1), _const(2), _const(4), (0.1, 0.7, 0.2))
    torch.testing.assert_close(out, _const(0.1 + 1.4 + 0.8))
    assert torch.equal(synergistic_energy_fusion(_const(1), _const(2), _const(4), (1, 0, 0)),
                       _const(1))
    assert torch.equal(synergistic_energy_fusion(None, _const(2), None, (0, 1, 0)), _const(2))
    with pytest.raises(ValueError, match="sum to 1"):
        synergistic_energy_fusion(_const(1), _const(2), _const(4), (0.5, 0.5, 0.5))
    with pytest.raises(ValueError, match="needs 3 weights"):
        synergistic_energy_fusion(_const(1), _const(2), _const(4), (0.5, 0.5))
    with pytest.raises(ValueError, match="eps_multi is None"):
        synergistic_energy_fusion(_const(1), _const(2), None, (0.4, 0.4, 0.2))


def test_composed_eps_fn_on_the_constant_toy_matches_hand_computation():
    toy = ConstantDenoiser().eval()
    z, t = _z_t()
    concepts, multi = [_concept(1.0), _concept(-2.0, length=3)], _concept(5.0)
    s = 3.0
    # latent, default w_i = s:  0 + 3·1 + 3·(−2) = −3
    latent = make_composed_eps_fn(toy, concepts, mode="latent", guidance_scale=s)(z, t)
    torch.testing.assert_close(latent, _const(-3.0)[:, :, :])
    # latent negation weights (2, −2): 2·(1 − (−2)) = 6
    negation = make_composed_eps_fn(toy, concepts, mode="latent", weights=[2.0, -2.0])(z, t)
    torch.testing.assert_close(negation, _const(6.0))
    # semantic w^s = (1, 1): ε^s = (1 − 2)/2 = −0.5, guided: 0 + 3·(−0.5) = −1.5
    semantic = make_composed_eps_fn(toy, concepts, mode="semantic", guidance_scale=s)(z, t)
    torch.testing.assert_close(semantic, _const(-1.5))
    # semantic negation w^s = (1, −0.5): (1 + 1)/0.5 = 4, guided 12
    semantic_neg = make_composed_eps_fn(toy, concepts, mode="semantic", guidance_scale=s,
                                        semantic_weights=[1.0, -0.5])(z, t)
    torch.testing.assert_close(semantic_neg, _const(12.0))
    # single: 0 + 3·5 = 15;  SEF (0.1, 0.7, 0.2): −0.3 − 1.05 + 3 = 1.65
    single = make_composed_eps_fn(toy, [], mode="single", multi=multi, guidance_scale=s)(z, t)
    torch.testing.assert_close(single, _const(15.0))
    sef = make_composed_eps_fn(toy, concepts, mode="sef", multi=multi, guidance_scale=s)(z, t)
    torch.testing.assert_close(sef, _const(1.65))


def test_sef_corners_equal_latent_and_semantic_only_on_the_real_denoiser():
    model = _real_denoiser()
    z, t = _z_t()
    concepts, multi = [_text(1), _text(2, length=5)], _text(3, length=4)
    common = dict(multi=multi, guidance_scale=2.0, gammas=(0.01, 0.02))
    latent_only = make_composed_eps_fn(model, concepts, mode="latent", **common)(z, t)
    semantic_only = make_composed_eps_fn(model, concepts, mode="semantic", **common)(z, t)
    single = make_composed_eps_fn(model, concepts, mode="single", **common)(z, t)
    corner = {lam: make_composed_eps_fn(model, concepts, mode="sef", lambdas=lam, **common)(z, t)
              for lam in [(1, 0, 0), (0, 1, 0), (0, 0, 1)]}
    torch.testing.assert_close(corner[(1, 0, 0)], latent_only)
    torch.testing.assert_close(corner[(0, 1, 0)], semantic_only)
    torch.testing.assert_close(corner[(0, 0, 1)], single)
    assert (latent_only - semantic_only).abs().max() > 1e-4
    mixed = make_composed_eps_fn(model, concepts, mode="sef", lambdas=(0.1, 0.7, 0.2),
                                 **common)(z, t)
    torch.testing.assert_close(mixed, 0.1 * latent_only + 0.7 * semantic_only + 0.2 * single)


def test_composed_eps_fn_rejects_bad_settings():
    model = _real_denoiser()
    concepts = [_text(1), _text(2)]
    with pytest.raises(ValueError, match="sum to 1"):
        make_composed_eps_fn(model, concepts, mode="sef", multi=_text(3), lambdas=(0.2, 0.2, 0.2))
    with pytest.raises(ValueError, match="needs the multi-concept text"):
        make_composed_eps_fn(model, concepts, mode="sef")
    with pytest.raises(ValueError, match="mode must be"):
        make_composed_eps_fn(model, concepts, mode="both")
    with pytest.raises(ValueError, match="signed sum"):
        make_composed_eps_fn(model, concepts, mode="semantic", semantic_weights=[1.0, -1.0])
    with pytest.raises(ValueError, match="needs 2 weights"):
        make_composed_eps_fn(model, concepts, mode="latent", weights=[1.0])
    with pytest.raises(ValueError, match="at least one concept"):
        make_composed_eps_fn(model, [], mode="latent")
    with pytest.raises(ValueError, match="eval"):
        make_composed_eps_fn(model.train(), concepts, mode="latent")


# -- semantic-aware (Eq. 9) and AGD (Eq. 3–4) on the real denoiser --------------------------------


def test_semantic_composition_single_concept_weight_one_is_the_conditional_forward():
    model = _real_denoiser()
    z, t = _z_t()
    tokens, mask = _text(4)
    plain = model(z, t, tokens.expand(B, -1, -1), mask.expand(B, -1))
    torch.testing.assert_close(semantic_composition(model, z, t, [(tokens, mask)], [1.0]), plain,
                               rtol=1e-6, atol=1e-6)
    uncond = model(z, t, *model.null_text(B))
    torch.testing.assert_close(
        semantic_composition(model, z, t, [(tokens, mask)], [1.0], guidance_scale=4.0),
        uncond + 4.0 * (plain - uncond), rtol=1e-5, atol=1e-5)


def test_agd_zero_gamma_is_identical_and_positive_gamma_changes_epsilon():
    model = _real_denoiser()
    z, t = _z_t()
    tokens, mask = _text(5)
    plain = model(z, t, tokens.expand(B, -1, -1), mask.expand(B, -1))
    assert torch.equal(adaptive_gradient_descent(model, z, t, (tokens, mask), gamma_attn=0.0,
                                                 gamma_reg=0.0), plain)
    refined = adaptive_gradient_descent(model, z, t, (tokens, mask), gamma_attn=0.5,
                                        gamma_reg=0.5)
    assert (refined - plain).abs().max() > 1e-5
    direct = model(z, t, tokens.expand(B, -1, -1), mask.expand(B, -1),
                   composition=CrossAttentionControl(gamma_attn=0.5, gamma_reg=0.5))
    torch.testing.assert_close(refined, direct)


def test_stack_conditions_pads_and_broadcasts():
    tokens, mask = stack_conditions([_text(1, length=2), _text(2, length=4)], batch=3)
    assert tokens.shape == (3, 2, 4, D_TEXT) and mask.shape == (3, 2, 4)
    assert mask[:, 0].tolist() == [[True, True, False, False]] * 3
    assert torch.count_nonzero(tokens[:, 0, 2:]) == 0
    with pytest.raises(ValueError, match="batch 2, expected 1 or 3"):
        stack_conditions([(torch.zeros(2, 2, D_TEXT), torch.ones(2, 2, dtype=torch.bool))], 3)


# -- DDIM with the composed ε ---------------------------------------------------------------------


def test_ddim_with_the_composed_eps_is_deterministic_given_the_seed():
    model = _real_denoiser()
    diffusion = GaussianDiffusion(cosine_betas(100))
    eps_fn = make_composed_eps_fn(model, [_text(1), _text(2)], mode="sef", multi=_text(3),
                                  guidance_scale=1.5, gammas=(0.001, 0.002))
    shape = (B, N, D_LATENT)
    a = diffusion.ddim_sample_loop(None, shape, steps=10, model_fn=eps_fn, seed=0)
    b = diffusion.ddim_sample_loop(None, shape, steps=10, model_fn=eps_fn, seed=0)
    c = diffusion.ddim_sample_loop(None, shape, steps=10, model_fn=eps_fn, seed=1)
    assert a.shape == shape and torch.isfinite(a).all()
    assert torch.equal(a, b)
    assert (a - c).abs().max() > 1e-3
