"""Notebook 00's library: settings, the clips shown, and the tables it renders."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

from repro.infra.paths import data_stubs_dir
from repro.motion.features import FEATURE_BLOCKS, FEATURE_DIM, Conformance
from repro.standin import figures
from repro.standin.cooccurrence import caption_co_occurrence
from repro.standin.dataset import DatasetConfig, read_clip


def test_settings_for_each_scale() -> None:
    quick, standard, paper = (figures.Settings.for_scale(s) for s in ("quick", "standard", "paper"))
    assert quick.n_clips < standard.n_clips and quick.shown_concepts <= standard.shown_concepts
    assert standard.dataset(3) == paper.dataset(3) == DatasetConfig(n_clips=standard.n_clips,
                                                                    seed=3)
    with pytest.raises(ValueError, match="scale must be one of"):
        figures.Settings.for_scale("full")


def test_shown_clips_are_single_concept_examples_in_order_of_appearance() -> None:
    shown, n_examples = figures.shown_clips(data_stubs_dir(), 5)
    assert len(shown) == 5 and n_examples >= 5
    concepts = [clip.labels["concepts"] for clip in shown]
    assert all(len(c) == 1 for c in concepts) and len({c[0] for c in concepts}) == 5
    assert all(clip.labels["composition"] == "single" for clip in shown)
    assert [clip.clip_id for clip in shown] == sorted(clip.clip_id for clip in shown)


def test_a_folder_without_labels_shows_its_first_clips(tmp_path) -> None:
    stubs = data_stubs_dir()
    for clip_id in ("000000", "000001", "000002"):
        for folder, suffix in (("new_joint_vecs", "npy"), ("new_joints", "npy"),
                               ("texts", "txt")):
            (tmp_path / folder).mkdir(exist_ok=True)
            (tmp_path / folder / f"{clip_id}.{suffix}").write_bytes(
                (stubs / folder / f"{clip_id}.{suffix}").read_bytes())
    shown, n_examples = figures.shown_clips(tmp_path, 2)
    assert n_examples == 0 and [c.clip_id for c in shown] == ["000000", "000001"]
    assert figures.first_composed_clip(tmp_path) is None
    fig = figures.concept_filmstrips(shown, frames=3)
    assert "unlabelled (000000)" in fig.axes[0].get_title()
    plt.close(fig)


def test_a_folder_without_new_joints_shows_clips_from_its_features(tmp_path) -> None:
    """``new_joints/`` is optional in HumanML3D's layout: the clips come from the features
    and their joints are recovered from them (notebook 00 on such a folder)."""
    stubs = data_stubs_dir()
    for clip_id in ("000000", "000001"):
        for folder, suffix in (("new_joint_vecs", "npy"), ("texts", "txt")):
            (tmp_path / folder).mkdir(exist_ok=True)
            (tmp_path / folder / f"{clip_id}.{suffix}").write_bytes(
                (stubs / folder / f"{clip_id}.{suffix}").read_bytes())
    shown, _ = figures.shown_clips(tmp_path, 2)
    assert [c.clip_id for c in shown] == ["000000", "000001"]
    stored = np.load(stubs / "new_joints" / "000000.npy")
    assert shown[0].joints.shape == stored.shape and shown[0].joints.dtype == np.float32
    assert np.abs(shown[0].joints - stored).max() < 1e-4
    plt.close(figures.concept_filmstrips(shown, frames=3))


def test_first_composed_clip_and_the_figures() -> None:
    clip = figures.first_composed_clip(data_stubs_dir())
    assert clip is not None and clip.labels["composition"] in ("simultaneous", "sequential")
    single = read_clip(data_stubs_dir(), "000000")
    fig = figures.concept_filmstrips([clip, single], frames=4)
    assert len(fig.axes) == 2 and clip.captions[0] in fig.axes[0].get_title()
    plt.close(fig)
    fig = figures.root_paths([clip, single])
    assert len(fig.axes[0].get_lines()) == 6                 # a path, a start and an end each
    plt.close(fig)
    with pytest.raises(ValueError, match="no clips"):
        figures.concept_filmstrips([])


def test_block_std_rows_divide_block_by_block() -> None:
    std, reference = np.ones(FEATURE_DIM), np.full(FEATURE_DIM, 4.0)
    std[FEATURE_BLOCKS["rot_6d"]] = 2.0
    rows = {name: rest for name, *rest in figures.block_std_rows(std, reference)}
    assert list(rows) == list(FEATURE_BLOCKS)
    assert rows["rot_6d"] == [2.0, 4.0, 0.5] and rows["root_y"] == [1.0, 4.0, 0.25]


def test_agreement_tables_show_missing_values_as_a_dash() -> None:
    agreement = {
        "per_concept": {"jump": {"support": 3, "precision": 0.5, "recall": None}},
        "by_composition": {"single": {"units": 3, "exact_match": 1.0,
                                      "all_truth_detected": 0.666}},
    }
    concepts, compositions = figures.agreement_tables(agreement)
    assert concepts.splitlines()[-1] == "| jump | 3 | 0.50 | — |"
    assert compositions.splitlines()[-1] == "| single | 3 | 1.00 | 0.67 |"


def test_conformance_table_names_the_exact_frames() -> None:
    result = Conformance(joint_error=1e-7, exact_frames=89,
                         block_errors={"rot_6d": (1.3e-2, 7.7e-6)})
    lines = figures.conformance_table(result).splitlines()
    assert lines[0] == "| block | max error, all frames | frames 0–88 |"
    assert lines[-1] == "| rot_6d | 1.3e-02 | 7.7e-06 |"


def test_co_occurrence_heatmap_and_its_reading() -> None:
    labels = [{"concepts": ["walk_forward", "clap"],
               "caption_concepts": [["walk_forward"], ["walk_forward", "clap"], ["clap"]]},
              {"concepts": ["walk_forward"], "caption_concepts": [["walk_forward"]] * 3}]
    table = caption_co_occurrence(labels, ["walk_forward", "clap"])
    fig = figures.co_occurrence_heatmap(table)
    assert len(fig.axes) == 2                                   # the map and its colour bar
    text = figures.co_occurrence_reading(table, 2 / 3, 0.5)
    assert "62% on average" in text and "least walk_forward at 25%" in text
    assert "most clap at 100%" in text and "66.7%" in text and "50%" in text
    empty = caption_co_occurrence([], ["clap"])
    assert figures.co_occurrence_reading(empty, None, 0.5).startswith("No caption")
