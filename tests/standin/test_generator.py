"""Stand-in clips: determinism, physical consistency, composition, bad specifications."""

from __future__ import annotations

import numpy as np
import pytest

from repro.motion.skeleton import BONE_LENGTHS, bone_lengths
from repro.standin import generator as g
from repro.standin.captions import humanml3d_text_line
from repro.standin.concepts import CONCEPTS

LOCOMOTION = ("walk_forward", "walk_backward", "walk_left", "walk_right", "run", "turn_left",
              "turn_right", "walk_circle")


def single(name: str, duration: float | None = None, **params: object) -> g.ClipSpec:
    duration = duration or max(g.MIN_DURATION, CONCEPTS[name].min_duration) + 1.0
    return g.ClipSpec((name,), "single", duration, params)


@pytest.fixture(scope="module")
def singles() -> dict[str, g.Clip]:
    names = list(CONCEPTS)
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
    spec = g.ClipSpec(("squat", "wave_left", "wave_right"), "simultaneous", 3.2,
                      partial_caption_share=0.0)
    clip = g.generate_clip(spec, 5)
    squat = g.generate_clip(single("squat", 3.2), 5)
    assert clip.labels["body_parts"] == {"root": "squat", "legs": "squat", "torso": "squat",
                                         "left_arm": "wave_left", "right_arm": "wave_right"}
    assert clip.labels["caption_concepts"] == [list(spec.concepts)] * 3
    assert not np.allclose(clip.joints[:, 20], squat.joints[:, 20], atol=0.05)  # left wrist
    assert len(clip.captions) == 3
    for caption in clip.captions:
        assert "squat" in caption and "left" in caption and "right" in caption
        humanml3d_text_line(caption)                         # every word is in the lexicon


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
