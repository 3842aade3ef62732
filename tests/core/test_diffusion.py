"""GaussianDiffusion: schedules, GMD Eq. 1–2 coefficients, losses, samplers, guidance, imputation.

Sampler tests use an *oracle* denoiser for Gaussian data x0 ~ N(m, s²) whose posterior
E[x0 | x_t] is known in closed form, so sample statistics have exact targets.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from repro.core.diffusion import (
    GaussianDiffusion,
    Guidance,
    Imputation,
    UniformSampler,
    cosine_betas,
    linear_betas,
)

torch.set_num_threads(1)


class GaussianOracle:
    """Exact denoiser for x0 ~ N(m, s² I): E[x0|x_t] = m + √ᾱ s²/(ᾱ s² + 1 − ᾱ)·(x_t − √ᾱ m)."""

    def __init__(self, diffusion: GaussianDiffusion, m: float, s: float, predict: str):
        self.alpha_bar = torch.from_numpy(diffusion.alphas_cumprod)
        self.m, self.s, self.predict = m, s, predict

    def __call__(self, x_t, t, **kwargs):
        ab = self.alpha_bar[t].to(x_t.dtype).reshape(-1, *([1] * (x_t.dim() - 1)))
        x0 = self.m + ab.sqrt() * self.s**2 / (ab * self.s**2 + 1 - ab) * (x_t - ab.sqrt() * self.m)
        if self.predict == "x0":
            return x0
        return (x_t - ab.sqrt() * x0) / (1 - ab).sqrt()


# -- schedules -----------------------------------------------------------------------------------


def test_cosine_schedule_matches_direct_formula_and_is_monotone():
    T = 1000
    betas = cosine_betas(T)

    def alpha_bar(u: float) -> float:
        return math.cos((u / T + 0.008) / 1.008 * math.pi / 2) ** 2

    expected = [min(1 - alpha_bar(i + 1) / alpha_bar(i), 0.999) for i in range(T)]
    np.testing.assert_allclose(betas, expected, rtol=1e-12, atol=0)
    ab = GaussianDiffusion(betas).alphas_cumprod
    assert np.all(np.diff(ab) < 0)
    assert np.all((ab > 0) & (ab < 1))
    assert betas.max() == pytest.approx(0.999)  # the last step is clipped


def test_linear_schedule_endpoints_scale_with_T():
    np.testing.assert_allclose(linear_betas(1000)[[0, -1]], [1e-4, 0.02])
    np.testing.assert_allclose(linear_betas(100)[[0, -1]], [1e-3, 0.2])
    with pytest.raises(ValueError, match="num_timesteps > 20"):
        linear_betas(20)
    with pytest.raises(ValueError, match="positive integer"):
        cosine_betas(0)


# -- coefficients (GMD Eq. 1-2) ------------------------------------------------------------------


@pytest.mark.parametrize("betas", [cosine_betas(1000), linear_betas(1000)], ids=["cos", "lin"])
def test_coefficients_against_independent_float64_loop(betas):
    d = GaussianDiffusion(betas)
    ab_prev = 1.0
    for t, beta in enumerate(betas.tolist()):
        alpha = 1.0 - beta
        ab = ab_prev * alpha
        a = beta * math.sqrt(ab_prev) / (1 - ab)
        b = math.sqrt(1 - beta) * (1 - ab_prev) / (1 - ab)
        assert d.alphas_cumprod[t] == pytest.approx(ab, rel=1e-12)
        assert d.alphas_cumprod_prev[t] == pytest.approx(ab_prev, rel=1e-12)
        assert d.posterior_variance[t] == pytest.approx((1 - ab_prev) / (1 - ab) * beta,
                                                        rel=1e-12, abs=1e-300)
        assert d.posterior_mean_coef_x0[t] == pytest.approx(a, rel=1e-12)
        assert d.posterior_mean_coef_xt[t] == pytest.approx(b, rel=1e-12, abs=1e-300)
        # c = 1/√α_t and d = β_t/(√α_t √(1 − ᾱ_t)): the closed forms, not the definitions
        assert d.eps_mean_coef_xt[t] == pytest.approx(1 / math.sqrt(alpha), rel=1e-9)
        assert d.eps_mean_coef_eps[t] == pytest.approx(
            beta / (math.sqrt(alpha) * math.sqrt(1 - ab)), rel=1e-9)
        ab_prev = ab
    assert d.posterior_log_variance_clipped[0] == pytest.approx(math.log(d.posterior_variance[1]))
    np.testing.assert_allclose(d.posterior_log_variance_clipped[1:],
                               np.log(d.posterior_variance[1:]), rtol=1e-12)


@pytest.mark.parametrize("prediction", ["x0", "epsilon"])
def test_both_forms_of_posterior_mean_agree_for_every_t(prediction):
    d = GaussianDiffusion(cosine_betas(1000), prediction)
    g = torch.Generator().manual_seed(1)
    t = torch.arange(1000)
    x0 = torch.randn(1000, 3, 8, generator=g, dtype=torch.float64)
    eps = torch.randn(1000, 3, 8, generator=g, dtype=torch.float64)
    x_t = d.q_sample(x0, t, eps)
    mu_eq1 = d.q_posterior_mean(x0, x_t, t)            # a·x0 + b·x_t
    mu_eq2 = d.posterior_mean_from_eps(x_t, eps, t)    # c·x_t − d·ε
    scale = 1 + mu_eq1.abs().amax(dim=(1, 2))
    assert ((mu_eq1 - mu_eq2).abs().amax(dim=(1, 2)) / scale).max() < 1e-10


def test_printed_eq2_coefficient_is_wrong_away_from_t0():
    d = GaussianDiffusion(cosine_betas(1000))
    correct, printed = d.eps_mean_coef_xt, d.eps_mean_coef_xt_as_printed
    np.testing.assert_allclose(correct, 1 / np.sqrt(d.alphas), rtol=1e-9)
    relative_error = printed / correct - 1
    assert relative_error[0] < 1e-4                        # ᾱ ≈ 1: the typo is invisible
    assert 1e-3 < relative_error[500] < 1e-2               # mid-schedule: 0.26 %
    assert relative_error[900] > 0.1 and relative_error[999] > 1e3   # ᾱ → 0: it explodes


# -- forward process, conversions, losses ---------------------------------------------------------


def test_q_sample_statistics():
    d = GaussianDiffusion(cosine_betas(1000))
    g = torch.Generator().manual_seed(0)
    for step in (0, 300, 700, 999):
        x0 = torch.full((200_000,), 1.5, dtype=torch.float64)
        t = torch.full((200_000,), step)
        x_t = d.q_sample(x0, t, torch.randn(200_000, generator=g, dtype=torch.float64))
        assert x_t.mean().item() == pytest.approx(1.5 * d.sqrt_alphas_cumprod[step], abs=0.01)
        assert x_t.std().item() == pytest.approx(d.sqrt_one_minus_alphas_cumprod[step],
                                                 rel=0.01)


def test_x0_eps_round_trip():
    d = GaussianDiffusion(cosine_betas(1000))
    g = torch.Generator().manual_seed(2)
    t = torch.randint(0, 999, (64,), generator=g)   # t = 999 has ᾱ ≈ 1e-8: ill-conditioned
    x0 = torch.randn(64, 4, 16, generator=g, dtype=torch.float64)
    eps = torch.randn(64, 4, 16, generator=g, dtype=torch.float64)
    x_t = d.q_sample(x0, t, eps)
    torch.testing.assert_close(d.predict_x0_from_eps(x_t, t, eps), x0, rtol=1e-8, atol=1e-8)
    torch.testing.assert_close(d.predict_eps_from_x0(x_t, t, x0), eps, rtol=1e-8, atol=1e-8)


def test_p_mean_variance_of_an_exact_eps_model_recovers_x0_and_eq1_mean():
    d = GaussianDiffusion(cosine_betas(100), "epsilon")
    g = torch.Generator().manual_seed(3)
    t = torch.randint(0, 100, (16,), generator=g)
    x0 = torch.randn(16, 2, 4, generator=g, dtype=torch.float64)
    eps = torch.randn(16, 2, 4, generator=g, dtype=torch.float64)
    x_t = d.q_sample(x0, t, eps)
    out = d.p_mean_variance(lambda x, tt: eps, x_t, t)
    torch.testing.assert_close(out.pred_x0, x0)
    torch.testing.assert_close(out.mean, d.q_posterior_mean(x0, x_t, t))
    torch.testing.assert_close(out.variance[:, 0, 0],
                               torch.from_numpy(d.posterior_variance)[t])


def test_training_losses_targets_weights_and_mask():
    x0 = torch.randn(3, 5, 8, generator=torch.Generator().manual_seed(4))
    t = torch.tensor([1, 50, 99])
    zero_model = lambda x, tt: torch.zeros_like(x)  # noqa: E731
    d_x0 = GaussianDiffusion(cosine_betas(100), "x0")
    d_eps = GaussianDiffusion(cosine_betas(100), "epsilon")
    noise = torch.randn_like(x0)
    torch.testing.assert_close(d_x0.training_losses(zero_model, x0, t, noise=noise),
                               x0.pow(2).mean(dim=(1, 2)))
    torch.testing.assert_close(d_eps.training_losses(zero_model, x0, t, noise=noise),
                               noise.pow(2).mean(dim=(1, 2)))
    w = torch.tensor([4.0, 4.0, 1.0, 1.0, 1.0])          # k² = 4 on the first two features
    expected = (w[None, :, None] * x0**2).sum(dim=(1, 2)) / (w.sum() * 8)
    torch.testing.assert_close(d_x0.training_losses(zero_model, x0, t, noise=noise,
                                                    feature_weights=w), expected)
    mask = torch.ones(3, 8, dtype=torch.bool)
    mask[:, 6:] = False
    padded = x0.clone()
    padded[:, :, 6:] = 1e6                                 # padding must not count
    torch.testing.assert_close(d_x0.training_losses(zero_model, padded, t, noise=noise,
                                                    mask=mask),
                               x0[:, :, :6].pow(2).mean(dim=(1, 2)))
    torch.testing.assert_close(d_x0.training_losses(zero_model, padded, t, noise=noise,
                                                    mask=mask[:, None, :]),
                               x0[:, :, :6].pow(2).mean(dim=(1, 2)))
    with pytest.raises(ValueError, match="feature_weights must have shape"):
        d_x0.training_losses(zero_model, x0, t, feature_weights=torch.ones(4))
    with pytest.raises(ValueError, match="mask must be"):
        d_x0.training_losses(zero_model, x0, t, mask=torch.ones(3, 7))
    with pytest.raises(ValueError, match="no valid frame"):
        d_x0.training_losses(zero_model, x0, t, mask=torch.zeros(3, 8))


def test_constructor_and_sampler_validation():
    with pytest.raises(ValueError, match="prediction"):
        GaussianDiffusion(cosine_betas(10), "v")
    with pytest.raises(ValueError, match=r"\(0, 1\)"):
        GaussianDiffusion(np.array([0.1, 1.0]))
    d = GaussianDiffusion(cosine_betas(10))
    oracle = GaussianOracle(d, 0.0, 1.0, "epsilon")
    with pytest.raises(ValueError, match="stop_guidance_at"):
        d.p_sample_loop(oracle, (2, 1, 4), stop_guidance_at=11)
    with pytest.raises(ValueError, match="does not broadcast"):
        d.p_sample_loop(oracle, (2, 1, 4), imputation=Imputation(torch.ones(3, 1, 4),
                                                                  torch.zeros(2, 1, 4)))
    with pytest.raises(ValueError, match="target shape"):
        d.p_sample_loop(oracle, (2, 1, 4), imputation=Imputation(torch.ones(1, 1, 4),
                                                                  torch.zeros(3, 2, 1, 4)))
    with pytest.raises(ValueError, match="either generator or seed"):
        d.p_sample_loop(oracle, (2, 1, 4), seed=1, generator=torch.Generator())
    with pytest.raises(ValueError, match="DDIM steps"):
        d.ddim_sample_loop(oracle, (2, 1, 4), steps=11)


def test_uniform_sampler_covers_range_reproducibly():
    sampler = UniformSampler(10)
    a = sampler.sample(5000, generator=torch.Generator().manual_seed(0))
    b = sampler.sample(5000, generator=torch.Generator().manual_seed(0))
    assert torch.equal(a, b) and a.dtype == torch.long
    assert set(a.tolist()) == set(range(10))
    np.testing.assert_allclose(sampler.weights(), np.ones(10))


# -- ancestral sampling -------------------------------------------------------------------------


@pytest.mark.parametrize("prediction", ["x0", "epsilon"])
def test_ancestral_sampling_with_oracle_reaches_data_distribution(prediction):
    # fixed-small variance β̃_t under-disperses slightly: std 0.386 at T = 100, 0.397 at 1000
    d = GaussianDiffusion(cosine_betas(1000), prediction)
    oracle = GaussianOracle(d, m=0.7, s=0.4, predict=prediction)
    x = d.p_sample_loop(oracle, (2000, 1, 4), seed=0)
    assert x.mean().item() == pytest.approx(0.7, abs=0.01)
    assert x.std().item() == pytest.approx(0.4, rel=0.02)
    again = d.p_sample_loop(oracle, (2000, 1, 4), seed=0)
    assert torch.equal(x, again)


def test_guidance_moves_samples_to_goal_and_stop_at_T_disables_it():
    d = GaussianDiffusion(cosine_betas(100), "epsilon")
    oracle = GaussianOracle(d, m=0.0, s=1.0, predict="epsilon")
    goal = 2.0
    guidance = Guidance(goal_fn=lambda x0: (x0 - goal).abs().sum(dim=(1, 2)), strength=3.0)
    shape = (1000, 1, 4)
    plain = d.p_sample_loop(oracle, shape, seed=5)
    guided = d.p_sample_loop(oracle, shape, seed=5, guidance=guidance)
    assert (guided - goal).abs().mean() < 0.25 * (plain - goal).abs().mean()
    assert guided.mean() > plain.mean() + 1.0
    never = d.p_sample_loop(oracle, shape, seed=5, guidance=guidance, stop_guidance_at=100)
    assert torch.equal(never, plain)
    late_stop = d.p_sample_loop(oracle, shape, seed=5, guidance=guidance, stop_guidance_at=20)
    assert not torch.equal(late_stop, guided)          # the last 20 steps are unguided
    assert (late_stop - goal).abs().mean() < 0.5 * (plain - goal).abs().mean()


def test_trajectory_records_guidance_shift_only_while_active():
    d = GaussianDiffusion(cosine_betas(50), "x0")
    oracle = GaussianOracle(d, m=0.0, s=1.0, predict="x0")
    guidance = Guidance(goal_fn=lambda x0: (x0 - 1.0).abs().sum(dim=(1, 2)), strength=5.0)
    x, traj = d.p_sample_loop(oracle, (8, 1, 4), seed=1, guidance=guidance, stop_guidance_at=10,
                              return_trajectory=True)
    assert traj.timesteps == list(range(49, -1, -1))
    assert traj.x_t.shape == traj.pred_x0.shape == traj.guidance_shift.shape == (50, 8, 1, 4)
    norms = traj.guidance_shift.flatten(1).norm(dim=1)
    assert torch.all(norms[:40] > 0) and torch.all(norms[40:] == 0)
    _, some = d.p_sample_loop(oracle, (8, 1, 4), seed=1, return_trajectory=True,
                              trajectory_timesteps=[0, 20])
    assert some.timesteps == [20, 0] and some.x_t.shape[0] == 2


@pytest.mark.parametrize("prediction", ["epsilon", "x0"])
def test_imputation_makes_masked_entries_equal_target(prediction):
    d = GaussianDiffusion(cosine_betas(100), prediction)
    oracle = GaussianOracle(d, m=0.0, s=1.0, predict=prediction)
    shape = (16, 4, 8)
    target = torch.full(shape, 3.0)
    mask = torch.zeros(shape, dtype=torch.bool)
    mask[:, :2, ::2] = True                           # features 0:2 on every other frame
    x = d.p_sample_loop(oracle, shape, seed=2, imputation=Imputation(mask, target))
    torch.testing.assert_close(x[mask], target[mask], rtol=0, atol=1e-5)
    assert (x[~mask] - 3.0).abs().mean() > 1.0         # the rest stays model-driven
    # the other variant on the same model also works; stopping at T disables it
    other = "x0" if prediction == "epsilon" else "x_prev"
    y = d.p_sample_loop(oracle, shape, seed=2, imputation=Imputation(mask, target, other))
    torch.testing.assert_close(y[mask], target[mask], rtol=0, atol=1e-5)
    z = d.p_sample_loop(oracle, shape, seed=2, imputation=Imputation(mask, target),
                        stop_guidance_at=100)
    assert (z[mask] - 3.0).abs().mean() > 1.0


# -- DDIM ---------------------------------------------------------------------------------------


def test_ddim_step_with_eta_one_equals_posterior_mean():
    d = GaussianDiffusion(cosine_betas(100))
    g = torch.Generator().manual_seed(6)
    t = torch.arange(1, 100)
    x_t = torch.randn(99, 2, 4, generator=g, dtype=torch.float64)
    eps = torch.randn(99, 2, 4, generator=g, dtype=torch.float64)
    zero_noise = torch.zeros_like(x_t)
    ddim_mean = d.ddim_step(x_t, t, t - 1, eps, eta=1.0, noise=zero_noise)
    torch.testing.assert_close(ddim_mean, d.posterior_mean_from_eps(x_t, eps, t),
                               rtol=1e-9, atol=1e-9)
    unit = torch.ones_like(x_t)
    sigma = d.ddim_step(x_t, t, t - 1, eps, eta=1.0, noise=unit) - ddim_mean
    torch.testing.assert_close(sigma[:, 0, 0] ** 2, torch.from_numpy(d.posterior_variance[1:]),
                               rtol=1e-9, atol=1e-12)


def test_ddim_eta0_deterministic_and_full_steps_approximates_ancestral():
    d = GaussianDiffusion(cosine_betas(100), "epsilon")
    oracle = GaussianOracle(d, m=-0.5, s=0.6, predict="epsilon")
    shape = (4000, 1, 4)
    x_T = torch.randn(shape, generator=torch.Generator().manual_seed(7))
    a = d.ddim_sample_loop(oracle, shape, steps=100, noise=x_T)
    b = d.ddim_sample_loop(None, shape, steps=100, noise=x_T, model_fn=oracle)
    assert torch.equal(a, b)
    c = d.ddim_sample_loop(oracle, shape, steps=100, seed=123)
    assert not torch.equal(a, c)
    ancestral = d.p_sample_loop(oracle, shape, noise=x_T)
    for sample in (a, ancestral):
        assert sample.mean().item() == pytest.approx(-0.5, abs=0.02)
        assert sample.std().item() == pytest.approx(0.6, rel=0.03)
    few = d.ddim_sample_loop(oracle, shape, steps=10, noise=x_T)   # coarse: std 0.52
    assert few.mean().item() == pytest.approx(-0.5, abs=0.02)
    assert few.std().item() == pytest.approx(0.6, rel=0.2)
    x0_model = GaussianOracle(d, m=-0.5, s=0.6, predict="x0")
    d_x0 = GaussianDiffusion(cosine_betas(100), "x0")
    torch.testing.assert_close(d_x0.ddim_sample_loop(x0_model, shape, steps=100, noise=x_T), a,
                               rtol=1e-4, atol=1e-4)
    assert list(d.ddim_timesteps(5)) == [0, 25, 50, 74, 99]


def test_the_sampler_pieces_impute_and_guide_where_they_should() -> None:
    """The pieces ``p_sample_loop`` composes: imputation replaces exactly the masked entries
    (by μ_t(target, x_t) on x̂0, by the target itself at the last step on x_{t−1}), and the
    guided mean moves against the goal's gradient only when guidance is given."""
    d = GaussianDiffusion(linear_betas(30), prediction="x0")
    x = torch.randn(2, 3, 4)
    mask = torch.zeros(1, 3, 4, dtype=torch.bool)
    mask[:, 0] = True
    target = torch.full((1, 3, 4), 0.5)
    t = torch.full((2,), 5, dtype=torch.long)
    mean, pred_x0 = torch.randn(2, 3, 4), torch.randn(2, 3, 4)
    imputed = d.impute_x0(mean, pred_x0, x, t, mask, target)
    expected = d.q_posterior_mean(target.expand_as(x), x, t)
    assert torch.equal(imputed[:, 0], expected[:, 0]) and torch.equal(imputed[:, 1:], mean[:, 1:])
    last = d.impute_x_prev(x, torch.zeros(2, dtype=torch.long), mask, target,
                           torch.Generator().manual_seed(0))
    assert torch.equal(last[:, 0], target.expand_as(x)[:, 0]) and torch.equal(last[:, 1:],
                                                                              x[:, 1:])

    def model(x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        return 0.5 * x_t

    plain, no_shift = d.guided_mean_variance(model, x, t, None, None, None)
    goal = Guidance(goal_fn=lambda x0: x0.sum(dim=(1, 2)), strength=3.0)
    guided, shift = d.guided_mean_variance(model, x, t, None, None, goal)
    assert torch.count_nonzero(no_shift) == 0
    # ∇_{x_t} Σ x̂0 = 0.5 everywhere, so μ̃ − μ = −s·β̃_t·0.5 < 0
    assert torch.allclose(guided.mean - plain.mean, -3.0 * plain.variance * 0.5)
    assert torch.allclose(shift, guided.mean - plain.mean)
