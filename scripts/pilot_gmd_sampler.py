"""Sampler and denoiser pilot of the GMD motion model (issue #14): where do the samples'
foot skating and joint jerk come from?

On notebook 01's full-mode windows (absolute root, 48 frames), with
``repro.gmd.denoiser_diagnostics``:

* ``--noise-floor``: the gate's skating and jerk of the test windows with white noise of σ
  (model units) added to every channel, to the root channels 0:4 only, or to the joint
  positions (ric) only: the per-frame precision a sample needs.
* otherwise a model (default: the design pilot's config C, 288 × (1, 0.5, 0.25), batch 32,
  lr 1e-3, x0, T = ``--diffusion-steps``) trained with the held-out validation of
  ``gmd.models.validation_split`` (patience never fires; ``--steps`` is the length), checked
  every ``--check-every`` steps: the gate's skating and jerk of 64 unguided samples (seed 0);
  the EMA weights' x̂0 error per feature block on 128 held-out windows at several t, beside
  the noise √(1 − ᾱ_t) that x_t holds; the skating and jerk of their x̂0 at t = 0 (what the
  sampler's last step returns when everything before it was right); the high-frequency share
  of samples, of x̂0 at t = 0 and of the data; with ``--fid`` the gate's FID too. Arms:
  ``--prediction epsilon``, ``--root-weight k²`` (loss weight on the root channels 0:4, GMD's
  loss scaling), ``--upsampling nearest`` (nearest ×2 + conv in place of the transposed
  convolutions), ``--diffusion-steps 1000`` (GMD's T), ``--batch``, ``--lr``.

One torch thread. Prints one JSON line per check and writes them to ``--out``.

    PYTHONPATH=src python scripts/pilot_gmd_sampler.py --noise-floor --out docs/x.jsonl
    PYTHONPATH=src python scripts/pilot_gmd_sampler.py --diffusion-steps 1000 --steps 2400 \
        --out build/pilot/T1000.jsonl
    PYTHONPATH=src python scripts/pilot_gmd_sampler.py --report --out docs/pilot_gmd_sampler.md
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import torch

from repro.core.gates import gate_results
from repro.core.tables import markdown_table
from repro.core.training import ValidationSet, train_diffusion
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.denoiser_diagnostics import (
    high_frequency_share,
    noise_floor,
    reconstruction,
    x0_error_by_block,
)
from repro.gmd.guidance import sample
from repro.gmd.measurements import motion_fid, sample_quality
from repro.gmd.model_gates import motion_evaluation
from repro.gmd.models import (
    GMDModelSpec,
    TrainedGMD,
    trajectory_loss_weights,
    validation_split,
)
from repro.gmd.windows import load_windows

#: white-noise levels (model units) of ``--noise-floor``
NOISE_SIGMAS = (0.0, 0.0015, 0.003, 0.0065, 0.0125, 0.025, 0.05)


def measure(joints: torch.Tensor) -> dict[str, float]:
    return sample_quality(joints, fid=None)


def nearest_upsampling(model: torch.nn.Module) -> torch.nn.Module:
    """Replace the UNet's transposed-convolution upsamplers (k = 4, stride 2) by nearest-
    neighbour ×2 followed by a k = 3 convolution (Odena et al. 2016's fix for checkerboard
    artifacts); the pilot's ``--upsampling nearest`` arm."""
    for k, up in enumerate(model.upsamplers):
        width = up.in_channels
        model.upsamplers[k] = torch.nn.Sequential(torch.nn.Upsample(scale_factor=2),
                                                  torch.nn.Conv1d(width, width, 3, padding=1))
    return model


def fid_measure(train: Any, test: Any, samples: int) -> Any:
    """A function (trained, samples) → {"fid", "fid_reference"}: the gate's FID of samples
    against the test windows (notebook 01's evaluator), and the reference, ``samples``
    training windows' own FID against them (as ``scripts/pilot_gmd_motion.py``)."""
    settings = x0eps.Settings.for_scale("paper")
    evaluation = motion_evaluation(
        train, test, settings.evaluator_config(train.fingerprint), reference_samples=samples,
        seed=0)

    def fid_of(trained: TrainedGMD, drawn: torch.Tensor) -> dict[str, float]:
        return {"fid": motion_fid(trained, drawn, evaluation.evaluator,
                                  evaluation.test_embeddings),
                "fid_reference": evaluation.real_fid}

    return fid_of


