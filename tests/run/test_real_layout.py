"""A folder in the real HumanML3D layout, without the stand-in's ``labels/``: the
validator and the parameter check accept it and reject what the notebooks cannot use, and the
notebooks run on it at the quick scale, reading "not measurable on real data" where they would
compare against labels.

The folders are small stand-in sets with ``labels/`` dropped, plus the shared real HumanML3D
clips (../shared/humanml3d_sample) where they fit the loader's 40 ≤ T < 200 frames (skipped
when that folder is absent). Notebook 00 is executed on the 60-clip folder without its
``new_joints/`` (optional in the layout): the GMD notebooks
(01, 02, 03, 06) read ``data_dir`` through ``gmd.windows.DataConfig`` alone and take minutes
each at the quick scale (train their models), too long for ``make test``; their windows are
loaded here instead. The EnergyMoGen notebooks cut 64-frame windows and need more of them
(``energymogen.settings.folder_needs``: the plan's validation clips and 32 training windows
besides, 32 test windows), which the 60-clip folder does not give — the validator and the
parameter check both say so; a 200-clip folder serves them, and all four (04, 05, 07, 08) are
executed on it in one run (≈ 95 s: the tiny pipeline trains once on the folder's windows).
EMG-1, 4, 7 and 9 are measured; EMG-2, 3, 5, 6 (compositions of the stand-in's labelled
concepts) and EMG-8 (fine-tuning on composed stand-in data) are recorded as not measurable
on real data.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from repro.claims.ledger import load_sidecars
from repro.energymogen.composed_augmentation.emg8 import AugmentationSettings
from repro.energymogen.data import build_folder_data, composition_items
from repro.energymogen.energy_contour_maps import EnergyViewSettings
from repro.energymogen.harness import oracle_accuracy
from repro.energymogen.latent_count.emg7 import LatentCountSettings, table8_markdown
from repro.energymogen.sef_ablation import common
from repro.energymogen.sef_ablation.common import SEFAblationSettings
from repro.energymogen.settings import FRAMES, folder_problems, pipeline_config
from repro.gmd.windows import DataConfig, load_windows
from repro.infra import paths
from repro.infra.context import RunContext
from repro.motion.features import features_to_joints
from repro.motion.humanml3d import validate_dataset
from repro.motion.usability import WindowNeeds, usability_problems
from repro.run import runner
from repro.run.params import check_standard_parameters, forget_checks, validate_parameters
from repro.standin.dataset import write_dataset

#: the EnergyMoGen notebooks, run on the 200-clip folder
EMG_NOTEBOOKS = ["04_energy_contour_maps", "05_sef_ablation", "07_latent_count",
                 "08_composed_augmentation"]
#: the shared real clips and the split each joins (012314 is a train clip of HumanML3D,
#: 000612 a test clip)
REAL_CLIPS = {"012314": ("new_joint_vecs/012314.npy", "train"),
              "000612": ("extra/000612.npy", "test")}


def _append(path: Path, clip: str) -> None:
    text = path.read_text(encoding="utf-8")
    path.write_text(text + ("" if not text or text.endswith("\n") else "\n") + clip + "\n",
                    encoding="utf-8")


def _add_real_clips(root: Path) -> None:
    """The shared real clips join ``root``'s splits where present and where they fit the
    loader's 40 ≤ T < 200 frames (their joints: HumanML3D's, else recovered from features)."""
    sample = paths.humanml3d_sample_dir()
    for clip, (source, split) in REAL_CLIPS.items():
        if not (sample / source).is_file():
            continue
        features = np.load(sample / source).astype(np.float32)
        if not 40 <= len(features) < 200:
            continue
        np.save(root / "new_joint_vecs" / f"{clip}.npy", features)
        joints = sample / "new_joints" / f"{clip}.npy"
        np.save(root / "new_joints" / f"{clip}.npy", np.load(joints) if joints.is_file() else
                features_to_joints(features.astype(np.float64)).astype(np.float32))
        (root / "texts" / f"{clip}.txt").write_text(
            "a person moves.#a/DET person/NOUN move/VERB#0.0#0.0\n", encoding="utf-8")
        _append(root / f"{split}.txt", clip)


def _without_labels(parent: Path, n_clips: int) -> Path:
    """A stand-in set of ``n_clips`` without ``labels/`` (and its ``dataset.json``), with the
    shared real clips added where present."""
    root = write_dataset(parent, n_clips=n_clips, seed=7)
    shutil.rmtree(root / "labels")
    (root / "dataset.json").unlink(missing_ok=True)
    _add_real_clips(root)
    return root


@pytest.fixture(scope="module")
def real_layout(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The GMD notebooks' folder: 60 stand-in clips without labels, the real clips added."""
    return _without_labels(tmp_path_factory.mktemp("real_layout"), 60)


