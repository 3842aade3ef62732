"""Notebook 00 ("the stand-in data"): its settings, the clips it shows, its figures and tables.

Everything the notebook states is computed here from the dataset it shows (the generated set
of :class:`Settings`, or any HumanML3D-layout folder), so the cells only call and display.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from repro.core.tables import markdown_table, render
from repro.infra.context import RunSettings, check_scale
from repro.motion import plotting
from repro.motion.features import FEATURE_BLOCKS, Conformance
from repro.standin.cooccurrence import CoOccurrence
from repro.standin.dataset import DatasetConfig, StoredClip, clip_ids, read_clip

__all__ = ["Settings", "agreement_tables", "block_std_rows", "co_occurrence_heatmap",
           "co_occurrence_reading", "concept_filmstrips", "conformance_table",
           "first_composed_clip", "root_paths", "shown_clips"]


@dataclass(frozen=True)
class Settings(RunSettings):
    """How big the generated set is and how many concepts the filmstrips show.

    Standard and paper scales: 1000 clips (default compositions, ``DatasetConfig``), 12
    concepts shown, the composed clip animated at every second frame. Quick: 120 clips, 6
    concepts, every eighth frame (a test of the code, never a result).
    """

    scale: str
    n_clips: int
    shown_concepts: int
    filmstrip_frames: int = 8
    animation_stride: int = 2

    @classmethod
    def for_scale(cls, scale: str) -> Settings:
        if check_scale(scale) == "quick":
            return cls(scale=scale, n_clips=120, shown_concepts=6, animation_stride=8)
        return cls(scale=scale, n_clips=1000, shown_concepts=12)

    def dataset(self, seed: int) -> DatasetConfig:
        """The generated set's config (its cache key) for base seed ``seed``."""
        return DatasetConfig(n_clips=self.n_clips, seed=seed)


def shown_clips(root: str | Path, count: int) -> tuple[list[StoredClip], int]:
    """Up to ``count`` clips to show, and how many concepts have a single-concept example.

    One clip per concept: the first (by ID) whose labels name that concept alone, in order of
    first appearance. A folder without labels (real HumanML3D) shows its first ``count``
    clips and reports 0 examples.
    """
    examples: dict[str, StoredClip] = {}
    ids = clip_ids(root)
    for clip_id in ids:
        clip = read_clip(root, clip_id)
        concepts = clip.labels.get("concepts", [])
        if clip.labels.get("composition") == "single" and concepts and \
                concepts[0] not in examples:
            examples[concepts[0]] = clip
    if examples:
        return list(examples.values())[:count], len(examples)
    return [read_clip(root, clip_id) for clip_id in ids[:count]], 0


def _concept_name(clip: StoredClip) -> str:
    concepts = clip.labels.get("concepts")
    return " + ".join(concepts) if concepts else "unlabelled"


def first_composed_clip(root: str | Path) -> StoredClip | None:
    """The first clip (by ID) labelled simultaneous or sequential; None if there is none."""
    for clip_id in clip_ids(root):
        clip = read_clip(root, clip_id)
        if clip.labels.get("composition") in ("simultaneous", "sequential"):
            return clip
    return None


def concept_filmstrips(clips: Sequence[StoredClip], *, frames: int = 8) -> plt.Figure:
    """One side-view filmstrip per clip, titled "concept (ID): first caption"."""
    if not clips:
        raise ValueError("no clips to show")
    fig, axes = plt.subplots(len(clips), 1, figsize=(10, 1.9 * len(clips)))
    for ax, clip in zip(np.atleast_1d(axes), clips, strict=True):
        plotting.filmstrip(clip.joints, frames=frames, ax=ax,
                           title=f"{_concept_name(clip)} ({clip.clip_id}): {clip.captions[0]}")
    fig.tight_layout()
    return fig


def root_paths(clips: Sequence[StoredClip]) -> plt.Figure:
    """The clips' root paths seen from above, labelled by concept."""
    fig, ax = plt.subplots(figsize=(6, 6))
    plotting.trajectories([clip.joints for clip in clips],
                          labels=[_concept_name(clip) for clip in clips], ax=ax,
                          title="root paths from above (facing +Z at frame 0)")
    return fig


def block_std_rows(std: np.ndarray, reference_std: np.ndarray) -> list[tuple[str, float, float,
                                                                             float]]:
    """Per feature block: (name, mean std here, mean std of the reference, ratio here/there).
    ``Std.npy`` is constant within each block (REFERENCE.md), so the mean is that value."""
    rows = []
    for name, block in FEATURE_BLOCKS.items():
        here, there = float(np.mean(std[block])), float(np.mean(reference_std[block]))
        rows.append((name, here, there, here / there))
    return rows


