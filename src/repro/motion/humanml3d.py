"""Load and validate any folder in HumanML3D's layout (the real data or the stand-in set).

Layout and loader conventions (REFERENCE.md "Folder layout"; HumanML3D/text-to-motion
``Text2MotionDatasetV2``): ``new_joint_vecs/ID.npy`` (T, 263), ``texts/ID.txt`` with lines
``caption#word/POS ...#start#end`` (seconds, ``0.0#0.0`` = whole clip), ``Mean.npy``/``Std.npy``,
``train.txt``/``val.txt``/``test.txt``; optional ``new_joints/ID.npy`` (T, 22, 3) and
``labels/ID.json`` (concept labels written by the stand-in generator). Clips are kept when
40 ≤ T < 200, cropped to a multiple of 4 frames (at most ``max_length``) and zero-padded.

Choices where HumanML3D's loader draws at random:
* the crop keeps the *first* frames (HumanML3D picks a random offset, and one time in three
  one unit shorter), so an item is a deterministic function of the folder and the index;
* the caption of an item is drawn from its captions by ``np.random.default_rng((seed, epoch,
  index))``: reproducible whatever the order of access, different per epoch (``set_epoch``).
Sub-range captions (start/end ≠ 0) become their own items, cut at ``int(20·start)`` to
``int(20·end)`` like HumanML3D; lines with the same range are grouped into one item.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import Dataset

from repro.infra import cache, paths, storage
from repro.motion.features import (
    FEATURE_BLOCKS,
    FEATURE_DIM,
    FPS,
    absolute_features_to_joints,
    features_to_joints,
    relative_to_absolute_root,
)
from repro.motion.layout import (
    MAX_FRAMES_EXCLUSIVE,
    MIN_FRAMES,
    SPLITS,
    UNIT_LENGTH,
    caption_spans,
    kept_length,
    parse_text_line,
    read_split,
    read_text_file,
)
from repro.motion.skeleton import NUM_JOINTS, bone_lengths
from repro.motion.usability import usability_problems

MAX_LENGTH = 196
REPRESENTATIONS = ("relative", "absolute")
#: validator tolerances: bone-length spread over frames (m), features → new_joints (m).
BONE_LENGTH_TOLERANCE = 1e-3
RECOVERY_TOLERANCE = 1e-4


def _check_root(root: str | os.PathLike) -> Path:
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"dataset folder {root} not found")
    return root


# ------------------------------------------------------------------------------- statistics

def _check_statistics(mean: np.ndarray, std: np.ndarray, source: str) -> None:
    for name, array in (("mean", mean), ("std", std)):
        if array.shape != (FEATURE_DIM,):
            raise ValueError(f"{source}: {name} must have shape ({FEATURE_DIM},), "
                             f"got {array.shape}")
        if not np.isfinite(array).all():
            raise ValueError(f"{source}: {name} contains NaN or inf")
    if (std <= 0).any():
        raise ValueError(f"{source}: std must be positive, dims {np.flatnonzero(std <= 0)[:5]} "
                         "are not")


def block_averaged_std(std: np.ndarray) -> np.ndarray:
    """Each feature block's per-dimension std replaced by the block's mean, float64 (263,).

    HumanML3D's ``mean_variance`` / ``cal_mean_variance`` convention (REFERENCE.md:
    "Std.npy is averaged within each block"); HumanML3D also divides the root and
    foot-contact blocks by ``feat_bias`` = 5, we do not. A block whose std is 0 (a constant
    feature) gets 1, so normalising never divides by 0.
    """
    out = np.asarray(std, dtype=np.float64).copy()
    for block in FEATURE_BLOCKS.values():
        value = out[block].mean()
        out[block] = value if value > 0 else 1.0
    return out


def compute_statistics(motions: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Mean and std (263,) float32 over all frames, the std averaged within each feature block
    (:func:`block_averaged_std`)."""
    if not motions:
        raise ValueError("no motions to compute statistics from")
    frames = np.concatenate([np.asarray(m, dtype=np.float64) for m in motions], axis=0)
    mean, std = frames.mean(axis=0), block_averaged_std(frames.std(axis=0))
    return mean.astype(np.float32), std.astype(np.float32)


