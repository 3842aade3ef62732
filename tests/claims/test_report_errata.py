"""docs/ERRATA.md: every entry complete, every claim and test it names exists, every number in
a Numbers field printed in its paper (``claims.printed``), and the facts about the papers'
printed text that no other test checks (EnergyMoGen Eq. 3's K′, the rows of Tables 3, 7 and
9)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from repro.claims import printed
from repro.claims.errata import errata_markdown, load_errata, parse_errata
from repro.claims.pages import markdown_html
from repro.claims.registry import CLAIMS
from repro.energymogen.sef_ablation import common
from repro.infra import paths


def test_every_entry_is_complete_and_names_claims_and_tests_that_exist() -> None:
    entries = load_errata()
    assert entries is not None and len(entries) == 29
    for entry in entries:
        assert set(entry.claim_ids) <= set(CLAIMS), entry.title
        assert entry.tests, entry.title
        for path, name in entry.tests:
            source = (paths.REPO_ROOT / path).read_text(encoding="utf-8")
            assert re.search(rf"^def {name}\(", source, re.M), f"{path}::{name}"
        assert ("Open question" in entry.fields) == entry.is_open, entry.title
        assert entry.fields["Claim impact"], entry.title
    assert sum(e.is_open for e in entries) == 5
    # the audit's coverage section ends the entries: its table headings are no errata
    assert not any(e.title.startswith(("GMD appendix (seed", "EnergyMoGen (seed"))
                   for e in entries)


#: where a number is printed ("Sec. 5.2", "Table B.1"): not a printed value
_PLACE = re.compile(r"\b(?:Sec\.|Table|Eq\.|appendix)\s+[\w.]*\w")
#: a printed number in a Numbers field: a decimal, or an integer of three or more digits
_PRINTED_NUMBER = re.compile(r"(?<![\w.])(?:\d+\.\d+|\d{1,3}(?:,\d{3})+|\d{3,})(?![\w.])")


def _printed_strings(paper: str) -> set[str]:
    """Every value, interval and quoted number ``claims.printed`` holds for ``paper``."""
    found = set()
    for table in printed.TABLES.values():
        if table.paper != paper:
            continue
        for row in table.rows:
            for i, cell in enumerate(row.cells):
                if cell:
                    number, interval, _ = row.parsed(i)
                    found |= {number, *([interval.strip()] if interval else [])}
    for quote in printed.QUOTES.values():
        if quote.paper == paper:
            found |= set(_PRINTED_NUMBER.findall(quote.text))
    return found


def test_every_number_in_a_numbers_field_is_printed_in_its_paper() -> None:
    entries = load_errata()
    assert entries is not None
    with_numbers = [e for e in entries if "Numbers" in e.fields]
    assert len(with_numbers) >= 9
    for entry in with_numbers:
        paper = "GMD" if entry.fields["Paper"].startswith("GMD") else "EnergyMoGen"
        numbers = _PRINTED_NUMBER.findall(_PLACE.sub("", entry.fields["Numbers"]))
        assert numbers, entry.title
        unprinted = set(numbers) - _printed_strings(paper)
        assert not unprinted, (entry.title, unprinted)
    assert "0.305" in _printed_strings("GMD") and "0.306" not in _printed_strings("GMD")


def test_the_report_section_renders_each_entry(tmp_path) -> None:
    entries = load_errata()
    assert entries is not None
    assert load_errata(tmp_path / "missing.md") is None
    assert "is missing: no errata listed." in "\n".join(errata_markdown(None))
    text = "\n".join(errata_markdown(entries))
    assert text.count("\n- **") == len(entries)
    assert "*Open question:*" in text and "*Correction:*" in text
    assert text.count("*Claim impact:*") == len(entries)
    assert "*Inconsistency:*" in text and "table by table" in text
    page = markdown_html(text)   # REPORT.html renders the same Markdown
    assert page.count("<li>") == len(entries) and "<em>Claim impact:</em>" in page


_ENTRY = ("## Eq. 1\n- **Paper:** X\n- **Printed:** a\n- **Numbers:** 1.5\n"
          "- **Inconsistency:** c\n- **Correction:** b\n- **Claim impact:** none\n"
          "- **Status:** corrected\n- **Shown by:** GMD-A1\n")


def test_an_entry_without_its_fields_is_refused() -> None:
    with pytest.raises(ValueError, match="missing Printed, Claim impact, Status, Shown by"):
        parse_errata("## Eq. 1\n\n- **Paper:** X\n- **Correction:** y\n")
    with pytest.raises(ValueError, match="unknown field"):
        parse_errata("## Eq. 1\n\n- **Papr:** X\n")
    with pytest.raises(ValueError, match="status must start"):
        parse_errata(_ENTRY.replace("corrected", "fixed"))
    with pytest.raises(ValueError, match="missing Claim impact"):
        parse_errata(_ENTRY.replace("- **Claim impact:** none\n", ""))


def test_entries_end_at_the_next_level_one_heading() -> None:
    text = ("# Paper errata\n\nintro\n\n" + _ENTRY
            + "\n# What the audit read\n\n## Table 1\n\nrows\n")
    (entry,) = parse_errata(text)
    assert entry.fields["Numbers"] == "1.5" and entry.fields["Inconsistency"] == "c"
    assert entry.claim_ids == ["GMD-A1"]
    both = parse_errata(_ENTRY.replace("Claim impact:** none", "Claim impact:** EMG-5: none"))
    assert both[0].claim_ids == ["GMD-A1", "EMG-5"]


def test_eq3_k_prime_as_printed_cannot_left_multiply_k() -> None:
    """K′ = ½ Σ_i k_i k_iᵀ over the rows k_i of K (N × d) is d × d (or a scalar), so
    M(SFM(K′))K is undefined; the N-vector ½‖k_i‖² gives the gradient of logsumexp_i(½‖k_i‖²)."""
    rng = np.random.default_rng(0)
    n, d = 5, 3
    keys = rng.standard_normal((n, d))
    k_prime = 0.5 * sum(np.outer(k, k) for k in keys)
    assert k_prime.shape == (d, d)
    assert np.isclose(0.5 * sum(k @ k for k in keys), np.trace(k_prime))  # the scalar reading
    with pytest.raises(ValueError):
        np.diag(np.exp(k_prime).sum(axis=0)) @ keys  # a d×d diagonal cannot left-multiply N×d
    half_norms = 0.5 * (keys**2).sum(axis=1)
    softmax = np.exp(half_norms - half_norms.max())
    softmax /= softmax.sum()
    regulariser = np.diag(softmax) @ keys

    def energy(k: np.ndarray) -> float:
        return float(np.log(np.exp(0.5 * (k**2).sum(axis=1)).sum()))

    step = 1e-6
    numeric = np.zeros_like(keys)
    for index in np.ndindex(keys.shape):
        shifted = keys.copy()
        shifted[index] += step
        numeric[index] = (energy(shifted) - energy(keys)) / step
    np.testing.assert_allclose(regulariser, numeric, atol=1e-4)


def test_sef_rows_of_tables_3_and_7_differ_only_in_r_at_1() -> None:
    table3, table7 = common.PAPER_TABLE3["SEF"], common.PAPER_TABLE7["0.1,0.7,0.2"]
    differing = sorted(k for k in table7 if table3[k] != table7[k])
    assert differing == ["r_precision_top1"]
    assert (table3["r_precision_top1"], table7["r_precision_top1"]) == (15.9, 15.7)
    # the erratum says no verdict reads R@1
    assert not any("top1" in name for claim in CLAIMS.values() for name in claim.measurements)


def test_table_7_multi_concept_row_is_table_3_without_agd() -> None:
    multi = common.PAPER_TABLE7["0.0,0.0,1.0"]
    assert multi == common.PAPER_TABLE3["single text"] == common.PAPER_TABLE9["0.0,0.0"]
    assert multi != common.PAPER_TABLE3["single text + AGD"]
    assert common.PAPER_TABLE7["0.0,1.0,0.0"] == common.PAPER_TABLE3["semantic only"]
