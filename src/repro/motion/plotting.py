"""Pictures of motion: skeleton filmstrips, top-down root trajectories, short GIFs (one clip,
or several side by side for a notebook page), and per-feature statistics.

Joints are (T, 22, 3) with Y up (HumanML3D); the side view plots x (right) against y (up),
the top-down view x against z (the body faces +Z at frame 0).
"""

from __future__ import annotations

import base64
import os
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402

from repro.motion.features import FEATURE_BLOCKS  # noqa: E402
from repro.motion.skeleton import KINEMATIC_CHAINS  # noqa: E402

CHAIN_COLOURS = ("tab:red", "tab:blue", "black", "tab:orange", "tab:green")


def _check_joints(joints: np.ndarray) -> np.ndarray:
    joints = np.asarray(joints)
    if joints.ndim != 3 or joints.shape[1:] != (22, 3):
        raise ValueError(f"joints must be (T, 22, 3), got {joints.shape}")
    return joints


def draw_skeleton(ax: plt.Axes, pose: np.ndarray, *, view: str = "front",
                  offset: float = 0.0, alpha: float = 1.0) -> None:
    """One pose (22, 3) as coloured kinematic chains; view 'front' (x–y) or 'side' (z–y)."""
    horizontal = 0 if view == "front" else 2
    for chain, colour in zip(KINEMATIC_CHAINS, CHAIN_COLOURS, strict=True):
        ax.plot(pose[list(chain), horizontal] + offset, pose[list(chain), 1], color=colour,
                lw=2, alpha=alpha, solid_capstyle="round")


def filmstrip(joints: np.ndarray, *, frames: int = 8, title: str | None = None,
              view: str = "side", ax: plt.Axes | None = None) -> plt.Figure:
    """``frames`` evenly spaced poses side by side (each centred on its own root)."""
    joints = _check_joints(joints)
    picks = np.linspace(0, len(joints) - 1, frames).round().astype(int)
    if ax is None:
        fig, ax = plt.subplots(figsize=(1.3 * frames, 2.6))
    else:
        fig = ax.figure
    horizontal = 0 if view == "front" else 2
    for k, frame in enumerate(picks):
        pose = joints[frame].copy()
        pose[:, horizontal] -= pose[0, horizontal]
        draw_skeleton(ax, pose, view=view, offset=1.0 * k)
        ax.text(1.0 * k, -0.15, f"{frame}", ha="center", fontsize=7)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_ylim(-0.25, max(2.0, float(joints[..., 1].max()) + 0.1))
    ax.grid(False)
    if title:
        ax.set_title(title, fontsize=9)
    return fig


def trajectories(joints_list: Sequence[np.ndarray], *, labels: Sequence[str] | None = None,
                 ax: plt.Axes | None = None, title: str | None = None) -> plt.Figure:
    """Top-down root paths (x against z) of several clips, with start and end marked."""
    if ax is None:
        fig, ax = plt.subplots(figsize=(4.5, 4.5))
    else:
        fig = ax.figure
    for i, joints in enumerate(joints_list):
        root = np.asarray(joints)[:, 0]
        label = labels[i] if labels is not None else None
        line, = ax.plot(root[:, 0], root[:, 2], lw=1.5, label=label)
        ax.plot(root[0, 0], root[0, 2], "o", color=line.get_color(), ms=4)
        ax.plot(root[-1, 0], root[-1, 2], ">", color=line.get_color(), ms=5)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m, facing direction at frame 0)")
    ax.set_aspect("equal", adjustable="datalim")
    if labels is not None:
        ax.legend(fontsize=7, loc="best")
    if title:
        ax.set_title(title, fontsize=9)
    return fig


def animate(joints: np.ndarray, path: str | os.PathLike, *, fps: int = 20,
            view: str = "side", stride: int = 2) -> Path:
    """A short GIF of a clip (every ``stride``-th frame), the camera following the root."""
    joints = _check_joints(joints)
    fig, ax = plt.subplots(figsize=(3, 3))
    horizontal = 0 if view == "front" else 2

    def update(frame: int) -> None:
        ax.clear()
        pose = joints[frame]
        draw_skeleton(ax, pose, view=view)
        centre = pose[0, horizontal]
        ax.set_xlim(centre - 1.0, centre + 1.0)
        ax.set_ylim(-0.1, 1.9)
        ax.set_aspect("equal")
        ax.axhline(0.0, color="grey", lw=0.5)
        ax.set_title(f"frame {frame}", fontsize=8)

    return _save_gif(FuncAnimation(fig, update, frames=range(0, len(joints), stride)), fig,
                     path, fps=fps, stride=stride)


