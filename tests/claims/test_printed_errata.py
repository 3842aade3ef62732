"""The arithmetic of each audit erratum in docs/ERRATA.md, on the printed values of
``claims.printed`` (which tests/claims/test_printed.py checks against the seeds' text)."""

from __future__ import annotations

import numpy as np
import pytest

from repro.claims.printed import QUOTES, get_table, value
from repro.claims.seed_text import normalise, seed_text, table_block
from repro.core.metrics import diversity, mm_distance

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


# -- the inconsistencies the table audit had noted without an entry ------------------------------


def test_gmd_appendix_e_mdm_has_the_absolute_root_but_0_556_is_the_relative_row() -> None:
    retrained = _quoted("gmd.E.mdm_retrained")
    assert "original MDM using our absolute root representation and proposed Emphasis" in (
        retrained)
    assert "retraining MDM [10] and our model with both relative and absolute" in _quoted(
        "gmd.B.ablated")
    assert "compared to the original MDM (0.556 vs 0.212)" in _quoted("gmd.D.more_than_half")
    b1 = get_table("GMD", "Table B.1")
    # appendix D's 0.556 is the relative-root MDM row, which appendix E's description excludes
    assert [r for r in b1.column("FID") if b1.value(r, "FID") == 0.556] == ["MDM [10] (rel)"]
    assert b1.value("MDM [10] (abs)", "FID") == 0.894
    # no row of Table B.1 is named for Emphasis projection but "Ours xproj"
    assert [r.label for r in b1.rows if "proj" in r.label] == ["Ours xproj"]


@pytest.mark.needs_seeds
def test_table_4_header_is_printed_in_its_table() -> None:
    t4 = get_table(EMG, "Table 4")
    assert _quoted("emg.table4.header") in normalise(table_block(t4, seed_text(EMG)))


def test_table_4_header_prints_top_3_before_top_2_but_the_values_rise() -> None:
    t4 = get_table(EMG, "Table 4")
    assert normalise(QUOTES["emg.table4.header"].text) == "$Top-1$ $Top-3$ $Top-2$"
    for row in t4.rows:
        name = t4.row_name(row)
        printed_order = [t4.value(name, c) for c in ("R@1", "R@2", "R@3")]
        assert printed_order == sorted(printed_order), name  # the middle column is not Top-3
    # the last of the three is Top-3: real motion's equals GMD Table B.1's Top-3 of the same set
    assert t4.value("Real motion", "R@3") == value("GMD", "Table B.1", "Real", "R@3") == 0.797
    assert t4.value("MDM [58]", "R@2") == 0.604 and t4.value("MDM [58]", "R@3") == 0.707


def test_guess_is_cited_as_13_in_table_2_and_14_in_the_text_and_listed_twice() -> None:
    labels = [r.label for r in get_table(EMG, "Table 2").rows]
    assert "GUESS $*$ [13]" in labels
    assert "GUESS [14] proposes" in _quoted("emg.4.guess")
    thirteen, fourteen = _quoted("emg.ref.13"), _quoted("emg.ref.14")
    authors = "Xuehao Gao, Yang Yang, Zhenyu Xie, Shaoyi Du, Zhongqian Sun, and Yang Wu."
    assert authors in thirteen and authors in fourteen
    assert "Guess gradually enriching synthesis" in thirteen
    assert "Guess: Gradually enriching synthesis" in fourteen


