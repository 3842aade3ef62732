"""GMD-B3's controls (Table B.1, notebook 02), beside ``repro.gmd.controls``: the evaluation
windows themselves, degraded by a fixed recipe, stand in for both models' samples; the positive
control degrades the abs arm less, by sizes measured on calibration draws to plant the FID and
diversity-gap effects at their registered δ."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from repro.claims.result import Controls
from repro.core import metrics
from repro.gmd.controls import calibrate_increasing, control_seed
from repro.gmd.table_b1 import EvaluationSet, registered_measurements, table_row
from repro.models.evaluator import Evaluator

__all__ = ["B3_DEGRADATION", "b3_controls"]
#: the rel arm's degradation, fixed before any control ran: shrink toward the mean window by
#: 30 %, a shift of 0.25 std along a fixed direction, white noise of 0.1 std (fresh per arm)
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


def b3_controls(evaluator: Evaluator, evaluation: EvaluationSet, real_row: Mapping[str, float],
                seeds: Sequence[int], *, calibration_draws: int = 3, rounds: int = 4,
                iterations: int = 12, fid_ratio: float = B3_FID_RATIO,
                gap_ratio: float = B3_GAP_RATIO) -> Controls:
    """GMD-B3's controls: the evaluation windows themselves, degraded (:func:`_degraded`),
    stand in for both models' samples, measured with the experiment's ``table_b1.table_row``
    and ``registered_measurements`` (FID, R@3, Diversity against the same evaluation set).

    Null: both arms degraded by :data:`B3_DEGRADATION` with independent noise. Positive: the
    abs arm degraded less — the shrink and shift that, measured on ``calibration_draws``
    further noise draws (alternating bisections, ``rounds`` times), give FID × (1 − 0.1525)
    and a diversity gap to real × (1 − 0.412) of the rel arm's: part 1's and part 2's δ (R@3
    is left to come out as it does). Each bisection takes ``iterations`` steps (quick runs
    pass fewer draws, rounds and steps: a test of the code)."""
    features, lengths = evaluation.features, evaluation.lengths
    direction = np.random.default_rng(control_seed(0, 0, stream=40)).standard_normal(
        features.shape[-1])
    direction /= np.linalg.norm(direction)
    real = float(real_row["diversity"])

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
    rows: dict[str, dict[str, list[dict[str, float]]]] = {
        "null": {"relative": [], "absolute": []}, "positive": {"relative": [], "absolute": []}}
    for s in seeds:
        def arm(k: int, b: float, a: float, s: int = s) -> dict[str, float]:
            generated = _degraded(features, shrink=b, shift=a, noise=B3_DEGRADATION["noise"],
                                  direction=direction, seed=control_seed(s, k, stream=42))
            return table_row(evaluator, generated, evaluation, seed=s)

        rel = arm(0, B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"])
        rows["null"]["relative"].append(rel)
        rows["positive"]["relative"].append(rel)
        rows["null"]["absolute"].append(arm(1, B3_DEGRADATION["shrink"],
                                            B3_DEGRADATION["shift"]))
        rows["positive"]["absolute"].append(arm(1, shrink, shift))
    return Controls(
        null=registered_measurements(dict(real_row), rows["null"]),
        positive=registered_measurements(dict(real_row), rows["positive"]),
        planted={"rel_degradation": B3_DEGRADATION, "abs_shrink": shrink, "abs_shift": shift,
                 "calibrated_fid_ratio": reached[0] / fid_rel,
                 "calibrated_gap_ratio": reached[1] / gap_rel,
                 "calibration_draws": calibration_draws},
        null_text=(f"the {len(features)} evaluation windows degraded alike in both arms "
                   f"(shrink {B3_DEGRADATION['shrink']:g}, shift {B3_DEGRADATION['shift']:g} "
                   f"std, noise {B3_DEGRADATION['noise']:g} std), independent noise, "
                   f"{len(seeds)} seed(s)"),
        positive_text=(f"the same; the abs arm degraded less (shrink {shrink:.3g}, shift "
                       f"{shift:.3g}: FID × {reached[0] / fid_rel:.3g}, diversity gap × "
                       f"{reached[1] / gap_rel:.3g} on {calibration_draws} calibration draws)"))
