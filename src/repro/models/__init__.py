"""Tiny denoisers: GMD's 1D UNet with AdaGN (``unet``)."""

from repro.models.unet import UNet1D

__all__ = ["UNet1D"]
