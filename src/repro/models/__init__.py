"""Models (layer 4): the GMD UNet, the MLD-style VAE, the latent denoiser, the text-motion
evaluator. Imports the layers below.

Layers: docs/DESIGN.md."""


from repro.models.unet import UNet1D

__all__ = ["UNet1D"]
