"""The fitness-gate measurements of tiny GMD's models (gates version 3): known answers, a model
that knows the held-out data passes, a constant one fails; no gate measures what a GMD claim
compares (the registry's parts against ``model_gates.COMPARED``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from repro.claims.registry import CLAIMS
from repro.core import metrics
from repro.core.gates import family_measures, gate_results, gates_markdown, loss_curve
from repro.gmd import model_gates as mg
from repro.gmd.measurements import sample_quality
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


def test_sample_quality_of_a_gliding_body_is_its_speed_and_no_jerk() -> None:
    values = sample_quality(_walk(speed=1.5), fid=0.25)
    assert values["foot_skating"] == pytest.approx(1.5)
    assert values["joint_jerk"] == pytest.approx(0.0, abs=1e-9)
    assert values["fid"] == 0.25
    assert "fid" not in sample_quality(_walk())


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


class _Memorised(torch.nn.Module):
    """An x0 "model" that has learnt the held-out windows: x̂0 is the window w nearest to x_t
    in ‖x_t − √ᾱ_t w‖ (or, ``constant``, the normalised data's mean 0)."""

    def __init__(self, windows: torch.Tensor, alphas: np.ndarray, constant: bool = False):
        super().__init__()
        self.windows, self.alphas, self.constant = windows, alphas, constant
        self.weight = torch.nn.Parameter(torch.zeros(1))

    def forward(self, x_t: torch.Tensor, t: torch.Tensor, **kwargs) -> torch.Tensor:
        if self.constant:
            return torch.zeros_like(x_t)
        scaled = float(np.sqrt(self.alphas[int(t[0])])) * self.windows
        nearest = torch.cdist(x_t.flatten(1), scaled.flatten(1)).argmin(dim=1)
        return self.windows[nearest]


@pytest.mark.parametrize("task", ["trajectory", "motion"])
def test_a_model_that_knows_the_held_out_windows_passes_and_a_constant_fails(
        cache, small_spec, windows, task) -> None:
    train, test = windows
    trained = load_or_train_gmd(small_spec(task=task, prediction="x0"), train)
    family = f"gmd_{task}"
    held = test.channels(task)
    alphas = trained.diffusion.alphas_cumprod

    def measured(constant: bool) -> dict[str, float]:
        model = _Memorised(held, alphas, constant=constant)
        return mg.denoising_gate_values(dataclasses.replace(trained, model=model), test,
                                        train, seed=0)

    learned, trivial = measured(False), measured(True)
    assert learned["x0_error_vs_gaussian"] < 0.1   # a near neighbour picked at high noise
    assert trivial["x0_error_vs_gaussian"] > 1.0
    path = {"path_length": 1.0}
    assert gate_results(family, {**learned, **path}, path, role="treatment")[
        "x0_error_vs_gaussian"]["passed"]
    assert not gate_results(family, {**trivial, **path}, path, role="treatment")[
        "x0_error_vs_gaussian"]["passed"]
    assert measured(True) == trivial  # the same windows and noise for the same seed


def test_the_path_length_gate_passes_the_data_and_fails_a_model_that_stands_still(
        windows) -> None:
    _, test = windows
    trajectory = test.space("trajectory")
    data_path = mg.trajectory_gate_values(trajectory, test.trajectory())
    assert data_path["path_length"] > 0
    fit = {"x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    assert all(g["passed"] for g in gate_results("gmd_trajectory", {**fit, **data_path},
                                                 data_path, role="reference").values())
    # a model that always returns the mean window stands still: no path
    still = mg.trajectory_gate_values(trajectory, torch.zeros_like(test.trajectory()))
    assert still["path_length"] == pytest.approx(0.0, abs=1e-6)
    assert not gate_results("gmd_trajectory", {**fit, **still}, data_path,
                            role="treatment")["path_length"]["passed"]
    # noise on the path: its length may pass, its jerk does not (a reference arm's gate)
    noisy = mg.trajectory_gate_values(trajectory, test.trajectory()
                                      + 0.3 * torch.randn_like(test.trajectory()))
    assert noisy["root_jerk"] > 2 * data_path["root_jerk"]
    assert not gate_results("gmd_trajectory", {**fit, **noisy}, data_path,
                            role="reference")["root_jerk"]["passed"]


def test_no_gate_of_a_treatment_arm_measures_what_a_claim_resting_on_it_compares() -> None:
    """A gate on a treatment arm's outcome makes the claim inconclusive by construction. Every
    measurement a GMD claim's parts read has its quantity in COMPARED, and no gate that a
    family's treatment arms pass measures one of them (the reference arm's sample gates
    bound where a comparison starts, not its sign)."""
    gmd_claims = {cid: claim for cid, claim in CLAIMS.items()
                  if cid.startswith("GMD-") and claim.parts}
    assert set(mg.FAMILIES_READ) == set(gmd_claims)
    for cid, claim in gmd_claims.items():
        compared = {mg.COMPARED[need] for part in claim.parts for need in part.needs}
        for family in mg.FAMILIES_READ[cid]:
            assert not family_measures(family) & compared, (cid, family)


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
                                EvaluatorConfig(dim=16, hidden=32).replace(steps=150))
    measured = dict(train_features=motions, samples=32)
    good = mg.evaluator_gate_values(evaluator, motions, lengths, captions, seed=0, **measured)
    assert good["r_precision_top3"] > 0.3 and good["trivial_fid_ratio"] > 0
    shuffled = [captions[i] for i in rng.permutation(n)]
    bad = mg.evaluator_gate_values(evaluator, motions, lengths, shuffled, seed=0, **measured)
    assert bad["r_precision_top3"] < good["r_precision_top3"]
    assert bad["trivial_fid_ratio"] == good["trivial_fid_ratio"]  # the captions play no part
    texts = evaluator.embed_texts(captions)  # R@3: the mean over R_PRECISION_SHUFFLES shuffles
    embedded = evaluator.embed_motions(motions, lengths)
    assert good["r_precision_top3"] == pytest.approx(np.mean([
        metrics.r_precision(texts, embedded, 32, 3, seed=k)[2]
        for k in range(mg.R_PRECISION_SHUFFLES)]))
    record = mg.evaluator_model_record(evaluator, values=good, reads=["abs_lower_fid"])
    assert record["family"] == "evaluator" and record["steps"] == 150
    assert record["reads"] == ["abs_lower_fid"]
    assert record["name"] == mg.evaluator_model_record(evaluator, values=bad)["name"]


