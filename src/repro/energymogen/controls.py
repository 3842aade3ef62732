"""Positive and null controls of the EnergyMoGen experiments (issue #13, item 3), one function
per claim: the experiment's own measurement code (oracles, the calls of
``studies.composition_metrics`` and ``evaluator.evaluate_generated`` for the quantities the
rules read, ``energy.map_similarity``, ``latent_count.mpjpe``) run on
the same number of seeds and items, on constructed sample sets whose truth is known.

Every function returns a ``claims.result.Controls``: ``positive`` and ``null`` measured dicts
shaped like the notebook's (the ledger decides them with the claim's own rule); *positive*
plants every part's registered effect δ (registry v2), *null* plants none (the compared arms
come from one source, with independent randomness per seed). Sizes are set analytically or
from a scale factor measured on the data before the arms are drawn (never by trying until a
control passes); ``planted`` records those numbers (the sidecar's ``control_calibration``),
``positive_text``/``null_text`` say what each control's arms are. ``scale``
multiplies every planted effect: 1 (the registered δ) in the notebooks; the tests plant
larger effects to show that the measurement sees them.

The sample sets are built from the stand-in data ("the data itself as the model"): training
and ground-truth clips whose concepts the oracles detect (EMG-2/3), ground-truth test
motions with a fraction of them swapped to another item's motion (R-precision drops linearly
in that fraction) or with their body's movement scaled about its temporal mean (transition
distance scales exactly), test clips with their root height offset (MPJPE is exactly the
offset), and test clips with Gaussian feature noise (FID rises with its size; calibrated on
a draw of its own). A control with one seed cannot decide a direction: in quick runs both
controls come out inconclusive, and the claim with them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from repro.claims.result import Controls
from repro.core import metrics
from repro.energymogen.config import LOWER_CONCEPTS
from repro.energymogen.data import (
    NotMeasurable,
    composition_items,
    energy_view_items,
    negation_items,
    stand_in_clips_of,
)
from repro.energymogen.energy import map_similarity
from repro.energymogen.harness import TextToMotionTest
from repro.energymogen.latent_count import mpjpe
from repro.energymogen.noise_calibration import (
    FidCurve,
    fid_curve,
    reference_embeddings,
    t2m_measurements,
    with_feature_noise,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, pipeline_for
from repro.energymogen.planted import (
    CONTROL_STREAM,
    amplify_transition_steps,
    permute_motions,
    plant_transitions,
    scale_movement,
    swap_motions,
)
from repro.energymogen.studies import (
    pair_index,
    per_pair_mean,
    timeline_measurements,
    transition_distance_cm,
)
from repro.energymogen.timelines import real_then_clips, timeline_items
from repro.standin.oracles import detect_concepts

__all__ = ["CONTROL_STREAM", "augmentation_controls", "amplify_transition_steps",
           "composition_controls", "energy_map_controls", "plant_transitions",
           "latent_count_controls", "scale_movement", "sef_controls", "step_size_controls",
           "swap_motions", "FidCurve", "fid_curve", "permute_motions"]

KINDS = ("positive", "null")


def _rng(seed: int, claim: int, kind: str) -> np.random.Generator:
    return np.random.default_rng([CONTROL_STREAM, claim, KINDS.index(kind), seed])


# --- EMG-2 / EMG-3: oracle-measured rates on generator clips ------------------------------

#: our choice: the single-concept arm's both-present rate in the constructed sets (the
#: registry example's level); the negation baseline keeps its negated concept in 90 %
_BASE_BOTH = 0.3
_BASE_NEGATED = 0.9


_FALLBACK_CLIPS = 4


class _TrainingClips:
    """Training clips by their concepts (single concepts and trained pairs), drawn at random:
    real stand-in motion whose concepts are known, without generating any (for a concept set
    no training clip holds, as in a tiny test configuration, :data:`_FALLBACK_CLIPS` clips are
    generated as the training clips were, ``data.stand_in_clip``, and drawn from)."""

    def __init__(self, pipe: EnergyMoGenPipeline) -> None:
        self.pipe = pipe
        self.index: dict[frozenset[str], list[int]] = {}
        self.generated: dict[frozenset[str], list[set[str]]] = {}
        for i, names in enumerate(pipe.data.train_concepts):
            self.index.setdefault(frozenset(names), []).append(i)

    def found(self, concepts: Sequence[tuple[str, ...]], rng: np.random.Generator
              ) -> list[set[str]]:
        """The oracles' concepts of one random training clip of each concept set."""
        out = []
        for names in concepts:
            options = self.index.get(frozenset(names))
            if options:
                pick = int(rng.choice(options))
                joints = self.pipe.joints(self.pipe.data.train_features[pick:pick + 1])[0]
                out.append(detect_concepts(joints))
                continue
            key = frozenset(names)
            if key not in self.generated:
                clips = stand_in_clips_of(tuple(names), self.pipe.data.frames, rng, _FALLBACK_CLIPS)
                self.generated[key] = [detect_concepts(joints) for _, joints, _ in clips]
            out.append(self.generated[key][int(rng.integers(_FALLBACK_CLIPS))])
        return out


