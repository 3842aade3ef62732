"""The gate measurements of tiny GMD's models: known answers, the data passes its own gate, a
constant or noise "model" fails it."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.core.gates import gate_results, gates_markdown
from repro.gmd import model_gates as mg
from repro.gmd.models import load_or_train_gmd
from repro.gmd.windows import load_windows
from repro.models.evaluator import EvaluatorConfig, train_evaluator
from repro.motion.features import FPS


def _walk(frames: int = 20, speed: float = 1.0) -> np.ndarray:
    """(1, frames, 22, 3): a rigid body gliding along +x at ``speed`` m/s, feet on the floor."""
    joints = np.zeros((1, frames, 22, 3))
    joints[0, :, :, 0] = speed * np.arange(frames)[:, None] / FPS
    joints[0, :, :, 1] = np.linspace(0.0, 1.7, 22)[None]
    joints[0, :, [10, 11], 1] = 0.0
    return joints


def test_motion_values_of_a_gliding_body_are_its_speed_and_no_jerk() -> None:
    values = mg.motion_gate_values(_walk(speed=1.5), fid=0.25)
    assert values["foot_skating"] == pytest.approx(1.5)
    assert values["joint_jerk"] == pytest.approx(0.0, abs=1e-9)
    assert values["fid"] == 0.25
    assert "fid" not in mg.motion_gate_values(_walk(), fid=None)


def test_path_length_of_a_straight_walk_and_a_square() -> None:
    straight = np.zeros((1, 11, 3))
    straight[0, :, 0] = np.linspace(0.0, 2.0, 11)
    square = np.zeros((1, 5, 3))
    square[0, :, [0, 2]] = np.array([[0, 1, 1, 0, 0], [0, 0, 1, 1, 0]], dtype=float)
    assert mg.path_length(straight) == pytest.approx([2.0])
    assert mg.path_length(np.concatenate([straight[:, :5], square])) == pytest.approx([0.8, 4.0])


@pytest.fixture()
def windows(small_config):
    train = load_windows(small_config())
    test = load_windows(small_config(), "test", statistics=(train.mean, train.std))
    return train, test


def test_the_data_passes_its_own_gates_and_noise_or_a_constant_fails(windows) -> None:
    train, test = windows
    motion, trajectory = test.space("motion"), test.space("trajectory")
    data_motion = mg.motion_gate_values(motion.joints(test.x), fid=1.0)
    data_path = mg.trajectory_gate_values(trajectory, test.trajectory())
    assert data_path["path_length"] > 0 and data_path["root_jerk"] > 0
    assert all(g["passed"] for g in gate_results("gmd_motion", data_motion, data_motion).values())
    assert all(g["passed"]
               for g in gate_results("gmd_trajectory", data_path, data_path).values())

    generator = torch.Generator().manual_seed(0)
    noise = torch.randn(test.x.shape, generator=generator)
    noisy_motion = mg.motion_gate_values(motion.joints(noise), fid=1.0)
    assert not gate_results("gmd_motion", noisy_motion, data_motion)["joint_jerk"]["passed"]
    noisy_path = mg.trajectory_gate_values(trajectory, noise[:, :4])
    assert not gate_results("gmd_trajectory", noisy_path, data_path)["root_jerk"]["passed"]
    # a model that always returns the mean window stands still: no path
    still = mg.trajectory_gate_values(trajectory, torch.zeros_like(test.trajectory()))
    assert still["path_length"] == pytest.approx(0.0, abs=1e-6)
    assert not gate_results("gmd_trajectory", still, data_path)["path_length"]["passed"]


def test_evaluator_r_precision_is_high_for_a_trained_evaluator_and_chance_when_shuffled() -> None:
    rng = np.random.default_rng(0)
    words = ["walk", "jump", "turn", "kick", "wave", "sit", "run", "crawl"]
    n, frames = 64, 8
    captions = [f"a person {words[i % 8]}s" for i in range(n)]
    motions = rng.normal(size=(n, frames, 263)).astype(np.float32) * 0.1
    for i in range(n):  # each word its own feature offset: a learnable text-motion pairing
        motions[i, :, i % 8] += 3.0
    lengths = [frames] * n
    evaluator = train_evaluator(motions, lengths, captions,
                                EvaluatorConfig(dim=16, hidden=32, steps=150))
    good = mg.evaluator_gate_values(evaluator, motions, lengths, captions, seed=0)
    assert good["r_precision_top3"] > 0.3
    shuffled = [captions[i] for i in rng.permutation(n)]
    bad = mg.evaluator_gate_values(evaluator, motions, lengths, shuffled, seed=0)
    assert bad["r_precision_top3"] < good["r_precision_top3"]
    record = mg.evaluator_model_record(evaluator, values=good)
    assert record["family"] == "evaluator" and record["steps"] == 150
    assert record["name"] == mg.evaluator_model_record(evaluator, values=bad)["name"]


def test_one_caption_each_draws_from_lists_and_keeps_strings() -> None:
    picked = mg.one_caption_each(["a", ["b", "c"], ["d"]], seed=0)
    assert picked[0] == "a" and picked[1] in ("b", "c") and picked[2] == "d"


def test_loss_curve_keeps_short_curves_and_averages_long_ones() -> None:
    assert mg.loss_curve([3.0, 2.0]) == [3.0, 2.0]
    curve = mg.loss_curve(list(range(100)), points=10)
    assert len(curve) == 10 and curve[0] == pytest.approx(4.5) and curve[-1] == pytest.approx(94.5)


def test_gmd_model_record_reads_the_cache_metrics(cache, small_spec, windows) -> None:
    train, test = windows
    trained = load_or_train_gmd(small_spec(), train)
    reference = mg.trajectory_gate_values(test.space("trajectory"), test.trajectory())
    record = mg.gmd_model_record(trained, family="gmd_trajectory", values=reference,
                                 reference=reference)
    assert record["steps"] == 3 and record["passed"] and record["precision"] == "fp32"
    assert record["train_seconds"] == trained.metrics["seconds"]
    assert record["validation_curve"] == pytest.approx(trained.metrics["losses"])
    assert trained.cache_key[:10] in record["name"] and "seed 0" in record["name"]
    failing = mg.gmd_model_record(trained, family="gmd_trajectory",
                                  values={"root_jerk": reference["root_jerk"] * 10},
                                  reference=reference)
    assert not failing["passed"] and failing["gate"]["path_length"]["value"] is None
    assert "**fail**" in gates_markdown([record, failing])
    with pytest.raises(ValueError, match="family"):
        mg.gmd_model_record(trained, family="vae", values={}, reference={})


def test_relative_features_give_the_same_values_as_the_joints(small_config) -> None:
    train = load_windows(small_config())  # absolute root: joints and features by other paths
    space = train.space("motion")
    with torch.no_grad():
        features = space.relative_features(train.x)
        joints = space.joints(train.x)
    from_features = mg.relative_features_gate_values(features.numpy(), fid=None)
    from_joints = mg.motion_gate_values(joints, fid=None)
    assert from_features == pytest.approx(from_joints, rel=1e-4)


def test_sample_quality_values_map_to_the_gate_metrics() -> None:
    values = {"motion_foot_skating_eps": [0.1, 0.2], "motion_jitter_eps": [5.0, 6.0],
              "motion_fid_eps": [1.0, 2.0], "motion_jitter_x0": [9.0, 9.0]}
    assert mg.sample_quality_gate_values(values, "eps", 1) == {
        "foot_skating": 0.2, "joint_jerk": 6.0, "fid": 2.0}


def test_emphasis_study_records_reuse_table_b1_samples_and_measure_the_rest(
        cache, dataset_dir) -> None:
    from repro.gmd import emphasis_study as study
    from repro.gmd.models import GMDModelSpec
    from repro.gmd.windows import DataConfig

    data = DataConfig(data_dir=str(dataset_dir), frames=16, stride=4)  # ≥ 32 test windows
    base = GMDModelSpec(task="motion", prediction="x0", text_conditioned=True, data=data,
                        base_channels=8, channel_mults=(1, 2), diffusion_steps=5,
                        train_steps=2, batch_size=8)
    settings = study.Settings(quick=True, seeds=1, stand_in_clips=0, stride=4,
                              diffusion_steps=5, train_steps=2, samples=32, evaluator_steps=5,
                              values=(1,))
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    train_relative = load_windows(DataConfig(data_dir=str(dataset_dir), frames=16, stride=4,
                                             representation="relative"))
    evaluator = study.window_evaluator(train_relative, 5)
    results = study.run_experiment(settings, base, train, test, evaluator, [0], log=lambda _: None)
    records = mg.emphasis_study_records(results, base=base, train=train, test=test,
                                        train_relative=train_relative, evaluator=evaluator,
                                        samples=settings.samples)
    assert [r["name"].split(" seed")[0] for r in records] == [
        "gmd motion/x0 loss scaling k=1", "gmd motion/x0 Emphasis c=1"]
    # loss scaling k=1 is a Table B.1 model: its text-to-motion values are reused as measured
    reused = records[0]["gate"]
    assert reused["foot_skating"]["value"] == results.text_to_motion["loss scaling k=1"][
        "foot_skating"][0]
    # Emphasis c=1 is not: measured here the same way, so a re-measurement agrees
    trained = study.load_or_train_variant(base, study.Variant("emphasis", 1), train, 0)
    again = study.measure_text_to_motion(trained, study.draw_targets(test, 32, seed=0),
                                         evaluator, seed=0)
    measured = records[1]["gate"]
    assert measured["joint_jerk"]["value"] == pytest.approx(again["jerk"])
    assert measured["fid"]["value"] == pytest.approx(again["fid"])
    # the reference is the targets' own skating, so the allowed bound is 3× it
    assert measured["foot_skating"]["at_most"] == pytest.approx(
        3 * results.ground_truth["foot_skating"][0])
    # and the FID bound 5× the training windows' mean FID against the targets (gates v2)
    with torch.no_grad():
        features = train_relative.space("motion").relative_features(train_relative.x)
    targets = study.draw_targets(test, 32, seed=0)
    lengths = [targets.relative.shape[1]] * len(targets)
    reference, _ = mg.reference_fid(evaluator, features.numpy().astype(np.float32), lengths[0],
                                    evaluator.embed_motions(targets.relative, lengths),
                                    len(targets), seed=0)
    assert measured["fid"]["at_most"] == pytest.approx(5 * reference)


def test_motion_evaluation_gives_the_reference_fid_of_training_windows(cache, windows) -> None:
    """The evaluator's reference FID is the FID of the picked training windows' embeddings
    against the test windows'; the test windows score 0 against themselves."""
    from repro.core import metrics
    from repro.gmd.measurements import evaluator_inputs

    train, test = windows
    config = EvaluatorConfig(steps=3, hidden=16, dim=8, batch_size=16,
                             data_id=train.fingerprint)
    evaluation = mg.motion_evaluation(train, test, config, reference_samples=6, seed=4)
    features, lengths = evaluator_inputs(train.space("motion"), train.x)
    picks = np.random.default_rng(4).choice(len(train), 6, replace=False)
    expected = metrics.fid(evaluation.evaluator.embed_motions(features[picks], lengths[:6]),
                           evaluation.test_embeddings)
    assert evaluation.real_fid == pytest.approx(expected, rel=1e-6)
    assert len(evaluation.test_embeddings) == len(test) == len(evaluation.test_lengths)
    assert metrics.fid(evaluation.test_embeddings, evaluation.test_embeddings) == pytest.approx(
        0.0, abs=1e-6)
    again = mg.motion_evaluation(train, test, config, reference_samples=6, seed=5)
    assert again.real_fid != evaluation.real_fid  # the picks follow the seed


