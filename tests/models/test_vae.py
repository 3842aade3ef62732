"""MotionVAE: shapes over N, padding never matters, KL ≥ 0, training and the cache."""

from __future__ import annotations

import pytest
import torch

from repro.models import vae as vae_module
from repro.models.vae import (
    ARCHITECTURES,
    MotionVAE,
    VAETrainConfig,
    kl_to_standard_normal,
    lengths_to_mask,
    load_or_train_vae,
    train_vae,
)

torch.set_num_threads(1)


def _tiny(latent_count: int = 3, **kwargs) -> MotionVAE:
    torch.manual_seed(0)
    options = dict(latent_count=latent_count, latent_dim=8, width=32, layers=1, heads=2,
                   max_frames=40)
    options.update(kwargs)
    return MotionVAE(**options).eval()


@pytest.mark.parametrize("architecture", ARCHITECTURES)
@pytest.mark.parametrize("latent_count", [1, 5, 7])
def test_shapes_for_each_latent_count(latent_count, architecture):
    vae = _tiny(latent_count, architecture=architecture)
    motion, lengths = torch.randn(3, 24, 263), torch.tensor([24, 10, 1])
    mu, logvar = vae.encode(motion, lengths)
    assert mu.shape == logvar.shape == (3, latent_count, 8)
    z = vae.sample_latent(mu, logvar, torch.Generator().manual_seed(0))
    assert z.shape == (3, latent_count, 8)
    assert vae.decode(z, lengths).shape == (3, 24, 263)
    assert vae.decode(z, lengths, frames=30).shape == (3, 30, 263)
    recon, mu2, _ = vae(motion, lengths)
    assert recon.shape == motion.shape and torch.equal(mu, mu2)
    rebuilt = MotionVAE(**vae.config())
    assert rebuilt.load_state_dict(vae.state_dict()) is not None
    assert rebuilt.config() == vae.config()


def test_distribution_tokens_are_two_n_and_latents_differ_per_token():
    vae = _tiny(5)
    assert vae.distribution_tokens.shape == (10, 32)
    mu, _ = vae.encode(torch.randn(2, 12, 263), [12, 12])
    assert not torch.allclose(mu[:, 0], mu[:, 1])


@pytest.mark.parametrize("architecture", ARCHITECTURES)
def test_padding_never_changes_the_latent_the_output_or_the_loss(architecture):
    vae = _tiny(5, architecture=architecture)
    lengths = torch.tensor([20, 9])
    motion = torch.randn(2, 20, 263)
    garbage = motion.clone()
    garbage[1, 9:] = 100.0 * torch.randn(11, 263)
    mu_a, logvar_a = vae.encode(motion, lengths)
    mu_b, logvar_b = vae.encode(garbage, lengths)
    torch.testing.assert_close(mu_a, mu_b)
    torch.testing.assert_close(logvar_a, logvar_b)

    loss_a = vae.loss(motion, lengths, generator=torch.Generator().manual_seed(3))
    loss_b = vae.loss(garbage, lengths, generator=torch.Generator().manual_seed(3))
    torch.testing.assert_close(loss_a["loss"], loss_b["loss"])
    # a change inside the valid frames does change it
    changed = motion.clone()
    changed[1, 3] += 5.0
    loss_c = vae.loss(changed, lengths, generator=torch.Generator().manual_seed(3))
    assert abs(loss_c["recon"].item() - loss_a["recon"].item()) > 1e-4

    recon = vae.decode(vae.sample_latent(mu_a, logvar_a), lengths)
    assert torch.count_nonzero(recon[1, 9:]) == 0
    assert torch.count_nonzero(recon[1, :9]) > 0


