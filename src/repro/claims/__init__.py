"""Claims (layer 5): the registry of verdict rules (``claim.REGISTRY_VERSION``, with the
earlier versions frozen beside it), outcomes and verdicts, the power calculation, the ledger,
the report, seed stability, the papers' printed tables and errata. Imports the layers below,
never a paper package.

Layers: docs/DESIGN.md. Rule changes: docs/REGISTRY_CHANGELOG.md."""
