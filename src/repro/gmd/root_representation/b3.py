"""GMD-B3: Table B.1's evaluation (``measurements``) of a text-conditioned motion model in
each root representation (GMD appendix B), except at a scale that runs none of B3's parts
(``Settings.runs_b3``: the claim is recorded as not run, with why); its controls, reading and
result (:func:`b3_result`, :func:`b3_not_run_result`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from repro.claims.result import ClaimResult, Controls
from repro.core import metrics
from repro.core.tables import interval_text, render
from repro.gmd import measurements, model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import calibrate_increasing, control_seed
from repro.gmd.figures import count_below
from repro.gmd.guidance import GMD_CFG_SCALE
from repro.gmd.measurements import EvaluationSet, table_row
from repro.gmd.models import TrainedGMD, describe
from repro.gmd.root_representation.common import (
    B3_PARTS,
    REPRESENTATION_ROLES,
    FigurePath,
    Settings,
    Windows,
)
from repro.gmd.windows import REPRESENTATIONS, MotionWindows
from repro.models.evaluator import Evaluator, load_or_train_evaluator

__all__ = ["B3Evaluation", "B3_DEGRADATION", "B3_FID_RATIO", "B3_GAP_RATIO",
           "DIVERSITY_PAIRS", "b3_controls", "b3_evaluation", "b3_model_records",
           "b3_not_run_markdown", "b3_not_run_result", "b3_result", "b3_rows",
           "reading_b3"]


# ------------------------------------------------------------------------------------------------
# GMD-B3's controls (Table B.1, notebook 02), beside ``repro.gmd.controls``: the evaluation
# windows themselves, degraded by a fixed recipe with the same noise in both arms of a seed, stand
# in for both models' samples; the positive control degrades the abs arm less, by sizes measured
# on calibration draws to plant the FID and diversity-gap effects at their registered δ.
# ------------------------------------------------------------------------------------------------

#: the rel arm's degradation, fixed before any control ran: shrink toward the mean window by
#: 30 %, a shift of 0.25 std along a fixed direction, white noise of 0.1 std (one draw per seed,
#: the same in both arms)
B3_DEGRADATION = {"shrink": 0.3, "shift": 0.25, "noise": 0.1}


#: Table B.1's effects at the registered δ: half the paper's FID drop and gap shrink
B3_FID_RATIO, B3_GAP_RATIO = 1 - 0.1525, 1 - 0.412


#: the diversity pairs of ``evaluator.evaluate_generated`` (its default)
DIVERSITY_PAIRS = 300


def _degraded(features: np.ndarray, *, shrink: float, shift: float, noise: float,
              direction: np.ndarray, seed: int) -> np.ndarray:
    """Relative-root features (n, T, 263) pulled toward their mean window by ``shrink``,
    shifted by ``shift`` per-feature std along ``direction`` and given white noise of
    ``noise`` std (a draw of ``seed``)."""
    mean = features.mean(axis=0, keepdims=True)
    std = features.reshape(-1, features.shape[-1]).std(axis=0) + 1e-6
    white = np.random.default_rng(seed).standard_normal(features.shape)
    out = mean + (1 - shrink) * (features - mean) + std * (shift * direction + noise * white)
    return out.astype(np.float32)


def _calibrated_abs_arm(evaluator: Evaluator, features: np.ndarray, lengths: np.ndarray,
                        direction: np.ndarray, real: float, *, calibration_draws: int,
                        rounds: int, iterations: int, fid_ratio: float,
                        gap_ratio: float) -> tuple[float, float, float, float]:
    """The positive control's abs arm: the shrink and shift (alternating bisections, ``rounds``
    times, ``iterations`` steps each) that give ``fid_ratio`` × the rel arm's FID and
    ``gap_ratio`` × its diversity gap to ``real``, measured on ``calibration_draws`` noise
    draws disjoint from the control's; with the FID and gap ratios they reach:
    (shrink, shift, FID ratio, gap ratio)."""
    truth = evaluator.embed_motions(features, lengths)
    pairs = min(DIVERSITY_PAIRS, len(features))

    def fid_and_gap(shrink: float, shift: float) -> tuple[float, float]:
        """Mean FID and |Diversity − real| over the calibration draws, computed as
        ``evaluate_generated`` computes them."""
        fids, gaps = [], []
        for k in range(calibration_draws):
            generated = evaluator.embed_motions(_degraded(
                features, shrink=shrink, shift=shift, noise=B3_DEGRADATION["noise"],
                direction=direction, seed=control_seed(k, 0, stream=41)), lengths)
            fids.append(metrics.fid(generated, truth))
            gaps.append(abs(metrics.diversity(generated, pairs, k) - real))
        return float(np.mean(fids)), float(np.mean(gaps))

    fid_rel, gap_rel = fid_and_gap(B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"])
    shrink, shift = B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"]
    for _ in range(rounds):
        shrink = calibrate_increasing(lambda b, a=shift: fid_and_gap(b, a)[1],
                                      gap_ratio * gap_rel, high=1.0,
                                      iterations=iterations)
        shift = calibrate_increasing(lambda a, b=shrink: fid_and_gap(b, a)[0],
                                     fid_ratio * fid_rel, high=1.0,
                                     iterations=iterations)
    reached = fid_and_gap(shrink, shift)
    return shrink, shift, reached[0] / fid_rel, reached[1] / gap_rel


def b3_controls(evaluator: Evaluator, evaluation: EvaluationSet, real_row: Mapping[str, float],
                seeds: Sequence[int], *, calibration_draws: int = 3, rounds: int = 4,
                iterations: int = 12, fid_ratio: float = B3_FID_RATIO,
                gap_ratio: float = B3_GAP_RATIO) -> Controls:
    """GMD-B3's controls: the evaluation windows themselves, degraded (:func:`_degraded`),
    stand in for both models' samples, measured with the experiment's ``measurements.table_row``
    and ``measurements.registered_measurements`` (FID, R@3, Diversity against the same
    evaluation set).

    Paired as the experiment (``b3_rows``: both representations generate for the same
    evaluation captions from the same seed, x_T included, and are scored with the same seed):
    in a seed both arms degrade the same windows with the same white-noise draw
    (:func:`control_seed` with arm 0; another draw per seed) and are scored with the seed.
    Null: both arms degraded by :data:`B3_DEGRADATION` (identical arms: every log ratio 0).
    Positive: the abs arm degraded less — the shrink and shift that, measured on
    ``calibration_draws`` noise draws disjoint from the control's (alternating bisections,
    ``rounds`` times), give FID × (1 − 0.1525) and a diversity gap to real × (1 − 0.412) of
    the rel arm's: part 1's and part 2's δ (no exact transformation moves an FID by a set
    ratio; R@3 is left to come out as it does). Each bisection takes ``iterations`` steps
    (quick runs pass fewer draws, rounds and steps: a test of the code)."""
    features, lengths = evaluation.features, evaluation.lengths
    direction = np.random.default_rng(control_seed(0, 0, stream=40)).standard_normal(
        features.shape[-1])
    direction /= np.linalg.norm(direction)
    shrink, shift, fid_reached, gap_reached = _calibrated_abs_arm(
        evaluator, features, lengths, direction, float(real_row["diversity"]),
        calibration_draws=calibration_draws, rounds=rounds, iterations=iterations,
        fid_ratio=fid_ratio, gap_ratio=gap_ratio)
    rows: dict[str, dict[str, list[dict[str, float]]]] = {
        "null": {"relative": [], "absolute": []}, "positive": {"relative": [], "absolute": []}}
    for s in seeds:
        def arm(b: float, a: float, s: int = s) -> dict[str, float]:
            generated = _degraded(features, shrink=b, shift=a, noise=B3_DEGRADATION["noise"],
                                  direction=direction, seed=control_seed(s, 0, stream=42))
            return table_row(evaluator, generated, evaluation, seed=s)

        rel = arm(B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"])
        rows["null"]["relative"].append(rel)
        rows["positive"]["relative"].append(rel)
        rows["null"]["absolute"].append(dict(rel))
        rows["positive"]["absolute"].append(arm(shrink, shift))
    return Controls(
        null=measurements.registered_measurements(dict(real_row), rows["null"]),
        positive=measurements.registered_measurements(dict(real_row), rows["positive"]),
        planted={"rel_degradation": B3_DEGRADATION, "abs_shrink": shrink, "abs_shift": shift,
                 "calibrated_fid_ratio": fid_reached,
                 "calibrated_gap_ratio": gap_reached,
                 "calibration_draws": calibration_draws},
        null_text=(f"paired as the experiment: the same {len(features)} evaluation windows "
                   f"with the same noise draw in both arms of a seed (another draw per seed), "
                   f"{len(seeds)} seed(s); no plant: both degraded alike (shrink "
                   f"{B3_DEGRADATION['shrink']:g}, shift {B3_DEGRADATION['shift']:g} std, noise "
                   f"{B3_DEGRADATION['noise']:g} std), identical arms"),
        positive_text=(f"the same paired draws; the abs arm degraded less (shrink "
                       f"{shrink:.3g}, shift {shift:.3g}: FID × {fid_reached:.3g}, "
                       f"diversity gap × {gap_reached:.3g} on {calibration_draws} "
                       f"calibration draws disjoint from the control's)"))


# ---------------------------------------- the evaluation, its rows, gate records and result

@dataclass
class B3Evaluation:
    """Table B.1's evaluator (trained once on the relative training windows, cached), those
    windows' features, the evaluation set (test windows, one caption each) and its Real row."""

    evaluator: Evaluator
    train_features: np.ndarray
    evaluation: measurements.EvaluationSet
    real_row: dict[str, float]


