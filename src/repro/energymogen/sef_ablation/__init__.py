"""Notebook 05: the ablation of Synergistic Energy Fusion and of AGD's step sizes — the rows of
the paper's Tables 3, 7 and 9 on the pipeline, the MTT-style timelines and the sets of three;
the settings are ``SEFAblationSettings``.

- ``common`` — what both claims share: :class:`SEFAblationSettings`; the paper's rows, Table 3
  (Sec. 5.4), Table 7 (appendix C, the λ of Eq. 10) and Table 9 (appendix E, the γ of Eq. 4),
  keyed as the registry spells them (``lambda_key``, ``gamma_key``); measured over seeds, one
  pipeline or one trained model per seed (``pipeline.SeedPipelines``), by ``run_rows`` and
  shown beside the paper's values (``markdown_table``).
- ``emg4`` — **EMG-4** (app. E, Table 9: "[γ_attn, γ_reg] = [0.001, 0.002] achieves best
  results on MTT"): how far AGD (Eq. 4) moves the text embedding (``agd_relative_change``),
  Table 9's rows transferred (``agd_scale``, ``table9_rows``), ``emg4_result``; its controls:
  ``step_size_controls``.
- ``emg5`` — **EMG-5** (Sec. 5.5 Q2, Tables 3 and 7: "Synergistic Energy Fusion (SEF)
  effectively alleviates these issues"): the λ rows of ``run_rows`` and their transitions on
  the MTT-style timelines (``timeline_items``, ``timeline_rows``, ``timeline_measurements``);
  ``emg5_result``; its controls: ``sef_controls`` (A/A runs: the latent row of an
  independently trained copy in the semantic and SEF rows' places).
- ``threes`` — **the sets of three** (outside the rules): the tables of every row on
  ``settings.THREE_CONCEPT_SETS`` (``run_rows(..., test_set="threes")``), of the two-concept
  control on the same motions (``settings.THREES_AS_PAIRS``, ``test_set="threes_as_pairs"``),
  and the summary's line on both (``threes_markdown``, ``control_markdown``,
  ``summary_line``). No number there enters a verdict.

On a data folder (real data, no concept labels) EMG-4 is measured; EMG-5 and the sets of
three compose the stand-in's concepts and are not measurable (``data.NotMeasurable``).
"""

from repro.energymogen.sef_ablation.common import SEFAblationSettings

__all__ = ["SEFAblationSettings"]
