"""Notebook 04 (``notebooks/04_energy_contour_maps.ipynb``): the energy view of EnergyMoGen's
latent diffusion and the composition it licenses, checked on the pipeline — EMG-1, 2, 3, 6
and 9. One module per claim, beside what its claims share:

- ``notebook_settings``: the notebook's settings, :class:`EnergyViewSettings` (EMG-1, 2, 3, 6);
- ``emg1``: EMG-1, is a denoising step a Langevin step on an energy, and is ε_θ a gradient
  field at each t (the energy view, the residual Jacobian asymmetry and loop integrals, their
  planted controls, the result and figure);
- ``composition``: the composition study EMG-2 and EMG-3 are both decided from (one set of
  samples per seed, oracle-measured), their shared baselines, A/A controls, notes, tables,
  figures and the guidance-scale check;
- ``emg2``: EMG-2's result (the latent-aware arm, Eq. 7/8);
- ``emg3``: EMG-3's result (the semantic-aware arm, Eq. 9);
- ``emg6``: EMG-6, energy maps of composed and multi-concept texts (maps, cases, similarities,
  A/A controls, the result, tables and figures);
- ``emg9``: EMG-9, the FID formula as printed (random and fixed cases, the result, tables).

Each ``emg*_result`` takes what its experiment measured and returns the
:class:`~repro.claims.result.ClaimResult` the notebook records: the measurements the
registered rule reads, headline, notes and the values kept beside them; the markdown helpers
and figures render what the notebook shows beside them.

The package re-exports :class:`EnergyViewSettings`, which the notebook, ``tests/conftest.py``
and ``scripts/pilot_emg_samples.py`` import from ``repro.energymogen.energy_contour_maps``.
"""

from __future__ import annotations

from repro.energymogen.energy_contour_maps.notebook_settings import EnergyViewSettings

__all__ = ["EnergyViewSettings"]
