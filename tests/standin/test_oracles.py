"""Oracles: each concept detected from joints alone, with physically set thresholds."""

from __future__ import annotations

import numpy as np
import pytest

from repro.infra.paths import data_stubs_dir
from repro.motion.features import joints_to_features
from repro.standin import generator as g
from repro.standin import oracles as o
from repro.standin.concepts import CONCEPTS

CLIPS_PER_CONCEPT = 5


def _rotation_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


@pytest.fixture(scope="module")
def singles() -> list[g.Clip]:
    """5 clips per concept: random durations, parameters, headings and start positions."""
    rng = np.random.default_rng(123)
    specs = [g.sample_clip_spec(rng, allow_compositions=False, concept_pool=[name])
             for name in CONCEPTS for _ in range(CLIPS_PER_CONCEPT)]
    return g.generate_clips(specs, list(range(len(specs))))


@pytest.fixture(scope="module")
def standing() -> np.ndarray:
    """Two seconds (41 frames) of still standing: a walk's first frame, before it starts."""
    clip = g.generate_clip(g.ClipSpec(("walk_forward",), "single", 2.0), 0)
    return np.repeat(clip.joints[:1].astype(np.float64), 41, axis=0)


def _with_nan(joints: np.ndarray) -> np.ndarray:
    joints = joints.copy()
    joints[5, 3, 1] = np.nan
    return joints


def test_concept_names_match_the_generator() -> None:
    assert set(o.CONCEPT_NAMES) == set(CONCEPTS)


def test_every_single_concept_is_detected_alone(singles: list[g.Clip]) -> None:
    report = o.oracle_agreement(singles)
    assert report["n_units"] == len(CONCEPTS) * CLIPS_PER_CONCEPT
    for name, stats in report["per_concept"].items():
        assert stats["support"] == CLIPS_PER_CONCEPT
        assert stats["recall"] == 1.0, (name, report["confusions"])
        assert stats["precision"] == 1.0, (name, report["confusions"])
    assert report["exact_match"] == 1.0


def test_simultaneous_and_sequential_compositions(singles: list[g.Clip]) -> None:
    rng = np.random.default_rng(7)
    simultaneous = [g.sample_clip_spec(rng, composition_weights={"simultaneous": 1})
                    for _ in range(30)]
    sequential = [g.sample_clip_spec(rng, composition_weights={"sequential": 1})
                  for _ in range(20)]
    clips = g.generate_clips(simultaneous + sequential, list(range(50)))
    report = o.oracle_agreement(clips)
    both = report["by_composition"]
    assert both["simultaneous"]["units"] == 30 and both["sequential"]["units"] == 40
    assert both["simultaneous"]["all_truth_detected"] >= 0.9, report["confusions"]
    assert both["sequential"]["all_truth_detected"] >= 0.9, report["confusions"]
    assert report["exact_match"] >= 0.9, report["confusions"]


def test_canonical_joints_give_the_same_answers(singles: list[g.Clip]) -> None:
    for clip in singles[::4]:
        _, canonical = joints_to_features(clip.joints)
        world = o.detect_concepts(clip.joints[:-1])
        assert o.detect_concepts(canonical) == world == set(clip.labels["concepts"])


def test_scores_do_not_depend_on_where_the_clip_is(singles: list[g.Clip]) -> None:
    joints = singles[0].joints.astype(np.float64)
    moved = joints @ _rotation_y(2.0).T + np.array([5.0, 0.3, -7.0])
    a, b = o.concept_scores(joints), o.concept_scores(moved)
    assert a.keys() == b.keys()
    assert np.allclose(list(a.values()), list(b.values()), atol=1e-6)


def test_the_committed_stubs_agree_with_their_labels() -> None:
    report = o.oracle_agreement(data_stubs_dir())
    assert report["n_units"] > 40
    assert report["exact_match"] >= 0.95, report["confusions"]


# Hand-made motions check the documented thresholds themselves.

def _slide(pose: np.ndarray, frames: int, step: np.ndarray) -> np.ndarray:
    return pose[None] + np.arange(frames)[:, None, None] * step


_LEFT_FOOT = [o.JOINT_INDEX[name] for name in ("L_ankle", "L_foot")]
_RIGHT_FOOT = [o.JOINT_INDEX[name] for name in ("R_ankle", "R_foot")]


def _stepping(pose: np.ndarray, frames: int, step: np.ndarray, lead: float = 0.15,
              cycle: int = 20) -> np.ndarray:
    """``_slide`` with the feet taking turns along the travel direction: each foot leads by
    up to ``lead`` m (the lead between them changes by 4·lead) every ``cycle`` frames."""
    motion = _slide(pose, frames, step)
    direction = step / np.linalg.norm(step)
    offset = lead * np.sin(2 * np.pi * np.arange(frames) / cycle)[:, None] * direction
    motion[:, _LEFT_FOOT] += offset[:, None]
    motion[:, _RIGHT_FOOT] -= offset[:, None]
    return motion


