"""Gates version 5: a gate guards a reading.

A trained model's gates (``core.gates``) say what it learned; whether a failed gate may hold
back a part of a claim depends on what that part *reads* and which of its arms differ. The
registry states it per part, before any outcome (``Reading``: ``registry_gmd.READINGS``,
``registry_energymogen.READINGS``), and :func:`held_back` applies it to a run's model records:

- a model every arm of the part shares (``model_record(arm=None)``) is *common-mode* there:
  whatever it does, it does to every arm, so its gates are reported beside the part and never
  hold it back (a part that reads one model — a single arm — gates that model);
- a model of an arm the claim predicts to learn or perform *worse* (``Reading.worse``) is
  gated on its training alone: trained with the reference arm's steps (the same spec and data
  are the experiment's design) and its own objective's loss at a plateau
  (``core.gates.TRAINING_GATES``) — a gate on its samples would bound the effect the claim
  predicts;
- every other arm's model is gated on the properties the part reads (``Reading.properties``,
  gate metrics such as ``path_length`` or ``foot_skating``), never on the compared quantity
  itself, and alike across those arms: a property a part reads but a model was not measured
  on holds the part back (it is unknown, not passed).

:func:`gate_table` is that registry as rows (part × property × arms) for the report and the
tests, :func:`violations` checks any gating policy against it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from repro.core.gates import GATES, TRAINING_GATES

__all__ = ["COMMON", "REFERENCE", "WORSE", "Reading", "arm_role", "gate_table", "held_back",
           "reads_of", "violations"]

#: how a model stands to a part (:func:`arm_role`)
COMMON, REFERENCE, WORSE = "common-mode", "gated on what the part reads", "gated on training"


@dataclass(frozen=True)
class Reading:
    """What one model-based part reads of its models.

    ``arms``: the arms the part compares (model records name theirs, ``model_record(arm=)``;
    a record's arm matches an entry it equals or starts with followed by a space, so "N=7"
    covers "N=7 train seed 0"); one arm: the part reads one model per seed. ``properties``:
    the gate metrics its reading depends on (never the quantity it compares). ``worse``: the
    arms the claim predicts to learn or perform worse, gated on training alone."""

    arms: tuple[str, ...]
    properties: tuple[str, ...]
    worse: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        unknown = sorted(set(self.worse) - set(self.arms))
        if unknown:
            raise ValueError(f"worse arms {unknown} are not among the arms {self.arms}")
        metrics = {g.metric for gates in GATES.values() for g in gates}
        unknown = sorted(set(self.properties) - metrics)
        if unknown:
            raise ValueError(f"properties {unknown} are no gate's metric; have {sorted(metrics)}")

    def arm_of(self, arm: str) -> str:
        """The registered arm a record's ``arm`` names (ValueError when none)."""
        for name in self.arms:
            if arm == name or arm.startswith(f"{name} "):
                return name
        raise ValueError(f"arm {arm!r} is none of the part's arms {self.arms}")


def _has_arm(reading: Reading, arm: str) -> bool:
    try:
        reading.arm_of(arm)
    except ValueError:
        return False
    return True


def arm_role(reading: Reading, arm: str | None) -> str:
    """:data:`COMMON` for a component every arm shares (``arm`` None, with more than one arm),
    :data:`WORSE` for an arm the claim predicts worse, else :data:`REFERENCE`."""
    if arm is None:
        return COMMON if len(reading.arms) > 1 else REFERENCE
    return WORSE if reading.arm_of(arm) in reading.worse else REFERENCE


def reads_of(reading: Reading, role: str) -> tuple[str, ...]:
    """The gate metrics a model in ``role`` is gated on for this part."""
    return {COMMON: (), WORSE: TRAINING_GATES, REFERENCE: reading.properties}[role]


def _failed(record: Mapping[str, Any], metrics: Sequence[str]) -> list[str]:
    """Of ``metrics``, those the record's family has a gate for that it failed or was not
    measured on."""
    family = {g.metric for g in GATES.get(record["family"], ())}
    gates = record.get("gate") or {}
    return [m for m in metrics if m in family
            and not (m in gates and gates[m]["passed"])]


