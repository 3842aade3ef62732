"""Guided Motion Diffusion's appendix (layer 5): its math, experiments and figures. Never imports
repro.energymogen.

Layers: docs/DESIGN.md."""
