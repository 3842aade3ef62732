"""EMG-6 (Sec. 5.5 Q3, Fig. 5–6: composed and multi-concept maps "demonstrate consistent high-
and low-energy regions"); the registered claim is EMG-6 in
``repro.claims.registry_energymogen``.

Denoising-loss energy maps on a 2-D slice of latent space (:func:`latent_plane`,
:func:`energy_landscape`, :func:`smooth_energy_map`, :func:`map_similarity`; one conjunction
or negation case: :func:`energy_map_case`, every case of a seed: :func:`energy_map_cases`,
every seed: :func:`energy_map_study`, the per-seed numbers between floor and ceiling:
:func:`map_similarities`); controls: :func:`energy_map_controls` (A/A runs: the floor read on
an independently trained copy); the claim: :func:`emg6_result`; the notebook's tables and
figures: :func:`map_cases_markdown`, :func:`map_similarity_markdown`,
:func:`raw_maps_markdown`, :func:`save_energy_map_figures`.
"""

from __future__ import annotations

import os
import textwrap
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import matplotlib.pyplot as plt
import numpy as np
import scipy.ndimage
import torch
from matplotlib.figure import Figure
from torch import Tensor

from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core.diffusion import GaussianDiffusion
from repro.core.tables import interval_text, markdown_table, render
from repro.energymogen import settings as rule_settings
from repro.energymogen.compose import Condition
from repro.energymogen.data import (
    NotMeasurable,
    StandInData,
    concept_text,
    not_measurable_reason,
    pair_caption,
)
from repro.energymogen.energy_contour_maps.notebook_settings import EnergyViewSettings
from repro.energymogen.harness import AASlot, aa_controls, copy_seed, copy_source
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, Sampler, pipeline_for
from repro.energymogen.settings import ARM_CONCEPTS, HELD_OUT_PAIRS, LOWER_CONCEPTS, NEGATION_CASES
from repro.models.latent_denoiser import LatentDenoiser
from repro.motion.plotting import save_figure

__all__ = ["LatentPlane", "MAP_KINDS", "case_similarities", "emg6_result", "energy_landscape",
           "energy_map_case", "energy_map_cases", "energy_map_controls", "energy_map_study",
           "energy_maps_figure", "latent_plane", "map_cases_markdown", "map_similarities",
           "map_similarity", "map_similarity_figure", "map_similarity_markdown",
           "raw_maps_markdown", "save_energy_map_figures", "smooth_energy_map"]


@dataclass(frozen=True)
class LatentPlane:
    """A 2-D slice: z(u, v) = center + u·basis[0] + v·basis[1], the grid spanning ±extent."""

    center: Tensor
    basis: Tensor
    extent: tuple[float, float]
    scores: np.ndarray

    def grid(self, size: int) -> tuple[np.ndarray, np.ndarray, Tensor]:
        """(u (G,), v (G,), latents (G·G, N, d)) with row-major (v, u) order."""
        u = np.linspace(-self.extent[0], self.extent[0], size)
        v = np.linspace(-self.extent[1], self.extent[1], size)
        uu, vv = np.meshgrid(u, v)
        coords = torch.tensor(np.stack([uu.ravel(), vv.ravel()], 1), dtype=self.basis.dtype)
        flat = self.center.reshape(1, -1) + coords @ self.basis
        return u, v, flat.reshape(-1, *self.center.shape)


def latent_plane(latents: Tensor, margin: float = 1.25) -> LatentPlane:
    """The plane of the first two principal components of ``latents`` (B, N, d), centred at
    their mean, spanning ``margin`` × the largest |score| on each axis (our choice)."""
    flat = latents.reshape(latents.shape[0], -1).double()
    center = flat.mean(0)
    _, _, vt = torch.linalg.svd(flat - center, full_matrices=False)
    basis = vt[:2]
    scores = ((flat - center) @ basis.T).numpy()
    extent = tuple(float(margin * np.abs(scores[:, k]).max()) for k in range(2))
    return LatentPlane(center.float().reshape(latents.shape[1:]), basis.float(), extent, scores)