def _steps_differ(record: Mapping[str, Any], reading: Reading,
                  records: Sequence[Mapping[str, Any]], part: str) -> bool:
    """A worse arm's model trained for other steps than the same family's models of the
    part's other arms."""
    others = {r.get("steps") for r in records
              if r["family"] == record["family"] and r.get("arm") is not None
              and (r.get("reads") is None or part in r["reads"])
              and reading.arm_of(r["arm"]) not in reading.worse}
    return bool(others) and record.get("steps") not in others


def held_back(readings: Mapping[str, Reading], records: Sequence[Mapping[str, Any]],
              parts: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Per model record (by name): ``holds_back`` part → the gates it failed that the part
    reads of it, ``common`` part → its failed gates reported beside that part (common-mode).
    ``readings``: the claim's registered readings; a part without one reads no model."""
    out: dict[str, dict[str, Any]] = {}
    every_arm = Reading(arms=tuple(dict.fromkeys(a for r in readings.values() for a in r.arms)),
                        properties=())
    for record in records:
        entry: dict[str, Any] = {"holds_back": {}, "common": {}}
        every_failed = [m for m, g in (record.get("gate") or {}).items() if not g["passed"]]
        arm = record.get("arm")
        if arm is not None and readings:
            every_arm.arm_of(arm)   # a name none of the claim's parts compares is an error
        for part in (parts if record.get("reads") is None else record["reads"]):
            reading = readings.get(part)
            if reading is None or (arm is not None and not _has_arm(reading, arm)):
                continue    # a part that reads no model, or not this arm's
            role = arm_role(reading, arm)
            if role == COMMON:
                if every_failed:
                    entry["common"][part] = every_failed
                continue
            failed = _failed(record, reads_of(reading, role))
            if role == WORSE and _steps_differ(record, reading, records, part):
                failed.append("steps")
            if failed:
                entry["holds_back"][part] = failed
        out[record["name"]] = entry
    return out


def gate_table(readings: Mapping[str, Mapping[str, Reading]]) -> list[dict[str, Any]]:
    """The registry's part × property × arms: per claim and part, each arm with what gates
    it (the part's properties, the training gates, or nothing for a shared component)."""
    rows = []
    for claim_id, parts in readings.items():
        for part, reading in parts.items():
            for arm in reading.arms:
                role = WORSE if arm in reading.worse else REFERENCE
                rows.append({"claim": claim_id, "part": part, "arm": arm, "role": role,
                             "gated_on": list(reads_of(reading, role))})
            if len(reading.arms) > 1:
                rows.append({"claim": claim_id, "part": part, "arm": "shared by every arm",
                             "role": COMMON, "gated_on": []})
    return rows


Policy = Callable[[Mapping[str, Reading], Sequence[Mapping[str, Any]], Sequence[str]],
                  Mapping[str, Mapping[str, Any]]]


def violations(policy: Policy, readings: Mapping[str, Reading],
               records: Sequence[Mapping[str, Any]], parts: Sequence[str]) -> list[str]:
    """Where ``policy`` (e.g. :func:`held_back`) holds a part back on a gate the part does not
    read of that model: a shared component, a worse arm's sample gate, a property not in the
    part's reading. Empty: the policy guards readings only."""
    found = []
    by_name = {r["name"]: r for r in records}
    for name, entry in policy(readings, records, parts).items():
        record = by_name[name]
        for part, gates in (entry.get("holds_back") or {}).items():
            reading = readings.get(part)
            if reading is None:
                found.append(f"{name} holds back {part}, which reads no model")
                continue
            role = arm_role(reading, record.get("arm"))
            allowed = set(reads_of(reading, role)) | ({"steps"} if role == WORSE else set())
            wrong = sorted(set(gates) - allowed)
            if wrong:
                found.append(f"{name} holds back {part} on {wrong}, which it does not read "
                             f"of that model")
    return found
