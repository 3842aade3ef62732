"""Pilot: GMD-B3's evaluator against its gate (R@3 of real windows, trivial-fake FID ratio)
on a stand-in set, at notebook 02's standard settings with a chosen number of steps.

``--encoder gru`` swaps the package's motion encoder (two convolutions, mean and max pooling)
for one that reads frame order (two convolutions, then a bidirectional GRU's last states),
to ask whether the shuffled-frames fake is missed for want of order in the encoder.

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
import torch.nn.functional as F
from torch import nn

from repro.gmd import measurements, model_gates
from repro.gmd import root_representation as rr
from repro.gmd.windows import LOCOMOTION_COMPOSITIONS, LOCOMOTION_CONCEPTS, load_windows
from repro.models import evaluator as evaluator_module
from repro.models.evaluator import load_or_train_evaluator


class GRUMotionEncoder(nn.Module):
    """(B, T, F) features + frame mask (B, T) → (B, D): convolutions, then a bidirectional
    GRU over the valid frames; its two last states map to the embedding."""

    def __init__(self, in_dim: int, hidden: int, dim: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv1d(in_dim, hidden, 5, padding=2)
        self.conv2 = nn.Conv1d(hidden, hidden, 5, padding=2)
        self.gru = nn.GRU(hidden, hidden, batch_first=True, bidirectional=True)
        self.out = nn.Linear(2 * hidden, dim)

    def forward(self, x: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        valid = mask[:, None, :]
        h = F.gelu(self.conv1(x.transpose(1, 2) * valid)) * valid
        h = F.gelu(self.conv2(h)) * valid
        packed = nn.utils.rnn.pack_padded_sequence(h.transpose(1, 2), mask.sum(1).cpu(),
                                                   batch_first=True, enforce_sorted=False)
        _, last = self.gru(packed)
        return self.out(torch.cat([last[0], last[1]], dim=-1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--locomotion", action="store_true",
                        help="the locomotion stand-in (windows.LOCOMOTION_CONCEPTS)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hidden", type=int, default=None, help="motion-encoder channels")
    parser.add_argument("--dim", type=int, default=None, help="embedding size")
    parser.add_argument("--encoder", choices=("package", "gru"), default="package")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = dataclasses.replace(rr.Settings.for_scale("standard"), evaluator_steps=args.steps)
    sizes = {k: v for k, v in (("hidden", args.hidden), ("dim", args.dim)) if v is not None}
    config = settings.evaluator_config().replace(**sizes)
    if args.encoder == "gru":   # its own cache key, and the encoder swapped in
        config = config.replace(data_id="pilot-gru")
        evaluator_module.MotionEncoder = GRUMotionEncoder
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
    b3 = rr.b3.B3Evaluation(evaluator, train_features, evaluation, real_row)
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
           "hidden": args.hidden, "dim": args.dim, "encoder": args.encoder, "values": values,
           "fakes": fakes, "real_row": b3.real_row,
           "cpu_s": round(time.perf_counter() - started, 1)}
    with args.out.open("a") as handle:
        handle.write(json.dumps(row) + "\n")
    print(json.dumps(row))


if __name__ == "__main__":
    main()
