"""EnergyMoGen (layer 6): its composition operators, pipeline, experiments and figures. Never
imports repro.gmd.

Modules, each importing only those above it in this list (and lower layers):
``compose`` (Eq. 3–4, 7–10 on ε) · ``settings`` (the concept pool, held-out pairs,
``PipelineConfig``, the training plan, the settings of each notebook and scale and what each
claim's rule quotes of them) · ``data`` (stand-in data, composition and negation test items)
· ``text_stage`` (the frozen text encoder, the stand-in for CLIP) · ``pipeline`` (the trained
pipeline, its stages, sampling and each model's training record) · ``harness`` (the
text-to-motion test sets, the measurements the experiments share, the A/A controls of the
model-based claims) · ``model_gates`` (the gates of the VAE, latent
denoiser and evaluator) · ``figures`` (the figures, training tables and validation curves the
notebooks share) · ``energy_contour_maps`` (notebook 04: EMG-1, 2, 3, 6, 9 — ``emg1``,
``emg2``, ``emg3``, ``emg6``, ``emg9`` beside ``composition`` and ``notebook_settings``) ·
``sef_ablation`` (notebook 05: EMG-4, 5 — ``emg4``, ``emg5`` beside ``common``, Tables 7 and
9, and ``threes``, the sets of three) · ``latent_count`` (notebook 07: EMG-7, Table 8 —
``emg7``) · ``composed_augmentation`` (notebook 08: EMG-8 — ``emg8`` beside ``compml``).

The last four are packages, one per claim group, with one module per claim beside what the
group's claims share.

Layers: docs/DESIGN.md."""
