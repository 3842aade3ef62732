"""Notebook 08: composed motions as training data (EnergyMoGen Sec. 5.1 "CompML", Sec. 5.5,
app. A) — one claim, EMG-8; the settings are ``AugmentationSettings``.

The paper composes 5000 motions from random sets of three STMC texts with EnergyMoGen,
fine-tunes *only the latent diffusion model* on HumanML3D + CompML for 100K iterations with
learning rate 5·10⁻⁵ (pretraining: 300K at 10⁻⁴ then 10⁻⁵) and reports better text-to-motion
on the HumanML3D test set (Table 1). On the stand-in data:

- ``compml`` — the training data and the fine-tuning: the composed set (``compose_set``, a
  CompML stand-in: SEF compositions of random composable concept pairs), denoiser training
  rows (``caption_rows``, ``concatenate_rows``) and the cached fine-tuning of the pretrained
  denoiser (``pipeline_finetune_config``, ``load_or_finetune``).
- ``emg8`` — **EMG-8** ("the model's performance improves with additional training data from
  CompML"): its settings, the study (``augmentation_study``: pretrained, control and
  augmented denoisers on the rule's shared-concept test and on the held-out composed texts),
  the models' gate records (``augmentation_records``), the controls
  (``augmentation_controls``), ``emg8_result``, the notebook's tables and figures.

On a data folder (real data, no concept labels) EMG-8 is not measurable (``data.NotMeasurable``:
the composed set composes stand-in concept pairs and the rule's test batches clips by
concept); the pretrained models' gates and ground truth's R@3 are still measured.
"""

from repro.energymogen.composed_augmentation.emg8 import AugmentationSettings

__all__ = ["AugmentationSettings"]
