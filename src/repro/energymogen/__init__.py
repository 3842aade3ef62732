"""EnergyMoGen (layer 5): its composition operators, pipeline, experiments and figures. Never
imports repro.gmd.

Layers: docs/DESIGN.md."""
