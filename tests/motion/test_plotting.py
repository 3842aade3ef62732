"""Figures of motion: the feature-statistics figure marks every feature block."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

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


def test_side_by_side_animation_is_a_gif_that_a_page_carries_inline(tmp_path):
    from repro.motion.plotting import animate_side_by_side, gif_html

    rng = np.random.default_rng(0)
    still = np.zeros((12, 22, 3)) + rng.normal(size=(1, 22, 3)) * 0.1 + [0, 1, 0]
    walking = still + np.linspace(0, 1, 12)[:, None, None] * [0, 0, 1]
    path = animate_side_by_side({"data": still, "model": walking}, tmp_path / "a.gif",
                                stride=3)
    assert path.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
    html = gif_html(path, width=300)
    assert html.startswith('<img src="data:image/gif;base64,') and 'width="300"' in html
    with pytest.raises(ValueError, match="no clips"):
        animate_side_by_side({}, tmp_path / "b.gif")