def _two_decimals(value: float | None) -> str:
    return "—" if value is None else f"{value:.2f}"


def agreement_tables(agreement: Mapping[str, Any]) -> tuple[str, str]:
    """Markdown tables of ``oracles.oracle_agreement``: per concept (support, precision,
    recall) and per composition (units, exact match, all true concepts detected)."""
    concepts = markdown_table(
        ["concept", "support", "precision", "recall"],
        [(name, c["support"], _two_decimals(c["precision"]), _two_decimals(c["recall"]))
         for name, c in agreement["per_concept"].items()])
    compositions = markdown_table(
        ["composition", "units", "exact match", "all true concepts detected"],
        [(kind, v["units"], _two_decimals(v["exact_match"]),
          _two_decimals(v["all_truth_detected"]))
         for kind, v in agreement["by_composition"].items()])
    return concepts, compositions


def conformance_table(result: Conformance) -> str:
    """Markdown: per block, the largest error on all frames and on the exact frames."""
    last = result.exact_frames - 1
    return markdown_table(
        ["block", "max error, all frames", f"frames 0–{last}"],
        [(name, f"{every:.1e}", f"{exact:.1e}")
         for name, (every, exact) in result.block_errors.items()])


def co_occurrence_heatmap(table: CoOccurrence) -> plt.Figure:
    """Rows: concepts; cell (A, B): the share of the captions naming A alone whose clip holds
    B (``cooccurrence.caption_co_occurrence``; the diagonal is 1 and left blank)."""
    if not table.rows:
        raise ValueError("no caption names a single concept")
    shares = table.shares.copy()
    for a, name in enumerate(table.rows):
        shares[a, table.columns.index(name)] = np.nan
    fig, ax = plt.subplots(figsize=(0.45 * len(table.columns) + 3, 0.4 * len(table.rows) + 2))
    image = ax.imshow(shares, cmap="viridis", vmin=0, vmax=max(np.nanmax(shares), 1e-9))
    ax.set_xticks(range(len(table.columns)), table.columns, rotation=90)
    ax.set_yticks(range(len(table.rows)),
                  [f"{name} (n={n})" for name, n in zip(table.rows, table.captions, strict=True)])
    ax.set_xlabel("concept the clip also holds")
    ax.set_ylabel("concept a caption names alone")
    fig.colorbar(image, ax=ax, label="share of those captions")
    ax.set_title("what the clips of a single-concept text hold")
    fig.tight_layout()
    return fig


def co_occurrence_reading(table: CoOccurrence, measured_share: float | None,
                          stated_share: float) -> str:
    """One paragraph read off the table: how often a single-concept caption's clip holds
    another concept (mean, least and most), and the partial share measured against the
    generator's setting."""
    if not table.rows:
        return "No caption names a single concept: nothing to read."
    least, most = int(np.argmin(table.with_other)), int(np.argmax(table.with_other))
    text = render(
        "Of the captions that name one concept, {mean:.0%} on average come from a clip that "
        "holds another concept too (least {least} at {least_share:.0%}, most {most} at "
        "{most_share:.0%}; over {n} captions).", mean=float(table.with_other.mean()),
        least=table.rows[least], least_share=float(table.with_other[least]),
        most=table.rows[most], most_share=float(table.with_other[most]),
        n=int(table.captions.sum()))
    if measured_share is not None:
        text += " " + render(
            "Captions of multi-concept clips that name only some of their concepts: "
            "{measured:.1%} (the generator's share: {stated:.0%}).",
            measured=measured_share, stated=stated_share)
    return text


#: how a measurement that needs the stand-in's labels reads on a folder without them
NOT_MEASURABLE = "not measurable on real data"


def has_labels(root: str | Path) -> bool:
    """Whether a HumanML3D-layout folder carries the stand-in's ``labels/`` (real HumanML3D
    does not: the oracle agreement and the caption co-occurrence need them)."""
    return (Path(root) / "labels").is_dir()


def not_measurable_reading(what: str, root: str | Path) -> str:
    """The notebook's line for a labels-based measurement on a folder without ``labels/``."""
    return (f"{what}: {NOT_MEASURABLE} ({Path(root)} has no `labels/`, the stand-in "
            f"generator's concept labels this measurement compares against).")
