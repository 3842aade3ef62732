"""Pilot: what does the EnergyMoGen VAE need for its reconstructions to pass gates version 4
(joint jerk ≤ 2×, foot skating ≤ 3× the held-out clips' own; concept recall ≥ 0.9×)?

The standard scale's VAE (``pipeline_config("standard")``: width 64, N = 5, batch 32,
KL 1e-4, its lr) on its training clips, with ``--width``, ``--layers``, ``--lr``, ``--kl``,
``--latent-dim``, ``--latent-count``, ``--steps``, ``--architecture``
(``models.vae.ARCHITECTURES``; default the transformer) and ``--foot-velocity`` (λ of
``models.vae.FootVelocityLoss``; default 0) set, checked every ``--every`` steps on notebook
07's held-out test clips: the gate values of ``model_gates.vae_gate_values`` /
``vae_sample_values``, MPJPE, and the training CPU seconds (``time.process_time``, one
thread). The loop is ``train_vae``'s (``models.vae``), run step by step here so it can be
checked on the way. One JSON line per check goes to ``--out``::

    PYTHONPATH=src python scripts/pilot_emg_vae_samples.py --width 64 --steps 3600 \\
        --every 900 --out pilots/emg_vae_samples.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from repro.core import metrics
from repro.energymogen.data import load_or_build_data
from repro.energymogen.harness import load_or_build_text_to_motion_test, oracle_accuracy
from repro.energymogen.latent_count.emg7 import LatentCountSettings, mpjpe
from repro.energymogen.pipeline import train_seed_for, vae_kwargs, vae_train_config
from repro.energymogen.settings import pipeline_config
from repro.models.vae import MotionVAE
from repro.motion.features import features_to_joints


def joints(features: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        return features_to_joints(torch.from_numpy(np.asarray(features, np.float32))).numpy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--label", required=True)
    parser.add_argument("--width", type=int, default=64)
    parser.add_argument("--layers", type=int, default=None)
    parser.add_argument("--lr", type=float, default=None)
    parser.add_argument("--kl", type=float, default=1e-4, help="KL weight (MLD's 1e-4)")
    parser.add_argument("--latent-dim", type=int, default=None,
                        help="d of each latent token (the standard pipeline's: 32)")
    parser.add_argument("--architecture", default="transformer")
    parser.add_argument("--foot-velocity", type=float, default=0.0,
                        help="λ of the foot-velocity term (0: none)")
    parser.add_argument("--latent-count", type=int, default=None)
    parser.add_argument("--steps", type=int, default=3600)
    parser.add_argument("--every", type=int, default=900)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--on-train", action="store_true",
                        help="check on as many training clips instead (does it generalise?)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = replace(pipeline_config("standard"), vae_width=args.width,
                     vae_architecture=args.architecture)
    if args.latent_count is not None:
        config = replace(config, latent_count=args.latent_count)
    if args.layers is not None:
        config = replace(config, vae_layers=args.layers)
    if args.latent_dim is not None:
        config = replace(config, latent_dim=args.latent_dim)
    train_config = vae_train_config(config, train_seed_for(config, args.seed), threads=1)
    if args.lr is not None:
        train_config = replace(train_config, lr=args.lr)
    train_config = replace(train_config, kl_weight=args.kl,
                           foot_velocity_weight=args.foot_velocity)
    data = load_or_build_data(config)
    foot_velocity = train_config.foot_velocity((data.mean, data.std))
    test = load_or_build_text_to_motion_test(config,
                                             LatentCountSettings.for_scale("standard").test_clips)
    if args.on_train:
        test = replace(test, features=data.train_features[:len(test.features)],
                       concepts=data.train_concepts[:len(test.features)])
    real = joints(test.features)
    real_stats = metrics.motion_statistics(real)
    real_recall = oracle_accuracy(real, test.concepts)
    torch.manual_seed(train_config.seed)
    vae = MotionVAE(**vae_kwargs(config))
    x = torch.from_numpy(data.normalise(data.train_features))
    batch_lengths = torch.full((train_config.batch_size,), data.frames)
    generator = torch.Generator().manual_seed(train_config.seed)
    optimizer = torch.optim.AdamW(vae.parameters(), lr=train_config.lr,
                                  weight_decay=train_config.weight_decay)
    order = torch.empty(0, dtype=torch.long)
    spent = 0.0
    vae.train()
    for step in range(1, args.steps + 1):
        start = time.process_time()
        while order.numel() < train_config.batch_size:
            order = torch.cat([order, torch.randperm(len(x), generator=generator)])
        index, order = order[:train_config.batch_size], order[train_config.batch_size:]
        out = vae.loss(x[index], batch_lengths, kl_weight=train_config.kl_weight,
                       generator=generator, foot_velocity=foot_velocity)
        optimizer.zero_grad(set_to_none=True)
        out["loss"].backward()
        if train_config.grad_clip is not None:
            torch.nn.utils.clip_grad_norm_(vae.parameters(), train_config.grad_clip)
        optimizer.step()
        spent += time.process_time() - start
        if step % args.every == 0 or step == args.steps:
            vae.eval()
            with torch.no_grad():
                xt = torch.from_numpy(data.normalise(test.features))
                lengths = [data.frames] * len(xt)
                mu, _ = vae.encode(xt, lengths)
                recon = vae.decode(mu, lengths, data.frames).numpy() * data.std + data.mean
            vae.train()
            rj = joints(recon)
            stats = metrics.motion_statistics(rj)
            row = {"label": args.label, "width": args.width, "layers": config.vae_layers,
                   "architecture": config.vae_architecture, "latent_count": config.latent_count,
                   "foot_velocity": train_config.foot_velocity_weight,
                   "latent_dim": config.latent_dim,
                   "lr": train_config.lr, "kl": train_config.kl_weight, "seed": args.seed,
                   "step": step, "clips": "train" if args.on_train else "test",
                   "train_cpu_s": round(spent, 1), "mpjpe": mpjpe(recon, test.features),
                   "concept_preservation": oracle_accuracy(rj, test.concepts) / real_recall,
                   **{f"{k}_ratio": stats[k] / real_stats[k] for k in stats},
                   "foot_skating_ratio_gmd": stats["foot_skating_ratio"],
                   "data": real_stats}
            print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v)
                              for k, v in row.items() if k != "data"}), flush=True)
            with args.out.open("a") as handle:
                handle.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