def energy_landscape(denoiser: LatentDenoiser, diffusion: GaussianDiffusion,
                     latents: Tensor, conditions: Mapping[str, Condition | None],
                     combinations: Mapping[str, Mapping[str, float]], *,
                     timesteps: Sequence[int], n_noise: int, seed: int,
                     chunk: int = 4096) -> dict[str, np.ndarray]:
    """Denoising-loss energies at every latent z of ``latents`` (M, N, d) (our definition):

        E_k(z) = mean over (t, ε) of ‖ε̂_k(√ᾱ_t z + √(1−ᾱ_t) ε, t) − ε‖² / dim,

    the Monte-Carlo form of the training loss (Eq. 2), itself a bound on −log p(z|·) up to
    weights and constants. ε̂_k = Σ_j w_kj ε(c_j) for ``combinations[k]`` = {condition: w}
    over ``conditions`` (None = ∅), e.g. Eq. 7 with unit weights: {∅: −1, c1: 1, c2: 1}.
    The same (t, ε) draws are used for every z and every k (common random numbers).
    Returns k → (M,).
    """
    generator = torch.Generator().manual_seed(seed)
    draws = [(int(t), torch.randn(latents.shape[1:], generator=generator))
             for t in timesteps for _ in range(n_noise)]
    dim = int(np.prod(latents.shape[1:]))
    totals = {k: torch.zeros(latents.shape[0], dtype=torch.float64) for k in combinations}
    with torch.no_grad():
        for t, noise in draws:
            tt = torch.full((latents.shape[0],), t, dtype=torch.long)
            z_t = diffusion.q_sample(latents, tt, noise.expand_as(latents))
            eps = {}
            for name, cond in conditions.items():
                parts = []
                for start in range(0, latents.shape[0], chunk):
                    x = z_t[start:start + chunk]
                    tokens, mask = cond if cond is not None else denoiser.null_text(1)
                    parts.append(denoiser(x, tt[start:start + chunk],
                                          tokens.expand(x.shape[0], -1, -1),
                                          mask.expand(x.shape[0], -1)))
                eps[name] = torch.cat(parts)
            for key, weights in combinations.items():
                pred = sum(float(w) * eps[name] for name, w in weights.items())
                totals[key] += ((pred - noise).pow(2).flatten(1).sum(1) / dim).double()
    return {k: (v / len(draws)).numpy() for k, v in totals.items()}


def smooth_energy_map(grid_values: np.ndarray, upsample: int = 4,
                      sigma: float = 2.0) -> np.ndarray:
    """Interpolate a (G, G) map by ``upsample`` (cubic spline, ``scipy.ndimage.zoom``) and
    Gaussian-smooth it (``scipy.ndimage.gaussian_filter``, σ in fine pixels), as Fig. 5/6."""
    fine = scipy.ndimage.zoom(np.asarray(grid_values, dtype=np.float64), upsample, order=3)
    return scipy.ndimage.gaussian_filter(fine, sigma)


