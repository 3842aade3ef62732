"""Notebook parameters checked before any kernel starts.

Names, defaults and annotated types come from each notebook's ``parameters`` cell (papermill's
``inspect_notebook``); a value must have the type of the annotation or, without one, of the
default (``n_seeds = 3`` takes an int). :data:`RULES` adds the ranges and the checks a type
cannot say (a seed is ≥ 0, a data folder exists and passes ``validate-dataset``, a device
exists here). The runner alone sets ``scale``, ``build_dir``, ``seed`` and ``device`` (from
``--scale``/``--quick``, its staging folder, ``--seed`` and ``--device``), so ``-p`` cannot
send one scale's output into another scale's folder.

These are the only checks of a parameter: the runner makes them (:func:`validate_parameters`)
before any kernel starts; a notebook run by hand makes the same ones in
``run.notebook.setup_notebook`` (:func:`check_standard_parameters`).
"""

from __future__ import annotations

import ast
import functools
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from repro.infra import paths
from repro.infra.context import scale_problem, seed_problem
from repro.motion.usability import WindowNeeds

STANDARD_PARAMETERS = ("scale", "seed", "device", "build_dir")
SET_BY_RUNNER = {
    "scale": "the scale is set by --scale (or --quick) alone: one scale's output never enters "
             "another's folder",
    "build_dir": "the runner writes each notebook into its run's staging folder",
    "seed": "use --seed (the base seed is part of the run ID)",
    "device": "use --device",
}

_TYPE_NAMES: dict[str, type] = {"bool": bool, "int": int, "float": float, "str": str,
                                "None": type(None), "NoneType": type(None), "list": list,
                                "dict": dict}


@dataclass(frozen=True)
class Rule:
    """What a parameter's value must satisfy beyond its type; ``check`` returns a problem."""

    types: tuple[type, ...]
    check: Callable[[Any], str | None] | None = None


def _at_least(minimum: int) -> Callable[[Any], str | None]:
    def check(value: Any) -> str | None:
        return None if value is None or value >= minimum else f"must be at least {minimum}"
    return check


def _device_problem(value: Any) -> str | None:
    import torch

    try:
        device = torch.device(value)
    except (RuntimeError, TypeError) as error:
        return f"is not a torch device ({error})"
    if device.type == "cuda" and not torch.cuda.is_available():
        return "names CUDA, which is not available here"
    if device.type not in ("cpu", "cuda"):
        return "must be cpu, cuda or cuda:N"
    return None


def resolve_device(device: str) -> str:
    """``--device``'s value as the notebooks take it: ``auto`` is ``cuda`` when torch sees a
    GPU on this machine, else ``cpu`` (decided where the run happens: a workflow job on a
    GPU node or on a laptop); any other value as given, checked with the parameters."""
    if device != "auto":
        return device
    import torch

    return "cuda" if torch.cuda.is_available() else "cpu"


def _data_dir_problem(value: Any) -> str | None:
    if value is None:
        return None
    return _dataset_problem(str(Path(value).expanduser().resolve()))


@functools.lru_cache(maxsize=8)
def _dataset_problem(resolved: str) -> str | None:
    """One validation per folder and run (``forget_checks`` at the start of each run)."""
    from repro.motion.humanml3d import format_problems, validate_dataset

    folder = Path(resolved)
    if folder.exists() and not folder.is_dir():
        return (f"is a file, not a folder ({folder}): give the HumanML3D-layout folder that "
                "holds new_joint_vecs/, texts/ and the split files")
    if not folder.is_dir():
        return f"is not a folder ({folder} does not exist)"
    try:
        problems = [p for p in validate_dataset(folder) if p.severity == "error"]
    except Exception as error:  # the validator names every file it can read; not this one
        return (f"could not be validated: the validator failed with {type(error).__name__}: "
                f"{error} (a bug of the validator: please report it with the folder)")
    if problems:
        return (f"is not a valid HumanML3D-layout folder:\n{format_problems(problems)}\n"
                f"(python -m repro validate-dataset {folder} shows the same)")
    return None


