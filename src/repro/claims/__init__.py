"""Claims (layer 6): the registry of verdict rules (version 2, with version 1 frozen beside
it), outcomes and verdicts, the power calculation, the ledger, the report, seed stability.
Imports the layers below, never a paper package.

Layers: docs/DESIGN.md. Rule changes: docs/REGISTRY_CHANGELOG.md."""
