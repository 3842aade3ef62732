"""The papers' printed numbers: every results table of both seeds, row by row, and the
sentences and formulas whose numbers or form the errata (docs/ERRATA.md) and the registry's
rules read.

Each cell is kept as the string the paper prints (``"0.424±.005"``: value and 95 % interval;
``"**3.325**"``: printed in bold), so ``claims.seed_text`` can check that the row is in the
seed verbatim, in its table's block of the text and in its order; :func:`value` gives the
number. The GMD appendix is seed ``000_…`` (Table B.1; Table D.1 holds settings, its numbers
are in :data:`QUOTES`); EnergyMoGen is seed ``004_…`` (Tables 2–9; Table 1's numbers are not in
the seed's text, only its caption). Row names: the label as printed; the λ, γ or N cells
for Tables 7, 9 and 8, joined by commas as ``energymogen.sef_ablation`` spells them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["GOALS", "QUOTES", "SEEDS", "TABLES", "Quote", "Row", "Table", "cell_value",
           "get_table", "value"]

#: seed file (in ``../shared/seeds/``) of each paper.
SEEDS = {"GMD": "000_5b5fb76d61c7092d.txt", "EnergyMoGen": "004_df11c7bf426170fc.txt"}
#: what "better" means for a column: higher, lower, closer to the real data's row, or a key.
GOALS = ("max", "min", "real", "key")
_CELL = re.compile(r"^(?P<bold>\*\*)?(?P<value>[^*±]+?)(?:\*\*)?(?:±(?P<ci>.+))?$")


@dataclass(frozen=True)
class Row:
    """One printed row: ``label`` as the line starts ("" when the first cells name the row),
    ``cells`` as printed (``""`` for an empty cell). ``stride``/``offset``: two rows printed
    interleaved on one line, cell by cell (EnergyMoGen Table 6)."""

    label: str
    cells: tuple[str, ...]
    stride: int = 1
    offset: int = 0
    name: str = ""

    def parsed(self, index: int) -> tuple[str, str | None, bool]:
        """(value as printed, interval as printed or None, bold) of cell ``index``."""
        match = _CELL.match(self.cells[index])
        if match is None:
            raise ValueError(f"cell {self.cells[index]!r} of {self.label!r} is not a number")
        return match["value"], match["ci"], bool(match["bold"])


@dataclass(frozen=True)
class Table:
    """A printed table: its block in the seed runs from ``start`` to the next ``end``."""

    paper: str
    name: str
    where: str
    start: str
    end: str
    columns: tuple[tuple[str, str], ...]
    rows: tuple[Row, ...]
    keys: int = 0
    real: str | None = None

    def row_name(self, row: Row) -> str:
        if row.name:
            return row.name
        if self.keys:
            return ",".join(row.cells[:self.keys])
        return row.label

    def row(self, name: str) -> Row:
        for row in self.rows:
            if self.row_name(row) == name:
                return row
        raise KeyError(f"{self.paper} {self.name} has no row {name!r}; rows: "
                       f"{', '.join(self.row_name(r) for r in self.rows)}")

    def column_index(self, column: str) -> int:
        names = [c for c, _ in self.columns]
        if column not in names:
            raise KeyError(f"{self.paper} {self.name} has no column {column!r}; columns: "
                           f"{', '.join(names)}")
        return names.index(column)

    def goal(self, column: str) -> str:
        return self.columns[self.column_index(column)][1]

    def value(self, row: str, column: str) -> float:
        return cell_value(self.row(row).parsed(self.column_index(column))[0])

    def column(self, column: str) -> dict[str, float]:
        """Row name → value of every row that prints ``column``."""
        index = self.column_index(column)
        return {self.row_name(r): cell_value(r.parsed(index)[0]) for r in self.rows
                if index < len(r.cells) and r.cells[index]}


@dataclass(frozen=True)
class Quote:
    """A sentence (or a part of one) as printed: its numbers are what a rule or an erratum
    reads. Verbatim up to whitespace, line-end hyphenation and the text's Markdown links."""

    paper: str
    where: str
    text: str


def cell_value(printed: str) -> float:
    """The number a printed cell means (``"1.6 \\times 10 - 3"`` is 1.6·10⁻³)."""
    power = re.fullmatch(r"([\d.]+) \\times 10 - (\d+)", printed)
    if power:
        return float(power[1]) * 10.0 ** -int(power[2])
    return float(printed)


def _rows(*rows: tuple[str, ...]) -> tuple[Row, ...]:
    return tuple(Row(r[0], tuple(r[1:])) for r in rows)


