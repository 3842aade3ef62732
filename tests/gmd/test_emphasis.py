"""The Emphasis projection: exact inverse, unit variance, Eq. 4 and its inverse, orthogonal kind."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from repro.gmd.emphasis_projection.projection import (
    EmphasisProjection,
    c_for_importance,
    distance_ratios,
    drowned_directions,
    gaussian_matrix,
    jl_tail_bound,
    normalising_factor,
    orthogonal_matrix,
    per_dimension_variance,
    projected_importance,
    reconstruction_error,
    relative_importance,
    simulated_relative_importance,
)


def _frames(n: int = 500, dim: int = 263, seed: int = 1) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal((n, dim))


def test_matrix_is_gmds_construction() -> None:
    """Rows 0–2 of the N(0,1) matrix times c, the whole divided by √(263 − 3 + 3c²)."""
    projection = EmphasisProjection(c=10.0, seed=3)
    expected = gaussian_matrix(263, 3).clone()
    expected[[0, 1, 2], :] *= 10.0
    expected /= math.sqrt(263 - 3 + 3 * 100)
    torch.testing.assert_close(projection.matrix, expected, rtol=1e-15, atol=1e-15)
    assert projection.matrix.dtype == torch.float64


def test_rows_scaled_means_inputs_weighted_by_c() -> None:
    """x P with rows 0–2 scaled = (x with features 0–2 times c) P₁ (the c = 1 matrix, same s)."""
    plain = EmphasisProjection(c=1.0, seed=0, normaliser="none")
    emphasised = EmphasisProjection(c=10.0, seed=0, normaliser="none")
    x = _frames(20)
    weighted = x.copy()
    weighted[:, :3] *= 10.0
    np.testing.assert_allclose(emphasised.project(x), plain.project(weighted), rtol=1e-12,
                               atol=1e-12)


@pytest.mark.parametrize("kind", ["gaussian", "orthogonal"])
@pytest.mark.parametrize("c", [1.0, 10.0])
def test_inverse_is_exact_in_float64(kind: str, c: float) -> None:
    projection = EmphasisProjection(c=c, seed=0, kind=kind)
    x = _frames()
    assert reconstruction_error(projection, x).max() <= 1e-10
    back = projection.unproject(projection.project(torch.from_numpy(x)))
    assert back.dtype == torch.float64
    assert float((back - torch.from_numpy(x)).norm() / np.linalg.norm(x)) <= 1e-10


def test_projection_is_differentiable_and_channels_first() -> None:
    projection = EmphasisProjection(dim=8, emphasised=(1, 5), c=3.0, seed=2)
    x = torch.randn(2, 8, 6, dtype=torch.float32, requires_grad=True)
    y = projection.project_channels_first(x)
    assert y.shape == x.shape and y.dtype == torch.float32
    y.sum().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all()
    torch.testing.assert_close(y.transpose(1, 2), projection.project(x.detach().transpose(1, 2)))
    back = projection.unproject_channels_first(y.detach())
    torch.testing.assert_close(back, x.detach(), rtol=1e-4, atol=1e-4)


def test_sqrt_factor_gives_unit_variance_printed_does_not() -> None:
    c = 10.0
    sqrt = per_dimension_variance(EmphasisProjection(c=c, seed=0), n_samples=20000, seed=4)
    assert abs(sqrt.mean() - 1.0) < 0.05
    printed = per_dimension_variance(EmphasisProjection(c=c, seed=0, normaliser="printed"),
                                     n_samples=20000, seed=4)
    assert printed.mean() == pytest.approx(1.0 / (263 - 3 + 3 * c**2), rel=0.05)
    assert normalising_factor(c) == pytest.approx(1 / math.sqrt(560))
    assert normalising_factor(c, normaliser="printed") == pytest.approx(1 / 560)


def test_orthogonal_kind_gives_exact_unit_variance_and_importance() -> None:
    """With √n·Q the expected per-dimension variance is exactly 1 at c = 1 and the energy
    share of the emphasised rows is exactly Eq. 4 for any c."""
    projection = EmphasisProjection(c=1.0, kind="orthogonal", seed=5)
    columns = projection.matrix.pow(2).sum(dim=0)
    torch.testing.assert_close(columns, torch.ones(263, dtype=torch.float64))
    for c in (1.0, 2.0, 10.0):
        assert projected_importance(EmphasisProjection(c=c, kind="orthogonal")) == \
            pytest.approx(relative_importance(c), abs=1e-12)


def test_eq4_formula_and_c_star() -> None:
    assert relative_importance(1.0) == pytest.approx(3 / 263)
    assert relative_importance(10.0) == pytest.approx(300 / 560)
    assert round(relative_importance(10.0), 3) == 0.536
    c_star = c_for_importance(0.5)
    assert c_star == pytest.approx(math.sqrt(260 / 3), abs=1e-12)
    assert round(c_star, 2) == 9.31
    assert relative_importance(c_star) == pytest.approx(0.5, abs=1e-12)
    grid = np.array([0.5, 1.0, 3.0, 20.0])
    np.testing.assert_allclose(relative_importance(grid), 3 * grid**2 / (260 + 3 * grid**2))
    for p in (0.1, 0.9):
        assert relative_importance(c_for_importance(p, 4, 100), 4, 100) == pytest.approx(p)
    with pytest.raises(ValueError):
        c_for_importance(1.0)


def test_simulated_importance_matches_eq4() -> None:
    for c in (1.0, 5.0, 10.0):
        assert simulated_relative_importance(c, n_samples=20000, seed=1) == pytest.approx(
            relative_importance(c), abs=0.01)


def test_orthogonal_variant_preserves_norms_exactly() -> None:
    q = orthogonal_matrix(263, 7) / math.sqrt(263)
    torch.testing.assert_close(q @ q.T, torch.eye(263, dtype=torch.float64), atol=1e-12, rtol=0)
    projection = EmphasisProjection(c=1.0, kind="orthogonal", seed=7)
    x = _frames(50)
    np.testing.assert_allclose(np.linalg.norm(projection.project(x), axis=1),
                               np.linalg.norm(x, axis=1), rtol=1e-12)
    ratios = distance_ratios(projection, x, n_pairs=200, seed=0)
    np.testing.assert_allclose(ratios, 1.0, rtol=1e-12)
    assert projection.condition_number == pytest.approx(1.0, abs=1e-9)


def test_gaussian_projection_keeps_distances_roughly() -> None:
    ratios = distance_ratios(EmphasisProjection(c=1.0, seed=0), _frames(), n_pairs=2000, seed=0)
    assert np.mean(np.abs(ratios - 1.0) <= 0.2) >= 0.99
    assert jl_tail_bound(0.8, 1.2, 263) < 1e-3
    assert jl_tail_bound(0.99, 1.01, 10) > 0.5  # a loose window and few dimensions: no promise


def test_any_layout_and_validation() -> None:
    projection = EmphasisProjection(dim=10, emphasised=(7,), c=2.0, seed=0)
    assert projection.matrix.shape == (10, 10)
    assert projection.weights.tolist() == [1.0] * 7 + [2.0] + [1.0] * 2
    with pytest.raises(ValueError, match="last axis"):
        projection.project(np.zeros((3, 9)))
    with pytest.raises(ValueError):
        EmphasisProjection(dim=10, emphasised=(10,))
    with pytest.raises(ValueError):
        EmphasisProjection(kind="qr")  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        EmphasisProjection(normaliser="half")  # type: ignore[arg-type]


def test_singular_values_and_drowned_directions() -> None:
    orthogonal = EmphasisProjection(c=1.0, kind="orthogonal", seed=0)
    torch.testing.assert_close(orthogonal.singular_values, torch.ones(263, dtype=torch.float64))
    assert drowned_directions(orthogonal, 0.9) == 0          # SNR 9 everywhere
    assert drowned_directions(orthogonal, 0.4) == 263        # SNR 2/3 everywhere
    gaussian = EmphasisProjection(c=1.0, seed=0)
    sigma = gaussian.singular_values
    assert sigma.max() / sigma.min() == pytest.approx(gaussian.condition_number, rel=1e-9)
    assert drowned_directions(gaussian, 0.9) > 0             # the smallest σ_i are ≪ 1/3


def test_condition_number_of_a_known_matrix() -> None:
    from repro.gmd.emphasis_projection.projection import condition_number

    # singular values 4 and 0.5 after a rotation: κ = 8
    angle = 0.3
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    matrix = rotation @ np.diag([4.0, 0.5]) @ rotation.T
    assert condition_number(matrix) == pytest.approx(8.0, rel=1e-12)
    assert condition_number(torch.eye(5)) == pytest.approx(1.0)
    assert condition_number(np.array([[1.0, 2.0], [2.0, 4.0]])) > 1e15  # singular (rounding)
    with pytest.raises(ValueError):
        condition_number(np.ones((2, 3)))
    gaussian = EmphasisProjection(c=10.0, seed=0)
    sigma = np.linalg.svd(gaussian.matrix.numpy(), compute_uv=False)
    assert gaussian.condition_number == pytest.approx(sigma.max() / sigma.min(), rel=1e-9)


def test_orthogonal_matrix_inverts_exactly_with_kappa_one() -> None:
    projection = EmphasisProjection(c=1.0, kind="orthogonal", seed=3)
    assert projection.condition_number == pytest.approx(1.0, abs=1e-12)
    identity = torch.eye(263, dtype=torch.float64)
    torch.testing.assert_close(projection.inverse @ projection.matrix, identity, rtol=0,
                               atol=1e-13)
    torch.testing.assert_close(projection.inverse, projection.matrix.T, rtol=0, atol=1e-13)
    # with the emphasis, κ(P) = κ(D) = c exactly: the least a matrix D·M can have
    assert EmphasisProjection(c=10.0, kind="orthogonal", seed=3).condition_number == \
        pytest.approx(10.0, rel=1e-12)


def test_gmd_float32_construction() -> None:
    """GMD's code: P in float32 and P⁻¹ = torch.inverse of that float32 matrix."""
    ours = EmphasisProjection(c=10.0, seed=1)
    gmd = EmphasisProjection(c=10.0, seed=1, precision="float32_gmd")
    rounded = ours.matrix.to(torch.float32)
    assert torch.equal(gmd.matrix, rounded.to(torch.float64))
    assert torch.equal(gmd.inverse, torch.linalg.inv(rounded).to(torch.float64))
    assert gmd.condition_number == pytest.approx(ours.condition_number, rel=1e-4)
    identity = torch.eye(263, dtype=torch.float64)
    gmd_error = float((gmd.inverse @ gmd.matrix - identity).abs().max())
    assert 1e-8 < gmd_error < 1e-2  # a float32 inverse of a κ ≈ 10³ matrix
    assert float((ours.inverse @ ours.matrix - identity).abs().max()) < 1e-11
    # the default precision leaves the cache configuration as it always was
    assert "precision" not in ours.as_config() and gmd.as_config()["precision"] == "float32_gmd"
    with pytest.raises(ValueError):
        EmphasisProjection(precision="float16")  # type: ignore[arg-type]
