"""The energy view's claims as notebook 04 records them: EMG-1 (Sec. 3.2, Eq. 5–6: "diffusion
models can be interpreted as EBMs under the gradient descent step η = 1"), EMG-6 (Sec. 5.5
Q3, Fig. 5–6: composed and multi-concept maps "demonstrate consistent high- and low-energy
regions") and EMG-9 (app. G.2, Eq. 12: the FID formula as printed).

Each function takes what the experiment measured (``energy.energy_view_study`` and
``gradient_field.gradient_field_study``; ``energy.energy_map_cases`` and
``energy.map_similarities``; ``energy.fid_formula_errors`` and
``fid_checks.fid_fixed_cases``) and returns the :class:`~repro.claims.result.ClaimResult`
the notebook records: the measurements the registered rule reads, headline, notes and the
values kept beside them. The markdown helpers render what the notebook shows beside them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core.tables import interval_text, markdown_table, render
from repro.energymogen import rule_settings
from repro.energymogen.data import NotMeasurable
from repro.energymogen.energy import MAP_KINDS
from repro.energymogen.settings import EnergyViewSettings

__all__ = ["emg1_result", "emg6_result", "emg9_result", "fid_draws_markdown",
           "fid_fixed_cases_markdown", "map_cases_markdown", "map_similarity_markdown",
           "raw_maps_markdown"]

#: the per-case values EMG-6 keeps beside its per-seed measurements
_CASE_KEYS = ("case", "control", "texts", "similarity_to_multi", "similarity_floor",
              "similarity_ceiling", "similarity_concept_1_to_multi",
              "similarity_concept_2_to_multi", "similarity_to_control", "raw_similarity_to_multi",
              "raw_similarity_to_control")


def emg1_result(energy_view: Mapping[str, Any], field: Mapping[str, Any],
                settings: EnergyViewSettings, seed: int, *,
                models: Sequence[Mapping[str, Any]], figures: Sequence[str | os.PathLike]
                ) -> ClaimResult:
    """EMG-1 from ``energy.energy_view_study`` (``energy_view``: the Langevin-step and
    sum-of-energies errors, the Jacobian asymmetry) and ``gradient_field.gradient_field_study``
    (``field``: the residual asymmetry and loop integrals by t), both at ``seed``."""
    langevin, linearity = energy_view["langevin"], energy_view["linearity"]
    sum_error, jacobian_median = energy_view["sum_error"], energy_view["jacobian_median"]
    asym, jac_timesteps = energy_view["asymmetry"], settings.jacobian_timesteps
    measured = {"langevin_step_max_abs_error": langevin["max_abs_error"],
                "sum_of_energies_max_abs_error": sum_error,
                "jacobian_relative_asymmetry": jacobian_median,
                "residual_jacobian_asymmetry_by_t": field["residual_jacobian_asymmetry_by_t"],
                "loop_integral_relative_by_t": field["loop_integral_relative_by_t"]}
    headline = (f"Langevin form exact (|Δ| ≤ {langevin['max_abs_error']:.1e}); energies add "
                f"(|Δ| ≤ {sum_error:.1e}); Jacobian asymmetry of ε_θ {jacobian_median:.2f} "
                f"(random init {np.median(asym['random init, text']):.2f})")
    notes = ("Energy with ∇E_t = ε_θ/√(1−ᾱ_t); DDPM and DDIM steps are exact Langevin steps on "
             "E_t − κ_t‖z‖²/2 with step η_t (float64, all 1000 t); Eq. 5's η = 1 is the "
             "small-β reading (exact coefficient on ε in "
             f"[{langevin['ddpm_eps_coefficient_min']:.1e}, "
             f"{langevin['ddpm_eps_coefficient_max']:.1e}]). Sum of energies: line-integral "
             "energies (16-node Gauss–Legendre from 0, float64 copy of the denoiser) of the "
             f"Eq. 7 sampler (w = s = {settings.pipeline.guidance_scale}) vs E∅ + Σ w(E_i − E∅), "
             f"t ∈ {set(settings.linearity_timesteps)}. Jacobian: "
             f"{settings.emg1_samples} noised test latents × t ∈ {list(jac_timesteps)}, with the "
             "joined text and ∅; median pooled.")
    if "data_dir" in energy_view:
        notes += (f" Data folder {energy_view['data_dir']} (real data): the test latents are its "
                  "test windows, the joined text one of each window's captions and the two "
                  "summed conditions two captions of different windows (Eq. 5–7's identities "
                  "hold for any conditions; nothing composed is read).")
    extra = {"ddpm_max_abs_error": langevin["ddpm_max_abs_error"],
             "ddim_max_abs_error": langevin["ddim_max_abs_error"],
             "eps_coefficient_range": [langevin["ddpm_eps_coefficient_min"],
                                       langevin["ddpm_eps_coefficient_max"]],
             "line_integral_gradient_relative_error": [x["gradient_relative_error"]
                                                       for x in linearity],
             "loop_radius_by_t": field["loop_radius_by_t"],
             "residual_and_loop_per_sample": field["per_sample"],
             "jacobian_asymmetry_by_t": {name: dict(zip(map(str, jac_timesteps),
                                                        np.median(v, axis=1).tolist(),
                                                        strict=True))
                                         for name, v in asym.items()}}
    return ClaimResult("EMG-1", measured, seeds=[seed], settings=rule_settings.emg1(settings),
                       models=models, figures=figures,
                       headline=headline, notes=notes, extra=extra)


def map_cases_markdown(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                       | NotMeasurable, seeds: Sequence[int]) -> str:
    """Notebook 04's table of EMG-6's cases (``energy.energy_map_study``): per kind, seed and
    case the floor, composed, ceiling and control similarities and the raw maps'; on a data
    folder the reason it is not measurable."""
    if isinstance(cases, NotMeasurable):
        return f"**EMG-6 energy maps**: {cases.reason}."
    rows = [[kind, sd, case["case"], f"{case['similarity_floor']:.3f}",
             f"{case['similarity_to_multi']:.3f}", f"{case['similarity_ceiling']:.3f}",
             f"{case['similarity_to_control']:.3f}",
             f"{case['raw_similarity_to_multi']:.4f} / {case['raw_similarity_to_control']:.4f}"]
            for kind, per_seed in cases.items() for sd, found in zip(seeds, per_seed, strict=True)
            for case in found]
    return markdown_table(
        ["kind", "seed", "case", "floor (one concept)", "composed", "ceiling (paraphrase)",
         "control", "raw maps: composed~multi / ~control"], rows)


def map_similarity_markdown(measured: Mapping[str, Sequence[float]] | NotMeasurable) -> str:
    """Notebook 04's table of EMG-6's similarities per kind (mean ± 95 % half-width over
    seeds): the floor, composed ~ multi, the ceiling and the unrelated control."""
    if isinstance(measured, NotMeasurable):
        return f"**EMG-6 map similarities**: {measured.reason}."
    return markdown_table(
        ["kind", "floor: one concept ~ multi", "composed ~ multi", "ceiling: paraphrase ~ multi",
         "composed ~ unrelated control"],
        [[kind] + [interval_text(measured[f"{kind}_similarity_{what}"])
                   for what in ("floor", "to_multi", "ceiling", "to_control")]
         for kind in MAP_KINDS])


def emg6_result(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]] | NotMeasurable,
                measured: Mapping[str, Sequence[float]] | NotMeasurable,
                settings: EnergyViewSettings, seeds: Sequence[int], *, controls: Controls | None,
                models: Sequence[Mapping[str, Any]], figures: Sequence[str | os.PathLike]
                ) -> ClaimResult:
    """EMG-6 from ``energy.map_similarities`` (``measured``: per kind and seed, composed ~
    multi, the floor, the ceiling and the control) and the cases behind it (``cases``: kind →
    one list of ``energy.energy_map_case`` results per seed); on a data folder (``cases`` a
    ``NotMeasurable``) not measurable on real data (``claims.result.not_measurable_result``)."""
    if isinstance(cases, NotMeasurable):
        return not_measurable_result("EMG-6", cases.reason, seeds,
                                     settings=rule_settings.emg6(settings), models=models)
    headline = ("Pearson r with the multi-concept map, floor / composed / ceiling: " + "; ".join(
        f"{kind} " + "/".join(f"{np.mean(measured[f'{kind}_similarity_{what}']):.3f}"
                              for what in ("floor", "to_multi", "ceiling"))
        for kind in MAP_KINDS))
    notes = ("Energy = denoising loss E_t,ε‖ε̂(z_t,t) − ε‖²/dim (t ∈ {100,…,900}, "
             f"{settings.map_noise_draws} draws, common "
             "random numbers); maps compared: the conditional part E_k − E_∅ (fixed after the "
             "quick test, where raw maps of an untrained model correlated ≥ 0.999 for any texts, "
             "before any full run; raw-map similarities in extra); composed "
             "= Eq. 7 unit weights / Eq. 8 w = 1; slice = PC1–PC2 of generated latents; 16×16 "
             "grid, cubic ×4, Gaussian σ = 2; similarity = Pearson r. "
             "Floor: one concept alone ~ multi (conjunction: the better concept; negation: c_i); "
             "ceiling: a paraphrase of the multi-concept text ~ multi; context: composed ~ "
             "unrelated control (conjunction — joined text of a disjoint held-out pair; "
             "negation — another concept of the kept concept's group). Every held-out pair and "
             "negation case per seed (mean per seed), each seed on its own trained model "
             "(training seed data_seed + s for seed s).")
    extra = {"cases": {kind: [[{k: c[k] for k in _CASE_KEYS} for c in found]
                              for found in per_seed] for kind, per_seed in cases.items()},
             "control_calibration": controls.planted}
    return ClaimResult("EMG-6", dict(measured), seeds=seeds,
                       settings=rule_settings.emg6(settings), controls=controls, models=models,
                       figures=figures, headline=headline, notes=notes, extra=extra)


def raw_maps_markdown(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                      | NotMeasurable) -> str:
    """EMG-6's sentence on the raw maps (E_k itself) against the conditional ones the rule
    compares: the range of each over every case of this run (none on a data folder)."""
    if isinstance(cases, NotMeasurable):
        return ""
    raw = [c[f"raw_similarity_to_{what}"] for per_seed in cases.values() for found in per_seed
           for c in found for what in ("multi", "control")]
    conditional = [c[key] for per_seed in cases.values() for found in per_seed for c in found
                   for key in ("similarity_to_multi", "similarity_floor")]
    return render(
        "In this run the raw maps (E_k itself, before subtracting E_∅) correlate {low:.4f} to "
        "{high:.4f} over every case, composed~multi and composed~control alike; the "
        "conditional maps that the rule compares (composed ~ multi and the floor), {clow:.3f} "
        "to {chigh:.3f}.",
        low=min(raw), high=max(raw), clow=min(conditional), chigh=max(conditional))


def emg9_result(fid_check: Mapping[str, Any], fixed: Mapping[str, Any], seed: int
                ) -> ClaimResult:
    """EMG-9 from ``energy.fid_formula_errors`` (``fid_check``, random commuting Gaussians of
    ``seed``) and ``fid_checks.fid_fixed_cases`` (``fixed``, no random draw)."""
    measured = {
        "fid_vs_closed_form_relative_error": fid_check["fid_vs_closed_form_relative_error"],
        "printed_vs_closed_form_relative_error":
            fid_check["printed_vs_closed_form_relative_error"],
        **{k: fixed[k] for k in ("fid_fixed_cases_max_relative_error", "printed_self_distance",
                                 "printed_fixed_cases_min_relative_error")}}
    headline = (f"ours vs closed form ≤ {fid_check['fid_vs_closed_form_relative_error']:.1e} "
                f"relative; printed Eq. 12 off by ≥ "
                f"{fid_check['printed_vs_closed_form_relative_error']:.2f} relative")
    notes = ("20 random pairs of 16-d Gaussians with commuting covariances (λ ∈ [0.1, 3]); ours: "
             "the largest relative error; printed: the smallest (it is off in every draw).")
    return ClaimResult("EMG-9", measured, seeds=[seed], headline=headline, notes=notes,
                       extra={"draws": fid_check["draws"][:5], "fixed_cases": fixed["cases"]})


def fid_draws_markdown(fid_check: Mapping[str, Any], shown: int = 5) -> str:
    """The first ``shown`` random draws of ``energy.fid_formula_errors``: the closed form, ours
    and the printed Eq. 12."""
    lines = ["| draw | closed form | ours (Eq. with √ and +Tr) | printed Eq. 12 |",
             "|---|---|---|---|"]
    for k, row in enumerate(fid_check["draws"][:shown]):
        lines.append(f"| {k} | {row['closed_form']:.6g} | {row['ours']:.6g} | "
                     f"{row['printed_eq12']:.6g} |")
    return "\n".join(lines)


def fid_fixed_cases_markdown(fixed: Mapping[str, Any]) -> str:
    """``fid_checks.fid_fixed_cases``'s cases: the closed form, ours and the printed Eq. 12."""
    return "**Fixed cases (no random draw)**\n\n" + markdown_table(
        ["case", "closed form", "ours", "printed Eq. 12"],
        [[r["case"], f"{r['closed_form']:.6g}", f"{r['ours']:.6g}", f"{r['printed_eq12']:.6g}"]
         for r in fixed["cases"]])
