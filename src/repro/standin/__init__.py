"""Stand-in data (layer 3): motion primitives, the clip generator, concept oracles, the caption
vocabulary. Imports the layers below.

Layers: docs/DESIGN.md."""
