"""Tiny GMD's data: fixed-length windows of HumanML3D-layout clips, and their feature space.

``DataConfig`` → ``load_windows``: windows of ``frames`` frames cut from the clips of a
HumanML3D-layout folder (the generated stand-in set when ``data_dir`` is None). Each window is
converted on its own, so it starts at the origin facing +Z: ``features.relative_to_absolute_root``
for the absolute representation (GMD's), left as is for the relative one (HumanML3D's).
Windows are normalised with the mean and block-averaged std of the training windows
(``humanml3d.compute_statistics``) and stored channels-first ``(N, 263, frames)``. The
trajectory view is channels 0:4 (``features.TRAJECTORY_FEATURES``). ``FeatureSpace`` maps
model space to the world (root path, joints) differentiably, for goal functions and
measurements.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor

from repro.infra import cache
from repro.motion.features import (
    FEATURE_DIM,
    TRAJECTORY_FEATURES,
    absolute_features_to_joints,
    absolute_to_relative_root,
    features_to_joints,
    recover_root,
    relative_to_absolute_root,
)
from repro.motion.humanml3d import REPRESENTATIONS, MotionDataset, compute_statistics, cut_windows
from repro.standin.text import Vocabulary

__all__ = ["CHANNELS", "LOCOMOTION_COMPOSITIONS", "LOCOMOTION_CONCEPTS", "DataConfig", "DataDir",
           "FeatureSpace", "MotionWindows", "REPRESENTATIONS", "Representation", "TASKS", "Task",
           "check_task", "goal_targets", "load_windows", "short_label"]

Task = Literal["trajectory", "motion"]


Representation = Literal["relative", "absolute"]


#: a HumanML3D-layout folder (a run context's `data_dir` is a Path; `DataConfig` keeps its
#: string), or None for the generated stand-in set
DataDir = str | Path | None


TASKS = ("trajectory", "motion")


#: number of model channels per task: the trajectory model sees (angle, x, z, y).
CHANNELS = {"trajectory": TRAJECTORY_FEATURES.stop - TRAJECTORY_FEATURES.start,
            "motion": FEATURE_DIM}


#: the stand-in's locomotion concepts: what GMD's claims are about (root trajectories, goals,
#: foot contacts, the root's representation) without the gestures and in-place actions that
#: EnergyMoGen composes (``DataConfig.stand_in_concepts``)
LOCOMOTION_CONCEPTS = ("walk_forward", "walk_backward", "walk_left", "walk_right", "run",
                       "turn_left", "turn_right", "walk_circle")

#: the locomotion set's clips: one concept (80 %) or two in sequence (20 %); no simultaneous
#: pair exists, every locomotion concept owning the root and the legs
LOCOMOTION_COMPOSITIONS = (("single", 0.8), ("sequential", 0.2))


def short_label(representation: str) -> str:
    """The short label of a representation in tables and measurement names: "rel", "abs"."""
    if representation not in REPRESENTATIONS:
        raise ValueError(f"representation must be one of {REPRESENTATIONS}, got "
                         f"{representation!r}")
    return representation[:3]


@dataclass(frozen=True)
class DataConfig:
    """Which windows a model trains on.

    ``data_dir`` is a HumanML3D-layout folder (a Path is kept as its string), or None for the
    generated stand-in set
    (``dataset.ensure_dataset(DatasetConfig(n_clips=stand_in_clips, seed=stand_in_seed))``).
    Windows of ``frames`` frames (a multiple of 4) start every ``stride`` frames of each clip;
    clips shorter than ``frames`` give none. ``max_windows`` keeps a random subset (seed 0,
    in clip order) of at most that many *training* windows; other splits are never cut.
    """

    data_dir: str | None = None
    stand_in_clips: int = 2000
    stand_in_seed: int = 0
    frames: int = 48
    stride: int = 24
    representation: Representation = "absolute"
    max_windows: int | None = None
    #: the stand-in set's concept pool and composition weights (``standin.dataset``); None:
    #: the whole catalogue and the generator's weights. Not read with ``data_dir``.
    stand_in_concepts: tuple[str, ...] | None = LOCOMOTION_CONCEPTS
    stand_in_compositions: tuple[tuple[str, float], ...] | None = LOCOMOTION_COMPOSITIONS

    def __post_init__(self) -> None:
        if self.data_dir is not None and not isinstance(self.data_dir, str):
            object.__setattr__(self, "data_dir", str(self.data_dir))  # a Path: its string
        if self.frames < 4 or self.frames % 4:
            raise ValueError(f"frames must be a positive multiple of 4, got {self.frames}")
        if self.stride < 1:
            raise ValueError(f"stride must be >= 1, got {self.stride}")
        if self.representation not in REPRESENTATIONS:
            raise ValueError(f"representation must be one of {REPRESENTATIONS}, got "
                             f"{self.representation!r}")
        if self.data_dir is None and self.stand_in_clips < 1:
            raise ValueError(f"stand_in_clips must be >= 1, got {self.stand_in_clips}")
        if self.max_windows is not None and self.max_windows < 1:
            raise ValueError(f"max_windows must be >= 1 or None, got {self.max_windows}")
        if self.stand_in_concepts is not None:
            from repro.standin.concepts import check_concept

            object.__setattr__(self, "stand_in_concepts", tuple(self.stand_in_concepts))
            if not self.stand_in_concepts:
                raise ValueError("stand_in_concepts must name at least one concept or be None")
            for name in self.stand_in_concepts:
                check_concept(name)
        if self.stand_in_compositions is not None:
            from repro.standin.clip_spec import COMPOSITIONS

            object.__setattr__(self, "stand_in_compositions", tuple(
                (str(kind), float(weight)) for kind, weight in self.stand_in_compositions))
            unknown = [k for k, _ in self.stand_in_compositions if k not in COMPOSITIONS]
            if unknown:
                raise ValueError(f"unknown stand-in compositions {unknown}; known: {COMPOSITIONS}")

    def as_dict(self) -> dict[str, Any]:
        config = dataclasses.asdict(self)
        for name in ("max_windows", "stand_in_concepts", "stand_in_compositions"):
            if config[name] is None:   # keeps the hashes of configs made before the field
                config.pop(name)
        for name in ("stand_in_concepts", "stand_in_compositions"):
            if name in config:
                config[name] = [list(v) if isinstance(v, tuple) else v for v in config[name]]
        if self.data_dir is not None:
            config["data_dir"] = str(Path(self.data_dir).resolve())
            for name in ("stand_in_clips", "stand_in_seed", "stand_in_concepts",
                         "stand_in_compositions"):
                config.pop(name, None)
        return config

    def dataset_root(self) -> Path:
        """The folder: ``data_dir``, or the stand-in set (generated on first use, cached)."""
        if self.data_dir is not None:
            return Path(self.data_dir)
        from repro.standin.dataset import DatasetConfig, ensure_dataset

        options: dict[str, Any] = {}
        if self.stand_in_concepts is not None:
            options["concept_pool"] = self.stand_in_concepts
        if self.stand_in_compositions is not None:
            options["compositions"] = self.stand_in_compositions
        return ensure_dataset(DatasetConfig(n_clips=self.stand_in_clips,
                                            seed=self.stand_in_seed, **options))


@dataclass(frozen=True)
class FeatureSpace:
    """Model space ↔ world: (B, C, T) normalised channels ↔ un-normalised features, root, joints.

    ``mean``/``std`` are the statistics of the C model channels (C = 4 for the trajectory task,
    263 for the motion task). Every torch method is differentiable (goal functions use them).
    """

    task: Task
    representation: Representation
    mean: np.ndarray
    std: np.ndarray

    @property
    def channels(self) -> int:
        return CHANNELS[self.task]

    def _stats(self, like: Tensor) -> tuple[Tensor, Tensor]:
        mean = torch.as_tensor(self.mean, dtype=like.dtype, device=like.device)
        std = torch.as_tensor(self.std, dtype=like.dtype, device=like.device)
        return mean, std

    def normalise(self, features: Tensor) -> Tensor:
        """Un-normalised features (B, T, C) → model space (B, C, T): (f − mean)/std."""
        mean, std = self._stats(features)
        return ((features - mean) / std).transpose(1, 2)

    def unnormalise(self, x: Tensor) -> Tensor:
        """Model space (B, C, T) → un-normalised features (B, T, C): x·std + mean."""
        if x.dim() != 3 or x.shape[1] != self.channels:
            raise ValueError(f"x must be (B, {self.channels}, T), got {tuple(x.shape)}")
        mean, std = self._stats(x)
        return x.transpose(1, 2) * std + mean

    def _as_263(self, features: Tensor) -> Tensor:
        if features.shape[-1] == FEATURE_DIM:
            return features
        # recover_root reads only the 4 root features: the trajectory task pads the rest
        pad = features.new_zeros(*features.shape[:-1], FEATURE_DIM - features.shape[-1])
        return torch.cat((features, pad), dim=-1)

    def root_positions(self, x: Tensor) -> Tensor:
        """World root positions (B, T, 3) = (x, y, z) of model-space samples (B, C, T).

        Absolute: read from features 1, 3, 2. Relative: ``features.recover_root``."""
        features = self.unnormalise(x)
        if self.representation == "absolute":
            return features[..., [1, 3, 2]]
        _, position = recover_root(self._as_263(features))
        return position

    def root_xz(self, x: Tensor) -> Tensor:
        """World root x/z (B, T, 2) of model-space samples (B, C, T)."""
        return self.root_positions(x)[..., [0, 2]]

    def joints(self, x: Tensor) -> Tensor:
        """Joint positions (B, T, 22, 3) of motion-task samples (B, 263, T)."""
        if self.task != "motion":
            raise ValueError("joints need the motion task (the trajectory task has no body)")
        features = self.unnormalise(x)
        if self.representation == "absolute":
            return absolute_features_to_joints(features)
        return features_to_joints(features)

    def relative_features(self, x: Tensor) -> Tensor:
        """HumanML3D (relative-root) features (B, T, 263) of motion-task samples (B, 263, T),
        e.g. for the evaluator, which reads the relative representation."""
        if self.task != "motion":
            raise ValueError("relative_features needs the motion task")
        features = self.unnormalise(x)
        if self.representation == "absolute":
            return absolute_to_relative_root(features)
        return features

    def as_dict(self) -> dict[str, Any]:
        return {"task": self.task, "representation": self.representation,
                "mean": np.asarray(self.mean).tolist(), "std": np.asarray(self.std).tolist()}


@dataclass
class MotionWindows:
    """Normalised windows ``x`` (N, 263, frames) float32 with their captions.

    ``mean``/``std`` (263,) are the statistics the windows were normalised with (the training
    windows'); ``ids`` are ``"<clip id>:<first frame>"``; ``fingerprint`` hashes the windows,
    captions and statistics (part of every model's cache key).
    """

    config: DataConfig
    split: str
    root: Path
    x: Tensor
    mean: np.ndarray
    std: np.ndarray
    captions: list[list[str]]
    ids: list[str]
    fingerprint: str
    vocabulary: Vocabulary | None = field(repr=False, default=None)

    def __len__(self) -> int:
        return int(self.x.shape[0])

    @property
    def frames(self) -> int:
        return int(self.x.shape[2])

    def trajectory(self) -> Tensor:
        """The trajectory view (N, 4, frames): channels (angle, x, z, y) — in the absolute
        representation the heading half-angle and the world root x, z, y."""
        return self.x[:, TRAJECTORY_FEATURES]

    def channels(self, task: Task) -> Tensor:
        """What a model of ``task`` sees: the trajectory view or all 263 channels."""
        check_task(task)
        return self.trajectory() if task == "trajectory" else self.x

    def space(self, task: Task) -> FeatureSpace:
        """The ``FeatureSpace`` of a model of ``task`` trained on these windows."""
        check_task(task)
        picks = TRAJECTORY_FEATURES if task == "trajectory" else slice(None)
        return FeatureSpace(task, self.config.representation, self.mean[picks].copy(),
                            self.std[picks].copy())

    def features(self) -> Tensor:
        """Un-normalised features (N, frames, 263) in the windows' representation."""
        return self.space("motion").unnormalise(self.x)


def check_task(task: str) -> None:
    if task not in TASKS:
        raise ValueError(f"task must be one of {TASKS}, got {task!r}")


def _to_representation(windows: np.ndarray, representation: str,
                       chunk: int = 512) -> np.ndarray:
    """Relative windows (N, T, 263) → the representation, each window starting at the origin."""
    if representation == "relative":
        return windows
    out = np.empty_like(windows)
    for start in range(0, len(windows), chunk):
        block = torch.from_numpy(windows[start:start + chunk].astype(np.float64))
        out[start:start + chunk] = relative_to_absolute_root(block).numpy().astype(np.float32)
    return out


def _fingerprint(x: Tensor, captions: list[list[str]], mean: np.ndarray,
                 std: np.ndarray) -> str:
    return cache.fingerprint(x, np.asarray(mean, np.float32), np.asarray(std, np.float32),
                             captions, digits=16)


def load_windows(config: DataConfig, split: str = "train", *,
                 statistics: tuple[np.ndarray, np.ndarray] | None = None) -> MotionWindows:
    """Windows of one split, normalised (channels-first, float32).

    ``statistics`` (mean, std) of the *training* windows must be passed for any other split
    (e.g. ``load_windows(cfg, "test", statistics=(train.mean, train.std))``); when None they
    are computed here — mean and block-averaged std over all frames of these windows
    (``humanml3d.compute_statistics``, HumanML3D's convention).
    """
    root = config.dataset_root()
    dataset = MotionDataset(root, split, normalise=False, representation="relative")
    pieces, captions, ids = cut_windows(dataset, config.frames, config.stride)
    if not pieces:
        raise ValueError(f"no clip of {root}/{split}.txt has {config.frames} frames")
    limit = config.max_windows if split == "train" else None
    if limit is not None and limit < len(pieces):
        keep = np.sort(np.random.default_rng(0).choice(len(pieces), limit, replace=False))
        pieces = [pieces[i] for i in keep]
        captions = [captions[i] for i in keep]
        ids = [ids[i] for i in keep]
    windows = _to_representation(np.stack(pieces).astype(np.float32), config.representation)
    if statistics is None:
        mean, std = compute_statistics([windows.reshape(-1, FEATURE_DIM)])
    else:
        mean, std = (np.asarray(a, dtype=np.float32) for a in statistics)
    x = torch.from_numpy(((windows - mean) / std).astype(np.float32)).transpose(1, 2).contiguous()
    vocabulary = Vocabulary.build(c for options in captions for c in options)
    return MotionWindows(config, split, Path(root), x, mean, std, captions, ids,
                         _fingerprint(x, captions, mean, std), vocabulary)


def goal_targets(windows: MotionWindows, n: int, *, seed: int, frame: int = -1,
                 min_distance: float = 0.0) -> np.ndarray:
    """n goal locations (n, 2): the root x/z at ``frame`` of n windows drawn with ``seed``
    among those whose root ends at least ``min_distance`` (m) from its start (e.g. test
    windows: places a motion of this data set does reach in that time)."""
    space = windows.space("trajectory")
    with torch.no_grad():
        ends = space.root_xz(windows.trajectory())[:, frame].numpy().astype(np.float32)
    eligible = np.flatnonzero(np.linalg.norm(ends, axis=1) >= min_distance)
    if n > len(eligible):
        raise ValueError(f"asked for {n} targets but only {len(eligible)} of {len(windows)} "
                         f"windows end ≥ {min_distance} m from their start")
    return ends[np.random.default_rng(seed).choice(eligible, n, replace=False)]
