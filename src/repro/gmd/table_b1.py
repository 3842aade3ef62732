"""GMD's Table B.1 on stand-in data (claim GMD-B3): text-to-motion with either root representation.

The same tiny text-conditioned motion model, trained on relative- and on absolute-root windows,
generates one motion per test caption; the package's evaluator scores FID, R-precision top-3
and Diversity against the test windows, and the concept oracles the recall of the captioned
concepts. Part of ``notebooks/02_root_representation.ipynb`` (with ``root_representation``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from repro.core.stats import t_interval
from repro.core.tables import interval_text, markdown_table
from repro.gmd.cfg import GMD_CFG_SCALE, sample_classifier_free
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import REPRESENTATIONS, MotionWindows, short_label
from repro.infra.storage import read_json
from repro.models.evaluator import Evaluator, evaluate_generated
from repro.motion.features import features_to_joints

__all__ = [
    "PAPER_TABLE_B1",
    "TABLE_METRICS",
    "by_label",
    "EvaluationSet",
    "concept_recall",
    "evaluation_set",
    "generate_for_captions",
    "registered_measurements",
    "ground_truth_row",
    "summarise_rows",
    "table_b1_markdown",
    "table_row",
    "window_concepts",
]

#: Table B.1 of the GMD appendix (HumanML3D): FID ↓, R-precision top-3 ↑, Diversity →.
PAPER_TABLE_B1: dict[str, tuple[float, float, float]] = {
    "Real": (0.002, 0.797, 9.503),
    "MDM (rel)": (0.556, 0.608, 9.446),
    "MDM (abs)": (0.894, 0.638, 8.819),
    "Ours (rel)": (0.305, 0.666, 9.861),
    "Ours (abs)": (0.212, 0.670, 9.440),
    "Ours xproj": (0.235, 0.652, 9.726),
}


@dataclass
class EvaluationSet:
    """The captions a Table B.1 run generates for, and the ground truth they came with.

    ``features`` (n, frames, 263) are the test windows' relative-root features (what the
    evaluator reads); ``captions`` one caption per window, drawn with the set's seed;
    ``truth`` the labelled concepts of each window (:func:`window_concepts`).
    """

    ids: list[str]
    captions: list[str]
    features: np.ndarray
    truth: list[set[str]]

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def lengths(self) -> np.ndarray:
        return np.full(len(self.ids), self.features.shape[1], dtype=np.int64)


def window_concepts(labels: dict, start: int, frames: int) -> set[str]:
    """Concepts labelled in clip frames [start, start + frames): every concept of a single or
    simultaneous clip; for a sequential clip the segments overlapping the window by at least
    half its length."""
    if labels.get("composition") == "sequential":
        found = set()
        for segment in labels["segments"]:
            overlap = min(segment["end"], start + frames) - max(segment["start"], start)
            if overlap >= frames // 2:
                found.add(segment["concept"])
        return found
    return set(labels.get("concepts", []))


def _window_labels(root: Path, window_id: str, frames: int) -> set[str]:
    clip, start = window_id.rsplit(":", 1)
    offset = 0
    if "@" in clip:                       # a sub-range item "<clip>@a-b"
        clip, span = clip.split("@")
        offset = int(span.split("-")[0])
    path = root / "labels" / f"{clip}.json"
    if not path.is_file():
        return set()
    return window_concepts(read_json(path), offset + int(start), frames)


def evaluation_set(test_windows: MotionWindows, n: int, *, seed: int) -> EvaluationSet:
    """n test windows drawn with ``seed`` (in window order), one caption each, as
    relative-root features (absolute-root windows are converted: the same motions)."""
    n = min(n, len(test_windows))
    rng = np.random.default_rng(seed)
    picks = np.sort(rng.choice(len(test_windows), n, replace=False))
    captions = [test_windows.captions[i][rng.integers(len(test_windows.captions[i]))]
                for i in picks]
    with torch.no_grad():
        features = test_windows.space("motion").relative_features(
            test_windows.x[torch.from_numpy(picks)]).numpy()
    ids = [test_windows.ids[i] for i in picks]
    truth = [_window_labels(test_windows.root, i, test_windows.frames) for i in ids]
    return EvaluationSet(ids, captions, features.astype(np.float32), truth)


def generate_for_captions(trained: TrainedGMD, captions: Sequence[str], *, seed: int,
                          guidance_scale: float = GMD_CFG_SCALE,
                          batch_size: int = 128) -> np.ndarray:
    """One sample per caption with classifier-free guidance at ``guidance_scale`` (GMD: 2.5;
    1 = plain conditional sampling; ``repro.gmd.cfg``), returned as relative-root features
    (n, frames, 263) (an abs model's samples are converted with ``absolute_to_relative_root``).
    Batch k uses the sampling seed 10 000·seed + k, so models sampled with one seed share
    their noise."""
    out = []
    for k, start in enumerate(range(0, len(captions), batch_size)):
        chunk = list(captions[start:start + batch_size])
        x = sample_classifier_free(trained, len(chunk), seed=10_000 * seed + k, text=chunk,
                                   scale=guidance_scale)
        with torch.no_grad():
            out.append(trained.space.relative_features(x).cpu().numpy())
    return np.concatenate(out).astype(np.float32)


def concept_recall(features: np.ndarray, truth: Sequence[set[str]]) -> float:
    """Fraction of (window, labelled concept) pairs the concept oracles find in the joints
    recovered from relative-root ``features`` (n, frames, 263) (``oracles.detect_concepts``)."""
    from repro.standin.oracles import detect_concepts

    joints = features_to_joints(np.asarray(features, dtype=np.float64))
    hits = total = 0
    for clip, concepts in zip(joints, truth, strict=True):
        if not concepts:
            continue
        detected = detect_concepts(clip)
        hits += len(concepts & detected)
        total += len(concepts)
    return hits / total if total else float("nan")


def table_row(evaluator: Evaluator, generated: np.ndarray, evaluation: EvaluationSet, *,
              seed: int) -> dict[str, float]:
    """FID (generated vs the evaluation set's ground truth), R-precision top-3, Diversity
    (``evaluator.evaluate_generated``) and the concept-oracle recall of one generated set."""
    result = evaluate_generated(evaluator, generated, evaluation.lengths, evaluation.captions,
                                evaluation.features, evaluation.lengths, seed=seed)
    return {"fid": result["fid"], "r_precision_top3": result["r_precision_top3"],
            "diversity": result["diversity"],
            "concept_recall": concept_recall(generated, evaluation.truth)}


def ground_truth_row(evaluator: Evaluator, evaluation: EvaluationSet,
                     train_features: np.ndarray, *, seed: int) -> dict[str, float]:
    """The "Real" row: FID of the evaluation set against as many training windows (drawn with
    ``seed``), R-precision top-3 and Diversity of the evaluation set with its own captions,
    and the concept oracles' recall on it (their ceiling on these windows)."""
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(train_features), len(evaluation), replace=False)
    train = np.asarray(train_features)[np.sort(picks)]
    result = evaluate_generated(evaluator, evaluation.features, evaluation.lengths,
                                evaluation.captions, train, evaluation.lengths, seed=seed)
    return {"fid": result["fid"], "r_precision_top3": result["r_precision_top3"],
            "diversity": result["diversity"],
            "concept_recall": concept_recall(evaluation.features, evaluation.truth)}


def summarise_rows(per_seed: Sequence[dict[str, float]]) -> dict[str, dict[str, float] | str]:
    """Per metric: mean and Student-t 95 % interval over seeds (``core.stats.t_interval``);
    :data:`NOT_MEASURABLE` for a metric with no number (concept recall without ``labels/``)."""
    names = per_seed[0].keys()
    columns = {name: [row[name] for row in per_seed] for name in names}
    return {name: t_interval(values).as_dict() if measurable(values) else NOT_MEASURABLE
            for name, values in columns.items()}


TABLE_METRICS = ("fid", "r_precision_top3", "diversity", "concept_recall")
#: concept recall on a folder without the stand-in's ``labels/`` (real HumanML3D): no window
#: has labelled concepts, so :func:`concept_recall` is NaN and the table says this instead
NOT_MEASURABLE = "not measurable on real data"


def measurable(values: float | Sequence[float]) -> bool:
    """Whether a column's values hold a number (concept recall is NaN without labels)."""
    return bool(np.isfinite(np.asarray(values, dtype=np.float64)).any())


def table_b1_markdown(real: dict[str, float], rows: dict[str, list[dict[str, float]]]) -> str:
    """Our Table B.1 (mean ± 95 % t half-width over seeds) with the paper's rows beside it;
    ``rows``: the per-seed rows (:func:`table_row`) of each representation."""
    header = ["row", "FID ↓", "R-precision top-3 ↑", "Diversity →", "concept recall ↑",
              "seeds"]
    body: list[list[object]] = [["Real (stand-in test vs train)"]
                                + [real[m] if measurable(real[m]) else NOT_MEASURABLE
                                   for m in TABLE_METRICS] + ["–"]]
    for rep in REPRESENTATIONS:
        body.append([f"tiny GMD ({short_label(rep)})"]
                    + [interval_text([r[m] for r in rows[rep]], decimals=3)
                       if measurable([r[m] for r in rows[rep]]) else NOT_MEASURABLE
                       for m in TABLE_METRICS] + [len(rows[rep])])
    for name, (fid, r3, div) in PAPER_TABLE_B1.items():
        body.append([f"paper: {name}", fid, r3, div, "–", "–"])
    return markdown_table(header, body)



def by_label(per_representation: dict[str, object]) -> dict[str, object]:
    """The same values keyed by the short labels "rel"/"abs" (the ledger's layout)."""
    return {short_label(rep): value for rep, value in per_representation.items()}


def registered_measurements(real: dict[str, float],
                            rows: dict[str, list[dict[str, float]]]) -> dict[str, object]:
    """GMD-B3's measured values: per-seed FID, R-precision top-3 and Diversity of each
    representation (``fid_rel``, ``fid_abs``, …) and the real windows' Diversity."""
    measured: dict[str, object] = {}
    for metric in ("fid", "r_precision_top3", "diversity"):
        for rep in REPRESENTATIONS:
            measured[f"{metric}_{short_label(rep)}"] = [r[metric] for r in rows[rep]]
    measured["diversity_real"] = real["diversity"]
    return measured
