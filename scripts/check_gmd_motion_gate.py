"""Does notebook 01's motion x0 model pass gates version 2's ``gmd_motion`` gate? (issue #14)

Gates version 3 (issue #31) replaced that gate (foot skating, joint jerk and FID of samples:
GMD-A4's, C4's and F1's outcomes) with a fitness gate; this pilot keeps measuring the v2 gate
(:data:`V2_MOTION_GATES`), which its recorded rows in docs/ were decided against.

Trains (or loads from the cache) notebook 01's full-mode GMD-A4 motion model as the notebook's
spec defines it (``x0_vs_eps.Settings.spec`` on ``motion_data()``: relative-root windows,
trained to convergence up to ``MOTION_TRAINING``'s cap), and measures the gate the way the
notebook does: ``settings.generated`` unguided samples (seed = the model's seed), their foot
skating, joint jerk and FID with notebook 01's evaluator against the test windows' own values
(for the reference, the training windows' mean FID over its draws: gates version 2). One
torch thread; prints JSON and appends it to ``--out``. The model lands in the cache under the
notebook's key, so a later full run loads it.

``--cap N --check-every K`` trains the same spec with the step cap N instead of
``MOTION_TRAINING``'s (every other field, the plateau criterion included, as the notebook's;
cached under that spec's key) and measures the gate the same way on the EMA weights every K
steps on the way, one row per check (``"kind": "check"``), each written as it is measured,
with the weights saved beside ``--out``: whether a longer cap passes the gate, and from when.
The training is the same with or without the checks (``train_diffusion``'s ``on_validation``).
``--autocast fp32|bfloat16`` trains the spec in that precision instead of the notebook's
(``MOTION_TRAINING.autocast``; docs/pilot_bf16_motion.md compares the two).

    PYTHONPATH=src python scripts/check_gmd_motion_gate.py --seed 1 --out build/motion_gate.jsonl
    PYTHONPATH=src python scripts/check_gmd_motion_gate.py --seed 1 --cap 12000 \
        --check-every 1000 --out build/motion_gate_long.jsonl
    PYTHONPATH=src python scripts/check_gmd_motion_gate.py --report build/motion_gate_long.jsonl \
        --out docs/check_gmd_motion_gate_long.md   # the checks' table, rendered from the rows

``--spread WEIGHTS --draws K`` measures how much the gate's values move with the sampling seed
alone: the saved EMA weights of one check (``--seed`` and ``--cap`` as that run's) draw the
notebook's unguided samples K times, with the check's own sampling seed first (it must give the
check's values again) and then seeds ``seed + 1000·k``; one row per draw (``"kind": "spread"``).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from repro.core.gates import Gate
from repro.core.tables import markdown_table
from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.measurements import sample_quality, unguided_sample_quality
from repro.gmd.models import MOTION_TRAINING, TrainedGMD, load_or_train_gmd
from repro.gmd.windows import load_windows

#: gates version 2's ``gmd_motion`` gate, relative to the data's values (the FID's reference:
#: the training windows' mean FID over ``model_gates.REFERENCE_FID_DRAWS`` draws)
V2_MOTION_GATES = (
    Gate("foot_skating", "foot skating of samples", "≤ 3× the data's", at_most=3.0),
    Gate("joint_jerk", "joint jerk of samples", "≤ 3× the data's", at_most=3.0),
    Gate("fid", "FID of samples", "≤ 5× the training windows' own", at_most=5.0),
)


def gate_results(family: str, values: dict[str, float],
                 reference: dict[str, float]) -> dict[str, dict[str, Any]]:
    """Per v2 gate: value, allowed range and passed (``family`` must be gmd_motion)."""
    assert family == "gmd_motion"
    out = {}
    for gate in V2_MOTION_GATES:
        low, high = gate.bounds(reference)
        value = values.get(gate.metric)
        out[gate.metric] = {"value": value, "at_least": low, "at_most": high,
                            "passed": value is not None and gate.passes(value, reference)}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="training and sampling seed")
    parser.add_argument("--prediction", choices=("x0", "epsilon"), default="x0")
    parser.add_argument("--cap", type=int, default=None,
                        help="step cap instead of MOTION_TRAINING's (the spec's train_steps)")
    parser.add_argument("--autocast", choices=("fp32", "bfloat16"), default=None,
                        help="train in fp32 or under bf16 autocast instead of the notebook's "
                             "setting (GMDModelSpec.autocast; its own key)")
    parser.add_argument("--check-every", type=int, default=None,
                        help="with --cap: measure the gate every K steps (a multiple of the "
                             "spec's validate_every)")
    parser.add_argument("--report", nargs="+", default=None, metavar="JSONL",
                        help="render these rows' checks as Markdown into --out instead")
    parser.add_argument("--spread", default=None, metavar="WEIGHTS",
                        help="the saved EMA weights of one check: draw the gate's samples "
                             "--draws times with other sampling seeds")
    parser.add_argument("--draws", type=int, default=4, help="with --spread: sample sets")
    parser.add_argument("--reference-draws", type=int, default=None, metavar="K",
                        help="the FID bound's own spread: the data's FID (256 training "
                             "windows against the test windows) for K draws of the windows "
                             "(model_gates.reference_fid; the notebook's gate takes the mean "
                             "of the first REFERENCE_FID_DRAWS)")
    parser.add_argument("--out", required=True, help="JSON lines, appended")
    args = parser.parse_args()
    if args.report:
        sources = {name: [json.loads(line) for line in Path(name).read_text("utf-8").splitlines()
                          if line.strip()] for name in args.report}
        Path(args.out).write_text(report(sources), "utf-8")
        return
    if args.check_every is not None and args.cap is None:
        parser.error("--check-every needs --cap")
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_scale("paper")
    train, evaluation, reference = notebook_reference(settings)
    started = time.process_time()
    spec = settings.spec("motion", args.prediction, train.config, seed=args.seed)
    if args.cap is not None:
        spec = spec.replace(train_steps=args.cap)
    if args.autocast is not None:
        spec = spec.replace(autocast=None if args.autocast == "fp32" else args.autocast)
    if args.check_every is not None and (spec.validate_every is None
                                         or args.check_every % spec.validate_every):
        parser.error(f"--check-every must be a multiple of validate_every={spec.validate_every}")
    out = Path(args.out)
    checking = [0.0]  # CPU seconds spent in the checks so far

    def gate_of(trained: TrainedGMD) -> tuple[dict[str, float], dict[str, Any]]:
        values = unguided_sample_quality(
            trained, settings.generated, seed=args.seed, evaluator=evaluation.evaluator,
            test_embeddings=evaluation.test_embeddings)
        return values, gate_results("gmd_motion", values, reference)

    def check(step: int, loss: float, ema_model: torch.nn.Module) -> None:
        if args.check_every is None or step == 0 or step % args.check_every:
            return
        t0 = time.process_time()
        trained = TrainedGMD(ema_model, spec.diffusion(), train.space("motion"), spec,
                             x0_bound=float(train.x.abs().max()))
        values, gates = gate_of(trained)
        weights = out.with_name(f"{out.stem}.seed{args.seed}.step{step}.pt")
        torch.save(ema_model.state_dict(), weights)
        train_cpu_seconds = t0 - started - checking[0]
        checking[0] += time.process_time() - t0
        append(out, {"kind": "check", "prediction": args.prediction, "seed": args.seed,
                     "autocast": spec.autocast,
                     "representation": train.config.representation, "step_cap": spec.train_steps,
                     "step": step, "val_loss": loss, "values": values,
                     "bounds": bounds_of(gates),
                     "passed": {m: g["passed"] for m, g in gates.items()},
                     "train_cpu_seconds": train_cpu_seconds,
                     "check_cpu_seconds": time.process_time() - t0, "weights": str(weights)})

    if args.reference_draws is not None:
        from repro.gmd.measurements import evaluator_inputs

        fid_gate = next(g for g in V2_MOTION_GATES if g.metric == "fid")
        features, _ = evaluator_inputs(train.space("motion"), train.x)
        t0 = time.process_time()
        mean, draws = model_gates.reference_fid(
            evaluation.evaluator, features, train.frames, evaluation.test_embeddings,
            settings.generated, seed=0, draws=args.reference_draws)
        append(out, {"kind": "reference", "reference_samples": settings.generated,
                     "draws": draws, "mean": mean, "sd": float(np.std(draws, ddof=1)),
                     "bound_of_each_draw": [fid_gate.bounds({"fid": d})[1] for d in draws],
                     "notebook_bound": fid_gate.bounds({"fid": evaluation.reference_fid})[1],
                     "notebook_draws": len(evaluation.reference_fid_draws),
                     "cpu_seconds": time.process_time() - t0})
        return
    if args.spread is not None:
        model = spec.build_model()
        model.load_state_dict(torch.load(args.spread, map_location="cpu", weights_only=True))
        trained = TrainedGMD(model.eval(), spec.diffusion(), train.space("motion"), spec,
                             x0_bound=float(train.x.abs().max()))
        for draw in range(args.draws):
            t0 = time.process_time()
            sampling_seed = args.seed + 1000 * draw
            values = unguided_sample_quality(
                trained, settings.generated, seed=sampling_seed, evaluator=evaluation.evaluator,
                test_embeddings=evaluation.test_embeddings)
            gates = gate_results("gmd_motion", values, reference)
            append(out, {"kind": "spread", "prediction": args.prediction, "seed": args.seed,
                         "weights": args.spread, "sampling_seed": sampling_seed,
                         "values": values, "bounds": bounds_of(gates),
                         "passed": {m: g["passed"] for m, g in gates.items()},
                         "cpu_seconds": time.process_time() - t0})
        return
    trained = load_or_train_gmd(spec, train, on_validation=check)
    values, gates = gate_of(trained)
    row = {"prediction": args.prediction, "seed": args.seed, "autocast": spec.autocast,
           "representation": train.config.representation, "cache_key": trained.cache_key,
           **model_gates.training_summary(trained),
           "train_seconds": trained.metrics.get("seconds"),
           "cpu_seconds": time.process_time() - started, "values": values,
           "reference": reference,
           "bounds": bounds_of(gates),
           "passed": all(g["passed"] for g in gates.values())}
    append(out, row)


def notebook_reference(settings: x0eps.Settings) -> tuple[Any, Any, dict[str, float]]:
    """Notebook 01's motion training windows, its evaluator (as its GMD-A4 cells build them,
    base seed 0) and the gate's reference values of the test windows."""
    train = load_windows(settings.motion_data())
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    evaluation = model_gates.motion_evaluation(
        train, test, settings.evaluator_config(train.fingerprint),
        reference_samples=settings.generated, seed=0)
    reference = sample_quality(test.space("motion").joints(test.x),
                               fid=evaluation.reference_fid)
    return train, evaluation, reference


