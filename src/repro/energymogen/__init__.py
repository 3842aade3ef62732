"""EnergyMoGen (layer 5): its composition operators, pipeline, experiments and figures. Never
imports repro.gmd.

Modules, each importing only those above it in this list (and lower layers):
``compose`` (Eq. 3–4, 7–10 on ε) · ``config`` (the concept pool, held-out pairs,
``PipelineConfig``) · ``data`` (stand-in data, composition and negation test items) ·
``text_stage`` (the frozen text encoder, the stand-in for CLIP) · ``convergence`` (the
training plan to convergence and each model's training record) · ``pipeline`` (the trained
pipeline, its stages and sampling) · ``harness`` (the text-to-motion test set and generation
metrics shared by EMG-7 and EMG-8) · ``energy`` (EMG-1, 6, 9) · ``gradient_field`` (EMG-1's
per-t residual Jacobian asymmetry and loop integrals) · ``fid_checks`` (EMG-9's fixed cases) ·
``timelines`` (EMG-5's MTT-style timelines and the real "then" clips) · ``studies`` (EMG-2,
3, 4, 5) · ``three_concepts`` (notebook 05's sets of three, outside the rules) ·
``planted`` (the planted sample sets of the controls) · ``noise_calibration`` (the
FID-vs-noise curve of EMG-7's and 8's controls) · ``latent_count`` (EMG-7) ·
``model_gates`` (the gates of the VAE, latent denoiser and evaluator) ·
``augmentation`` (EMG-8, which measures its fine-tuned denoisers' gate) · ``controls`` (the
positive and null controls of EMG-2 to 8) · ``settings`` (the settings per notebook and
scale) · ``rule_settings`` (what each claim's rule quotes of its run's
settings) · ``energy_claims`` (EMG-1, 6, 9 as notebook 04 records them) ·
``composition_claims`` (EMG-2 to 5 as notebooks 04 and 05 record them) · ``t2m_claims`` (EMG-7
and 8 as notebooks 07 and 08 record them) · ``figures`` (the notebooks' figures) ·
``training_report`` (the notebooks' training tables and validation curves).

Layers: docs/DESIGN.md."""
