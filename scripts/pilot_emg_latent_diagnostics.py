"""Pilot diagnostic: is it the decoder or the samples that slide? (pilots/pilot_emg_vae_gait.md §5)

On the standard scale's reference pipeline of seed 0 and notebook 07's held-out test clips,
decodes and reads (oracle recall, foot skating, jerk, root speed) latents that differ from
the test clips' in known ways:

- the test latents projected onto their top k principal directions (k = 8 … 160), and with
  isotropic noise of σ per scaled coordinate: how sensitive the decoder is;
- a Gaussian fitted to the training latents, and the midpoint of two test latents: what an
  average of latents decodes to;
- the denoiser's samples for the test captions at guidance 1 and at the pipeline's scale.

    PYTHONPATH=src python scripts/pilot_emg_latent_diagnostics.py

The numbers in §5 came from its first form at 325f1ae (registry version 11's design): the same
readings, the isotropic noise drawn in another order.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from repro.core import fitness, metrics
from repro.energymogen.energy_contour_maps import EnergyViewSettings
from repro.energymogen.harness import load_or_build_text_to_motion_test, oracle_accuracy
from repro.energymogen.latent_count.emg7 import LatentCountSettings
from repro.energymogen.pipeline import Sampler, load_pipeline
from repro.energymogen.settings import pipeline_config


def main() -> None:
    torch.set_num_threads(1)
    config = pipeline_config("standard")
    pipe = load_pipeline(config, "cpu", plan=EnergyViewSettings.for_scale("standard").plan)
    test = load_or_build_text_to_motion_test(
        config, LatentCountSettings.for_scale("standard").test_clips, data=pipe.data)

    def read(label: str, latents: torch.Tensor) -> None:
        joints = pipe.joints(pipe.decode(latents))
        stats = metrics.motion_statistics(joints)
        print(f"{label:40s} recall {oracle_accuracy(joints, test.concepts):.3f} skating "
              f"{stats['foot_skating']:.4f} jerk {stats['joint_jerk']:.1f} root speed "
              f"{stats['root_speed']:.3f}", flush=True)

    z = pipe.encode_motion(test.features)
    flat = z.flatten(1).double()
    train = pipe.encode_motion(pipe.data.train_features).flatten(1).double()
    centre = train.mean(0)
    values, vectors = torch.linalg.eigh(torch.cov((train - centre).T))
    values, vectors = values.flip(0), vectors.flip(1)
    share = torch.cumsum(values, 0) / values.sum()
    print("principal directions for 90 / 95 / 99 / 99.9 % of the variance:",
          [int((share < q).sum()) + 1 for q in (0.9, 0.95, 0.99, 0.999)])
    read("test latents", z)
    for k in (8, 14, 20, 30, 40, 60, 100):
        basis = vectors[:, :k]
        projected = centre + ((flat - centre) @ basis) @ basis.T
        read(f"top {k} directions", projected.float().view_as(z))
    generator = torch.Generator().manual_seed(0)
    for sigma in (0.05, 0.1, 0.2, 0.4):
        read(f"isotropic noise {sigma}", z + sigma * torch.randn(z.shape, generator=generator))
    mean, cov = fitness.gaussian_fit(train.numpy())
    rng = np.random.default_rng(0)
    gaussian = rng.multivariate_normal(mean, cov, size=len(z), method="eigh")
    read("Gaussian of the training latents", torch.from_numpy(gaussian).float().view_as(z))
    read("midpoint of two test latents", 0.5 * (z + z[torch.from_numpy(rng.permutation(len(z)))]))
    texts = test.texts(0)
    for scale in (1.0, config.guidance_scale):
        guided = replace(pipe, config=replace(pipe.config, guidance_scale=scale))
        read(f"denoiser samples, guidance {scale}",
             guided.sample(Sampler("single"), [], texts, 0, batch=len(texts)))


if __name__ == "__main__":
    main()
