"""Every fault of issues #18 and #35 ends with an error naming the problem, and leaves
``results/`` and the last good report untouched. Tiny notebooks written by the tests; no model
training."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import write_notebook

from repro.infra import paths
from repro.infra.storage import read_json
from repro.run import runner
from repro.run.cli import main

PARAMETERS = ("scale = 'quick'\nseed = 0\ndevice = 'cpu'\nbuild_dir = None\ndata_dir = None\n"
              "train_steps = None\nn_seeds = 3\nguidance = 0.5\n")

RECORD = """
from repro.run.notebook import setup_notebook
from repro.claims.ledger import record_claim
ctx = setup_notebook(scale=scale, seed=seed, device=device, build_dir=build_dir)
import matplotlib.pyplot as plt
figure = ctx.figure_path("{name}.png")
plt.plot([0, 1]); plt.savefig(figure)
measured = {{"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5,
            "cosine_x0_share_argmax_fraction": 0.05, "cosine_eps_share_argmax_fraction": 0.95,
            "round_trip_max_error": 0.0, "rel_late_displacement": 1.0,
            "abs_late_displacement": 0.1, "abs_early_displacement": 0.2,
            "rel_sensitivity_growth": 2.0}}
for claim in {claims}:
    record_claim(ctx, claim, measured, seeds=[seed], figures=[figure])
{tail}
"""


def _notebook(path: Path, body: str) -> None:
    write_notebook(path, body, parameters=PARAMETERS)


def _recording(name: str, claims: list[str], tail: str = "") -> str:
    return RECORD.format(name=name, claims=claims, tail=tail)


def _tree_digest(*folders: Path) -> dict[str, str]:
    """Path → sha256 of every file below ``folders`` (what "untouched" is checked against)."""
    out = {}
    for folder in folders:
        for path in sorted(folder.rglob("*")) if folder.exists() else []:
            if path.is_file():
                out[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


@pytest.fixture()
def sandbox(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    notebooks = tmp_path / "notebooks"
    notebooks.mkdir()
    _notebook(notebooks / "01_two_claims.ipynb", _recording("one", ["GMD-A1", "GMD-A2"]))
    monkeypatch.setenv("REPRO_NOTEBOOKS_DIR", str(notebooks))
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path


@pytest.fixture()
def guarded(sandbox: Path):
    """A last good quick report (recorded directly, no kernel); yields a check that results/
    and that report and its sidecars are byte for byte what they were."""
    from conftest import make_context

    from repro.claims.ledger import record_claim
    from repro.claims.report import write_report

    quick = sandbox / "build" / "quick"
    record_claim(make_context(quick, run_id="earlier-run"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5}, seeds=[0])
    write_report(quick, scale="quick")
    before = _tree_digest(paths.results_dir(), quick / "report", quick / "claims")
    yield lambda: _tree_digest(paths.results_dir(), quick / "report",
                               quick / "claims") == before


def test_a_run_publishes_sidecars_notebook_and_figures_under_its_run_id(sandbox: Path) -> None:
    assert runner.reproduce(scale="quick") == 0
    quick = sandbox / "build" / "quick"
    sidecar = read_json(quick / "claims" / "GMD-A1.json")
    assert sidecar["run_id"].endswith("-seed0-quick") and sidecar["scale"] == "quick"
    assert sidecar["figures"] == [str(quick / "figures" / "one.png")]
    assert (quick / "figures" / "one.png").is_file()
    assert (quick / "notebooks" / "01_two_claims.ipynb").is_file()
    # a finished run keeps only its run.json (the report's run span starts there)
    assert [p.name for p in (quick / "runs" / sidecar["run_id"]).iterdir()] == ["run.json"]
    assert read_json(quick / "report" / "claims.json")["run_span_seconds"] is not None
    assert f"Run {sidecar['run_id']}." in (quick / "report" / "REPORT.md").read_text()
    assert read_json(quick / "claims" / "GMD-A2.json")["run_id"] == sidecar["run_id"]


def test_a_failed_notebook_publishes_nothing_and_the_others_do(
        sandbox: Path, guarded, capsys: pytest.CaptureFixture[str]) -> None:
    notebooks = sandbox / "notebooks"
    # records GMD-A1 with seed 7, then fails: the last good run's A1 must stay as it was
    _notebook(notebooks / "01_two_claims.ipynb",
              _recording("one", ["GMD-A1"], "raise RuntimeError('half-way failure')"))
    _notebook(notebooks / "02_other.ipynb", _recording("two", ["GMD-B1"]))
    assert runner.reproduce(scale="quick", seed=7, jobs=2) == 1
    out = capsys.readouterr()
    assert "half-way failure" in out.out and "not published" in out.out
    assert "the last good report" in out.err
    quick = sandbox / "build" / "quick"
    assert read_json(quick / "claims" / "GMD-B1.json")["seeds"] == [7]  # the good one published
    assert read_json(quick / "claims" / "GMD-A1.json")["run_id"] == "earlier-run"
    staged = list((quick / "runs").glob("*-seed7-quick/01_two_claims/claims/GMD-A1.json"))
    assert len(staged) == 1  # kept for inspection, in the staging folder only
    (quick / "claims" / "GMD-B1.json").unlink()  # the check below is about the rest
    assert guarded()


def test_report_refuses_to_mix_runs_unless_allowed(
        sandbox: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert runner.reproduce(scale="quick") == 0
    first = read_json(sandbox / "build" / "quick" / "claims" / "GMD-A1.json")["run_id"]
    _notebook(sandbox / "notebooks" / "02_other.ipynb", _recording("two", ["GMD-B1"]))
    quick = sandbox / "build" / "quick"
    report_before = (quick / "report" / "REPORT.md").read_bytes()
    # a partial run that succeeded: exit 0, saying how to report mixed runs
    assert runner.reproduce(scale="quick", only=["02"], seed=7) == 0
    out = capsys.readouterr().out
    assert "published" in out and "come from 2 runs" in out and first in out
    assert "python -m repro report --scale quick --allow-mixed" in out
    assert (quick / "report" / "REPORT.md").read_bytes() == report_before
    assert main(["report", "--quick"]) == 2
    assert "come from 2 runs" in capsys.readouterr().err
    assert (quick / "report" / "REPORT.md").read_bytes() == report_before
    assert main(["report", "--quick", "--allow-mixed"]) == 0
    text = (quick / "report" / "REPORT.md").read_text()
    second = read_json(quick / "claims" / "GMD-B1.json")["run_id"]
    assert "Mixed runs (--allow-mixed)" in text
    assert f"run {first} (GMD-A1, GMD-A2)" in text and f"run {second} (GMD-B1)" in text


@pytest.mark.parametrize("name", ["scale", "build_dir", "seed", "device"])
def test_runner_parameters_cannot_be_passed_with_p(sandbox: Path, guarded, name: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    value = {"scale": '"quick"', "build_dir": '"/tmp/x"', "seed": "3", "device": '"cpu"'}[name]
    assert main(["reproduce", "-p", f"{name}={value}"]) == 2
    assert f"-p cannot set {name}" in capsys.readouterr().err
    assert not (sandbox / "build" / "claims").exists()  # nothing reached the standard folder
    assert guarded()


def test_report_over_no_claim_or_the_wrong_mode_is_an_error(
        sandbox: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (sandbox / "build" / "claims").mkdir(parents=True)
    assert main(["report"]) == 2
    assert "no claim is recorded" in capsys.readouterr().err
    from conftest import make_context

    from repro.claims.ledger import record_claim

    record_claim(make_context(sandbox / "build", scale="quick", run_id="r"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5},
                 seeds=[0])  # a quick sidecar in the standard folder
    assert main(["report"]) == 2
    assert "holds sidecars of another scale" in capsys.readouterr().err
    assert not (sandbox / "build" / "report").exists()


BAD_VALUES = [
    (["-p", 'train_steps="abc"'], "parameter train_steps must be int or None"),
    (["-p", "train_steps=0"], "parameter train_steps=0 must be at least 1"),
    (["-p", "n_seeds=true"], "parameter n_seeds must be int"),
    (["-p", "guidance=\"big\""], "parameter guidance must be float or int"),
    (["-p", "stepz=3"], "has no parameter(s) ['stepz']"),
    (["--seed", "-1"], "parameter seed=-1 is negative: a base seed is a whole number from 0 "
                       "to 2^48 - 1 = 281474976710655 (e.g. --seed 0)"),
    # a seed past 2^48 - 1 is refused before any kernel starts (the kernels cannot take it)
    (["--seed", str(2**64 - 1)], "parameter seed=18446744073709551615 must be between 0 and "
                                 "2^48 - 1 = 281474976710655"),
    (["--device", "cuda:0"], "names CUDA, which is not available here"),
    (["--device", "gpu"], "parameter device='gpu' is not a torch device"),
    (["-p", 'data_dir="/no/such/folder"'], "is not a folder (/no/such/folder does not exist)"),
    (["-p", f'data_dir="{paths.REPO_ROOT / "pyproject.toml"}"'],
     f"is a file, not a folder ({paths.REPO_ROOT / 'pyproject.toml'}): give the "
     "HumanML3D-layout folder"),
    (["--only", "99_nope"], "unknown notebook or claim ID '99_nope'"),
    (["--only", "XYZ-9"], "unknown notebook or claim ID 'XYZ-9'"),
]


@pytest.mark.parametrize(("arguments", "message"), BAD_VALUES)
def test_bad_input_is_refused_before_any_kernel_starts(
        sandbox: Path, guarded, arguments: list[str], message: str,
        capsys: pytest.CaptureFixture[str]) -> None:
    import torch

    if "cuda:0" in arguments and torch.cuda.is_available():
        pytest.skip("CUDA is available here")
    runs_before = sorted((sandbox / "build" / "quick" / "runs").glob("*"))
    assert main(["reproduce", "--quick", *arguments]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert "pick a smaller one" not in err or "18446744073709551615" in arguments
    assert sorted((sandbox / "build" / "quick" / "runs").glob("*")) == runs_before  # no run
    assert guarded()


def _damage(folder: Path, how: str) -> str:
    """Damage one file of a copy of the stand-in dataset; returns what the error must name."""
    clip = (folder / "train.txt").read_text().split()[0]
    features = folder / "new_joint_vecs" / f"{clip}.npy"
    if how == "missing":
        features.unlink()
    elif how == "empty":
        features.write_bytes(b"")
    elif how == "truncated":
        features.write_bytes(features.read_bytes()[:200])
    elif how == "wrong-shape":
        np.save(features, np.zeros((40, 12), dtype=np.float32))
    elif how == "missing-statistics":
        (folder / "Mean.npy").unlink()
        return "Mean.npy"
    elif how == "garbled-statistics":
        (folder / "Mean.npy").write_bytes(b"\x80\x04 not an array " * 40)
        return f"{folder / 'Mean.npy'}: is not a .npy array: it does not start with numpy's header"
    elif how == "truncated-without-layout":  # four layout errors besides
        features.write_bytes(features.read_bytes()[:200])
        shutil.rmtree(folder / "texts")
        for split in ("train", "val", "test"):
            (folder / f"{split}.txt").unlink()
        return f"{features}: cannot be read as a .npy array (truncated"
    return f"{clip}.npy"


@pytest.mark.parametrize("how", [
    "missing", "empty", "truncated", "wrong-shape", "missing-statistics", "garbled-statistics",
    "truncated-without-layout"])
def test_bad_dataset_files_are_named_before_any_kernel_starts(
        sandbox: Path, guarded, how: str, capsys: pytest.CaptureFixture[str]) -> None:
    data = sandbox / "data"
    shutil.copytree(paths.data_stubs_dir(), data)
    named = _damage(data, how)
    assert main(["reproduce", "--quick", "-p", f'data_dir="{data}"']) == 2
    err = capsys.readouterr().err
    assert "is not a valid HumanML3D-layout folder" in err and named in err
    assert "allow_pickle" not in err and "validator failed" not in err
    assert guarded()
    assert main(["validate-dataset", str(data)]) == 1  # the check it names shows the same
    assert named in capsys.readouterr().out


def test_an_empty_dataset_file_is_refused_before_any_kernel_starts(
        sandbox: Path, guarded, capsys: pytest.CaptureFixture[str]) -> None:
    data = sandbox / "data"
    shutil.copytree(paths.data_stubs_dir(), data)
    _damage(data, "empty")
    assert main(["reproduce", "--quick", "-p", f'data_dir="{data}"']) == 2
    err = capsys.readouterr().err
    assert "is not a valid HumanML3D-layout folder" in err and "No data left in file" in err
    assert not (sandbox / "build" / "quick" / "runs").exists()
    assert guarded()


def test_the_largest_base_seed_fits_every_seed_derived_from_it(tmp_path: Path) -> None:
    """Issue #35 case 1: the range checked up front is what every notebook can use."""
    import torch

    from repro.gmd.controls import control_seed
    from repro.infra.context import MAX_SEED
    from repro.run.notebook import setup_notebook

    largest = 10_000 * (MAX_SEED + 100) + 10_000  # Table B.1's seeds, 100 from the base
    assert largest < 2**63 and control_seed(MAX_SEED + 100, 99, stream=99) < 2**63
    torch.Generator().manual_seed(largest)
    np.random.default_rng(largest)
    with pytest.raises(ValueError, match=f"seed={MAX_SEED + 1} must be between 0 and 2"):
        setup_notebook(scale="quick", seed=MAX_SEED + 1, device="cpu", build_dir=str(tmp_path))


