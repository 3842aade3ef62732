"""The EnergyMoGen pipeline (repro.energymogen) and what is measured on it
(repro.energymogen_studies, repro.energymogen_energy): data split, paper tables, the EMG-1
identities on toy fields with known answers, energy maps, the FID check, and a tiny end-to-end
run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from repro.claims.registry import get_claim
from repro.core.diffusion import GaussianDiffusion
from repro.energymogen import energy as em_energy
from repro.energymogen import pipeline as em
from repro.energymogen import studies as em_studies
from repro.models.latent_denoiser import LatentDenoiser
from repro.standin.concepts import can_be_simultaneous

torch.set_num_threads(1)

TINY = em.PipelineConfig(n_train_clips=24, test_clips_per_pair=2, vae_steps=2, text_steps=2,
                         denoiser_steps=2, evaluator_steps=2, ddim_steps=2, items_per_pair=4)


# --- design of the stand-in test ----------------------------------------------------------


def test_held_out_pairs_are_composable_and_never_trained() -> None:
    held = {frozenset(p) for p in em.HELD_OUT_PAIRS}
    assert len(held) == len(em.HELD_OUT_PAIRS) == 10
    assert all(can_be_simultaneous(*p) for p in em.HELD_OUT_PAIRS)
    assert not held & {frozenset(p) for p in em.trained_pairs()}
    for pair, negated in em.NEGATION_CASES:
        assert frozenset(pair) not in held and negated in pair


def test_paper_tables_have_the_registry_rows() -> None:
    assert len(em_studies.PAPER_TABLE7) == 12 and len(em_studies.PAPER_TABLE9) == 6
    for key in ("1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"):
        assert key in em_studies.PAPER_TABLE7
    for key in ("0.0,0.0", "0.1,0.2", "0.001,0.002"):
        assert key in em_studies.PAPER_TABLE9
    assert all(abs(sum(lam) - 1) < 1e-9 for lam in em_studies.TABLE7_LAMBDAS)
    assert em_studies.PAPER_TABLE9["0.001,0.002"]["r_precision_top3"] == 26.3
    assert set(get_claim("EMG-5").measurements) == {"r_precision_top3", "transition_distance"}


def test_sampler_canonical_form() -> None:
    assert em.Sampler("sef", lambdas=(0.0, 0.0, 1.0)).canonical() == em.Sampler("single")
    assert em.Sampler("sef", lambdas=(1.0, 0.0, 0.0)).canonical().mode == "latent"
    sef = em.Sampler("sef", lambdas=(0.1, 0.7, 0.2))
    assert sef.canonical() is sef


def test_scaled_linear_betas() -> None:
    betas = em.scaled_linear_betas(1000)
    assert betas[0] == pytest.approx(0.00085) and betas[-1] == pytest.approx(0.012)
    with pytest.raises(ValueError):
        em.scaled_linear_betas(1000, 0.02, 0.01)


# --- EMG-1 ---------------------------------------------------------------------------------


def test_sampler_steps_are_langevin_steps() -> None:
    diffusion = GaussianDiffusion(em.scaled_linear_betas(100))
    z = torch.randn(3, 2, 4, generator=torch.Generator().manual_seed(0))
    errors = em_energy.langevin_step_errors(diffusion,
                                            lambda x, t: torch.tanh(x) + 0.1 * t[:, None, None],
                                            z, timesteps=range(100), ddim_steps=10)
    assert errors["max_abs_error"] < 1e-10 and errors["ddim_max_abs_error"] < 1e-10
    assert 0 < errors["ddpm_eps_coefficient_min"] < errors["ddpm_eps_coefficient_max"] < 1


def test_jacobian_asymmetry_of_known_fields() -> None:
    gen = torch.Generator().manual_seed(1)
    a = torch.randn(6, 6, generator=gen, dtype=torch.float64)
    sym = a + a.T
    z = torch.randn(4, 2, 3, generator=gen, dtype=torch.float64)
    gradient_field = em_energy.jacobian_asymmetry(
        lambda x: (x.reshape(-1, 6) @ sym + x.reshape(-1, 6) ** 3).reshape(x.shape), z)
    assert np.all(gradient_field < 1e-12)
    linear = em_energy.jacobian_asymmetry(lambda x: (x.reshape(-1, 6) @ a.T).reshape(x.shape), z)
    assert linear == pytest.approx(float((a - a.T).norm() / a.norm()), rel=1e-10)


def test_line_integral_energy_of_a_quadratic() -> None:
    gen = torch.Generator().manual_seed(2)
    a = torch.randn(5, 5, generator=gen, dtype=torch.float64)
    s = a @ a.T
    z = torch.randn(3, 5, generator=gen, dtype=torch.float64)
    energy = em_energy.line_integral_energy(lambda x: x @ s, z)
    assert torch.allclose(energy, 0.5 * ((z @ s) * z).sum(1), atol=1e-12)


def test_energy_of_eq7_is_the_weighted_sum_of_energies() -> None:
    torch.manual_seed(0)
    model = LatentDenoiser(4, 3, 4, width=16, layers=2, heads=2).eval()
    conds = [(torch.randn(1, 2, 4), torch.ones(1, 2, dtype=torch.bool)) for _ in range(2)]
    z = torch.randn(2, 3, 4)
    out = em_energy.energy_linearity_error(model, z, 10, conds, [2.5, -1.0], nodes=8)
    assert out["max_abs_error"] < 1e-9 * max(1.0, out["max_energy"])
    assert out["gradient_relative_error"] > 1e-6      # a random network is not conservative


# --- EMG-6 and EMG-9 -----------------------------------------------------------------------


def test_latent_plane_and_maps() -> None:
    gen = torch.Generator().manual_seed(3)
    latents = torch.randn(20, 3, 4, generator=gen)
    plane = em_energy.latent_plane(latents)
    u, v, grid = plane.grid(5)
    assert grid.shape == (25, 3, 4) and len(u) == len(v) == 5
    assert np.all(np.abs(plane.scores) <= np.array(plane.extent) + 1e-6)
    smooth = em_energy.smooth_energy_map(np.arange(25.0).reshape(5, 5), upsample=2, sigma=1.0)
    assert smooth.shape == (10, 10)
    assert em_energy.map_similarity(smooth, 2 * smooth + 1) == pytest.approx(1.0)


def test_energy_landscape_combines_linearly() -> None:
    torch.manual_seed(0)
    model = LatentDenoiser(4, 3, 4, width=16, layers=2, heads=2).eval()
    diffusion = GaussianDiffusion(em.scaled_linear_betas(50))
    cond = (torch.randn(1, 2, 4), torch.ones(1, 2, dtype=torch.bool))
    latents = torch.randn(6, 3, 4)
    maps = em_energy.energy_landscape(model, diffusion, latents, {"∅": None, "c": cond},
                                      {"c": {"c": 1.0}, "same": {"∅": 0.0, "c": 1.0},
                                       "uncond": {"∅": 1.0}},
                                      timesteps=(5, 25), n_noise=2, seed=0, chunk=4)
    assert maps["c"].shape == (6,)
    assert np.allclose(maps["c"], maps["same"])
    assert not np.allclose(maps["c"], maps["uncond"])


def test_fid_formula_check() -> None:
    out = em_energy.fid_formula_errors(seed=0, dim=8, draws=5)
    assert out["fid_vs_closed_form_relative_error"] < 1e-6
    assert out["printed_vs_closed_form_relative_error"] > 1e-3


# --- end to end ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tiny_pipeline(tmp_path_factory: pytest.TempPathFactory) -> em.EnergyMoGenPipeline:
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("REPRO_CACHE_DIR", str(cache))
        pipe = em.load_pipeline(TINY, log=None)
        again = em.load_pipeline(TINY, log=None)          # every stage from the cache
    for a, b in zip(pipe.denoiser.parameters(), again.denoiser.parameters(), strict=True):
        assert torch.equal(a, b)
    assert (Path(cache) / "emg_data").is_dir()
    return pipe


def test_data_holds_out_pairs(tiny_pipeline: em.EnergyMoGenPipeline) -> None:
    data = tiny_pipeline.data
    held = {frozenset(p) for p in em.HELD_OUT_PAIRS}
    assert all(frozenset(c) not in held for c in data.train_concepts)
    assert data.train_features.shape == (24, em.FRAMES, 263)
    assert data.test_joints.shape == (20, em.FRAMES, 22, 3)
    words = {w for caps in data.train_captions for c in caps for w in c.lower().split()}
    assert all(w.strip(".,") in tiny_pipeline.vocab for w in words)
    tokens, mask = tiny_pipeline.encode(["a person waves the left hand.", "someone claps."])
    assert tokens.shape[:2] == mask.shape and mask.sum(1).tolist() == [6, 2]


def test_items_sampling_and_metrics(tiny_pipeline: em.EnergyMoGenPipeline) -> None:
    pipe = tiny_pipeline
    items = em.composition_items(pipe.data, seed=0, per_pair=4)
    assert len(items) == 40 and len(items.concept_texts) == 2
    assert em.composition_items(pipe.data, 0, 4).multi_texts == items.multi_texts
    rows = {"0.1,0.7,0.2": em.Sampler("sef"), "0.0,0.0,1.0": em.Sampler("sef", (0.0, 0.0, 1.0)),
            "0.0,0.0": em.Sampler("single"),
            "0.1,0.2": em.Sampler("single", gammas=(0.1, 0.2))}
    results = em_studies.run_rows(pipe, rows, seeds=[0])
    assert results["0.0,0.0"] == results["0.0,0.0,1.0"]    # one sampler, sampled once
    assert set(results["real"]) >= {"r_precision_top3", "transition_distance", "fid",
                                    "oracle_accuracy"}
    assert results["real"]["both_present"][0] > 0.9       # the oracles see the ground truth
    table = em_studies.markdown_table(results, [("SEF", "0.1,0.7,0.2")], em_studies.PAPER_TABLE7)
    assert "[28.0]" in table
    assert em_studies.agd_relative_change(pipe, items.multi_texts[:4], (0.1, 0.2)) > 0.0
    assert em_studies.agd_relative_change(pipe, items.multi_texts[:4], (0.0, 0.0)) == 0.0


def test_sets_of_three_concepts(tiny_pipeline: em.EnergyMoGenPipeline, tmp_path: Path,
                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    pipe = tiny_pipeline
    assert len(em.THREE_CONCEPT_SETS) == len(em.LOWER_CONCEPTS)
    pool = em.load_or_build_test_pool(pipe.config, "threes")
    assert pool.features.shape == (2 * len(em.THREE_CONCEPT_SETS), em.FRAMES, 263)
    again = em.load_or_build_test_pool(pipe.config, "threes")           # from the cache
    assert np.array_equal(again.joints, pool.joints) and again.captions == pool.captions
    assert all(" and " in c for caps in pool.captions for c in caps)
    items = em.composition_items(pipe.data, 0, 5, pool)
    assert len(items) == 35 and len(items.concept_texts) == 3
    assert {c for c in items.concepts} == set(em.THREE_CONCEPT_SETS)
    mixed = em.CompositionPool(np.concatenate([pool.features, pipe.data.test_features]),
                               np.concatenate([pool.joints, pipe.data.test_joints]),
                               pool.captions + pipe.data.test_captions,
                               pool.concepts + pipe.data.test_concepts)
    with pytest.raises(ValueError, match="one concept count"):
        em.composition_items(pipe.data, 0, 5, mixed)
    results = em_studies.run_rows(pipe, {"SEF": em.Sampler("sef")}, [0], test_set="threes")
    assert results["real"]["both_present"][0] > 0.9       # all three seen on the ground truth
    assert "oracle_accuracy_concept_3" in results["SEF"]
    assert results["SEF"]["fid"][0] != pytest.approx(
        em_studies.run_rows(pipe, {"SEF": em.Sampler("sef")}, [0])["SEF"]["fid"][0])
    control = em.load_or_build_test_pool(pipe.config, "threes_as_pairs")
    assert {c for c in control.concepts} == set(em.THREES_AS_PAIRS)
    assert em.load_or_build_test_pool(pipe.config, "pairs").concepts == pipe.data.test_concepts
    with pytest.raises(ValueError, match="unknown test set 'fours'"):
        em.load_or_build_test_pool(pipe.config, "fours")


def test_oracle_counts_both_arms_waving_as_each_arm_only_for_sets_naming_both() -> None:
    joints = em.build_composition_pool([("squat", "wave_both")], 1, 0, 7).joints
    three = em_studies.oracle_presence(joints, [("squat", "wave_left", "wave_right")])
    assert three.tolist() == [[True, True, True]]
    one_arm = em_studies.oracle_presence(joints, [("squat", "wave_left")])
    assert one_arm.tolist() == [[True, False]]             # one arm named: the oracle's call


def test_studies_run(tiny_pipeline: em.EnergyMoGenPipeline) -> None:
    study = em_studies.composition_study(tiny_pipeline, seeds=[0], per_case=2)
    for mode in ("latent", "semantic"):
        assert set(study[mode]) == set(get_claim("EMG-2").measurements)
        assert all(len(v) == 1 for v in study[mode].values())
    case = em_energy.energy_map_case(tiny_pipeline, "negation", 0, seed=0, grid=4, n_noise=1,
                                     timesteps=(100,), samples=4, upsample=2, sigma=1.0)
    assert case["smooth"]["composed"].shape == (8, 8)
    assert -1.0 <= case["similarity_to_multi"] <= 1.0