def _keyed(*rows: str) -> tuple[Row, ...]:
    """Rows whose first cells are their key (λ, γ, N), written as tab-free strings."""
    return tuple(Row("", tuple(r.split())) for r in rows)


_HML = (("R@1", "max"), ("R@2", "max"), ("R@3", "max"), ("FID", "min"), ("MM-Dist", "min"),
        ("Diversity", "real"), ("MModality", "max"))
_MTT = (("R@1", "max"), ("R@3", "max"), ("M2T", "max"), ("M2M", "max"), ("FID", "min"),
        ("Transition", "min"))
_LATENT = (("N", "key"), ("R@1", "max"), ("R@2", "max"), ("R@3", "max"), ("FID", "min"),
           ("MM-Dist", "min"), ("Diversity", "real"))
_SKELETON_AGD = "ENERGYMOGEN (skeleton) ENERGYMOGEN (skeleton) + AGD"

_TABLE_LIST = (
    Table("GMD", "Table B.1", "appendix B", start="FID ↓ R-precision ↑",
          end="C. Analysis on Emphasis projection",
          columns=(("FID", "min"), ("R@3", "max"), ("Diversity", "real")), real="Real",
          rows=_rows(("Real", "0.002", "0.797", "9.503"),
                     ("MDM [10] (rel)", "0.556", "0.608", "9.446"),
                     ("MDM [10] (abs)", "0.894", "0.638", "8.819"),
                     ("Ours (rel)", "0.305", "0.666", "9.861"),
                     ("Ours (abs)", "0.212", "0.670", "9.440"),
                     ("Ours xproj", "0.235", "0.652", "9.726"))),
    Table("EnergyMoGen", "Table 2", "Sec. 5.3 (KIT-ML test set)",
          start="Methods\t\tR-Precision \\uparrow", end="Table 2. Comparison", columns=_HML,
          real="Real motion",
          rows=_rows(
              ("Real motion", "0.424±.005", "0.649±.006", "0.779±.006", "0.031±.004",
               "2.788±.012", "11.08±.097"),
              ("MDM [58]", "0.404±.005", "0.606±.004", "0.731±.004", "0.513±.046",
               "3.096±.024", "10.732±.103", "1.806±.176"),
              ("MotionDiffuse [69]", "0.417±.004", "0.621±.004", "0.739±.004", "1.954±.062",
               "2.958±.005", "11.10±.143", "0.730±.013"),
              ("M2DM [33]", "0.416±.004", "0.628±.004", "0.743±.004", "0.515±.029",
               "3.015±.017", "11.42±.970", "**3.325**±.370"),
              ("Fg-T2M[60]", "0.418±.005", "0.626±.004", "0.745±.004", "0.571±.047",
               "3.114±.015", "10.93±.083", "1.019±.029"),
              ("ReMoDiffusion [70]", "0.427±.014", "0.641±.004", "0.765±.055", "0.155±.006",
               "2.814±.012", "10.80±.105", "1.239±.028"),
              ("FineMoGen [71]", "0.432±.006", "0.649±.005", "0.772±.006", "0.178±.007",
               "2.896±.014", "10.85±.115", "1.877±.093"),
              ("MLD^*[64]", "0.390±.008", "0.609±.008", "0.734±.007", "0.404±.027",
               "3.204±.027", "10.80±.117", "2.192±.071"),
              ("GUESS $*$ [13]", "0.425±.003", "0.632±.007", "0.751±.005", "0.371±.020",
               "**2.421**±.022", "10.93±.110", "2.732±.084"),
              ("MotionMamba $*$ [73]", "0.419±.006", "0.645±.005", "0.765±.006", "0.307±.041",
               "3.021±.025", "11.02±.098", "1.678±.064"),
              ("ENERGYMOGEN*", "0.436±.006", "0.651±.006", "0.772±.006", "0.495±.020",
               "2.861±.020", "11.06±.101", "1.256±0.024"))),
    Table("EnergyMoGen", "Table 3", "Sec. 5.4 (MTT)",
          start="Multi-concept motion generation (single text)", end="Table 3. Quantitative",
          columns=_MTT,
          rows=_rows(("MotionDiffuse [69]", "10.9", "21.3", "0.558", "0.546", "0.621", "1.9"),
                     ("MDM [58]", "9.5", "19.7", "0.556", "0.549", "0.666", "2.5"),
                     ("ReModiffuse [70]", "7.4", "18.3", "0.531", "0.534", "0.699", "3.3"),
                     ("FineMoGen [71]", "5.4", "11.7", "0.504", "0.533", "0.948", "9.4"),
                     ("MLD [64]", "10.5", "22.3", "0.559", "0.552", "0.685", "2.4"),
                     ("Ours", "12.7", "25.4", "0.570", "0.562", "0.592", "2.7"),
                     ("Ours + AGD", "14.0", "26.3", "0.570", "0.560", "0.587", "2.7"),
                     ("Ours (latent only)", "9.7", "19.6", "0.547", "0.521", "0.917", "1.6"),
                     ("Ours (semantic only)", "15.1", "27.5", "0.585", "0.567", "0.569",
                      "2.2"),
                     ("Ours + SEF", "15.9", "28.0", "0.591", "0.567", "0.604", "1.6"))),
    Table("EnergyMoGen", "Table 4", "appendix B.1 (HumanML3D test set, skeleton-based)",
          start="Methods\tR-Precision \\uparrow\t\t\t$FID", end="Table 4. Comparison",
          columns=_HML, real="Real motion",
          rows=_rows(
              ("Real motion", "0.511±.003", "0.703±.003", "0.797±.002", "0.002±.000",
               "2.974±.008", "9.503±.065"),
              ("MDM [58]", "0.418±.005", "0.604±.001", "0.707±.004", "0.489±.025",
               "3.630±.023", "9.450±.066", "2.870±1.11"),
              ("MotionDiffuse $[69]$", "0.491±.001", "0.681±.001", "0.782±.001",
               "0.630±.001", "3.113±.001", "9.410±.049", "1.553±.042"),
              ("ReMoDiffusion [70]", "0.510±.005", "0.698±.006", "0.795±.004",
               "**0.103**±.004", "2.974±.016", "9.018±.075", "1.795±.043"),
              ("FineMoGen [71]", "0.504±.002", "0.690±.002", "0.784±.004", "0.151±.008",
               "2.998±.008", "9.263±.094", "2.696±.079"),
              ("ENERGYMOGEN (skeleton)", "0.528±.003", "0.718±.003", "0.810±.002",
               "0.139±.007", "2.902±.010", "9.386±.078", "2.549±0.104"))),
    Table("EnergyMoGen", "Table 5", "appendix B.2 (HumanML3D, temporal composition)",
          start="Methods\tR-Precision \\uparrow\t$FID \\downarrow$\tDiversity",
          end="Table 5. Quantitative",
          columns=(("R@3", "max"), ("FID", "min"), ("Diversity", "real"), ("MM-Dist", "min")),
          real="Ground Truth",
          rows=_rows(("Ground Truth", "0.80", "1.6 \\times 10 - 3", "9.62", "2.96"),
                     ("PriorMDM [53] (Double take)", "0.59", "0.60", "9.50", "5.61"),
                     ("PriorMDM [53] (First take)", "0.59", "1.00", "9.46", "5.63"),
                     ("MotionDiffuse [73]", "0.62", "1.76", "8.55", "5.40"),
                     ("ReMoDiffuse [70]", "0.64", "0.40", "9.35", "5.24"),
                     ("FineMoGen [53]", "0.64", "0.45", "9.23", "5.27"),
                     ("Ours", "0.67", "0.43", "9.52", "5.22"))),
    Table("EnergyMoGen", "Table 6", "appendix B.3 (MTT, skeleton-based)",
          start="Methods\tR-Presicion $R@3", end="Table 6. Quantitative", columns=_MTT,
          rows=(*_rows(("MotionDiffuse [69]", "10.9", "21.3", "0.558", "0.546", "0.621", "1.9"),
                       ("MDM [58]", "9.5", "19.7", "0.556", "0.549", "0.666", "2.5"),
                       ("ReModiffuse [70]", "7.4", "18.3", "0.531", "0.534", "0.699", "3.3"),
                       ("FineMoGen [71]", "5.4", "11.7", "0.504", "0.533", "0.948", "9.4")),
                Row(_SKELETON_AGD, ("11.5", "22.6", "0.550", "0.549", "0.670", "2.2"),
                    stride=2, offset=0, name="ENERGYMOGEN (skeleton)"),
                Row(_SKELETON_AGD, ("11.5", "24.4", "0.560", "0.552", "0.643", "1.9"),
                    stride=2, offset=1, name="ENERGYMOGEN (skeleton) + AGD"))),
    Table("EnergyMoGen", "Table 7", "appendix C (MTT, SEF weights λl, λs, λm)",
          start="Per-crop semantic correctness\t\t\t\tRealism", end="Table 7. Ablation",
          columns=(("λl", "key"), ("λs", "key"), ("λm", "key"), *_MTT), keys=3,
          rows=_keyed("1.0 0.0 0.0 9.7 19.6 0.547 0.521 0.917 1.6",
                      "0.0 1.0 0.0 15.1 27.5 0.585 0.567 0.569 2.2",
                      "0.0 0.0 1.0 12.7 25.4 0.570 0.562 0.592 2.7",
                      "0.5 0.5 0.0 13.3 25.5 0.584 0.551 0.740 1.4",
                      "0.4 0.6 0.0 12.7 25.0 0.584 0.555 0.730 1.4",
                      "0.3 0.7 0.0 13.4 26.4 0.589 0.559 0.694 1.4",
                      "0.2 0.8 0.0 13.6 26.9 0.590 0.558 0.668 1.5",
                      "0.1 0.9 0.0 14.2 27.5 0.587 0.563 0.613 1.7",
                      "0.3 0.4 0.3 14.5 27.1 0.588 0.560 0.669 1.6",
                      "0.2 0.5 0.3 14.4 26.9 0.590 0.563 0.628 1.6",
                      "0.1 0.7 0.2 15.7 28.0 0.591 0.567 0.604 1.6",
                      "0.1 0.8 0.1 14.9 26.7 0.587 0.563 0.615 1.6")),
    Table("EnergyMoGen", "Table 8 reconstruction", "appendix D (HumanML3D test set)",
          start="\t\t\tReconstruction", end="\t\t\tGeneration", columns=_LATENT, keys=1,
          rows=_keyed("1 0.493±.002 0.681±.002 0.787±.003 0.170±.001 3.160±.015 9.589±.074",
                      "3 0.501±.002 0.696±.002 0.792±.004 0.117±.000 3.037±.007 9.621±.091",
                      "5 0.508±.003 0.700±.003 0.795±.002 0.080±.000 3.004±.008 9.620±.098",
                      "7 0.513±.002 0.704±.003 0.797±.002 0.022±.000 2.984±.009 9.603±.085")),
    Table("EnergyMoGen", "Table 8 generation", "appendix D (HumanML3D test set)",
          start="\t\t\tGeneration", end="Table 8. Study", columns=_LATENT, keys=1,
          rows=_keyed("1 0.498±.003 0.686±.004 0.791±.004 0.424±.009 3.085±.009 9.705±.097",
                      "3 0.523±.004 0.712±.002 0.814±.002 0.418±.025 2.946±.009 9.443±.136",
                      "5 0.523±.003 0.715±.002 0.815±.002 0.188±.006 2.915±.007 9.488±.099",
                      "7 0.514±.004 0.713±.005 0.813±.003 0.291±.006 2.938±.012 9.456±.130")),
    Table("EnergyMoGen", "Table 9", "appendix E (MTT, AGD steps γattn, γreg)",
          start="\t\t\tPer-crop semantic correctness\tRealism", end="Table 9. Ablation",
          columns=(("γattn", "key"), ("γreg", "key"), *_MTT), keys=2,
          rows=_keyed("0.0 0.0 12.7 25.4 0.570 0.562 0.592 2.7",
                      "0.1 0.2 1.4 4.2 0.498 0.495 1.083 6.1",
                      "0.01 0.02 9.1 20.1 0.551 0.547 0.623 2.9",
                      "0.005 0.01 6.7 15.3 0.531 0.523 0.806 1.9",
                      "0.005 0.005 13.8 25.6 0.570 0.558 0.591 2.7",
                      "0.001 0.002 14.0 26.3 0.570 0.560 0.587 2.7")),
)

