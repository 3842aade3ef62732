"""Feature-noised test clips and the FID-vs-noise curve that EMG-7's and EMG-8's controls
(``energymogen.controls``) read their planted noise amplitudes off: the test clips plus
Gaussian feature noise of amplitude × the data's per-feature std
(:func:`with_feature_noise`), measured as ``harness.generation_metrics`` measures FID and R@3
(:func:`t2m_measurements`), and a power law FID ≈ c·aᵏ fitted on calibration draws of its own
(:class:`FidCurve`, :func:`fid_curve`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from repro.core import metrics
from repro.energymogen.harness import TextToMotionTest, grouped_r_precision
from repro.energymogen.pipeline import EnergyMoGenPipeline
from repro.energymogen.planted import CONTROL_STREAM

__all__ = ["FidCurve", "fid_curve", "reference_embeddings", "t2m_measurements",
           "with_feature_noise"]


def with_feature_noise(features: np.ndarray, std: np.ndarray, amplitude: float,
                       rng: np.random.Generator) -> np.ndarray:
    """features + amplitude·std·z, z ~ N(0, 1) in the features' dtype (float32: half the time)."""
    noise = rng.standard_normal(features.shape, dtype=features.dtype)
    return features + (amplitude * np.asarray(std)).astype(features.dtype) * noise


def t2m_measurements(pipe: EnergyMoGenPipeline, test: TextToMotionTest, features: np.ndarray,
                     seed: int, reference: np.ndarray) -> dict[str, float]:
    """FID against the test clips (``reference``: their evaluator embeddings) and R@3
    (fraction) of the test captions drawn with ``seed``, computed exactly as
    ``harness.generation_metrics`` computes those two (the same calls: random batches, or the
    test's own batches when it is grouped, ``harness.grouped_r_precision``)."""
    gen = pipe.evaluator.embed_motions(features, test.lengths)
    text = pipe.evaluator.embed_texts(test.texts(seed))
    r = (grouped_r_precision(text, gen) if test.grouped
         else metrics.r_precision(text, gen, 32, 3, seed))
    return {"fid": metrics.fid(gen, reference), "r_precision_top3": float(r[2])}


def reference_embeddings(pipe: EnergyMoGenPipeline, test: TextToMotionTest) -> np.ndarray:
    """The evaluator embeddings of the test clips themselves (FID's reference)."""
    return pipe.evaluator.embed_motions(test.features, test.lengths)


#: the calibration grid around the base amplitude (the planted arms only lower FID from it)
_AMPLITUDES = np.geomspace(0.2, 0.7, 6)
_CALIBRATION_DRAWS = 4


@dataclass(frozen=True)
class FidCurve:
    """FID of noised test clips against the clean ones as a power law of the noise amplitude,
    FID ≈ c·aᵏ, fitted (least squares in log–log) to the mean FID over calibration draws of
    its own on a grid around the base amplitude: the measured scale factor from which each
    arm's amplitude is read (a fit, so one noisy calibration draw does not set it)."""

    amplitudes: tuple[float, ...]
    fids: tuple[float, ...]
    log_c: float
    k: float

    def fid(self, amplitude: float) -> float:
        return float(np.exp(self.log_c + self.k * np.log(amplitude)))

    def amplitude(self, fid: float) -> float:
        return float(np.exp((np.log(fid) - self.log_c) / self.k))


def fid_curve(pipe: EnergyMoGenPipeline, test: TextToMotionTest, reference: np.ndarray
              ) -> FidCurve:
    """:class:`FidCurve` of the pipeline's evaluator on ``test`` (feature noise: amplitude ×
    the data's per-feature std, :func:`with_feature_noise`)."""
    rng = np.random.default_rng([CONTROL_STREAM, 77])
    std = pipe.data.std
    fids = np.mean([[t2m_measurements(pipe, test, with_feature_noise(test.features, std, a, rng),
                                      0, reference)["fid"] for a in _AMPLITUDES]
                    for _ in range(_CALIBRATION_DRAWS)], axis=0)
    k, log_c = np.polyfit(np.log(_AMPLITUDES), np.log(fids), 1)
    return FidCurve(tuple(_AMPLITUDES.tolist()), tuple(fids.tolist()), float(log_c), float(k))

