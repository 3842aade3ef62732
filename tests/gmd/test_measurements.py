"""Motion-quality measurements of tiny-GMD samples: the root jitter of known paths."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.gmd.measurements import jitter_of
from repro.gmd.windows import FeatureSpace
from repro.motion.features import FPS


def _space() -> FeatureSpace:
    return FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                        np.ones(4, np.float32))


def _path(x_of_frame: np.ndarray) -> torch.Tensor:
    x = torch.zeros(1, 4, len(x_of_frame), dtype=torch.float64)
    x[0, 1] = torch.as_tensor(x_of_frame)            # root x (m) in the absolute representation
    return x


def test_root_jitter_of_constant_velocity_is_zero() -> None:
    jitter = jitter_of(_space(), _path(0.05 * np.arange(20.0)))
    assert jitter.acceleration == pytest.approx(0.0, abs=1e-9)
    assert jitter.jerk == pytest.approx(0.0, abs=1e-6)


def test_root_acceleration_of_a_parabola() -> None:
    a = 0.001                                          # x = a·f² (m): Δ²x = 2a per frame²
    jitter = jitter_of(_space(), _path(a * np.arange(20.0) ** 2))
    assert jitter.acceleration == pytest.approx(2 * a * FPS**2, rel=1e-6)
    assert jitter.jerk == pytest.approx(0.0, abs=1e-6)
