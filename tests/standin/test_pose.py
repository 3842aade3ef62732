"""The pose solver: two-bone IK by the law of cosines, and tracks realised exactly."""

from __future__ import annotations

import numpy as np
import pytest

from repro.motion.skeleton import forward_kinematics
from repro.standin import pose as p
from repro.standin.primitives import idle, kick, sample_kick


def test_two_bone_reaches_a_reachable_target_bending_toward_the_hint() -> None:
    rng = np.random.default_rng(0)
    targets = rng.normal(size=(50, 3))
    targets *= rng.uniform(0.2, 0.75, (50, 1)) / np.linalg.norm(targets, axis=1, keepdims=True)
    hint = np.array([0.0, 0.0, 1.0])
    upper, lower = p.two_bone(targets, 0.4, 0.4, hint)
    assert np.allclose(np.linalg.norm(upper, axis=1), 1) and np.allclose(
        np.linalg.norm(lower, axis=1), 1)
    assert np.abs(0.4 * upper + 0.4 * lower - targets).max() < 1e-9
    middle = 0.4 * upper                 # the knee/elbow leaves the line toward the hint
    along = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    off_line = middle - (middle * along).sum(1, keepdims=True) * along
    toward = hint - (hint * along).sum(1, keepdims=True) * along
    assert ((off_line * toward).sum(1) > 0).all()


def test_two_bone_stretches_along_the_line_to_an_unreachable_target() -> None:
    upper, lower = p.two_bone(np.array([[0.0, -2.0, 0.0]]), 0.4, 0.4, np.array([0, 0, 1.0]))
    assert np.allclose(upper, [[0, -1, 0]], atol=0.03) and np.allclose(lower, [[0, -1, 0]],
                                                                       atol=0.03)


@pytest.mark.parametrize("make", [
    lambda t: idle(t, 0.3),
    lambda t: kick(t, sample_kick(1)(np.random.default_rng(0), 2.0, False)),
])
def test_solved_pose_puts_root_and_ankles_where_the_track_says(make) -> None:
    track = make(np.arange(41) / 20)
    root, rotations = p.solve_pose(track)
    joints = forward_kinematics(root, rotations).numpy()
    assert np.abs(joints[:, 0, [0, 2]] - track.root_xz).max() < 1e-9
    assert np.abs(joints[:, 0, 1] - track.pelvis_y).max() < 1e-9
    assert np.abs(joints[:, [7, 8]] - track.ankles).max() < 1e-9


def test_take_part_copies_only_that_part() -> None:
    t = np.arange(21) / 20
    base, other = idle(t), kick(t, sample_kick(0)(np.random.default_rng(1), 2.0, False))
    other.arms[:] = 0.5
    p.take_part(base, other, "right_arm")
    assert np.array_equal(base.arms[:, 1], other.arms[:, 1])
    assert not np.array_equal(base.arms[:, 0], other.arms[:, 0])
    assert not np.array_equal(base.ankles, other.ankles)
    p.take_part(base, other, "legs")
    assert np.array_equal(base.ankles, other.ankles)
