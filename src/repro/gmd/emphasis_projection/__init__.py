"""Notebook 03 (GMD appendix C, C.1): the Emphasis projection (claims GMD-C1…C4).

- ``projection``: the projection itself (Eq. 3–4), :class:`EmphasisProjection` and the
  measurements around it, shared by every claim, and ``ProjectionSettings``, the sample sizes
  of the GMD-C1…C3 checks;
- ``c1``, ``c2``, ``c3``: the three analytic claims (GMD-C1 Eq. 4's relative importance, GMD-C2
  distances and the exact inverse, GMD-C3 the unit-variance factor), each as an experiment that
  returns its measurements, its figure and the ``ClaimResult`` it records;
- ``experiment``: GMD-C4's experiment, tiny GMD motion models with trajectory loss scaling k or
  the Emphasis projection c at matched values (Eq. 5: weight k² ≈ c² on the trajectory), its
  :class:`Settings` (also the stand-in data every claim of the notebook reads),
  ``run_experiment`` and ``window_evaluator``;
- ``c4``: GMD-C4 itself, its controls, fitness-gate records, readings, figures and result.

Re-exported here: :class:`Settings` (``tests/conftest.py`` reads each claim's settings class
from its group), and the names notebook 03's text cites by this path
(:class:`EmphasisProjection`, :func:`emphasis_study_records`, :func:`c4_aa_controls`).
"""

from repro.gmd.emphasis_projection.c4 import c4_aa_controls, emphasis_study_records
from repro.gmd.emphasis_projection.experiment import Settings
from repro.gmd.emphasis_projection.projection import EmphasisProjection

__all__ = ["EmphasisProjection", "Settings", "c4_aa_controls", "emphasis_study_records"]