def test_the_temporal_decoder_gives_each_time_slot_its_own_weights():
    """z → T/4 slots by one linear map, so frames differ from the first step; a bad
    architecture name is refused."""
    vae = _tiny(5, architecture="temporal", max_frames=42)
    assert vae.slots == 11 and vae.config()["architecture"] == "temporal"
    out = vae.decode(torch.randn(2, 5, 8), [42, 42])
    assert out.shape == (2, 42, 263)
    assert out.std(dim=1).mean() > 0.1 * out.std()        # not one pose held over the clip
    with pytest.raises(ValueError, match="architecture must be one of"):
        MotionVAE(architecture="lstm")


def test_kl_is_nonnegative_matches_the_closed_form_and_is_zero_at_the_prior():
    g = torch.Generator().manual_seed(0)
    mu, logvar = 3 * torch.randn(500, generator=g), 3 * torch.randn(500, generator=g)
    kl = kl_to_standard_normal(mu, logvar)
    assert torch.all(kl >= 0)
    expected = torch.distributions.kl_divergence(
        torch.distributions.Normal(mu, torch.exp(0.5 * logvar)), torch.distributions.Normal(0, 1))
    torch.testing.assert_close(kl, expected, rtol=1e-5, atol=1e-5)
    assert torch.count_nonzero(kl_to_standard_normal(torch.zeros(4), torch.zeros(4))) == 0

    vae = _tiny(3, kl_weight=0.5)
    out = vae.loss(torch.randn(2, 10, 263), [10, 4], generator=torch.Generator().manual_seed(0))
    assert out["kl"].item() >= 0 and out["recon"].item() > 0
    torch.testing.assert_close(out["loss"], out["recon"] + 0.5 * out["kl"])


def test_sample_latent_is_seeded_reparameterisation():
    mu, logvar = torch.randn(2, 3, 4), torch.randn(2, 3, 4)
    a = MotionVAE.sample_latent(mu, logvar, torch.Generator().manual_seed(1))
    b = MotionVAE.sample_latent(mu, logvar, torch.Generator().manual_seed(1))
    assert torch.equal(a, b)
    eps = torch.randn(mu.shape, generator=torch.Generator().manual_seed(1))
    torch.testing.assert_close(a, mu + torch.exp(0.5 * logvar) * eps)


def test_bad_inputs_raise_value_errors():
    vae = _tiny(3)
    with pytest.raises(ValueError, match=r"motion must be \(B, T, 263\)"):
        vae.encode(torch.randn(2, 10, 262), [10, 10])
    with pytest.raises(ValueError, match=r"lengths must lie in \[1, 10\]"):
        vae.encode(torch.randn(2, 10, 263), [10, 11])
    with pytest.raises(ValueError, match=r"lengths must lie"):
        vae.encode(torch.randn(2, 10, 263), [0, 5])
    with pytest.raises(ValueError, match="2 entries for a batch of 3"):
        vae.encode(torch.randn(3, 10, 263), [10, 10])
    with pytest.raises(ValueError, match="exceed max_frames"):
        vae.encode(torch.randn(1, 41, 263), [41])
    with pytest.raises(ValueError, match=r"z must be \(B, 3, 8\)"):
        vae.decode(torch.randn(1, 4, 8), [5])
    with pytest.raises(ValueError, match="divisible by heads"):
        MotionVAE(width=30, heads=4)
    with pytest.raises(ValueError, match="latent_count"):
        MotionVAE(latent_count=0)
    assert lengths_to_mask([2, 3], 3).tolist() == [[True, True, False], [True, True, True]]


def _toy_data(count: int = 16, frames: int = 12) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(0)
    # one 3-number code per clip, smooth over frames: a tiny VAE learns it in a few steps
    basis = torch.randn(3, 263, generator=g)
    codes = torch.randn(count, 1, 3, generator=g)
    phase = torch.cos(torch.arange(frames) / frames * torch.pi)[None, :, None]
    lengths = torch.randint(6, frames + 1, (count,), generator=g)
    motions = (codes * phase) @ basis * lengths_to_mask(lengths, frames)[..., None]
    return motions, lengths


