"""workflow/Snakefile under Snakemake: dry runs list the expected jobs and requests at every
scale; a real local run at the quick scale measures what ``python -m repro reproduce`` does.

Skipped when Snakemake is not installed (``make setup`` installs requirements-workflow.txt;
``make test`` does not)."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from repro.claims.ledger import load_sidecars
from repro.infra import paths
from repro.run import runner, workflow

pytestmark = pytest.mark.skipif(importlib.util.find_spec("snakemake") is None,
                                reason="snakemake is not installed (make setup installs "
                                "requirements-workflow.txt)")

SNAKEFILE = paths.REPO_ROOT / "workflow" / "Snakefile"
PROFILES = paths.REPO_ROOT / "workflow" / "profiles"
NOTEBOOKS = runner.available_notebooks()


def _env() -> dict[str, str]:
    """The test's environment, with this checkout's package first for every job."""
    source = str(paths.REPO_ROOT / "src")
    return {**os.environ, "OMP_NUM_THREADS": "1",
            "PYTHONPATH": os.pathsep.join(filter(None, [source, os.environ.get("PYTHONPATH")]))}


def _snakemake(directory: Path, *arguments: str, config: list[str],
               check: bool = True) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE),
               "--directory", str(directory), *arguments, "--config", *config]
    done = subprocess.run(command, env=_env(), capture_output=True, text=True, timeout=1800,
                          check=False)
    if check and done.returncode:
        raise AssertionError(f"snakemake failed ({done.returncode}):\n{done.stdout[-4000:]}\n"
                             f"{done.stderr[-4000:]}")
    return done


_JOB = re.compile(r"^(?:local)?rule (\w+):\n(.*?)(?=^\S|\Z)", re.M | re.S)


def _jobs(output: str) -> list[tuple[str, dict[str, str]]]:
    """(rule, {field: value}) of every job a dry run lists."""
    jobs = []
    for rule, body in _JOB.findall(output):
        fields = dict(re.findall(r"^\s+(\w+): (.*)$", body, re.M))
        jobs.append((rule, fields))
    return jobs


def _pairs(text: str) -> dict[str, str]:
    """``a=1, b=x`` as a dict (a dry run's wildcards and resources lines)."""
    return dict(item.split("=", 1) for item in text.split(", ") if item)


def _resources(fields: dict[str, str]) -> dict[str, str]:
    return _pairs(fields.get("resources", ""))


@pytest.mark.parametrize("scale", ["quick", "standard", "paper"])
def test_dry_run_lists_every_notebook_and_seed_with_its_request(scale: str,
                                                                 tmp_path: Path) -> None:
    done = _snakemake(tmp_path, "--dry-run", "--cores", "4",
                      config=[f"scale={scale}", "seeds=[0,3]", f"out={tmp_path / 'out'}"])
    jobs = _jobs(done.stdout + done.stderr)
    rules = [rule for rule, _ in jobs]
    assert rules.count("notebook") == 2 * len(NOTEBOOKS)
    assert rules.count("report") == 2 and rules.count("stability") == 1
    seen = set()
    for rule, fields in jobs:
        if rule != "notebook":
            continue
        wildcards = _pairs(fields["wildcards"])
        name, seed = wildcards["notebook"], int(wildcards["seed"])
        seen.add((name, seed))
        expected = workflow.job_resources(name, scale)
        resources = _resources(fields)
        assert int(fields.get("threads", 1)) == expected.threads  # not listed when 1
        assert int(resources["runtime"]) == expected.runtime
        assert int(resources["mem_mb"]) == expected.mem_mb
        assert int(resources["gpu"]) == expected.gpu == (scale == "paper" and name[:2] != "00")
        assert fields["output"] == str(workflow.executed_notebook(tmp_path / "out", name, seed,
                                                                  scale))
    assert seen == {(n, s) for n in NOTEBOOKS for s in (0, 3)}


def test_dry_run_on_slurm_asks_for_a_gpu_model_and_the_shell_runs_reproduce(
        tmp_path: Path) -> None:
    # a dry run without --cores plans for one core (Snakemake's default), a cluster run not
    done = _snakemake(tmp_path, "--dry-run", "--printshellcmds", "--profile",
                      str(PROFILES / "slurm"), "--cores", "8",
                      config=["scale=paper", "seeds=[2]", "notebooks=[00,GMD-C4]",
                              "gpu_model=h100", f"out={tmp_path / 'out'}"])
    output = done.stdout + done.stderr
    jobs = {_pairs(fields["wildcards"])["notebook"]: _resources(fields)
            for rule, fields in _jobs(output) if rule == "notebook"}
    c4 = jobs["03_emphasis_projection"]
    assert c4["gpu"] == "1" and c4["gpu_model"] == "h100"
    assert int(c4["runtime"]) == workflow.job_resources("03_emphasis_projection",
                                                        "paper").runtime
    assert jobs["00_stand_in_data"]["gpu"] == "0"
    root = workflow.job_root(tmp_path / "out", "03_emphasis_projection", 2)
    assert (f"REPRO_BUILD_ROOT={root} REPRO_CACHE_DIR={tmp_path / 'out' / 'cache'}") in output
    assert ("-m repro reproduce --only 03_emphasis_projection --scale paper --seed 2 --jobs 1 "
            "--threads 4 --device auto") in output


def test_a_local_job_runs_with_the_threads_it_is_granted(tmp_path: Path) -> None:
    """On a machine of 2 cores a paper job asking for 4 threads is granted 2 by the local
    profile, and its command passes 2 (not its request); its device is decided where it
    runs (``--device auto``: cpu here without a GPU), so a CPU-only machine runs it."""
    done = _snakemake(tmp_path, "--dry-run", "--printshellcmds", "--profile",
                      str(PROFILES / "local"), "--cores", "2",
                      config=["scale=paper", "notebooks=[GMD-C4]", f"out={tmp_path / 'out'}"])
    output = done.stdout + done.stderr
    [fields] = [fields for rule, fields in _jobs(output) if rule == "notebook"]
    assert fields["threads"] == "2"
    assert "--scale paper --seed 0 --jobs 1 --threads 2 --device auto" in output


def test_a_wrong_config_stops_before_any_job(tmp_path: Path) -> None:
    done = _snakemake(tmp_path, "--dry-run", config=["scale=huge"], check=False)
    assert done.returncode != 0
    assert "scale must be one of quick, standard, paper" in done.stdout + done.stderr


CHEAP = ["00_stand_in_data", "03_emphasis_projection"]


@pytest.mark.notebook
@pytest.mark.workflow
def test_quick_workflow_measures_what_reproduce_measures(tmp_path: Path) -> None:
    """Two cheap notebooks from base seed 1 through the local profile, and the same two
    through ``python -m repro reproduce --quick --only`` (own build root and cache, one
    thread each): every claim's measured values and verdict are the same."""
    out = tmp_path / "workflow"
    _snakemake(tmp_path, "--profile", str(PROFILES / "local"), "--cores", "1",
               config=["scale=quick", "seeds=[1]", f"notebooks=[{','.join(CHEAP)}]",
                       f"out={out}", "threads=1"])
    direct_root = tmp_path / "direct"
    env = {**_env(), "REPRO_BUILD_ROOT": str(direct_root),
           "REPRO_CACHE_DIR": str(tmp_path / "direct-cache")}
    subprocess.run([sys.executable, "-m", "repro", "reproduce", "--quick", "--only", *CHEAP,
                    "--seed", "1", "--jobs", "1", "--threads", "1"], env=env, check=True,
                   capture_output=True, timeout=1800)

    gathered = load_sidecars(workflow.scale_folder(workflow.gather_root(out, 1), "quick")
                             / "claims")
    direct = load_sidecars(direct_root / "quick" / "claims")
    assert sorted(gathered) == sorted(direct) == ["GMD-C1", "GMD-C2", "GMD-C3", "GMD-C4"]
    for claim_id, sidecar in direct.items():
        assert gathered[claim_id]["measured"] == sidecar["measured"], claim_id
        assert gathered[claim_id]["verdict"] == sidecar["verdict"], claim_id
        assert gathered[claim_id]["seeds"] == sidecar["seeds"]
        assert gathered[claim_id]["seeds"][:1] in ([], [1])  # from base seed 1

    report = workflow.report_path(out, 1, "quick").read_text()
    for name in CHEAP:  # every job's run is named, also 00's, which records no claim
        build = workflow.scale_folder(workflow.job_root(out, name, 1), "quick")
        (run_id,) = [p.name for p in (build / "runs").iterdir()]
        assert f"{name} → run {run_id}" in report
        assert (build / "notebooks" / f"{name}.ipynb").is_file()
    assert (out / "cache").is_dir()  # the jobs' one model cache


def test_report_and_stability_rules_gather_finished_jobs(tmp_path: Path) -> None:
    """Jobs already finished (their executed notebooks and sidecars in place, as the runner
    leaves them): Snakemake runs only the gathers and the comparison of the two base seeds."""
    from conftest import make_context

    from repro.claims.ledger import record_claim
    from repro.infra.storage import write_json

    out = tmp_path / "out"
    for seed, error in [(0, 0.5), (3, 0.0)]:
        for name, claim_id, measured in [
                ("01_x0_vs_eps", "GMD-A1", {"max_abs_mu_difference": 0.0,
                                            "printed_c_max_relative_error": error}),
                ("02_root_representation", "GMD-A2",
                 {"cosine_x0_share_argmax_fraction": 0.0,
                  "cosine_eps_share_argmax_fraction": 0.99})]:
            build = workflow.scale_folder(workflow.job_root(out, name, seed), "quick")
            run_id = f"20261204T00000{seed}.000Z-abc1234-seed{seed}-quick"
            write_json(build / "runs" / run_id / "run.json", {"run_id": run_id,
                                                              "notebooks": [name]})
            record_claim(make_context(build, scale="quick", seed=seed, run_id=run_id),
                         claim_id, measured, seeds=[seed])
            notebook = workflow.executed_notebook(out, name, seed, "quick")
            notebook.parent.mkdir(parents=True)
            notebook.write_text("{}")
    done = _snakemake(tmp_path, "--cores", "1",
                      config=["scale=quick", "seeds=[0,3]", "notebooks=[01,02]", f"out={out}"])
    log = done.stdout + done.stderr
    assert "rule notebook" not in log  # nothing reran
    for seed in (0, 3):
        assert "GMD-A1" in workflow.report_path(out, seed, "quick").read_text()
    stability = (workflow.report_path(out, 0, "quick").parent / "STABILITY.md").read_text()
    assert "Verdicts that changed with the seed: GMD-A1." in stability
