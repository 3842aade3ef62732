"""Shared fixtures of the tiny-GMD tests: a small stand-in folder, a private cache, small specs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
import torch

from repro.gmd.models import GMDModelSpec
from repro.gmd.windows import DataConfig
from repro.standin.dataset import write_dataset

torch.set_num_threads(1)
#: frames of the small windows (a multiple of 4 that a two-level UNet divides).
FRAMES = 16


@pytest.fixture(scope="module")
def dataset_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_dataset(tmp_path_factory.mktemp("stand_in"), n_clips=10, seed=3)


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture()
def small_config(dataset_dir: Path) -> Callable[..., DataConfig]:
    """``small_config(representation="absolute", root=dataset_dir)``: 16-frame windows."""

    def make(representation: str = "absolute", root: Path | None = None) -> DataConfig:
        return DataConfig(data_dir=str(root or dataset_dir), frames=FRAMES, stride=8,
                          representation=representation)

    return make


@pytest.fixture()
def small_spec(small_config: Callable[..., DataConfig]) -> Callable[..., GMDModelSpec]:
    """``small_spec(root=None, **changes)``: a 3-step ε trajectory model on ``small_config``
    (``changes`` as ``GMDModelSpec.replace``: training fields by their ``TrainConfig`` names)."""

    def make(root: Path | None = None, **changes: object) -> GMDModelSpec:
        base = GMDModelSpec(task="trajectory", prediction="epsilon",
                            data=small_config(root=root), base_channels=8,
                            channel_mults=(1, 2), diffusion_steps=20)
        return base.replace(steps=3, batch_size=8).replace(**changes)

    return make