def test_one_caption_each_draws_from_lists_and_keeps_strings() -> None:
    picked = mg.one_caption_each(["a", ["b", "c"], ["d"]], seed=0)
    assert picked[0] == "a" and picked[1] in ("b", "c") and picked[2] == "d"


def test_loss_curve_keeps_short_curves_and_averages_long_ones() -> None:
    assert loss_curve([3.0, 2.0]) == [3.0, 2.0]
    curve = loss_curve(list(range(100)), points=10)
    assert len(curve) == 10 and curve[0] == pytest.approx(4.5) and curve[-1] == pytest.approx(94.5)


def test_gmd_model_record_reads_the_cache_metrics(cache, small_spec, windows) -> None:
    train, test = windows
    trained = load_or_train_gmd(small_spec(), train)
    reference = mg.trajectory_gate_values(test.space("trajectory"), test.trajectory())
    values = {**reference, "x0_error_vs_gaussian": 0.5}
    record = mg.gmd_model_record(trained, family="gmd_trajectory", values=values,
                                 reference=reference, reads=["eps_reaches_goal_better"],
                                 role="reference")
    assert record["steps"] == 3 and record["passed"] and record["precision"] == "fp32"
    assert record["reads"] == ["eps_reaches_goal_better"]
    assert record["train_seconds"] == trained.metrics["seconds"]
    assert record["validation_curve"] == pytest.approx(trained.metrics["losses"])
    assert trained.cache_key[:10] in record["name"] and "seed 0" in record["name"]
    failing = mg.gmd_model_record(trained, family="gmd_trajectory",
                                  values={"x0_error_vs_gaussian": 1.2}, reference=reference,
                                  role="treatment")
    assert not failing["passed"] and failing["gate"]["path_length"]["value"] is None
    assert failing["reads"] is None
    assert "**fail**" in gates_markdown([record, failing])
    with pytest.raises(ValueError, match="family"):
        mg.gmd_model_record(trained, family="vae", values={}, reference={}, role="treatment")


def test_emphasis_study_records_measure_each_variant_in_its_own_space(
        cache, dataset_dir) -> None:
    from repro.gmd.emphasis_projection import experiment as study
    from repro.gmd.emphasis_projection.c4 import emphasis_study_records
    from repro.gmd.models import GMDModelSpec
    from repro.gmd.windows import DataConfig

    data = DataConfig(data_dir=str(dataset_dir), frames=16, stride=4)  # ≥ 32 test windows
    base = GMDModelSpec(task="motion", prediction="x0", text_conditioned=True, data=data,
                        base_channels=8, channel_mults=(1, 2),
                        diffusion_steps=5).replace(steps=2, batch_size=8)
    settings = study.Settings(scale="quick", seeds=1, stand_in_clips=0, stride=4,
                              diffusion_steps=5, train_steps=2, samples=32, evaluator_steps=5,
                              values=(1,))
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    train_relative = load_windows(DataConfig(data_dir=str(dataset_dir), frames=16, stride=4,
                                             representation="relative"))
    evaluator = study.window_evaluator(train_relative, 5)
    results = study.run_experiment(settings, base, train, test, evaluator, [0], log=lambda _: None)
    records = emphasis_study_records(results, base=base, train=train, test=test,
                                     parts={1: ["emphasis_less_foot_skating_at_1"]})
    assert [r["name"].split(" seed")[0] for r in records] == [
        "gmd motion/x0 loss scaling k=1", "gmd motion/x0 Emphasis c=1"]
    assert all(r["reads"] == ["emphasis_less_foot_skating_at_1"] for r in records)
    assert emphasis_study_records(results, base=base, train=train, test=test,
                                  parts={2: ["x"]})[0]["reads"] == []
    assert set(records[0]["gate"]) == {"x0_error_vs_gaussian", "training_plateau"}
    # the Emphasis model is measured in its projected space: the same as by hand
    trained = study.load_or_train_variant(base, study.Variant("emphasis", 1), train, 0)
    assert not torch.allclose(mg.model_space_windows(trained, test), test.channels("motion"))
    again = mg.denoising_gate_values(trained, test, train, seed=0)
    assert records[1]["gate"]["x0_error_vs_gaussian"]["value"] == pytest.approx(
        again["x0_error_vs_gaussian"])


def test_motion_evaluation_gives_the_reference_fid_of_training_windows(cache, windows) -> None:
    """The evaluator's reference FID is the FID of the picked training windows' embeddings
    against the test windows'; the test windows score 0 against themselves."""
    from repro.core import metrics
    from repro.gmd.measurements import evaluator_inputs

    train, test = windows
    config = EvaluatorConfig(hidden=16, dim=8, data_id=train.fingerprint).replace(
        steps=3, batch_size=16)
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
    config = EvaluatorConfig(hidden=16, dim=8, data_id=train.fingerprint).replace(
        steps=3, batch_size=16)
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
