"""Quality gates: what a trained model must be able to do before a verdict may rest on it.

Registered before the models are trained as results (issue "Models that work"); never lowered
to let a model pass. Each gate compares one measurement of the model against the same
measurement of the data it was trained on (``reference``), or against a fixed bound, and
gives its reason. A model passes when every gate of its family passes; a claim whose model
fails is inconclusive for the parts that rest on it (``repro.claims.ledger.record_claim``,
``models=``).

The factors are wide on purpose: a tiny CPU model is not expected to match the data, only to
make motion of the data's kind. What failure looked like before the gates (registry v1 runs):
samples whose joint jerk was 10–10⁴ times the data's and whose feet skated at metres per
second, where the data's feet skate at centimetres per second.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from repro.core.tables import markdown_table

__all__ = ["GATES", "GATES_VERSION", "Gate", "gate_results", "gates_markdown",
           "model_record"]

#: 2: the ``gmd_motion`` FID gate's reference is the training windows' mean FID over
#: ``gmd.model_gates.REFERENCE_FID_DRAWS`` draws (1: one draw, whose FID moved by 17 % (sd)
#: between draws, and the bound with it; docs/REGISTRY_CHANGELOG.md "Gates version 2").
GATES_VERSION = 2


@dataclass(frozen=True)
class Gate:
    """``metric`` of the model within [``at_least``, ``at_most``] (either may be None): bounds
    in units of the data's own value of the metric when ``relative``, else absolute."""

    metric: str
    reason: str
    at_most: float | None = None
    at_least: float | None = None
    relative: bool = True

    def bounds(self, reference: Mapping[str, float]) -> tuple[float | None, float | None]:
        """(lowest allowed, highest allowed) value of the model's metric."""
        scale = 1.0
        if self.relative:
            if self.metric not in reference:
                raise ValueError(f"gate {self.metric!r} is relative to the data's value; the "
                                 f"reference has {sorted(reference)}")
            scale = float(reference[self.metric])
        low = None if self.at_least is None else self.at_least * scale
        high = None if self.at_most is None else self.at_most * scale
        return low, high

    def passes(self, value: float, reference: Mapping[str, float]) -> bool:
        low, high = self.bounds(reference)
        return (math.isfinite(value) and (low is None or value >= low)
                and (high is None or value <= high))


_PHYSICAL = ("a model within a factor 3 of the data's own value makes motion of the data's "
             "kind; the failures seen before gates were 10–10⁴× off")

#: family → gates. Families: the GMD UNets (``gmd_motion``, ``gmd_trajectory``), the MLD-style
#: VAE (``vae``), the latent denoiser (``latent_denoiser``), the evaluator (``evaluator``).
GATES: dict[str, tuple[Gate, ...]] = {
    "gmd_motion": (
        Gate("foot_skating", f"foot skating (m/s) of unguided samples ≤ 3× the data's: "
             f"{_PHYSICAL}", at_most=3.0),
        Gate("joint_jerk", f"joint jerk (m/s³) of unguided samples ≤ 3× the data's: {_PHYSICAL}",
             at_most=3.0),
        Gate("fid", "FID against the test windows ≤ 5× the training windows' own FID against "
             "them, the mean over 64 draws of as many windows as samples (the data's sampling "
             "noise sets the floor; 5× leaves room for a tiny model without admitting motion "
             "of another kind)", at_most=5.0),
    ),
    "gmd_trajectory": (
        Gate("root_jerk", f"root jerk (m/s³) of unguided samples ≤ 3× the data's: {_PHYSICAL}",
             at_most=3.0),
        Gate("path_length", "path length (m) of unguided samples within ½–2× the data's: a "
             "model that stands still or drifts has not learnt the data's speed",
             at_least=0.5, at_most=2.0),
    ),
    "vae": (
        Gate("reconstruction_mpjpe", "reconstruction MPJPE (m) of held-out clips ≤ 5 cm, the "
             "oracles' contact threshold, so what a concept looks like survives", at_most=0.05,
             relative=False),
        Gate("concept_preservation", "oracle concept recall on reconstructions ≥ 0.9× the "
             "oracles' recall on the clips themselves", at_least=0.9),
    ),
    "latent_denoiser": (
        Gate("single_text_accuracy", "oracle accuracy of single-text samples ≥ ½ the oracles' "
             "accuracy on real clips of those concepts: the model follows its text",
             at_least=0.5),
    ),
    "evaluator": (
        Gate("r_precision_top3", "R@3 on held-out real windows (batches of 32, chance 3/32) "
             "≥ 0.8: the evaluator ranks true text–motion pairs far above chance",
             at_least=0.8, relative=False),
    ),
}


def gate_results(family: str, values: Mapping[str, float],
                 reference: Mapping[str, float] | None = None) -> dict[str, dict[str, Any]]:
    """Per gate of ``family``: the model's value, the allowed range, passed and the reason.
    A gate whose value was not measured fails, saying so."""
    if family not in GATES:
        raise ValueError(f"unknown model family {family!r}; have {sorted(GATES)}")
    reference = dict(reference or {})
    results = {}
    for gate in GATES[family]:
        low, high = gate.bounds(reference)
        value = values.get(gate.metric)
        results[gate.metric] = {
            "value": None if value is None else float(value), "at_least": low, "at_most": high,
            "passed": value is not None and gate.passes(float(value), reference),
            "reason": gate.reason if value is not None else f"not measured — {gate.reason}"}
    return results


def model_record(*, name: str, family: str, values: Mapping[str, float],
                 reference: Mapping[str, float] | None = None, parameters: int | None = None,
                 steps: int | None = None, train_seconds: float | None = None,
                 validation_curve: list[float] | None = None,
                 converged: bool | None = None) -> dict[str, Any]:
    """What the report's "Models" section and ``models.json`` show of one trained model."""
    gates = gate_results(family, values, reference)
    return {"name": name, "family": family, "gates_version": GATES_VERSION,
            "parameters": parameters, "steps": steps, "train_seconds": train_seconds,
            "converged": converged, "validation_curve": list(validation_curve or []),
            "gate": gates, "passed": all(g["passed"] for g in gates.values())}


def _number(value: float | None) -> str:
    return "—" if value is None else f"{value:.3g}"


def gates_markdown(records: list[dict[str, Any]] | tuple[dict[str, Any], ...]) -> str:
    r"""One row per (model, gate) of :func:`model_record`\ s: the model's family, size, steps
    and training time, the gate's value, its allowed range and pass/fail; then how many pass."""
    rows = []
    for record in records:
        for k, (metric, gate) in enumerate(record["gate"].items()):
            head = ([record["name"], record["family"], _number(record["parameters"]),
                     _number(record["steps"]), _number(record["train_seconds"])]
                    if k == 0 else ["", "", "", "", ""])
            value = "not measured" if gate["value"] is None else _number(gate["value"])
            rows.append([*head, metric, value,
                         f"[{_number(gate['at_least'])}, {_number(gate['at_most'])}]",
                         "pass" if gate["passed"] else "**fail**"])
    passed = sum(bool(r["passed"]) for r in records)
    return (markdown_table(["model", "family", "parameters", "steps", "training s", "gate",
                            "value", "allowed", ""], rows)
            + f"\n\n{passed} of {len(records)} models pass their registered gates "
            "(`repro.core.gates`); a verdict resting on a model that fails its gate is "
            "inconclusive.")
