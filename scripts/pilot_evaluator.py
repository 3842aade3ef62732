"""Pilot: GMD-B3's evaluator against its gate (R@3 of real windows, trivial-fake FID ratio)
on a stand-in set, at notebook 02's standard settings with a chosen number of steps.

    PYTHONPATH=src python scripts/pilot_evaluator.py --steps 500 --locomotion \
        --out pilots/gmd_evaluator_gate.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from repro.gmd import measurements, model_gates
from repro.gmd import root_representation as rr
from repro.gmd.windows import LOCOMOTION_COMPOSITIONS, LOCOMOTION_CONCEPTS, load_windows
from repro.models.evaluator import load_or_train_evaluator


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--locomotion", action="store_true",
                        help="the locomotion stand-in (windows.LOCOMOTION_CONCEPTS)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hidden", type=int, default=None, help="motion-encoder channels")
    parser.add_argument("--dim", type=int, default=None, help="embedding size")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = dataclasses.replace(rr.Settings.for_scale("standard"), evaluator_steps=args.steps)
    sizes = {k: v for k, v in (("hidden", args.hidden), ("dim", args.dim)) if v is not None}
    config = settings.evaluator_config().replace(**sizes)
    data = settings.data("relative")
    if args.locomotion:
        data = dataclasses.replace(data, stand_in_concepts=LOCOMOTION_CONCEPTS,
                                   stand_in_compositions=LOCOMOTION_COMPOSITIONS)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    started = time.perf_counter()
    with torch.no_grad():
        train_features = train.features().numpy()
    evaluator = load_or_train_evaluator(train_features, np.full(len(train), train.frames),
                                        train.captions, config)
    evaluation = measurements.evaluation_set(test, settings.evaluation_windows, seed=args.seed)
    real_row = measurements.ground_truth_row(evaluator, evaluation, train_features,
                                             seed=args.seed)
    b3 = rr.B3Evaluation(evaluator, train_features, evaluation, real_row)
    values = model_gates.evaluator_gate_values(
        b3.evaluator, evaluation.features, evaluation.lengths, evaluation.captions,
        seed=args.seed, train_features=b3.train_features, samples=len(evaluation))
    from repro.core import fitness
    with torch.no_grad():
        held = b3.evaluator.embed_motions(evaluation.features, list(evaluation.lengths))
    fakes = fitness.trivial_fid_ratio(
        lambda w: b3.evaluator.embed_motions(w, [w.shape[1]] * len(w)), b3.train_features, held,
        len(evaluation), seed=args.seed)
    row = {"steps": args.steps, "locomotion": args.locomotion, "seed": args.seed,
           "hidden": args.hidden, "dim": args.dim, "values": values, "fakes": fakes,
           "real_row": b3.real_row,
           "cpu_s": round(time.perf_counter() - started, 1)}
    with args.out.open("a") as handle:
        handle.write(json.dumps(row) + "\n")
    print(json.dumps(row))


if __name__ == "__main__":
    main()
