"""Goal functions: the guidance gradient reaches x_t."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from repro.gmd.guidance import goal_reaching_loss
from repro.gmd.models import load_or_train_gmd

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
