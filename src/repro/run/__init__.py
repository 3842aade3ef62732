"""Running (layer 7): the notebook set-up, the papermill runner, the bench, the command line.

Layers: docs/DESIGN.md."""
