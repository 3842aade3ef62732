"""Pilot: do a GMD motion model's *samples* look like the stand-in data it learned?

Trains one motion model of notebook 01's standard spec (text-conditioned, relative root,
48 frames) with the design given on the command line, then measures, the same way on data
and samples (one torch thread, this machine):

- ``uncond``: 64 unguided samples (null condition) against 64 test windows: mean joint
  speed, mean horizontal root speed, joint jerk, foot skating;
- ``text``: one sample per caption of the same 64 test windows (classifier-free guidance at
  GMD's 2.5): the same four, and the concept oracles' recall of each window's labelled
  concepts, against the oracles' recall on the windows themselves.

One JSON line per (variant, checkpoint) goes to ``--out``::

    PYTHONPATH=src python scripts/pilot_motion_samples.py --width 64 --mults 1 1 \
        --steps 900 --every 300 --out pilots/gmd_motion_samples.jsonl
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from repro.core import metrics
from repro.gmd import measurements
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.guidance import sample, sample_classifier_free
from repro.gmd.models import TrainedGMD, load_or_train_gmd
from repro.gmd.windows import load_windows
from repro.motion.features import FPS, features_to_joints


def motion_stats(joints: np.ndarray) -> dict[str, float]:
    """``metrics.motion_statistics`` under the pilot's short names."""
    stats = metrics.motion_statistics(np.asarray(joints, dtype=np.float64), fps=FPS)
    return {"joint_speed": stats["joint_speed"], "root_speed": stats["root_speed"],
            "jerk": stats["joint_jerk"], "skating": stats["foot_skating"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--label", required=True)
    parser.add_argument("--width", type=int, default=64)
    parser.add_argument("--mults", type=float, nargs="+", default=[1.0, 1.0])
    parser.add_argument("--prediction", choices=("x0", "epsilon"), default="x0")
    parser.add_argument("--representation", choices=("relative", "absolute"),
                        default="relative")
    parser.add_argument("--steps", type=int, default=900)
    parser.add_argument("--every", type=int, default=300)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--lr", type=float, default=1e-3)
    parser.add_argument("--ema", type=float, default=0.9999)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--input-skip", action="store_true")
    parser.add_argument("--bf16", action="store_true")
    parser.add_argument("--schedule", choices=("cosine",), default=None)
    parser.add_argument("--root-weight", type=float, default=None,
                        help="loss weight of the root features 0:4 (the rest 1)")
    parser.add_argument("--caption-draw", choices=("mean", "one"), default="mean")
    parser.add_argument("--cfg", type=float, default=2.5)
    parser.add_argument("--n", type=int, default=64)
    parser.add_argument("--frames", type=int, default=48)
    parser.add_argument("--compositions", default=None,
                        help="a stand-in set of these compositions, e.g. single=1")
    parser.add_argument("--pool", nargs="+", default=None, help="the stand-in's concept pool")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--save-samples", type=Path, default=None,
                        help="a folder for each check's samples and the windows (.npz)")
    args = parser.parse_args()
    torch.set_num_threads(1)

    settings = x0eps.Settings.for_scale("standard")
    data = settings.data(None, representation=args.representation)
    weights = tuple((k, float(v)) for k, v in (
        item.split("=") for item in (args.compositions or "").split(",") if item))
    data = dataclasses.replace(data, stand_in_concepts=tuple(args.pool) if args.pool else None,
                               stand_in_compositions=weights or None)
    if args.frames != data.frames:
        data = dataclasses.replace(data, frames=args.frames, stride=args.frames // 2)
    spec = settings.spec("motion", args.prediction, data, seed=args.seed)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    relative_test = test
    if args.representation != "relative":
        rel = dataclasses.replace(data, representation="relative")
        rel_train = load_windows(rel)
        relative_test = load_windows(rel, "test", statistics=(rel_train.mean, rel_train.std))
    spec = spec.replace(
        base_channels=args.width, channel_mults=tuple(args.mults), steps=args.steps,
        batch_size=args.batch, lr=args.lr, validate_every=args.every, patience=10**6,
        autocast="bfloat16" if args.bf16 else None, input_skip=args.input_skip,
        ema_decay=args.ema, lr_schedule=args.schedule, caption_draw=args.caption_draw,
        feature_weights=None if args.root_weight is None else tuple(
            [args.root_weight] * 4 + [1.0] * 259))
    evaluation = measurements.evaluation_set(relative_test, args.n, seed=args.seed)
    data_joints = features_to_joints(evaluation.features.astype(np.float64))
    reference = motion_stats(data_joints)
    reference["recall"] = measurements.concept_recall(evaluation.features, evaluation.truth)
    started = time.perf_counter()
    diffusion = spec.diffusion()
    vocabulary = train.vocabulary

    spent = {"checks": 0.0}

    def check(step: int, loss: float, ema: torch.nn.Module) -> None:
        train_s = time.perf_counter() - started - spent["checks"]
        trained = TrainedGMD(copy.deepcopy(ema).eval().requires_grad_(False), diffusion,
                             train.space("motion"), spec, vocabulary)
        t0 = time.perf_counter()
        x = sample(trained, args.n, seed=args.seed)
        with torch.no_grad():
            uncond = motion_stats(trained.space.joints(x).double().numpy())
        x = sample_classifier_free(trained, args.n, seed=args.seed, text=evaluation.captions,
                                   scale=args.cfg)
        with torch.no_grad():
            features = trained.space.relative_features(x).numpy().astype(np.float32)
        text = motion_stats(features_to_joints(features.astype(np.float64)))
        text["recall"] = measurements.concept_recall(features, evaluation.truth)
        if args.save_samples is not None:
            args.save_samples.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(
                args.save_samples / f"{args.label}_step{step}.npz", text=features,
                uncond=trained.space.relative_features(
                    sample(trained, args.n, seed=args.seed)).numpy().astype(np.float32),
                data=evaluation.features, captions=np.array(evaluation.captions),
                truth=np.array([json.dumps(sorted(t)) for t in evaluation.truth]))
        sample_s = time.perf_counter() - t0
        spent["checks"] += time.perf_counter() - t0 + 0.0
        row = {"label": args.label, "step": step, "held_out_loss": loss,
               "train_cpu_s_so_far": round(train_s, 1), "sample_s": round(sample_s, 1),
               "width": args.width, "mults": args.mults, "prediction": args.prediction,
               "representation": args.representation, "input_skip": args.input_skip,
               "bf16": args.bf16, "schedule": args.schedule, "batch": args.batch, "lr": args.lr,
               "ema": args.ema, "root_weight": args.root_weight,
               "caption_draw": args.caption_draw,
               "compositions": args.compositions, "pool": args.pool,
               "frames": args.frames, "seed": args.seed, "cfg": args.cfg,
               "parameters": sum(p.numel() for p in ema.parameters()),
               "data": reference, "uncond": uncond, "text": text,
               "uncond_ratio": {k: round(uncond[k] / reference[k], 3) for k in uncond},
               "text_ratio": {k: round(text[k] / reference[k], 3) for k in text}}
        with args.out.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        print(json.dumps({k: row[k] for k in ("label", "step", "held_out_loss",
                                              "train_cpu_s_so_far", "uncond_ratio",
                                              "text_ratio")}), flush=True)

    load_or_train_gmd(spec, train, retrain=True, on_validation=check)


if __name__ == "__main__":
    main()
