"""EMG-1's per-t measurements (``energymogen.gradient_field``) on fields with a known answer."""

from __future__ import annotations

import torch

from repro.energymogen.energy_contour_maps import (
    flat_jacobian,
    loop_plane,
    relative_circulation,
    residual_asymmetry,
)


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
