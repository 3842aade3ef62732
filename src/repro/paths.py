"""Where things live: the repository, the build folder, the model cache, the shared fixtures.

Every path is absolute so that papermill's ``cwd`` never changes what a path means.
Environment variables override the defaults (useful for CI and for a shared cache).
"""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]


def build_dir() -> Path:
    """``build/`` (git-ignored): executed notebooks, claim sidecars, report, figures."""
    return Path(os.environ.get("REPRO_BUILD_DIR", REPO_ROOT / "build")).resolve()


def cache_dir() -> Path:
    """Trained weights and generated datasets, keyed by a hash of their configuration."""
    return Path(os.environ.get("REPRO_CACHE_DIR", build_dir() / "cache")).resolve()


def shared_dir() -> Path:
    """``../shared`` beside the clone: claims, reference facts and the real HumanML3D sample."""
    return Path(os.environ.get("REPRO_SHARED_DIR", REPO_ROOT.parent / "shared")).resolve()


def humanml3d_sample_dir() -> Path:
    """The real HumanML3D clips used only by conformance tests (never committed)."""
    return shared_dir() / "humanml3d_sample"


def notebooks_dir() -> Path:
    return REPO_ROOT / "notebooks"


def data_stubs_dir() -> Path:
    """The small committed stand-in dataset in HumanML3D's folder layout."""
    return REPO_ROOT / "data_stubs"


def results_dir() -> Path:
    """The committed snapshot of the last full run (claims table, report, figures)."""
    return REPO_ROOT / "results"


def figures_dir() -> Path:
    return build_dir() / "figures"


def claims_dir() -> Path:
    return build_dir() / "claims"
