"""Pilot for the standard scale (issue #32, docs/COMPUTE.md §4 item 3): does the EnergyMoGen
motion VAE pass its fitness gate (gates version 3, family ``vae``: the oracles' concept recall
on reconstructions of held-out clips ≥ 0.9× their recall on the clips themselves) within
~1000 steps, and what does a step cost here?

The full-mode pipeline's VAE (``pipeline_config("paper")``, ``pipeline.vae_kwargs``,
``pipeline.vae_train_config`` for evaluation seed ``--seed``: batch 32, AdamW lr 1e-3, KL 1e-4,
clip 1.0), trained by ``models.vae.train_vae``'s loop (the same generator draws the batches and
the reparameterisation noise) for a fixed ``--steps`` (no plateau stop), one torch thread,
fp32. Every ``--every`` steps: the gate value as ``model_gates.vae_gate_values`` measures it
(decode(μ(x)) of the ``--test-clips`` held-out text-to-motion test clips, the notebooks'
``gate_test_clips``) against the bound 0.9 × the real clips' recall, the held-out
reconstruction loss (``vae_validation_loss`` on the plan's 128 validation clips, the training
loop's validation hook), MPJPE (no longer a gate, for the record) and the training CPU seconds
(``time.process_time``: the machine was shared, wall time is not a speed). ``--width`` runs the
same design at other widths (e.g. 32, half). One JSON line per check goes to ``--out``
(appended, so a stopped run keeps its rows); the rows of docs/pilot_standard_vae.jsonl::

    PYTHONPATH=src python scripts/pilot_standard_vae.py --width 64 32 --steps 1200 \
        --every 150 --out docs/pilot_standard_vae.jsonl
    PYTHONPATH=src python scripts/pilot_standard_vae.py --width 64 --seed 1 --steps 1200 \
        --every 150 --out docs/pilot_standard_vae.jsonl
    PYTHONPATH=src python scripts/pilot_standard_vae.py --width 32 --steps 1800 --every 150 \
        --check-from 1350 --out docs/pilot_standard_vae.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from repro.core.gates import GATES, GATES_VERSION
from repro.core.training import VALIDATION_SEED_OFFSET
from repro.energymogen.config import PipelineConfig, pipeline_config
from repro.energymogen.convergence import TrainingPlan
from repro.energymogen.data import StandInData, load_or_build_data, load_or_build_validation_clips
from repro.energymogen.harness import (
    TextToMotionTest,
    load_or_build_text_to_motion_test,
    oracle_accuracy,
)
from repro.energymogen.latent_count import mpjpe
from repro.energymogen.pipeline import train_seed_for, vae_kwargs, vae_train_config
from repro.models.vae import MotionVAE, vae_validation_loss
from repro.motion.features import features_to_joints


def joints(features: np.ndarray) -> np.ndarray:
    """Joint positions (B, T, 22, 3) of unnormalised features (``pipeline.joints``)."""
    with torch.no_grad():
        return features_to_joints(torch.from_numpy(np.asarray(features, np.float32))).numpy()


@torch.no_grad()
def check(vae: MotionVAE, data: StandInData, test: TextToMotionTest, val_x: torch.Tensor,
          config: PipelineConfig, seed: int, kl_weight: float) -> dict[str, float]:
    """Gate value (concept recall of decode(μ(x)) on the test clips), MPJPE and held-out loss."""
    vae.eval()
    x = torch.from_numpy(data.normalise(test.features))
    lengths = [data.frames] * len(x)
    mu, _ = vae.encode(x, lengths)
    recon = vae.decode(mu, lengths, data.frames).numpy() * data.std + data.mean
    loss = vae_validation_loss(vae, val_x, torch.full((len(val_x),), data.frames),
                               kl_weight=kl_weight, batch_size=config.vae_batch,
                               noise_seed=seed + VALIDATION_SEED_OFFSET)
    vae.train()
    return {"concept_preservation": oracle_accuracy(joints(recon), test.concepts),
            "mpjpe": mpjpe(recon, test.features), "heldout_loss": loss}


def run(width: int, args: argparse.Namespace) -> None:
    """Train the full-mode VAE at ``width`` to ``args.steps``, appending a row per check."""
    config = replace(pipeline_config("paper"), vae_width=width)
    train_config = vae_train_config(config, train_seed_for(config, args.seed), threads=1)
    plan = TrainingPlan.for_scale("paper")
    data = load_or_build_data(config)
    test = load_or_build_text_to_motion_test(config, args.test_clips)
    val = load_or_build_validation_clips(config, plan.validation_clips)
    val_x = torch.from_numpy(data.normalise(val.features))
    real = oracle_accuracy(joints(test.features), test.concepts)
    bound = GATES["vae"][0].at_least * real
    torch.manual_seed(train_config.seed)
    vae = MotionVAE(**vae_kwargs(config))
    params = sum(p.numel() for p in vae.parameters())
    # ``train_vae``'s loop, checked every ``args.every`` steps without its plateau stop
    x = torch.from_numpy(data.normalise(data.train_features))
    batch_lengths = torch.full((train_config.batch_size,), data.frames)
    generator = torch.Generator().manual_seed(train_config.seed)
    optimizer = torch.optim.AdamW(vae.parameters(), lr=train_config.lr,
                                  weight_decay=train_config.weight_decay)
    order = torch.empty(0, dtype=torch.long)
    spent, wall = 0.0, time.perf_counter()
    vae.train()
    for step in range(1, args.steps + 1):
        start = time.process_time()
        while order.numel() < train_config.batch_size:
            order = torch.cat([order, torch.randperm(len(x), generator=generator)])
        index, order = order[:train_config.batch_size], order[train_config.batch_size:]
        out = vae.loss(x[index], batch_lengths, kl_weight=train_config.kl_weight,
                       generator=generator)
        optimizer.zero_grad(set_to_none=True)
        out["loss"].backward()
        if train_config.grad_clip is not None:
            torch.nn.utils.clip_grad_norm_(vae.parameters(), train_config.grad_clip)
        optimizer.step()
        spent += time.process_time() - start
        if step >= args.check_from and (step % args.every == 0 or step == args.steps):
            values = check(vae, data, test, val_x, config, train_config.seed,
                           train_config.kl_weight)
            row = {"pilot": "standard_vae", "gates_version": GATES_VERSION, "width": width,
                   "layers": config.vae_layers, "latent_count": config.latent_count,
                   "params": params, "batch": train_config.batch_size, "lr": train_config.lr,
                   "seed": args.seed, "train_seed": train_config.seed, "steps": step,
                   "test_clips": len(test), "real_recall": real, "bound": bound,
                   **values, "passes": values["concept_preservation"] >= bound,
                   "train_cpu_seconds": spent, "cpu_ms_per_step": 1000 * spent / step,
                   "wall_seconds": time.perf_counter() - wall, "threads": 1,
                   "dtype": "float32"}
            print(json.dumps(row), flush=True)
            with args.out.open("a") as handle:
                handle.write(json.dumps(row) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, nargs="+", default=[64])
    parser.add_argument("--steps", type=int, default=1200)
    parser.add_argument("--every", type=int, default=150)
    parser.add_argument("--seed", type=int, default=0,
                        help="evaluation seed (training seed ``pipeline.train_seed_for``)")
    parser.add_argument("--check-from", type=int, default=0,
                        help="check only from this step on (to extend a run already recorded)")
    parser.add_argument("--test-clips", type=int, default=256)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    for width in args.width:
        run(width, args)


if __name__ == "__main__":
    main()
