"""The "Reading" paragraphs of the GMD notebooks, rendered from the values a run measured.

A sentence whose truth depends on the numbers is chosen by the numbers (``_either``); the
numbers themselves enter through ``repro.core.tables.render`` and ``interval_text``, never as
typed text, so a re-run with another seed or more steps rewrites the paragraph.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from repro.core.tables import interval_text, render
from repro.gmd import table_b1

__all__ = ["reading_a3", "reading_b1", "reading_b2", "reading_b3", "reading_c4", "reading_clamp"]


def _either(condition: bool, when_true: str, when_false: str) -> str:
    return when_true if condition else when_false


def _count(values_a: Sequence[float], values_b: Sequence[float]) -> int:
    """How many seeds have a < b."""
    return int(np.sum(np.asarray(values_a) < np.asarray(values_b)))


# ----------------------------------------------------------------------------- notebook 02

def reading_b1(*, round_trip_error: float, joints_error: float, summary: dict,
               late_gap: int, growth: float, real_growth: float | None,
               linearisation: Sequence[float], deltas: Sequence[float]) -> str:
    """GMD-B1: round trip, the flat linear-velocity curve, the growing rotation curve, the
    first-order error. ``summary`` is ``SensitivityResult.summary()``."""
    linear, rotation = summary["rel_linear"], summary["rel_rotation"]
    last = f"gap_{late_gap}"
    real = ("" if real_growth is None else
            render(" (the real walking clip ×{g:.2f})", g=real_growth))
    errors = ", ".join(render("{e:.1%} at δω = {d:g}", e=e, d=d)
                       for e, d in zip(linearisation, deltas, strict=True))
    flat = abs(linear[last] - linear["gap_1"]) <= 1e-9 * max(linear["gap_1"], 1e-12)
    return render(
        "**Reading** (this run). The round trip is exact to {trip:.1e} over every clip, and "
        "both representations give the same joints to {joints:.1e} m. A linear-velocity "
        "change at the perturbed frame moves the later frames by {lin1:.4f} m at gap 1 and "
        "{linL:.4f} m at gap {gap} ({flat}): p_t depends on *all* earlier steps, but "
        "linearly. A rotation change turns the rest of the path about the perturbed frame's "
        "position: its displacement goes from {rot1:.4f} m at gap 1 to {rotL:.4f} m at gap "
        "{gap}. With all three entries perturbed the displacement grows ×{growth:.2f} from "
        "gap 1 to gap {gap} on the stand-in mean{real}. The Jacobian maps show the structure "
        "(exact, whatever the clip): rel is lower-triangular, every frame depending on all "
        "earlier ones; abs is the identity on the diagonal. The first-order (Jacobian) prediction "
        "of a rotation change is off by {errors}, relatively. On a clip that stands still "
        "the rotation term vanishes: compounding needs travel.",
        trip=round_trip_error, joints=joints_error, lin1=linear["gap_1"], linL=linear[last],
        gap=late_gap, flat=_either(flat, "the same shift", "not constant"),
        rot1=rotation["gap_1"], rotL=rotation[last], growth=growth, real=real, errors=errors)


def reading_b2(per_method: dict[str, list[dict[str, float]]], *, seeds: Sequence[int],
               stop_t: int) -> str:
    """GMD-B2: imputation against imputation, guidance against guidance, and what each route
    costs. ``per_method[method]``: ``ImputationRun.summary()`` per seed; ``stop_t``: the step
    after which neither mechanism acts."""
    def values(method: str, key: str = "location_error") -> list[float]:
        return [row[key] for row in per_method[method]]

    def mean(method: str, key: str = "location_error") -> float:
        return float(np.mean(values(method, key)))

    imputation_better = _count(values("abs_imputation"), values("rel_imputation"))
    guidance_better = _count(values("abs_guidance"), values("rel_guidance"))
    abs_guidance_helps = mean("abs_guidance") < mean("abs_unguided")
    rel_guidance_helps = mean("rel_guidance") < mean("rel_unguided")
    return render(
        "**Reading** (this run, seeds {seeds}). *Imputation against imputation:* replacing "
        "the two x/z entries in abs ends {abs_imp} m from the targets, replacing the root "
        "entries of every frame in rel {rel_imp} m (abs closer on {ki} of {n} seeds). "
        "{free} The rel imputation dictates the whole root path (every frame's entries are "
        "replaced); against the unguided samples of the same noise it moves the path "
        "{rel_off:.3f} m on frames away from the targets, abs imputation {abs_off:.3f} m. "
        "*Guidance against "
        "guidance:* abs ends {abs_g} m, rel {rel_g} m from the targets (abs closer on {kg} of "
        "{n} seeds); against the unguided samples guidance {abs_help} in abs ({abs_u} m "
        "unguided) and {rel_help} in rel ({rel_u} m).",
        seeds=list(seeds), abs_imp=interval_text(values("abs_imputation")),
        rel_imp=interval_text(values("rel_imputation")), ki=imputation_better, n=len(seeds),
        free=_either(stop_t > 0, render(
            "Both replacements hold the targets while t ≥ {stop}; what the last {stop} free "
            "steps move in rel is summed over every earlier frame, in abs it is the entry "
            "itself.", stop=stop_t), "Both replacements act to the last step (t = 0), so both "
            "end on their targets up to rounding."),
        rel_off=mean("rel_imputation", "path_change_off_target"),
        abs_off=mean("abs_imputation", "path_change_off_target"),
        abs_g=interval_text(values("abs_guidance")), rel_g=interval_text(values("rel_guidance")),
        kg=guidance_better, abs_help=_either(abs_guidance_helps, "helped", "did not help"),
        rel_help=_either(rel_guidance_helps, "helped", "did not help"),
        abs_u=interval_text(values("abs_unguided")), rel_u=interval_text(values("rel_unguided")))


def reading_b3(rows: dict[str, list[dict[str, float]]], real: dict[str, float], *,
               paper_fid: tuple[float, float]) -> str:
    """GMD-B3: each Table B.1 column per representation, concept recall, the distance from
    the real windows. ``rows`` keyed "relative"/"absolute" (``table_b1.table_row`` per seed);
    ``paper_fid`` the paper's (rel, abs) FID."""
    def values(rep: str, metric: str) -> list[float]:
        return [row[metric] for row in rows[rep]]

    def lower(metric: str) -> str:
        rel, ab = np.mean(values("relative", metric)), np.mean(values("absolute", metric))
        return "tie" if rel == ab else ("rel" if rel < ab else "abs")

    recall_abs_lower = _count(values("absolute", "concept_recall"),
                              values("relative", "concept_recall"))
    n = len(rows["relative"])
    gap_rel = [abs(v - real["diversity"]) for v in values("relative", "diversity")]
    gap_abs = [abs(v - real["diversity"]) for v in values("absolute", "diversity")]
    columns = render(
        "**Reading** (this run, {n} seed(s)). FID: rel {fid_rel} vs abs {fid_abs} (lower "
        "mean: {fid_low}; the paper has abs lower). R-precision top-3: rel {r3_rel} vs abs "
        "{r3_abs}. Diversity gap to the real windows' {div_real:.3f}: rel {gap_rel} vs abs "
        "{gap_abs}.",
        n=n, fid_rel=interval_text(values("relative", "fid")),
        fid_abs=interval_text(values("absolute", "fid")), fid_low=lower("fid"),
        r3_rel=interval_text(values("relative", "r_precision_top3")),
        r3_abs=interval_text(values("absolute", "r_precision_top3")),
        div_real=real["diversity"], gap_rel=interval_text(gap_rel),
        gap_abs=interval_text(gap_abs))
    if not table_b1.measurable(values("relative", "concept_recall")
                               + values("absolute", "concept_recall")):
        return columns + render(
            " Concept recall: {not_measurable} (the folder has no `labels/` for the concept "
            "oracles to compare with). The real windows' R-precision: {r3_real:.2f}.",
            not_measurable=table_b1.NOT_MEASURABLE, r3_real=real["r_precision_top3"])
    return columns + render(
        " The concept oracles find fewer of the captioned concepts in abs samples than in rel "
        "samples on {k} of {n} seeds (recall rel {cr_rel} vs abs {cr_abs}). Both tiny models "
        "are far from the real windows (R-precision {r3_real:.2f}, concept recall "
        "{cr_real:.2f}), so this is a weak test of a small effect: the paper's FID difference "
        "({p_rel:g} vs {p_abs:g}) is {share:.0%} of its rel value.",
        n=n, k=recall_abs_lower,
        cr_rel=interval_text(values("relative", "concept_recall")),
        cr_abs=interval_text(values("absolute", "concept_recall")),
        r3_real=real["r_precision_top3"], cr_real=real["concept_recall"],
        p_rel=paper_fid[0], p_abs=paper_fid[1],
        share=(paper_fid[0] - paper_fid[1]) / paper_fid[0])


