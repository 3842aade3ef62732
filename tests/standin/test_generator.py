"""The procedural stand-in generator: determinism, physical consistency, layout on disk."""

from __future__ import annotations

import re

import numpy as np
import pytest

from repro.motion.features import FEATURE_BLOCKS, FEATURE_DIM
from repro.motion.skeleton import BONE_LENGTHS, bone_lengths
from repro.standin import generator as g

UPOS = {"NOUN", "VERB", "ADJ", "ADV", "ADP", "DET", "PRON", "CCONJ", "SCONJ", "NUM", "PART",
        "INTJ"}
TEXT_LINE = re.compile(r"^([^#]+)#((?:[a-z]+/[A-Z]+ ?)+)#0\.0#0\.0$")
LOCOMOTION = ("walk_forward", "walk_backward", "walk_left", "walk_right", "run", "turn_left",
              "turn_right", "walk_circle")


def single(name: str, duration: float | None = None, **params: object) -> g.ClipSpec:
    duration = duration or max(g.MIN_DURATION, g.CONCEPTS[name].min_duration) + 1.0
    return g.ClipSpec((name,), "single", duration, params)


@pytest.fixture(scope="module")
def singles() -> dict[str, g.Clip]:
    names = list(g.CONCEPTS)
    clips = g.generate_clips([single(n) for n in names], list(range(len(names))))
    return dict(zip(names, clips, strict=True))


def test_same_seed_same_bytes_different_seed_differs() -> None:
    spec = g.ClipSpec(("walk_forward", "wave_right"), "simultaneous", 3.0)
    a, b, c = g.generate_clip(spec, 5), g.generate_clip(spec, 5), g.generate_clip(spec, 6)
    assert a.joints.tobytes() == b.joints.tobytes()
    assert a.captions == b.captions and a.labels == b.labels
    assert np.abs(a.joints - c.joints).max() > 0.01


def test_batched_generation_equals_one_at_a_time() -> None:
    specs = [g.sample_clip_spec(np.random.default_rng([1, i])) for i in range(6)]
    batch = g.generate_clips(specs, list(range(6)))
    for i, spec in enumerate(specs):
        assert batch[i].joints.tobytes() == g.generate_clip(spec, i).joints.tobytes()


def test_every_concept_keeps_the_real_bone_lengths(singles: dict[str, g.Clip]) -> None:
    for name, clip in singles.items():
        lengths = bone_lengths(clip.joints.astype(np.float64))
        assert np.abs(lengths - BONE_LENGTHS).max() <= 1e-5, name


def test_feet_reach_the_floor(singles: dict[str, g.Clip]) -> None:
    toes = [10, 11]
    for name, clip in singles.items():
        heights = clip.joints[:, toes, 1]
        assert abs(clip.joints[..., 1].min()) < 1e-3, name   # the toes are the lowest joints
        if name not in ("jump", "run"):                        # no flight phase
            assert heights.min(axis=1).max() < 0.02, name      # a toe down in every frame


def test_body_faces_plus_z_at_frame_zero_by_default(singles: dict[str, g.Clip]) -> None:
    for name, clip in singles.items():
        j = clip.joints[0]
        across = j[1] - j[2] + j[16] - j[17]                    # left − right: +X when facing +Z
        assert across[0] > 0 and abs(across[2]) < 0.1 * across[0], name


def test_initial_heading_and_start_position_move_the_clip() -> None:
    clip = g.generate_clip(single("walk_forward", 3.0, initial_heading=np.pi / 2,
                                  start_xz=[2.0, -1.0]), 0)
    assert np.allclose(clip.joints[0, 0, [0, 2]], [2.0, -1.0], atol=1e-5)
    travel = clip.joints[-1, 0, [0, 2]] - clip.joints[0, 0, [0, 2]]
    assert travel[0] > 1.0 and abs(travel[1]) < 0.2       # heading π/2 walks toward +X


def test_stance_feet_do_not_skate(singles: dict[str, g.Clip]) -> None:
    for name in LOCOMOTION:
        toes = singles[name].joints[:, [10, 11]]
        on_floor = (toes[1:, :, 1] < 0.005) & (toes[:-1, :, 1] < 0.005)
        speed = np.linalg.norm(np.diff(toes[..., [0, 2]], axis=0), axis=-1) * 20
        assert on_floor.sum() > 10, name
        assert speed[on_floor].mean() < 0.02, name


