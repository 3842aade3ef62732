"""Figures of motion: the feature-statistics figure marks every feature block."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from repro.motion import plotting
from repro.motion.features import FEATURE_BLOCKS, FEATURE_DIM


def test_feature_statistics_draws_both_sets_and_names_every_block() -> None:
    mean, std = np.zeros(FEATURE_DIM), np.ones(FEATURE_DIM)
    fig = plotting.feature_statistics(mean, std, reference=(mean + 1, std * 2))
    top, bottom = fig.axes
    assert [line.get_label() for line in top.get_lines()][:2] == ["stand-in", "HumanML3D"]
    assert np.array_equal(bottom.get_lines()[1].get_ydata(), std * 2)
    assert [text.get_text() for text in bottom.texts] == list(FEATURE_BLOCKS)
    plt.close(fig)
    alone = plotting.feature_statistics(mean, std)
    assert len(alone.axes[0].get_legend().get_texts()) == 1
    plt.close(alone)