# ----------------------------------------------------------------------------- notebook 01

def reading_a3(*, stop: int, num_timesteps: int, best_step: dict[str, float],
               survival: dict[str, float], stop_step_survival: dict[str, float]) -> str:
    """How to read GMD-A3's survival, rendered from this run's values (means over seeds):
    ``best_step`` the step t of the closest approach, ``survival`` the registered best-gain
    survival and ``stop_step_survival`` v2's survival from the stop step, per model ("x0",
    "epsilon")."""
    return render(
        "**Reading GMD-A3.** Guidance acts while t ≥ {stop} of T = {T}. The registered "
        "survival compares the end with the guided x̂0's closest approach to the goal, "
        "wherever in sampling it happens: on average at t ≈ {best_x0:.0f} for the x0 model "
        "and t ≈ {best_eps:.0f} for the ε model. The x0 model keeps {s_x0:.2f} of its best "
        "gain and the ε model {s_eps:.2f}. Counted from the stop step instead (registry v2's "
        "measurement, outside the rule) they keep {v2_x0:.2f} and {v2_eps:.2f}: {v2_reading} "
        "A share is undefined (stored as null) for a seed whose guided x̂0 never came nearer "
        "the goal than the unguided sample.",
        stop=stop, T=num_timesteps, best_x0=best_step["x0"], best_eps=best_step["epsilon"],
        s_x0=survival["x0"], s_eps=survival["epsilon"], v2_x0=stop_step_survival["x0"],
        v2_eps=stop_step_survival["epsilon"],
        v2_reading=_either(
            min(best_step.values()) > stop,
            "both closest approaches lie before the stop step, so what is undone there is "
            "outside the v2 measurement.",
            "at least one closest approach lies after the stop step."))


