"""Every claim sidecar of notebooks 01 and 06 records the diffusion settings it ran under
(``extra["parameters"]``: num_timesteps, guidance_stop_t, x0_clamp; issue #17)."""

from __future__ import annotations

import ast

import nbformat
import pytest

from repro.infra import paths

KEYS = {"num_timesteps", "guidance_stop_t", "x0_clamp"}


def _record_claim_calls(source: str) -> list[ast.Call]:
    tree = ast.parse(source)
    return [node for node in ast.walk(tree) if isinstance(node, ast.Call)
            and getattr(node.func, "id", None) == "record_claim"]


def _extra(call: ast.Call, assignments: dict[str, ast.expr]) -> ast.expr:
    extra = next(k.value for k in call.keywords if k.arg == "extra")
    return assignments.get(extra.id, extra) if isinstance(extra, ast.Name) else extra


# notebook 06 records a ClaimResult built by gmd.schedule_study.f1_result, whose
# extra["parameters"] tests/gmd/test_schedule_study.py checks
@pytest.mark.parametrize("name", ["01_x0_vs_eps"])
def test_every_sidecar_records_the_guidance_parameters(name: str) -> None:
    notebook = nbformat.read(paths.notebooks_dir() / f"{name}.ipynb", as_version=4)
    source = "\n".join(c.source for c in notebook.cells if c.cell_type == "code"
                       and not c.source.lstrip().startswith(("%", "!")))
    tree = ast.parse(source)
    assignments = {t.id: node.value for node in ast.walk(tree) if isinstance(node, ast.Assign)
                   for t in node.targets if isinstance(t, ast.Name)}
    calls = _record_claim_calls(source)
    assert calls
    for call in calls:
        extra = _extra(call, assignments)
        assert isinstance(extra, ast.Dict), ast.unparse(call)[:80]
        keys = {k.value for k in extra.keys if isinstance(k, ast.Constant)}
        assert "parameters" in keys, ast.unparse(call)[:80]
        value = extra.values[[getattr(k, "value", None) for k in extra.keys].index("parameters")]
        value = assignments.get(value.id, value) if isinstance(value, ast.Name) else value
        if isinstance(value, ast.Dict):
            assert {k.value for k in value.keys} == KEYS
        else:  # built by guidance_parameters, whose keys tests/gmd/test_x0_vs_eps.py checks
            assert "guidance_parameters" in ast.unparse(value)
