"""The arithmetic of each audit erratum in docs/ERRATA.md, on the printed values of
``claims.printed`` (which tests/claims/test_printed.py checks against the seeds' text)."""

from __future__ import annotations

import numpy as np
import pytest

from repro.claims.printed import QUOTES, get_table, value
from repro.claims.seed_text import normalise, seed_text
from repro.core.metrics import mm_distance

EMG = "EnergyMoGen"


def _quoted(key: str) -> str:
    """The quote as ``claims.printed`` holds it (tests/claims/test_printed.py checks every
    quote against the seed, where ../shared is beside the clone)."""
    return normalise(QUOTES[key].text)


def test_table_b1_our_rows_trade_nothing_mdm_rows_trade_fid_for_r_precision() -> None:
    assert "trade-off between the FID and R-precision" in _quoted("gmd.B.trade_off")
    b1 = get_table("GMD", "Table B.1")
    real = b1.value("Real", "Diversity")

    def change(model: str) -> dict[str, float]:
        """abs − rel, signed so that positive is better, per column."""
        rel, ab = f"{model} (rel)" if model == "Ours" else f"{model} [10] (rel)", (
            f"{model} (abs)" if model == "Ours" else f"{model} [10] (abs)")
        return {"FID": b1.value(rel, "FID") - b1.value(ab, "FID"),
                "R@3": b1.value(ab, "R@3") - b1.value(rel, "R@3"),
                "Diversity": abs(b1.value(rel, "Diversity") - real)
                - abs(b1.value(ab, "Diversity") - real)}

    ours, mdm = change("Ours"), change("MDM")
    assert all(v > 0 for v in ours.values())  # better on every column: no trade-off
    assert mdm["FID"] < 0 and mdm["Diversity"] < 0 and mdm["R@3"] > 0  # MDM's is one
    assert round(ours["R@3"], 3) == 0.004
    assert [round(abs(b1.value(r, "Diversity") - real), 3) for r in
            ("Ours (rel)", "Ours (abs)", "MDM [10] (rel)", "MDM [10] (abs)")] == [
        0.358, 0.063, 0.057, 0.684]


def test_architecture_alone_does_not_halve_fid_like_for_like() -> None:
    assert "(0.556 vs 0.212)" in _quoted("gmd.D.more_than_half")
    fid = get_table("GMD", "Table B.1").column("FID")
    assert (fid["MDM [10] (rel)"], fid["Ours (abs)"]) == (0.556, 0.212)  # the quoted pair
    reduction = {"quoted": 1 - fid["Ours (abs)"] / fid["MDM [10] (rel)"],
                 "rel": 1 - fid["Ours (rel)"] / fid["MDM [10] (rel)"],
                 "abs": 1 - fid["Ours (abs)"] / fid["MDM [10] (abs)"]}
    assert reduction["quoted"] > 0.5 and reduction["abs"] > 0.5
    assert reduction["rel"] < 0.5  # like for like with the relative root: less than half
    assert [round(100 * reduction[k], 1) for k in ("rel", "abs")] == [45.1, 76.3]


def test_eq5_coefficient_on_eps_is_far_from_one_where_beta_is_small() -> None:
    assert "for small β_t" in _quoted("emg.3.2.eq5")
    assert "$\\eta = 1$" in _quoted("emg.3.2.eta")
    steps = 1000
    s = np.arange(steps + 1)
    f = np.cos(((s / steps + 0.008) / 1.008) * np.pi / 2) ** 2
    beta = np.minimum(1 - f[1:] / f[:-1], 0.999)
    alpha = 1 - beta
    alpha_bar = np.cumprod(alpha)
    eps_coefficient = beta / (np.sqrt(alpha) * np.sqrt(1 - alpha_bar))
    small = beta < 0.01
    assert small.sum() == 807
    assert 0.0031 < eps_coefficient[small].min() and eps_coefficient[small].max() < 0.0105
    # the mean μ = (z − coefficient·√α·ε)/√α is the DDPM posterior mean from ε
    eta, kappa = beta / np.sqrt(alpha), (1 - np.sqrt(alpha)) / beta
    z, eps = 0.7, -0.3
    for t in (3, 400, 800):
        mean = (z - beta[t] / np.sqrt(1 - alpha_bar[t]) * eps) / np.sqrt(alpha[t])
        langevin = z - eta[t] * (eps / np.sqrt(1 - alpha_bar[t]) - kappa[t] * z)
        assert np.isclose(mean, langevin)
    assert np.isclose(kappa[0], 0.5, atol=1e-4)