#: the labels of ``x0_vs_eps.CLAMPS`` (registered first)
CLAMP_LABELS = ("GMD's ±6 (registered)", "±max|x| of the training windows", "no clamp")


def reading_clamp(errors: dict[str, list[float]], *, bound: float, unguided_eps: float,
                  guided_x0: float, seeds: Sequence[int]) -> str:
    """The x̂0-clamp sensitivity check of GMD-A3. ``errors``: ``x0_vs_eps.clamp_sensitivity``
    (``CLAMP_LABELS``); ``bound`` the ±max|x| bound; the other values are means over seeds."""
    gmds, ours, none = (float(np.mean(errors[k])) for k in CLAMP_LABELS)
    x0_better_both = guided_x0 < ours and guided_x0 < gmds

    def effect(value: float) -> str:
        return _either(value > unguided_eps, "makes the ε model *worse*", "helps the ε model")

    return render(
        "**Reading** (this run, seeds {seeds}). With GMD's ±6 (registered) guidance "
        "{gmd_effect} ({gmds:.3g} m against {unguided:.3g} m unguided); with ± the largest "
        "|value| of the training windows (±{bound:.1f}, registry v2's bound) it {ours_effect} "
        "({ours:.3g} m); without any clamp the guided samples end {none:.3g} m from their "
        "goals. The x0 model's guided error is {x0:.3g} m. {verdict}",
        seeds=list(seeds), bound=bound, ours_effect=effect(ours), ours=ours,
        unguided=unguided_eps, gmd_effect=effect(gmds), gmds=gmds, none=none, x0=guided_x0,
        verdict=_either(
            (guided_x0 < ours) == (guided_x0 < gmds),
            _either(x0_better_both,
                    "Under both bounds the x0 model reaches the goals better than the ε model: "
                    "the goal-error comparison does not hinge on the bound.",
                    "Under both bounds the ε model reaches the goals at least as well as the "
                    "x0 model: the goal-error comparison does not hinge on the bound."),
            "Which model reaches the goals better depends on the clamp bound here: the "
            "goal-error half of the verdict rests on taking GMD's bound."))


# ----------------------------------------------------------------------------- notebook 03