def _absolute_cache_key(root: Path, ids: list[str], min_length: int) -> str:
    def stamp(path: Path) -> list[int]:
        info = path.stat()
        return [info.st_size, info.st_mtime_ns]

    files = {i: stamp(root / "new_joint_vecs" / f"{i}.npy") + stamp(root / "texts" / f"{i}.txt")
             for i in ids}
    config = {"root": str(root.resolve()), "min_length": min_length, "files": files, "v": 1}
    return cache.fingerprint(json.dumps(config, sort_keys=True), digits=16)


def absolute_statistics(root: str | os.PathLike, *,
                        min_length: int = MIN_FRAMES) -> tuple[np.ndarray, np.ndarray]:
    """Statistics of GMD's absolute-root features over the *train* split's kept clips
    (GMD recomputes ``Mean_abs_3d``/``Std_abs_3d`` the same way), cached under
    ``cache_dir()/statistics/<hash>/`` where the hash covers the folder, the clip files'
    sizes and modification times, and ``min_length``."""
    root = _check_root(root)
    ids = read_split(root, "train")
    _require_files(root, ids, "train")
    folder = paths.cache_dir() / "statistics" / _absolute_cache_key(root, ids, min_length)
    if (folder / "std.npy").is_file():
        return storage.read_npy(folder / "mean.npy"), storage.read_npy(folder / "std.npy")
    entries, _ = _load_entries(root, ids, min_length, "absolute")
    mean, std = compute_statistics([entry.motion for entry in entries])
    storage.write_npy(folder / "mean.npy", mean)
    storage.write_npy(folder / "std.npy", std)  # written last: its presence marks completion
    return mean, std


