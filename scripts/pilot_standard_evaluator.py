"""Pilot (docs/pilot_standard_evaluator.jsonl): the GMD evaluator's fitness gate (R@3 of held-out
windows; FID of trivial fakes over the real windows') on the standard scale's data, per design.

One thread: ``REPRO_BUILD_ROOT=/tmp/pilot python scripts/pilot_standard_evaluator.py``.
"""

from __future__ import annotations

import dataclasses
import json
import time

import torch

from repro.core import fitness
from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.windows import load_windows

#: the frame-differences rows of docs/pilot_standard_evaluator.jsonl came from an opt-in
#: ``EvaluatorConfig.frame_differences`` (commit e0df75c), removed when it did not pass
DESIGNS = [("default", {}), ("1500 steps", {"steps": 1500}), ("dim 32", {"dim": 32})]


def main() -> None:
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_scale("standard")
    data = settings.motion_data(None)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    base = settings.evaluator_config(train.fingerprint)
    for label, changes in DESIGNS:
        started = time.process_time()
        evaluation = model_gates.motion_evaluation(
            train, test, dataclasses.replace(base, **changes), reference_samples=128, seed=0)
        evaluator = evaluation.evaluator
        held_out = evaluator.embed_motions(evaluation.test_features,
                                           list(evaluation.test_lengths))
        fakes = fitness.trivial_fid_ratio(
            lambda w, e=evaluator: e.embed_motions(w, [w.shape[1]] * len(w)),
            evaluation.train_features, held_out, 128, seed=0,
            real_fid=evaluation.reference_fid)
        gate = model_gates.evaluator_gate_values(
            evaluator, evaluation.test_features, evaluation.test_lengths, test.captions,
            seed=0, train_features=evaluation.train_features, samples=128,
            real_fid=evaluation.reference_fid)
        print(json.dumps({"label": label, **changes, **gate, **fakes,
                          "cpu_s": round(time.process_time() - started, 1)}), flush=True)


if __name__ == "__main__":
    main()