def b3_evaluation(relative: Mapping[str, MotionWindows], settings: Settings, *,
                  seed: int) -> B3Evaluation:
    """The evaluator of ``relative["train"]`` (``settings.evaluator_config()``), the
    ``settings.evaluation_windows`` test windows drawn with ``seed`` and their Real row
    (``measurements.ground_truth_row``)."""
    train = relative["train"]
    with torch.no_grad():
        train_features = train.features().numpy()
    evaluator = load_or_train_evaluator(train_features, np.full(len(train), train.frames),
                                        train.captions, settings.evaluator_config())
    evaluation = measurements.evaluation_set(relative["test"], settings.evaluation_windows,
                                             seed=seed)
    real_row = measurements.ground_truth_row(evaluator, evaluation, train_features, seed=seed)
    return B3Evaluation(evaluator, train_features, evaluation, real_row)


def b3_rows(motion_models: Mapping[str, Mapping[int, TrainedGMD]], b3: B3Evaluation,
            seeds: Sequence[int]) -> dict[str, list[dict[str, float]]]:
    """Per representation, one Table B.1 row per seed: one sample per evaluation caption with
    classifier-free guidance at GMD's scale (``measurements.generate_for_captions``), scored by
    ``measurements.table_row``."""
    rows: dict[str, list[dict[str, float]]] = {rep: [] for rep in REPRESENTATIONS}
    for s in seeds:
        for rep in REPRESENTATIONS:
            generated = measurements.generate_for_captions(
                motion_models[rep][s], b3.evaluation.captions, seed=s,
                guidance_scale=GMD_CFG_SCALE)
            rows[rep].append(measurements.table_row(b3.evaluator, generated, b3.evaluation, seed=s))
    return rows


