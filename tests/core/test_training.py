"""train_diffusion (AdamW + clip + EMA, seeded) and the config-hash cache (load_or_train)."""

from __future__ import annotations

import copy
import json
import math
import os

import pytest
import torch
from conftest import bimodal_mixture
from torch import nn

from repro.core import training
from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.core.train_config import WARMUP_SHARE, learning_rate_factor
from repro.core.training import (
    TrainConfig,
    TrainResult,
    _update_ema,
    ema_decay_at,
    make_adamw,
    train_diffusion,
    train_loop,
)
from repro.infra import cache
from repro.infra.cache import cached_artifact_dir, config_hash, load_or_train
from repro.models.unet import sinusoidal_embedding

torch.set_num_threads(1)


class TinyDenoiser(nn.Module):
    """An MLP on (B, C, T) flattened, with a sinusoidal timestep embedding."""

    def __init__(self, channels: int = 1, frames: int = 1, hidden: int = 64):
        super().__init__()
        self.shape = (channels, frames)
        self.net = nn.Sequential(nn.Linear(channels * frames + 16, hidden), nn.Mish(),
                                 nn.Linear(hidden, hidden), nn.Mish(),
                                 nn.Linear(hidden, channels * frames))

    def forward(self, x, t, cond=None, cond_mask=None):
        h = torch.cat([x.flatten(1), sinusoidal_embedding(t, 16)], dim=1)
        return self.net(h).reshape(x.shape)




# -- training ----------------------------------------------------------------------------------


@pytest.mark.parametrize("prediction", ["epsilon", "x0"])
def test_training_on_a_gaussian_mixture_learns_it(prediction):
    diffusion = GaussianDiffusion(cosine_betas(100), prediction)
    config = TrainConfig(steps=800, batch_size=256, lr=3e-3, ema_decay=0.99, seed=0,
                         num_threads=1)
    result = train_diffusion(TinyDenoiser, diffusion, bimodal_mixture(4096, 0), config)
    first, last = sum(result.losses[:20]) / 20, sum(result.losses[-50:]) / 50
    assert last < 0.7 * first
    with torch.no_grad():
        x = diffusion.p_sample_loop(result.ema_model, (2000, 1, 1), seed=1).flatten()
    assert x.mean().item() == pytest.approx(0.0, abs=0.15)
    assert x.std().item() == pytest.approx(math.sqrt(1 + 0.04), abs=0.15)
    near_minus = ((x + 1).abs() < 0.5).float().mean()
    near_plus = ((x - 1).abs() < 0.5).float().mean()
    assert near_minus > 0.3 and near_plus > 0.3 and near_minus + near_plus > 0.85   # two modes


def test_training_is_deterministic_given_the_seed():
    diffusion = GaussianDiffusion(cosine_betas(50), "epsilon")
    data = bimodal_mixture(64, 0)

    def run(seed: int) -> TrainResult:
        return train_diffusion(TinyDenoiser, diffusion, data,
                               TrainConfig(steps=5, batch_size=16, lr=1e-3, seed=seed))

    a, b, c = run(0), run(0), run(1)
    assert a.losses == b.losses
    assert a.losses != c.losses
    for pa, pb in zip(a.ema_model.parameters(), b.ema_model.parameters(), strict=True):
        assert torch.equal(pa, pb)


def test_ema_follows_the_documented_update():
    assert ema_decay_at(0, 0.9999) == pytest.approx(0.1)
    assert ema_decay_at(90, 0.9999) == pytest.approx(91 / 100)
    assert ema_decay_at(10**6, 0.9999) == 0.9999
    assert ema_decay_at(0, 0.9999, warmup=False) == 0.9999
    diffusion = GaussianDiffusion(cosine_betas(50), "x0")
    data = bimodal_mixture(32, 0)
    torch.manual_seed(3)
    initial = TinyDenoiser()
    config = TrainConfig(steps=1, batch_size=8, lr=1e-2, ema_decay=0.25, ema_warmup=False,
                         seed=3)
    result = train_diffusion(TinyDenoiser, diffusion, data, config)
    for p0, p1, pe in zip(initial.parameters(), result.model.parameters(),
                          result.ema_model.parameters(), strict=True):
        assert not torch.equal(p0, p1)
        torch.testing.assert_close(pe, 0.25 * p0 + 0.75 * p1)   # θ_ema = d·θ_ema + (1−d)·θ
    same = train_diffusion(TinyDenoiser, diffusion, data,
                           TrainConfig(steps=3, batch_size=8, ema_decay=0.0, seed=0))
    for p1, pe in zip(same.model.parameters(), same.ema_model.parameters(), strict=True):
        assert torch.equal(p1, pe)


