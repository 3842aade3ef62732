"""Notebook 03's figures draw from measured values alone (smoke tests on small inputs)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from repro.gmd import emphasis_projection  # noqa: E402


def test_emphasis_figures() -> None:
    grid = np.array([1.0, 2.0, 10.0])
    share = grid**2 / (grid**2 + 1)
    fig = emphasis_projection.plot_relative_importance(grid, share, {0: share}, share, share,
                                                    c_star=9.3, importance_at_10=0.54,
                                                    simulation_error=1e-3)
    assert len(fig.axes) == 1
    spread = np.ones(263)
    fig = emphasis_projection.plot_unit_variance(grid, 260 + 3 * grid**2,
                                              1 / np.sqrt(260 + 3 * grid**2),
                                              1 / (260 + 3 * grid**2), spread, spread, spread)
    assert len(fig.axes) == 3
    plt.close("all")