def window_needs(scale: str) -> WindowNeeds:
    """What the GMD notebooks of ``scale`` cut from a data folder, as their claim groups state
    it (``gmd.x0_vs_eps.window_needs``: notebook 01's longest windows;
    ``gmd.root_representation.window_needs``: as many test windows as notebook 02 draws goal
    targets from): the longest windows and, per split, the most windows any of them needs."""
    from repro.gmd import root_representation, x0_vs_eps

    needs = (x0_vs_eps.window_needs(scale), root_representation.window_needs(scale))
    if len({n.stride for n in needs}) != 1:
        raise ValueError(f"the GMD notebooks cut windows at different strides: {needs}")
    splits = dict.fromkeys(split for n in needs for split in n.windows)
    return WindowNeeds(max(n.frames for n in needs), needs[0].stride,
                       {split: max(n.windows.get(split, 0) for n in needs) for split in splits})


def emg_window_needs(scale: str) -> WindowNeeds:
    """What the EnergyMoGen notebooks of ``scale`` cut from a data folder
    (``energymogen.settings.folder_needs``)."""
    from repro.energymogen.settings import folder_needs

    return folder_needs(scale)


#: The notebook that shows a folder's clips whole (statistics, skeletons, conformance): it
#: cuts no windows, so a valid layout with usable splits is all it needs.
WHOLE_CLIPS_NOTEBOOK = "00_stand_in_data"


def needs_of(name: str | None, scale: str) -> WindowNeeds | None:
    """The windows notebook ``name`` cuts at ``scale``: :func:`emg_window_needs` for an
    EnergyMoGen notebook, None (no windows) for :data:`WHOLE_CLIPS_NOTEBOOK`, else (and
    without a name: a notebook run by hand, whose EnergyMoGen settings check the rest
    themselves) :func:`window_needs`."""
    from repro.energymogen.settings import NOTEBOOKS

    if name == WHOLE_CLIPS_NOTEBOOK:
        return None
    return emg_window_needs(scale) if name in NOTEBOOKS else window_needs(scale)


def notebook_acceptance(folder: str | os.PathLike, scale: str,
                        notebooks: Sequence[str]) -> dict[str, list[str]]:
    """notebook → why it cannot use ``folder`` at ``scale`` ([] when it can): the checks
    ``reproduce`` makes before a kernel starts (:func:`needs_of`), for a folder whose layout
    ``motion.humanml3d.validate_dataset`` found valid."""
    from repro.motion.usability import usability_problems

    return {name: [f"{path}: {message}"
                   for path, message in usability_problems(folder, needs_of(name, scale))]
            for name in notebooks}


@functools.lru_cache(maxsize=8)
def _usability_problem(resolved: str, scale: str, name: str | None = None) -> str | None:
    """Whether notebook ``name`` (None: the GMD notebooks) of ``scale`` can use a valid folder
    (one check per folder, scale, notebook family and run)."""
    from repro.motion.usability import usability_problems

    problems = usability_problems(resolved, needs_of(name, scale))
    if not problems:
        return None
    return (f"cannot be used at the {scale} scale:\n"
            + "\n".join(f"  {path}: {message}" for path, message in problems)
            + f"\n(python -m repro validate-dataset {resolved} --scale {scale} shows the same)")


def _scale_problems(parameters: dict[str, Any], name: str | None = None) -> list[str]:
    """data_dir against what notebook ``name`` cuts at its scale (after the per-value checks
    passed)."""
    from repro.energymogen.settings import NOTEBOOKS

    folder, scale = parameters.get("data_dir"), parameters.get("scale", "standard")
    if not isinstance(folder, str) or scale_problem(scale) is not None:
        return []
    family = name if name in NOTEBOOKS or name == WHOLE_CLIPS_NOTEBOOK else None
    problem = _usability_problem(str(Path(folder).expanduser().resolve()), scale, family)
    return [] if problem is None else [f"data_dir {problem}"]


RULES: dict[str, Rule] = {
    "scale": Rule((str,), scale_problem),
    "seed": Rule((int,), seed_problem),
    "device": Rule((str,), _device_problem),
    "build_dir": Rule((str, type(None))),
    "data_dir": Rule((str, type(None)), _data_dir_problem),
    "n_seeds": Rule((int,), _at_least(1)),
    "train_steps": Rule((int, type(None)), _at_least(1)),
}