class RecordingModel(nn.Module):
    def __init__(self):
        super().__init__()
        self.scale = nn.Parameter(torch.zeros(()))
        self.calls: list[dict] = []

    def forward(self, x, t, cond=None, cond_mask=None):
        self.calls.append({"cond": cond, "cond_mask": cond_mask, "batch": x.shape[0]})
        return self.scale * x


def test_condition_dropout_masks_and_data_loader_batches():
    diffusion = GaussianDiffusion(cosine_betas(20), "epsilon")
    data, cond = torch.randn(100, 2, 4), torch.randn(100, 3)
    model = RecordingModel()
    train_diffusion(model, diffusion, data, TrainConfig(steps=20, batch_size=50,
                                                        cond_dropout=0.3), cond=cond)
    kept = torch.cat([c["cond_mask"] for c in model.calls]).float().mean().item()
    assert 0.6 < kept < 0.8
    assert all(c["cond"].shape == (50, 3) for c in model.calls)
    model = RecordingModel()
    train_diffusion(model, diffusion, data, TrainConfig(steps=2, batch_size=50), cond=cond)
    assert all(c["cond_mask"] is None for c in model.calls)

    model = RecordingModel()
    loader = [{"x": data[:30], "mask": torch.ones(30, 4)}, data[30:40]]
    result = train_diffusion(model, diffusion, loader, TrainConfig(steps=5, batch_size=1))
    assert [c["batch"] for c in model.calls] == [30, 10, 30, 10, 30]
    assert len(result.losses) == 5
    with pytest.raises(ValueError, match="dicts with key 'x'"):
        train_diffusion(RecordingModel(), diffusion, [(data,)], TrainConfig(steps=1))
    with pytest.raises(ValueError, match="cond has 99 rows"):
        train_diffusion(RecordingModel(), diffusion, data, TrainConfig(steps=1), cond=cond[:99])
    with pytest.raises(ValueError, match="feature_weights must have shape"):
        train_diffusion(RecordingModel(), diffusion, data,
                        TrainConfig(steps=1, feature_weights=[1.0, 4.0, 1.0]))


def test_train_config_validation_and_hashable_fields(capsys):
    with pytest.raises(ValueError, match="ema_decay"):
        TrainConfig(ema_decay=1.0)
    with pytest.raises(ValueError, match="cond_dropout"):
        TrainConfig(cond_dropout=1.5)
    with pytest.raises(ValueError, match="steps and batch_size"):
        TrainConfig(steps=0)
    fields = TrainConfig(device="cuda", num_threads=2).to_config()
    assert "device" not in fields and "num_threads" not in fields
    assert config_hash(TrainConfig(device="cuda").to_config()) == config_hash(
        TrainConfig().to_config())
    # progress=True but stderr is not a terminal under pytest: no bar is drawn
    train_diffusion(RecordingModel(), GaussianDiffusion(cosine_betas(20)), torch.randn(8, 1, 4),
                    TrainConfig(steps=3, batch_size=4), progress=True)
    assert "training" not in capsys.readouterr().err


# -- speed levers --------------------------------------------------------------------------------


