"""Design pilot of the GMD motion UNet (issue #14): time to pass the ``gmd_motion`` gate.

Each configuration is a ``GMDModelSpec`` on notebook 01's full-mode windows (2000 stand-in
clips, 48 frames, absolute root, T = 100 cosine, x0 prediction) whose full-resolution width
is at least the 263 features. It trains with convergence validation (5 % of the training
clips held out, ``models.validation_split``); at every validation the EMA weights' unguided
samples are measured against the registered gate (``core.gates``, family ``gmd_motion``):
foot skating and joint jerk of the recovered joints against the test windows' own, FID (the
package's evaluator, notebook 01's) against the training windows' own FID to the test
windows, both with the same number of windows. A configuration stops at its first pass, at
its plateau, or at its share of the time budget. One torch thread; the seconds per step
exclude the gate measurements. Writes ``docs/pilot_gmd_motion.md`` (``--out``).

    PYTHONPATH=src python scripts/pilot_gmd_motion.py [--budget-minutes 40] [--only A,B]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from repro.core import metrics
from repro.core.gates import gate_results
from repro.core.tables import markdown_table
from repro.core.training import ValidationSet, train_diffusion
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.guidance import sample
from repro.gmd.measurements import evaluator_inputs, sample_quality
from repro.gmd.model_gates import motion_evaluation, one_caption_each
from repro.gmd.models import (
    GMDModelSpec,
    TrainedGMD,
    bag_of_words,
    validation_split,
)
from repro.gmd.windows import load_windows
from repro.models.unet import narrowest_full_resolution_width


@dataclass(frozen=True)
class PilotConfig:
    """One configuration of the pilot: widths, batch, learning rate, conditioning."""

    name: str
    base_channels: int
    channel_mults: tuple[float, ...]
    batch_size: int
    lr: float
    text_conditioned: bool = False


CONFIGS = (
    PilotConfig("A", 288, (1, 0.5, 0.25), 64, 1e-3),
    PilotConfig("B", 288, (1, 0.5, 0.25), 64, 3e-4),
    PilotConfig("C", 288, (1, 0.5, 0.25), 32, 1e-3),
    PilotConfig("D", 288, (1, 1, 1), 32, 1e-3),
    PilotConfig("E", 288, (1, 0.5, 0.25), 64, 1e-3, text_conditioned=True),
)


@dataclass
class Check:
    step: int
    validation_loss: float
    values: dict[str, float]
    passed: bool


@dataclass
class Outcome:
    config: PilotConfig
    parameters: int
    full_resolution_width: int
    seconds_per_step: float = float("nan")
    checks: list[Check] = field(default_factory=list)
    stop: str = ""

    @property
    def first_pass(self) -> Check | None:
        return next((c for c in self.checks if c.passed), None)


class StopPilot(Exception):
    """Raised by the validation callback to end a configuration's run."""


def run_config(config: PilotConfig, *, train: Any, test: Any, evaluator: Any,
               test_embeddings: np.ndarray, reference: dict[str, float], samples: int,
               check_every: int, cap: int, cpu_seconds: float, wall_seconds: float) -> Outcome:
    spec = GMDModelSpec(task="motion", prediction="x0", data=train.config,
                        base_channels=config.base_channels, channel_mults=config.channel_mults,
                        diffusion_steps=100, train_steps=cap, batch_size=config.batch_size,
                        lr=config.lr, text_conditioned=config.text_conditioned,
                        validate_every=check_every)
    vocabulary = train.vocabulary if config.text_conditioned else None
    cond = bag_of_words(vocabulary, train.captions) if vocabulary is not None else None
    fit, held = validation_split(train, spec.validation_fraction)
    x = train.x
    validation = ValidationSet(x[held], cond=None if cond is None else cond[held])
    diffusion = spec.diffusion()
    model = spec.build_model(None if vocabulary is None else len(vocabulary))
    outcome = Outcome(config, sum(p.numel() for p in model.parameters()),
                      narrowest_full_resolution_width(model))
    captions = one_caption_each(test.captions, seed=0)
    picks = np.random.default_rng(0).choice(len(test), samples, replace=False)
    texts = [captions[i] for i in picks] if config.text_conditioned else None
    measuring = [0.0]
    started, started_wall = time.process_time(), time.perf_counter()

    def on_validation(step: int, loss: float, ema_model: torch.nn.Module) -> None:
        if step == 0:
            return
        t0 = time.process_time()
        trained = TrainedGMD(ema_model, diffusion, train.space("motion"), spec, vocabulary)
        with torch.no_grad():
            drawn = sample(trained, samples, seed=0, text=texts)
        features, lengths = evaluator_inputs(trained, drawn)
        fid = metrics.fid(evaluator.embed_motions(features, lengths), test_embeddings)
        values = sample_quality(trained.space.joints(drawn), fid=fid)
        gates = gate_results("gmd_motion", values, reference)
        passed = all(g["passed"] for g in gates.values())
        outcome.checks.append(Check(step, loss, values, passed))
        measuring[0] += time.process_time() - t0
        training_seconds = time.process_time() - started - measuring[0]
        if step:
            outcome.seconds_per_step = training_seconds / step
        print(f"{config.name} step {step}: val {loss:.4f} skating {values['foot_skating']:.3f} "
              f"jerk {values['joint_jerk']:.1f} fid {fid:.3f} passed {passed} "
              f"({training_seconds:.0f} CPU-s training, {measuring[0]:.0f} CPU-s measuring, "
              f"{time.perf_counter() - started_wall:.0f} s wall)", flush=True)
        if passed:
            outcome.stop = "gate passed"
            raise StopPilot
        if (time.process_time() - started > cpu_seconds
                or time.perf_counter() - started_wall > wall_seconds):
            outcome.stop = "time budget"
            raise StopPilot

    try:
        result = train_diffusion(model, diffusion, x[fit].contiguous(), spec.train_config(),
                                 cond=None if cond is None else cond[fit],
                                 validation=validation, on_validation=on_validation,
                                 progress=False)
        assert result.convergence is not None
        outcome.stop = result.convergence.stop_reason
    except StopPilot:
        pass
    return outcome