def test_a_relative_data_dir_is_read_from_the_callers_folder(
        sandbox: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue #35 case 2: the kernels run in notebooks/, so the runner makes it absolute."""
    shutil.copytree(paths.data_stubs_dir(), sandbox / "mydata")
    _notebook(sandbox / "notebooks" / "01_two_claims.ipynb",
              "from repro.run.notebook import setup_notebook\n"
              "ctx = setup_notebook(scale=scale, seed=seed, device=device, "
              "build_dir=build_dir, data_dir=data_dir)\nprint('data:', ctx.data_dir)")
    monkeypatch.chdir(sandbox)
    assert main(["reproduce", "--quick", "-p", 'data_dir="mydata"']) == 0
    executed = (sandbox / "build" / "quick" / "notebooks" / "01_two_claims.ipynb").read_text()
    assert f"data: {sandbox / 'mydata'}" in executed


def test_a_read_only_build_is_named_before_any_kernel_starts(
        sandbox: Path, guarded, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Issue #35 case 5 (as root, chmod does not stop a write: the failing call is made to
    fail as it does for another user)."""
    lock = sandbox / "cache" / "gmd" / "abc" / ".lock"

    def read_only(*_: object, **__: object) -> None:
        raise PermissionError(13, "Permission denied", str(lock))

    monkeypatch.setattr(runner.cache, "clean_cache", read_only)
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err
    assert f"cannot write {lock}: Permission denied; make its folder writable" in err
    assert "REPRO_BUILD_ROOT" in err and "Traceback" not in err
    assert not list((sandbox / "build" / "quick" / "runs").glob("*"))
    assert guarded()
    from repro.claims import report

    report_file = sandbox / "build" / "quick" / "report" / "claims.json"
    monkeypatch.setattr(report, "write_json", lambda path, _: (_ for _ in ()).throw(
        PermissionError(13, "Permission denied", str(report_file))))
    assert main(["report", "--quick"]) == 2
    assert f"cannot write {report_file}: Permission denied" in capsys.readouterr().err
    assert guarded()


def test_a_garbled_claim_sidecar_is_named(sandbox: Path, guarded,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """Issue #35 case 6."""
    quick = sandbox / "build" / "quick"
    report_before = (quick / "report" / "REPORT.md").read_bytes()
    (quick / "claims" / "GMD-A2.json").write_text('{"id": "GMD-A2", "verdict": ')
    assert main(["report", "--quick"]) == 2
    err = capsys.readouterr().err
    assert f"the claim sidecar {quick / 'claims' / 'GMD-A2.json'} is not valid JSON" in err
    assert "python -m repro reproduce --only GMD-A2" in err and "Traceback" not in err
    assert "the last good report" in err
    assert (quick / "report" / "REPORT.md").read_bytes() == report_before


def test_a_garbled_sidecar_is_named_before_any_kernel_starts(
        sandbox: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A sidecar the report after the run would refuse stops the run before it starts, not
    after its notebooks ran; so does one of another scale."""
    from conftest import make_context

    from repro.claims.ledger import record_claim

    claims = sandbox / "build" / "quick" / "claims"
    claims.mkdir(parents=True)
    (claims / "GMD-B1.json").write_text('{"id": "GMD-B1", "verdict": ')
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err
    assert f"the claim sidecar {claims / 'GMD-B1.json'} is not valid JSON" in err
    assert err.rstrip().endswith("nothing ran") and "Traceback" not in err
    assert not (sandbox / "build" / "quick" / "runs").exists()   # no run, no kernel
    (claims / "GMD-B1.json").unlink()
    record_claim(make_context(claims.parent, scale="standard", run_id="r"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5},
                 seeds=[0])
    assert main(["reproduce", "--quick"]) == 2
    assert f"the claim sidecar {claims / 'GMD-A1.json'} is of the 'standard' scale" in \
        capsys.readouterr().err


def test_a_garbled_sidecar_the_run_records_anew_does_not_stop_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    claims = tmp_path / "build" / "quick" / "claims"
    claims.mkdir(parents=True)
    (claims / "GMD-F1.json").write_text("garbled")           # notebook 06 records it anew
    runner.preflight(["06_guidance_schedule"], "quick")
    with pytest.raises(ValueError, match="GMD-F1.json is not valid JSON"):
        runner.preflight(["01_x0_vs_eps"], "quick")


def test_a_disk_without_room_is_named_before_any_kernel_starts(
        sandbox: Path, guarded, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(runner, "free_bytes", lambda _: 3 * 2**20)
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err
    assert (f"the disk holding the build folder {sandbox / 'build' / 'quick'} has 3.0 MiB "
            "free; a quick-scale run needs about 128 MiB there: free space on it") in err
    assert not list((sandbox / "build" / "quick" / "runs").glob("*"))
    assert guarded()


def test_a_damaged_cache_entry_is_set_aside_before_any_kernel_starts(
        sandbox: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    entry = sandbox / "cache" / "gmd_motion" / "abc"
    entry.mkdir(parents=True)
    (entry / "metrics.json").write_text('{"losses": [0.5, ', encoding="utf-8")
    lines: list[str] = []

    def no_kernel(*_: object, **__: object) -> None:
        raise RuntimeError("no kernel in this test")

    monkeypatch.setattr(runner, "_start", no_kernel)
    with pytest.raises(RuntimeError, match="no kernel"):
        runner.run_notebooks(["01_two_claims"], scale="quick", log=lines.append)
    [warning] = [line for line in lines if line.startswith("warning: cache:")]
    assert f"{entry / 'metrics.json'} cannot be read" in warning
    assert not (entry / "metrics.json").exists() and list(entry.glob("metrics.json.corrupt-*"))


def test_a_full_disk_is_named_before_and_during_a_run(
        sandbox: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Issue #35 case 7: before a run (staging cannot be written) and after a worker that
    could write neither its result nor its log; with no report yet, none is said kept."""
    from types import SimpleNamespace

    staging = sandbox / "build" / "quick" / "runs" / "x" / "run.json"

    def full(**_: object) -> None:
        raise OSError(28, "No space left on device", str(staging))

    monkeypatch.setattr(runner.transaction, "new_run", full)
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err
    assert f"cannot write {staging}: No space left on device (the disk is full" in err
    assert "free space on it and rerun; nothing ran" in err
    folder = sandbox / "staged"
    folder.mkdir()
    (folder / "worker.log").write_bytes(b"")
    job = SimpleNamespace(name="01_two_claims", process=SimpleNamespace(returncode=1))
    monkeypatch.setattr(runner, "free_bytes", lambda _: 4096)
    error = runner._no_result(job, folder)
    assert f"the disk holding {folder} is full (4096 bytes free)" in error
    assert "worker.log" not in error
    failed = runner.NotebookResult("01_two_claims", False, 1.0, str(folder), error)
    monkeypatch.setattr(runner, "run_notebooks", lambda *_, **__: [failed])
    assert runner.reproduce(scale="quick") == 1
    err = capsys.readouterr().err
    assert "there is no report in" in err and "last good report" not in err


def test_two_runs_ending_together_both_succeed_and_say_how_to_report(
        sandbox: Path, guarded, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Issue #35 case 8: two identical runs started together leave claims of both runs."""
    from conftest import make_context

    from repro.claims.ledger import record_claim

    quick = sandbox / "build" / "quick"
    record_claim(make_context(quick, run_id="the-other-run"), "GMD-A2",
                 {"cosine_x0_share_argmax_fraction": 0.05,
                  "cosine_eps_share_argmax_fraction": 0.95}, seeds=[0])
    done = runner.NotebookResult("01_two_claims", True, 1.0, "x", claims=("GMD-A1", "GMD-A2"))
    monkeypatch.setattr(runner, "run_notebooks", lambda *_, **__: [done])
    report_before = (quick / "report" / "REPORT.md").read_bytes()
    assert runner.reproduce(scale="quick") == 0
    out = capsys.readouterr().out
    assert "come from 2 runs: run earlier-run (GMD-A1); run the-other-run (GMD-A2)" in out
    assert "--allow-mixed" in out
    assert (quick / "report" / "REPORT.md").read_bytes() == report_before


CORRUPT_CACHE = """
import torch
from repro.infra import cache
def make():
    return torch.nn.Linear(2, 2)
cache.load_or_train("issue35", {"a": 1}, make, lambda module: module)
next(cache.paths.cache_dir().glob("issue35/*/model.pt")).write_bytes(b"garbage")
cache.load_or_train("issue35", {"a": 1}, make, lambda module: module)
"""


def test_a_corrupt_cached_model_is_reported_on_the_terminal_and_in_the_report(
        sandbox: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue #35 case 9."""
    _notebook(sandbox / "notebooks" / "01_two_claims.ipynb",
              CORRUPT_CACHE + _recording("one", ["GMD-A1"]))
    assert runner.reproduce(scale="quick") == 0
    out = capsys.readouterr().out
    warning = [line for line in out.splitlines() if "warning: cache:" in line]
    assert len(warning) == 1 and "model.pt" in warning[0] and "moved it aside" in warning[0]
    report = (sandbox / "build" / "quick" / "report" / "REPORT.md").read_text()
    assert "Warnings of this run: 01_two_claims: cache:" in report and "moved it aside" in report