def _copy(root: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(root, tmp_path / "copy"))


def _parameters(data_dir: Path, scale: str = "quick") -> dict[str, object]:
    return {"scale": scale, "seed": 0, "device": "cpu", "build_dir": None,
            "data_dir": str(data_dir)}


def test_the_real_layout_without_labels_is_valid_and_usable(real_layout: Path) -> None:
    assert not (real_layout / "labels").exists()
    assert [p for p in validate_dataset(real_layout) if p.severity == "error"] == []
    forget_checks()
    check_standard_parameters(_parameters(real_layout))


def test_the_shared_real_clips_join_the_folder_where_present(real_layout: Path) -> None:
    sample = paths.humanml3d_sample_dir()
    if not (sample / "new_joint_vecs" / "012314.npy").is_file():
        pytest.skip(f"{sample} not found: the real clips are not added")
    assert "012314" in (real_layout / "train.txt").read_text().split()
    assert "000612" in (real_layout / "test.txt").read_text().split()


def test_an_empty_test_split_is_rejected_by_both_checks(real_layout: Path,
                                                        tmp_path: Path) -> None:
    root = _copy(real_layout, tmp_path)
    (root / "test.txt").write_text("", encoding="utf-8")
    problems = [p for p in validate_dataset(root) if p.severity == "error"]
    assert [(p.path.name, p.kind) for p in problems] == [("test.txt", "split")]
    assert "lists no clips" in problems[0].message
    forget_checks()
    with pytest.raises(ValueError, match="test.txt: lists no clips"):
        check_standard_parameters(_parameters(root))


def test_a_split_the_loader_keeps_nothing_of_is_rejected(real_layout: Path,
                                                         tmp_path: Path) -> None:
    root = _copy(real_layout, tmp_path)
    short = np.load(root / "new_joint_vecs" / "000000.npy")[:20]
    np.save(root / "new_joint_vecs" / "short.npy", short)
    np.save(root / "new_joints" / "short.npy", np.load(root / "new_joints" / "000000.npy")[:20])
    (root / "texts" / "short.txt").write_text("a person stands.#a/DET#0.0#0.0\n")
    (root / "train.txt").write_text("short\n", encoding="utf-8")
    (root / "val.txt").write_text("", encoding="utf-8")  # no notebook reads val: allowed
    messages = [p.message for p in validate_dataset(root) if p.severity == "error"]
    assert len(messages) == 1 and "the loader keeps none" in messages[0]


def test_too_few_test_windows_for_the_scale_are_named(real_layout: Path) -> None:
    """The quick scale needs 8 test windows of 48 frames, the standard 64 (notebook 02's goal
    targets): the small folder serves the first and not the second."""
    forget_checks()
    check_standard_parameters(_parameters(real_layout, "quick"))
    with pytest.raises(ValueError, match="(?s)cannot be used at the standard scale.*windows of 48"):
        check_standard_parameters(_parameters(real_layout, "standard"))
    wanted = WindowNeeds(48, 24, {"test": 10_000})
    [(path, message)] = usability_problems(real_layout, wanted)
    assert path.name == "test.txt" and "at least 10000" in message


