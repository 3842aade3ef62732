"""Shared test fixtures: run contexts and the tiny configurations the tests train."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
import torch

from repro.infra import paths
from repro.infra.context import RunContext


def make_context(build_dir: str | Path, *, quick: bool = True, seed: int = 0,
                 run_id: str = "") -> RunContext:
    """A run context writing under ``build_dir`` (no process-wide side effects)."""
    return RunContext(quick=quick, seed=seed, device=torch.device("cpu"), threads=1,
                      build_dir=Path(build_dir).resolve(), cache_dir=paths.cache_dir(),
                      run_id=run_id)


@pytest.fixture
def run_context() -> Callable[..., RunContext]:
    """``run_context(build_dir, quick=..., seed=..., run_id=...)`` → a :class:`RunContext`."""
    return make_context