def bounds_of(gates: dict[str, Any]) -> dict[str, dict[str, float | None]]:
    """The bounds each gate was decided against, kept with the row that was decided."""
    return {m: {k: v for k, v in g.items() if k in ("at_most", "at_least")}
            for m, g in gates.items()}


def report(sources: dict[str, list[dict[str, Any]]]) -> str:
    """Markdown of ``--cap`` runs and ``--spread`` draws, one section per rows file (one
    machine, so one set of bounds: the test windows' values, recorded in the rows; a file whose
    checks were decided against two sets is refused): a line per check, seeds side by side."""
    if not any(r.get("kind") == "check" for rows in sources.values() for r in rows):
        raise ValueError("no check rows to report")
    sections = []
    for name, rows in sources.items():
        checks = sorted((r for r in rows if r.get("kind") == "check"),
                        key=lambda r: (r["step"], r["seed"]))
        spreads = [r for r in rows if r.get("kind") == "spread"]
        decided = checks + spreads
        if not decided:
            continue
        recorded = {json.dumps(r["bounds"], sort_keys=True) for r in decided}
        if len(recorded) != 1:
            raise ValueError(f"{name}: the rows were decided against {len(recorded)} sets of "
                             "bounds")
        bounds = ", ".join(f"{m} ≤ {b['at_most']:.4g}"
                           for m, b in decided[0]["bounds"].items())
        lines = ["", f"## `{name}`", "", f"Gate bounds on the machine that measured these "
                 f"rows: {bounds}."]
        if checks:
            caps = ", ".join(str(cap) for cap in sorted({r["step_cap"] for r in checks}))
            lines += ["", f"Checks on the way to the step cap {caps}:", "", markdown_table(
                ["step", "seed", "held-out loss", "foot skating m/s", "joint jerk m/s³", "FID",
                 "failed gates", "training CPU-s (cumulative)"],
                [[r["step"], r["seed"], f"{r['val_loss']:.4f}",
                  f"{r['values']['foot_skating']:.3f}", f"{r['values']['joint_jerk']:.0f}",
                  f"{r['values']['fid']:.3f}",
                  ", ".join(m for m, ok in r["passed"].items() if not ok) or "none (pass)",
                  f"{r['train_cpu_seconds']:.0f}"] for r in checks])]
        if spreads:
            lines += ["", spread_table(spreads)]
        finals = [r for r in rows if r.get("kind") is None and "step_cap" in r]
        lines += (["", "Finished runs: " + "; ".join(
            f"seed {r['seed']}: {r['steps_used']} steps ({r['stop_reason']}), "
            f"{'passed' if r['passed'] else 'failed'}" for r in finals) + "."] if finals else
            ["", "No run reached its stop (plateau or cap): the rows are what was measured "
                 "before the runs were stopped."] if checks else [])
        sections += lines
    return "\n".join([
        "# Notebook 01's relative-root x0 motion model with a longer step cap (issue #14)",
        "",
        "Generated by `scripts/check_gmd_motion_gate.py --report` (do not edit by hand). "
        "Notebook 01's full-mode GMD-A4 motion spec with a step cap of 12000 "
        f"(`MOTION_TRAINING`'s is {MOTION_TRAINING.step_cap}; 4000 until session 11), "
        "everything else as the notebook's (plateau criterion included); at each check the "
        "EMA weights draw the notebook's 256 unguided samples "
        "(seed = the model's seed), measured with notebook 01's evaluator against the test "
        "windows. Each machine's evaluator gives its own bounds (the FID bound is 5× the "
        "data's own FID, which moves in the evaluator's last bits), so each file of rows has "
        "its own section. One torch thread per run, two runs on the 2 cores.",
        *sections, ""])