def final_check(spec: GMDModelSpec, train: Any, test: Any, weights: str, *,
                label: str, root_weight: float) -> list[dict[str, Any]]:
    """The gate's skating, jerk and FID of saved EMA weights: 256 unguided samples for each of
    seeds 1 and 2 (the checks during training used 64 of seed 0); FID on the first 64."""
    model = spec.build_model()
    model.load_state_dict(torch.load(weights))
    trained = TrainedGMD(model.eval(), spec.diffusion(), train.space("motion"), spec, None)
    fid_of = fid_measure(train, test, 64)
    rows = []
    for seed in (1, 2):
        with torch.no_grad():
            drawn = sample(trained, 256, seed=seed)
        rows.append({"kind": "final", "arm": label, "seed": seed, "samples": 256,
                     "root_weight": root_weight,
                     **measure(trained.space.joints(drawn)), **fid_of(trained, drawn[:64])})
    return rows


def write_lines(rows: list[dict[str, Any]], out: str, *, echo: bool = True) -> None:
    """The rows as JSON lines into ``out`` (and on stdout)."""
    text = "".join(json.dumps(r) + "\n" for r in rows)
    if echo:
        print(text, end="", flush=True)
    Path(out).write_text(text, "utf-8")


def _number(value: Any, digits: int = 3) -> str:
    return "—" if value is None else f"{value:.{digits}g}"


def _root_xz(blocks: dict[str, float]) -> float | None:
    """The root x/z block's value: positions (absolute root) or velocities (relative)."""
    return blocks.get("root_xz", blocks.get("root_linear_velocity"))


def _fid(results: dict[str, dict[str, Any]]) -> str:
    """The FID gate's value and its registered bound, from ``gate_results``."""
    return f"{results['fid']['value']:.2f} (≤ {results['fid']['at_most']:.2f})"


def _noise_table(rows: list[dict[str, Any]]) -> str:
    return markdown_table(["noise on", "σ (model units)", "foot skating m/s", "joint jerk m/s³"],
                          [[r["channels"], _number(r["sigma"], 2), r["foot_skating"],
                            _number(r["joint_jerk"])] for r in rows])