def reading_c4(*, skating: dict[str, dict[str, list[float]]], data_skating: float,
               final_losses: dict[str, float], train_steps: int, kappas: dict[int, float],
               emphasis_skating_c10: Sequence[float]) -> str:
    """GMD-C4: what the budget buys and how far the conditioning of P goes with skating.
    ``skating[method][str(value)]``: per-seed foot skating (``Results.per_value``);
    ``final_losses``: the first seed's final training loss per variant; ``kappas``: κ(P) at
    c = 10 per seed, ``emphasis_skating_c10`` the Emphasis c = 10 models' skating per seed."""
    def span(method: str) -> tuple[float, float]:
        values = [v for per_seed in skating[method].values() for v in per_seed]
        return min(values), max(values)

    values = list(skating["emphasis"])
    gaps = {v: float(np.mean(skating["loss_scaling"][v]) - np.mean(skating["emphasis"][v]))
            for v in values}
    worse_everywhere = all(gap < 0 for gap in gaps.values())
    better_everywhere = all(gap > 0 for gap in gaps.values())
    first, last = values[0], values[-1]
    shrinks = abs(gaps[last]) < abs(gaps[first])
    loss_lo, loss_hi = span("loss_scaling")
    emph_lo, emph_hi = span("emphasis")
    seeds = list(kappas)
    worst = max(seeds, key=kappas.get)
    worst_skating = emphasis_skating_c10[seeds.index(worst)]
    others = [s for i, s in enumerate(emphasis_skating_c10) if seeds[i] != worst]
    if worse_everywhere:
        direction = "Emphasis skates more than loss scaling at every matched value on average"
    elif better_everywhere:
        direction = "Emphasis skates less than loss scaling at every matched value on average"
    else:
        direction = "neither method skates less at every matched value"
    kappa_sentence = "" if not others else render(
        " In this run the seed with the largest κ at c = 10 is seed {s} (κ = {k:.3g}, against "
        "{k_min:.3g} for the smallest); its Emphasis c = 10 model skates {sk:.3g} m/s against "
        "{o_lo:.3g}–{o_hi:.3g} m/s for the other seeds'.",
        s=worst, k=kappas[worst], k_min=min(kappas.values()), sk=worst_skating,
        o_lo=min(others), o_hi=max(others))
    return render(
        "### Reading the GMD-C4 numbers\n\n"
        "Two things dominate these tiny models, and both should be kept in mind before reading "
        "the verdict as evidence about GMD:\n\n"
        "1. **Training budget.** Each model sees {steps} × 64 windows; the filmstrips show "
        "what that buys. In this run the first seed's models ended with a training loss of "
        "{l_lo:.2f}–{l_hi:.2f} (the data's variance is 1). Loss-scaling samples skate "
        "{a_lo:.2g}–{a_hi:.2g} m/s and Emphasis samples {b_lo:.2g}–{b_hi:.2g} m/s, against "
        "{data:.2g} m/s in the data; {direction} (loss scaling − Emphasis: {g_first:+.2g} m/s "
        "at v = {v_first}, {g_last:+.2g} m/s at v = {v_last}; the gap {trend} as the value "
        "grows). Both kinds of model are far from GMD's, so this is evidence about small, "
        "short-trained models, not about GMD's.\n"
        "2. **Conditioning of the Emphasis matrix.** A square N(0, 1) matrix has a few tiny "
        "singular values (GMD-C2; here κ(P) at c = 10 is {k_all} over the seeds). A "
        "unit-variance signal along the data direction v_i reaches the projected space scaled "
        "by σ_i, so (a) the projected MSE "
        "weighs errors along v_i by σ_i² and (b) the diffusion noise hides v_i until "
        "σ_i² ᾱ_t/(1 − ᾱ_t) ≥ 1. The cell below counts the data directions that stay below "
        "SNR 1 even at the last sampling step (`emphasis.drowned_directions`): the sampler "
        "never observes them, and the model has to infer them from the rest; the "
        "un-projection P⁻¹ (gain up to 1/σ_min) turns its errors along them into broken "
        "bodies. κ varies a lot between draws (the table below puts κ and skating per seed "
        "side by side).{kappa} An orthogonal matrix (√263·Q) has no tiny singular values — "
        "and GMD's paper does not mention this trade-off.",
        steps=train_steps, l_lo=min(final_losses.values()), l_hi=max(final_losses.values()),
        a_lo=loss_lo, a_hi=loss_hi, b_lo=emph_lo, b_hi=emph_hi, data=data_skating,
        direction=direction, g_first=gaps[first], v_first=first, g_last=gaps[last],
        v_last=last, trend=_either(shrinks, "shrinks", "does not shrink"),
        kappa=kappa_sentence, k_all=", ".join(f"{k:.3g}" for k in kappas.values()))
