"""Loading and validating HumanML3D-layout folders built in tmp_path."""

from __future__ import annotations

import json
import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

from repro.infra.paths import humanml3d_sample_dir
from repro.motion import features as F
from repro.motion import humanml3d as D
from repro.motion import quaternion as Q
from repro.motion import skeleton as S


def _walk(frames: int, turn: float = 0.5, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Features (frames, 263) and joints (frames, 22, 3) of a swinging walk along a curve."""
    rng = np.random.default_rng(seed)
    t = torch.arange(frames + 1, dtype=torch.float64)
    yaw = turn * t / frames + float(rng.uniform(-3, 3))
    local = torch.zeros(frames + 1, 22, 4, dtype=torch.float64)
    local[..., 0] = 1.0
    local[:, 0] = Q.quat_about_y(yaw)
    swing = 0.4 * torch.sin(2 * math.pi * t / 20 + float(rng.uniform(0, 6)))
    x_axis = torch.tensor([1.0, 0.0, 0.0], dtype=torch.float64).expand(frames + 1, 3)
    local[:, 1] = Q.axis_angle_to_quat(x_axis, swing)
    local[:, 2] = Q.axis_angle_to_quat(x_axis, -swing)
    step = 0.05 * torch.stack((torch.sin(yaw), 0 * t, torch.cos(yaw)), dim=-1)
    root = torch.cumsum(step, dim=0) + torch.tensor([0.0, 0.93, 0.0], dtype=torch.float64)
    features, joints = F.joints_to_features(S.forward_kinematics(root, local).numpy())
    return features, joints


def _text(*lines: str) -> str:
    return "\n".join(lines) + "\n"


WALK = "a person walks forward#a/DET person/NOUN walk/VERB forward/ADV#0.0#0.0"
TURN = "someone turns while walking#someone/PRON turn/VERB while/SCONJ walk/VERB#0.0#0.0"


def write_dataset(root: Path, clips: dict[str, int], *, splits: dict[str, list[str]] | None = None,
                  texts: dict[str, str] | None = None, labels: dict[str, dict] | None = None,
                  joints: bool = True) -> dict[str, np.ndarray]:
    """A HumanML3D-layout folder with synthetic walks of the given frame counts."""
    features = {}
    for index, (clip, frames) in enumerate(clips.items()):
        features[clip], clip_joints = _walk(frames, seed=index)
        (root / "new_joint_vecs").mkdir(parents=True, exist_ok=True)
        np.save(root / "new_joint_vecs" / f"{clip}.npy", features[clip])
        if joints:
            (root / "new_joints").mkdir(exist_ok=True)
            np.save(root / "new_joints" / f"{clip}.npy", clip_joints)
        (root / "texts").mkdir(exist_ok=True)
        text = (texts or {}).get(clip, _text(WALK, TURN))
        (root / "texts" / f"{clip}.txt").write_text(text, encoding="utf-8")
        if labels and clip in labels:
            (root / "labels").mkdir(exist_ok=True)
            (root / "labels" / f"{clip}.json").write_text(json.dumps(labels[clip]))
    mean, std = D.compute_statistics(list(features.values()))
    np.save(root / "Mean.npy", mean)
    np.save(root / "Std.npy", std)
    ids = list(clips)
    splits = splits or {"train": ids[:-2], "val": ids[-2:-1], "test": ids[-1:]}
    for split, split_ids in splits.items():
        (root / f"{split}.txt").write_text("\n".join(split_ids) + "\n")
    return features


@pytest.fixture()
def dataset_dir(tmp_path: Path) -> tuple[Path, dict[str, np.ndarray]]:
    root = tmp_path / "hml"
    clips = {"000001": 120, "000002": 199, "000003": 30, "000004": 63, "000005": 90,
             "000006": 41}
    splits = {"train": ["000001", "000002", "000003", "000004"], "val": ["000005"],
              "test": ["000006"]}
    features = write_dataset(root, clips, splits=splits,
                             labels={"000001": {"concepts": ["walk"], "speed": 1.2}})
    return root, features


@pytest.fixture(autouse=True)
def private_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


# ---------------------------------------------------------------------------------- loading

def test_items_are_cropped_padded_and_normalised(dataset_dir) -> None:
    root, features = dataset_dir
    dataset = D.MotionDataset(root, "train")
    assert [entry.id for entry in dataset.entries] == ["000001", "000002", "000004"]
    assert dataset.skipped["length"] == ["000003"]
    lengths = {}
    for index in range(len(dataset)):
        item = dataset[index]
        assert set(item) == {"motion", "length", "caption", "captions", "labels", "id"}
        motion, length = item["motion"], item["length"]
        assert motion.shape == (196, 263) and motion.dtype == torch.float32
        assert length % 4 == 0 and torch.all(motion[length:] == 0)
        restored = dataset.denormalise(motion[:length]).numpy()
        assert np.abs(restored - features[item["id"]][:length]).max() <= 1e-5
        lengths[item["id"]] = length
    assert lengths == {"000001": 120, "000002": 196, "000004": 60}


def test_normalisation_uses_folder_statistics(dataset_dir) -> None:
    root, features = dataset_dir
    item = D.MotionDataset(root, "train")[0]
    mean, std = np.load(root / "Mean.npy"), np.load(root / "Std.npy")
    expected = (features["000001"][:120] - mean) / std
    assert np.abs(item["motion"][:120].numpy() - expected).max() <= 1e-5
    raw = D.MotionDataset(root, "train", normalise=False)[0]
    assert np.abs(raw["motion"][:120].numpy() - features["000001"][:120]).max() == 0


def test_captions_labels_and_deterministic_draw(dataset_dir) -> None:
    root, _ = dataset_dir
    dataset = D.MotionDataset(root, "train", seed=3)
    item = dataset[0]
    assert item["captions"] == ["a person walks forward", "someone turns while walking"]
    assert item["labels"] == {"concepts": ["walk"], "speed": 1.2}
    assert dataset[1]["labels"] == {}
    assert dataset[0]["caption"] == D.MotionDataset(root, "train", seed=3)[0]["caption"]
    drawn = set()
    for epoch in range(20):
        dataset.set_epoch(epoch)
        drawn.add(dataset[0]["caption"])
    assert drawn == set(item["captions"])


def test_sub_range_captions_become_items(tmp_path: Path) -> None:
    texts = {"000001": _text(WALK, "a person turns#a/DET person/NOUN turn/VERB#0.5#3.0",
                             "it turns left#it/PRON turn/VERB left/ADV#0.5#3.0",
                             "too short#too/ADV short/ADJ#1.0#2.0")}
    write_dataset(tmp_path, {"000001": 150, "000002": 80, "000003": 80}, texts=texts)
    dataset = D.MotionDataset(tmp_path, "train", normalise=False)
    ids = [entry.id for entry in dataset.entries]
    assert ids == ["000001", "000001@10-60"]
    item = dataset[1]
    assert item["captions"] == ["a person turns", "it turns left"] and item["length"] == 48
    whole = np.load(tmp_path / "new_joint_vecs" / "000001.npy")
    assert np.array_equal(item["motion"][:48].numpy(), whole[10:58])
    assert dataset.skipped["length"] == ["000001@20-40"]


def test_collate_with_dataloader(dataset_dir) -> None:
    root, _ = dataset_dir
    loader = DataLoader(D.MotionDataset(root, "train"), batch_size=2, collate_fn=D.collate)
    batch = next(iter(loader))
    assert batch["motion"].shape == (2, 196, 263)
    assert batch["length"].tolist() == [120, 196]
    assert batch["id"] == ["000001", "000002"] and len(batch["captions"][0]) == 2


def test_max_length_crops(dataset_dir) -> None:
    root, _ = dataset_dir
    dataset = D.MotionDataset(root, "train", max_length=50)
    assert dataset[0]["motion"].shape == (50, 263) and dataset[0]["length"] == 48


# --------------------------------------------------------------------------- absolute root

def test_absolute_representation(dataset_dir, private_cache: Path) -> None:
    root, features = dataset_dir
    dataset = D.MotionDataset(root, "train", representation="absolute")
    item = dataset[0]
    expected = F.relative_to_absolute_root(features["000001"].astype(np.float64))[:120]
    assert np.abs(dataset.denormalise(item["motion"][:120]).numpy() - expected).max() <= 1e-4
    kept = [F.relative_to_absolute_root(features[i].astype(np.float64))
            for i in ("000001", "000002", "000004")]
    mean, std = D.compute_statistics(kept)
    assert np.allclose(dataset.mean, mean, atol=1e-6) and np.allclose(dataset.std, std, atol=1e-6)
    assert not np.allclose(dataset.mean, np.load(root / "Mean.npy"))
    cached = list(private_cache.glob("statistics/*/std.npy"))
    assert len(cached) == 1
    # val uses the train split's absolute statistics (read back from the cache)
    val = D.MotionDataset(root, "val", representation="absolute")
    assert np.array_equal(val.mean, dataset.mean) and np.array_equal(val.std, dataset.std)
    joints = D.recover_joints(dataset.denormalise(item["motion"][:120]), "absolute")
    assert torch.allclose(joints, torch.from_numpy(F.features_to_joints(features["000001"][:120])),
                          atol=1e-4)


def test_statistics_block_averaged() -> None:
    motions = [np.random.default_rng(0).normal(size=(50, 263)) * np.arange(1, 264)]
    mean, std = D.compute_statistics(motions)
    for block in F.FEATURE_BLOCKS.values():
        assert np.ptp(std[block]) == 0
    constant = D.compute_statistics([np.zeros((10, 263))])[1]
    assert np.all(constant == 1.0)



def test_block_averaged_std_is_each_blocks_mean() -> None:
    std = np.random.default_rng(1).uniform(0.5, 2.0, 263).astype(np.float32)
    std[F.FEATURE_BLOCKS["foot_contact"]] = 0.0
    kept = std.copy()
    out = D.block_averaged_std(std)
    assert out.dtype == np.float64 and np.array_equal(std, kept)       # input untouched
    for name, block in F.FEATURE_BLOCKS.items():
        expected = 1.0 if name == "foot_contact" else std[block].astype(np.float64).mean()
        assert np.all(out[block] == expected), name

@pytest.mark.real_sample
def test_real_std_is_block_averaged() -> None:
    root = humanml3d_sample_dir()
    if not root.is_dir():
        pytest.skip(f"real HumanML3D sample not found at {root}")
    mean, std = D.load_statistics(root)
    for name, block in F.FEATURE_BLOCKS.items():
        assert np.ptp(std[block]) <= 1e-6 * std[block].max(), name


# ------------------------------------------------------------------------------ load errors

def test_nan_clips_are_skipped_with_warning(dataset_dir) -> None:
    root, features = dataset_dir
    broken = features["000002"].copy()
    broken[5, 7] = np.nan
    np.save(root / "new_joint_vecs" / "000002.npy", broken)
    with pytest.warns(UserWarning, match="NaN.*000002"):
        dataset = D.MotionDataset(root, "train")
    assert dataset.skipped["nan"] == ["000002"] and len(dataset) == 2


def test_missing_folder_and_split(tmp_path: Path, dataset_dir) -> None:
    with pytest.raises(FileNotFoundError, match="dataset folder .*nowhere"):
        D.MotionDataset(tmp_path / "nowhere")
    root, _ = dataset_dir
    with pytest.raises(FileNotFoundError, match="split file .*holdout.txt"):
        D.MotionDataset(root, "holdout")
    (root / "empty.txt").write_text("\n")
    with pytest.raises(ValueError, match="empty.txt lists no clips"):
        D.MotionDataset(root, "empty")


def test_missing_listed_files(dataset_dir) -> None:
    root, _ = dataset_dir
    (root / "new_joint_vecs" / "000004.npy").unlink()
    (root / "texts" / "000001.txt").unlink()
    with pytest.raises(FileNotFoundError, match="2 files listed in train.txt are missing"):
        D.MotionDataset(root, "train")


def test_wrong_feature_dimension(dataset_dir) -> None:
    root, features = dataset_dir
    np.save(root / "new_joint_vecs" / "000004.npy", features["000004"][:, :251])
    with pytest.raises(ValueError, match=r"000004.npy.*\(T, 263\).*\(63, 251\)"):
        D.MotionDataset(root, "train")


def test_bad_arguments_and_statistics(dataset_dir) -> None:
    root, _ = dataset_dir
    with pytest.raises(ValueError, match="representation"):
        D.MotionDataset(root, representation="global")
    with pytest.raises(ValueError, match="std must be positive"):
        D.MotionDataset(root, statistics=(np.zeros(263), np.zeros(263)))
    with pytest.raises(ValueError, match="mean must have shape"):
        D.MotionDataset(root, statistics=(np.zeros(251), np.ones(263)))
    with pytest.raises(ValueError, match="no clip"):
        D.MotionDataset(root, "train", min_length=200)


def test_bad_text_line_raises_on_load(dataset_dir) -> None:
    root, _ = dataset_dir
    (root / "texts" / "000004.txt").write_text(_text(WALK, "no fields here"))
    with pytest.raises(ValueError, match="000004.txt, line 2: expected 4"):
        D.MotionDataset(root, "train")


@pytest.mark.parametrize("line, message", [
    ("walk#walk/VERB#0.0", "4 '#'-separated"),
    (" #walk/VERB#0.0#0.0", "empty caption"),
    ("walk#walk#0.0#0.0", "word/POS"),
    ("walk#walk/VERB#zero#0.0", "numbers"),
    ("walk#walk/VERB#2.0#1.0", "time range"),
])
def test_parse_text_line_errors(line: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        D.parse_text_line(line)


def test_parse_text_line_nan_times_mean_whole_clip() -> None:
    line = D.parse_text_line("a man jumps#a/DET man/NOUN jump/VERB#nan#nan")
    assert line.whole_clip and line.tokens == ("a/DET", "man/NOUN", "jump/VERB")


# -------------------------------------------------------------------------------- validator

def _kinds(problems: list[D.Problem]) -> set[tuple[str, str]]:
    return {(p.path.name, p.kind) for p in problems}


def test_clean_folder_validates(dataset_dir) -> None:
    root, _ = dataset_dir
    assert D.validate_dataset(root) == []
    assert D.format_problems([]) == "no problems found"


def test_validator_names_each_problem(dataset_dir) -> None:
    root, features = dataset_dir
    broken = features["000002"].copy()
    broken[3, 0] = np.nan
    np.save(root / "new_joint_vecs" / "000002.npy", broken)
    np.save(root / "new_joint_vecs" / "000004.npy", features["000004"][:, :262])
    joints = np.load(root / "new_joints" / "000005.npy")
    joints[10, 15] += 0.01
    np.save(root / "new_joints" / "000005.npy", joints)
    (root / "texts" / "000001.txt").write_text(_text(WALK, "bad line#x/NOUN"))
    (root / "train.txt").write_text("000001\n000002\n000004\n000009\n000005\n")
    (root / "Std.npy").unlink()
    problems = D.validate_dataset(root)
    assert _kinds(problems) == {
        ("000002.npy", "nan"), ("000004.npy", "shape"), ("000005.npy", "mismatch"),
        ("000005.npy", "bones"), ("000001.txt", "text"), ("000009.npy", "missing"),
        ("000009.txt", "missing"), ("Std.npy", "missing"), ("val.txt", "split"),
    }
    assert any("line 2" in p.message for p in problems if p.kind == "text")
    report = D.format_problems(problems)
    assert report.startswith(f"{len(problems)} problems ({len(problems)} errors, 0 warnings)")
    assert "000009.npy" in report


def test_validator_missing_folder_and_splits(tmp_path: Path) -> None:
    problems = D.validate_dataset(tmp_path / "absent")
    assert [(p.kind, p.path.name) for p in problems] == [("missing", "absent")]
    (tmp_path / "empty").mkdir()
    names = {p.path.name for p in D.validate_dataset(tmp_path / "empty")}
    assert names == {"new_joint_vecs", "texts", "Mean.npy", "Std.npy", "train.txt", "val.txt",
                     "test.txt"}


def test_validator_float64_is_a_warning_and_bones_without_joints(tmp_path: Path) -> None:
    features = write_dataset(tmp_path, {"000001": 60, "000002": 70, "000003": 50}, joints=False)
    np.save(tmp_path / "new_joint_vecs" / "000001.npy", features["000001"].astype(np.float64))
    stretched = features["000002"].copy()
    stretched[20:, 4:67] *= 1.2  # body positions scaled mid-clip: bone lengths change
    np.save(tmp_path / "new_joint_vecs" / "000002.npy", stretched)
    problems = D.validate_dataset(tmp_path)
    assert {(p.path.name, p.kind, p.severity) for p in problems} == {
        ("000001.npy", "dtype", "warning"), ("000002.npy", "bones", "error")}
    assert "1 warnings" in D.format_problems(problems)


def test_validator_labels_unreadable_and_missing_joint_file(dataset_dir) -> None:
    root, _ = dataset_dir
    (root / "labels" / "000001.json").write_text("[1, 2]")
    (root / "labels" / "000002.json").write_text("{concepts: walk")
    (root / "new_joints" / "000004.npy").unlink()
    (root / "new_joint_vecs" / "000005.npy").write_bytes(b"not an npy file")
    problems = D.validate_dataset(root)
    assert {(p.path.parent.name, p.path.name, p.kind) for p in problems} == {
        ("labels", "000001.json", "labels"), ("labels", "000002.json", "labels"),
        ("new_joints", "000004.npy", "missing"), ("new_joint_vecs", "000005.npy", "unreadable")}
    with pytest.raises(ValueError, match="000001.json: labels must be a JSON object, got list"):
        D.MotionDataset(root, "train")


@pytest.mark.real_sample
def test_real_clips_validate_and_load(tmp_path: Path) -> None:
    sample = humanml3d_sample_dir()
    if not sample.is_dir():
        pytest.skip(f"real HumanML3D sample not found at {sample}")
    for folder in ("new_joint_vecs", "new_joints", "texts"):
        (tmp_path / folder).mkdir()
    for name in ("Mean.npy", "Std.npy", "new_joint_vecs/012314.npy", "new_joints/012314.npy"):
        shutil.copy(sample / name, tmp_path / name)
    shutil.copy(sample / "extra" / "000612.npy", tmp_path / "new_joint_vecs" / "000612.npy")
    for clip in ("012314", "000612"):
        (tmp_path / "texts" / f"{clip}.txt").write_text(_text(WALK))
    (tmp_path / "train.txt").write_text("012314\n")
    (tmp_path / "val.txt").write_text("")   # no notebook reads val; an empty test is refused
    (tmp_path / "test.txt").write_text("000612\n")
    problems = D.validate_dataset(tmp_path)  # 000612 comes without new_joints
    assert {(p.path.parent.name, p.kind) for p in problems} == {("new_joint_vecs", "dtype"),
                                                                ("new_joints", "missing")}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        val = D.MotionDataset(tmp_path, "test")
    assert val[0]["length"] == 196 and val[0]["motion"].dtype == torch.float32
    (tmp_path / "test.txt").write_text("")   # an empty split list must not pass
    assert ("test.txt", "split") in {(p.path.name, p.kind) for p in D.validate_dataset(tmp_path)}
