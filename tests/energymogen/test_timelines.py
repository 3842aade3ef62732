"""The MTT-style test set (repro.energymogen.timelines) and the transition measurements read at
its boundaries (studies.transition_distances_at_cm, studies.transition_speed_ratio)."""

from __future__ import annotations

import numpy as np
import pytest

from repro.energymogen import harness as em_harness
from repro.energymogen import sef_ablation as sef
from repro.energymogen.sef_ablation import (
    real_then_clips,
    timeline_item,
    timeline_items,
    transition_frames,
)
from repro.energymogen.settings import ARM_CONCEPTS, FRAMES, LOWER_CONCEPTS
from repro.standin.concepts import CONCEPTS


def test_items_compose_by_body_part_and_duration_as_mtt() -> None:
    items = timeline_items(seed=3, count=200)
    spans = set()
    for item in items.items:
        a, b, c = item.intervals
        assert a.start == 0 and a.end == b.start and b.end == FRAMES      # A then B
        assert FRAMES // 4 <= a.end <= FRAMES - FRAMES // 4
        assert a.concept != b.concept and {a.concept, b.concept} <= set(LOWER_CONCEPTS)
        assert c.concept in ARM_CONCEPTS
        assert not c.body_parts & (a.body_parts | b.body_parts)          # complementary parts
        assert c.body_parts == CONCEPTS[c.concept].parts
        inside_a, inside_b = c.end <= a.end, c.start >= b.start
        spans.add("A" if inside_a else "B" if inside_b else "both")
        assert 0 <= c.start < c.end <= FRAMES and c.end - c.start >= 2
        assert item.transitions == tuple(sorted({a.end, c.start, c.end} - {0, FRAMES}))
        assert " then " in item.multi_text and " while " in item.multi_text or (
            "all the while" in item.multi_text)
    assert spans == {"A", "B", "both"}
    assert items.concept_texts[2][0] == items.items[0].intervals[2].text
    assert len(items.multi_texts) == len(items) == 200


def test_items_are_deterministic_in_the_seed() -> None:
    assert timeline_items(1, 5) == timeline_items(1, 5)
    assert timeline_items(1, 5) != timeline_items(2, 5)
    item = timeline_item(np.random.default_rng(0), frames=40)
    assert all(0 < p < 40 for p in item.transitions)


def test_transition_frames_are_the_inner_boundaries_as_stmc() -> None:
    assert transition_frames([(0, 30), (30, 64), (10, 30)], 64) == (10, 30)
    assert transition_frames([(0, 30), (30, 64), (40, 64)], 64) == (30, 40)


def test_real_then_clips_carry_the_generator_transition() -> None:
    items = timeline_items(seed=0, count=3)
    real = real_then_clips(items, seed=0)
    for features, points, pair, item in zip(real.features, real.transitions, real.concepts,
                                            items.items, strict=True):
        assert pair == item.concepts[:2] and len(points) == 1
        assert 0 < points[0] < features.shape[0] and features.shape[1] == 263


def _clip_with_jump(frames: int, at: int, jump_m: float, speed_m: float = 0.0) -> np.ndarray:
    """Features whose every root-relative joint moves ``speed_m`` per frame along x and jumps
    by ``jump_m`` along z into frame ``at`` (root height fixed)."""
    features = np.zeros((frames, 263))
    features[:, 3] = 0.9
    t = np.arange(frames)
    x = speed_m * t
    z = np.where(t >= at, jump_m, 0.0)
    features[:, 4:67:3] = x[:, None]
    features[:, 6:67:3] = z[:, None]
    return features


def test_transition_distance_sees_a_known_jump_at_a_known_transition() -> None:
    clip = _clip_with_jump(64, at=30, jump_m=0.05)
    # 21 of the 22 joints jump 5 cm (the root is the origin): the mean over joints is 5·21/22
    assert em_harness.transition_distances_at_cm([clip], [(30,)])[0] == pytest.approx(
        5.0 * 21 / 22)
    assert em_harness.transition_distance_at_transitions_cm([clip], [(20,)]) == 0.0
    both = em_harness.transition_distances_at_cm([clip, clip], [(30, 20), (30,)])
    assert both.tolist() == pytest.approx([5.0 * 21 / 22, 0.0, 5.0 * 21 / 22])
    with pytest.raises(ValueError, match="transition frames"):
        em_harness.transition_distances_at_cm([clip], [(64,)])


def test_speed_ratio_does_not_reward_standing_still() -> None:
    still = _clip_with_jump(64, at=30, jump_m=0.0)
    moving = _clip_with_jump(64, at=30, jump_m=0.0, speed_m=0.01)
    jumping = _clip_with_jump(64, at=30, jump_m=0.05, speed_m=0.01)
    ratio = {name: em_harness.transition_speed_ratio([clip], [(30,)]) for name, clip in
             (("still", still), ("moving", moving), ("jumping", jumping))}
    assert ratio["still"] == pytest.approx(1.0) and ratio["moving"] == pytest.approx(1.0)
    assert ratio["jumping"] > 3.0
    # the all-frames distance v2 read calls the still clip the smoothest
    assert em_harness.transition_distance_cm(still[None]) < em_harness.transition_distance_cm(
        moving[None])
    values = sef.timeline_measurements([jumping, still], [(30,), (30,)])
    assert values["transition_speed_ratio"] == pytest.approx((ratio["jumping"] + 1.0) / 2)
