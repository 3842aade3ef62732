"""What a single-concept text's clips hold (generator version 3): per concept A, of the
captions that name A alone, the share whose clip also holds each other concept B.

Composition by summed energies (EnergyMoGen Eq. 7) multiplies single-concept conditionals
p(x | "A") p(x | "B"); the product has mass where both happen only if the clips of the text
"A" include ones where B happens too. HumanML3D's captions are partial, so they do; generator
v2's complete captions gave a share of 0. :func:`caption_co_occurrence` measures it on a
dataset's labels (``concepts``: what the motion holds; ``caption_concepts``: what each caption
names), and :func:`partial_caption_pilot` is the pilot behind
``generator.PARTIAL_CAPTION_SHARE`` (docs/GENERATOR_V3.md; ``python -m
repro.standin.cooccurrence`` prints it).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from repro.core.tables import markdown_table
from repro.standin.captions import sample_named_captions
from repro.standin.concepts import CONCEPTS
from repro.standin.dataset import clip_ids, read_clip
from repro.standin.generator import sample_clip_spec

__all__ = ["CoOccurrence", "caption_co_occurrence", "dataset_labels", "partial_caption_pilot",
           "partial_share", "pilot_table"]


@dataclass(frozen=True)
class CoOccurrence:
    """Rows: concepts A with at least one caption naming A alone; ``captions[a]`` how many;
    ``shares[a, b]`` the share of them whose clip holds concept ``columns[b]`` (1 where
    b is A); ``with_other[a]`` the share whose clip holds any concept besides A."""

    rows: tuple[str, ...]
    columns: tuple[str, ...]
    captions: np.ndarray
    shares: np.ndarray
    with_other: np.ndarray


def caption_co_occurrence(labels: Iterable[Mapping[str, Any]],
                          concepts: Sequence[str] | None = None) -> CoOccurrence:
    """Count, over every (clip, caption) whose caption names exactly one concept A, which
    concepts the clip holds. ``labels`` are ``labels/ID.json`` dicts; one without
    ``caption_concepts`` (generator ≤ 2) names all its concepts in every caption, as those
    generators wrote. ``concepts`` orders the rows and columns (default: the catalogue's)."""
    columns = tuple(concepts) if concepts is not None else tuple(CONCEPTS)
    index = {name: k for k, name in enumerate(columns)}
    counts = np.zeros(len(columns))
    holds = np.zeros((len(columns), len(columns)))
    other = np.zeros(len(columns))
    for label in labels:
        held = set(label.get("concepts", []))
        named = label.get("caption_concepts") or [sorted(held)] * 3
        for names in named:
            if len(names) != 1 or names[0] not in index:
                continue
            a = index[names[0]]
            counts[a] += 1
            other[a] += bool(held - {names[0]})
            for name in held & set(columns):
                holds[a, index[name]] += 1
    keep = counts > 0
    return CoOccurrence(rows=tuple(n for n, k in zip(columns, keep, strict=True) if k),
                        columns=columns, captions=counts[keep].astype(int),
                        shares=holds[keep] / counts[keep, None],
                        with_other=other[keep] / counts[keep])


def partial_share(labels: Iterable[Mapping[str, Any]]) -> tuple[float | None, int]:
    """(share of the captions of multi-concept clips that name only some of their concepts,
    how many such captions); (None, 0) when there are none."""
    partial = [len(names) < len(label["concepts"]) for label in labels
               if len(label.get("concepts", [])) > 1
               for names in label.get("caption_concepts") or [label["concepts"]] * 3]
    return (float(np.mean(partial)) if partial else None), len(partial)


def dataset_labels(root: str | Path) -> list[dict[str, Any]]:
    """The ``labels/ID.json`` of every clip of a HumanML3D-layout folder (empty dicts where
    there are none, as in real HumanML3D)."""
    return [read_clip(root, clip_id).labels for clip_id in clip_ids(root)]


def partial_caption_pilot(shares: Sequence[float], *, n_clips: int = 2000,
                          seed: int = 0) -> list[dict[str, float]]:
    """For each candidate ``partial_caption_share``: the clip specifications and captions of
    ``n_clips`` clips as ``write_dataset`` draws them (default compositions; no motion is
    solved, the captions depend on the specification alone) and, measured on them: the mean
    and the smallest over concepts of ``with_other`` (how far single-concept texts span the
    others), and the share of multi-concept clips that keep a caption naming all their
    concepts."""
    results = []
    for share in shares:
        labels, multi, complete = [], 0, 0
        for i in range(n_clips):
            rng = np.random.default_rng([seed, i])
            spec = sample_clip_spec(rng, partial_caption_share=share)
            named = [list(n) for _, n in sample_named_captions(spec, rng,
                                                               partial_share=share)]
            labels.append({"concepts": list(spec.concepts), "caption_concepts": named})
            if len(spec.concepts) > 1:
                multi += 1
                complete += any(len(n) == len(spec.concepts) for n in named)
        table = caption_co_occurrence(labels)
        results.append({"share": float(share), "mean_with_other": float(table.with_other.mean()),
                        "min_with_other": float(table.with_other.min()),
                        "multi_clips_with_a_complete_caption": complete / multi})
    return results


def pilot_table(results: Sequence[Mapping[str, float]]) -> str:
    """Markdown table of :func:`partial_caption_pilot`."""
    return markdown_table(
        ["partial caption share", "single-concept texts whose clip holds another concept: "
         "mean over concepts", "smallest", "multi-concept clips with a complete caption"],
        [(f"{r['share']:.1f}", f"{r['mean_with_other']:.3f}", f"{r['min_with_other']:.3f}",
          f"{r['multi_clips_with_a_complete_caption']:.3f}") for r in results])


if __name__ == "__main__":
    print(pilot_table(partial_caption_pilot([k / 10 for k in range(10)])))