def test_train_vae_reduces_the_loss_and_is_seeded():
    motions, lengths = _toy_data()
    config = VAETrainConfig(steps=60, batch_size=8, lr=3e-3, seed=0, num_threads=1)
    first = train_vae(_tiny(2, max_frames=12, dropout=0.0), motions, lengths, config)
    second = train_vae(_tiny(2, max_frames=12, dropout=0.0), motions, lengths, config)
    assert first.losses["loss"] == second.losses["loss"]
    recon = first.losses["recon"]
    assert sum(recon[-10:]) / 10 < 0.8 * sum(recon[:5]) / 5
    assert not first.model.training
    with pytest.raises(ValueError, match="contains NaN"):
        train_vae(_tiny(2, max_frames=12), motions * float("nan"), lengths, config)


def test_load_or_train_vae_caches_by_config(tmp_path, monkeypatch):
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    motions, lengths = _toy_data(8, 10)
    kwargs = dict(latent_count=2, latent_dim=4, width=16, layers=1, heads=2, max_frames=10)
    config = VAETrainConfig(steps=3, batch_size=4)
    trained = load_or_train_vae(motions, lengths, model_kwargs=kwargs, config=config)
    assert len(list(tmp_path.glob("motion_vae/*/model.pt"))) == 1

    def fail(*args, **kwargs):
        raise AssertionError("should have loaded from the cache")

    monkeypatch.setattr(vae_module, "train_vae", fail)
    loaded = load_or_train_vae(motions, lengths, model_kwargs=kwargs, config=config)
    for a, b in zip(trained.state_dict().values(), loaded.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    with pytest.raises(AssertionError, match="cache"):       # other data → a new entry
        load_or_train_vae(motions + 1, lengths, model_kwargs=kwargs, config=config)


def test_vae_convergence_is_opt_in_and_leaves_the_trajectory_unchanged():
    assert set(VAETrainConfig().to_config()) == {"steps", "batch_size", "lr", "weight_decay",
                                                 "grad_clip", "kl_weight", "seed"}
    assert {"validate_every", "patience", "min_delta"} <= set(
        VAETrainConfig(validate_every=10).to_config())
    with pytest.raises(ValueError, match="only act with validate_every"):
        VAETrainConfig(patience=2)
    with pytest.raises(ValueError, match="does not use"):      # no EMA, no diffusion loss
        VAETrainConfig(ema_decay=0.99)
    motions, lengths = _toy_data()
    held_out, held_lengths = _toy_data(count=8)
    plain = train_vae(_tiny(2, max_frames=12, dropout=0.0), motions, lengths,
                      VAETrainConfig(steps=20, batch_size=8, lr=3e-3, num_threads=1))
    capped = train_vae(_tiny(2, max_frames=12, dropout=0.0), motions, lengths,
                       VAETrainConfig(steps=20, batch_size=8, lr=3e-3, num_threads=1,
                                      validate_every=10, patience=50),
                       validation=(held_out, held_lengths))
    assert capped.losses == plain.losses and plain.convergence is None
    record = capped.convergence
    assert record is not None and not record.converged
    assert [step for step, _ in record.validation] == [0, 10, 20]
    assert record.validation[-1][1] < record.validation[0][1]
    assert capped.metrics()["convergence"]["steps_used"] == 20
    with pytest.raises(ValueError, match="exactly when"):
        train_vae(_tiny(2, max_frames=12), motions, lengths, VAETrainConfig(validate_every=5))


def test_vae_training_stops_on_a_plateau():
    motions, lengths = _toy_data()
    config = VAETrainConfig(steps=2000, batch_size=8, lr=3e-3, num_threads=1, validate_every=10,
                            patience=2, min_delta=0.05)
    result = train_vae(_tiny(2, max_frames=12, dropout=0.0), motions, lengths, config,
                       validation=_toy_data(count=8))
    record = result.convergence
    assert record is not None and record.converged
    assert record.steps_used == len(result.losses["loss"]) == record.validation[-1][0] < 2000