def _loop_reference(model: nn.Module, steps: int, lr: float) -> tuple[nn.Module, nn.Module]:
    """The plain per-parameter loops: for-loop AdamW, clip and EMA (lerp_ per parameter)."""
    ema = copy.deepcopy(model)
    optimizer = torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=0.01, foreach=False)
    x, t = torch.randn(16, 1, 1), torch.randint(0, 50, (16,))
    for _ in range(steps):
        loss = (model(x, t) - x).pow(2).mean()
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(model.parameters(), 1.0, foreach=False)
        optimizer.step()
        with torch.no_grad():
            for ema_param, param in zip(ema.parameters(), model.parameters(), strict=True):
                ema_param.lerp_(param, 0.1)
    return model, ema


def _package_levers(model: nn.Module, steps: int, lr: float,
                    fused: bool = False) -> tuple[nn.Module, nn.Module]:
    """The same steps through the package's AdamW, foreach clip and ``_update_ema``."""
    ema = copy.deepcopy(model)
    optimizer = make_adamw(model.parameters(), lr=lr, weight_decay=0.01, fused=fused)
    x, t = torch.randn(16, 1, 1), torch.randint(0, 50, (16,))
    for _ in range(steps):
        loss = (model(x, t) - x).pow(2).mean()
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(model.parameters(), 1.0, foreach=True)
        optimizer.step()
        _update_ema(ema, model, 0.9)
    return model, ema


def test_foreach_adamw_clip_and_ema_are_bitwise_the_per_parameter_loops():
    torch.manual_seed(0)
    start = TinyDenoiser()
    torch.manual_seed(1)
    reference = _loop_reference(copy.deepcopy(start), steps=6, lr=3e-2)
    torch.manual_seed(1)
    levers = _package_levers(copy.deepcopy(start), steps=6, lr=3e-2)
    for ref_module, lever_module in zip(reference, levers, strict=True):
        for a, b in zip(ref_module.parameters(), lever_module.parameters(), strict=True):
            assert torch.equal(a, b)
    assert not torch.equal(next(start.parameters()), next(levers[0].parameters()))


def test_fused_adamw_stays_within_float_noise_of_the_loop():
    torch.manual_seed(0)
    start = TinyDenoiser()
    torch.manual_seed(1)
    reference, _ = _loop_reference(copy.deepcopy(start), steps=6, lr=3e-2)
    torch.manual_seed(1)
    fused, _ = _package_levers(copy.deepcopy(start), steps=6, lr=3e-2, fused=True)
    for a, b in zip(reference.parameters(), fused.parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-5)


def test_opt_in_levers_enter_the_cache_key_only_when_set():
    default = TrainConfig().to_config()
    assert "autocast" not in default and "fused_adamw" not in default
    assert set(default) == {"steps", "batch_size", "lr", "weight_decay", "grad_clip",
                            "ema_decay", "ema_warmup", "seed", "feature_weights",
                            "cond_dropout"}
    bf16 = TrainConfig(autocast="bfloat16").to_config()
    fused = TrainConfig(fused_adamw=True).to_config()
    assert bf16["autocast"] == "bfloat16" and fused["fused_adamw"] is True
    hashes = {config_hash(c) for c in (default, bf16, fused)}
    assert len(hashes) == 3
    assert TrainConfig(autocast="bfloat16").autocast_dtype is torch.bfloat16
    assert TrainConfig().autocast_dtype is None
    with pytest.raises(ValueError, match="autocast must be one of"):
        TrainConfig(autocast="float16")
    cosine = TrainConfig(lr_schedule="cosine").to_config()
    assert cosine["lr_schedule"] == "cosine" and "lr_schedule" not in default
    assert config_hash(cosine) not in hashes
    with pytest.raises(ValueError, match="lr_schedule must be one of"):
        TrainConfig(lr_schedule="step")


def test_cosine_schedule_warms_up_then_decays_to_zero():
    steps = 200
    factors = [learning_rate_factor("cosine", k, steps) for k in range(steps)]
    warmup = math.ceil(WARMUP_SHARE * steps)
    assert factors[0] == pytest.approx(1 / warmup) and factors[warmup - 1] == pytest.approx(1.0)
    after = factors[warmup - 1:]
    assert all(a >= b for a, b in zip(after, after[1:], strict=False))
    assert factors[-1] < 1e-3
    assert all(learning_rate_factor(None, k, steps) == 1.0 for k in (0, 100, 199))


