"""Notebook 04's measurements (repro.energymogen.energy_contour_maps): EMG-1's identities on toy
fields with known answers and its per-t measurements, EMG-6's maps, EMG-9's FID check (its
fixed cases: test_fid_checks.py), and one energy-map case on the tiny pipeline."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.core.diffusion import GaussianDiffusion
from repro.energymogen.energy_contour_maps import emg1, emg6, emg9
from repro.energymogen.energy_contour_maps.emg1 import (
    flat_jacobian,
    loop_plane,
    relative_circulation,
    residual_asymmetry,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline, scaled_linear_betas
from repro.energymogen.settings import HELD_OUT_PAIRS
from repro.models.latent_denoiser import LatentDenoiser

# --- EMG-1 ---------------------------------------------------------------------------------


def test_sampler_steps_are_langevin_steps() -> None:
    diffusion = GaussianDiffusion(scaled_linear_betas(100))
    z = torch.randn(3, 2, 4, generator=torch.Generator().manual_seed(0))
    errors = emg1.langevin_step_errors(diffusion,
                                             lambda x, t: torch.tanh(x) + 0.1 * t[:, None, None],
                                             z, timesteps=range(100), ddim_steps=10)
    assert errors["max_abs_error"] < 1e-10 and errors["ddim_max_abs_error"] < 1e-10
    assert 0 < errors["ddpm_eps_coefficient_min"] < errors["ddpm_eps_coefficient_max"] < 1


def test_jacobian_asymmetry_of_known_fields() -> None:
    gen = torch.Generator().manual_seed(1)
    a = torch.randn(6, 6, generator=gen, dtype=torch.float64)
    sym = a + a.T
    z = torch.randn(4, 2, 3, generator=gen, dtype=torch.float64)
    gradient_field = emg1.jacobian_asymmetry(
        lambda x: (x.reshape(-1, 6) @ sym + x.reshape(-1, 6) ** 3).reshape(x.shape), z)
    assert np.all(gradient_field < 1e-12)
    linear = emg1.jacobian_asymmetry(lambda x: (x.reshape(-1, 6) @ a.T).reshape(x.shape), z)
    assert linear == pytest.approx(float((a - a.T).norm() / a.norm()), rel=1e-10)


def test_line_integral_energy_of_a_quadratic() -> None:
    gen = torch.Generator().manual_seed(2)
    a = torch.randn(5, 5, generator=gen, dtype=torch.float64)
    s = a @ a.T
    z = torch.randn(3, 5, generator=gen, dtype=torch.float64)
    energy = emg1.line_integral_energy(lambda x: x @ s, z)
    assert torch.allclose(energy, 0.5 * ((z @ s) * z).sum(1), atol=1e-12)


def test_energy_of_eq7_is_the_weighted_sum_of_energies() -> None:
    torch.manual_seed(0)
    model = LatentDenoiser(4, 3, 4, width=16, layers=2, heads=2).eval()
    conds = [(torch.randn(1, 2, 4), torch.ones(1, 2, dtype=torch.bool)) for _ in range(2)]
    z = torch.randn(2, 3, 4)
    out = emg1.energy_linearity_error(model, z, 10, conds, [2.5, -1.0], nodes=8)
    assert out["max_abs_error"] < 1e-9 * max(1.0, out["max_energy"])
    assert out["gradient_relative_error"] > 1e-6      # a random network is not conservative


# --- EMG-6 and EMG-9 -----------------------------------------------------------------------


def test_latent_plane_and_maps() -> None:
    gen = torch.Generator().manual_seed(3)
    latents = torch.randn(20, 3, 4, generator=gen)
    plane = emg6.latent_plane(latents)
    u, v, grid = plane.grid(5)
    assert grid.shape == (25, 3, 4) and len(u) == len(v) == 5
    assert np.all(np.abs(plane.scores) <= np.array(plane.extent) + 1e-6)
    smooth = emg6.smooth_energy_map(np.arange(25.0).reshape(5, 5), upsample=2, sigma=1.0)
    assert smooth.shape == (10, 10)
    assert emg6.map_similarity(smooth, 2 * smooth + 1) == pytest.approx(1.0)


def test_energy_landscape_combines_linearly() -> None:
    torch.manual_seed(0)
    model = LatentDenoiser(4, 3, 4, width=16, layers=2, heads=2).eval()
    diffusion = GaussianDiffusion(scaled_linear_betas(50))
    cond = (torch.randn(1, 2, 4), torch.ones(1, 2, dtype=torch.bool))
    latents = torch.randn(6, 3, 4)
    maps = emg6.energy_landscape(model, diffusion, latents, {"∅": None, "c": cond},
                                       {"c": {"c": 1.0}, "same": {"∅": 0.0, "c": 1.0},
                                        "uncond": {"∅": 1.0}},
                                       timesteps=(5, 25), n_noise=2, seed=0, chunk=4)
    assert maps["c"].shape == (6,)
    assert np.allclose(maps["c"], maps["same"])
    assert not np.allclose(maps["c"], maps["uncond"])


def test_fid_formula_check() -> None:
    out = emg9.fid_formula_errors(seed=0, dim=8, draws=5)
    assert out["fid_vs_closed_form_relative_error"] < 1e-6
    assert out["printed_vs_closed_form_relative_error"] > 1e-3


def test_energy_map_case_on_the_tiny_pipeline(tiny_pipeline: EnergyMoGenPipeline) -> None:
    case = emg6.energy_map_case(tiny_pipeline, "negation", 0, seed=0, grid=4, n_noise=1,
                                      timesteps=(100,), samples=4, upsample=2, sigma=1.0)
    assert case["smooth"]["composed"].shape == (8, 8)
    assert -1.0 <= case["similarity_to_multi"] <= 1.0
    assert case["texts"]["ceiling"] != case["texts"]["multi"]
    assert -1.0 <= case["similarity_floor"] <= 1.0 and -1.0 <= case["similarity_ceiling"] <= 1.0
    cases = emg6.energy_map_cases(tiny_pipeline, "conjunction", 0, count=2, grid=4,
                                        n_noise=1, timesteps=(100,), samples=4, upsample=2,
                                        sigma=1.0)
    assert [c["case"] for c in cases] == ["/".join(p) for p in HELD_OUT_PAIRS[:2]]


def test_energy_view_study_on_the_tiny_pipeline(tiny_pipeline: EnergyMoGenPipeline) -> None:
    out = emg1.energy_view_study(tiny_pipeline, 0, samples=2, linearity_timesteps=(100,),
                                       jacobian_timesteps=(100, 900))
    assert out["langevin"]["max_abs_error"] < 1e-8          # an identity, trained or not
    assert len(out["linearity"]) == 1
    assert out["sum_error"] == out["linearity"][0]["max_abs_error"]
    assert out["sum_error"] < 1e-8 * max(1.0, out["linearity"][0]["max_energy"])
    assert set(out["asymmetry"]) == {"trained, text", "trained, ∅", "random init, text"}
    assert all(v.shape == (2, 2) for v in out["asymmetry"].values())
    pooled = np.concatenate([out["asymmetry"]["trained, text"].ravel(),
                             out["asymmetry"]["trained, ∅"].ravel()])
    assert out["jacobian_median"] == pytest.approx(float(np.median(pooled)))


def _field(rng: np.random.Generator) -> np.ndarray:
    return emg6.smooth_energy_map(rng.standard_normal((8, 8)))


def test_floor_and_ceiling_order_on_a_constructed_case() -> None:
    """Multi-concept map M; its paraphrase M plus a little noise (ceiling); the composition M
    plus more; each concept a quarter of M in its own noise: floor < composed < ceiling, and
    the conjunction's floor is the better of the two concepts."""
    rng = np.random.default_rng(0)
    multi = _field(rng)
    smooth = {"multi-concept": multi, "paraphrase": multi + 0.2 * _field(rng),
              "composed": multi + 0.8 * _field(rng), "concept 1": 0.25 * multi + _field(rng),
              "concept 2": 0.5 * multi + _field(rng), "control": _field(rng)}
    sim = emg6.case_similarities(smooth, "conjunction")
    assert sim["similarity_floor"] < sim["similarity_to_multi"] < sim["similarity_ceiling"]
    assert sim["similarity_floor"] == max(sim["similarity_concept_1_to_multi"],
                                          sim["similarity_concept_2_to_multi"])
    negation = emg6.case_similarities(smooth, "negation")
    assert negation["similarity_floor"] == sim["similarity_concept_1_to_multi"]
    measured = emg6.map_similarities({"conjunction": [[sim, sim], [sim]]})
    assert measured["conjunction_similarity_floor"] == [sim["similarity_floor"]] * 2
    assert set(measured) == {f"conjunction_{k}" for k in (
        "similarity_to_multi", "similarity_floor", "similarity_ceiling",
        "similarity_to_control")}