def test_walk_displacement_matches_speed_times_time() -> None:
    clip = g.generate_clip(single("walk_forward", 4.0), 3)
    p = clip.labels["params"]["walk_forward"]
    expected = p["v_forward"] * (4.0 - p["ramp_in"] / 2)     # smoothstep ramp loses half of it
    travelled = np.linalg.norm(clip.joints[-1, 0, [0, 2]] - clip.joints[0, 0, [0, 2]])
    assert travelled == pytest.approx(expected, rel=0.05)
    stride = p["v_forward"] * p["cycle"]
    assert 0.8 < stride < 1.8                                 # human stride lengths (m)


def test_durations_and_frame_counts_stay_in_range() -> None:
    rng = np.random.default_rng(0)
    for _ in range(300):
        spec = g.sample_clip_spec(rng)
        assert g.MIN_DURATION <= spec.duration <= g.MAX_DURATION
        assert 41 <= spec.n_frames <= 121                    # features: 40 ≤ T − 1 < 200
        if spec.composition == "sequential":
            assert sum(spec.segment_durations) == pytest.approx(spec.duration)


def test_simultaneous_composition_takes_each_part_from_its_owner() -> None:
    walk = g.generate_clip(single("walk_forward", 3.0), 11)
    both = g.generate_clip(g.ClipSpec(("walk_forward", "wave_right"), "simultaneous", 3.0), 11)
    legs = [0, 1, 2, 4, 5, 7, 8, 10, 11]
    assert np.allclose(both.joints[:, legs], walk.joints[:, legs], atol=1e-6)
    assert not np.allclose(both.joints[:, 21], walk.joints[:, 21], atol=0.05)   # right wrist
    assert both.labels["body_parts"]["right_arm"] == "wave_right"
    assert both.labels["body_parts"]["legs"] == "walk_forward"


def test_three_simultaneous_concepts_each_own_their_parts_and_all_are_captioned() -> None:
    spec = g.ClipSpec(("squat", "wave_left", "wave_right"), "simultaneous", 3.2)
    clip = g.generate_clip(spec, 5)
    squat = g.generate_clip(single("squat", 3.2), 5)
    assert clip.labels["body_parts"] == {"root": "squat", "legs": "squat", "torso": "squat",
                                         "left_arm": "wave_left", "right_arm": "wave_right"}
    assert not np.allclose(clip.joints[:, 20], squat.joints[:, 20], atol=0.05)  # left wrist
    assert len(clip.captions) == 3
    for caption in clip.captions:
        assert "squat" in caption and "left" in caption and "right" in caption
        g.humanml3d_text_line(caption)                         # every word is in the lexicon


def test_sequential_clips_record_segments_and_blend_smoothly() -> None:
    spec = g.ClipSpec(("jump", "turn_left"), "sequential", 4.0, segment_durations=(2.0, 2.0))
    clip = g.generate_clip(spec, 2)
    segments = clip.labels["segments"]
    assert [s["concept"] for s in segments] == ["jump", "turn_left"]
    assert segments[0]["start"] == 0 and segments[0]["end"] == segments[1]["start"] == 40
    assert segments[1]["end"] == len(clip.joints) - 1
    assert clip.labels["transitions"] == [40]
    step = np.linalg.norm(np.diff(clip.joints, axis=0), axis=-1).max(axis=-1)
    assert step[35:45].max() < 0.1                           # < 2 m/s for every joint


def test_captions_are_humanml3d_text_lines() -> None:
    rng = np.random.default_rng(4)
    specs = [g.sample_clip_spec(rng) for _ in range(40)]
    for clip in g.generate_clips(specs, list(range(40))):
        lines = clip.text_lines()
        assert len(lines) == 3 and len(set(clip.captions)) == 3
        for line in lines:
            match = TEXT_LINE.match(line)
            assert match, line
            assert {token.split("/")[1] for token in match.group(2).split()} <= UPOS


def test_pos_rules() -> None:
    tags = dict(g.tag_caption("a person waves the left hand"))
    assert tags["left"] == "ADJ" and tags["wave"] == "VERB" and tags["person"] == "NOUN"
    assert g.tag_caption("turns to the left")[-1] == ("left", "NOUN")
    assert g.tag_caption("someone turns left")[-1] == ("left", "ADV")
    assert g.tag_caption("takes several steps")[-1] == ("step", "NOUN")
    assert g.tag_caption("a man steps back")[2] == ("step", "VERB")
    with pytest.raises(ValueError, match="'moonwalks' .* not in the lexicon"):
        g.tag_caption("a person moonwalks")


