"""The CPU label every measured time carries."""

from __future__ import annotations

from pathlib import Path

from repro.infra import cache
from repro.infra.machine import cpu_label

_INTEL = ("processor\t: 0\nmodel name\t: Intel(R) Xeon(R) Processor @ 2.80GHz\n"
          "flags\t\t: fpu avx512f {extra}\n\nprocessor\t: 1\nmodel name\t: Intel(R) Xeon(R) "
          "Processor @ 2.80GHz\nflags\t\t: fpu avx512f {extra}\n")


def test_cpu_label_tells_the_three_cpus_apart() -> None:
    assert cpu_label(_INTEL.format(extra="avx512_bf16 amx_bf16 amx_tile")) == (
        "Intel Xeon Processor @ 2.80GHz, 2 cores, AMX-BF16")
    assert cpu_label(_INTEL.format(extra="avx512_bf16")).endswith("AVX512-BF16, no AMX")
    assert cpu_label(_INTEL.format(extra="avx512_vnni")).endswith("no AMX, no BF16")
    amd = "processor\t: 0\nmodel name\t: AMD EPYC 9R14 96-Core Processor\nflags\t: avx512_bf16\n"
    assert cpu_label(amd) == "AMD EPYC 9R14 96-Core Processor, 1 cores"


def test_a_cache_holds_models_once_a_complete_entry_is_there(tmp_path: Path) -> None:
    assert not cache.holds_models(tmp_path / "absent")
    entry = tmp_path / "gmd_motion" / "ab12"
    entry.mkdir(parents=True)
    (entry / "model.pt").write_bytes(b"x")
    assert not cache.holds_models(tmp_path)          # no checksums: incomplete
    (entry / cache.CHECKSUMS).write_text("{}")
    assert cache.holds_models(tmp_path)