def _matrices(dim: int = 8) -> tuple[torch.Tensor, torch.Tensor]:
    a = torch.randn(dim, dim, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    return a + a.T, a - a.T


def test_a_symmetric_linear_field_has_no_asymmetry_and_no_circulation() -> None:
    sym, _ = _matrices()
    z = torch.randn(1, 8, dtype=torch.float64)
    jac = flat_jacobian(lambda x: x @ sym.T, z)
    assert torch.allclose(jac, sym)
    assert residual_asymmetry(jac, 0.0) == 0.0
    u, v = loop_plane(jac + 1e-3 * _matrices()[1])
    assert relative_circulation(lambda x: x @ sym.T, z, u, v, 0.5) < 1e-12


def test_a_rotation_circulates_fully_around_its_centre() -> None:
    _, anti = _matrices()
    jac = flat_jacobian(lambda x: x @ anti.T, torch.zeros(1, 8, dtype=torch.float64))
    assert abs(residual_asymmetry(jac, 0.0) - 2.0) < 1e-12
    u, v = loop_plane(jac)
    assert relative_circulation(lambda x: x @ anti.T, torch.zeros(1, 8, dtype=torch.float64),
                                u, v, 1.0) > 0.999


def test_a_nonlinear_gradient_field_has_no_circulation() -> None:
    w = torch.randn(8, 8, dtype=torch.float64, generator=torch.Generator().manual_seed(1))

    def grad(x: torch.Tensor) -> torch.Tensor:      # ∇ Σ cos(x W)
        return -torch.sin(x @ w) @ w.T

    z = torch.randn(1, 8, dtype=torch.float64, generator=torch.Generator().manual_seed(2))
    jac = flat_jacobian(grad, z)
    assert residual_asymmetry(jac, 3.0) < 1e-12
    u, v = loop_plane(jac + 1e-3 * _matrices()[1])
    assert relative_circulation(grad, z, u, v, 0.3) < 1e-6


def test_the_identity_term_changes_only_the_denominator() -> None:
    sym, anti = _matrices()
    jac = sym + 0.1 * anti
    assert residual_asymmetry(jac, 5.0) != residual_asymmetry(jac, 0.0)
    assert residual_asymmetry(jac + 5.0 * torch.eye(8, dtype=torch.float64), 5.0) == \
        residual_asymmetry(jac, 0.0)


def _nonlinear_field(dim: int = 8) -> emg1.EpsFn:
    """A field with a Jacobian neither symmetric nor antisymmetric (tanh of a random map)."""
    w = torch.randn(dim, dim, dtype=torch.float64, generator=torch.Generator().manual_seed(3))
    return lambda x: torch.tanh(x @ w.T) + 0.5 * x


@pytest.mark.parametrize("radius", [0.2, 1.0])
def test_emg1_controls_read_zero_for_the_gradient_and_twice_the_tolerance_for_the_null(
        radius: float) -> None:
    eps = _nonlinear_field()
    z = torch.randn(1, 8, dtype=torch.float64, generator=torch.Generator().manual_seed(4))
    jac = flat_jacobian(eps, z)
    planted = emg1.planted_fields(eps, z, jac, 2.0, radius)
    asym, loop, k = planted["positive"]
    assert asym < 1e-12 and loop < 1e-9 and k == 0.0
    asym, loop, k = planted["null"]
    assert asym >= emg1.EMG1_NULL_READING - 1e-9 and loop >= emg1.EMG1_NULL_READING
    assert k > 0 and min(asym, loop) < emg1.EMG1_NULL_READING + 0.01   # the smallest such k
    assert emg1.linear_field(eps(z), z, jac)(z) == pytest.approx(eps(z))   # ε₀ at the centre


def test_emg1_controls_are_decided_by_the_rule_on_the_tiny_pipeline(
        tiny_pipeline: EnergyMoGenPipeline) -> None:
    from repro.claims.registry import get_claim

    field = emg1.gradient_field_study(tiny_pipeline, 0, samples=2, timesteps=(100, 900))
    assert set(field["controls"]) == {"positive", "null"}
    assert len(field["null_scale_by_t"]["100"]) == 4          # every point: 2 samples × 2 conds
    measured = {"langevin_step_max_abs_error": 1e-14, "sum_of_energies_max_abs_error": 1e-14,
                "jacobian_relative_asymmetry": 0.5,
                "residual_jacobian_asymmetry_by_t": field["residual_jacobian_asymmetry_by_t"],
                "loop_integral_relative_by_t": field["loop_integral_relative_by_t"]}
    controls = emg1.gradient_field_controls(measured, field)
    claim = get_claim("EMG-1")
    assert claim.decide(controls.positive, control=True).verdict == "reproduced"
    assert claim.decide(controls.null, control=True).verdict == "not reproduced"
    assert controls.null["langevin_step_max_abs_error"] == 1e-14     # the experiment's algebra
    assert all(v >= emg1.EMG1_NULL_READING - 1e-6
                for v in controls.null["loop_integral_relative_by_t"].values())