def test_standing_still_is_nothing(standing: np.ndarray) -> None:
    assert o.detect_concepts(standing) == set()


@pytest.mark.parametrize(("distance", "expected"), [(0.4, set()), (0.7, {"walk_forward"})])
def test_walk_needs_half_a_metre(standing: np.ndarray, distance: float, expected) -> None:
    motion = _stepping(standing[0], 41, np.array([0.0, 0.0, distance / 40]))
    assert o.detect_concepts(motion) == expected


def test_fast_travel_is_running_not_walking(standing: np.ndarray) -> None:
    motion = _stepping(standing[0], 41, np.array([0.0, 0.0, 2.5 / 20]))   # 2.5 m/s forward
    assert o.detect_concepts(motion) == {"run"}
    sideways = _stepping(standing[0], 41, np.array([-0.7 / 40, 0.0, 0.0]))  # −X: the right
    assert o.detect_concepts(sideways) == {"walk_right"}


@pytest.mark.parametrize("step", [np.array([0.0, 0.0, 0.7 / 40]),     # a walk's distance
                                  np.array([0.0, 0.0, 2.5 / 20]),     # a run's speed
                                  np.array([-0.7 / 40, 0.0, 0.0])])   # sideways
def test_gliding_without_steps_does_not_travel(standing: np.ndarray, step: np.ndarray) -> None:
    assert o.detect_concepts(_slide(standing[0], 41, step)) == set()
    assert o.detect_concepts(_stepping(standing[0], 41, step, lead=0.02)) == set()


def test_a_frozen_pose_moved_along_a_walk_is_not_walking(singles: list[g.Clip]) -> None:
    """Every travelling clip's own root path, carried by its first pose frozen: no travel."""
    travelling = [c for c in singles if set(c.labels["concepts"]) & set(o.TRAVEL_CONCEPTS)]
    assert len(travelling) == len(o.TRAVEL_CONCEPTS) * CLIPS_PER_CONCEPT
    for clip in travelling:
        joints = clip.joints.astype(np.float64)
        root = joints[:, :1] * np.array([1.0, 0.0, 1.0])
        frozen = joints[:1] - joints[:1, :1] * np.array([1.0, 0.0, 1.0]) + root
        assert set(clip.labels["concepts"]) <= o.detect_concepts(joints)
        assert not o.detect_concepts(frozen) & set(o.TRAVEL_CONCEPTS), clip.labels


@pytest.mark.parametrize(("degrees", "expected"), [
    (40, set()), (90, {"turn_left"}), (-150, {"turn_right"}), (320, set())])
def test_turning_on_the_spot(standing: np.ndarray, degrees: float, expected) -> None:
    root = standing[0, 0]
    angles = np.radians(degrees) * np.linspace(0, 1, 41)
    motion = np.stack([(standing[0] - root) @ _rotation_y(a).T + root for a in angles])
    assert o.detect_concepts(motion) == expected              # 320° on the spot: no circle


def test_a_quarter_second_off_the_floor_is_a_jump(standing: np.ndarray) -> None:
    for frames, expected in ((3, set()), (6, {"jump"})):
        motion = standing.copy()
        motion[10:10 + frames, :, 1] += 0.1
        assert o.detect_concepts(motion) == expected


def test_exclusions_between_wave_and_raise(singles: list[g.Clip]) -> None:
    wave_both = next(c for c in singles if c.labels["concepts"] == ["wave_both"])
    scores = o.concept_scores(wave_both.joints)
    assert scores["wave_left"] >= 1 and scores["wave_right"] >= 1
    assert o.detect_concepts(wave_both.joints) == {"wave_both"}
    assert not o.concept_present(wave_both.joints, "wave_left")


def test_segments_are_evaluated_on_their_frames() -> None:
    spec = g.ClipSpec(("walk_forward", "turn_right"), "sequential", 5.0,
                      segment_durations=(2.5, 2.5))
    clip = g.generate_clip(spec, 4)
    found = o.detect_segments(clip.joints, clip.labels["segments"])
    assert found == [{"walk_forward"}, {"turn_right"}]
    assert o.concept_present(clip.joints, "turn_right", start=50, end=100)
    assert not o.concept_present(clip.joints, "turn_right", start=0, end=50)


@pytest.mark.parametrize(("call", "message"), [
    (lambda j: o.concept_present(j, "fly"), "unknown concept 'fly'"),
    (lambda j: o.concept_scores(j[:, :21]), r"shape \(T, 22, 3\)"),
    (lambda j: o.concept_scores(_with_nan(j)), "NaN"),
    (lambda j: o.concept_scores(j, start=30, end=20), r"frame range \[30, 20\)"),
    (lambda j: o.concept_scores(j, end=500), "not inside a clip of 41 frames"),
    (lambda j: o.oracle_agreement([], split="test"), "split applies to a dataset folder"),
])
def test_bad_input_is_rejected(standing: np.ndarray, call, message) -> None:
    with pytest.raises(ValueError, match=message):
        call(standing)
