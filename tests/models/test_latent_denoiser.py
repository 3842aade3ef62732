"""LatentDenoiser: shapes, ∅ path, text masking, Eq. 9 hook, Eq. 3–4 energies and AGD."""

from __future__ import annotations

import pytest
import torch

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.core.training import TrainConfig
from repro.models.latent_denoiser import (
    CrossAttentionControl,
    EnergyCrossAttention,
    LatentDenoiser,
    normalised_concept_weights,
    train_latent_denoiser,
)

torch.set_num_threads(1)
N, D_LATENT, D_TEXT = 4, 6, 10


def _denoiser(layers: int = 2, latent_count: int = N) -> LatentDenoiser:
    torch.manual_seed(0)
    return LatentDenoiser(D_LATENT, latent_count, D_TEXT, width=16, layers=layers, heads=2).eval()


def _text(batch: int, length: int, valid: list[int] | None = None, seed: int = 1):
    g = torch.Generator().manual_seed(seed)
    tokens = torch.randn(batch, length, D_TEXT, generator=g)
    valid = valid or [length] * batch
    mask = torch.arange(length)[None] < torch.tensor(valid)[:, None]
    return tokens, mask


def _inputs(batch: int = 3, latent_count: int = N):
    g = torch.Generator().manual_seed(2)
    return torch.randn(batch, latent_count, D_LATENT, generator=g), torch.tensor([0, 500, 999])[
        :batch]


@pytest.mark.parametrize("latent_count,length", [(1, 1), (5, 7), (7, 3)])
def test_output_shape(latent_count, length):
    model = _denoiser(latent_count=latent_count)
    z, t = _inputs(3, latent_count)
    tokens, mask = _text(3, length)
    assert model(z, t, tokens, mask).shape == (3, latent_count, D_LATENT)
    assert model(z, torch.tensor(7), tokens, mask).shape == (3, latent_count, D_LATENT)
    rebuilt = LatentDenoiser(**model.config())
    rebuilt.load_state_dict(model.state_dict())
    assert rebuilt.config() == model.config()


def test_text_changes_the_output_and_padded_tokens_do_not():
    model = _denoiser()
    z, t = _inputs()
    tokens, mask = _text(3, 6, valid=[6, 3, 1])
    out = model(z, t, tokens, mask)
    other = model(z, t, _text(3, 6, valid=[6, 3, 1], seed=9)[0], mask)
    assert (out - other).abs().amax(dim=(1, 2)).min() > 1e-4
    garbage = tokens.clone()
    garbage[1, 3:] = 50.0
    garbage[2, 1:] = -50.0
    torch.testing.assert_close(model(z, t, garbage, mask), out)


def test_null_condition_path():
    model = _denoiser()
    z, t = _inputs()
    tokens, mask = _text(3, 5)
    null_tokens, null_mask = model.null_text(3)
    assert null_tokens.shape == (3, 1, D_TEXT) and null_mask.all()
    uncond = model(z, t, null_tokens, null_mask)
    cond = model(z, t, tokens, mask)
    torch.testing.assert_close(model(z, t, tokens, mask, cond_keep=torch.zeros(3, dtype=bool)),
                               uncond)
    torch.testing.assert_close(model(z, t, tokens, mask, cond_keep=torch.ones(3, dtype=bool)),
                               cond)
    mixed = model(z, t, tokens, mask, cond_keep=torch.tensor([True, False, True]))
    torch.testing.assert_close(mixed[[0, 2]], cond[[0, 2]])
    torch.testing.assert_close(mixed[1], uncond[1])
    assert (cond - uncond).abs().max() > 1e-4
    # the null token is a parameter that training reaches through cond_keep
    model.train()
    model(z, t, tokens, mask, cond_keep=torch.tensor([True, False, True])).sum().backward()
    assert model.null_token.grad is not None and model.null_token.grad.abs().sum() > 0


