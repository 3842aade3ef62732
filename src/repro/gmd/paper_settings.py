"""GMD's settings that several notebooks share, in one place (issues #14 and #17).

Each constant is a fact of GMD's paper or code (REFERENCE.md "GMD"; ``korrawe/guided-motion-
diffusion``) or a registered choice of this package, with its reason beside it. Notebooks 01,
02, 03 and 06 read them from here, so the models one notebook trains are the ones another
loads (one cache key), and a change is made once.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["GUIDANCE_DIFFUSION_STEPS", "GUIDANCE_SCHEDULE", "GUIDANCE_STOP_T",
           "MOTION_ARCHITECTURE", "STANDARD_DIFFUSION_STEPS", "STANDARD_MOTION_ARCHITECTURE",
           "STANDARD_TRAJECTORY_ARCHITECTURE", "TRAJECTORY_ARCHITECTURE", "X0_CLAMP",
           "Architecture"]


@dataclass(frozen=True)
class Architecture:
    """A ``models.unet.UNet1D``'s widths: ``base_channels`` × ``channel_mults`` per level."""

    base_channels: int
    channel_mults: tuple[float, ...]

    @property
    def full_resolution_width(self) -> int:
        """The narrowest width at full temporal resolution (the first level's)."""
        return int(self.base_channels * self.channel_mults[0])


#: the guidance experiments (GMD-A3, B2, F1) run GMD's diffusion: T = 1000, cosine schedule.
GUIDANCE_DIFFUSION_STEPS = 1000
GUIDANCE_SCHEDULE = "cosine"
#: GMD stops guidance at t = 20 of T = 1000 (appendix F).
GUIDANCE_STOP_T = 20
#: GMD clamps its ε trajectory model's x̂0 to ±6 (in its normalised units).
X0_CLAMP = 6.0

#: the tiny GMD UNets (set by #14's design pilots, pilots/pilot_gmd_motion.md and
#: pilots/pilot_gmd_trajectory.jsonl; the motion model's full-resolution width must be at least
#: the 263 features it carries, as GMD's [263 → 1024] is). The trajectory UNet has GMD's own
#: widths [4 → 64, 128, 256]: at 16 × (1, 2, 4) its ε model failed the trajectory gate (root
#: jerk 144 m/s³ against the bound 67.5), at 64 × (1, 2, 4) trained to its plateau it passed
#: (62.5; docs/TRAINING.md).
MOTION_ARCHITECTURE = Architecture(base_channels=288, channel_mults=(1, 0.5, 0.25))
TRAJECTORY_ARCHITECTURE = Architecture(base_channels=64, channel_mults=(1, 2, 4))

#: the standard scale (issue #32, docs/COMPUTE.md §3–§4; ``make reproduce`` on 2 CPU cores):
#: every GMD model at T = 100 cosine (the guidance stop steps at the same fraction of T,
#: ``guidance_schedule.model_stop_step``: GMD's 20 of 1000 → 2); the motion UNet 64 × (1, 1)
#: with the full-rank input skip (``UNet1D(input_skip=True)``: without it the ε arm cannot
#: carry 263-d noise through 64 channels, COMPUTE.md §4 item 1), the trajectory UNet
#: 32 × (1, 2): the first run's 16 × (1, 2) at 1000 steps failed its path-length gate in 9 of
#: 12 records (COMPUTE.md §8); the wider net passes at 1000 steps with a margin and costs less
#: than 16 × (1, 2) at the 2000 steps that also pass (COMPUTE.md §11). Fixed from pilots, before
#: the standard run that reports with it.
STANDARD_DIFFUSION_STEPS = 100
STANDARD_MOTION_ARCHITECTURE = Architecture(base_channels=64, channel_mults=(1, 1))
STANDARD_TRAJECTORY_ARCHITECTURE = Architecture(base_channels=32, channel_mults=(1, 2))