def _neither(pair: tuple[str, ...]) -> str:
    """A concept of neither of ``pair``: the first lower-body concept not in it."""
    return next(c for c in LOWER_CONCEPTS if c not in pair)


def composition_controls(source: PipelineSource, seeds: Sequence[int], *, per_case: int,
                         scale: float = 1.0) -> dict[str, Controls] | None:
    """EMG-2/3's controls: the six rates of ``studies.composition_study`` measured by the same
    oracles on constructed sets of generator clips, per seed on that seed's items (the same
    composition items and negation cases and counts).

    Each item of an arm is, with a planted probability, the clip that has the measured
    concept(s) (the item's ground-truth composed clip; for negation a training clip of the pair)
    and otherwise one that lacks it (a single-concept training clip; the kept concept alone, the
    negated concept alone or a third concept), drawn per item. Conjunction: concept 1's arm
    holds both concepts with probability p₀ = 0.3 and concept 2's never, so "best single" (per
    pair the better of the two, as the study) has mean p₀ with no max-of-two bias; the
    conjunction arm p₀ + δ (δ = 0.1) in the positive control, p₀ in the null. Negation: the
    baseline keeps the negated concept with probability 0.9 and the kept one always; the
    negation arm has the negated concept with probability 0.9·(1 − 0.1) (δ: 10 % of the
    baseline) in the positive control, 0.9 in the null, and the kept concept with probability
    1.1/2 (2·kept − baseline = δ = 10 % of the baseline) vs ½ (the null of "at least half its
    baseline"). The oracles find every pool concept in the ground truth, so these probabilities
    are the planted rates.

    Returns ``{"EMG-2": controls, "EMG-3": controls}``: the clips are generated once per seed
    and shared by both claims and both controls; each arm's draws are independent. None on a
    data folder: the arms are generator clips of the stand-in's concepts, and the claims they
    control are not measurable there (``studies.composition_study``).
    """
    if not pipeline_for(source, seeds[0]).data.labelled:
        return None
    names = ("conjunction_both_present", "best_single_concept_both_present",
             "negation_negated_present", "baseline_negated_present", "negation_kept_present",
             "baseline_kept_present")
    plan = {"positive": {"conjunction": _BASE_BOTH + 0.1 * scale,
                         "negated": _BASE_NEGATED * (1 - 0.1 * scale),
                         "kept": (1 + 0.1 * scale) / 2},
            "null": {"conjunction": _BASE_BOTH, "negated": _BASE_NEGATED, "kept": 0.5}}
    claims = {"EMG-2": 2, "EMG-3": 3}
    out: dict[str, Any] = {c: {kind: {n: [] for n in names} for kind in KINDS} for c in claims}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        pool = _TrainingClips(pipe)
        items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
        pairs = pair_index(items)
        neg = negation_items(seed, per_case)
        clips = np.random.default_rng([CONTROL_STREAM, 23, seed])   # shared by both controls
        has_both = np.array([bool(set(names_) <= detect_concepts(j))
                             for names_, j in zip(items.concepts, items.gt_joints, strict=True)])
        singles = pool.found([(c[0],) for c in items.concepts], clips)
        alone = np.array([set(c) <= f for c, f in zip(items.concepts, singles, strict=True)])
        found = _negation_sets(neg, pool, clips)
        for claim_id, kind in ((c, k) for c in claims for k in KINDS):
            rng, rates = _rng(seed, claims[claim_id], kind), plan[kind]

            def arm(p: float, rng: np.random.Generator = rng, has_both: np.ndarray = has_both,
                    alone: np.ndarray = alone) -> np.ndarray:
                return np.where(rng.uniform(size=len(has_both)) < p, has_both, alone)

            single1 = arm(_BASE_BOTH)
            single2 = alone.copy()
            best = np.maximum(per_pair_mean(single1, pairs), per_pair_mean(single2, pairs))
            m = out[claim_id][kind]
            m["conjunction_both_present"].append(float(arm(rates["conjunction"]).mean()))
            m["best_single_concept_both_present"].append(float(best.mean()))
            base = _draw_negation(found, rng, negated=_BASE_NEGATED, kept=1.0)
            treated = _draw_negation(found, rng, negated=rates["negated"], kept=rates["kept"])
            m["negation_negated_present"].append(float(treated[:, 1].mean()))
            m["baseline_negated_present"].append(float(base[:, 1].mean()))
            m["negation_kept_present"].append(float(treated[:, 0].mean()))
            m["baseline_kept_present"].append(float(base[:, 0].mean()))
    positive = plan["positive"]
    positive_text = (f"both concepts in {positive['conjunction']:.3g} of the conjunction arm's "
                     f"items against {_BASE_BOTH:g} of the best single concept's; negated "
                     f"concept kept in {positive['negated']:.3g} against {_BASE_NEGATED:g}, the "
                     f"kept one in {positive['kept']:.3g} against 1")
    null_text = (f"the baseline's rates in both arms ({_BASE_BOTH:g} both concepts, negated "
                 f"concept {_BASE_NEGATED:g}; kept 0.5 against 1), independent draws, "
                 f"{len(seeds)} seed(s)")
    return {claim_id: Controls(null=out[claim_id]["null"], positive=out[claim_id]["positive"],
                               planted={"planted": plan,
                                        "single_concept_both_present": _BASE_BOTH,
                                        "baseline_negated_present": _BASE_NEGATED},
                               null_text=null_text, positive_text=positive_text)
            for claim_id in claims}