def map_similarity(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two maps (flattened)."""
    a, b = np.ravel(a), np.ravel(b)
    if a.shape != b.shape:
        raise ValueError(f"maps differ in size: {a.shape} vs {b.shape}")
    return float(np.corrcoef(a, b)[0, 1])


def _control_pair(pair: tuple[str, str], start: int) -> tuple[str, str]:
    """The next held-out pair (cyclically from ``start``) sharing no concept with ``pair``."""
    for k in range(len(HELD_OUT_PAIRS)):
        other = HELD_OUT_PAIRS[(start + k) % len(HELD_OUT_PAIRS)]
        if not set(other) & set(pair):
            return other
    raise ValueError(f"no held-out pair is disjoint from {pair}")


def _control_concept(kept: str, pair: tuple[str, str], start: int) -> str:
    """A concept of the kept concept's group (lower/arms) outside ``pair`` (cyclic)."""
    group = LOWER_CONCEPTS if kept in LOWER_CONCEPTS else ARM_CONCEPTS
    options = [c for c in group if c not in pair]
    return options[start % len(options)]


def case_similarities(smooth: Mapping[str, np.ndarray],
                      kind: Literal["conjunction", "negation"]) -> dict[str, float]:
    """Pearson r of the maps of one case (``smooth``: "composed", "concept 1", "concept 2",
    "multi-concept", "paraphrase", "control"): composed ~ multi; the floor, one concept alone
    ~ multi (conjunction: the better of the two concepts; negation: concept 1, c_i before
    negating); the ceiling, the paraphrase ~ multi; composed ~ control; each concept ~ multi."""
    to_multi = {name: map_similarity(smooth[name], smooth["multi-concept"])
                for name in ("composed", "concept 1", "concept 2", "paraphrase")}
    floor = (max(to_multi["concept 1"], to_multi["concept 2"]) if kind == "conjunction"
             else to_multi["concept 1"])
    return {"similarity_to_multi": to_multi["composed"], "similarity_floor": floor,
            "similarity_ceiling": to_multi["paraphrase"],
            "similarity_concept_1_to_multi": to_multi["concept 1"],
            "similarity_concept_2_to_multi": to_multi["concept 2"],
            "similarity_to_control": map_similarity(smooth["composed"], smooth["control"])}


def _paraphrase(text: str, draw: Callable[[], str], tries: int = 50) -> str:
    """Another wording of ``text``: the first of ``draw()``'s texts that differs from it."""
    for _ in range(tries):
        other = draw()
        if other != text:
            return other
    raise ValueError(f"no paraphrase of {text!r} in {tries} draws")


def _case_texts(data: StandInData, kind: Literal["conjunction", "negation"], case_index: int,
                rng: np.random.Generator, s: float
                ) -> tuple[dict[str, str], dict[str, float], Sampler, dict[str, str]]:
    """The texts of one :func:`energy_map_case` (c1, c2, multi, control, ceiling, drawn from
    ``rng`` of the stand-in ``data``), the composed energy's weights, the composed sampler
    (guidance ``s``) and the case's labels, for a conjunction or a negation case."""
    if kind == "conjunction":
        pair = HELD_OUT_PAIRS[case_index % len(HELD_OUT_PAIRS)]
        control_pair = _control_pair(pair, case_index + 1)

        def caption(p: tuple[str, str]) -> str:
            clips = [i for i, c in enumerate(data.test_concepts) if tuple(c) == p]
            i = clips[int(rng.integers(len(clips)))]
            return data.test_captions[i][int(rng.integers(len(data.test_captions[i])))]

        texts = {"c1": concept_text(pair[0], rng), "c2": concept_text(pair[1], rng),
                 "multi": caption(pair), "control": caption(control_pair)}
        texts["ceiling"] = _paraphrase(texts["multi"], lambda: caption(pair))
        composed = {"∅": -1.0, "c1": 1.0, "c2": 1.0}
        sampler = Sampler("latent")
        label = {"case": "/".join(pair), "control": "/".join(control_pair)}
    else:
        pair, negated = NEGATION_CASES[case_index % len(NEGATION_CASES)]
        kept = pair[0] if pair[1] == negated else pair[1]
        control = _control_concept(kept, pair, case_index)
        texts = {"c1": pair_caption(pair, rng), "c2": concept_text(negated, rng),
                 "multi": concept_text(kept, rng), "control": concept_text(control, rng)}
        texts["ceiling"] = _paraphrase(texts["multi"], lambda: concept_text(kept, rng))
        composed = {"∅": 1.0, "c1": 1.0, "c2": -1.0}
        sampler = Sampler("latent", weights=(s, -s))
        label = {"case": f"{'/'.join(pair)} not {negated}", "control": control}
    return texts, composed, sampler, label


def energy_map_case(pipe: EnergyMoGenPipeline, kind: Literal["conjunction", "negation"],
                    case_index: int, seed: int, *, grid: int = 16, n_noise: int = 4,
                    timesteps: Sequence[int] = (100, 300, 500, 700, 900), samples: int = 16,
                    upsample: int = 4, sigma: float = 2.0) -> dict[str, Any]:
    """One EMG-6 case: energy maps of concept 1, concept 2, their composition, the single
    multi-concept text and an unrelated control, on one 2-D latent slice.

    - conjunction: a held-out pair (``case_index`` cyclic); composed = Eq. 7 with unit weights
      {∅: −1, c1: 1, c2: 1} (the product p(z|c1)p(z|c2)/p(z)); multi = the joined text;
      control = the joined text of a held-out pair sharing no concept.
    - negation: a :data:`NEGATION_CASES` entry; c1 = the pair's text (c_i), c2 = the negated
      concept's text (c_j); composed = Eq. 8 with w = 1 {∅: 1, c1: 1, c2: −1}; multi = the
      kept concept's own text (as "walking to the right" in Fig. 5b); control = another
      concept of the kept concept's group.
    - slice (our choice): the plane of the first two principal components of generated
      latents — ``samples`` each from c1, c2, the composition (guided with s) and multi.
    - energy: :func:`energy_landscape` on a ``grid``² grid, smoothed by
      :func:`smooth_energy_map`; the maps compared are the *conditional part* E_k − E_∅
      (``smooth``), which removes the noise floor and the distance from the data that every
      condition shares (in the quick test run, an untrained model, raw maps correlated
      ≥ 0.999 whatever the text; we fixed this measure then, before any full run); raw-map
      similarities are returned too (``raw_similarity_*``, ``smooth_raw``).
    - similarity: Pearson correlation of the smoothed conditional maps; ``similarity_to_multi``
      (composed ~ multi) sits between a **floor**, one concept alone ~ multi (conjunction: the
      better of concept 1 and concept 2; negation: c_i, the text before negating), and a
      **ceiling**, a paraphrase of the multi-concept text ~ multi (another caption of the
      pair; negation: another wording of the kept concept) — how alike two texts of one
      meaning are on this slice; ``similarity_to_control`` (an unrelated text)
      is context.
    """
    rng = np.random.default_rng([seed, 606, 0 if kind == "conjunction" else 1])
    texts, composed, sampler, label = _case_texts(pipe.data, kind, case_index, rng,
                                                  pipe.config.guidance_scale)
    rows = {"concept 1": (Sampler("single"), [], [texts["c1"]] * samples),
            "concept 2": (Sampler("single"), [], [texts["c2"]] * samples),
            "composed": (sampler, [[texts["c1"]] * samples, [texts["c2"]] * samples], None),
            "multi-concept": (Sampler("single"), [], [texts["multi"]] * samples)}
    generated = {name: pipe.sample(spec, concepts, multi, seed, batch=samples)
                 for name, (spec, concepts, multi) in rows.items()}
    plane = latent_plane(torch.cat(list(generated.values())))
    u, v, grid_latents = plane.grid(grid)
    conditions: dict[str, Condition | None] = {"∅": None}
    conditions.update({k: pipe.encode([t]) for k, t in texts.items()})
    combinations = {"concept 1": {"c1": 1.0}, "concept 2": {"c2": 1.0}, "composed": composed,
                    "multi-concept": {"multi": 1.0}, "control": {"control": 1.0},
                    "paraphrase": {"ceiling": 1.0}, "unconditional": {"∅": 1.0}}
    energies = energy_landscape(pipe.denoiser, pipe.diffusion, grid_latents.to(pipe.device),
                                conditions, combinations, timesteps=timesteps,
                                n_noise=n_noise, seed=seed)
    raw = {k: e.reshape(grid, grid) for k, e in energies.items()}
    smooth_raw = {k: smooth_energy_map(m, upsample, sigma) for k, m in raw.items()}
    smooth = {k: m - smooth_raw["unconditional"] for k, m in smooth_raw.items()
              if k != "unconditional"}
    flat = plane.center.reshape(1, -1).double()
    scores = {name: ((z.reshape(z.shape[0], -1).double().cpu() - flat) @ plane.basis.double().T
                     ).numpy() for name, z in generated.items()}
    return {"kind": kind, "texts": texts, **label, "u": u, "v": v, "raw": raw,
            "smooth_raw": smooth_raw, "smooth": smooth, "scores": scores,
            "extent": plane.extent, **case_similarities(smooth, kind),
            "raw_similarity_to_multi": map_similarity(smooth_raw["composed"],
                                                      smooth_raw["multi-concept"]),
            "raw_similarity_to_control": map_similarity(smooth_raw["composed"],
                                                        smooth_raw["control"])}


MAP_KINDS: tuple[str, str] = ("conjunction", "negation")


def energy_map_cases(pipe: EnergyMoGenPipeline, kind: Literal["conjunction", "negation"],
                     seed: int, *, count: int | None = None, **kwargs: Any
                     ) -> list[dict[str, Any]]:
    """:func:`energy_map_case` for every held-out pair (conjunction) or every
    :data:`NEGATION_CASES` entry (negation) of one seed — or the first ``count`` of them (a
    quick run) — on that seed's model, noise and texts."""
    total = len(HELD_OUT_PAIRS) if kind == "conjunction" else len(NEGATION_CASES)
    return [energy_map_case(pipe, kind, k, seed, **kwargs)
            for k in range(total if count is None else min(count, total))]


#: what :func:`map_similarities` averages per seed: measurement suffix → case key
_SIMILARITIES = {"similarity_to_multi": "similarity_to_multi",
                 "similarity_floor": "similarity_floor",
                 "similarity_ceiling": "similarity_ceiling",
                 "similarity_to_control": "similarity_to_control"}


def energy_map_study(source: PipelineSource, seeds: Sequence[int], *, count: int | None = None,
                     **kwargs: Any) -> dict[str, list[list[dict[str, Any]]]] | NotMeasurable:
    """EMG-6's cases: kind (:data:`MAP_KINDS`) → one :func:`energy_map_cases` list per seed
    (seed s on ``pipeline_for(source, s)``, ``count`` and ``kwargs`` passed on). On a data
    folder a ``data.NotMeasurable``: the maps compare composed concepts of the stand-in (held-out
    pairs, negation cases and their concept texts) with their joined text, which real captions
    do not decompose into."""
    first = pipeline_for(source, seeds[0])
    if not first.data.labelled:
        return NotMeasurable(not_measurable_reason(first.data))
    return {kind: [energy_map_cases(pipeline_for(source, sd), kind, sd, count=count, **kwargs)
                   for sd in seeds]
            for kind in MAP_KINDS}


def map_similarities(cases_by_seed: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                     | NotMeasurable) -> dict[str, list[float]] | NotMeasurable:
    """EMG-6's measurements: per kind and seed, the mean over that seed's cases of composed ~
    multi, the floor, the ceiling and composed ~ control (``{kind}_{suffix}`` → per-seed
    list). ``cases_by_seed``: kind → one list of :func:`energy_map_case` results per seed
    (:func:`energy_map_study`; a ``NotMeasurable`` is passed on)."""
    if isinstance(cases_by_seed, NotMeasurable):
        return cases_by_seed
    return {f"{kind}_{suffix}": [float(np.mean([c[key] for c in cases])) for cases in per_seed]
            for kind, per_seed in cases_by_seed.items() for suffix, key in _SIMILARITIES.items()}


def energy_map_controls(source: PipelineSource,
                        measured: Mapping[str, Sequence[float]] | NotMeasurable,
                        seeds: Sequence[int], *, count: int | None = None, **kwargs: Any
                        ) -> Controls | None:
    """EMG-6's controls as A/A runs (``harness.aa_controls``). The reference arm is the floor,
    r(one concept alone's map, the multi-concept map), a reading that lives in one pipeline's
    latent plane (maps of two trainings are on different latent coordinates, so a reading is
    compared, never a map). The null: seed s's floor against the floor read the same way
    (:func:`energy_map_study` with ``count`` and ``kwargs``: seed s's cases, noise draws and
    grid) on the pipeline of seed s' = ``copy_seed(seeds, s)`` (the run's next seed, cyclic;
    one seed: s + 1), in the composed arm's place, per case kind. Positive: the same A/A with
    twice δ (0.2 in r) added to the composed arm. None for a ``NotMeasurable`` (a data
    folder: no maps, no claim to control)."""
    if isinstance(measured, NotMeasurable):
        return None
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    copy = map_similarities(energy_map_study(copy_source(source, copies), seeds, count=count,
                                             **kwargs))
    if isinstance(copy, NotMeasurable):
        return None
    slots = [AASlot((f"{kind}_similarity_to_multi",), (f"{kind}_similarity_floor",))
             for kind in MAP_KINDS]
    return aa_controls("EMG-6", measured, copy, slots,
                       {kind: [(f"{kind}_similarity_to_multi",)] for kind in MAP_KINDS},
                       copies=copies, what="the floor (one concept alone's map ~ multi)")


#: the per-case values EMG-6 keeps beside its per-seed measurements
_CASE_KEYS = ("case", "control", "texts", "similarity_to_multi", "similarity_floor",
              "similarity_ceiling", "similarity_concept_1_to_multi",
              "similarity_concept_2_to_multi", "similarity_to_control", "raw_similarity_to_multi",
              "raw_similarity_to_control")


def map_cases_markdown(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                       | NotMeasurable, seeds: Sequence[int]) -> str:
    """Notebook 04's table of EMG-6's cases (``energy_map_study``): per kind, seed and
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
    """EMG-6 from ``map_similarities`` (``measured``: per kind and seed, composed ~
    multi, the floor, the ceiling and the control) and the cases behind it (``cases``: kind →
    one list of ``energy_map_case`` results per seed); on a data folder (``cases`` a
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


_MAP_COLUMNS = ("concept 1", "concept 2", "composed", "multi-concept", "paraphrase",
                "control")


def save_energy_map_figures(cases: Mapping[str, Any] | NotMeasurable,
                            measured: Mapping[str, Sequence[float]] | NotMeasurable,
                            seeds: Sequence[int], figure_path: Callable[[str], Path]
                            ) -> list[Path]:
    """Notebook 04's EMG-6 figures saved under ``figure_path(name)``: the first case of each
    kind on the first seed (:func:`energy_maps_figure`) and :func:`map_similarity_figure`
    (their paths, in that order); none when not measurable (a data folder)."""
    if isinstance(cases, NotMeasurable) or isinstance(measured, NotMeasurable):
        return []
    return [save_figure(energy_maps_figure({kind: per_seed[0][0]
                                            for kind, per_seed in cases.items()}, seeds[0]),
                        figure_path("emg6_energy_contour_maps.png")),
            save_figure(map_similarity_figure(measured), figure_path("emg6_map_similarity.png"))]


def energy_maps_figure(cases: Mapping[str, Mapping[str, Any]], seed: int) -> Figure:
    """EMG-6 as Fig. 5/6: one row per kind (``energy_map_case`` results of one seed),
    the smoothed conditional maps of every condition with that row's samples."""
    fig, axes = plt.subplots(2, len(_MAP_COLUMNS), figsize=(20, 6.6))
    for row, kind in enumerate(("conjunction", "negation")):
        case = cases[kind]
        extent = [-case["extent"][0], case["extent"][0], -case["extent"][1], case["extent"][1]]
        levels = np.linspace(min(case["smooth"][c].min() for c in _MAP_COLUMNS),
                             max(case["smooth"][c].max() for c in _MAP_COLUMNS), 14)
        if levels[0] == levels[-1]:
            levels = np.linspace(levels[0] - 1e-9, levels[0] + 1e-9, 3)
        for col, name in enumerate(_MAP_COLUMNS):
            ax = axes[row, col]
            ax.contourf(case["smooth"][name], levels=levels, cmap="viridis", extent=extent,
                        origin="lower")
            ax.contour(case["smooth"][name], levels=levels, colors="k", linewidths=0.3,
                       extent=extent, origin="lower")
            key = {"concept 1": "c1", "concept 2": "c2", "multi-concept": "multi",
                   "paraphrase": "ceiling", "control": "control"}.get(name)
            text = case["texts"][key] if key else (
                "Eq. 7 (unit weights)" if kind == "conjunction" else "Eq. 8 (w = 1)")
            if name in case["scores"]:
                pts = case["scores"][name]
                ax.plot(pts[:, 0], pts[:, 1], "w.", ms=3)
            ax.set_title(f"{name}\n" + "\n".join(textwrap.wrap(text, 34)), fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
        axes[row, 0].set_ylabel(f"{kind}: {case['case']}", fontsize=8)
    fig.suptitle("Conditional part of the denoising-loss energy, E_k − E_∅, on the PC1–PC2 "
                 "slice of generated latents (dark = low energy; white dots: that row's "
                 f"samples). Seed {seed} (default model).", fontsize=9)
    return fig


def map_similarity_figure(measured: Mapping[str, Sequence[float]]) -> Figure:
    """EMG-6's numbers (``map_similarities``): per kind, the floor (one concept alone ~
    multi), composed ~ multi and the ceiling (a paraphrase ~ multi), one line per seed (each
    seed the mean over its cases); composed ~ unrelated control as grey crosses."""
    fig, ax = plt.subplots(figsize=(8, 3.8))
    ticks, labels = [], []
    for k, kind in enumerate(("conjunction", "negation")):
        x = 4 * k + np.arange(3)
        values = np.array([measured[f"{kind}_similarity_{what}"]
                           for what in ("floor", "to_multi", "ceiling")])      # (3, seeds)
        for seed_values in values.T:
            ax.plot(x, seed_values, "-", color="grey", lw=0.8)
        for xi, row, marker, colour in zip(x, values, ("v", "o", "^"), ("C3", "C0", "C2"),
                                           strict=True):
            ax.plot(np.full(row.size, xi), row, marker, color=colour)
        control = measured[f"{kind}_similarity_to_control"]
        ax.plot(np.full(len(control), x[1] + 0.25), control, "x", color="0.5")
        ticks += list(x)
        labels += [f"{kind[:4]}.: floor\n(one concept)", f"{kind[:4]}.: composed",
                   f"{kind[:4]}.: ceiling\n(paraphrase)"]
    ax.set_xticks(ticks, labels, fontsize=8)
    ax.set_ylabel("Pearson r with the multi-concept map")
    ax.set_title("EMG-6: one line per seed (mean over its cases); grey ×: composed ~ unrelated "
                 "control", fontsize=9)
    return fig
