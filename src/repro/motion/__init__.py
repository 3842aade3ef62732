"""Motion (layer 1): quaternions, the 22-joint skeleton, HumanML3D's 263-d features, the HumanML3D
folder loader and validator, plotting. Imports infra.

Layers: docs/DESIGN.md."""
