"""Gates: what a trained model must have learned before a verdict may rest on it.

Registered before the models are trained as results; never lowered to let a model pass.
Two kinds, each saying what it measures (``Gate.measures``) so the paper packages can check
it against what their claims compare (``gmd.model_gates.COMPARED``,
``energymogen.model_gates.COMPARED``):

- *Fitness* gates (``Gate.role`` "any") ask whether a model learned what a claim's
  measurement needs, anchored to a trivial baseline (a Gaussian with the data's per-feature
  mean and covariance, shuffled frames, chance); they never measure a quantity a claim
  resting on the model compares — a gate on an outcome would make the claim inconclusive by
  construction when the paper's effect is large.
- *Sample* gates (role "reference") judge a model on what it generates, against the data
  measured the same way in the same run: it moves as much as the data (mean joint and root
  speed within ½–2×), its joints are no more jagged (jerk ≤ 2×) and its feet slide no more
  (foot skating ≤ 3×) than a small multiple of the data's, and a conditioned model's samples
  show the asked-for concept (oracle recall ≥ 0.7× the data's). They apply to the
  *reference arm* of a comparison (``model_record(role="reference")``: the model a claim's
  other arm is compared against, or the one model both arms of a claim sample), never to a
  *treatment arm* (role "treatment"), which passes the fitness gates only: a band on the
  reference arm bounds where the comparison starts, not its sign, while a gate on the
  treatment arm's compared quantity would decide the claim.

A model passes when every gate of its family and role passes; a model that fails makes
inconclusive the parts of a claim that read it (``model_record(reads=...)``,
``repro.claims.ledger.record_claim``). The versions and their reasons are in
docs/REGISTRY_CHANGELOG.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from repro.core.tables import markdown_table

__all__ = ["CURVE_POINTS", "GATES", "GATES_VERSION", "PLATEAU_LOG_IMPROVEMENT",
           "PUBLISHED_SKATING_RATIO", "PUBLISHED_SKATING_RATIO_SOURCE",
           "REPORTED_METRICS", "REREAD_DRAWS", "REREAD_SEED_STRIDE", "TRAINING_GATES",
           "Gate", "family_measures", "gate_results", "gates_markdown", "loss_curve",
           "model_record", "plateau_improvement", "reading", "reported_values",
           "straddling"]

#: 5: a gate guards a reading (``claims.gating``): which failed gate holds back which part is
#: the registry's, per part; every trained diffusion model and autoencoder reports whether its
#: loss reached a plateau (:data:`TRAINING_GATES`), the gate of an arm its claim predicts
#: worse. docs/REGISTRY_CHANGELOG.md "Gates version 5".
#: 4: sample gates on the reference arm (``Gate.role``; docs/REGISTRY_CHANGELOG.md "Gates
#: version 4"). 3: fitness gates: held-out x̂0 error against the Gaussian denoiser for every
#: diffusion model, the evaluator's R@3 of real data and its FID of trivial fakes; no gate on
#: a compared quantity (foot skating, jerk, FID of samples, reconstruction MPJPE, oracle
#: accuracy of samples). 2: the ``gmd_motion`` FID gate's reference was the training windows'
#: mean FID over 64 draws. docs/REGISTRY_CHANGELOG.md "Gates version 2" and "Gates version 3".
GATES_VERSION = 5
#: the roles of a model in a claim (``model_record(role=...)``): "reference" passes every gate
#: of its family, "treatment" only the gates whose ``role`` is "any" (the fitness gates)
ROLES = ("reference", "treatment")


@dataclass(frozen=True)
class Gate:
    """``metric`` of the model within [``at_least``, ``at_most``] (either may be None): bounds
    in units of the data's own value of the metric when ``relative``, else absolute.
    ``measures``: the quantity in words, as the claims' tables of compared quantities name
    theirs (``gmd.model_gates.COMPARED``, ``energymogen.model_gates.COMPARED``). ``role``
    "any": every model of the family (a fitness gate); "reference": only a model in the
    reference role (a sample gate, :data:`ROLES`)."""

    metric: str
    measures: str
    reason: str
    at_most: float | None = None
    at_least: float | None = None
    relative: bool = True
    role: str = "any"

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


#: points of the training-loss curve kept in a model record (means of equal chunks of steps)
CURVE_POINTS = 50


def loss_curve(losses: Sequence[float], points: int = CURVE_POINTS) -> list[float]:
    """The per-step training losses as ``points`` means of equal chunks of steps (all of
    them when there are fewer steps): a model record's curve where no held-out curve was
    kept."""
    values = np.asarray(list(losses), dtype=np.float64)
    if len(values) <= points:
        return values.tolist()
    return [float(chunk.mean()) for chunk in np.array_split(values, points)]


#: a tenth of training that lowers the loss by more than this (log scale: 5 %) is not a plateau
PLATEAU_LOG_IMPROVEMENT = 0.05


def plateau_improvement(curve: Sequence[float]) -> float:
    """The loss's improvement over the last tenth of training, on the log scale: the mean of
    the curve's last tenth of points against the tenth before, ln(before / last), scaled to a
    tenth of training when the curve has fewer than ten points (its last two points then lie
    1/n of training apart: × n/10). The curve's points are means of equal spans of steps
    (the training loss, or the held-out loss at equal intervals). NaN with fewer than two
    points or a non-positive loss."""
    values = [float(v) for v in curve]
    n = len(values)
    if n < 2 or min(values) <= 0.0:
        return math.nan
    k = max(1, n // 10)
    last = sum(values[-k:]) / k
    before = sum(values[-2 * k:-k]) / k
    return math.log(before / last) * (0.1 / (k / n))


_PLATEAU = Gate(
    "training_plateau", "improvement of the training objective's loss in the last tenth of "
    "training", "the model's own training loss (its objective: ε or x0 MSE, weighted as it "
    "was trained) fell by at most 5 % (log scale) over the last tenth of its steps "
    "(``plateau_improvement``): more training of the same model would not change what it "
    "learned by much. The gate of an arm its claim predicts to learn worse "
    "(``claims.gating``): it is judged on its training, never on its samples, which carry "
    "the effect", at_most=PLATEAU_LOG_IMPROVEMENT, relative=False)

#: the gates an arm its claim predicts worse is held to (``claims.gating``), with the same
#: steps as the reference arm
TRAINING_GATES = ("training_plateau",)


#: what the x̂0-error gates measure (``core.fitness.x0_error_ratio``)
X0_ERROR = "x̂0 error of held-out data"

_X0_REASON = (
    "held-out x̂0 error at ᾱ = 0.75, 0.5, 0.25 (one forward pass each, the same x_t) ≤ 0.9× "
    "that of the best denoiser of a Gaussian with the training data's per-feature mean and "
    "covariance (core.fitness.x0_error_ratio): a model at or above 1 has learned nothing "
    "beyond the data's first two moments, and 10 % below it is the stated margin. A mean over "
    "every held-out {unit} and three levels, no sampling draw. No claim compares x̂0 errors: "
    "{claims}")

#: what the sample gates measure, and why each bound (gates version 4, kept in version 5)
JOINT_SPEED = "mean joint speed of samples"
ROOT_SPEED = "mean root speed of samples"
JOINT_JERK = "joint jerk of samples"
FOOT_SKATING = "foot skating of samples"
CONCEPT_RECALL = "oracle concept recall of samples"


def _sample_gates(*, recall: bool, root: bool = True) -> tuple[Gate, ...]:
    """The reference arm's sample gates, each relative to the data's own value measured the
    same way in the same run (test windows against as many samples)."""
    moves = ("within ½–2× the data's: a model that stands still has low jerk and no foot "
             "skating, so the two ceilings below need a floor on movement; the mean motion "
             "of the data (an untrained x0 model) moves at about half the data's speed")
    gates = [Gate("joint_speed", JOINT_SPEED, f"mean joint speed (m/s) {moves}",
                  at_least=0.5, at_most=2.0, role="reference")]
    if root:
        gates.append(Gate("root_speed", ROOT_SPEED, f"mean horizontal root speed (m/s) "
                          f"{moves}", at_least=0.5, at_most=2.0, role="reference"))
    gates += [
        Gate("joint_jerk", JOINT_JERK, "mean joint jerk (m/s³) ≤ 2× the data's: white noise "
             "left in a sample's positions shows in its third difference, amplified by fps³; "
             "twice the data's is jagged motion the eye sees", at_most=2.0, role="reference"),
        Gate("foot_skating", FOOT_SKATING, "mean horizontal foot speed in contact (m/s) ≤ 3× "
             "the data's: feet that slide while planted are motion the data never has; the "
             "multiple allows for a tiny model's root and limbs agreeing less well than the "
             "generator's solver makes them", at_most=3.0, role="reference")]
    if recall:
        gates.append(Gate("concept_recall", CONCEPT_RECALL, "the concept oracles find the "
                          "captioned concepts in samples generated for test captions at ≥ 0.7× "
                          "their rate on the test windows themselves: the model makes what the "
                          "text asks for, which every reading by concept, R@3 and FID of "
                          "conditioned samples needs", at_least=0.7, role="reference"))
    return tuple(gates)


#: family → gates. Families: the GMD UNets (``gmd_motion``, ``gmd_trajectory``), the MLD-style
#: VAE (``vae``), the latent denoiser (``latent_denoiser``), the evaluator (``evaluator``).
GATES: dict[str, tuple[Gate, ...]] = {
    "gmd_motion": (
        Gate("x0_error_vs_gaussian", X0_ERROR, _X0_REASON.format(
            unit="window's frames (text-conditioned models with the window's captions)",
            claims="GMD-A4 compares joint jerk and FID of samples, B3 FID, diversity and R@3 "
                   "of samples, C4 and F1 foot skating and joint jerk of samples, so the old "
                   "gates on foot skating, jerk and FID sat on their outcomes"),
             at_most=0.9, relative=False),
        *_sample_gates(recall=True),
        _PLATEAU,
    ),
    "gmd_trajectory": (
        Gate("x0_error_vs_gaussian", X0_ERROR, _X0_REASON.format(
            unit="window's frames",
            claims="GMD-A3, B2 and F1 compare goal and location errors of guided samples, "
                   "A4 and F1 root jerk of samples, so the old root-jerk gate sat on theirs"),
             at_most=0.9, relative=False),
        Gate("path_length", "path length of unguided samples", "path length (m) of unguided "
             "samples within ½–2× the test windows': a model that stands still or drifts has "
             "not learnt the data's speed, which every goal and location error needs; no claim "
             "compares path lengths (the goal errors it bounds are of guided samples)",
             at_least=0.5, at_most=2.0),
        Gate("root_jerk", "root jerk of unguided samples", "mean root jerk (m/s³) of unguided "
             "samples ≤ 2× the test windows': a path that wobbles frame to frame is not the "
             "data's locomotion, whatever its length", at_most=2.0, role="reference"),
        _PLATEAU,
    ),
    "vae": (
        Gate("concept_preservation", "oracle concept recall of reconstructions", "oracle "
             "concept recall on reconstructions of held-out clips ≥ 0.9× the oracles' recall on "
             "the clips themselves: what a concept looks like survives the autoencoder, which "
             "every oracle, R@3 and FID reading of decoded samples needs. The old MPJPE gate "
             "sat on EMG-7's outcome (reconstruction error by N); no claim compares the recall "
             "of reconstructions (EMG-2/3 read the oracles on generated samples)",
             at_least=0.9),
        Gate("joint_jerk", "joint jerk of reconstructions", "mean joint jerk (m/s³) of "
             "reconstructions of held-out clips ≤ 2× the clips' own: every decoded sample "
             "passes through the decoder, so a decoder that adds jitter makes every sample "
             "jagged", at_most=2.0, role="reference"),
        Gate("foot_skating", "foot skating of reconstructions", "mean horizontal foot speed in "
             "contact (m/s) of reconstructions of held-out clips ≤ 3× the clips' own: a "
             "decoder whose feet slide makes every decoded sample slide", at_most=3.0,
             role="reference"),
        _PLATEAU,
    ),
    "latent_denoiser": (
        Gate("x0_error_vs_gaussian", X0_ERROR, _X0_REASON.format(
            unit="clip's latent (with one of its captions)",
            claims="EMG-2/3 compare oracle concept presence of samples (the old gate's "
                   "oracle accuracy of single-text samples), EMG-4/5/8 R@3 of samples, EMG-5 "
                   "transition distances, EMG-6 the correlation of energy maps, EMG-7/8 FID of "
                   "samples"),
             at_most=0.9, relative=False),
        *_sample_gates(recall=True),
        _PLATEAU,
    ),
    "evaluator": (
        Gate("r_precision_top3", "R-precision of held-out real data", "R@3 of held-out real "
             "windows with their own captions (batches of 32, chance 3/32 ≈ 0.09; the mean over "
             "8 shuffles of the batches) ≥ 0.8, chance + 0.7: the evaluator ranks true "
             "text–motion pairs far above chance, which every R@3 and FID of samples needs; "
             "claims compare R@3 of samples, never of real data", at_least=0.8,
             relative=False),
        Gate("trivial_fid_ratio", "FID of trivial fakes over real data's", "FID of trivial "
             "fakes (frames i.i.d. from the data's per-feature Gaussian; real windows with "
             "shuffled frames; each the mean of 4 draws) against held-out windows ≥ 3× the "
             "real training windows' own FID (core.fitness.trivial_fid_ratio): an evaluator "
             "whose FID cannot tell motion from either fake cannot rank samples by FID; claims "
             "compare FID of samples, never of fakes", at_least=3.0, relative=False),
    ),
}


def check_role(role: str) -> None:
    if role not in ROLES:
        raise ValueError(f"role must be one of {ROLES}, got {role!r}")


def gates_for(family: str, role: str) -> tuple[Gate, ...]:
    """The gates of ``family`` a model in ``role`` must pass: all of them for the reference
    arm, the fitness gates (``role`` "any") for a treatment arm."""
    if family not in GATES:
        raise ValueError(f"unknown model family {family!r}; have {sorted(GATES)}")
    check_role(role)
    return tuple(g for g in GATES[family] if role == "reference" or g.role == "any")


def family_measures(family: str, role: str = "treatment") -> set[str]:
    """The quantities (``Gate.measures``) the gates of ``family`` measure for a model in
    ``role`` (a treatment arm by default: the gates that must never measure what a claim
    compares)."""
    return {gate.measures for gate in gates_for(family, role)}


def gate_results(family: str, values: Mapping[str, float],
                 reference: Mapping[str, float] | None = None, *,
                 role: str) -> dict[str, dict[str, Any]]:
    """Per gate of ``family`` that a model in ``role`` must pass (:func:`gates_for`): the
    model's value, the allowed range, passed and the reason. A gate whose value was not
    measured fails, saying so."""
    reference = dict(reference or {})
    results = {}
    for gate in gates_for(family, role):
        value = values.get(gate.metric)
        data = float(reference.get(gate.metric, math.nan)) if gate.relative else None
        if data is not None and gate.metric in reference and math.isnan(data):
            # the data hold no value to compare with (e.g. concept recall without labels)
            results[gate.metric] = {
                "value": None if value is None else float(value), "at_least": None,
                "at_most": None, "data": None, "passed": True, "applies": False,
                "reason": f"not measurable on this data — {gate.reason}"}
            continue
        low, high = gate.bounds(reference)
        results[gate.metric] = {
            "value": None if value is None else float(value), "at_least": low, "at_most": high,
            "data": data,
            "passed": value is not None and gate.passes(float(value), reference),
            "reason": gate.reason if value is not None else f"not measured — {gate.reason}"}
        interval = values.get(f"{gate.metric}_interval")
        if interval is not None:
            results[gate.metric]["interval"] = [float(v) for v in interval]
            results[gate.metric]["straddles"] = _straddles(interval, low, high)
            results[gate.metric]["draws"] = int(values.get("gate_draws", 1))
    return results


def _straddles(interval: Sequence[float], low: float | None, high: float | None) -> bool:
    return any(bound is not None and interval[0] < bound < interval[1] for bound in (low, high))


#: a sample gate whose interval straddles its bound is read again on this many draws of the
#: same size, pooled (``straddling``), before it decides
REREAD_DRAWS = 4
#: the seed of a sample gate's k-th draw is the first's + k × this (draws far apart)
REREAD_SEED_STRIDE = 100_003


def straddling(family: str, values: Mapping[str, Any], reference: Mapping[str, float],
               role: str) -> list[str]:
    """The gates of ``family`` (for ``role``) whose sampling interval (``values``'
    ``<metric>_interval``, :func:`core.metrics.motion_statistics_intervals`) straddles a
    bound: the draw cannot tell pass from fail, so the caller reads them again on
    :data:`REREAD_DRAWS` draws before the gate decides."""
    out = []
    for gate in gates_for(family, role):
        interval = values.get(f"{gate.metric}_interval")
        if interval is None or (gate.relative and gate.metric not in reference):
            continue
        if gate.relative and math.isnan(float(reference[gate.metric])):
            continue
        if _straddles(interval, *gate.bounds(reference)):
            out.append(gate.metric)
    return out


#: measurements a model record reports beside its gates, with the data's, gating nothing:
#: GMD's foot skating ratio (:func:`core.metrics.foot_skating_ratio`), which the field's
#: tables print
REPORTED_METRICS = ("foot_skating_ratio",)

#: the skating ratio of real motion and published text-to-motion models on HumanML3D
#: (InterControl, NeurIPS 2024, Table 1), for the report to place ours among
PUBLISHED_SKATING_RATIO = {"real motion": 0.000, "MDM": 0.094, "PriorMDM": 0.092,
                           "GMD": 0.111, "OmniControl": 0.055}
PUBLISHED_SKATING_RATIO_SOURCE = "InterControl (NeurIPS 2024), Table 1, HumanML3D"


def reported_values(values: Mapping[str, float],
                    reference: Mapping[str, float] | None = None) -> dict[str, dict[str, Any]]:
    """:data:`REPORTED_METRICS` of a model's ``values`` with the data's (``reference``)."""
    reference = dict(reference or {})

    def number(value: Any) -> float | None:
        return None if value is None or math.isnan(float(value)) else float(value)

    return {metric: {"value": number(values.get(metric)), "data": number(reference.get(metric))}
            for metric in REPORTED_METRICS if metric in values}


def model_record(*, name: str, family: str, values: Mapping[str, float],
                 reference: Mapping[str, float] | None = None, parameters: int | None = None,
                 steps: int | None = None, train_seconds: float | None = None,
                 validation_curve: list[float] | None = None,
                 converged: bool | None = None,
                 reads: Sequence[str] | None = None, role: str,
                 arm: str | None = None) -> dict[str, Any]:
    """What the report's "Models" section and ``models.json`` show of one trained model.

    ``reads``: the names of the claim's parts that rest on this model (None: every part); a
    model that fails its gate makes only those inconclusive. ``role``: "reference" (every
    gate of the family) or "treatment" (its fitness gates only, :func:`gates_for`); each gate
    keeps the model's value and, for a gate relative to the data, the data's. ``arm``: the arm
    of the parts it is read by that this model serves (e.g. "x0", "eps", "N=7"); None: a
    component every arm of those parts shares (common-mode: reported beside the parts, never
    gating them)."""
    check_role(role)
    values = dict(values)
    if any(g.metric == "training_plateau" for g in GATES.get(family, ())):
        values.setdefault("training_plateau", plateau_improvement(validation_curve or []))
    gates = gate_results(family, values, reference, role=role)
    return {"name": name, "family": family, "gates_version": GATES_VERSION, "role": role,
            "reads": None if reads is None else [str(part) for part in reads],
            "arm": None if arm is None else str(arm),
            "parameters": parameters, "steps": steps, "train_seconds": train_seconds,
            "converged": converged, "validation_curve": list(validation_curve or []),
            "gate": gates, "reported": reported_values(values, reference),
            "passed": all(g["passed"] for g in gates.values())}


def reading(records: Sequence[Mapping[str, Any]],
            parts: Sequence[str] | None) -> list[dict[str, Any]]:
    """Copies of ``records`` whose ``reads`` are ``parts`` (None: every part of the claim): for
    a notebook that passes the same models to claims whose parts rest on them differently."""
    return [{**record, "reads": None if parts is None else [str(p) for p in parts]}
            for record in records]


def _number(value: float | None) -> str:
    return "—" if value is None else f"{value:.3g}"


def gates_markdown(records: list[dict[str, Any]] | tuple[dict[str, Any], ...]) -> str:
    r"""One row per (model, gate) of :func:`model_record`\ s: the model's family and role,
    size, steps and training time, the gate's value, the data's own value (for a gate
    relative to it), its allowed range and pass/fail; then how many pass."""
    rows = []
    for record in records:
        for k, (metric, gate) in enumerate(record["gate"].items()):
            head = ([record["name"], f"{record['family']} ({record.get('role', '—')})",
                     _number(record["parameters"]), _number(record["steps"]),
                     _number(record["train_seconds"])]
                    if k == 0 else ["", "", "", "", ""])
            value = "not measured" if gate["value"] is None else _number(gate["value"])
            if gate.get("interval") and gate["value"] is not None:   # its sampling interval
                low, high = gate["interval"]
                value += f" [{_number(low)}, {_number(high)}]"
                if gate.get("draws", 1) > 1:
                    value += f", {gate['draws']} draws"
            rows.append([*head, metric, value, _number(gate.get("data")),
                         f"[{_number(gate['at_least'])}, {_number(gate['at_most'])}]",
                         "pass" if gate["passed"] else "**fail**"])
    passed = sum(bool(r["passed"]) for r in records)
    return (markdown_table(["model", "family (role)", "parameters", "steps", "training s",
                            "gate", "value", "data", "allowed", ""], rows)
            + f"\n\n{passed} of {len(records)} models pass their registered gates "
            "(`repro.core.gates`); a verdict resting on a model that fails its gate is "
            "inconclusive.")
