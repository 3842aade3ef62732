"""Stand-in datasets on disk: HumanML3D's layout, splits, statistics, the cache."""

from __future__ import annotations

import re

import numpy as np
import pytest

from repro.infra import storage
from repro.motion.features import FEATURE_BLOCKS, FEATURE_DIM
from repro.standin import dataset as d

TEXT_LINE = re.compile(r"^([^#]+)#((?:[a-z]+/[A-Z]+ ?)+)#0\.0#0\.0$")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("stand_in")
    return d.write_dataset(out, n_clips=14, seed=9)


def test_write_dataset_layout(dataset) -> None:
    ids = sorted(p.stem for p in (dataset / "new_joint_vecs").glob("*.npy"))
    assert ids == [f"{i:06d}" for i in range(14)]
    for clip_id in ids:
        features = np.load(dataset / "new_joint_vecs" / f"{clip_id}.npy")
        joints = np.load(dataset / "new_joints" / f"{clip_id}.npy")
        assert features.dtype == joints.dtype == np.float32
        assert features.shape[1] == FEATURE_DIM and joints.shape[1:] == (22, 3)
        assert len(features) == len(joints) and 40 <= len(features) < 200
        lines = (dataset / "texts" / f"{clip_id}.txt").read_text().splitlines()
        assert len(lines) == 3 and all(TEXT_LINE.match(line) for line in lines)
        labels = storage.read_json(dataset / "labels" / f"{clip_id}.json")
        assert labels["id"] == clip_id and labels["n_frames"] == len(features) + 1
        assert {"concepts", "composition", "segments", "body_parts", "params"} <= set(labels)
    mean, std = np.load(dataset / "Mean.npy"), np.load(dataset / "Std.npy")
    assert mean.shape == std.shape == (FEATURE_DIM,) and std.dtype == np.float32
    for block in FEATURE_BLOCKS.values():
        assert np.ptp(std[block]) == 0 and std[block][0] > 0     # one value per block
    assert (dataset / d.DATASET_MARKER).exists()


def test_splits_are_disjoint_and_cover_every_id(dataset) -> None:
    splits = {name: (dataset / f"{name}.txt").read_text().split() for name in d.SPLITS}
    every = [i for ids in splits.values() for i in ids]
    assert len(every) == len(set(every)) == 14
    assert len(splits["train"]) == round(0.8 * 14)


def test_write_dataset_is_deterministic(dataset, tmp_path) -> None:
    again = d.write_dataset(tmp_path / "again", n_clips=14, seed=9)
    for path in sorted(dataset.rglob("*")):
        if path.is_file():
            assert (again / path.relative_to(dataset)).read_bytes() == path.read_bytes(), path


def test_held_out_pairs_go_to_test(tmp_path) -> None:
    out = d.write_dataset(tmp_path, n_clips=12, seed=1, compositions={"simultaneous": 1.0},
                          concept_pool=("walk_forward", "jump", "wave_right"),
                          held_out_pairs=[("walk_forward", "wave_right")])
    test = set((out / "test.txt").read_text().split())
    held = 0
    for path in (out / "labels").glob("*.json"):
        labels = storage.read_json(path)
        pair = set(labels["concepts"]) == {"walk_forward", "wave_right"}
        assert labels["held_out"] == pair
        held += pair
        if pair:
            assert path.stem in test
    assert held > 0


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"n_clips": 0}, "n_clips must be a positive integer"),
    ({"split_fractions": (0.5, 0.1, 0.1)}, "summing to 1"),
    ({"compositions": {"parallel": 1.0}}, "unknown composition 'parallel'"),
    ({"held_out_pairs": [("jump", "hover")]}, "unknown concept 'hover'"),
])
def test_write_dataset_rejects_bad_options(tmp_path, kwargs, message) -> None:
    options = {"n_clips": 3, "seed": 0, **kwargs}
    with pytest.raises(ValueError, match=message):
        d.write_dataset(tmp_path, **options)


def test_ensure_dataset_generates_once_then_reuses(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    config = d.DatasetConfig(n_clips=5, seed=2)
    first = d.ensure_dataset(config)
    assert first.parent == tmp_path / "datasets" and (first / d.DATASET_MARKER).exists()
    stamp = (first / "new_joint_vecs" / "000000.npy").stat().st_mtime_ns
    assert d.ensure_dataset(config) == first
    assert (first / "new_joint_vecs" / "000000.npy").stat().st_mtime_ns == stamp
    assert d.ensure_dataset(d.DatasetConfig(n_clips=5, seed=3)) != first
    (first / d.DATASET_MARKER).unlink()                        # an interrupted generation
    assert d.ensure_dataset(config) == first
    assert (first / "new_joint_vecs" / "000000.npy").stat().st_mtime_ns != stamp


def test_read_clip_gives_back_what_was_written(dataset) -> None:
    assert d.clip_ids(dataset) == [f"{i:06d}" for i in range(14)]
    clip = d.read_clip(dataset, "000003")
    assert np.array_equal(clip.joints, np.load(dataset / "new_joints" / "000003.npy"))
    assert clip.labels == storage.read_json(dataset / "labels" / "000003.json")
    lines = (dataset / "texts" / "000003.txt").read_text().splitlines()
    assert clip.captions == tuple(line.split("#")[0] for line in lines) and len(lines) == 3


def test_clips_are_listed_from_the_features_and_need_no_new_joints(dataset, tmp_path) -> None:
    import shutil

    copy = shutil.copytree(dataset, tmp_path / "copy")
    shutil.rmtree(copy / "new_joints")
    assert d.clip_ids(copy) == d.clip_ids(dataset)
    recovered = d.clip_joints(copy, "000003")
    assert np.abs(recovered - np.load(dataset / "new_joints" / "000003.npy")).max() < 1e-4
