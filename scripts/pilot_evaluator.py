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

import torch

from repro.gmd import model_gates
from repro.gmd import root_representation as rr
from repro.gmd.windows import LOCOMOTION_COMPOSITIONS, LOCOMOTION_CONCEPTS, load_windows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--locomotion", action="store_true",
                        help="the locomotion stand-in (windows.LOCOMOTION_CONCEPTS)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = dataclasses.replace(rr.Settings.for_scale("standard"), evaluator_steps=args.steps)
    data = settings.data("relative")
    if args.locomotion:
        data = dataclasses.replace(data, stand_in_concepts=LOCOMOTION_CONCEPTS,
                                   stand_in_compositions=LOCOMOTION_COMPOSITIONS)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    started = time.perf_counter()
    b3 = rr.b3_evaluation({"train": train, "test": test}, settings, seed=args.seed)
    evaluation = b3.evaluation
    values = model_gates.evaluator_gate_values(
        b3.evaluator, evaluation.features, evaluation.lengths, evaluation.captions,
        seed=args.seed, train_features=b3.train_features, samples=len(evaluation))
    row = {"steps": args.steps, "locomotion": args.locomotion, "seed": args.seed,
           "values": values, "real_row": b3.real_row,
           "cpu_s": round(time.perf_counter() - started, 1)}
    with args.out.open("a") as handle:
        handle.write(json.dumps(row) + "\n")
    print(json.dumps(row))


if __name__ == "__main__":
    main()
