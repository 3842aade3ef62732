"""Notebook 01 (GMD appendix A, A.1): x0 vs ε prediction (claims GMD-A1…A4).

One module per claim, each with its measurements, controls, readings and result function
(``a*_result``: it takes what the notebook measured, runs the claim's controls and returns the
:class:`~repro.claims.result.ClaimResult` its registered rule reads, with the fitness-gate
records of the models behind it):

- ``a1``: GMD-A1, the two forms of the posterior mean (Eq. 1–2) and Eq. 2's printed c;
- ``a2``: GMD-A2, where the x0 and the ε share of the posterior mean peak (Fig. A.1);
- ``a3``: GMD-A3, goal reaching of the x0 and the ε trajectory model under GMD's goal guidance
  (the study, the x̂0-clamp sensitivity check, the exact and planted models that check the
  measurement code, the A/A runs: the ε model against an independently trained copy, the
  reading paragraphs);
- ``a4``: GMD-A4, the unguided sample quality (jitter, FID) of x0 and ε models (the study, its
  controls and A/A runs: each task's reference arm against an independently trained copy, the
  gate records, the longer ε run outside the rule, the training-budget table);

and beside them what they share:

- ``common``: the notebook's :class:`Settings` (every size and step count at one scale; the
  scale is checked in ``Settings.for_scale``), ``guidance_trajectory_spec`` (the trajectory
  model of the guidance experiments: GMD-A3 here, GMD-B2 in notebook 02, GMD-F1 in 06, one
  cache key; GMD's diffusion, T = 1000 cosine), the two parametrisations, the trajectory gate
  values of A3's and A4's trajectory models;
- ``goal_reaching``: GMD-A3's experiment, a guided and an unguided run from the same seed,
  and its measurements (``best_gain_survival``, the registered one), run by A3's study and
  its controls.

The package re-exports :class:`Settings`, which ``run.params``, the tests' conftest and
scripts/ read; the models it shares with notebook 06 are the scale's
``gmd.models.GuidanceModels`` (``Settings.models``).
"""

from __future__ import annotations

from repro.gmd.x0_vs_eps.common import Settings, window_needs

__all__ = ["Settings", "window_needs"]
