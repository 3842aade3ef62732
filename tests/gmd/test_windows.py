"""Windows of tiny GMD: shape, normalisation, representations, statistics, stand-in data."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from repro.gmd.windows import DataConfig, load_windows
from repro.motion.features import features_to_joints, relative_to_absolute_root
from repro.motion.humanml3d import MotionDataset

FRAMES = 16  # = conftest.FRAMES: the windows of the small_config fixture


def test_windows_shape_normalisation_and_round_trip(small_config, dataset_dir: Path) -> None:
    windows = load_windows(small_config())
    assert windows.x.dtype == torch.float32 and windows.x.shape[1:] == (263, FRAMES)
    # normalised with the training windows' own mean: every channel averages to 0
    assert windows.x.mean(dim=(0, 2)).abs().max() < 1e-4
    # un-normalising gives the absolute-root features of the raw window, each from the origin
    clip = MotionDataset(dataset_dir, "train", normalise=False)[0]
    raw = clip["motion"][:FRAMES].double()
    expected = relative_to_absolute_root(raw).float()
    assert windows.ids[0] == f"{clip['id']}:0"
    np.testing.assert_allclose(windows.features()[0].numpy(), expected.numpy(), atol=2e-5)
    again = windows.space("motion").normalise(windows.features()[:3])
    np.testing.assert_allclose(again.numpy(), windows.x[:3].numpy(), atol=1e-4)


def test_trajectory_view_is_angle_x_z_y_of_the_root(small_config, dataset_dir: Path) -> None:
    windows = load_windows(small_config())
    view = windows.trajectory()
    assert view.shape[1] == 4 and torch.equal(view, windows.x[:, 0:4])
    clip = MotionDataset(dataset_dir, "train", normalise=False)[0]
    root = features_to_joints(clip["motion"][:FRAMES].double())[:, 0]   # (T, 3) world root
    positions = windows.space("trajectory").root_positions(view[:1])[0]
    np.testing.assert_allclose(positions.numpy(), root.numpy(), atol=2e-5)
    # the relative representation recovers the same root path through recover_root
    relative = load_windows(small_config("relative"))
    rel_positions = relative.space("trajectory").root_positions(relative.trajectory()[:1])[0]
    np.testing.assert_allclose(rel_positions.numpy(), root.numpy(), atol=2e-5)


def test_other_splits_use_the_training_statistics(small_config) -> None:
    train = load_windows(small_config())
    test = load_windows(small_config(), "test", statistics=(train.mean, train.std))
    assert np.array_equal(test.mean, train.mean) and test.split == "test"


def test_max_windows_cuts_only_the_training_split(small_config, dataset_dir: Path) -> None:
    full = load_windows(small_config())
    config = DataConfig(data_dir=str(dataset_dir), frames=FRAMES, stride=8, max_windows=5)
    cut = load_windows(config)
    assert len(cut) == 5 < len(full) and set(cut.ids) <= set(full.ids)
    assert "max_windows" not in small_config().as_dict()
    assert cut.fingerprint != full.fingerprint


def test_stand_in_data_is_generated_when_no_folder_is_given(small_config, cache: Path) -> None:
    config = DataConfig(stand_in_clips=8, stand_in_seed=1, frames=FRAMES, stride=8)
    windows = load_windows(config)
    assert str(windows.root).startswith(str(cache)) and len(windows) > 0


def test_short_labels_derive_from_the_one_definition() -> None:
    from repro.gmd.windows import REPRESENTATIONS, short_label
    from repro.motion import humanml3d

    assert REPRESENTATIONS is humanml3d.REPRESENTATIONS
    assert [short_label(r) for r in REPRESENTATIONS] == ["rel", "abs"]
    with pytest.raises(ValueError, match="representation"):
        short_label("rel")


def test_a_path_data_dir_is_kept_as_its_string(tmp_path: Path) -> None:
    """A run context's ``data_dir`` (a Path) makes the config, and so the cache key, of its
    string (notebooks pass ``ctx.data_dir``)."""
    from_path = DataConfig(data_dir=tmp_path, frames=16)
    from_text = DataConfig(data_dir=str(tmp_path), frames=16)
    assert from_path == from_text and isinstance(from_path.data_dir, str)
    assert from_path.as_dict() == from_text.as_dict()
    assert DataConfig(data_dir=None).data_dir is None


def test_a_stand_in_concept_pool_generates_only_those_concepts(cache: Path) -> None:
    """``stand_in_concepts``/``stand_in_compositions`` choose the generated set (GMD's default:
    the locomotion pool): every clip's labels come from the pool, the key names them only when
    they are set (None: the whole catalogue, the key as before the option), and a name outside
    the catalogue is refused before anything is generated."""
    import json

    from repro.gmd.windows import LOCOMOTION_COMPOSITIONS, LOCOMOTION_CONCEPTS

    loco = DataConfig(stand_in_clips=12, stand_in_seed=3, frames=FRAMES, stride=8)
    assert (loco.stand_in_concepts, loco.stand_in_compositions) == (   # GMD's default pool
        LOCOMOTION_CONCEPTS, LOCOMOTION_COMPOSITIONS)
    plain = dataclasses.replace(loco, stand_in_concepts=None, stand_in_compositions=None)
    assert "stand_in_concepts" not in plain.as_dict()
    assert loco.as_dict()["stand_in_concepts"] == list(LOCOMOTION_CONCEPTS)
    root = loco.dataset_root()
    assert root != plain.dataset_root()
    labels = [json.loads(p.read_text()) for p in sorted((root / "labels").glob("*.json"))]
    assert labels and all(set(lab["concepts"]) <= set(LOCOMOTION_CONCEPTS) for lab in labels)
    assert {lab["composition"] for lab in labels} <= {"single", "sequential"}
    with pytest.raises(ValueError, match="wave_hello"):
        DataConfig(stand_in_concepts=("wave_hello",))
    with pytest.raises(ValueError, match="parallel"):
        DataConfig(stand_in_compositions=(("parallel", 1.0),))
    with_folder = DataConfig(data_dir="/tmp", stand_in_concepts=LOCOMOTION_CONCEPTS)
    assert "stand_in_concepts" not in with_folder.as_dict()