def _negation_sets(neg: Any, pool: _TrainingClips, rng: np.random.Generator
                   ) -> dict[str, np.ndarray]:
    """Per negation item, the oracle's (kept, negated) presence on four training clips: the
    pair, the kept concept alone, the negated concept alone, a third concept."""
    out: dict[str, np.ndarray] = {}
    kinds = {"pair": lambda k, n: (k, n), "kept": lambda k, n: (k,),
             "negated": lambda k, n: (n,), "neither": lambda k, n: (_neither((k, n)),)}
    for key, concepts_of in kinds.items():
        found = pool.found([concepts_of(k, n) for k, n in zip(neg.kept, neg.negated,
                                                                strict=True)], rng)
        out[key] = np.array([[k in f, n in f] for k, n, f in zip(neg.kept, neg.negated, found,
                                                                strict=True)], dtype=bool)
    return out


def _draw_negation(found: Mapping[str, np.ndarray], rng: np.random.Generator, *,
                   negated: float, kept: float) -> np.ndarray:
    """(B, 2) presence of (kept, negated) of an arm whose items hold the negated concept with
    probability ``negated`` and the kept one with ``kept`` (both: the pair clip; one: that
    concept alone; none: a third concept), the two drawn as independently as the rates allow
    (P(both) = max(0, negated + kept − 1), the rest split)."""
    both = max(0.0, negated + kept - 1.0)
    probabilities = np.clip([both, kept - both, negated - both, 1.0 - negated - kept + both],
                            0.0, 1.0)
    choice = rng.choice(4, size=len(found["pair"]), p=probabilities / probabilities.sum())
    stacked = np.stack([found["pair"], found["kept"], found["negated"], found["neither"]])
    return stacked[choice, np.arange(len(choice))]


