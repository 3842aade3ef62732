"""Infrastructure (layer 0): paths, atomic storage, the content-keyed cache, the run context.
Imports nothing of repro.

Layers: docs/DESIGN.md."""
