"""Training to convergence: EMA validation loss on fixed (t, noise) pairs, the
plateau criterion, the step cap, and the opt-in cache key."""

from __future__ import annotations

import pytest
import torch
from conftest import bimodal_mixture
from torch import nn

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.core.training import (
    PlateauCriterion,
    TrainConfig,
    ValidationSet,
    train_diffusion,
    validation_loss,
)
from repro.infra.cache import config_hash
from repro.models.unet import sinusoidal_embedding

torch.set_num_threads(1)

#: TrainConfig's cache-key fields before the convergence fields existed
KEY_FIELDS_BEFORE = {"steps", "batch_size", "lr", "weight_decay", "grad_clip", "ema_decay",
                     "ema_warmup", "seed", "feature_weights", "cond_dropout"}


class TinyDenoiser(nn.Module):
    def __init__(self, hidden: int = 32):
        super().__init__()
        self.net = nn.Sequential(nn.Linear(1 + 16, hidden), nn.Mish(), nn.Linear(hidden, 1))

    def forward(self, x, t, cond=None, cond_mask=None):
        h = torch.cat([x.flatten(1), sinusoidal_embedding(t, 16)], dim=1)
        return self.net(h).reshape(x.shape)




def test_without_validate_every_the_key_is_the_key_before_convergence_existed():
    assert set(TrainConfig().to_config()) == KEY_FIELDS_BEFORE
    assert set(TrainConfig(steps=7, lr=3e-3).to_config()) == KEY_FIELDS_BEFORE
    with pytest.raises(ValueError, match="only act with validate_every"):
        TrainConfig(patience=3)
    with pytest.raises(ValueError, match="only act with validate_every"):
        TrainConfig(min_delta=0.1)


def test_the_convergence_fields_enter_the_key_together_when_validating():
    config = TrainConfig(validate_every=50).to_config()
    assert set(config) == KEY_FIELDS_BEFORE | {"validate_every", "patience", "min_delta",
                                              "validation_timesteps"}
    hashes = {config_hash(c.to_config()) for c in (
        TrainConfig(), TrainConfig(validate_every=50), TrainConfig(validate_every=50, patience=9),
        TrainConfig(validate_every=50, min_delta=0.05))}
    assert len(hashes) == 4
    with pytest.raises(ValueError, match="validate_every must be"):
        TrainConfig(validate_every=0)
    with pytest.raises(ValueError, match="patience"):
        TrainConfig(validate_every=5, patience=0)


def test_plateau_criterion_counts_evaluations_without_a_relative_improvement():
    plateau = PlateauCriterion(patience=2, min_delta=0.1)
    assert not plateau.update(0, 1.0)          # first value: the best
    assert not plateau.update(10, 0.95)        # 5 % better: not an improvement of 10 %
    assert not plateau.update(20, 0.85)        # 15 % better than 1.0: the new best
    assert plateau.best_step == 20 and plateau.evaluations_since_best == 0
    assert not plateau.update(30, 0.80)
    assert plateau.update(40, float("nan"))    # second evaluation without improvement: stop
    assert plateau.best == 0.85 and plateau.best_step == 20


def test_validation_pairs_are_fixed_and_cover_the_t_grid():
    data = bimodal_mixture(6, 1)
    validation = ValidationSet(data)
    pairs = validation.pairs(100, 5, noise_seed=3)
    assert pairs.t.unique().tolist() == [0, 25, 50, 74, 99]   # round(k·99/4)
    assert pairs.index.tolist() == list(range(6)) * 5
    assert validation.pairs(100, 1, noise_seed=3).t.unique().tolist() == [99]
    diffusion = GaussianDiffusion(cosine_betas(100), "epsilon")
    torch.manual_seed(0)
    model = TinyDenoiser().eval()
    cpu = torch.device("cpu")
    first = validation_loss(model, diffusion, pairs, batch_size=4, device=cpu)
    assert validation_loss(model, diffusion, pairs, batch_size=4, device=cpu) == first
    other_noise = validation.pairs(100, 5, noise_seed=4)
    assert validation_loss(model, diffusion, other_noise, batch_size=4, device=cpu) != first
    with pytest.raises(ValueError, match="cond has 2 rows"):
        ValidationSet(data, cond=torch.zeros(2, 3))