def test_table_7_sef_row_is_best_on_alignment_not_on_fid_or_transition() -> None:
    assert "achieves best performance" in _quoted("emg.C.best")
    assert "can further improve the performance" in _quoted("emg.C.best")
    t7 = get_table(EMG, "Table 7")
    sef = "0.1,0.7,0.2"
    middle = [t7.row_name(r) for r in t7.rows[3:8]]
    last = [t7.row_name(r) for r in t7.rows[8:]]
    assert sef in last and len(middle) == 5 and len(last) == 4

    def best(rows: list[str], column: str) -> float:
        pick = max if t7.goal(column) == "max" else min
        return pick(t7.value(r, column) for r in rows)

    columns = ("R@1", "R@3", "M2T", "M2M", "FID", "Transition")
    assert [t7.value(sef, c) for c in columns] == [best(last, c) for c in columns]
    assert sorted({t7.value(r, "Transition") for r in last}) == [1.6]  # tied on transition
    everything = [t7.row_name(r) for r in t7.rows]
    assert [c for c in columns if t7.value(sef, c) != best(everything, c)] == ["FID",
                                                                              "Transition"]
    assert best(everything, "FID") == t7.value("0.0,1.0,0.0", "FID") == 0.569
    assert best(everything, "Transition") == 1.4
    assert t7.value("0.0,1.0,0.0", "M2M") == t7.value(sef, "M2M") == 0.567  # M2M tied
    # the last four rows against the middle five: better except on the transition distance
    assert [best(middle, c) for c in columns] == [14.2, 27.5, 0.590, 0.563, 0.613, 1.4]
    assert [best(last, c) for c in columns] == [15.7, 28.0, 0.591, 0.567, 0.604, 1.6]


def test_table_8_seven_latents_reconstruct_best_except_on_diversity() -> None:
    assert "For reconstruction, 7 latent vectors achieve the best results." in _quoted(
        "emg.D.best")
    recon = get_table(EMG, "Table 8 reconstruction")
    for column, goal in recon.columns[1:]:
        if goal != "real":
            values = recon.column(column)
            pick = max if goal == "max" else min
            assert pick(values, key=values.get) == "7", column
    real = value(EMG, "Table 4", "Real motion", "Diversity")
    gap = {n: round(abs(v - real), 3) for n, v in recon.column("Diversity").items()}
    assert gap == {"1": 0.086, "3": 0.118, "5": 0.117, "7": 0.100}
    assert min(gap, key=gap.get) == "1"


def test_table_9_agd_row_is_best_on_r_precision_and_fid_only() -> None:
    assert "achieves best results on MTT" in _quoted("emg.E.best")
    assert "comparable results on the TMR-Score and transition distance" in _quoted("emg.5.5.q1")
    t9 = get_table(EMG, "Table 9")
    agd = "0.001,0.002"
    wins = {}
    for column, goal in t9.columns[2:]:
        values = t9.column(column)
        pick = max if goal == "max" else min
        top = pick(values.values())
        wins[column] = sorted(r for r, v in values.items() if v == top)
    assert wins == {"R@1": [agd], "R@3": [agd], "FID": [agd],
                    "M2T": ["0.0,0.0", agd, "0.005,0.005"], "M2M": ["0.0,0.0"],
                    "Transition": ["0.005,0.01"]}
    assert (t9.value(agd, "M2M"), t9.value("0.0,0.0", "M2M")) == (0.560, 0.562)
    assert (t9.value(agd, "Transition"), t9.value("0.005,0.01", "Transition")) == (2.7, 1.9)


# -- the equations ------------------------------------------------------------------------------


def _logsumexp(x: np.ndarray, axis: int | None = None) -> np.ndarray:
    top = np.max(x, axis=axis, keepdims=True)
    out = top + np.log(np.exp(x - top).sum(axis=axis, keepdims=True))
    return out.squeeze() if axis is None else out.squeeze(axis)


def _softmax(x: np.ndarray, axis: int) -> np.ndarray:
    e = np.exp(x - x.max(axis=axis, keepdims=True))
    return e / e.sum(axis=axis, keepdims=True)


def _attention_energy(keys: np.ndarray, queries: np.ndarray, alpha: float) -> float:
    """Park et al.'s E(Q|K) = −α⁻¹ Σ_j logsumexp_i(α q_i·k_j) (keys k_j: rows of K)."""
    return -float(_logsumexp(alpha * keys @ queries.T, axis=1).sum()) / alpha


