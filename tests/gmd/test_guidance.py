"""Goal functions: the guidance gradient reaches x_t."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from repro.gmd import guidance
from repro.gmd.guidance import goal_reaching_loss, sample
from repro.gmd.models import GMDModelSpec, TrainedGMD, load_or_train_gmd
from repro.gmd.windows import DataConfig, FeatureSpace
from repro.standin.text import Vocabulary

FRAMES = 16  # = conftest.FRAMES: the windows of the small_config fixture


@pytest.mark.parametrize("prediction", ["epsilon", "x0"])
def test_goal_gradient_flows_to_x_t(small_spec, cache: Path, prediction: str) -> None:
    trained = load_or_train_gmd(small_spec(prediction=prediction, steps=5))
    x_t = torch.randn(2, 4, FRAMES, requires_grad=True)
    t = torch.full((2,), 10, dtype=torch.long)
    out = trained.diffusion.p_mean_variance(trained.model, x_t, t)
    goal = goal_reaching_loss(trained.space, [[1.0, 2.0], [-1.0, 0.5]])(out.pred_x0)
    assert goal.shape == (2,)
    (grad,) = torch.autograd.grad(goal.sum(), x_t)
    assert torch.isfinite(grad).all() and grad[:, 1:3, -1].abs().min() > 0


# ------------------------------------------------------------------------------------------------
# Classifier-free guidance at sampling: scale 1 is conditional sampling and scale 0
# unconditional, bit for bit with the same noise; other scales mix the two outputs.
# ------------------------------------------------------------------------------------------------

CAPTIONS = ["a person walks forward", "someone waves the left hand", "a person jumps"]


@pytest.fixture(scope="module")
def trained() -> TrainedGMD:
    """A small text-conditioned trajectory UNet with random (non-zero) weights, so the
    conditional and unconditional outputs differ."""
    spec = GMDModelSpec(task="trajectory", prediction="x0", text_conditioned=True,
                        data=DataConfig(frames=16), diffusion_steps=12, base_channels=8)
    vocabulary = Vocabulary.build(CAPTIONS)
    torch.manual_seed(0)
    model = spec.build_model(cond_dim=len(vocabulary)).eval()
    with torch.no_grad():
        for p in model.parameters():
            p.add_(0.05 * torch.randn_like(p))
    space = FeatureSpace("trajectory", "absolute", np.zeros(4), np.ones(4))
    return TrainedGMD(model.requires_grad_(False), spec.diffusion(), space, spec, vocabulary)


def test_scale_one_is_conditional_sampling_exactly(trained: TrainedGMD) -> None:
    plain = sample(trained, 3, seed=5, text=CAPTIONS)
    guided = guidance.sample_classifier_free(trained, 3, seed=5, text=CAPTIONS, scale=1.0)
    assert torch.equal(plain, guided)


def test_scale_zero_is_unconditional_sampling_exactly(trained: TrainedGMD) -> None:
    unconditional = sample(trained, 3, seed=5)
    guided = guidance.sample_classifier_free(trained, 3, seed=5, text=CAPTIONS, scale=0.0)
    assert torch.equal(unconditional, guided)
    assert not torch.equal(unconditional, sample(trained, 3, seed=5, text=CAPTIONS))


def test_gmd_scale_mixes_the_two_outputs(trained: TrainedGMD) -> None:
    assert guidance.GMD_CFG_SCALE == 2.5
    wrapped = guidance.ClassifierFreeModel(trained.model, guidance.GMD_CFG_SCALE)
    x, t = torch.randn(3, 4, 16), torch.tensor([3, 7, 11])
    cond = trained.text_condition(CAPTIONS, 3)
    conditional = trained.model(x, t, cond=cond)
    unconditional = trained.model(x, t, force_unconditional=True)
    expected = unconditional + 2.5 * (conditional - unconditional)
    torch.testing.assert_close(wrapped(x, t, cond=cond), expected, rtol=1e-5, atol=1e-6)
    assert torch.equal(wrapped(x, t), unconditional)


def test_classifier_free_needs_a_model_trained_with_condition_dropout(trained) -> None:
    import dataclasses

    no_dropout = dataclasses.replace(trained, spec=trained.spec.replace(cond_dropout=0.0))
    with pytest.raises(ValueError, match="condition dropout"):
        guidance.classifier_free(no_dropout)
    with pytest.raises(ValueError, match="text-conditioned"):
        guidance.classifier_free(dataclasses.replace(trained, vocabulary=None))