def report(outcomes: list[Outcome], reference: dict[str, float], *, samples: int,
           check_every: int, budget_minutes: float, total_seconds: float) -> str:
    rows = []
    for o in outcomes:
        c = o.config
        widths = f"{c.base_channels}×({', '.join(f'{m:g}' for m in c.channel_mults)})"
        for check in o.checks:
            rows.append([c.name, widths,
                         str(o.full_resolution_width), f"{o.parameters / 1e6:.1f} M",
                         str(c.batch_size), f"{c.lr:g}", "text" if c.text_conditioned else "—",
                         f"{o.seconds_per_step:.2f}", str(check.step),
                         f"{check.validation_loss:.4f}", f"{check.values['foot_skating']:.3f}",
                         f"{check.values['joint_jerk']:.0f}", f"{check.values['fid']:.2f}",
                         "**pass**" if check.passed else "fail"])
    summary = []
    for o in outcomes:
        first = o.first_pass
        summary.append([o.config.name, f"{o.seconds_per_step:.2f}",
                        str(o.checks[-1].step if o.checks else 0), o.stop,
                        "—" if first is None else str(first.step),
                        "—" if first is None else f"{first.step * o.seconds_per_step / 60:.1f}"])
    bounds = gate_results("gmd_motion", {}, reference)
    allowed = ", ".join(f"{m} ≤ {g['at_most']:.3g}" for m, g in bounds.items())
    return "\n".join([
        "# Design pilot: the GMD motion UNet (issue #14)",
        "",
        "Generated by `scripts/pilot_gmd_motion.py` (do not edit by hand). Notebook 01's "
        "full-mode windows (2000 stand-in clips, 48 frames, absolute root), x0 prediction, "
        "T = 100 cosine, AdamW, EMA 0.9999 with warm-up, constant lr; 5 % of the training "
        "clips held out for the validation loss (`gmd.models.validation_split`). Every "
        f"{check_every} steps the EMA weights draw {samples} unguided samples (seed 0; the "
        "text-conditioned model gets one caption each of as many test windows), measured "
        "against the registered `gmd_motion` gate; a configuration stops at its first pass, "
        "at its plateau (patience 5, 1 %) or at its share of the budget. One torch thread on "
        "2 cores shared with other jobs; seconds are CPU seconds of this process (not wall), "
        "excluding the gate measurements.",
        "",
        f"Data (the gate's reference, {samples} windows for the FID): foot skating "
        f"{reference['foot_skating']:.4f} m/s, joint jerk {reference['joint_jerk']:.1f} m/s³, "
        f"FID(train vs test) {reference['fid']:.3f}; allowed: {allowed}.",
        "",
        f"Budget {budget_minutes:g} CPU-minutes; used {total_seconds / 60:.1f} (training, "
        "sampling and measuring).",
        "",
        "## Per configuration",
        "",
        markdown_table(["config", "s/step", "steps run", "stopped by", "first pass at step",
                        "training minutes to pass"], summary),
        "",
        "## Every check",
        "",
        markdown_table(["config", "widths", "full-res width", "parameters", "batch", "lr",
                        "cond", "s/step", "step", "val loss", "foot skating m/s",
                        "joint jerk m/s³", "FID", "gate"], rows),
        "",
    ])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget-minutes", type=float, default=40.0)
    parser.add_argument("--wall-minutes", type=float, default=60.0,
                        help="also stop each configuration at its share of this wall time")
    parser.add_argument("--only", default="", help="comma-separated config names")
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--check-every", type=int, default=200)
    parser.add_argument("--cap", type=int, default=4000)
    parser.add_argument("--out", default="docs/pilot_gmd_motion.md")
    args = parser.parse_args()
    torch.set_num_threads(1)
    started, started_wall = time.process_time(), time.perf_counter()
    settings = x0eps.Settings.for_scale("paper")
    train = load_windows(settings.data())
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    evaluation = motion_evaluation(train, test, settings.evaluator_config(train.fingerprint),
                                   reference_samples=args.samples, seed=0)
    evaluator, test_embeddings = evaluation.evaluator, evaluation.test_embeddings
    reference = sample_quality(test.space("motion").joints(test.x), fid=evaluation.real_fid)
    chosen = [c for c in CONFIGS if not args.only or c.name in args.only.split(",")]
    cpu_share = (args.budget_minutes * 60 - (time.process_time() - started)) / len(chosen)
    wall_share = (args.wall_minutes * 60 - (time.perf_counter() - started_wall)) / len(chosen)
    outcomes = []
    for config in chosen:
        outcomes.append(run_config(config, train=train, test=test, evaluator=evaluator,
                                   test_embeddings=test_embeddings, reference=reference,
                                   samples=args.samples, check_every=args.check_every,
                                   cap=args.cap, cpu_seconds=cpu_share,
                                   wall_seconds=wall_share))
    total = time.process_time() - started
    text = report(outcomes, reference, samples=args.samples, check_every=args.check_every,
                  budget_minutes=args.budget_minutes, total_seconds=total)
    Path(args.out).write_text(text, encoding="utf-8")
    Path(args.out).with_suffix(".json").write_text(json.dumps(
        [{"config": o.config.__dict__, "seconds_per_step": o.seconds_per_step, "stop": o.stop,
          "checks": [c.__dict__ for c in o.checks]} for o in outcomes], indent=1),
        encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