def _prior_energy(keys: np.ndarray) -> float:
    """Park et al.'s E(K) = logsumexp_j(½‖k_j‖²)."""
    return float(_logsumexp(0.5 * (keys**2).sum(axis=1)))


def _gradient(f, x: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Central differences of the scalar f at x."""
    out = np.zeros_like(x)
    for index in np.ndindex(x.shape):
        up, down = x.copy(), x.copy()
        up[index] += step
        down[index] -= step
        out[index] = (f(up) - f(down)) / (2 * step)
    return out


def _eq3_bracket(keys: np.ndarray, queries: np.ndarray, alpha: float) -> np.ndarray:
    """SFM(αKQᵀ)Q − M(SFM(K′))K with the softmax over queries and K′_j = ½‖k_j‖² (N^t × d)."""
    attention = _softmax(alpha * keys @ queries.T, axis=1) @ queries
    regulariser = np.diag(_softmax(0.5 * (keys**2).sum(axis=1), axis=0)) @ keys
    return attention - regulariser


def _eq3_setup(seed: int = 0) -> tuple[np.ndarray, np.ndarray, float]:
    rng = np.random.default_rng(seed)
    n_text, n_query, d = 4, 5, 3
    return (0.7 * rng.standard_normal((n_text, d)), rng.standard_normal((n_query, d)),
            1 / np.sqrt(d))


def test_eq3_both_energies_enter_log_p_with_a_minus() -> None:
    assert "\\exp(-E_{\\theta}(\\boldsymbol{X}))" in _quoted("emg.2.eq1")
    assert "p(K|Q) \\propto p(Q|K)p(K)" in _quoted("emg.3.1.kv")
    printed = _quoted("emg.3.1.eq3_lhs")
    assert printed.endswith("= \\nabla_{\\mathbf{K}} E(\\mathbf{K}) - \\nabla_{\\mathbf{K}} "
                            "E(\\mathbf{Q}|\\mathbf{K})")
    assert "\\text{SEM}(\\alpha \\mathbf{K} \\mathbf{Q}^{\\top})" in _quoted("emg.3.1.eq3_rhs")
    assert "SEM" not in _quoted("emg.3.1.sfm") and "SFM" in _quoted("emg.3.1.sfm")
    keys, queries, alpha = _eq3_setup()
    grad_attention = _gradient(lambda k: _attention_energy(k, queries, alpha), keys)
    grad_prior = _gradient(_prior_energy, keys)
    # p ∝ exp(−E) for both factors: log p(K|Q) = −E(Q|K) − E(K) + const
    log_posterior = _gradient(lambda k: -_attention_energy(k, queries, alpha)
                              - _prior_energy(k), keys)
    np.testing.assert_allclose(log_posterior, -grad_prior - grad_attention, atol=1e-8)
    # the bracket on the right is the minus-minus gradient ...
    bracket = _eq3_bracket(keys, queries, alpha)
    np.testing.assert_allclose(bracket, log_posterior, atol=1e-6)
    # ... and the printed middle, +∇E(K) − ∇E(Q|K), is not: it is off by 2∇E(K)
    printed_middle = grad_prior - grad_attention
    assert not np.allclose(printed_middle, bracket, atol=1e-3)
    np.testing.assert_allclose(printed_middle - bracket, 2 * grad_prior, atol=1e-6)


def test_eq3_eq4_the_gradient_for_c_is_the_k_gradient_times_w_k_transposed() -> None:
    assert "$K = cW_K$" in _quoted("emg.3.1.kv")
    assert "W_K, W_V \\in \\mathbb{R}^{d \\times d}" in _quoted("emg.3.1.kv")
    assert "c \\in \\mathbb{R}^{N^t \\times d}" in _quoted("emg.3.1.c")
    assert _quoted("emg.3.1.eq3_lhs").startswith("\\nabla_{\\mathbf{K}} \\log p")
    assert _quoted("emg.3.1.eq3_rhs").endswith("]W_{\\mathbf{K}},\\tag{3}")
    assert "c is refined" in _quoted("emg.3.1.eq4")
    assert "\\hat{c} = c + \\gamma \\nabla_K \\log p(K|Q)" in _quoted("emg.3.1.eq4")
    rng = np.random.default_rng(1)
    _, queries, alpha = _eq3_setup(1)
    d = queries.shape[1]
    text = 0.7 * rng.standard_normal((4, d))
    w_k = rng.standard_normal((d, d))  # not symmetric, not orthogonal

    def log_p(c: np.ndarray) -> float:
        keys = c @ w_k
        return -_attention_energy(keys, queries, alpha) - _prior_energy(keys)

    bracket = _eq3_bracket(text @ w_k, queries, alpha)  # ∇_K log p(K|Q) at K = cW_K
    grad_c = _gradient(log_p, text)
    np.testing.assert_allclose(grad_c, bracket @ w_k.T, atol=1e-6)  # chain rule: W_Kᵀ
    assert not np.allclose(grad_c, bracket @ w_k, atol=1e-3)        # the printed factor
    # Eq. 4 adds ∇_K to c: the shapes agree (N^t × d), the variable does not
    assert bracket.shape == text.shape and not np.allclose(bracket, grad_c, atol=1e-3)
    # with W_K = I the three coincide, which is why the mismatch is one of variables
    np.testing.assert_allclose(
        _gradient(lambda c: -_attention_energy(c, queries, alpha) - _prior_energy(c), text),
        _eq3_bracket(text, queries, alpha), atol=1e-6)


def test_sec2_attention_update_is_softmax_of_q_k_transposed() -> None:
    assert "softmax $(\\alpha QK)V$" in _quoted("emg.2.attention")
    hopfield = _quoted("emg.2.hopfield")
    assert "\\tilde{\\textbf{X}}$ softmax $(\\alpha \\textbf{X}^{\\top} \\xi)" in hopfield
    rng = np.random.default_rng(2)
    n_query, n_key, d = 3, 5, 4
    queries, keys = rng.standard_normal((n_query, d)), rng.standard_normal((n_key, d))
    alpha, gamma = 1 / np.sqrt(d), 0.3
    with pytest.raises(ValueError):
        queries @ keys  # QK: (3 × 4)(5 × 4) is not defined
    patterns = keys.T  # X: the N stored patterns x_i ∈ R^d as columns

    def energy(xi: np.ndarray) -> float:
        return -float(_logsumexp(alpha * patterns.T @ xi)) / alpha + 0.5 * float(xi @ xi)

    rows = []
    for xi in queries:
        update = xi - gamma * (xi - patterns @ _softmax(alpha * patterns.T @ xi, axis=0))
        np.testing.assert_allclose(update, xi - gamma * _gradient(energy, xi), atol=1e-6)
        rows.append(patterns @ _softmax(alpha * patterns.T @ xi, axis=0))  # γ = 1
    np.testing.assert_allclose(np.array(rows), _softmax(alpha * queries @ keys.T, axis=1) @ keys)


def _log_gaussian(z: np.ndarray, mean: float) -> np.ndarray:
    return -0.5 * (z - mean) ** 2


def test_negation_as_printed_is_p_of_z_and_eq8_needs_p_of_c_j_below() -> None:
    assert "\\frac{p(z)p(c_i|z)}{p(c_i|z)}" in _quoted("emg.3.2.negation")
    assert "w^{l}(\\epsilon_{\\theta}(z_t, t, \\mathbf{c}_i) - \\epsilon_{\\theta}(z_t, t, " \
           "\\mathbf{c}_j))" in _quoted("emg.3.2.eq8")
    # one-dimensional toy: p(z) = N(0, 1), p(z|c) = N(μ_c, 1); p(c|z) ∝ p(z|c)/p(z); ε = −score
    z = np.linspace(-2.0, 2.0, 9)
    mean = {"∅": 0.0, "i": 1.5, "j": -0.8}

    def log_p_c_given_z(c: str, x: np.ndarray) -> np.ndarray:
        return _log_gaussian(x, mean[c]) - _log_gaussian(x, mean["∅"])

    def eps(log_density) -> np.ndarray:
        step = 1e-5
        return -(log_density(z + step) - log_density(z - step)) / (2 * step)

    eps_null, eps_i, eps_j = (eps(lambda x, c=c: _log_gaussian(x, mean[c])) for c in "∅ij")
    for w in (1.0, 2.0):
        eq8 = eps_null + w * (eps_i - eps_j)
        corrected = eps(lambda x, w=w: _log_gaussian(x, 0.0) + w * (
            log_p_c_given_z("i", x) - log_p_c_given_z("j", x)))
        np.testing.assert_allclose(corrected, eq8, atol=1e-6)
    printed = eps(lambda x: _log_gaussian(x, 0.0) + log_p_c_given_z("i", x)
                  - log_p_c_given_z("i", x))
    np.testing.assert_allclose(printed, eps_null, atol=1e-6)  # p(z): c_j plays no part
    assert not np.allclose(printed, eps_null + eps_i - eps_j, atol=1e-2)


def _cosine_schedule(steps: int = 1000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """β_t, α_t, ᾱ_t for t = 1..T (index t − 1), as in the Eq. 5 test above."""
    s = np.arange(steps + 1)
    f = np.cos(((s / steps + 0.008) / 1.008) * np.pi / 2) ** 2
    beta = np.minimum(1 - f[1:] / f[:-1], 0.999)
    alpha = 1 - beta
    return beta, alpha, np.cumprod(alpha)


def test_eq6_noise_is_not_a_langevin_steps_and_ddpm_noise_is_under_half_of_it() -> None:
    text = _quoted("emg.3.2.eq6")
    assert "Langevin Dynamicsbased MCMC" in text
    assert "- \\eta \\nabla_z E_\\theta(z_t, \\mathbf{c}) + \\mathcal{N}(0, \\tilde{\\beta}_t I)" \
        in text
    # on E = ½z² (p = N(0, 1)), z' = (1 − η) z + noise of variance v keeps the variance
    # v / (1 − (1 − η)²): Langevin's v = 2η keeps ≈ 1, a noise v = η only ≈ ½
    def stationary(eta: float, noise: float) -> float:
        return noise / (1 - (1 - eta) ** 2)

    eta = 1e-3
    assert abs(stationary(eta, 2 * eta) - 1) < 1e-3
    assert abs(stationary(eta, eta) - 0.5) < 1e-3
    rng = np.random.default_rng(3)
    chains = np.zeros(20000)
    eta = 0.05
    for _ in range(400):
        chains = chains - eta * chains + np.sqrt(2 * eta) * rng.standard_normal(chains.size)
    assert abs(chains.var() - stationary(eta, 2 * eta)) < 0.05
    # a DDPM step as Eq. 6 (η_t = β_t/√α_t, the Eq. 5–6 entry) has noise β̃_t < ½ · 2η_t
    beta, alpha, alpha_bar = _cosine_schedule()
    alpha_bar_prev = np.concatenate([[1.0], alpha_bar[:-1]])
    posterior_variance = (1 - alpha_bar_prev) / (1 - alpha_bar) * beta
    ratio = posterior_variance / (2 * beta / np.sqrt(alpha))
    assert ratio[0] == 0.0
    assert round(ratio[1:].min(), 3) == 0.016 and round(ratio[1:].max(), 3) == 0.498
    # at the printed η = 1 a Langevin step adds variance 2; β̃_t stays below 1
    assert posterior_variance.max() < 0.999 < 2


def test_eq9_normaliser_vanishes_or_flips_with_negative_weights() -> None:
    assert "\\frac{1}{\\sum_{i=1}^{n} w_i^s} \\sum_{i=1}^{n} (w_i^s z_i')" in _quoted(
        "emg.3.2.eq9")
    assert "$w^s < 0$ suggests a negation" in _quoted("emg.3.2.negative_weight")
    features = np.array([[1.0, 2.0], [-0.5, 3.0]])  # z′_1 (kept), z′_2 (negated)

    def eq9(weights: list[float]) -> np.ndarray:
        w = np.array(weights)
        return (w[:, None] * features).sum(axis=0) / w.sum()

    np.testing.assert_allclose(eq9([1.0, -0.5]), 2 * features[0] - features[1])  # as EMG-3
    np.testing.assert_allclose(eq9([1.0, -2.0]), -features[0] + 2 * features[1])  # roles swap
    with np.errstate(divide="ignore", invalid="ignore"):
        assert not np.isfinite(eq9([1.0, -1.0])).any()  # Σ w = 0
    from repro.models.latent_denoiser import normalised_concept_weights

    with pytest.raises(ValueError, match="signed sum"):
        normalised_concept_weights([1.0, -1.0], 1, 2)
    assert normalised_concept_weights([1.0, -0.5], 1, 2).tolist() == [[2.0, -1.0]]


def test_eq11_overlap_takes_one_frame_of_the_first_concept() -> None:
    text = _quoted("emg.B2.eq11")
    assert "M_3^t \\in \\mathbb{R}^{N' \\times d_m}" in text
    assert "(M_{\\mathbf{c}_1}^t[N_1 - N'] + M_{\\mathbf{c}_2}^t[:N'] - M_3^t)" in text
    rng = np.random.default_rng(4)
    n1, n2, overlap, dim = 7, 6, 3, 2
    m1, m2 = rng.standard_normal((n1, dim)), rng.standard_normal((n2, dim))
    m3 = rng.standard_normal((overlap, dim))
    assert m1[n1 - overlap].shape == (dim,)  # one frame, not N′ frames
    printed = np.concatenate([m1[:n1 - overlap], m1[n1 - overlap] + m2[:overlap] - m3,
                              m2[overlap:]])  # defined only by broadcasting that frame
    corrected = np.concatenate([m1[:n1 - overlap], m1[n1 - overlap:] + m2[:overlap] - m3,
                                m2[overlap:]])
    assert printed.shape == corrected.shape == (n1 + n2 - overlap, dim)
    assert not np.allclose(printed, corrected)
    # the printed form never reads the first concept's frames N1 − N′ + 1 … N1 − 1
    changed = m1.copy()
    changed[n1 - overlap + 1:] += 1.0
    again = np.concatenate([changed[:n1 - overlap], changed[n1 - overlap] + m2[:overlap] - m3,
                            m2[overlap:]])
    np.testing.assert_array_equal(again, printed)


def test_eq14_summand_does_not_depend_on_i() -> None:
    text = _quoted("emg.G2.eq14")
    assert "we randomly select 300 pairs of motions" in text
    assert "\\sum_{i=1}^{300} ||\\hat{m}_1 - \\hat{m}_2||" in text
    rng = np.random.default_rng(5)
    motions = rng.standard_normal((600, 8))
    printed = np.mean([np.linalg.norm(motions[0] - motions[1]) for _ in range(300)])
    assert np.isclose(printed, np.linalg.norm(motions[0] - motions[1]))  # one pair's distance
    first, second = motions[:300], motions[300:]
    over_pairs = np.linalg.norm(first - second, axis=1).mean()
    assert abs(printed - over_pairs) > 0.1
    # the package's Diversity averages over 300 distinct pairs (Guo et al.'s form)
    assert abs(diversity(motions, 300, seed=0) - over_pairs) < 0.3
