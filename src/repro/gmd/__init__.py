"""Guided Motion Diffusion's appendix (layer 5): its math, experiments and figures. Never imports
repro.energymogen.

The tiny GMD every notebook shares: ``coefficients`` (appendix A's posterior-mean forms),
``windows`` (data windows and their feature space), ``models`` (specs, text conditioning,
cached training), ``guidance`` (guided sampling, goal functions), ``measurements`` (jitter,
foot skating, evaluator inputs), ``model_gates`` (the registered quality gates of every
model behind a verdict, measured). One module per notebook experiment: ``x0_vs_eps`` (01),
``root_representation``, ``location_imputation``, ``table_b1`` and ``cfg`` (02),
``emphasis`` and ``emphasis_study`` (03), ``guidance_schedule`` (06), each with its
notebook's ``Settings``; their figures are in
``figures`` and ``emphasis_figures``, their rendered reading paragraphs in ``readings``.

Layers: docs/DESIGN.md."""
