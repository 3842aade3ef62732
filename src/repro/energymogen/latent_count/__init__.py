"""Notebook 07: the number N of latent vectors of the motion VAE (EnergyMoGen appendix D,
Table 8) — one claim, EMG-7; the settings are ``LatentCountSettings``.

- ``emg7`` — **EMG-7** ("For reconstruction, 7 latent vectors achieve the best results. ...
  Using 5 latent vectors ... obtains the best text-to-motion generation performance"): its
  settings, Table 8's paper values, every N's models trained as the pipeline's
  (``load_or_train_variant``), the sweep (``latent_count_study``: reconstruction MPJPE,
  ``mpjpe``, and generation on the held-out text-to-motion test set), the models' gate records
  (``latent_count_records``), the controls (``latent_count_controls``), ``emg7_result`` and
  the figures.

On a data folder EMG-7 is measured (reconstruction error, FID against the folder's test
windows); its oracle columns read not measurable on real data.
"""

from repro.energymogen.latent_count.emg7 import LatentCountSettings

__all__ = ["LatentCountSettings"]