# --- EMG-6: Pearson r of maps --------------------------------------------------------------

def _standardised(values: np.ndarray) -> np.ndarray:
    flat = np.asarray(values, dtype=np.float64)
    return (flat - flat.mean()) / flat.std()


def energy_map_controls(cases: Mapping[str, Sequence[Sequence[Mapping[str, Any]]]]
                        | NotMeasurable, smooth: Callable[[np.ndarray], np.ndarray], grid: int,
                        *, scale: float = 1.0) -> Controls | None:
    """EMG-6's controls on the experiment's own composed maps (``case["smooth"]["composed"]``;
    ``cases``: kind → one list of cases per seed, as ``energy.map_similarities`` reads): the
    maps the composed one is compared with — the multi-concept map and the floor's — are
    replaced by maps whose correlation with it is known, the similarity is the experiment's
    ``map_similarity`` and, as in the experiment, a seed's value is the mean over its cases.

    The stand-in maps: ``smooth`` (the experiment's interpolation and smoothing) of white noise
    on the ``grid``² grid (independent per seed, case and arm), standardised: N₁, N₂. The
    positive control's multi-concept map is a·Â + √(1−a²)·N₁ with Â the standardised composed
    map and a = δ = 0.1, so E r(composed, multi) = a to first order (N₁ independent of Â), and
    its floor map is N₂ (E r = 0): r(multi) − floor has mean δ, and the noise a smooth random
    field puts on a correlation. The null control: multi = N₁, floor = N₂. None for a
    ``NotMeasurable`` (a data folder: no maps, no claim to control).
    """
    if isinstance(cases, NotMeasurable):
        return None
    delta = 0.1 * scale
    out: dict[str, Any] = {kind: {} for kind in KINDS}
    for index_kind, (case_kind, per_seed) in enumerate(cases.items()):
        for kind in KINDS:
            multi, floor = [], []
            for index, found in enumerate(per_seed):
                rng = _rng(index, 6 + 10 * index_kind, kind)
                seed_multi, seed_floor = [], []
                for case in found:
                    composed = np.asarray(case["smooth"]["composed"])
                    noise = [_standardised(smooth(rng.standard_normal((grid, grid))))
                             for _ in range(2)]
                    a = delta if kind == "positive" else 0.0
                    planted = a * _standardised(composed) + np.sqrt(1 - a ** 2) * noise[0]
                    seed_multi.append(map_similarity(composed, planted))
                    seed_floor.append(map_similarity(composed, noise[1]))
                multi.append(float(np.mean(seed_multi)))
                floor.append(float(np.mean(seed_floor)))
            out[kind][f"{case_kind}_similarity_to_multi"] = multi
            out[kind][f"{case_kind}_similarity_floor"] = floor
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"planted_correlation": delta, "grid": grid,
                             "reason": "δ = 0.1 in Pearson r (registry v3)"},
                    null_text=("random smooth fields as the multi-concept and the floor's maps, "
                               "independent per seed, case and arm"),
                    positive_text=(f"the multi-concept field mixed with the composed map at "
                                   f"weight {delta:g} (r {delta:g} above the floor's)"))


# --- EMG-4 / EMG-5: R-precision and transition distance of ground-truth motions ------------
# (the planted sample sets: ``energymogen.planted``)

def row_measurements(pipe: EnergyMoGenPipeline, features: np.ndarray, items: Any, seed: int
                     ) -> dict[str, float]:
    """R@3 (%) and transition distance of one row, computed exactly as
    ``studies.composition_metrics`` computes those two (the same calls; the oracles and the
    other columns, which no control reads, are left out for speed)."""
    evaluator = pipe.evaluator
    text = evaluator.embed_texts(list(items.multi_texts))
    gen = evaluator.embed_motions(features, np.full(len(features), features.shape[1]))
    r = metrics.r_precision(text, gen, 32, 3, seed)
    return {"r_precision_top3": 100.0 * float(r[2]),
            "transition_distance": transition_distance_cm(features)}