def test_the_gmd_windows_load_from_the_folder(real_layout: Path) -> None:
    config = DataConfig(data_dir=str(real_layout), frames=48, representation="relative")
    train = load_windows(config)
    test = load_windows(config, "test", statistics=(train.mean, train.std))
    assert len(train) > 0 and len(test) >= 8 and train.x.shape[1:] == (263, 48)


@pytest.mark.notebook
def test_notebook_00_runs_on_the_folder_without_new_joints(
        real_layout: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``new_joints/`` is optional: the validator accepts the folder without it, and notebook
    00 lists its clips from the features and recovers their joints."""
    root = _copy(real_layout, tmp_path)
    shutil.rmtree(root / "new_joints")
    forget_checks()
    check_standard_parameters(_parameters(root))
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    [result] = runner.run_notebooks(["00_stand_in_data"], scale="quick",
                                    extra_parameters={"data_dir": str(root)},
                                    log=lambda *_: None)
    assert result.ok, result.error
    text = Path(result.output).read_text(encoding="utf-8")
    assert text.count("not measurable on real data") >= 2
    assert f"{len(list((root / 'new_joint_vecs').glob('*.npy')))} clips; " in text


def test_validate_dataset_checks_the_windows_of_the_scale_it_is_given(
        real_layout: Path, emg_layout: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from repro.run.cli import main

    assert main(["validate-dataset", str(emg_layout), "--scale", "quick"]) == 0
    capsys.readouterr()
    # standard, as reproduce: notebook 00 shows the clips whole, notebook 01 cuts windows
    assert main(["validate-dataset", str(real_layout), "--notebook", "00"]) == 0
    capsys.readouterr()
    assert main(["validate-dataset", str(real_layout), "--notebook", "01"]) == 1
    assert "this scale's notebooks need at least 64" in capsys.readouterr().out
    # the small folder serves the GMD notebooks at quick, not the EnergyMoGen ones
    assert main(["validate-dataset", str(real_layout), "--scale", "quick",
                 "--notebook", "01", "--notebook", "06"]) == 0
    capsys.readouterr()
    assert main(["validate-dataset", str(real_layout), "--scale", "quick",
                 "--notebook", "04"]) == 1
    out = capsys.readouterr().out
    assert "cannot   04_energy_contour_maps" in out and "windows of 64 frames" in out


@pytest.fixture(scope="module")
def emg_layout(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The EnergyMoGen notebooks' folder: 200 stand-in clips without labels, the real clips
    added — enough 64-frame windows at the quick scale (about 185 train, 34 test)."""
    return _without_labels(tmp_path_factory.mktemp("emg_layout"), 200)


def test_the_emg_notebooks_check_the_folder_for_their_windows(real_layout: Path,
                                                              emg_layout: Path) -> None:
    forget_checks()
    validate_parameters("04_energy_contour_maps", _parameters(emg_layout))
    validate_parameters("01_x0_vs_eps", _parameters(real_layout))   # the GMD windows only
    with pytest.raises(ValueError, match="(?s)cannot be used at the quick scale.*windows of 64"):
        validate_parameters("04_energy_contour_maps", _parameters(real_layout))
    assert folder_problems(str(emg_layout), "quick") == []
    assert any("windows of 64" in p for p in folder_problems(str(real_layout), "quick"))
    # run by hand (setup_notebook names its notebook): the same per-family check
    check_standard_parameters(_parameters(real_layout), "01_x0_vs_eps")
    check_standard_parameters(_parameters(emg_layout), "04_energy_contour_maps")
    with pytest.raises(ValueError, match="(?s)cannot be used at the quick scale.*windows of 64"):
        check_standard_parameters(_parameters(real_layout), "04_energy_contour_maps")


def _folder_context(emg_layout: Path, tmp_path: Path) -> RunContext:
    return RunContext("quick", 0, torch.device("cpu"), 1, tmp_path, tmp_path / "cache",
                      data_dir=emg_layout)


@pytest.mark.parametrize("settings", [EnergyViewSettings, SEFAblationSettings,
                                      LatentCountSettings, AugmentationSettings])
def test_every_emg_notebook_takes_the_folder(settings: type, emg_layout: Path,
                                             tmp_path: Path) -> None:
    assert settings.for_run(_folder_context(emg_layout, tmp_path)) == settings.for_scale("quick")


def test_the_emg_pipeline_data_come_from_the_folder(emg_layout: Path) -> None:
    config = pipeline_config("quick")
    data = build_folder_data(config, str(emg_layout), validation_clips=16)
    assert not data.labelled and data.data_dir == str(emg_layout)
    assert data.train_features.shape[1:] == (FRAMES, 263)
    assert len(data.train_features) == config.n_train_clips and len(data.validation) == 16
    assert len(data.test_features) >= 32 and all(data.test_captions)
    assert not set(map(tuple, data.validation.features.reshape(16, -1)[:, :8].tolist())) & set(
        map(tuple, data.train_features.reshape(len(data.train_features), -1)[:, :8].tolist()))
    with pytest.raises(ValueError, match="not measurable on real data"):
        composition_items(data, 0, 2)


def test_the_oracle_columns_of_a_folder_read_not_measurable() -> None:
    """Notebook 07 on a folder (run by hand, not here: ≈ 30 s more): its test windows have no
    concepts, so the oracles' accuracy is NaN and Table 8 says so instead of a number."""
    assert np.isnan(oracle_accuracy(np.zeros((2, FRAMES, 22, 3)), [(), ()]))
    row = {"fid": [1.0, 1.2], "oracle_accuracy": [float("nan")] * 2}
    results = {"reconstruction": {"5": row}, "generation": {"5": row}, "real": row}
    table = table8_markdown(results, (5,), extra=(("oracle_accuracy", "oracle acc."),))
    assert table.count("not measurable on real data") == 3 and "nan" not in table
    # notebook 05's tables: a row run_rows left empty (it composes texts) and a NaN column
    rows = {"0.1,0.7,0.2": {}, "0.001,0.002": {"r_precision_top3": [12.5],
                                               "both_present": [float("nan")]}}
    table = common.markdown_table(rows, [("SEF", "0.1,0.7,0.2"), ("γ", "0.001,0.002")], {},
                                  [("r_precision_top3", "R@3"), ("both_present", "both")])
    assert table.count("not measurable on real data") == 3 and "12.5" in table


@pytest.mark.notebook
def test_the_emg_notebooks_run_on_the_folder(emg_layout: Path, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """Notebooks 04, 05, 07 and 08 in one quick run (≈ 95 s alone: 04 trains the tiny
    pipeline on the folder's windows, the others reuse it; 07 trains its N variants)."""
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    # one torch thread: make test runs two pytest workers on two cores (two threads each
    # measured 4× slower there)
    results = runner.run_notebooks(EMG_NOTEBOOKS, scale="quick", threads=1,
                                   extra_parameters={"data_dir": str(emg_layout)},
                                   log=lambda *_: None)
    assert [r.ok for r in results] == [True] * len(EMG_NOTEBOOKS), [r.error for r in results]
    text = Path(results[0].output).read_text(encoding="utf-8")
    assert text.count("not measurable on real data") >= 3
    claims = load_sidecars(tmp_path / "build" / "quick" / "claims")
    for claim in ("EMG-2", "EMG-3", "EMG-5", "EMG-6", "EMG-8"):   # compositions, composed data
        assert claims[claim]["not_measurable"].startswith("not measurable on real data")
        assert claims[claim]["measured"] == {} and claims[claim]["verdict"] == "inconclusive"
    for claim in ("EMG-1", "EMG-4", "EMG-7", "EMG-9"):   # what needs no concept is measured
        assert "not_measurable" not in claims[claim] and claims[claim]["measured"]
    assert f"Data folder {emg_layout}" in claims["EMG-4"]["notes"]
    assert len(claims["EMG-8"]["models"]) == 3   # the pretrained VAE, denoiser, evaluator