def spread_table(spreads: list[dict[str, Any]]) -> str:
    """The ``--spread`` draws of each saved weights file: the gate's values under other
    sampling seeds (the first, the check's own seed, reproduces the check), mean ± sd."""
    import numpy as np

    out = []
    for weights in dict.fromkeys(r["weights"] for r in spreads):
        draws = [r for r in spreads if r["weights"] == weights]
        cells = []
        for metric in ("foot_skating", "joint_jerk", "fid"):
            values = np.array([r["values"][metric] for r in draws])
            digits = 0 if metric == "joint_jerk" else 3
            cells.append(f"{values.mean():.{digits}f} ± {values.std(ddof=1):.{digits}f} "
                         f"({values.min():.{digits}f}–{values.max():.{digits}f})"
                         if len(values) > 1 else f"{values[0]:.{digits}f}")
        passing = sum(all(r["passed"].values()) for r in draws)
        out.append([f"`{Path(weights).name}`", len(draws), *cells,
                    f"{passing} of {len(draws)}"])
    return ("The same weights, sampled again (`--spread`: 256 samples per draw, sampling seeds "
            "seed + 1000·k; mean ± sd (min–max) over the draws):\n\n" + markdown_table(
                ["weights", "draws", "foot skating m/s", "joint jerk m/s³", "FID",
                 "draws passing every gate"], out))


def append(out: Path, row: dict[str, Any]) -> None:
    """Print ``row`` as one JSON line and append it to ``out`` at once (a stopped run keeps
    every row measured before it)."""
    line = json.dumps(row)
    print(line, flush=True)
    with out.open("a", encoding="utf-8") as stream:
        stream.write(line + "\n")


if __name__ == "__main__":
    main()
