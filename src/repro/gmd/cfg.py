"""Classifier-free guidance at sampling (Ho & Salimans 2022), as GMD samples its motion model.

GMD wraps a model trained with condition dropout (``cond_mask_prob`` > 0; here
``GMDModelSpec.cond_dropout``) and returns, at every step,

    out = out_uncond + s · (out_cond − out_uncond),

with s = ``guidance_param`` = 2.5 by default in its sampling and evaluation options (GMD
``model/cfg_sampler.py``, ``utils/parser_util.py``). s = 1 is plain conditional sampling,
s = 0 unconditional. Computed here as (1 − s)·out_uncond + s·out_cond — the same value, and
exactly the conditional (unconditional) output at s = 1 (s = 0), as 0·a = 0 and 1·b = b.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from torch import Tensor, nn

from repro.gmd.guidance import sample
from repro.gmd.models import TrainedGMD

__all__ = ["GMD_CFG_SCALE", "ClassifierFreeModel", "classifier_free", "sample_classifier_free"]

#: GMD's classifier-free guidance scale s (``guidance_param`` default 2.5).
GMD_CFG_SCALE = 2.5


class ClassifierFreeModel(nn.Module):
    """``model``'s output mixed with its unconditional output: (1 − s)·ε(x, t, ∅) + s·ε(x, t, c).

    Without a condition (or with ``force_unconditional``) it is the unconditional output.
    The two passes are separate calls of the same batch size as plain sampling's, so s = 1
    and s = 0 reproduce conditional and unconditional sampling bit for bit.
    """

    def __init__(self, model: nn.Module, scale: float) -> None:
        super().__init__()
        self.model = model
        self.scale = float(scale)

    def forward(self, x: Tensor, t: Tensor, cond: Tensor | None = None,
                force_unconditional: bool = False) -> Tensor:
        unconditional = self.model(x, t, force_unconditional=True)
        if cond is None or force_unconditional:
            return unconditional
        conditional = self.model(x, t, cond=cond)
        return (1.0 - self.scale) * unconditional + self.scale * conditional


def classifier_free(trained: TrainedGMD, scale: float = GMD_CFG_SCALE) -> TrainedGMD:
    """The same trained model sampled with classifier-free guidance at ``scale``: a copy whose
    network is :class:`ClassifierFreeModel` (weights shared, nothing retrained)."""
    if trained.vocabulary is None:
        raise ValueError("classifier-free guidance needs a text-conditioned model")
    if not trained.spec.training.cond_dropout > 0:
        raise ValueError("classifier-free guidance needs a model trained with condition "
                         "dropout (cond_dropout > 0)")
    return dataclasses.replace(trained, model=ClassifierFreeModel(trained.model, scale).eval())


def sample_classifier_free(trained: TrainedGMD, n: int, *, seed: int,
                           text: str | Sequence[str], scale: float = GMD_CFG_SCALE,
                           **kwargs: object) -> Tensor:
    """``guidance.sample`` of :func:`classifier_free` (``trained``, ``scale``) with ``text``;
    the same seed gives the same x_T and per-step noise as plain sampling."""
    return sample(classifier_free(trained, scale), n, seed=seed, text=text,
                  **kwargs)  # type: ignore[arg-type]