def declared_types(entry: dict[str, Any]) -> tuple[type, ...] | None:
    """The types papermill's inspection gives for one parameter: its annotation
    (``inferred_type_name``, e.g. "int | None"), else the type of its literal default (None
    for a default of None: any type)."""
    annotation = str(entry.get("inferred_type_name") or "None")
    if annotation != "None":
        names = [part.strip() for part in annotation.replace("Optional[", "").strip("]")
                 .split("|")]
        types = tuple(_TYPE_NAMES[n] for n in names if n in _TYPE_NAMES)
        if types:
            return types
    try:
        default = ast.literal_eval(str(entry.get("default")))
    except (ValueError, SyntaxError):
        return None
    if default is None:
        return None
    return (float, int) if isinstance(default, float) else (type(default),)


def _type_matches(value: Any, types: tuple[type, ...]) -> bool:
    if isinstance(value, bool) and bool not in types:
        return False  # True is an int to Python, not to a reader of the notebook
    return isinstance(value, types)


def _type_text(types: tuple[type, ...]) -> str:
    return " or ".join("None" if t is type(None) else t.__name__ for t in types)


def value_problems(name: str, value: Any, entry: dict[str, Any]) -> list[str]:
    """Why ``value`` does not fit parameter ``name`` (declared as ``entry``); [] if it does."""
    rule = RULES.get(name)
    types = rule.types if rule else declared_types(entry)
    if types is not None and not _type_matches(value, types):
        default = f" (the notebook's default is {entry['default']})" if "default" in entry else ""
        return [f"parameter {name} must be {_type_text(types)}{default}, got {value!r} "
                f"({type(value).__name__})"]
    if rule and rule.check:
        problem = rule.check(value)
        if problem:
            return [f"parameter {name}={value!r} {problem}"]
    return []


def notebook_parameters(name: str) -> dict[str, Any]:
    """The parameters a notebook declares (papermill's inspection of its tagged cell)."""
    import papermill

    path = paths.notebooks_dir() / f"{name}.ipynb"
    if not path.is_file():
        raise ValueError(f"no notebook {path}")
    declared = papermill.inspect_notebook(str(path))
    if not declared:
        raise ValueError(f"notebook {name} has no cell tagged 'parameters'")
    return declared


def forget_checks() -> None:
    """Forget the dataset folders validated so far (the runner calls this per run)."""
    _dataset_problem.cache_clear()
    _usability_problem.cache_clear()


#: parameters naming a folder: a relative one is read from the caller's working folder, so the
#: runner makes it absolute before validating it (the kernels run in notebooks/)
FOLDER_PARAMETERS = ("data_dir",)


def absolute_folders(extra: dict[str, Any]) -> dict[str, Any]:
    """``extra`` with every folder parameter (a string) made absolute against the working
    folder, ``~`` expanded."""
    return {name: str(Path(value).expanduser().resolve())
            if name in FOLDER_PARAMETERS and isinstance(value, str) else value
            for name, value in extra.items()}


def check_extra_parameters(extra: dict[str, Any]) -> None:
    """Refuse ``-p`` values for what the runner sets itself."""
    reserved = [f"{name} ({SET_BY_RUNNER[name]})" for name in extra if name in SET_BY_RUNNER]
    if reserved:
        raise ValueError(f"-p cannot set {'; '.join(reserved)}")


def check_standard_parameters(parameters: dict[str, Any], notebook: str | None = None) -> None:
    """Raise ValueError naming every problem of the standard parameters a notebook run by hand
    passes to ``setup_notebook`` (the runner's checks of :data:`RULES`, with no notebook file
    to inspect); a data folder is checked against the windows of ``notebook``'s family
    (:func:`needs_of`; None: the GMD notebooks')."""
    problems = [problem for key, value in parameters.items()
                for problem in value_problems(key, value, {})]
    problems = problems or _scale_problems(parameters, notebook)
    if problems:
        raise ValueError("; ".join(problems))


def validate_parameters(name: str, parameters: dict[str, Any]) -> None:
    """Raise ValueError naming every problem: unknown names, missing standard parameters, and
    values of the wrong type or out of range."""
    declared = notebook_parameters(name)
    unknown = sorted(set(parameters) - set(declared))
    if unknown:
        raise ValueError(f"notebook {name} has no parameter(s) {unknown}; it declares "
                         f"{sorted(declared)}")
    missing = sorted(set(STANDARD_PARAMETERS) - set(declared))
    if missing:
        raise ValueError(f"notebook {name} must declare the standard parameters {missing}")
    problems = [problem for key, value in parameters.items()
                for problem in value_problems(key, value, declared[key])]
    problems = problems or _scale_problems(parameters, name)
    if problems:
        raise ValueError(f"notebook {name}: " + "; ".join(problems))
