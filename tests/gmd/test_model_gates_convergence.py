"""GMD-A4's budget records: training summaries, the longer ε run's gate values, the table."""

from __future__ import annotations

from repro.gmd import model_gates as mg
from repro.gmd.models import load_or_train_gmd, longer_run
from repro.gmd.windows import load_windows


def test_budget_table_reports_steps_stops_and_gates(cache, small_spec, small_config) -> None:
    train = load_windows(small_config())
    test = load_windows(small_config(), "test", statistics=(train.mean, train.std))
    spec = small_spec(task="motion", prediction="epsilon", steps=2, validate_every=1)
    plain = load_or_train_gmd(small_spec(task="motion", prediction="x0", steps=2), train)
    short = load_or_train_gmd(spec, train)
    longer = load_or_train_gmd(longer_run(spec), train)
    assert mg.training_summary(plain) == {"steps_used": 2, "step_cap": 2, "converged": None,
                                          "stop_reason": None}
    assert mg.training_summary(longer)["steps_used"] == 4 == mg.training_summary(longer)[
        "step_cap"]
    assert mg.training_summary(short)["stop_reason"] in ("plateau", "step cap")

    values = mg.denoising_gate_values(longer, test, train, seed=0)
    assert set(values) == {"x0_error_vs_gaussian"}
    assert values == mg.denoising_gate_values(longer, test, train, seed=0)
    passing = mg.gmd_model_record(longer, family="gmd_motion", role="treatment",
                                  values={"x0_error_vs_gaussian": 0.5})
    failing = mg.gmd_model_record(short, family="gmd_motion", role="treatment",
                                  values={"x0_error_vs_gaussian": 1.5})
    table = mg.budget_markdown({"ε": [short], "ε, 2× cap": [longer]},
                               {"ε": [failing], "ε, 2× cap": [passing]})
    assert "| ε, 2× cap | 0 | 4 | 4 | step cap | 0.5 | pass |" in table
    assert "ε: 0 of 1 seeds; ε, 2× cap: 1 of 1 seeds" in table