def test_bad_inputs_raise_value_errors():
    model = _denoiser()
    z, t = _inputs()
    tokens, mask = _text(3, 4)
    with pytest.raises(ValueError, match=r"z_t must be \(B, 4, 6\)"):
        model(z[:, :3], t, tokens, mask)
    with pytest.raises(ValueError, match="no valid token"):
        model(z, t, tokens, torch.zeros_like(mask))
    with pytest.raises(ValueError, match="do not match"):
        model(z, t, tokens[..., :9], mask)
    with pytest.raises(ValueError, match="must be bool"):
        model(z, t, tokens, mask.float())
    with pytest.raises(ValueError, match="cond_keep must be"):
        model(z, t, tokens, mask, cond_keep=torch.ones(2, dtype=bool))
    with pytest.raises(ValueError, match=r"\(B=3, n, L, D\)"):
        model(z, t, tokens, mask, composition=CrossAttentionControl(concept_weights=[1.0]))
    with pytest.raises(ValueError, match="gamma_attn must be"):
        CrossAttentionControl(gamma_attn=-1.0)
    with pytest.raises(ValueError, match="signed sum"):
        normalised_concept_weights([1.0, -1.0], 2, 2)
    with pytest.raises(ValueError, match=r"\(n,\) or \(B, n\)"):
        normalised_concept_weights([1.0, 2.0, 3.0], 2, 2)


# -- Eq. 9: semantic composition in the cross-attention ------------------------------------------


def test_cross_attention_combines_concepts_after_the_output_projection():
    torch.manual_seed(0)
    attention = EnergyCrossAttention(16, D_TEXT, heads=2)
    h = torch.randn(2, 5, 16)
    (t1, m1), (t2, m2) = _text(2, 4, valid=[4, 2], seed=3), _text(2, 4, valid=[1, 4], seed=4)
    o1, o2 = attention(h, t1, m1), attention(h, t2, m2)
    stacked, masks = torch.stack([t1, t2], 1), torch.stack([m1, m2], 1)
    for weights, expected in (([1.0, 1.0], (o1 + o2) / 2),
                              ([1.0, -0.5], (o1 - 0.5 * o2) / 0.5),
                              ([3.0, 1.0], (3 * o1 + o2) / 4)):
        w = normalised_concept_weights(weights, 2, 2)
        torch.testing.assert_close(attention(h, stacked, masks, w), expected)
    with pytest.raises(ValueError, match="normalised concept weights"):
        attention(h, stacked, masks)


def test_single_concept_with_weight_one_is_the_plain_forward():
    model = _denoiser()
    z, t = _inputs()
    tokens, mask = _text(3, 5, valid=[5, 2, 4])
    plain = model(z, t, tokens, mask)
    composed = model(z, t, tokens[:, None], mask[:, None],
                     composition=CrossAttentionControl(concept_weights=[1.0]))
    torch.testing.assert_close(composed, plain, rtol=1e-6, atol=1e-6)
    composed_twice = model(z, t, torch.stack([tokens, tokens], 1), torch.stack([mask, mask], 1),
                           composition=CrossAttentionControl(concept_weights=[0.3, 0.7]))
    torch.testing.assert_close(composed_twice, plain, rtol=1e-5, atol=1e-5)


# -- Eq. 3–4: energies and AGD ---------------------------------------------------------------------


def _energy_setup():
    torch.manual_seed(0)
    attention = EnergyCrossAttention(16, D_TEXT, heads=4)
    q = attention.queries(torch.randn(2, 5, 16))
    c, mask = _text(2, 6, valid=[6, 3], seed=5)
    return attention, q, c, mask


def test_analytic_energy_gradients_match_autograd():
    attention, q, c, mask = _energy_setup()
    grad_attn, grad_reg = attention.energy_gradients(q, c, mask)
    c_var = c.clone().requires_grad_(True)
    (auto_attn,) = torch.autograd.grad(attention.energy_attention(q, c_var, mask).sum(), c_var)
    (auto_reg,) = torch.autograd.grad(attention.energy_regulariser(c_var, mask).sum(), c_var)
    torch.testing.assert_close(grad_attn, auto_attn, rtol=1e-4, atol=1e-5)
    torch.testing.assert_close(grad_reg, auto_reg, rtol=1e-4, atol=1e-5)
    assert torch.count_nonzero(grad_attn[1, 3:]) == 0 and torch.count_nonzero(grad_reg[1, 3:]) == 0
    assert grad_attn[1, :3].abs().sum() > 0 and grad_reg[1, :3].abs().sum() > 0