def b3_model_records(motion_models: Mapping[str, Mapping[int, TrainedGMD]], b3: B3Evaluation,
                     windows: Windows, seeds: Sequence[int], *,
                     seed: int) -> list[dict[str, Any]]:
    """The motion models' ``gmd_motion`` records (held-out x̂0 error) and then the evaluator's
    (R@3 of the evaluation windows with their captions, trivial fakes' FID); every part of
    GMD-B3 reads every one."""
    samples = model_gates.sample_gate_data(windows["relative"]["test"], seed=seed)

    def values(rep: str, s: int) -> dict[str, float]:
        model = motion_models[rep][s]
        found = model_gates.denoising_gate_values(model, windows[rep]["test"],
                                                  windows[rep]["train"], seed=s)
        if REPRESENTATION_ROLES[rep] == "reference":
            found.update(model_gates.motion_sample_values(model, samples, seed=s))
        return found

    records = [model_gates.gmd_model_record(
        motion_models[rep][s], family="gmd_motion", label=rep, role=REPRESENTATION_ROLES[rep],
        arm=rep, reference=samples.values, values=values(rep, s))
        for rep in REPRESENTATIONS for s in seeds]
    evaluation = b3.evaluation
    evaluator_record = model_gates.evaluator_model_record(
        b3.evaluator, values=model_gates.evaluator_gate_values(
            b3.evaluator, evaluation.features, evaluation.lengths, evaluation.captions,
            seed=seed, train_features=b3.train_features, samples=len(evaluation)))
    return [*records, evaluator_record]