def test_cosine_schedule_sets_the_optimiser_learning_rate(monkeypatch):
    made = []

    def recording_adamw(*args, **kwargs):
        made.append(make_adamw(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(training, "make_adamw", recording_adamw)
    model, seen = nn.Linear(2, 1), []

    def loss_fn(batch):
        seen.append(made[0].param_groups[0]["lr"])
        return model(batch).pow(2).mean()

    steps = 40
    config = TrainConfig(steps=steps, batch_size=4, lr=1e-2, lr_schedule="cosine")
    train_loop(model, loss_fn, iter([torch.randn(4, 2)] * steps), config, ema=False)
    assert seen == pytest.approx([1e-2 * learning_rate_factor("cosine", k, steps)
                                  for k in range(steps)])


def test_bf16_autocast_training_tracks_fp32_losses():
    """bf16 matrix products, fp32 weights: the loss curve stays within a few per cent."""
    diffusion = GaussianDiffusion(cosine_betas(50), "epsilon")
    data = bimodal_mixture(512, 0)

    def run(autocast: str | None) -> TrainResult:
        return train_diffusion(TinyDenoiser, diffusion, data,
                               TrainConfig(steps=60, batch_size=128, lr=3e-3, seed=0,
                                           autocast=autocast))

    fp32, bf16 = run(None), run("bfloat16")
    assert all(math.isfinite(v) for v in bf16.losses)
    assert fp32.losses != bf16.losses                       # autocast did act
    assert all(p.dtype == torch.float32 for p in bf16.ema_model.parameters())
    mean_fp32, mean_bf16 = sum(fp32.losses[-20:]) / 20, sum(bf16.losses[-20:]) / 20
    assert mean_bf16 == pytest.approx(mean_fp32, rel=0.05)


# -- cache --------------------------------------------------------------------------------------


@pytest.fixture()
def cache_root(tmp_path, monkeypatch):
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_config_hash_is_canonical():
    a = {"lr": 0.001, "layers": (1, 2, 4), "name": "traj"}
    b = {"name": "traj", "layers": [1, 2, 4], "lr": 1e-3}
    assert config_hash(a) == config_hash(b)
    assert len(config_hash(a)) == 16 and int(config_hash(a), 16) >= 0
    assert config_hash({**a, "lr": 0.002}) != config_hash(a)
    assert config_hash({"x": 1}) != config_hash({"x": 1.5})
    with pytest.raises(ValueError):
        config_hash({"lr": float("nan")})
    with pytest.raises(ValueError, match="cannot be hashed"):
        config_hash({"model": object()})
    with pytest.raises(ValueError, match="must be a dict"):
        config_hash([1, 2])  # type: ignore[arg-type]


def test_cached_artifact_dir_writes_config(cache_root):
    config = {"steps": 10, "mults": (1, 2)}
    directory = cached_artifact_dir("toy", config)
    assert directory == cache_root / "toy" / config_hash(config)
    assert json.loads((directory / "config.json").read_text()) == {"steps": 10, "mults": [1, 2]}
    with pytest.raises(ValueError, match="simple folder name"):
        cached_artifact_dir("../escape", config)


def _counting_trainer(calls: list[int]):
    def train(model: nn.Module):
        calls.append(1)
        with torch.no_grad():
            for p in model.parameters():
                p.fill_(float(len(calls)))
        return model, {"losses": [1.0, 0.5]}
    return train


def test_load_or_train_loads_the_second_time_and_retrains_on_change(cache_root):
    calls: list[int] = []
    config = {"kind": "linear", "width": 3}

    def build() -> nn.Module:
        return nn.Linear(3, 3)

    first = load_or_train("toy", config, build, _counting_trainer(calls))
    second = load_or_train("toy", config, build, _counting_trainer(calls))
    assert len(calls) == 1
    assert not second.training
    for p1, p2 in zip(first.parameters(), second.parameters(), strict=True):
        assert torch.equal(p1, p2) and torch.all(p2 == 1.0)
    directory = cached_artifact_dir("toy", config)
    assert json.loads((directory / "metrics.json").read_text()) == {"losses": [1.0, 0.5]}

    load_or_train("toy", {**config, "width": 4}, build, _counting_trainer(calls))
    assert len(calls) == 2
    # a stored config that does not match (e.g. edited by hand) forces retraining too
    (directory / "config.json").write_text(json.dumps({"something": "else"}))
    third = load_or_train("toy", config, build, _counting_trainer(calls))
    assert len(calls) == 3 and torch.all(third.weight == 3.0)
    load_or_train("toy", config, build, _counting_trainer(calls), retrain=True)
    assert len(calls) == 4


def test_failed_save_leaves_no_partial_file(cache_root, monkeypatch):
    config = {"kind": "fails"}
    real_save = torch.save

    def broken_save(obj, handle, *args, **kwargs):
        handle.write(b"half a checkpoint")
        raise OSError("disk full")

    monkeypatch.setattr(cache.torch, "save", broken_save)
    calls: list[int] = []
    with pytest.raises(OSError, match="disk full"):
        load_or_train("toy", config, lambda: nn.Linear(2, 2), _counting_trainer(calls))
    directory = cache_root / "toy" / config_hash(config)
    assert not (directory / "model.pt").exists()
    assert [name for name in os.listdir(directory) if name.endswith(".tmp")] == []
    monkeypatch.setattr(cache.torch, "save", real_save)
    load_or_train("toy", config, lambda: nn.Linear(2, 2), _counting_trainer(calls))
    assert len(calls) == 2 and (directory / "model.pt").exists()


def test_train_diffusion_result_plugs_into_the_cache(cache_root):
    diffusion = GaussianDiffusion(cosine_betas(20), "epsilon")
    data = bimodal_mixture(32, 0)
    train_config = TrainConfig(steps=3, batch_size=8, seed=0)
    config = {"model": "tiny", "train": train_config.to_config(), "T": 20}

    def train(model: nn.Module):
        return train_diffusion(model, diffusion, data, train_config).for_cache()

    model = load_or_train("tiny_diffusion", config, TinyDenoiser, train)
    metrics = json.loads((cached_artifact_dir("tiny_diffusion", config) / "metrics.json")
                         .read_text())
    assert len(metrics["losses"]) == 3 and metrics["final_loss"] == metrics["losses"][-1]
    again = load_or_train("tiny_diffusion", config, TinyDenoiser,
                          lambda m: pytest.fail("should have loaded from the cache"))
    for p1, p2 in zip(model.parameters(), again.parameters(), strict=True):
        assert torch.equal(p1, p2)


def test_a_condition_with_alternatives_gives_one_of_them_per_example_and_batch():
    """With ``cond_choices``, cond (N, K, D): each batch holds, for every example, one of its K
    alternatives, drawn afresh per batch, so that over a run every alternative is seen."""
    diffusion = GaussianDiffusion(cosine_betas(20), "epsilon")
    data = torch.randn(4, 2, 4)
    cond = torch.arange(4 * 3, dtype=torch.float32).reshape(4, 3, 1).expand(4, 3, 2).clone()
    model = RecordingModel()
    train_diffusion(model, diffusion, data, TrainConfig(steps=30, batch_size=4), cond=cond,
                    cond_choices=True)
    seen = torch.cat([c["cond"] for c in model.calls])
    assert seen.shape == (120, 2) and torch.equal(seen[:, 0], seen[:, 1])
    assert set(seen[:, 0].long().tolist()) == set(range(12))
    assert all(sorted((c["cond"][:, 0].long() // 3).tolist()) == [0, 1, 2, 3]
               for c in model.calls)
    # without cond_choices a 3-D cond is one condition per example (token states), as it was
    model = RecordingModel()
    train_diffusion(model, diffusion, data, TrainConfig(steps=2, batch_size=4), cond=cond)
    assert all(c["cond"].shape == (4, 3, 2) for c in model.calls)
    with pytest.raises(ValueError, match="cond_choices"):
        train_diffusion(RecordingModel(), diffusion, data, TrainConfig(steps=1),
                        cond=cond[:, 0], cond_choices=True)
