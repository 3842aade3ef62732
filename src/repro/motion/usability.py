"""Whether a HumanML3D-layout folder is *usable* by the notebooks, beyond being well formed.

:func:`repro.motion.humanml3d.validate_dataset` checks that every file reads; this module
checks what the loaders then need, so that the validator and the notebooks agree on what a
usable folder is: the train and test splits each list clips and keep at least one
piece (a whole clip or a captioned segment, as ``MotionDataset`` cuts them) with
``MIN_FRAMES ≤ T < MAX_FRAMES_EXCLUSIVE`` frames and a caption. With ``needs`` (what a scale's
notebooks cut: window length, stride and how many windows each split must give, from
``run.params``) it also counts the windows each split gives.

Lengths are read from the ``.npy`` headers (memory-mapped), so a full HumanML3D folder is
checked without loading its motion. Unreadable files are left to ``validate_dataset``, which
names them; they count as no piece here.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from repro.motion.features import FPS
from repro.motion.layout import (
    MAX_FRAMES_EXCLUSIVE,
    MIN_FRAMES,
    caption_spans,
    kept_length,
    read_split,
    read_text_file,
)

#: the splits the notebooks read and what for (val.txt must exist but may be empty: no
#: notebook reads it)
SPLIT_USE = {"train": "the models train on it", "test": "the notebooks measure on it"}


@dataclass(frozen=True)
class WindowNeeds:
    """What a scale's notebooks cut from a folder: windows of ``frames`` frames every
    ``stride`` frames, and at least ``windows[split]`` of them per split."""

    frames: int
    stride: int = 1
    windows: Mapping[str, int] = field(default_factory=lambda: {"train": 1, "test": 1})


def _frames(path: Path) -> int | None:
    """The frame count of a (T, 263) features file, from its header; None if unreadable."""
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, EOFError):
        return None
    return int(array.shape[0]) if array.ndim == 2 else None


def _piece_lengths(root: Path, clip: str, frames: int) -> list[int]:
    """Lengths of the pieces ``MotionDataset`` makes of one clip: the whole clip when a text
    line covers it all, and one piece per distinct captioned time range."""
    try:
        lines = read_text_file(root / "texts" / f"{clip}.txt")
    except (OSError, ValueError):
        return []
    whole, spans = caption_spans(lines, FPS)
    return ([frames] if whole else []) + [len(range(frames)[a:b]) for a, b in spans]


def split_pieces(root: str | os.PathLike, split: str) -> list[int] | None:
    """The lengths of the pieces the loader keeps from one split (None: no split file)."""
    root = Path(root)
    try:
        ids = read_split(root, split)
    except FileNotFoundError:
        return None
    kept = []
    for clip in ids:
        frames = _frames(root / "new_joint_vecs" / f"{clip}.npy")
        if frames is None or not kept_length(frames):
            continue
        kept += [n for n in _piece_lengths(root, clip, frames) if kept_length(n)]
    return kept


def usability_problems(root: str | os.PathLike,
                       needs: WindowNeeds | None = None) -> list[tuple[Path, str]]:
    """(path, message) for each way the notebooks could not use ``root``: an empty train or
    test split, one none of whose clips the loader keeps, and with ``needs`` a split
    giving fewer windows than the scale cuts. [] when the folder is usable."""
    root = Path(root)
    problems: list[tuple[Path, str]] = []
    for split, use in SPLIT_USE.items():
        path = root / f"{split}.txt"
        pieces = split_pieces(root, split)
        if pieces is None:
            continue  # validate_dataset names a missing split file
        if not path.read_text(encoding="utf-8").split():
            problems.append((path, f"lists no clips ({use})"))
            continue
        if not pieces:
            problems.append((path, f"none of its clips has a caption and {MIN_FRAMES} ≤ T < "
                                   f"{MAX_FRAMES_EXCLUSIVE} frames, so the loader keeps none "
                                   f"({use})"))
            continue
        wanted = 0 if needs is None else needs.windows.get(split, 0)
        if wanted:
            count = sum(max(0, (n - needs.frames) // needs.stride + 1) for n in pieces)
            if count < wanted:
                problems.append((path, f"gives {count} windows of {needs.frames} frames "
                                       f"(stride {needs.stride}); this scale's notebooks need "
                                       f"at least {wanted}"))
    return problems