def b3_result(rows: Mapping[str, list[dict[str, float]]], b3: B3Evaluation,
              motion_models: Mapping[str, Mapping[int, TrainedGMD]], seeds: Sequence[int],
              settings: Settings, *, figures: Sequence[FigurePath],
              models: Sequence[Mapping[str, Any]]) -> ClaimResult:
    """GMD-B3: Table B.1's FID, R@3 and Diversity per seed in each representation, with its
    controls (``b3_controls``: degraded evaluation windows, calibrated as
    ``settings.b3_control_options`` says)."""
    rows = dict(rows)
    measured = measurements.registered_measurements(b3.real_row, rows)
    mean = {k: float(np.mean(v)) for k, v in measured.items()}
    controls = b3_controls(b3.evaluator, b3.evaluation, b3.real_row, seeds,
                           **settings.b3_control_options)
    return ClaimResult(
        "GMD-B3", measured, seeds=seeds, settings=rule_settings.b3(settings),
        figures=list(figures), controls=controls, models=list(models),
        headline=(f"FID rel {mean['fid_rel']:.3f} vs abs {mean['fid_abs']:.3f}; R@3 rel "
                  f"{mean['r_precision_top3_rel']:.3f} vs abs "
                  f"{mean['r_precision_top3_abs']:.3f}; Diversity rel "
                  f"{mean['diversity_rel']:.3f} vs abs {mean['diversity_abs']:.3f} (real "
                  f"{mean['diversity_real']:.3f}); {len(seeds)} seeds, CFG s = "
                  f"{GMD_CFG_SCALE:g}"),
        notes=("Model: " + describe(motion_models["absolute"][seeds[0]].spec) + ", text "
               f"condition = bag of words, classifier-free guidance at sampling with s = "
               f"{GMD_CFG_SCALE:g} (GMD's); evaluator: the package's tiny contrastive one "
               f"trained on the relative training windows; {len(b3.evaluation)} test windows, "
               "one caption each; abs samples converted to rel before evaluation. The paper's "
               "text calls the abs/rel change a trade-off between FID and R-precision, but its "
               "Table B.1 has abs better on FID, R-precision and Diversity: the rule tests the "
               "table's directions."),
        extra={"real": b3.real_row, "rows": measurements.by_label(rows),
               "summary": measurements.by_label({rep: measurements.summarise_rows(rows[rep])
                                                 for rep in REPRESENTATIONS}),
               "paper_table_b1": measurements.PAPER_TABLE_B1,
               "classifier_free_scale": GMD_CFG_SCALE,
               "evaluation_windows": len(b3.evaluation),
               "controls_planted": controls.planted})


def _b3_why(settings: Settings) -> str:
    """Why this scale runs no part of GMD-B3 (the registered reasons, each once)."""
    return "; ".join(dict.fromkeys(settings.b3_not_run.values()))


def b3_not_run_markdown(settings: Settings) -> str:
    """A markdown line where GMD-B3's experiment would be: that this scale does not run it
    and why (``Settings.b3_not_run``)."""
    return f"*GMD-B3 is not run at the {settings.scale} scale: {_b3_why(settings)}.*"