def report(noise_rows: list[dict[str, Any]], model_rows: list[dict[str, Any]],
           final_rows: list[dict[str, Any]], relative_rows: list[dict[str, Any]]) -> str:
    """docs/pilot_gmd_sampler.md from the JSON lines of ``--noise-floor``, of the model arms
    (each row labelled with its ``arm``) and of ``--weights`` (the final weights)."""
    reference = next(r for r in noise_rows if r["sigma"] == 0.0)
    bounds = gate_results("gmd_motion", {}, {**reference, "fid": 1.0})
    models = []
    for r in model_rows:
        errors = r["x0_rms_error"]
        t_half = str(r["diffusion_steps"] // 2)
        at_t0 = r.get("x0_at_t0", {})
        share = _root_xz(r.get("high_frequency_share", {}))
        share_t0 = _root_xz(r.get("high_frequency_share_x0_at_t0", {}))
        gate = fid = "—"
        if "fid" in r:
            results = gate_results("gmd_motion", r, {**reference, "fid": r["fid_reference"]})
            gate = "**pass**" if all(g["passed"] for g in results.values()) else "fail"
            fid = _fid(results)
        models.append([r["arm"], r["step"], _number(r["foot_skating"]),
                       _number(r["joint_jerk"]), fid, gate,
                       _number(at_t0.get("foot_skating")),
                       _number(at_t0.get("joint_jerk")), _number(_root_xz(errors["0"])),
                       _number(_root_xz(errors[t_half])), _number(errors["0"]["noise"]),
                       _number(share, 2), _number(share_t0, 2)])
    finals = []
    for r in final_rows:
        results = gate_results("gmd_motion", r, {**reference, "fid": r["fid_reference"]})
        finals.append([r["arm"], r["seed"], r["samples"], r["foot_skating"],
                       _number(r["joint_jerk"]), _fid(results),
                       ", ".join(f"{m} {'pass' if g['passed'] else '**fail**'}"
                                 for m, g in results.items())])
    data_share = next((r["high_frequency_share_data"]["root_xz"] for r in model_rows
                       if r.get("representation", "absolute") == "absolute"
                       if "high_frequency_share_data" in r), None)
    return "\n".join([
        "# Sampler and denoiser pilot: the GMD motion model (issue #14)",
        "",
        "Generated by `scripts/pilot_gmd_sampler.py --report` (do not edit by hand) from "
        "`docs/pilot_gmd_noise_floor.jsonl`, `docs/pilot_gmd_noise_floor_relative.jsonl`, "
        "`docs/pilot_gmd_sampler.jsonl` and `docs/pilot_gmd_sampler_final.jsonl`. Notebook 01's "
        "full-mode windows (2000 stand-in clips, 48 frames, absolute root unless an arm says "
        "relative); one torch thread "
        "per run on 2 cores shared by two runs.",
        "",
        "## The precision a sample needs (white noise on real test windows)",
        "",
        f"All {reference['windows']} test windows (the gate's reference); their own foot "
        f"skating {reference['foot_skating']:.3f} m/s and "
        f"joint jerk {reference['joint_jerk']:.0f} m/s³. The gate allows skating ≤ "
        f"{bounds['foot_skating']['at_most']:.3f} and jerk ≤ "
        f"{bounds['joint_jerk']['at_most']:.0f} (3× these). x_t still holds noise of σ = "
        "√(1 − ᾱ_0) = 0.025 at the last step of T = 100 cosine and 0.0064 at T = 1000.",
        "",
        _noise_table(noise_rows),
        "",
        "The same noise on the relative-root windows (HumanML3D's representation, notebook "
        "02's rel arm: root angular and x/z velocity, height), each channel block normalised "
        "as there:",
        "",
        _noise_table(relative_rows),
        "",
        "## Models (288 × (1, 0.5, 0.25), batch 32, lr 1e-3, T = 100 unless the arm says)",
        "",
        "Samples: 64 unguided samples (seed 0). x̂0 at t = 0: the model's x̂0 of 128 held-out "
        "validation windows noised to t = 0, what the sampler's last step returns when "
        "everything before it was right. "
        "Root x/z error: RMS of x̂0 − x0 on the root x/z channels (model units) at t = 0 and "
        "at T/2, beside the noise x_t holds at t = 0. FID (arms run with `--fid`): notebook "
        "01's evaluator, samples against the test windows, bound 5× 64 training windows' own "
        "FID; gate: all three of `gmd_motion`'s gates. The first two arms ran before the "
        "x̂0-at-t = 0 and high-frequency measurements were added (—). High-frequency share: "
        "power of the root x/z frame differences at ≥ 0.35 cycles/frame"
        + ("" if data_share is None else f" (the held-out data's own: {data_share:.3f})") + ".",
        "",
        markdown_table(["arm", "step", "samples: skating m/s", "samples: jerk m/s³",
                        "samples: FID", "gate", "x̂0 at t=0: skating", "x̂0 at t=0: jerk",
                        "root x/z error t=0",
                        "root x/z error T/2", "noise at t=0", "HF share samples",
                        "HF share x̂0 at t=0"], models),
        "",
        "## The last weights of the longer arms, measured again",
        "",
        "256 unguided samples for each of seeds 1 and 2 (the checks above drew 64 of seed 0); "
        "FID of the first 64 of them.",
        "",
        markdown_table(["arm", "seed", "samples", "foot skating m/s", "joint jerk m/s³", "FID",
                        "gates"], finals),
        "",
    ])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noise-floor", action="store_true")
    parser.add_argument("--representation", choices=("absolute", "relative"),
                        default="absolute", help="the windows' root")
    parser.add_argument("--report", action="store_true",
                        help="render docs/pilot_gmd_sampler.md from the JSON lines in docs/")
    parser.add_argument("--diffusion-steps", type=int, default=100)
    parser.add_argument("--steps", type=int, default=1200)
    parser.add_argument("--check-every", type=int, default=600)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--base", type=int, default=288)
    parser.add_argument("--mults", type=float, nargs="+", default=[1, 0.5, 0.25])
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--lr", type=float, default=1e-3)
    parser.add_argument("--upsampling", choices=("transposed", "nearest"),
                        default="transposed")
    parser.add_argument("--prediction", choices=("x0", "epsilon"), default="x0")
    parser.add_argument("--root-weight", type=float, default=1.0,
                        help="loss weight on the root channels 0:4 (GMD's loss scaling k²)")
    parser.add_argument("--fid", action="store_true",
                        help="also the gate's FID (trains or loads notebook 01's evaluator)")
    parser.add_argument("--weights", default="",
                        help="measure these saved EMA weights (of a --save) with 256 samples "
                             "for each of seeds 1 and 2, instead of training")
    parser.add_argument("--label", default="", help="the arm's name in --weights' rows")
    parser.add_argument("--save", default="", help="write the EMA weights here at each check")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    if args.report:
        docs = Path(__file__).resolve().parent.parent / "docs"
        rows = [[json.loads(line) for line in (docs / name).read_text("utf-8").splitlines()]
                for name in ("pilot_gmd_noise_floor.jsonl", "pilot_gmd_sampler.jsonl",
                             "pilot_gmd_sampler_final.jsonl",
                             "pilot_gmd_noise_floor_relative.jsonl")]
        Path(args.out).write_text(report(*rows), "utf-8")
        return
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_scale("paper")
    train = load_windows(settings.data(representation=args.representation))
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    lines: list[dict[str, Any]] = []
    if args.noise_floor:
        lines = [{"kind": "noise_floor", "representation": args.representation, **row}
                 for row in noise_floor(
            test.space("motion"), test.x, NOISE_SIGMAS,
            {"all": slice(0, 263), "root": slice(0, 4), "ric": slice(4, 67)}, measure)]
        write_lines(lines, args.out)
        return
    spec = GMDModelSpec(task="motion", prediction=args.prediction, data=train.config,
                        base_channels=args.base, channel_mults=tuple(args.mults),
                        diffusion_steps=args.diffusion_steps, train_steps=args.steps,
                        batch_size=args.batch, lr=args.lr, validate_every=args.check_every,
                        patience=1000,
                        feature_weights=None if args.root_weight == 1.0
                        else tuple(trajectory_loss_weights(math.sqrt(args.root_weight))))
    if args.weights:
        write_lines(final_check(spec, train, test, args.weights, label=args.label,
                                root_weight=args.root_weight), args.out)
        return
    fit, held = validation_split(train, spec.validation_fraction)
    validation = ValidationSet(train.x[held])
    diffusion = spec.diffusion()
    T = args.diffusion_steps
    timesteps = sorted({0, 1, 2, 5, T // 50, T // 10, T // 2, T - 1})
    fid_of = fid_measure(train, test, args.samples) if args.fid else None
    blocks = {"representation": args.representation}
    started = time.process_time()
    measuring = [0.0]

    def on_validation(step: int, loss: float, ema_model: torch.nn.Module) -> None:
        if step == 0:
            return
        t0 = time.process_time()
        trained = TrainedGMD(ema_model, diffusion, train.space("motion"), spec, None,
                             x0_bound=float(train.x.abs().max()))
        held_x = train.x[held][:128]
        errors = x0_error_by_block(ema_model, diffusion, held_x, timesteps,
                                   representation=args.representation)
        with torch.no_grad():
            drawn = sample(trained, args.samples, seed=0)
        values = measure(trained.space.joints(drawn))
        if fid_of is not None:
            values.update(fid_of(trained, drawn))
        rebuilt = reconstruction(ema_model, diffusion, held_x, 0)
        rebuilt_values = measure(trained.space.joints(rebuilt))
        measuring[0] += time.process_time() - t0
        lines.append({"kind": "model", "diffusion_steps": T, "base": args.base,
                      "mults": args.mults, "batch": args.batch, "lr": args.lr, "step": step,
                      "prediction": args.prediction, "upsampling": args.upsampling,
                      "root_weight": args.root_weight, "val_loss": loss, **values,
                      "x0_rms_error": errors,
                      "x0_at_t0": rebuilt_values,
                      "representation": args.representation,
                      "high_frequency_share": high_frequency_share(drawn, **blocks),
                      "high_frequency_share_data": high_frequency_share(held_x, **blocks),
                      "high_frequency_share_x0_at_t0": high_frequency_share(rebuilt, **blocks),
                      "train_cpu_s": time.process_time() - started - measuring[0],
                      "measure_cpu_s": measuring[0]})
        print(json.dumps(lines[-1]), flush=True)
        if args.save:
            torch.save(ema_model.state_dict(), args.save)
        write_lines(lines, args.out, echo=False)

    model = spec.build_model()
    if args.upsampling == "nearest":
        nearest_upsampling(model)
    train_diffusion(model, diffusion, train.x[fit].contiguous(),
                    spec.train_config(), validation=validation, on_validation=on_validation,
                    progress=False)


if __name__ == "__main__":
    main()
