"""The workflow's package side: each job's folders, command line and request, the config
check, and the gather of one base seed's jobs into one report naming every run."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from conftest import make_context

from repro.claims.ledger import record_claim
from repro.infra import paths
from repro.infra.storage import read_json, write_json
from repro.run import plan, runner, workflow
from repro.run.workflow import WorkflowConfig, job_resources


def test_every_notebook_has_a_request_at_every_scale() -> None:
    assert set(plan.STANDARD_PLAN_MINUTES) == set(runner.available_notebooks())
    assert set(plan.PAPER_CPU_HOURS) == set(plan.STANDARD_PLAN_MINUTES)
    for scale in ("quick", "standard", "paper"):
        for name in runner.available_notebooks():
            request = job_resources(name, scale)
            assert request.runtime >= workflow.MIN_RUNTIME_MIN
            assert request.mem_mb >= 512 and request.threads >= 1
            assert request.gpu == (scale == "paper" and name != "00_stand_in_data")


def test_paper_requests_come_from_the_counted_costs() -> None:
    # docs/COMPUTE.md §2: ≈ 265 CPU-hours in fp32 (the notebooks' own shares)
    assert sum(plan.PAPER_CPU_HOURS.values()) == pytest.approx(265, abs=1.5)
    # 03 (GMD-C4: 36 motion models at the cap) is the longest job, 06 waits for 01's model
    own = 60 * plan.PAPER_CPU_HOURS["06_guidance_schedule"]
    shared = 60 * plan.PAPER_SHARED_CPU_HOURS["06_guidance_schedule"]["01_x0_vs_eps"]
    assert job_resources("06_guidance_schedule", "paper").runtime == \
        pytest.approx((own + shared) * workflow.RUNTIME_MARGIN, abs=1)
    runtimes = {n: job_resources(n, "paper").runtime for n in plan.PAPER_CPU_HOURS}
    assert max(runtimes, key=runtimes.get) == "03_emphasis_projection"
    standard = job_resources("05_sef_ablation", "standard").runtime
    minutes = plan.STANDARD_PLAN_MINUTES
    assert standard == pytest.approx((minutes["05_sef_ablation"]
                                      + minutes["04_energy_contour_maps"]) * 1.3, abs=1)


def test_device_and_threads() -> None:
    """At the paper scale a job asks for a GPU and takes cuda where it runs on one
    (``--device auto``), cpu on a machine without one."""
    assert workflow.job_device("01_x0_vs_eps", "paper") == "auto"
    assert job_resources("01_x0_vs_eps", "paper").gpu == 1
    assert workflow.job_device("01_x0_vs_eps", "paper", "cuda") == "cuda"
    assert workflow.job_device("01_x0_vs_eps", "standard") == "cpu"
    assert workflow.job_device("00_stand_in_data", "paper", "cuda") == "cpu"
    assert job_resources("01_x0_vs_eps", "standard", device="cuda").gpu == 1
    assert job_resources("01_x0_vs_eps", "paper", device="cpu").gpu == 0
    assert job_resources("01_x0_vs_eps", "paper", threads=8).threads == 8
    with pytest.raises(ValueError, match="no plan"):
        job_resources("09_new", "paper")
    with pytest.raises(ValueError, match="at least 1"):
        job_resources("01_x0_vs_eps", "paper", threads=0)


def test_job_folders_follow_the_runner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = workflow.job_root(tmp_path, "03_emphasis_projection", 3)
    assert root == tmp_path / "seed3" / "03_emphasis_projection"
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(root))
    for scale in ("quick", "standard", "paper"):
        assert workflow.scale_folder(root, scale) == paths.run_build_dir(scale)
    assert workflow.executed_notebook(tmp_path, "03_emphasis_projection", 3, "paper") == \
        root / "paper" / "notebooks" / "03_emphasis_projection.ipynb"
    assert workflow.report_path(tmp_path, 3, "standard") == \
        tmp_path / "seed3" / "all" / "report" / "REPORT.md"


def test_reproduce_arguments() -> None:
    words = shlex.split(workflow.reproduce_arguments("02_root_representation", "paper", 5,
                                                     data_dir="/data/Human ML3D"))
    assert words == ["reproduce", "--only", "02_root_representation", "--scale", "paper",
                     "--seed", "5", "--jobs", "1", "--threads", "4", "--device", "auto",
                     "-p", 'data_dir="/data/Human ML3D"']
    config = workflow.WorkflowConfig.from_config({"scale": "paper"})
    granted = shlex.split(config.arguments("02_root_representation", 5, threads=2))
    assert granted[granted.index("--threads") + 1] == "2"   # what Snakemake granted


def test_device_auto_is_this_machines(capsys: pytest.CaptureFixture[str]) -> None:
    import torch

    from repro.run.cli import main
    from repro.run.params import resolve_device

    assert resolve_device("auto") == ("cuda" if torch.cuda.is_available() else "cpu")
    assert resolve_device("cuda:1") == "cuda:1"
    # accepted by reproduce's checks (the only problem named is the unknown parameter)
    assert main(["reproduce", "--quick", "--only", "01", "--device", "auto",
                 "-p", "n_seeds=0"]) == 2
    err = capsys.readouterr().err
    assert "parameter n_seeds=0 must be at least 1" in err and "parameter device" not in err


def test_config_file_repeats_the_defaults() -> None:
    yaml = pytest.importorskip("yaml")
    written = yaml.safe_load((paths.REPO_ROOT / "workflow" / "config.yaml").read_text())
    assert written == {**workflow.DEFAULTS, "gpu_model": ""}


def test_config_is_checked(tmp_path: Path) -> None:
    config = WorkflowConfig.from_config({"scale": "quick", "seeds": [0, 3],
                                         "notebooks": ["00", "GMD-C4"], "out": str(tmp_path)})
    assert config.notebooks == ("00_stand_in_data", "03_emphasis_projection")
    assert config.claim_notebooks() == ("03_emphasis_projection",)
    assert config.seeds == (0, 3) and config.cache_dir == tmp_path / "cache"
    assert WorkflowConfig.from_config({}).scale == "paper"
    assert len(WorkflowConfig.from_config({"seeds": 2}).notebooks) == len(
        runner.available_notebooks())
    for bad, match in [({"scale": "huge"}, "scale must be"), ({"seeds": [1, 1]}, "distinct"),
                       ({"seeds": ["x"]}, "base seeds"), ({"notebooks": ["99"]}, "unknown"),
                       ({"device": "tpu"}, "device must be"), ({"threads": 0}, "threads"),
                       ({"jobs": 2}, "unknown workflow config")]:
        with pytest.raises(ValueError, match=match):
            WorkflowConfig.from_config(bad)


def _job(out: Path, notebook: str, seed: int, claims: dict[str, dict], *,
         stamp: str = "000000") -> Path:
    """A finished quick job: its run.json, executed notebook and claim sidecars."""
    root = workflow.job_root(out, notebook, seed)
    build = workflow.scale_folder(root, "quick")
    run_id = f"20261204T{stamp}.000Z-abc1234-seed{seed}-quick"
    write_json(build / "runs" / run_id / "run.json", {"run_id": run_id, "notebooks": [notebook]})
    (build / "notebooks").mkdir(parents=True)
    (build / "notebooks" / f"{notebook}.ipynb").write_text("{}")
    ctx = make_context(build, scale="quick", seed=seed, run_id=run_id)
    for claim_id, measured in claims.items():
        record_claim(ctx, claim_id, measured, seeds=[seed])
    return root


def test_gather_reports_every_job_and_run(tmp_path: Path) -> None:
    a1 = {"GMD-A1": {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5}}
    a2 = {"GMD-A2": {"cosine_x0_share_argmax_fraction": 0.0,
                     "cosine_eps_share_argmax_fraction": 0.99}}
    roots = [_job(tmp_path, "00_stand_in_data", 3, {}, stamp="000001"),
             _job(tmp_path, "01_x0_vs_eps", 3, a1, stamp="000002"),
             _job(tmp_path, "02_root_representation", 3, a2, stamp="000003")]
    into = workflow.gather_root(tmp_path, 3)
    code = workflow.main(["gather", "--scale", "quick", "--seed", "3", "--into", str(into),
                          *map(str, roots)])
    assert code == 0
    report = workflow.report_path(tmp_path, 3, "quick")
    text = report.read_text()
    for stamp, notebook in [("000001", "00_stand_in_data"), ("000002", "01_x0_vs_eps"),
                            ("000003", "02_root_representation")]:
        assert f"{notebook} → run 20261204T{stamp}.000Z-abc1234-seed3-quick" in text
    assert "Mixed runs (--allow-mixed)" in text  # write_report's own line, every run named
    merged = workflow.scale_folder(into, "quick")
    assert sorted(p.name for p in (merged / "notebooks").iterdir()) == [
        "00_stand_in_data.ipynb", "01_x0_vs_eps.ipynb", "02_root_representation.ipynb"]
    claims = read_json(merged / "report" / "claims.json")["sidecars"]
    assert claims["GMD-A1"]["measured"] == a1["GMD-A1"]

    # a job of another base seed, a claim recorded twice, a job that never ran: refused
    other = _job(tmp_path / "other", "03_emphasis_projection", 4, {"GMD-A1": a1["GMD-A1"]})
    with pytest.raises(ValueError, match="base seed 3"):
        workflow.gather([*roots, other], into, scale="quick", seed=3)
    twice = _job(tmp_path / "twice", "03_emphasis_projection", 3, {"GMD-A1": a1["GMD-A1"]})
    with pytest.raises(ValueError, match="recorded by two jobs"):
        workflow.gather([*roots, twice], into, scale="quick", seed=3)
    assert workflow.main(["gather", "--scale", "quick", "--seed", "3", "--into", str(into),
                          str(tmp_path / "never")]) == 2