def _save_gif(animation: FuncAnimation, fig: plt.Figure, path: str | os.PathLike, *,
              fps: int, stride: int) -> Path:
    """Write ``animation`` (every ``stride``-th frame of a ``fps`` clip) as a GIF, atomically
    (a temporary file renamed into place), and close its figure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp.gif")
    animation.save(tmp, writer=PillowWriter(fps=max(1, fps // stride)))
    os.replace(tmp, path)
    plt.close(fig)
    return path


def animate_side_by_side(clips: Mapping[str, np.ndarray], path: str | os.PathLike, *,
                         fps: int = 20, view: str = "side", stride: int = 2,
                         columns: int = 4) -> Path:
    """A GIF of several clips (label → joints (T, 22, 3)) in a grid. Each panel's camera
    follows its root over a floor marked every 25 cm in the world, so a body that walks
    passes the marks, one that stands keeps still over them, and a foot that slides while
    planted (a purple mark: a foot below 5 cm) is seen sliding against them."""
    items = [(label, _check_joints(joints)) for label, joints in clips.items()]
    if not items:
        raise ValueError("no clips to animate")
    frames = min(len(joints) for _, joints in items)
    rows = -(-len(items) // columns)
    cols = min(columns, len(items))
    fig, axes = plt.subplots(rows, cols, figsize=(2.3 * cols, 2.5 * rows), squeeze=False)
    horizontal = 0 if view == "front" else 2
    feet, half = [10, 11], 1.2

    def update(frame: int) -> None:
        for k, ax in enumerate(axes.flat):
            ax.clear()
            ax.set_axis_off()
            if k >= len(items):
                continue
            label, joints = items[k]
            pose = joints[frame]
            centre = float(pose[0, horizontal])
            marks = np.arange(np.floor((centre - half) / 0.25), np.ceil((centre + half) / 0.25)
                              + 1) * 0.25
            ax.plot(marks, np.zeros_like(marks), "|", color="grey", ms=5)
            ax.axhline(0.0, color="grey", lw=0.6)
            draw_skeleton(ax, pose, view=view)
            planted = pose[feet][pose[feet, 1] < 0.05]
            ax.plot(planted[:, horizontal], np.zeros(len(planted)), "v", color="tab:purple",
                    ms=4)
            ax.set_xlim(centre - half, centre + half)
            ax.set_ylim(-0.1, 2.0)
            ax.set_aspect("equal")
            ax.set_title(textwrap.fill(label, 26), fontsize=7)
        fig.suptitle(f"frame {frame} of {frames}", fontsize=8)

    return _save_gif(FuncAnimation(fig, update, frames=range(0, frames, stride)), fig, path,
                     fps=fps, stride=stride)


def shorten(text: str, width: int = 44) -> str:
    """``text`` cut to ``width`` characters with an ellipsis (a panel's title)."""
    return text if len(text) <= width else text[: width - 1] + "…"


def gif_html(path: str | os.PathLike, *, width: int | None = None) -> str:
    """An ``<img>`` tag holding the GIF at ``path`` inline (base64), so an executed notebook
    and its HTML rendering carry the animation without the file beside them."""
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    size = f' width="{int(width)}"' if width else ""
    return f'<img src="data:image/gif;base64,{data}"{size} alt="{Path(path).name}">'


def feature_statistics(mean: np.ndarray, std: np.ndarray, *, label: str = "stand-in",
                       reference: tuple[np.ndarray, np.ndarray] | None = None,
                       reference_label: str = "HumanML3D") -> plt.Figure:
    """Per-feature mean (top) and std (bottom) of the 263 features, the feature blocks
    (``features.FEATURE_BLOCKS``) marked and named; ``reference`` (mean, std) drawn beside."""
    fig, axes = plt.subplots(2, 1, figsize=(10, 5), sharex=True)
    axes[0].plot(mean, label=label, lw=1)
    axes[1].plot(std, label=label, lw=1)
    if reference is not None:
        axes[0].plot(reference[0], label=reference_label, lw=1, alpha=0.7)
        axes[1].plot(reference[1], label=reference_label, lw=1, alpha=0.7)
    for name, block in FEATURE_BLOCKS.items():
        for ax in axes:
            ax.axvline(block.start, color="grey", lw=0.5)
        axes[1].text((block.start + block.stop) / 2, axes[1].get_ylim()[1] * 0.9, name,
                     fontsize=6, ha="center")
    axes[0].set_ylabel("mean")
    axes[1].set_ylabel("std")
    axes[1].set_xlabel("feature index")
    axes[0].legend(fontsize=8)
    return fig


def save_figure(fig: plt.Figure, path: str | os.PathLike) -> Path:
    """Save a figure atomically as PNG (the report copies it) and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, bbox_inches="tight", format="png")
    os.replace(tmp, path)
    return path