def test_validating_leaves_the_training_trajectory_unchanged():
    diffusion = GaussianDiffusion(cosine_betas(50), "epsilon")
    data = bimodal_mixture(64, 0)
    plain = train_diffusion(TinyDenoiser, diffusion, data,
                            TrainConfig(steps=30, batch_size=16, lr=1e-3), progress=False)
    validated = train_diffusion(
        TinyDenoiser, diffusion, data,
        TrainConfig(steps=30, batch_size=16, lr=1e-3, validate_every=10, patience=100),
        validation=ValidationSet(bimodal_mixture(32, 1)), progress=False)
    assert validated.losses == plain.losses
    for pa, pb in zip(plain.ema_model.parameters(), validated.ema_model.parameters(),
                      strict=True):
        assert torch.equal(pa, pb)
    assert plain.convergence is None and "convergence" not in plain.metrics()
    record = validated.convergence
    assert record is not None and not record.converged and record.stop_reason == "step cap"
    assert [step for step, _ in record.validation] == [0, 10, 20, 30]
    assert record.steps_used == 30 == validated.steps_used
    assert validated.metrics()["convergence"]["validation"][0][0] == 0
    seen = []
    watched = train_diffusion(
        TinyDenoiser, diffusion, data,
        TrainConfig(steps=30, batch_size=16, lr=1e-3, validate_every=10, patience=100),
        validation=ValidationSet(bimodal_mixture(32, 1)), progress=False,
        on_validation=lambda step, loss, ema: seen.append((step, loss, ema.training)))
    assert watched.losses == plain.losses
    assert [(step, loss) for step, loss, _ in seen] == record.validation
    assert not any(training for _, _, training in seen)     # the EMA copy, in eval mode


def test_training_stops_on_a_plateau_before_the_cap():
    diffusion = GaussianDiffusion(cosine_betas(50), "epsilon")
    config = TrainConfig(steps=3000, batch_size=128, lr=3e-3, ema_decay=0.9, validate_every=25,
                         patience=3, min_delta=0.02, validation_timesteps=10)
    result = train_diffusion(TinyDenoiser, diffusion, bimodal_mixture(2048, 0), config,
                             validation=ValidationSet(bimodal_mixture(256, 1)), progress=False)
    record = result.convergence
    assert record is not None and record.converged and record.stop_reason == "plateau"
    assert record.steps_used < config.steps
    assert record.steps_used == record.validation[-1][0] == len(result.losses)
    steps = [step for step, _ in record.validation]
    assert steps == list(range(0, record.steps_used + 1, 25))
    losses = [loss for _, loss in record.validation]
    assert dict(record.validation)[record.best_step] == record.best_loss < 0.8 * losses[0]
    # the last `patience` evaluations each missed the 2 % improvement on the best
    assert record.validation[-4][0] == record.best_step
    assert all(loss >= record.best_loss * (1 - 0.02) for loss in losses[-3:])


def test_a_validation_set_is_passed_exactly_when_validating():
    diffusion = GaussianDiffusion(cosine_betas(20), "epsilon")
    with pytest.raises(ValueError, match="exactly when"):
        train_diffusion(TinyDenoiser, diffusion, bimodal_mixture(8, 0),
                        TrainConfig(steps=2, validate_every=1), progress=False)
    with pytest.raises(ValueError, match="exactly when"):
        train_diffusion(TinyDenoiser, diffusion, bimodal_mixture(8, 0), TrainConfig(steps=2),
                        validation=ValidationSet(bimodal_mixture(4, 1)), progress=False)