def _swap_groups(items: Any) -> np.ndarray:
    """Whose motions a swap takes: another held-out pair's (``studies.pair_index``); on a data
    folder's items (its test windows, no concepts) any other item's."""
    return pair_index(items) if any(items.concepts) else np.arange(len(items))


def _swap_fraction(clean: float, swapped: float, target: float) -> float:
    """The swap fraction whose expected R@3 is ``target`` (linear between the endpoints)."""
    if clean - swapped <= 0:
        return 0.0
    return float(np.clip((clean - target) / (clean - swapped), 0.0, 1.0))


def _row_plan(source: PipelineSource, seeds: Sequence[int], claim: int,
              rows: Callable[[EnergyMoGenPipeline, Any, int, str], dict[str, dict[str, Any]]]
              ) -> dict[str, Any]:
    out: dict[str, Any] = {kind: {"r_precision_top3": {}, "transition_distance": {}}
                           for kind in KINDS}
    calibration: dict[str, list[Any]] = {}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        items = energy_view_items(pipe.data, seed, pipe.config.items_per_pair)
        groups = _swap_groups(items)
        for kind in KINDS:
            rng = _rng(seed, claim, kind)
            plan = rows(pipe, items, seed, kind)
            calibration.setdefault(kind, []).append(plan)
            for row, spec in plan.items():
                moved = scale_movement(items.gt_features, spec["movement"])
                features = swap_motions(moved, spec["swap"], rng, groups)
                values = row_measurements(pipe, features, items, seed)
                for metric in ("r_precision_top3", "transition_distance"):
                    out[kind][metric].setdefault(row, []).append(values[metric])
    out["calibration"] = calibration
    return out


def _endpoints(pipe: EnergyMoGenPipeline, items: Any, seed: int, movement: float
               ) -> tuple[float, float]:
    """R@3 of the ground truth (moved by ``movement``) clean and with every motion swapped, on
    a calibration draw of its own."""
    groups = _swap_groups(items)
    moved = scale_movement(items.gt_features, movement)
    clean = row_measurements(pipe, moved, items, seed)["r_precision_top3"]
    rng = np.random.default_rng([CONTROL_STREAM, 99, seed])
    swapped = row_measurements(pipe, swap_motions(moved, 1.0, rng, groups), items,
                               seed)["r_precision_top3"]
    return clean, swapped


def step_size_controls(source: PipelineSource, seeds: Sequence[int], row_keys: Sequence[str],
                       *, scale: float = 1.0) -> Controls:
    """EMG-4's controls: every Table 9 row is the seed's ground-truth composition motions with
    a fraction swapped (:func:`swap_motions`), measured as ``composition_metrics`` measures
    (:func:`row_measurements`).

    Positive: [0.001, 0.002] clean (R₀); every other row at R₀/1.035 (the claimed best exceeds
    it by δ = 3.5 % of the other row); [0.1, 0.2] at (1 − 0.417) of γ = 0's (δ: half the
    paper's 83.5 % drop). Null: every row at R₀/1.035, independent swaps. Swap fractions
    from R₀ and the all-swapped R@3 measured per seed (a linear scale factor). On a data
    folder the rows are its test windows (``data.energy_view_items``, as ``run_rows``), a swap
    takes any other window's motion."""
    best, large = "0.001,0.002", "0.1,0.2"

    def rows(pipe: EnergyMoGenPipeline, items: Any, seed: int, kind: str
             ) -> dict[str, dict[str, Any]]:
        clean, swapped = _endpoints(pipe, items, seed, 1.0)
        other = clean / (1 + 0.035 * (scale if kind == "positive" else 1.0))
        targets = {key: other for key in row_keys}
        if kind == "positive":
            targets[best], targets[large] = clean, other * (1 - 0.417 * scale)
        return {key: {"movement": 1.0, "swap": _swap_fraction(clean, swapped, target),
                      "target": target, "clean": clean, "swapped": swapped}
                for key, target in targets.items()}

    out = _row_plan(source, seeds, 4, rows)
    r3 = {kind: {"r_precision_top3": out[kind]["r_precision_top3"]} for kind in KINDS}
    return Controls(null=r3["null"], positive=r3["positive"], planted=out["calibration"],
                    null_text=(f"every row the ground truth at R@3 R₀/1.035, independent swaps, "
                               f"{len(seeds)} seed(s)"),
                    positive_text=(f"[{best}] clean (R₀), the other rows at R₀/"
                                   f"{1 + 0.035 * scale:g}, [{large}] at {1 - 0.417 * scale:g} "
                                   "of γ = 0's"))


