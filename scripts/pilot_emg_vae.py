"""Pilot (issue #16, EMG-7): what it costs on one thread to train the pipeline's motion VAE
to its gate (reconstruction MPJPE <= 5 cm, concept preservation >= 0.9x the real clips').

Full-mode data (``pipeline_config("paper")``), the VAE of ``pipeline.vae_kwargs`` with the
full-mode batch and lr, trained in chunks of ``--chunk`` steps; after each chunk the gate
values on ``--clips`` validation clips (drawn as training clips, keys disjoint from
training and test) and the validation loss. Stops at the gate, at ``--minutes`` of training
CPU time (one thread, so CPU seconds are what the training costs on a core of its own) or at
``--wall-minutes``.
Writes one JSON line per evaluation to stdout.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np
import torch

from repro.energymogen.config import pipeline_config
from repro.energymogen.data import load_or_build_data, load_or_build_validation_clips
from repro.energymogen.harness import oracle_accuracy
from repro.energymogen.latent_count import mpjpe
from repro.energymogen.pipeline import vae_kwargs
from repro.models.vae import MotionVAE, vae_validation_loss
from repro.motion.features import features_to_joints


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--latent-count", type=int, default=5)
    parser.add_argument("--chunk", type=int, default=500)
    parser.add_argument("--minutes", type=float, default=20.0)
    parser.add_argument("--clips", type=int, default=128)
    parser.add_argument("--wall-minutes", type=float, default=35.0)
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = replace(pipeline_config("paper"), latent_count=args.latent_count)
    data = load_or_build_data(config)
    val = load_or_build_validation_clips(config, args.clips)
    train_x = data.normalise(data.train_features)
    val_x = torch.from_numpy(data.normalise(val.features))
    batch_lengths = torch.full((config.vae_batch,), data.frames)
    val_lengths = torch.full((len(val_x),), data.frames)
    with torch.no_grad():
        real = oracle_accuracy(features_to_joints(torch.from_numpy(val.features)).numpy(),
                               val.concepts)
    torch.manual_seed(0)
    vae = MotionVAE(**vae_kwargs(config))
    steps, spent, wall_start = 0, 0.0, time.perf_counter()
    # the loop of ``models.vae.train_vae`` (AdamW, clip 1.0, a permutation per epoch and the
    # reparameterisation noise from one generator), run in chunks so the gate can be measured
    optimizer = torch.optim.AdamW(vae.parameters(), lr=config.vae_lr, weight_decay=0.01)
    generator = torch.Generator().manual_seed(0)
    x = torch.from_numpy(train_x)
    order = torch.empty(0, dtype=torch.long)
    while spent < args.minutes * 60 and time.perf_counter() - wall_start < args.wall_minutes * 60:
        start = time.process_time()        # CPU seconds of this one-thread process
        vae.train()
        for _ in range(args.chunk):
            while order.numel() < config.vae_batch:
                order = torch.cat([order, torch.randperm(len(x), generator=generator)])
            index, order = order[:config.vae_batch], order[config.vae_batch:]
            out = vae.loss(x[index], batch_lengths, kl_weight=1e-4,
                           generator=generator)
            optimizer.zero_grad(set_to_none=True)
            out["loss"].backward()
            torch.nn.utils.clip_grad_norm_(vae.parameters(), 1.0)
            optimizer.step()
        steps += args.chunk
        spent += time.process_time() - start
        vae.eval()
        with torch.no_grad():
            mu, _ = vae.encode(val_x, val_lengths)
            recon = vae.decode(mu, val_lengths, data.frames).numpy() * data.std + data.mean
            value = mpjpe(recon, val.features)
            joints = features_to_joints(torch.from_numpy(recon.astype(np.float32))).numpy()
            keep = oracle_accuracy(joints, val.concepts)
        loss = vae_validation_loss(vae, val_x, val_lengths, kl_weight=1e-4, batch_size=32,
                                   noise_seed=7919)
        print(json.dumps({"N": args.latent_count, "steps": steps, "train_cpu_seconds": spent,
                          "wall_seconds": time.perf_counter() - wall_start,
                          "val_loss": loss, "mpjpe": value, "concept_preservation": keep,
                          "real_recall": real}), flush=True)
        if value <= 0.05 and keep >= 0.9 * real:
            break


if __name__ == "__main__":
    main()
