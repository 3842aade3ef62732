"""Guided Motion Diffusion's appendix (layer 6): its math, experiments and figures. Never imports
repro.energymogen.

One package per claim group, named like its notebook, with one module per claim (its
experiment, controls, readings, figures and result) beside what the group's claims share:

- ``x0_vs_eps`` (01): appendix A, x0 vs ε prediction (GMD-A1…A4): ``a1`` … ``a4``,
  ``common``, ``goal_reaching``;
- ``root_representation`` (02): appendix B, relative vs absolute root (GMD-B1…B3): ``b1``,
  ``b2``, ``b3``, ``common``;
- ``emphasis_projection`` (03): appendix C, the Emphasis projection (GMD-C1…C4): ``c1`` …
  ``c4``, ``projection``, C4's ``experiment``;
- ``guidance_schedule`` (06): appendix F, guidance strength and stop step (GMD-F1): ``f1`` and
  the machinery it rests on (``settings``, ``sampling``, ``experiment``, ``obstacles``,
  ``plots``).

Below them, the tiny GMD every notebook shares: ``windows`` (data windows and their feature
space), ``models`` (the paper's settings, specs, text conditioning, cached training),
``guidance`` (guided and classifier-free sampling, goal functions), ``measurements`` (jitter,
foot skating, evaluator inputs, Table B.1's evaluation, denoiser diagnostics), ``model_gates``
(the registered quality gates of every model behind a verdict, measured), ``figures`` (figures
drawn from shared measurements, reading helpers), ``controls`` (control seeds, calibration,
exact plantings) and ``settings`` (seeds per scale, what each rule quotes, the scale note).

Layers: docs/DESIGN.md."""
