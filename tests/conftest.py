"""Shared test fixtures: run contexts and the tiny configurations the tests train."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import nbformat
import pytest
import torch

from repro.energymogen.pipeline import EnergyMoGenPipeline, load_pipeline
from repro.energymogen.settings import PipelineConfig
from repro.infra import paths
from repro.infra.context import RunContext


def make_context(build_dir: str | Path, *, scale: str = "quick", seed: int = 0,
                 run_id: str = "") -> RunContext:
    """A run context writing under ``build_dir`` (no process-wide side effects)."""
    return RunContext(scale=scale, seed=seed, device=torch.device("cpu"), threads=1,
                      build_dir=Path(build_dir).resolve(), cache_dir=paths.cache_dir(),
                      run_id=run_id)


def settings_classes() -> dict[str, Any]:
    """claim → the Settings class its notebook builds (``for_scale``; the EnergyMoGen ones'
    ``for_run`` is ``for_scale`` without a data folder)."""
    from repro.energymogen import (
        composed_augmentation,
        energy_contour_maps,
        latent_count,
        sef_ablation,
    )
    from repro.gmd import emphasis_projection, guidance_schedule, root_representation, x0_vs_eps

    return {"GMD-A3": x0_vs_eps.Settings, "GMD-A4": x0_vs_eps.Settings,
            "GMD-B2": root_representation.Settings, "GMD-B3": root_representation.Settings,
            "GMD-C4": emphasis_projection.Settings, "GMD-F1": guidance_schedule.Settings,
            **dict.fromkeys(("EMG-1", "EMG-2", "EMG-3", "EMG-6"),
                            energy_contour_maps.EnergyViewSettings),
            "EMG-4": sef_ablation.SEFAblationSettings, "EMG-5": sef_ablation.SEFAblationSettings,
            "EMG-7": latent_count.LatentCountSettings,
            "EMG-8": composed_augmentation.AugmentationSettings}


def run_settings(claim_id: str, scale: str = "standard") -> dict[str, Any]:
    """What ``claim_id``'s rule quotes of a run at ``scale``: its paper package's
    ``rule_settings`` of the Settings its notebook builds (no model trained)."""
    from repro.energymogen import settings as emg_rules
    from repro.gmd import settings as gmd_rules

    functions = {**gmd_rules.RULE_SETTINGS, **emg_rules.RULE_SETTINGS}
    if claim_id not in functions:
        return {}
    return functions[claim_id](settings_classes()[claim_id].for_scale(scale))


@pytest.fixture
def run_context() -> Callable[..., RunContext]:
    """``run_context(build_dir, scale=..., seed=..., run_id=...)`` → a :class:`RunContext`."""
    return make_context


# --- tiny EnergyMoGen configurations (seconds to train: tests of the code, never results) ---

#: the tiny pipeline every EnergyMoGen test trains (its cache keys are pinned in
#: tests/energymogen/test_pipeline.py)
TINY_PIPELINE = PipelineConfig(n_train_clips=24, test_clips_per_pair=2, ddim_steps=2,
                               items_per_pair=4).with_steps(vae=2, text=2, denoiser=2,
                                                            evaluator=2)
#: EMG-8's tiny pipeline: 6 pretraining steps, so that fine-tuning (a third of them) takes 2
TINY_AUGMENTATION_PIPELINE = PipelineConfig(
    n_train_clips=24, test_clips_per_pair=2, ddim_steps=2,
    items_per_pair=4).with_steps(vae=2, text=2, denoiser=6, evaluator=2)


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist (``make test`` runs one worker per core) each worker and the
    notebook kernels it starts use one torch thread, so workers do not oversubscribe cores."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        torch.set_num_threads(1)
        os.environ.setdefault("REPRO_TORCH_THREADS", "1")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The notebook tests first (order otherwise kept): under ``--dist loadfile`` their file,
    the longest by far (every quick notebook, two kernels at a time), then starts at once and
    the unit tests fill the cores around it, instead of it running last with a core idle."""
    items.sort(key=lambda item: item.get_closest_marker("notebook") is None)
    missing = _missing_seeds()
    if missing:
        skip = pytest.mark.skip(reason=missing)
        for item in items:
            if item.get_closest_marker("needs_seeds"):
                item.add_marker(skip)


def _missing_seeds() -> str:
    """Why the tests that read the papers' text cannot run here ("" when they can): the text
    is ``../shared/seeds/``, beside a developer's and CI's clone, never a user's."""
    from repro.claims.printed import SEEDS
    from repro.claims.seed_text import seeds_dir

    absent = [name for name in SEEDS.values() if not (seeds_dir() / name).is_file()]
    return (f"the papers' text ({', '.join(absent)}) not found in {seeds_dir()}: ../shared is "
            "not beside this clone") if absent else ""


@pytest.fixture(scope="module")
def emg_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A test module's own cache folder (``REPRO_CACHE_DIR`` while the module runs, one
    torch thread), so no EnergyMoGen test reads or writes build/cache."""
    directory = tmp_path_factory.mktemp("emg_cache")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("REPRO_CACHE_DIR", str(directory))
        yield directory
    torch.set_num_threads(threads)


@pytest.fixture(scope="module")
def tiny_pipeline(emg_cache: Path) -> EnergyMoGenPipeline:
    """The pipeline of :data:`TINY_PIPELINE` (seconds to train), once per test module."""
    return load_pipeline(TINY_PIPELINE, log=None)


def write_notebook(path: Path, body: str, *, parameters: str) -> None:
    """A two-cell notebook (a ``parameters`` cell, then ``body``) on the plain python3 kernel,
    for runner tests."""
    notebook = nbformat.v4.new_notebook()
    cell = nbformat.v4.new_code_cell(parameters)
    cell.metadata["tags"] = ["parameters"]
    notebook.cells = [cell, nbformat.v4.new_code_cell(body)]
    notebook.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3",
                                       "language": "python"}
    nbformat.write(notebook, path)


def bimodal_mixture(n: int, seed: int) -> torch.Tensor:
    """0.5·N(−1, 0.2²) + 0.5·N(+1, 0.2²) as (n, 1, 1): a target a tiny denoiser can learn."""
    g = torch.Generator().manual_seed(seed)
    sign = torch.randint(0, 2, (n, 1, 1), generator=g) * 2.0 - 1.0
    return sign + 0.2 * torch.randn(n, 1, 1, generator=g)
