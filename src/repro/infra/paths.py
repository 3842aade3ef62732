"""Where things live: the repository, the build folder, the model cache, the shared fixtures.

Every path is absolute so that papermill's ``cwd`` never changes what a path means.
Environment variables override the defaults (tests, CI, a shared cache):
``REPRO_BUILD_ROOT`` (default ``build/``), ``REPRO_CACHE_DIR``, ``REPRO_SHARED_DIR``,
``REPRO_NOTEBOOKS_DIR``.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[3]


def build_root() -> Path:
    """``build/`` (git-ignored): standard runs write here, quick and paper runs under
    ``build/quick`` and ``build/paper``."""
    return Path(os.environ.get("REPRO_BUILD_ROOT", REPO_ROOT / "build")).resolve()


def run_build_dir(scale: str) -> Path:
    """A run's output folder, one per scale: ``build/`` for the standard scale (what
    ``results/`` is written from), ``build/quick`` and ``build/paper`` for the others, so a
    quick (test) run never overwrites a result."""
    from repro.infra.context import check_scale

    return build_root() if check_scale(scale) == "standard" else build_root() / scale


def cache_dir() -> Path:
    """Trained weights and generated datasets, keyed by a hash of their configuration.

    Shared by every scale (their configurations differ, so their hashes do)."""
    return Path(os.environ.get("REPRO_CACHE_DIR", build_root() / "cache")).resolve()


def shared_dir() -> Path:
    """``../shared`` beside the clone: claims, reference facts and the real HumanML3D sample."""
    return Path(os.environ.get("REPRO_SHARED_DIR", REPO_ROOT.parent / "shared")).resolve()


def humanml3d_sample_dir() -> Path:
    """The real HumanML3D clips used only by conformance tests (never committed)."""
    return shared_dir() / "humanml3d_sample"


def notebooks_dir() -> Path:
    return Path(os.environ.get("REPRO_NOTEBOOKS_DIR", REPO_ROOT / "notebooks")).resolve()


def data_stubs_dir() -> Path:
    """The small committed stand-in dataset in HumanML3D's folder layout."""
    return REPO_ROOT / "data_stubs"


def results_dir() -> Path:
    """The committed snapshot of the last full run (claims table, report, figures)."""
    return REPO_ROOT / "results"


def _locations() -> list[tuple[str, str]]:
    """(absolute location of this machine, what :func:`portable` writes for it), the longest
    first: the build root, cache, shared and notebooks folders where a variable moved them
    out of their default place (as that variable), the clone (relative to it), the shared
    folder beside it (``../shared``), and the home folder (``~``)."""
    repo = str(REPO_ROOT)
    moved = [(build_root(), REPO_ROOT / "build", "$REPRO_BUILD_ROOT"),
             (cache_dir(), build_root() / "cache", "$REPRO_CACHE_DIR"),
             (shared_dir(), REPO_ROOT.parent / "shared", "$REPRO_SHARED_DIR"),
             (notebooks_dir(), REPO_ROOT / "notebooks", "$REPRO_NOTEBOOKS_DIR")]
    pairs = {str(where): name for where, default, name in moved if where != default.resolve()}
    pairs.setdefault(str((REPO_ROOT.parent / "shared").resolve()), "../shared")
    pairs.setdefault(repo, ".")
    home = os.path.expanduser("~")
    if home not in ("~", os.sep):
        pairs.setdefault(home, "~")
    return sorted(pairs.items(), key=lambda pair: -len(pair[0]))


def portable(text: str) -> str:
    """``text`` with this machine's absolute locations written so that a reader elsewhere
    learns nothing of the machine and can still follow them: paths in the clone relative to
    it (``/x/repo/build/runs/ID`` → ``build/runs/ID``), the overridden build, cache, shared
    and notebooks folders as their variables (``$REPRO_BUILD_ROOT/quick``), the home folder
    as ``~``. A rendered notebook or a snapshot written with it names no machine path."""
    for where, name in _locations():
        start = r"(?<![\w.-])" + re.escape(where)
        if name == ".":
            text = re.sub(start + re.escape(os.sep), "", text)
        text = re.sub(start + r"(?![\w.-])", lambda _match, name=name: name, text)
    return text