def test_the_fid_gates_reference_is_the_mean_of_its_draws_and_draw_0_is_the_single_draw(
        cache, windows) -> None:
    """Gates version 2: the reference FID is the mean over REFERENCE_FID_DRAWS draws of
    training windows; its draw 0 picks the windows the single draw of version 1 picked."""
    from repro.gmd.measurements import evaluator_inputs

    train, test = windows
    config = EvaluatorConfig(steps=3, hidden=16, dim=8, batch_size=16,
                             data_id=train.fingerprint)
    evaluation = mg.motion_evaluation(train, test, config, reference_samples=6, seed=4)
    assert len(evaluation.reference_fid_draws) == mg.REFERENCE_FID_DRAWS
    assert evaluation.reference_fid_draws[0] == pytest.approx(evaluation.real_fid, rel=1e-4)
    assert evaluation.reference_fid == pytest.approx(np.mean(evaluation.reference_fid_draws))
    assert len(set(evaluation.reference_fid_draws)) > 1  # each draw picks other windows
    features, _ = evaluator_inputs(train.space("motion"), train.x)
    args = (evaluation.evaluator, features, train.frames, evaluation.test_embeddings, 6)
    mean, draws = mg.reference_fid(*args, seed=4, draws=3)
    assert draws == pytest.approx(list(evaluation.reference_fid_draws[:3]), rel=1e-4)
    assert mean == pytest.approx(np.mean(draws))
    assert mg.reference_fid(*args, seed=5, draws=3)[1] != draws  # the draws follow the seed
    with pytest.raises(ValueError, match="at least one draw"):
        mg.reference_fid(*args, seed=4, draws=0)
    with pytest.raises(ValueError, match="windows per draw"):
        mg.reference_fid(*args[:4], len(features) + 1, seed=4)