def b3_not_run_result(settings: Settings, seeds: Sequence[int]) -> ClaimResult:
    """GMD-B3 at a scale that runs none of its parts (``Settings.runs_b3`` false): nothing
    measured, no models, no controls, every part not run with its registered reason
    (``settings.not_run``); the rule is rendered from the settings a run of it would use
    (``seeds``, the evaluation windows, T, GMD's CFG scale), so the record says what was not
    run."""
    if settings.runs_b3:
        raise ValueError(f"the {settings.scale} scale runs GMD-B3: record its measurements "
                         "(b3_result)")
    why = _b3_why(settings)
    return ClaimResult(
        "GMD-B3", {}, seeds=list(seeds), settings=rule_settings.b3(settings),
        not_run=settings.b3_not_run,
        headline=f"not run at the {settings.scale} scale (each part says why)",
        notes=(f"Not run at the {settings.scale} scale (a registered cut, "
               "repro.gmd.settings.STANDARD_NOT_RUN): no relative- or absolute-root motion "
               "model is trained, no evaluator, no sample drawn; every part "
               f"({', '.join(B3_PARTS)}) is recorded inconclusive with why: {why}. The rule "
               "states what a run of it measures."))


# ------------------------------------------------------------------------------------ reading

def reading_b3(rows: dict[str, list[dict[str, float]]], real: dict[str, float], *,
               paper_fid: tuple[float, float]) -> str:
    """GMD-B3: each Table B.1 column per representation, concept recall, the distance from
    the real windows. ``rows`` keyed "relative"/"absolute" (``measurements.table_row`` per seed);
    ``paper_fid`` the paper's (rel, abs) FID."""
    def values(rep: str, metric: str) -> list[float]:
        return [row[metric] for row in rows[rep]]

    def lower(metric: str) -> str:
        rel, ab = np.mean(values("relative", metric)), np.mean(values("absolute", metric))
        return "tie" if rel == ab else ("rel" if rel < ab else "abs")

    recall_abs_lower = count_below(values("absolute", "concept_recall"),
                                   values("relative", "concept_recall"))
    n = len(rows["relative"])
    gap_rel = [abs(v - real["diversity"]) for v in values("relative", "diversity")]
    gap_abs = [abs(v - real["diversity"]) for v in values("absolute", "diversity")]
    columns = render(
        "**Reading** (this run, {n} seed(s)). FID: rel {fid_rel} vs abs {fid_abs} (lower "
        "mean: {fid_low}; the paper has abs lower). R-precision top-3: rel {r3_rel} vs abs "
        "{r3_abs}. Diversity gap to the real windows' {div_real:.3f}: rel {gap_rel} vs abs "
        "{gap_abs}.",
        n=n, fid_rel=interval_text(values("relative", "fid")),
        fid_abs=interval_text(values("absolute", "fid")), fid_low=lower("fid"),
        r3_rel=interval_text(values("relative", "r_precision_top3")),
        r3_abs=interval_text(values("absolute", "r_precision_top3")),
        div_real=real["diversity"], gap_rel=interval_text(gap_rel),
        gap_abs=interval_text(gap_abs))
    if not measurements.measurable(values("relative", "concept_recall")
                                   + values("absolute", "concept_recall")):
        return columns + render(
            " Concept recall: {not_measurable} (the folder has no `labels/` for the concept "
            "oracles to compare with). The real windows' R-precision: {r3_real:.2f}.",
            not_measurable=measurements.NOT_MEASURABLE, r3_real=real["r_precision_top3"])
    return columns + render(
        " The concept oracles find fewer of the captioned concepts in abs samples than in rel "
        "samples on {k} of {n} seeds (recall rel {cr_rel} vs abs {cr_abs}). Both tiny models "
        "are far from the real windows (R-precision {r3_real:.2f}, concept recall "
        "{cr_real:.2f}), so this is a weak test of a small effect: the paper's FID difference "
        "({p_rel:g} vs {p_abs:g}) is {share:.0%} of its rel value.",
        n=n, k=recall_abs_lower,
        cr_rel=interval_text(values("relative", "concept_recall")),
        cr_abs=interval_text(values("absolute", "concept_recall")),
        r3_real=real["r_precision_top3"], cr_real=real["concept_recall"],
        p_rel=paper_fid[0], p_abs=paper_fid[1],
        share=(paper_fid[0] - paper_fid[1]) / paper_fid[0])