@pytest.mark.parametrize("gamma_attn,gamma_reg", [(1e-3, 0.0), (0.0, 1e-3), (1e-3, 2e-3)])
def test_one_agd_step_lowers_the_energy(gamma_attn, gamma_reg):
    attention, q, c, mask = _energy_setup()

    def energy(text):
        return (gamma_attn * attention.energy_attention(q, text, mask)
                + gamma_reg * attention.energy_regulariser(text, mask))

    stepped = attention.agd_step(q, c, mask, gamma_attn, gamma_reg)
    assert torch.all(energy(stepped) < energy(c))
    assert torch.equal(stepped[1, 3:], c[1, 3:])           # padded tokens do not move
    assert torch.equal(attention.agd_step(q, c, mask, 0.0, 0.0), c)


def test_agd_with_zero_gamma_is_a_no_op_and_positive_gamma_acts_from_layer_two():
    model = _denoiser(layers=2)
    z, t = _inputs()
    tokens, mask = _text(3, 5)
    plain = model(z, t, tokens, mask)
    zero = model(z, t, tokens, mask, composition=CrossAttentionControl())
    assert torch.equal(zero, plain)
    agd = model(z, t, tokens, mask,
                composition=CrossAttentionControl(gamma_attn=0.5, gamma_reg=0.5))
    assert (agd - plain).abs().max() > 1e-5
    # every call restarts from the caller's embedding: the input is untouched, calls repeat
    assert torch.equal(tokens, _text(3, 5)[0])
    again = model(z, t, tokens, mask,
                  composition=CrossAttentionControl(gamma_attn=0.5, gamma_reg=0.5))
    assert torch.equal(agd, again)
    # the update only reaches the next layer: one block ⇒ no effect
    single = _denoiser(layers=1)
    torch.testing.assert_close(
        single(z, t, tokens, mask, composition=CrossAttentionControl(gamma_attn=0.5)),
        single(z, t, tokens, mask))


# -- training --------------------------------------------------------------------------------------


def test_train_latent_denoiser_learns_and_returns_denoisers():
    diffusion = GaussianDiffusion(cosine_betas(100))
    g = torch.Generator().manual_seed(0)
    # two text classes, each with its own latent mean
    labels = torch.randint(0, 2, (256,), generator=g)
    latents = (labels.float() * 2 - 1)[:, None, None] + 0.1 * torch.randn(256, N, D_LATENT,
                                                                         generator=g)
    tokens = torch.zeros(256, 3, D_TEXT)
    tokens[:, :, 0] = labels.float()[:, None] * 2 - 1
    mask = torch.ones(256, 3, dtype=torch.bool)
    mask[:, 2] = False
    config = TrainConfig(steps=120, batch_size=64, lr=3e-3, ema_decay=0.9, cond_dropout=0.1,
                         seed=0, num_threads=1)
    result = train_latent_denoiser(_denoiser(), diffusion, latents, tokens, mask, config)
    assert isinstance(result.model, LatentDenoiser) and isinstance(result.ema_model,
                                                                   LatentDenoiser)
    first, last = sum(result.losses[:10]) / 10, sum(result.losses[-20:]) / 20
    assert last < 0.7 * first
    with pytest.raises(ValueError, match="predicts ε"):
        train_latent_denoiser(_denoiser(), GaussianDiffusion(cosine_betas(10), "x0"), latents,
                              tokens, mask, config)
    with pytest.raises(ValueError, match=r"latents must be \(M, 4, 6\)"):
        train_latent_denoiser(_denoiser(), diffusion, latents[:, :2], tokens, mask, config)


def test_train_latent_denoiser_passes_the_convergence_record_through():
    diffusion = GaussianDiffusion(cosine_betas(50))
    g = torch.Generator().manual_seed(0)
    latents = torch.randn(40, N, D_LATENT, generator=g)
    tokens = torch.randn(40, 3, D_TEXT, generator=g)
    mask = torch.ones(40, 3, dtype=torch.bool)
    config = TrainConfig(steps=6, batch_size=8, lr=1e-3, cond_dropout=0.1, seed=0,
                         num_threads=1, validate_every=3, patience=10)
    result = train_latent_denoiser(_denoiser(), diffusion, latents[:32], tokens[:32], mask[:32],
                                   config, validation=(latents[32:], tokens[32:], mask[32:]))
    assert isinstance(result.ema_model, LatentDenoiser)
    assert result.convergence is not None
    assert [step for step, _ in result.convergence.validation] == [0, 3, 6]
    with pytest.raises(ValueError, match="validation latents"):
        train_latent_denoiser(_denoiser(), diffusion, latents[:32], tokens[:32], mask[:32],
                              config, validation=(latents[32:, :2], tokens[32:], mask[32:]))
