"""Rules quote the run (registry v5): every claim's rule text is rendered from the settings its
experiment used, at every scale, from the paper packages' ``rule_settings`` of the Settings
objects the notebooks build (no model trained); no template types a setting a run could
change; every experiment that returns a ClaimResult passes its settings."""

from __future__ import annotations

import ast
import re
from pathlib import Path
from typing import Any

import pytest
from conftest import settings_classes

from repro.claims.claim import MissingRuleSetting, setting_text
from repro.claims.registry import CLAIMS, get_claim
from repro.energymogen import settings as emg_rules
from repro.gmd import guidance_schedule, x0_vs_eps
from repro.gmd import settings as gmd_rules
from repro.infra import paths
from repro.infra.context import SCALES

#: claim → the Settings class its notebook builds
SETTINGS: dict[str, Any] = settings_classes()
RULE_SETTINGS = {**gmd_rules.RULE_SETTINGS, **emg_rules.RULE_SETTINGS}


def test_every_claim_whose_rule_quotes_the_run_reads_it_from_its_settings() -> None:
    quoting = {c.id for c in CLAIMS.values() if c.rule_fields}
    assert quoting == set(RULE_SETTINGS) == set(SETTINGS)
    assert all(c.rule_fields for c in CLAIMS.values() if c.rests_on_effects)


@pytest.mark.parametrize("scale", SCALES)
@pytest.mark.parametrize("claim_id", sorted(RULE_SETTINGS))
def test_the_rendered_rule_contains_the_settings_of_its_run(claim_id: str, scale: str) -> None:
    settings = SETTINGS[claim_id].for_scale(scale)
    used = RULE_SETTINGS[claim_id](settings)
    claim = get_claim(claim_id)
    assert set(claim.rule_fields) <= set(used), claim_id
    rule = claim.render_rule(used)
    for name in claim.rule_fields:
        assert setting_text(used[name]) in rule, (claim_id, scale, name)
    assert not any(f"{{{name}}}" in rule for name in claim.rule_fields), rule
    if "seeds" in used:
        assert used["seeds"] == settings.seeds or used["seeds"] == getattr(
            settings, "motion_seeds", None)


@pytest.mark.parametrize(("scale", "steps", "stop"), [("quick", 50, 1), ("standard", 100, 2),
                                                      ("paper", 1000, 20)])
def test_gmd_guidance_rules_say_the_t_and_stop_step_the_run_used(scale: str, steps: int,
                                                                 stop: int) -> None:
    """GMD-A3's and F1's rule once typed T = 1000 and t = 20 whatever the run did; the
    standard scale runs T = 100 and stops at t = 2."""
    a3 = get_claim("GMD-A3").render_rule(gmd_rules.a3(x0_vs_eps.Settings.for_scale(scale)))
    assert f"T = {steps} cosine" in a3 and f"while t ≥ {stop} " in a3
    f1 = get_claim("GMD-F1").render_rule(
        gmd_rules.f1(guidance_schedule.Settings.for_scale(scale)))
    assert f"T = {steps}, stops at t = 0 and {stop} of {steps}" in f1


def test_no_template_types_a_setting_a_run_can_change() -> None:
    typed = re.compile(r"T\s*=\s*\d|t\s*[=≥]\s*[1-9]|\b\d+ seeds\b|s\s*=\s*100\b|±6\b|scale 2\.5")
    for claim in CLAIMS.values():
        found = typed.findall(claim.rule)
        assert not found, f"{claim.id}: {found} typed in the rule; quote the run's setting"


def test_a_result_without_a_setting_its_rule_quotes_is_refused_by_name(tmp_path: Path) -> None:
    from conftest import make_context

    from repro.claims.result import ClaimResult, record

    claim = get_claim("GMD-A3")
    measured = claim.planted_example(__import__("numpy").random.default_rng(0), 3)
    used = gmd_rules.a3(x0_vs_eps.Settings.for_scale("standard"))
    with pytest.raises(MissingRuleSetting, match=r"GMD-A3: .*stop_step"):
        record(make_context(tmp_path), ClaimResult(
            "GMD-A3", measured, seeds=[0, 1, 2],
            settings={k: v for k, v in used.items() if k != "stop_step"}))
    assert not (tmp_path / "claims" / "GMD-A3.json").exists()   # nothing written


def _claim_result_calls(path: Path) -> list[ast.Call]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [node for node in ast.walk(tree) if isinstance(node, ast.Call)
            and getattr(node.func, "id", None) in ("ClaimResult", "not_measurable_result")]


def test_every_experiment_passes_the_settings_its_rule_quotes() -> None:
    """Each ClaimResult (and not-measurable result) of a claim whose rule quotes the run
    passes ``settings=`` read from its rule_settings function."""
    checked = set()
    for package in ("gmd", "energymogen"):
        for path in sorted((paths.REPO_ROOT / "src" / "repro" / package).rglob("*.py")):
            for call in _claim_result_calls(path):
                first = call.args[0] if call.args else None
                ids = [first.value] if isinstance(first, ast.Constant) else []
                keywords = {k.arg: k.value for k in call.keywords}
                for claim_id in ids:
                    if not get_claim(claim_id).rule_fields:
                        continue
                    assert "settings" in keywords, f"{path.name}:{call.lineno} {claim_id}"
                    assert "rule_settings" in ast.unparse(keywords["settings"]) or isinstance(
                        keywords["settings"], ast.Name), f"{path.name}:{call.lineno}"
                    checked.add(claim_id)
    assert checked == set(RULE_SETTINGS)
