"""Metrics against closed forms, constructed embeddings and constructed motions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import ortho_group

from repro.core import metrics
from repro.motion.skeleton import NUM_JOINTS

D = 6


def _commuting_pair(seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    q = ortho_group.rvs(D, random_state=seed)
    lam1, lam2 = rng.uniform(0.2, 3.0, D), rng.uniform(0.2, 3.0, D)
    mu1, mu2 = rng.normal(size=D), rng.normal(size=D)
    return mu1, q @ np.diag(lam1) @ q.T, lam1, mu2, q @ np.diag(lam2) @ q.T, lam2


def test_fid_of_a_set_with_itself_is_zero():
    x = np.random.default_rng(0).normal(size=(500, 8))
    assert abs(metrics.fid(x, x)) < 1e-8
    assert metrics.fid(x, x + 0.5) == pytest.approx(8 * 0.25, rel=1e-6)


def test_frechet_distance_matches_closed_form_for_diagonal_covariances():
    rng = np.random.default_rng(1)
    mu1, mu2 = rng.normal(size=D), rng.normal(size=D)
    var1, var2 = rng.uniform(0.1, 4.0, D), rng.uniform(0.1, 4.0, D)
    expected = metrics.gaussian_fid_closed_form(mu1, var1, mu2, var2)
    got = metrics.frechet_distance(mu1, np.diag(var1), mu2, np.diag(var2))
    assert got == pytest.approx(expected, rel=1e-6)
    by_hand = np.sum((mu1 - mu2) ** 2) + np.sum((np.sqrt(var1) - np.sqrt(var2)) ** 2)
    assert expected == pytest.approx(by_hand, rel=1e-12)


def test_frechet_distance_matches_closed_form_for_commuting_non_diagonal_covariances():
    mu1, s1, lam1, mu2, s2, lam2 = _commuting_pair(2)
    assert np.abs(s1 - np.diag(np.diag(s1))).max() > 0.1  # really not diagonal
    expected = metrics.gaussian_fid_closed_form(mu1, lam1, mu2, lam2)
    assert metrics.frechet_distance(mu1, s1, mu2, s2) == pytest.approx(expected, rel=1e-6)


def test_monte_carlo_fid_approaches_the_closed_form():
    mu1, s1, lam1, mu2, s2, lam2 = _commuting_pair(3)
    expected = metrics.gaussian_fid_closed_form(mu1, lam1, mu2, lam2)
    rng = np.random.default_rng(3)

    def error(n: int) -> float:
        a = rng.multivariate_normal(mu1, s1, size=n)
        b = rng.multivariate_normal(mu2, s2, size=n)
        return abs(metrics.fid(a, b) - expected) / expected

    small = np.mean([error(100) for _ in range(5)])
    large = np.mean([error(20000) for _ in range(5)])
    assert large < 0.02
    assert large < small


def test_printed_energymogen_formula_differs_and_can_be_negative():
    mu1, s1, _, mu2, s2, _ = _commuting_pair(4)
    correct = metrics.frechet_distance(mu1, s1, mu2, s2)
    printed = metrics.fid_as_printed_in_energymogen(mu1, s1, mu2, s2)
    assert abs(printed - correct) > 0.1 * abs(correct)
    half = 0.5 * np.eye(D)
    mu = np.zeros(D)
    assert metrics.frechet_distance(mu, half, mu, half) == pytest.approx(0.0, abs=1e-9)
    # ‖0‖² − Tr(½I + ½I − 2·¼I) = −D/2
    assert metrics.fid_as_printed_in_energymogen(mu, half, mu, half) == pytest.approx(-D / 2)


def test_fid_handles_singular_covariances_and_rejects_indefinite_ones():
    few = np.random.default_rng(5).normal(size=(5, 10))  # rank-4 covariance in 10-D
    value = metrics.fid(few, few[::-1] + 1.0)
    assert np.isfinite(value) and value == pytest.approx(10.0, abs=1e-3)
    with pytest.raises(ValueError, match="imaginary"):
        metrics.frechet_distance(np.zeros(2), np.diag([1.0, -1.0]), np.zeros(2), np.eye(2))


def test_fid_rejects_bad_input():
    with pytest.raises(ValueError, match="same length|different"):
        metrics.frechet_distance(np.zeros(2), np.eye(2), np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match="NaN"):
        metrics.fid(np.full((4, 2), np.nan), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="at least 2"):
        metrics.fid(np.zeros((1, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="non-negative"):
        metrics.gaussian_fid_closed_form(np.zeros(2), [1.0, -1.0], np.zeros(2), [1.0, 1.0])


def test_r_precision_perfect_and_random():
    rng = np.random.default_rng(6)
    emb = rng.normal(size=(320, 16))
    np.testing.assert_array_equal(metrics.r_precision(emb, emb, seed=0), [1.0, 1.0, 1.0])
    text, motion = rng.normal(size=(32 * 400, 16)), rng.normal(size=(32 * 400, 16))
    rates = metrics.r_precision(text, motion, seed=0)
    np.testing.assert_allclose(rates, [1 / 32, 2 / 32, 3 / 32], atol=0.006)
    everything = metrics.r_precision(text[:64], motion[:64], top_k=32, seed=0)
    assert everything[-1] == 1.0 and np.all(np.diff(everything) >= 0)


def test_r_precision_ranks_by_distance_within_batches():
    # 16 far-apart clusters of two pairs each, laid out along a direction v:
    # text 2k at 0, motion 2k at 2, motion 2k+1 at 1, text 2k+1 at 1.2. Text 2k has motion
    # 2k+1 nearer than its own (top-2 hit, top-1 miss); text 2k+1 finds its own first.
    centres = 100.0 * np.eye(17)[:16]
    v = np.eye(17)[16]
    text = np.concatenate([[c, c + 1.2 * v] for c in centres])
    motion = np.concatenate([[c + 2.0 * v, c + 1.0 * v] for c in centres])
    rates = metrics.r_precision(text, motion, top_k=2, seed=0)
    np.testing.assert_allclose(rates, [0.5, 1.0])
    assert metrics.mm_distance(text, motion) == pytest.approx((2.0 + 0.2) / 2)


def test_r_precision_rejects_too_few_pairs():
    with pytest.raises(ValueError, match="batch_size"):
        metrics.r_precision(np.zeros((10, 4)), np.zeros((10, 4)))
    with pytest.raises(ValueError, match="same shape"):
        metrics.r_precision(np.zeros((40, 4)), np.zeros((40, 5)))


def test_mm_distance_of_a_constant_offset():
    text = np.random.default_rng(7).normal(size=(50, 4))
    motion = text + np.array([3.0, 0.0, 4.0, 0.0])
    assert metrics.mm_distance(text, motion) == pytest.approx(5.0)
    assert metrics.matching_score is metrics.mm_distance


def test_diversity_of_known_points():
    rng = np.random.default_rng(8)
    signs = np.repeat([[-1.0], [1.0]], 1000, axis=0)  # pairs are 0 or 2 apart, P(2) ≈ ½
    assert metrics.diversity(signs, seed=0) == pytest.approx(1.0, abs=0.2)
    gauss = rng.normal(size=(3000, 64))  # E‖x−y‖ = √2·E χ_64 ≈ √2·7.9686
    assert metrics.diversity(gauss, seed=0) == pytest.approx(np.sqrt(2) * 7.9686, rel=0.02)
    shifted = metrics.diversity(3.0 * gauss + 7.0, seed=0)
    assert shifted == pytest.approx(3.0 * metrics.diversity(gauss, seed=0), rel=1e-9)
    assert metrics.diversity(np.ones((400, 3)), seed=0) == 0.0
    with pytest.raises(ValueError, match="n_pairs"):
        metrics.diversity(gauss[:100], n_pairs=300)


def test_multimodality_measures_spread_within_texts_only():
    rng = np.random.default_rng(9)
    n_texts, n_gen, sigma = 200, 30, 0.5
    spread = sigma * rng.normal(size=(n_texts, n_gen, 16))
    centres = 100.0 * rng.normal(size=(n_texts, 1, 16))
    value = metrics.multimodality(spread, seed=1)
    # E‖g−g'‖ = σ√2·E χ_16 (≈ 3.9377), times P(the two draws differ) = 1 − 1/n_gen
    expected = sigma * np.sqrt(2) * 3.9377 * (1 - 1 / n_gen)
    assert value == pytest.approx(expected, rel=0.05)
    assert metrics.multimodality(spread + centres, seed=1) == pytest.approx(value, rel=1e-9)
    assert metrics.multimodality(np.repeat(centres, n_gen, axis=1), seed=1) == 0.0
    with pytest.raises(ValueError, match="n_gen"):
        metrics.multimodality(spread[:, :5])


def test_tmr_score_bounds():
    rng = np.random.default_rng(10)
    a = rng.normal(size=(100, 8))
    assert metrics.tmr_score(a, 3.0 * a) == pytest.approx(1.0)
    assert metrics.tmr_score(a, -a) == pytest.approx(0.0)
    e = np.eye(2)
    assert metrics.tmr_score(e[:1], e[1:]) == pytest.approx(0.5)
    score = metrics.tmr_score(a, rng.normal(size=(100, 8)))
    assert 0.0 <= score <= 1.0 and score == pytest.approx(0.5, abs=0.05)
    with pytest.raises(ValueError, match="zero norm"):
        metrics.tmr_score(np.zeros((1, 8)), a[:1])


def _still_pose(frames: int) -> np.ndarray:
    pose = np.random.default_rng(11).normal(size=(NUM_JOINTS, 3))
    return np.repeat(pose[None], frames, axis=0)


def test_transition_distance_of_a_constructed_jump():
    joints = _still_pose(30)
    joints[10:, 1:] += np.array([0.3, 0.0, 0.4])  # every non-root joint jumps 0.5 m at t=10
    assert metrics.transition_distance(joints, [10]) == pytest.approx(0.5 * 21 / 22)
    assert metrics.transition_distance(joints, [10, 20]) == pytest.approx(0.25 * 21 / 22)
    moved = joints + np.linspace(0, 5, 30)[:, None, None]  # whole-body translation
    assert metrics.transition_distance(moved, [10]) == pytest.approx(0.5 * 21 / 22)
    batch = np.stack([joints, _still_pose(30)])
    assert metrics.transition_distance(batch, [10]) == pytest.approx(0.25 * 21 / 22)
    with pytest.raises(ValueError, match="transition frames"):
        metrics.transition_distance(joints, [0])
    with pytest.raises(ValueError, match="joints must be"):
        metrics.transition_distance(joints[:, :21], [10])


def test_ric_joints_are_the_root_relative_joints_without_heading():
    from repro.motion.features import features_to_joints

    features = np.random.default_rng(12).normal(size=(2, 15, 263)).astype(np.float32)
    features[..., 0:3] = 0.0  # no turning and no root motion: world joints = ric joints
    world = np.asarray(features_to_joints(features), dtype=np.float64)
    np.testing.assert_allclose(metrics.ric_joints(features), world - world[..., :1, :],
                               atol=1e-5)


def _walking_feet(frames: int, left_step: float, right_step: float,
                  height: float = 0.0) -> np.ndarray:
    joints = _still_pose(frames)
    t = np.arange(frames)
    joints[:, 10] = np.stack([left_step * t, np.full(frames, height), np.zeros(frames)], -1)
    joints[:, 11] = np.stack([right_step * t, np.full(frames, height), np.ones(frames)], -1)
    return joints


def test_foot_skating_zero_when_planted_and_positive_when_sliding():
    assert metrics.foot_skating(_walking_feet(40, 0.0, 0.0)) == 0.0
    assert metrics.foot_skating(_walking_feet(40, 0.05, 0.05)) == pytest.approx(1.0)  # m/s
    assert metrics.foot_skating(_walking_feet(40, 0.0, 0.05)) == pytest.approx(0.5)
    assert np.isnan(metrics.foot_skating(_walking_feet(40, 0.05, 0.05, height=0.3)))
    assert metrics.foot_skating_ratio(_walking_feet(40, 0.0, 0.0)) == 0.0
    assert metrics.foot_skating_ratio(_walking_feet(40, 0.0, 0.05)) == 1.0
    assert metrics.foot_skating_ratio(_walking_feet(40, 0.0, 0.01)) == 0.0  # 0.2 m/s < 0.5


def test_foot_skating_ignores_padding():
    planted = _walking_feet(40, 0.0, 0.0)
    planted[20:, 10, 0] += np.arange(20)  # garbage after the clip ends
    assert metrics.foot_skating(planted, lengths=[20]) == 0.0
    assert metrics.foot_skating(planted) > 0.0


def test_jitter_of_smooth_and_noisy_trajectories():
    t = np.arange(50) / 20.0
    linear = _still_pose(50) + (0.7 * t)[:, None, None]
    assert metrics.jitter(linear) == pytest.approx((0.0, 0.0), abs=1e-9)
    accelerating = _still_pose(50)
    accelerating[..., 0] += 0.5 * 2.0 * t[:, None] ** 2  # a = 2 m/s² along x, no jerk
    acc, jerk = metrics.jitter(accelerating)
    assert acc == pytest.approx(2.0) and jerk == pytest.approx(0.0, abs=1e-6)
    noisy = linear + 0.01 * np.random.default_rng(13).normal(size=linear.shape)
    noisy_jitter = metrics.jitter(noisy)
    assert noisy_jitter.acceleration > 1.0 and noisy_jitter.jerk > noisy_jitter.acceleration
    with pytest.raises(ValueError, match="at least 4"):
        metrics.jitter(linear[:3])


def test_mean_and_ci95_by_hand():
    mean, half = metrics.mean_and_ci95([1.0, 2.0, 3.0, 4.0])
    assert mean == 2.5
    assert half == pytest.approx(1.96 * np.sqrt(1.25) / 2.0)
    summary = metrics.summarise_replications([{"fid": 1.0, "r1": 0.2}, {"fid": 3.0, "r1": 0.4}])
    assert summary["fid"] == pytest.approx((2.0, 1.96 * 1.0 / np.sqrt(2)))
    assert summary["r1"][0] == pytest.approx(0.3)
    with pytest.raises(ValueError, match="keys"):
        metrics.summarise_replications([{"fid": 1.0}, {"r1": 1.0}])
    with pytest.raises(ValueError, match="at least one"):
        metrics.mean_and_ci95([])


def test_mean_speeds_of_a_body_walking_at_a_known_speed():
    frames, speed, fps = 30, 1.5, 20.0
    joints = np.zeros((2, frames, 22, 3))
    joints[..., 1] = np.linspace(0.0, 1.6, 22)              # a standing body ...
    joints[..., list(metrics.FOOT_JOINTS_FOR_SKATING), 1] = 0.0  # ... its feet on the floor
    joints[..., 2] += (np.arange(frames) * speed / fps)[None, :, None]
    joint_speed, root_speed = metrics.mean_speeds(joints, fps)
    assert joint_speed == pytest.approx(speed) and root_speed == pytest.approx(speed)
    still = metrics.motion_statistics(np.zeros((1, 8, 22, 3)) + joints[:1, :1], fps)
    assert still["joint_speed"] == 0.0 and still["joint_jerk"] == 0.0
    sliding = metrics.motion_statistics(joints, fps)
    assert sliding["foot_skating"] == pytest.approx(speed)   # the feet slide with the body


def test_a_sample_statistic_carries_its_bootstrap_interval() -> None:
    rng = np.random.default_rng(0)
    joints = rng.normal(size=(64, 24, 22, 3)).cumsum(axis=1) * 0.01
    point = metrics.motion_statistics(joints)
    wide = metrics.motion_statistics_intervals(joints[:8], resamples=50)
    narrow = metrics.motion_statistics_intervals(joints, resamples=50)
    for metric, value in point.items():
        low, high = narrow[f"{metric}_interval"]
        assert low <= value <= high, metric
        if metric != "foot_skating_ratio":
            assert np.diff(wide[f"{metric}_interval"]) > np.diff(narrow[f"{metric}_interval"])