def load_statistics(root: str | os.PathLike,
                    representation: str = "relative") -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) float32 (263,): ``Mean.npy``/``Std.npy`` for the relative representation,
    :func:`absolute_statistics` for the absolute one."""
    root = _check_root(root)
    if representation not in REPRESENTATIONS:
        raise ValueError(f"representation must be one of {REPRESENTATIONS}, got {representation!r}")
    if representation == "absolute":
        return absolute_statistics(root)
    arrays = []
    for name in ("Mean.npy", "Std.npy"):
        if not (root / name).is_file():
            raise FileNotFoundError(f"statistics file {root / name} not found")
        arrays.append(storage.read_npy(root / name).astype(np.float32))
    _check_statistics(arrays[0], arrays[1], str(root))
    return arrays[0], arrays[1]


# -------------------------------------------------------------------------------- the dataset

@dataclass
class _Entry:
    id: str
    motion: np.ndarray  # (T, 263) float32, in the dataset's representation, unnormalised
    captions: list[str]
    labels: dict[str, Any]


def _require_files(root: Path, ids: list[str], split: str) -> None:
    missing = [str(root / folder / f"{i}{suffix}") for i in ids
               for folder, suffix in (("new_joint_vecs", ".npy"), ("texts", ".txt"))
               if not (root / folder / f"{i}{suffix}").is_file()]
    if missing:
        raise FileNotFoundError(f"{len(missing)} files listed in {split}.txt are missing, e.g. "
                                + ", ".join(missing[:3]))


def _read_labels(path: Path) -> dict[str, Any]:
    if not path.is_file():
        return {}
    try:
        labels = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not valid JSON ({error})") from None
    if not isinstance(labels, dict):
        raise ValueError(f"{path}: labels must be a JSON object, got {type(labels).__name__}")
    return labels


def _load_features(path: Path) -> np.ndarray:
    motion = storage.read_npy(path)
    if motion.ndim != 2 or motion.shape[1] != FEATURE_DIM:
        raise ValueError(f"{path}: features must have shape (T, {FEATURE_DIM}), "
                         f"got {motion.shape}")
    return motion


def _load_entries(root: Path, ids: list[str], min_length: int,
                  representation: str) -> tuple[list[_Entry], dict[str, list[str]]]:
    entries: list[_Entry] = []
    skipped: dict[str, list[str]] = {"nan": [], "length": [], "no_caption": []}

    def keep(frames: int) -> bool:
        return kept_length(frames, min_length)

    for clip in ids:
        motion = _load_features(root / "new_joint_vecs" / f"{clip}.npy")
        if not np.isfinite(motion).all():
            skipped["nan"].append(clip)
            continue
        if not keep(len(motion)):
            skipped["length"].append(clip)
            continue
        labels = _read_labels(root / "labels" / f"{clip}.json")
        whole, ranges = caption_spans(read_text_file(root / "texts" / f"{clip}.txt"), FPS)
        pieces = [(clip, motion, whole)] if whole else []
        pieces += [(f"{clip}@{a}-{b}", motion[a:b], captions)
                   for (a, b), captions in ranges.items()]
        if not pieces:
            skipped["no_caption"].append(clip)
        for name, piece, captions in pieces:
            if not keep(len(piece)):
                skipped["length"].append(name)
                continue
            if representation == "absolute":
                piece = relative_to_absolute_root(piece.astype(np.float64))
            entries.append(_Entry(name, piece.astype(np.float32), captions, labels))
    return entries, skipped


class MotionDataset(Dataset):
    """Clips of one split as ``{motion, length, caption, captions, labels, id}`` items.

    ``motion`` is a float32 tensor (max_length, 263), normalised by (mean, std) when
    ``normalise`` and zero-padded after ``length`` frames (a multiple of 4). ``representation``
    "absolute" converts each clip with ``relative_to_absolute_root`` and, unless ``statistics``
    is given, normalises with :func:`absolute_statistics` (the train split's). Clips with NaN
    are skipped with a warning, as HumanML3D does with 007975; ``skipped`` counts every skip.
    """

    def __init__(self, root: str | os.PathLike, split: str = "train", *,
                 min_length: int = MIN_FRAMES, max_length: int = MAX_LENGTH,
                 normalise: bool = True, representation: str = "relative",
                 statistics: tuple[np.ndarray, np.ndarray] | None = None,
                 seed: int = 0) -> None:
        self.root = _check_root(root)
        if representation not in REPRESENTATIONS:
            raise ValueError(f"representation must be one of {REPRESENTATIONS}, "
                             f"got {representation!r}")
        if min_length < 1 or max_length < UNIT_LENGTH:
            raise ValueError(f"need min_length ≥ 1 and max_length ≥ {UNIT_LENGTH}, "
                             f"got {min_length}, {max_length}")
        self.split, self.representation = split, representation
        self.min_length, self.max_length = min_length, max_length
        self.normalise, self.seed, self.epoch = normalise, seed, 0
        ids = read_split(self.root, split)
        if not ids:
            raise ValueError(f"{self.root / f'{split}.txt'} lists no clips")
        _require_files(self.root, ids, split)
        self.entries, self.skipped = _load_entries(self.root, ids, min_length, representation)
        if self.skipped["nan"]:
            warnings.warn(f"{len(self.skipped['nan'])} clips of {self.root}/{split}.txt contain "
                          f"NaN and were skipped: {', '.join(self.skipped['nan'][:5])}",
                          stacklevel=2)
        if not self.entries:
            raise ValueError(f"no clip of {self.root}/{split}.txt passes {min_length} ≤ T < "
                             f"{MAX_FRAMES_EXCLUSIVE} with a caption (skipped: {self.skipped})")
        if statistics is None:
            statistics = load_statistics(self.root, representation)
        mean, std = (np.asarray(a, dtype=np.float32) for a in statistics)
        _check_statistics(mean, std, "statistics")
        self.mean, self.std = mean, std

    def __len__(self) -> int:
        return len(self.entries)

    def set_epoch(self, epoch: int) -> None:
        """Change which caption each item draws (the draw is seeded by seed, epoch, index)."""
        self.epoch = epoch

    def normalise_motion(self, motion: np.ndarray | torch.Tensor) -> np.ndarray | torch.Tensor:
        """(motion − mean) / std."""
        mean, std = self._statistics_like(motion)
        return (motion - mean) / std

    def denormalise(self, motion: np.ndarray | torch.Tensor) -> np.ndarray | torch.Tensor:
        """motion · std + mean (inverse of :meth:`normalise_motion`)."""
        mean, std = self._statistics_like(motion)
        return motion * std + mean

    def _statistics_like(self, motion: np.ndarray | torch.Tensor) -> tuple[Any, Any]:
        if isinstance(motion, torch.Tensor):
            return (torch.as_tensor(self.mean, dtype=motion.dtype, device=motion.device),
                    torch.as_tensor(self.std, dtype=motion.dtype, device=motion.device))
        return self.mean, self.std

    def __getitem__(self, index: int) -> dict[str, Any]:
        entry = self.entries[index]
        length = min(len(entry.motion), self.max_length) // UNIT_LENGTH * UNIT_LENGTH
        motion = entry.motion[:length]
        if self.normalise:
            motion = self.normalise_motion(motion)
        padded = np.zeros((self.max_length, FEATURE_DIM), dtype=np.float32)
        padded[:length] = motion
        draw = np.random.default_rng((self.seed, self.epoch, index)).integers(len(entry.captions))
        return {"motion": torch.from_numpy(padded), "length": length,
                "caption": entry.captions[draw], "captions": list(entry.captions),
                "labels": dict(entry.labels), "id": entry.id}


def cut_windows(dataset: MotionDataset, frames: int,
                stride: int) -> tuple[list[np.ndarray], list[list[str]], list[str]]:
    """Windows of ``frames`` frames every ``stride`` frames of each item of ``dataset`` (its
    first ``length`` frames; an item shorter than ``frames`` gives none): the windows, each
    window's captions (its item's) and ids ``"<item id>:<start>"``. The GMD notebooks' and the
    EnergyMoGen notebooks' windows of a data folder (``repro.motion.usability`` counts the
    same windows)."""
    pieces, captions, ids = [], [], []
    for index in range(len(dataset)):
        item = dataset[index]
        motion = item["motion"][:item["length"]].numpy()
        for start in range(0, len(motion) - frames + 1, stride):
            pieces.append(motion[start:start + frames])
            captions.append(list(item["captions"]))
            ids.append(f"{item['id']}:{start}")
    return pieces, captions, ids


def collate(batch: list[dict[str, Any]]) -> dict[str, Any]:
    """Stack motions (B, max_length, 263) and lengths (B,); keep the rest as lists (captions
    and labels differ in size between items, so ``default_collate`` cannot batch them)."""
    return {
        "motion": torch.stack([item["motion"] for item in batch]),
        "length": torch.tensor([item["length"] for item in batch], dtype=torch.long),
        "caption": [item["caption"] for item in batch],
        "captions": [item["captions"] for item in batch],
        "labels": [item["labels"] for item in batch],
        "id": [item["id"] for item in batch],
    }


# --------------------------------------------------------------------------------- validation

@dataclass(frozen=True)
class Problem:
    """One finding of :func:`validate_dataset`.

    ``kind`` is one of: missing, unreadable, shape, dtype, nan, statistics, text, labels,
    split (an ID in two splits), mismatch (features vs ``new_joints``), bones. ``severity`` is
    "error" or "warning"; the only warning is a float64 features file (it loads fine but is
    not HumanML3D's on-disk float32).
    """

    path: Path
    kind: str
    message: str
    severity: str = field(default="error")


def format_problems(problems: Sequence[Problem]) -> str:
    """One line per problem, errors first, with a count header."""
    if not problems:
        return "no problems found"
    errors = sum(p.severity == "error" for p in problems)
    lines = [f"{len(problems)} problems ({errors} errors, {len(problems) - errors} warnings)"]
    for p in sorted(problems, key=lambda p: (p.severity != "error", str(p.path), p.kind)):
        lines.append(f"  {p.severity:7s} {p.kind:10s} {p.path}: {p.message}")
    return "\n".join(lines)


def _unreadable(path: Path, error: ValueError) -> Problem:
    return Problem(path, "unreadable", str(error).removeprefix(f"{path} "))


def _validate_unlisted(root: Path, listed: set[str]) -> list[Problem]:
    """Features files no split lists (all of them when the split files are missing): each
    must still be a readable (T, 263) array, so that a damaged one is named whatever else
    is wrong with the folder."""
    problems = []
    folder = root / "new_joint_vecs"
    for path in sorted(folder.glob("*.npy")) if folder.is_dir() else []:
        if path.stem in listed:
            continue
        try:
            features = storage.read_npy(path)
        except ValueError as error:
            problems.append(_unreadable(path, error))
            continue
        if features.ndim != 2 or features.shape[1] != FEATURE_DIM:
            problems.append(Problem(path, "shape", f"expected (T, {FEATURE_DIM}), "
                                                   f"got {features.shape}"))
    return problems


def _validate_statistics(root: Path) -> list[Problem]:
    problems = []
    for name in ("Mean.npy", "Std.npy"):
        path = root / name
        if not path.is_file():
            problems.append(Problem(path, "missing", "statistics file not found"))
            continue
        try:
            array = storage.read_npy(path)
        except ValueError as error:
            problems.append(_unreadable(path, error))
            continue
        if array.shape != (FEATURE_DIM,):
            problems.append(Problem(path, "shape", f"expected ({FEATURE_DIM},), got {array.shape}"))
        elif not np.isfinite(array).all():
            problems.append(Problem(path, "nan", "contains NaN or inf"))
        elif name == "Std.npy" and (array <= 0).any():
            problems.append(Problem(path, "statistics", "std must be positive everywhere"))
    return problems


def _validate_texts(path: Path) -> list[Problem]:
    if not path.is_file():
        return [Problem(path, "missing", "text file of a listed clip not found")]
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        return [Problem(path, "text", f"not UTF-8 text: {error}")]
    problems, count = [], 0
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        count += 1
        try:
            parse_text_line(line)
        except ValueError as error:
            problems.append(Problem(path, "text", f"line {number}: {error}"))
    if count == 0:
        problems.append(Problem(path, "text", "no caption lines"))
    return problems


def _validate_joints(joints_path: Path | None, features_path: Path,
                     features: np.ndarray | None, frames: int) -> list[Problem]:
    """Bone lengths of ``new_joints`` (when ``joints_path`` exists) or of the joints recovered
    from ``features``; and the recovery against ``new_joints``."""
    joints = None
    if joints_path is not None and joints_path.is_file():
        try:
            joints = storage.read_npy(joints_path)
        except ValueError as error:
            return [_unreadable(joints_path, error)]
        if joints.shape != (frames, NUM_JOINTS, 3):
            return [Problem(joints_path, "shape", f"expected ({frames}, {NUM_JOINTS}, 3) to "
                                                  f"match the features, got {joints.shape}")]
        if not np.isfinite(joints).all():
            return [Problem(joints_path, "nan", "contains NaN or inf")]
    problems = []
    recovered = None if features is None else features_to_joints(features.astype(np.float64))
    if joints is not None and recovered is not None:
        error = float(np.abs(recovered - joints).max())
        if error > RECOVERY_TOLERANCE:
            problems.append(Problem(joints_path, "mismatch", f"features recover to joints "
                                    f"{error:.2e} m away (tolerance {RECOVERY_TOLERANCE:g} m)"))
    checked, where = (joints, joints_path) if joints is not None else (recovered, features_path)
    if checked is not None:
        lengths = bone_lengths(checked.astype(np.float64))
        spread = float((lengths.max(axis=0) - lengths.min(axis=0)).max())
        if spread > BONE_LENGTH_TOLERANCE:
            problems.append(Problem(where, "bones", f"bone lengths vary by {spread:.2e} m over "
                                    f"frames (tolerance {BONE_LENGTH_TOLERANCE:g} m)"))
    return problems


def _validate_clip(root: Path, clip: str, check_joints: bool) -> list[Problem]:
    path = root / "new_joint_vecs" / f"{clip}.npy"
    problems = _validate_texts(root / "texts" / f"{clip}.txt")
    labels = root / "labels" / f"{clip}.json"
    try:
        _read_labels(labels)
    except ValueError as error:
        problems.append(Problem(labels, "labels", str(error).removeprefix(f"{labels}: ")))
    if not path.is_file():
        return problems + [Problem(path, "missing", "features of a listed clip not found")]
    try:
        features = storage.read_npy(path)
    except ValueError as error:
        return problems + [_unreadable(path, error)]
    if features.ndim != 2 or features.shape[1] != FEATURE_DIM:
        return problems + [Problem(path, "shape", f"expected (T, {FEATURE_DIM}), "
                                                  f"got {features.shape}")]
    if features.dtype != np.float32:
        problems.append(Problem(path, "dtype", f"{features.dtype}, HumanML3D stores float32",
                                severity="warning" if features.dtype == np.float64 else "error"))
    finite = bool(np.isfinite(features).all())
    if not finite:
        problems.append(Problem(path, "nan", "contains NaN or inf (loaders skip this clip)"))
    joints_path = root / "new_joints" / f"{clip}.npy"
    if check_joints and not joints_path.is_file():
        problems.append(Problem(joints_path, "missing", "new_joints/ exists but lacks this clip"))
    if len(features) >= 2:
        problems += _validate_joints(joints_path if check_joints else None, path,
                                     features if finite else None, len(features))
    return problems


def validate_dataset(root: str | os.PathLike) -> list[Problem]:
    """Check a HumanML3D-layout folder; returns the problems found ([] for a clean folder).

    Checks: required folders/files (``new_joint_vecs/``, ``texts/``, ``Mean.npy``, ``Std.npy``,
    ``train/val/test.txt``); every listed ID has features and a text file; feature shapes
    (T, 263), dtype float32 (float64: warning), NaN/inf; text lines parse; labels are JSON
    objects; no ID in two splits; joints — ``new_joints/`` when present (shape (T, 22, 3),
    features recover to them within 1e-4 m), else recovered from the features — keep
    their bone lengths within 1e-3 m over frames; a features file no split lists (every one,
    when the split files are missing) must still be a readable (T, 263) array; the folder is
    usable (``motion.usability``: no split is empty, train and test keep a clip).
    """
    root = Path(root)
    if root.exists() and not root.is_dir():
        return [Problem(root, "missing", "is a file, not a folder: give the HumanML3D-layout "
                                         "folder that holds new_joint_vecs/ and texts/")]
    if not root.is_dir():
        return [Problem(root, "missing", "dataset folder not found")]
    problems = [Problem(root / name, "missing", "required folder not found")
                for name in ("new_joint_vecs", "texts") if not (root / name).is_dir()]
    problems += _validate_statistics(root)
    splits: dict[str, list[str]] = {}
    for split in SPLITS:
        try:
            splits[split] = read_split(root, split)
        except FileNotFoundError:
            problems.append(Problem(root / f"{split}.txt", "missing", "split file not found"))
    seen: dict[str, str] = {}
    for split, ids in splits.items():
        for clip in ids:
            if clip in seen and seen[clip] != split:
                problems.append(Problem(root / f"{split}.txt", "split",
                                        f"{clip} is also listed in {seen[clip]}.txt"))
            seen.setdefault(clip, split)
    check_joints = (root / "new_joints").is_dir()
    for clip in seen:
        problems += _validate_clip(root, clip, check_joints)
    problems += [Problem(path, "split", message) for path, message in usability_problems(root)]
    return problems + _validate_unlisted(root, set(seen))


def recover_joints(motion: np.ndarray | torch.Tensor,
                   representation: str = "relative") -> np.ndarray | torch.Tensor:
    """Joints (..., T, 22, 3) from unnormalised features in either representation."""
    if representation not in REPRESENTATIONS:
        raise ValueError(f"representation must be one of {REPRESENTATIONS}, got {representation!r}")
    if representation == "absolute":
        return absolute_features_to_joints(motion)
    return features_to_joints(motion)