def sef_controls(source: PipelineSource, seeds: Sequence[int], *, scale: float = 1.0,
                 timeline_items_per_seed: int = 16) -> Controls | None:
    """EMG-5's controls: R@3 on the seed's ground-truth composition motions (held-out pairs)
    with a fraction swapped (:func:`swap_motions`, R@3 linear in it; movement scaled with
    :func:`scale_movement` as before, for the all-frames distance kept as context); the
    transition measurements on ground-truth "then" clips of the seed's MTT-style timeline
    items (``timelines.real_then_clips``, an independent draw per row, kind and seed),
    measured at their labelled transitions as ``studies.timeline_measurements`` measures.

    Positive (every part's δ, half the paper's relative effects): transition measurements
    latent 1, semantic 1.1875 (+18.75 %), SEF 1.1875·(1 − 0.1364) × their clean values, both
    planted exactly (:func:`plant_transitions`); R@3 SEF clean at its movement (R₀), latent
    R₀/1.2143 (SEF − latent = 21.43 % of latent), semantic 1.2015 × latent's target. Null:
    all three rows clean (independent draws), movement 1 and the latent row's swap
    fraction. None on a data folder (EMG-5 composes concepts: not measurable there)."""
    if not pipeline_for(source, seeds[0]).data.labelled:
        return None
    lat, sem, sef = "1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"

    def rows(pipe: EnergyMoGenPipeline, items: Any, seed: int, kind: str
             ) -> dict[str, dict[str, Any]]:
        if kind == "null":
            clean, swapped = _endpoints(pipe, items, seed, 1.0)
            swap = _swap_fraction(clean, swapped, clean / 1.2143)
            return {key: {"movement": 1.0, "swap": swap, "clean": clean, "swapped": swapped}
                    for key in (lat, sem, sef)}
        semantic = 1 + 0.1875 * scale
        movement = {lat: 1.0, sem: semantic, sef: semantic * (1 - 0.1364 * scale)}
        ends = {key: _endpoints(pipe, items, seed, factor) for key, factor in movement.items()}
        target_lat = ends[sef][0] / (1 + 0.2143 * scale)
        targets = {lat: target_lat, sem: (1 + 0.2015 * scale) * target_lat, sef: ends[sef][0]}
        return {key: {"movement": movement[key], "target": targets[key],
                      "swap": _swap_fraction(*ends[key], targets[key]), "clean": ends[key][0],
                      "swapped": ends[key][1]} for key in movement}

    out = _row_plan(source, seeds, 5, rows)
    planted: dict[str, list[float]] = {}
    for seed in seeds:
        frames = pipeline_for(source, seed).data.frames
        items = timeline_items(seed, timeline_items_per_seed, frames)
        for kind in KINDS:
            m = out[kind]
            for index, key in enumerate((lat, sem, sef)):
                factor = 1.0
                if kind == "positive":
                    factor = {lat: 1.0, sem: 1 + 0.1875 * scale,
                              sef: (1 + 0.1875 * scale) * (1 - 0.1364 * scale)}[key]
                clips = real_then_clips(items, seed, (CONTROL_STREAM, 5, KINDS.index(kind),
                                                      index))
                features, f = plant_transitions(clips, factor)
                planted.setdefault(f"{kind} {key}", []).append(f)
                values = timeline_measurements(features, clips.transitions)
                for metric in ("transition_distance_at_transitions", "transition_speed_ratio"):
                    m.setdefault(metric, {}).setdefault(key, []).append(values[metric])
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"rows": out["calibration"], "transition_step_factor": planted},
                    null_text=(f"the three rows clean ground truth (R@3 at R₀/1.2143), "
                               f"independent draws, {len(seeds)} seed(s)"),
                    positive_text=(f"transitions latent × 1, semantic × {1 + 0.1875 * scale:g}, "
                                   f"SEF × {(1 + 0.1875 * scale) * (1 - 0.1364 * scale):.4g}; "
                                   f"R@3 SEF R₀, latent R₀/{1 + 0.2143 * scale:g}, semantic "
                                   f"{1 + 0.2015 * scale:g} × latent's"))


