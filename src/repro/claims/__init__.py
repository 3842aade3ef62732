"""Claims (layer 6): the registry of verdict rules, verdicts, the ledger, the report, seed
stability. Imports the layers below, never a paper package.

Layers: docs/DESIGN.md."""
