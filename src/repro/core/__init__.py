"""Core (layer 2): the Gaussian diffusion, the training loop, metrics, statistics over seeds,
Markdown from values. Imports infra and motion.

Layers: docs/DESIGN.md."""
