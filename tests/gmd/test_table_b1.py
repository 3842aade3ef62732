"""Table B.1 on stand-in data (GMD-B3): window concepts, the paper's rows, the ledger layout."""

from __future__ import annotations

from repro.gmd import measurements as B


def test_window_concepts() -> None:
    sequential = {"composition": "sequential", "concepts": ["clap", "walk_forward"],
                  "segments": [{"concept": "clap", "start": 0, "end": 46},
                               {"concept": "walk_forward", "start": 46, "end": 90}]}
    assert B.window_concepts(sequential, 0, 48) == {"clap"}
    assert B.window_concepts(sequential, 22, 48) == {"walk_forward", "clap"}
    assert B.window_concepts(sequential, 24, 48) == {"walk_forward"}
    assert B.window_concepts(sequential, 42, 48) == {"walk_forward"}
    single = {"composition": "simultaneous", "concepts": ["wave_left", "walk_forward"]}
    assert B.window_concepts(single, 30, 48) == {"wave_left", "walk_forward"}


def test_paper_table_matches_the_registry() -> None:
    from repro.claims.registry import get_claim

    value = get_claim("GMD-B3").paper_value
    for row in ("Ours (rel)", "Ours (abs)"):
        for number in B.PAPER_TABLE_B1[row]:
            assert f"{number:g}" in value


def test_registered_measurements_use_the_short_labels() -> None:
    row = {"fid": 1.0, "r_precision_top3": 0.5, "diversity": 2.0, "concept_recall": 0.1}
    rows = {"relative": [row, {**row, "fid": 3.0}], "absolute": [{**row, "fid": 2.0}] * 2}
    measured = B.registered_measurements({"diversity": 9.0}, rows)
    assert measured["fid_rel"] == [1.0, 3.0] and measured["fid_abs"] == [2.0, 2.0]
    assert measured["diversity_real"] == 9.0 and len(measured) == 7
    assert list(B.by_label(rows)) == ["rel", "abs"]
    table = B.table_b1_markdown({"fid": 0.1, "r_precision_top3": 0.9, "diversity": 9.0,
                                 "concept_recall": 0.8}, rows)
    assert "| tiny GMD (rel) | 2.000 ± " in table and "| tiny GMD (abs) | 2.000 ± 0.000" in table