@pytest.mark.parametrize(("make", "message"), [
    (lambda: g.ClipSpec(("fly",)), "unknown concept 'fly'"),
    (lambda: g.ClipSpec(("walk_forward", "run"), "simultaneous"), "cannot be simultaneous"),
    (lambda: g.ClipSpec(("wave_left", "wave_right"), "simultaneous"), "wave_both"),
    (lambda: g.ClipSpec(("jump",), duration=7.0), r"duration must be in \[2.0, 6.0\]"),
    (lambda: g.ClipSpec(("walk_circle",), duration=2.0), "needs at least 3.5 s"),
    (lambda: g.ClipSpec(("jump", "clap"), "sideways"), "unknown composition"),
    (lambda: g.ClipSpec(("jump", "clap"), "single"), "has 1 concept"),
    (lambda: g.ClipSpec(("run", "wave_left", "clap"), "simultaneous"), "share"),
    (lambda: g.ClipSpec(("run", "wave_left", "wave_left"), "simultaneous"), "twice"),
    (lambda: g.ClipSpec(("jump", "clap", "run"), "sequential"), "has 2 concept"),
    (lambda: g.ClipSpec(("jump",) * 4, "simultaneous"), "has 2 or 3 concept"),
])
def test_bad_specs_are_rejected(make, message) -> None:
    with pytest.raises(ValueError, match=message):
        make()


def test_unknown_parameter_overrides_are_rejected() -> None:
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['wings'\]"):
        g.generate_clip(g.ClipSpec(("jump",), params={"jump": {"wings": 2}}), 0)
    with pytest.raises(ValueError, match="unknown spec.params"):
        g.generate_clip(g.ClipSpec(("jump",), params={"run": {}}), 0)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("stand_in")
    return g.write_dataset(out, n_clips=14, seed=9)


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
        labels = g.storage.read_json(dataset / "labels" / f"{clip_id}.json")
        assert labels["id"] == clip_id and labels["n_frames"] == len(features) + 1
        assert {"concepts", "composition", "segments", "body_parts", "params"} <= set(labels)
    mean, std = np.load(dataset / "Mean.npy"), np.load(dataset / "Std.npy")
    assert mean.shape == std.shape == (FEATURE_DIM,) and std.dtype == np.float32
    for block in FEATURE_BLOCKS.values():
        assert np.ptp(std[block]) == 0 and std[block][0] > 0     # one value per block
    assert (dataset / g.DATASET_MARKER).exists()


def test_splits_are_disjoint_and_cover_every_id(dataset) -> None:
    splits = {name: (dataset / f"{name}.txt").read_text().split() for name in g.SPLITS}
    every = [i for ids in splits.values() for i in ids]
    assert len(every) == len(set(every)) == 14
    assert len(splits["train"]) == round(0.8 * 14)


def test_write_dataset_is_deterministic(dataset, tmp_path) -> None:
    again = g.write_dataset(tmp_path / "again", n_clips=14, seed=9)
    for path in sorted(dataset.rglob("*")):
        if path.is_file():
            assert (again / path.relative_to(dataset)).read_bytes() == path.read_bytes(), path


def test_held_out_pairs_go_to_test(tmp_path) -> None:
    out = g.write_dataset(tmp_path, n_clips=12, seed=1, compositions={"simultaneous": 1.0},
                          concept_pool=("walk_forward", "jump", "wave_right"),
                          held_out_pairs=[("walk_forward", "wave_right")])
    test = set((out / "test.txt").read_text().split())
    held = 0
    for path in (out / "labels").glob("*.json"):
        labels = g.storage.read_json(path)
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
        g.write_dataset(tmp_path, **options)


def test_ensure_dataset_generates_once_then_reuses(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    config = g.DatasetConfig(n_clips=5, seed=2)
    first = g.ensure_dataset(config)
    assert first.parent == tmp_path / "datasets" and (first / g.DATASET_MARKER).exists()
    stamp = (first / "new_joint_vecs" / "000000.npy").stat().st_mtime_ns
    assert g.ensure_dataset(config) == first
    assert (first / "new_joint_vecs" / "000000.npy").stat().st_mtime_ns == stamp
    assert g.ensure_dataset(g.DatasetConfig(n_clips=5, seed=3)) != first
    (first / g.DATASET_MARKER).unlink()                        # an interrupted generation
    assert g.ensure_dataset(config) == first
    assert (first / "new_joint_vecs" / "000000.npy").stat().st_mtime_ns != stamp