#: (paper, table name) → table.
TABLES: dict[tuple[str, str], Table] = {(t.paper, t.name): t for t in _TABLE_LIST}


def get_table(paper: str, name: str) -> Table:
    try:
        return TABLES[(paper, name)]
    except KeyError:
        raise KeyError(f"no printed table {paper} {name!r}; have "
                       f"{', '.join(f'{p} {n}' for p, n in TABLES)}") from None


def value(paper: str, table: str, row: str, column: str) -> float:
    """The number printed in ``table`` at ``row``, ``column``."""
    return get_table(paper, table).value(row, column)


def _quotes(paper: str, *items: tuple[str, str, str]) -> dict[str, Quote]:
    return {key: Quote(paper, where, text) for key, where, text in items}


#: key → a sentence or formula whose numbers, comparison or form a rule, an erratum or the
#: audit reads (formulas verbatim in the seed's LaTeX).
QUOTES: dict[str, Quote] = {
    **_quotes(
        "GMD",
        ("gmd.B.trade_off", "appendix B",
         "MDM shows a significant drop in performance when converted to the absolute "
         "representation, likely because the architecture is highly optimized for the relative "
         "representation, while for our models, the representation change results in a "
         "trade-off between the FID and R-precision."),
        ("gmd.B.adopt_abs", "appendix B",
         "we observe that representing the root with absolute coordinates (abs) is more "
         "favorable than the relative one (rel) in two aspects"),
        ("gmd.D.more_than_half", "appendix D",
         "Our proposed architecture alone has led to a significant improvement in motion "
         "generation tasks, reducing the Fréchet Inception Distance (FID) by more than half "
         "compared to the original MDM (0.556 vs 0.212), as shown in Table 1 in the main "
         "paper."),
        ("gmd.A1.latent", "appendix A.1",
         "Increasing the latent dimension of MDM from 512 to 1,536 did not solve the problem "
         "entirely"),
        ("gmd.C.c_star", "appendix C", "≈ 9.3 results in a relative importance of 50%"),
        ("gmd.C.c10", "appendix C", "We have selected c = 10 as a rounded number of this fact"),
        ("gmd.C1.k10", "appendix C.1",
         "setting k = 10 would increase the importance of the trajectory part by 100-fold, "
         "which has the same scaling effect as setting c = 10 in Emphasis projection"),
        ("gmd.C1.k_grid", "appendix C.1",
         "In the main text, we experimented with k ∈ 1, 2, 5, 10"),
        ("gmd.D1.batch", "Table D.1", "Batch size 512 64"),
        ("gmd.D1.channels", "Table D.1",
         "Base channels 512 512 Channel multipliers [0.125, 0.25, 0.5] [2, 2, 2, 2]"),
        ("gmd.D1.samples", "Table D.1", "Samples trained 32M"),
        ("gmd.D1.lr", "Table D.1",
         "Learning rate 1e-4 Optimizer AdamW (wd = 1e-2) Training T 1000"),
        ("gmd.D1.ema", "Table D.1", "Model avg. beta 0.9999"),
        ("gmd.E.batch", "appendix E",
         "We used a batch size of 64 for motion models and a batch size of 512 for trajectory "
         "models."),
        ("gmd.E.lr", "appendix E",
         "We used AdamW with a learning rate of 0.0001 and weight decay of 0.01."),
        ("gmd.E.samples", "appendix E",
         "We trained all motion models for 32,000,000 samples (equivalent to 500,000 "
         "iterations at batch size 64, and 62,500 iterations at batch size 512)."),
        ("gmd.E.ema", "appendix E", "(β = 0.9999)"),
        ("gmd.E.trajectory_samples", "appendix E",
         "Our choice of training the trajectory model for 32,000,000 samples"),
        ("gmd.E.mdm", "appendix E",
         "we trained these models for 400,000 iterations at a batch size of 64"),
        ("gmd.E.mdm_retrained", "appendix E",
         "We retrained the original MDM using our absolute root representation and proposed "
         "Emphasis projection as the two main baselines."),
        ("gmd.B.ablated", "appendix B",
         "We ablated the root representation by retraining MDM [10] and our model with both "
         "relative and absolute root representation, then show the results in Tab B.1."),
        ("gmd.F.s", "appendix F",
         "We have chosen the value of s as 100 for the classifier guidance strength. Our "
         "experiments have shown that this value of s performs well within the range of 100 "
         "to 200."),
        ("gmd.F.stop", "appendix F",
         "we ceased the guidance signals, i.e., classifier guidance and imputation, at t = 20"),
    ),
    **_quotes(
        "EnergyMoGen",
        ("emg.2.eq1", "Sec. 2, Eq. 1",
         "p_{\\theta}(\\boldsymbol{X}) = "
         "\\frac{\\exp(-E_{\\theta}(\\boldsymbol{X}))}{Z(\\theta)},"),
        ("emg.2.hopfield", "Sec. 2",
         "introduces an energy function $E(\\mathbf{X}, \\xi) = -\\alpha^{-1} \\log "
         "\\sum_{i=1}^{N} \\exp(\\alpha (\\mathbf{X}^{\\top} \\xi)_i) +$ "
         "$\\frac{1}{2}\\xi^{\\top}\\xi$ and a update rule ξ_{new} = ξ - $\\gamma(\\xi$ - "
         "$\\tilde{\\textbf{X}}$ softmax $(\\alpha \\textbf{X}^{\\top} \\xi)$)"),
        ("emg.2.attention", "Sec. 2",
         "the attention mechanism can be understood as the energy update Q_{new} = softmax "
         "$(\\alpha QK)V$, when $\\gamma = 1$ and $\\alpha = 1/\\sqrt{d}$."),
        ("emg.3.1.c", "Sec. 3.1",
         "based on the text embedding $c \\in \\mathbb{R}^{N^t \\times d}$"),
        ("emg.3.1.kv", "Sec. 3.1",
         "K and V in cross attention is computed as $K = cW_K$ and $V = cW_V$, where $W_K, W_V "
         "\\in \\mathbb{R}^{d \\times d}$. To alleviate the impact of misalignment in "
         "multi-concept text embeddings, we focus on refining c through adaptive gradient "
         "descent (AGD) based on MAP estimation with $p(K|Q) \\propto p(Q|K)p(K)$."),
        ("emg.3.1.eq3_lhs", "Sec. 3.1, Eq. 3",
         "\\nabla_{\\mathbf{K}} \\log p(\\mathbf{K}|\\mathbf{Q}) = \\nabla_{\\mathbf{K}} "
         "E(\\mathbf{K}) - \\nabla_{\\mathbf{K}} E(\\mathbf{Q}|\\mathbf{K})"),
        ("emg.3.1.eq3_rhs", "Sec. 3.1, Eq. 3",
         "= \\underbrace{[\\text{SEM}(\\alpha \\mathbf{K} \\mathbf{Q}^{\\top})\\mathbf{Q}}"
         "_{Attention} - \\underbrace{\\mathcal{M}(\\text{SFM}(\\mathbf{K}'))\\mathbf{K}}"
         "_{Regularization}]W_{\\mathbf{K}},\\tag{3}"),
        ("emg.3.1.sfm", "Sec. 3.1, Eq. 3",
         "where SFM and M are softmax and diagonalization operator, respectively, $K' = "
         "\\frac{1}{2} \\sum_{i=1}^{N^t} k_i k_i^{\\top}$, k_i denotes the *i*-th row of K."),
        ("emg.3.1.eq4", "Sec. 3.1, Eq. 4",
         "Finally, c is refined with the step size γ : $$ \\hat{c} = c + \\gamma \\nabla_K "
         "\\log p(K|Q). \\tag{4} $$"),
        ("emg.3.2.eq5", "Sec. 3.2, Eq. 5",
         "With $\\mu_\\theta(\\cdot)$ approximated by $z_t - \\epsilon_\\theta(z_t, \\mathbf{c}, "
         "t)$ for small β_t , the denoising step can be written as:"),
        ("emg.3.2.eta", "Sec. 3.2, Eq. 6",
         "diffusion models can be interpreted as EBMs under the gradient descent step "
         "$\\eta = 1$"),
        ("emg.3.2.eq6", "Sec. 3.2, Eq. 6",
         "the Langevin Dynamicsbased MCMC sampling is one of the most popular strategies for the "
         "generative process. According to [7, 8, 38, 61], each gradient descent step in the "
         "sampling process is defined as $$ z_{t-1} = z_t - \\eta \\nabla_z E_\\theta(z_t, "
         "\\mathbf{c}) + \\mathcal{N}(0, \\tilde{\\beta}_t I), \\quad (6) $$"),
        ("emg.3.2.negation", "Sec. 3.2, before Eq. 8",
         "to define the probability distribution of negation as $p(z|c_i, \\text{not } c_j) "
         "\\sim \\frac{p(z)p(c_i|z)}{p(c_i|z)}$ $\\frac{z}{p(c_i | z)}$."),
        ("emg.3.2.eq8", "Sec. 3.2, Eq. 8",
         "\\epsilon_{\\theta}^{l}(z_t, t, \\mathbb{C}) = \\epsilon_{\\theta}(z_t, t) + "
         "w^{l}(\\epsilon_{\\theta}(z_t, t, \\mathbf{c}_i) - \\epsilon_{\\theta}(z_t, t, "
         "\\mathbf{c}_j))."),
        ("emg.3.2.eq9", "Sec. 3.2, Eq. 9",
         "we compose them by performing a weighted average: $$ \\hat{z}' = "
         "\\frac{1}{\\sum_{i=1}^{n} w_i^s} \\sum_{i=1}^{n} (w_i^s z_i'),\\tag{9} $$"),
        ("emg.3.2.negative_weight", "Sec. 3.2, after Eq. 9",
         "while $w^s < 0$ suggests a negation operation."),
        ("emg.4.guess", "Sec. 4", "GUESS [14] proposes a Gradually Enriching Synthesis strategy "
         "based on MLD."),
        ("emg.table4.header", "Table 4's header", "$Top-1$ $Top-3$ $Top-2$"),
        ("emg.B2.eq11", "appendix B.2, Eq. 11",
         "$M_3^t \\in \\mathbb{R}^{N' \\times d_m}$ indicates the overlapping part, where N' is "
         "the number of interval frame. Each reverse process can be formulated as: $$ "
         "M_{\\mathbf{c}_1, \\mathbf{c}_2}^t = M_{\\mathbf{c}_1}^t[:N_1 - N'] \\oplus "
         "(M_{\\mathbf{c}_1}^t[N_1 - N'] + M_{\\mathbf{c}_2}^t[:N'] - M_3^t) \\oplus "
         "M_{\\mathbf{c}_2}^t[N':],"),
        ("emg.G2.eq14", "appendix G.2, Eq. 14",
         "we randomly select 300 pairs of motions and compute this metric as follows: "
         "Diversity $$ =\\frac{1}{300} \\sum_{i=1}^{300} ||\\hat{m}_1 - \\hat{m}_2|| $$ (14)"),
        ("emg.1.compml", "Sec. 1",
         "comprising 5000 compositionally generated motion sequences with textual descriptions"),
        ("emg.5.1.compml", "Sec. 5.1", "CompML, which consists of 5000 unique motion-text pairs"),
        ("emg.5.2.tokens", "Sec. 5.2 and appendix A",
         "We use 10 additional tokens (mean and various tokens) to sample $N = 5$ latent "
         "vectors representing the motion."),
        ("emg.5.2.gamma", "Sec. 5.2",
         "we split γ into $[\\gamma_{attn}, \\gamma_{reg}]$ for compositional and "
         "multi-concept motion generation. [$\\gamma_{attn}, \\gamma_{reg}$] are set to "
         "[0.0004, 0.0004] [0.001, 0.002] for two tasks, respectively."),
        ("emg.5.2.lambda", "Sec. 5.2",
         "λ_s , λ_l , and λ_m are set to 0.7, 0.1, and 0.2 for compositional generation "
         "evaluation."),
        ("emg.5.3.improves", "Sec. 5.3 (Tables 1 and 2)",
         "Our method significantly improves the text-condition consistency and diversity "
         "compared with the existing diffusion models while achieving competitive results on "
         "fidelity."),
        ("emg.5.4.jitter", "Sec. 5.4 (Table 3)",
         "We empirically find that the motion jitter issue in FineMoGen [71] and ReMoDiffuse "
         "[70] hinders their performance on this task."),
        ("emg.5.4.agd", "Sec. 5.4 (Table 3)",
         "ENERGYMOGEN with adaptive gradient descent of text embeddings (in Equation 4) "
         "outperforms previous state-of-the-art methods on R-Precision, TMR-Score, and FID."),
        ("emg.5.4.sef", "Sec. 5.4 (Table 3)",
         "With synergistic energy fusion, ENERGYMOGEN significantly exhibits significant "
         "performance advantages over all prior methods."),
        ("emg.5.5.q1", "Sec. 5.5 Q1 (Table 3)",
         "It improves the R-Precision by 1.3% and 0.9% for Top1 and Top3 accuracy, "
         "respectively. Meanwhile, we achieve better FID and comparable results on the "
         "TMR-Score and transition distance."),
        ("emg.5.5.q2", "Sec. 5.5 Q2 (Table 3)",
         "Although the latent-aware method performs poorly on R-Precision and TMR Score, it "
         "clearly decreases the transition distance."),
        ("emg.B1.outperforms", "appendix B.1 (Table 4)",
         "Our approach outperforms current state-of-the-art skeleton-based methods, *i.e*., "
         "ReMoDiffuse [70] and FineMoGen [71] on R-Precision, Diversity, and MM-Dist, while "
         "achieves comparable results on FID and MModality."),
        ("emg.B2.first_take", "appendix B.2 (Table 5)",
         "We implement MotionDiffuse [69], ReMoDiffuse [70], and FineMoGen [71] using the "
         "\"first take\" from Prior-MDM [53]."),
        ("emg.B2.advantages", "appendix B.2 (Table 5)",
         "exhibits performance advantages compared with previous methods."),
        ("emg.B3.superior", "appendix B.3 (Table 6)",
         "By combining AGD, our approach achieves superior performance on R-Precision, "
         "TMR-Score, and Transition distance."),
        ("emg.C.first_three", "appendix C (Table 7)",
         "correspond to \"Ours (latent only)\", \"Ours (semantic only)\", and \"Ours\" in "
         "Table 3, respectively."),
        ("emg.C.trend", "appendix C (Table 7) and Table 7's caption",
         "as shown in the middle five rows (Ta-ble 7). We find that as the weight of λ_s "
         "increases, the results align more closely with the text (R-Precision and "
         "TMR-Score), while larger weights for λ_l produce smoother motions (Transition "
         "distance)."),
        ("emg.C.best", "appendix C (Table 7)",
         "combining multiconcept motion generation can further improve the performance, as "
         "shown in the last 4 rows. It can be seen that Synergistic Energy Fusion with "
         "$\\lambda_l = 0.1$, $\\lambda_s = 0.7$, and $\\lambda_m = 0.2$ achieves best "
         "performance."),
        ("emg.D.best", "appendix D (Table 8)",
         "For reconstruction, 7 latent vectors achieve the best results. However, it increases "
         "the difficulty of latent diffusion models in training. Using 5 latent vectors to "
         "represent the motion obtains the best textto-motion generation performance."),
        ("emg.E.best", "appendix E (Table 9)",
         "We notice that $\\gamma_{attn}, \\gamma_{reg} >= 0.1$ significantly degrades the "
         "performance, and $\\gamma_{attn}, \\gamma_{reg} = [0.001, 0.002]$ achieves best "
         "results on MTT"),
        ("emg.A.vae", "appendix A",
         "We train 300K iterations in total, and the learning rate changes from 0.0001 to "
         "0.00001 after 200K iterations."),
        ("emg.A.denoiser", "appendix A",
         "with an initial learning rate of 0.0001 for 200K iterations and decayed to 0.00001 "
         "for another 100K iterations."),
        ("emg.G1.humanml3d", "appendix G.1",
         "contains 14,616 human motions with 44,970 textual descriptions. The dataset is split "
         "with proportions of 80%, 5%, and 15% for training, validation, and testing, "
         "respectively."),
        ("emg.G1.kit", "appendix G.1",
         "It has 3,911 finely annotated human motions, with 4888/300/830 for the training, "
         "validation, and test sets."),
        ("emg.G2.features", "appendix G.2",
         "We denote two sets of features from the ground truth and generated motion as m and "
         "\\hat{m} , respectively."),
        ("emg.G2.mm_dist", "appendix G.2, Eq. 13",
         "MM-Dist. MM-Dist is used to measure the distance between the generated motion and "
         "text directly: $$ MM\\text{-}Dist = \\frac{1}{N} \\sum_{i=1}^{N} ||m_i - "
         "\\hat{m}_i|| \\tag{13} $$"),
        ("emg.G2.diversity", "appendix G.2",
         "we randomly select 300 pairs of motions"),
        ("emg.ref.13", "references", "[13] Xuehao Gao, Yang Yang, Zhenyu Xie, Shaoyi Du, "
         "Zhongqian Sun, and Yang Wu. Guess gradually enriching synthesis"),
        ("emg.ref.14", "references", "[14] Xuehao Gao, Yang Yang, Zhenyu Xie, Shaoyi Du, "
         "Zhongqian Sun, and Yang Wu. Guess: Gradually enriching synthesis"),
        ("emg.ref.53", "references", "[53] Yoni Shafir, Guy Tevet, Roy Kapon, and Amit Haim "
         "Bermano. Human motion diffusion as a generative prior."),
        ("emg.ref.69", "references", "[69] Mingyuan Zhang, Zhongang Cai, Liang Pan, Fangzhou "
         "Hong, Xinying Guo, Lei Yang, and Ziwei Liu. Motiondiffuse"),
        ("emg.ref.71", "references", "[71] Mingyuan Zhang, Huirong Li, Zhongang Cai, Jiawei "
         "Ren, Lei Yang, and Ziwei Liu. Finemogen"),
        ("emg.ref.73", "references", "[73] Zeyu Zhang, Akide Liu, Ian Reid, Richard Hartley, "
         "Bohan Zhuang, and Hao Tang. Motion mamba"),
        ("emg.G2.mmodality", "appendix G.2",
         "generate 30 motion samples from one text and randomly select two subsets, each "
         "containing 10 motions."),
    ),
}