def test_table_2_energymogen_row_against_the_sentence() -> None:
    assert "significantly improves the text-condition consistency and diversity" in _quoted(
        "emg.5.3.improves")
    t2 = get_table(EMG, "Table 2")
    methods = [t2.row_name(r) for r in t2.rows if t2.row_name(r) != "Real motion"]
    ours = "ENERGYMOGEN*"
    for column in ("R@1", "R@2", "R@3"):
        assert t2.value(ours, column) == max(t2.value(m, column) for m in methods)
    assert t2.value(ours, "R@3") == t2.value("FineMoGen [71]", "R@3")  # tied
    interval = float("0" + t2.row(ours).parsed(0)[1])
    rival = float("0" + t2.row("FineMoGen [71]").parsed(0)[1])
    assert t2.value(ours, "R@1") - interval < t2.value("FineMoGen [71]", "R@1") + rival
    mm_dist = t2.column("MM-Dist")
    del mm_dist["Real motion"]
    assert sorted(mm_dist, key=mm_dist.get)[:3] == ["GUESS $*$ [13]", "ReMoDiffusion [70]", ours]
    real = t2.value("Real motion", "Diversity")
    gap = {m: round(abs(t2.value(m, "Diversity") - real), 3) for m in methods}
    assert gap[ours] == gap["MotionDiffuse [69]"] == min(gap.values()) == 0.02
    fid = {m: t2.value(m, "FID") for m in methods}
    assert sorted(fid, key=fid.get).index(ours) == 5 and len(fid) == 10
    latent = [m for m in methods if "*" in m]
    assert len(latent) == 4 and max(latent, key=fid.get) == ours


def test_table_5_cites_motion_mamba_and_priormdm_for_motiondiffuse_and_finemogen() -> None:
    rows = {r.label for r in get_table(EMG, "Table 5").rows}
    assert {"MotionDiffuse [73]", "FineMoGen [53]"} <= rows
    text = _quoted("emg.B2.first_take")
    assert "MotionDiffuse [69]" in text and "FineMoGen [71]" in text
    assert "Motion mamba" in _quoted("emg.ref.73")
    assert "generative prior" in _quoted("emg.ref.53")
    assert "Motiondiffuse" in _quoted("emg.ref.69") and "Finemogen" in _quoted("emg.ref.71")
    for table in ("Table 2", "Table 3", "Table 6"):
        labels = {r.label for r in get_table(EMG, table).rows}
        assert "MotionDiffuse [69]" in labels and "FineMoGen [71]" in labels


def test_table_6_agd_ties_motiondiffuse_on_transition() -> None:
    assert "superior performance on R-Precision, TMR-Score, and Transition distance" in _quoted(
        "emg.B3.superior")
    t6 = get_table(EMG, "Table 6")
    agd = "ENERGYMOGEN (skeleton) + AGD"
    prior = ("MotionDiffuse [69]", "MDM [58]", "ReModiffuse [70]", "FineMoGen [71]")
    for column in ("R@1", "R@3", "M2T", "M2M"):
        assert all(t6.value(agd, column) > t6.value(p, column) for p in prior), column
    best_prior = min(t6.value(p, "Transition") for p in prior)
    assert t6.value(agd, "Transition") == best_prior == t6.value("MotionDiffuse [69]",
                                                                 "Transition")
    assert t6.value(agd, "FID") > t6.value("MotionDiffuse [69]", "FID")


def test_table_7_middle_rows_trend_end_to_end_not_monotone() -> None:
    text = _quoted("emg.C.trend")
    assert "middle five rows" in text and "as the weight of λ_s increases" in text
    t7 = get_table(EMG, "Table 7")
    middle = ["0.5,0.5,0.0", "0.4,0.6,0.0", "0.3,0.7,0.0", "0.2,0.8,0.0", "0.1,0.9,0.0"]
    assert [t7.row_name(r) for r in t7.rows[3:8]] == middle
    falls = {}
    for column in ("R@1", "R@3", "M2T", "M2M"):
        series = [t7.value(r, column) for r in middle]
        assert series[-1] > series[0], column  # end to end the trend holds
        falls[column] = [i for i in range(4) if series[i + 1] < series[i]]
    assert falls == {"R@1": [0], "R@3": [0], "M2T": [3], "M2M": [2]}
    transition = [t7.value(r, "Transition") for r in middle]
    assert transition == [1.4, 1.4, 1.4, 1.5, 1.7]
    assert t7.value("1.0,0.0,0.0", "Transition") > min(transition)


def test_kit_ml_split_sizes_do_not_add_up_to_its_motions() -> None:
    text = _quoted("emg.G1.kit")
    assert "3,911" in text and "4888/300/830" in text
    assert 4888 + 300 + 830 == 6018 and 6018 not in (3911, 2 * 3911)


@pytest.mark.needs_seeds
def test_the_paper_names_mm_dist_a_text_motion_consistency() -> None:
    assert "Multi-Modal Distance (MM-Dist) for text-motion consistency" in normalise(
        seed_text(EMG))


def test_eq13_as_printed_pairs_motion_with_motion() -> None:
    assert "features from the ground truth and generated motion as m and \\hat{m}" in _quoted(
        "emg.G2.features")
    eq13 = _quoted("emg.G2.mm_dist")
    assert "between the generated motion and text" in eq13 and "||m_i - \\hat{m}_i||" in eq13
    # the package's MM-Dist is text to motion: a motion equal to its text's feature scores 0
    rng = np.random.default_rng(0)
    text_features = rng.standard_normal((8, 4))
    assert mm_distance(text_features, text_features) == 0.0
    assert mm_distance(text_features, text_features + 1.0) == np.sqrt(4.0)
    # under Eq. 13 as printed real motion (m̂ = m) would score 0; the tables print otherwise
    assert value(EMG, "Table 4", "Real motion", "MM-Dist") == 2.974
    assert value(EMG, "Table 2", "Real motion", "MM-Dist") == 2.788