# --- EMG-7: MPJPE and generation FID ------------------------------------------------------

def _offset_height(features: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Test clips raised by ``offsets`` (per clip, m): the root height (feature 3) and the y of
    every stored joint position (features 4:67, which carry their own height), so every
    recovered joint moves up by exactly that much and MPJPE is the mean |offset|."""
    out = np.array(features, copy=True)
    lift = offsets[:, None].astype(out.dtype)
    out[:, :, 3] += lift
    out[:, :, 5:67:3] += lift[..., None]
    return out



#: our choice: the compared arms' base noise (× the data's per-feature std)
_BASE_AMPLITUDE = 0.5


def latent_count_controls(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                          counts: Sequence[int], seeds: Sequence[int], *, scale: float = 1.0
                          ) -> Controls:
    """EMG-7's controls: per N and seed, "reconstructions" = the test clips with per-clip root
    height offsets |N(0, 1)|·√(π/2)·e (mean e, independent per N and seed; MPJPE through
    ``latent_count.mpjpe`` is exactly their mean) and "generations" = the test clips with
    feature noise (FID as ``evaluate_generated`` computes it,
    ``noise_calibration.t2m_measurements``).

    Positive: N = 7's offsets scaled by 1 − 0.362 (δ: half the paper's 72.5 % margin, of the
    other N's error), N = 5's FID at (1 − 0.177) of the others' (δ: half of 35.4 %), its noise
    amplitude read off the FID curve fitted on calibration draws (:class:`FidCurve`). Null:
    every N alike.
    e = 0.05 m (the decision is scale-free in e)."""
    base = 0.05
    reference = reference_embeddings(pipe, test)
    curve = fid_curve(pipe, test, reference)
    other_fid = curve.fid(_BASE_AMPLITUDE)
    best_amplitude = curve.amplitude((1 - 0.177 * scale) * other_fid)
    out: dict[str, Any] = {kind: {"reconstruction_error": {}, "generation_fid": {}}
                           for kind in KINDS}
    for seed in seeds:
        for kind in KINDS:
            rng = _rng(seed, 7, kind)
            for n in counts:
                mean = base * (1 - 0.362 * scale if kind == "positive" and n == 7 else 1.0)
                offsets = mean * np.sqrt(np.pi / 2) * np.abs(rng.standard_normal(len(test)))
                recon = _offset_height(test.features, offsets)
                amplitude = (best_amplitude if kind == "positive" and n == 5
                             else _BASE_AMPLITUDE)
                generated = with_feature_noise(test.features, pipe.data.std, amplitude, rng)
                out[kind]["reconstruction_error"].setdefault(str(n), []).append(
                    mpjpe(recon, test.features))
                out[kind]["generation_fid"].setdefault(str(n), []).append(
                    t2m_measurements(pipe, test, generated, seed, reference)["fid"])
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"offset_mean_m": base, "base_amplitude": _BASE_AMPLITUDE,
                             "best_amplitude": best_amplitude, "other_fid": other_fid,
                             "fid_curve": dataclasses.asdict(curve)},
                    null_text=(f"every N the test clips lifted by {base:g} m on average and "
                               f"noised at {_BASE_AMPLITUDE:g} × std, independent draws, "
                               f"{len(seeds)} seed(s)"),
                    positive_text=(f"N = 7's lift × {1 - 0.362 * scale:g}; N = 5's noise "
                                   f"{best_amplitude:.3g} × std (FID × {1 - 0.177 * scale:g})"))


# --- EMG-8: R@3 and FID of the text-to-motion test -----------------------------------------

def augmentation_controls(pipe: EnergyMoGenPipeline, test: TextToMotionTest | NotMeasurable,
                          seeds: Sequence[int], *, scale: float = 1.0) -> Controls | None:
    """EMG-8's controls: "generations" of the baseline and the augmented model are the test
    clips with feature noise and a fraction of their motions passed round
    (:func:`permute_motions`: R@3 falls, FID does not move), measured
    as ``evaluate_generated`` measures (R@3 over the test set, FID against it).

    Baseline: noise 0.5 × std and half the clips swapped (our choices: R@3 and FID off their
    floors). Positive: the augmented arm's noise read off the FID curve for 0.9 × the
    baseline's FID (δ: 10 % of it; :class:`FidCurve`) and its permuted fraction for R@3 + 0.01
    (δ: one percentage point; R@3 clean and fully permuted at that noise, measured on a
    calibration draw, linear in between). Null: both arms alike. None for a ``NotMeasurable``
    test (a data folder: no shared-concept test, EMG-8 not measurable)."""
    if isinstance(test, NotMeasurable):
        return None
    reference = reference_embeddings(pipe, test)
    curve = fid_curve(pipe, test, reference)
    rng_cal = np.random.default_rng([CONTROL_STREAM, 88])

    def r3_at(amplitude: float, fraction: float) -> float:
        noisy = with_feature_noise(test.features, pipe.data.std, amplitude, rng_cal)
        return t2m_measurements(pipe, test, permute_motions(noisy, fraction, rng_cal),
                                0, reference)["r_precision_top3"]

    base_swap = 0.5
    base_fid = curve.fid(_BASE_AMPLITUDE)
    aug_amplitude = curve.amplitude((1 - 0.1 * scale) * base_fid)
    base_r3 = r3_at(_BASE_AMPLITUDE, base_swap)
    aug_swap = _swap_fraction(r3_at(aug_amplitude, 0.0), r3_at(aug_amplitude, 1.0),
                              base_r3 + 0.01 * scale)
    plan = {"positive": {"augmented": (aug_amplitude, aug_swap),
                         "baseline": (_BASE_AMPLITUDE, base_swap)},
            "null": {"augmented": (_BASE_AMPLITUDE, base_swap),
                     "baseline": (_BASE_AMPLITUDE, base_swap)}}
    out: dict[str, Any] = {kind: {} for kind in KINDS}
    for seed in seeds:
        for kind in KINDS:
            rng = _rng(seed, 8, kind)
            for arm, (amplitude, fraction) in plan[kind].items():
                noisy = with_feature_noise(test.features, pipe.data.std, amplitude, rng)
                values = t2m_measurements(pipe, test, permute_motions(noisy, fraction, rng),
                                          seed, reference)
                out[kind].setdefault(f"r_precision_top3_{arm}", []).append(
                    values["r_precision_top3"])
                out[kind].setdefault(f"fid_{arm}", []).append(values["fid"])
    return Controls(null=out["null"], positive=out["positive"],
                    planted={"plan": plan, "baseline_fid_expected": base_fid,
                             "fid_curve": dataclasses.asdict(curve),
                             "baseline_r3_expected": base_r3},
                    null_text=(f"both arms noised at {_BASE_AMPLITUDE:g} × std with {base_swap:g} "
                               f"of the motions permuted, independent draws, "
                               f"{len(seeds)} seed(s)"),
                    positive_text=(f"the augmented arm at {aug_amplitude:.3g} × std (FID × "
                                   f"{1 - 0.1 * scale:g}), {aug_swap:.3g} permuted (R@3 "
                                   f"+ {0.01 * scale:g})"))
