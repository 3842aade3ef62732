"""GMD appendix A: the two posterior-mean forms and Fig. A.1's shares."""

from __future__ import annotations

import numpy as np
import pytest

from repro.gmd.models import schedule_diffusion
from repro.gmd.x0_vs_eps.a1 import posterior_mean_forms, printed_c_relative_error
from repro.gmd.x0_vs_eps.a2 import coefficient_shares, peak_fraction

FRAMES = 16  # = conftest.FRAMES: the windows of the small_config fixture


def test_appendix_a_coefficients() -> None:
    diffusion = schedule_diffusion("cosine", 1000)
    assert posterior_mean_forms(diffusion, samples=8).max() < 1e-12
    assert printed_c_relative_error(diffusion).max() > 1e-6
    shares = coefficient_shares(diffusion)
    np.testing.assert_allclose(shares["c"], 1 / np.sqrt(diffusion.alphas), rtol=1e-12)
    assert peak_fraction(shares["x0_share"]) == pytest.approx(0.001)
