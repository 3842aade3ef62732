"""HTML pages that read offline: Markdown rendered once, its math typeset at build time.

Both the report (REPORT.md → REPORT.html) and the executed notebooks go through nbconvert's
Markdown (mistune with Jupyter's math syntax: ``$…$``, ``$$…$$``, ``\\(…\\)``, ``\\[…\\]``,
``\\begin{env}…\\end{env}``), whose renderer here writes each formula as MathML
(``latex2mathml``) instead of leaving TeX for MathJax to typeset from a CDN: a browser lays
MathML out itself (MathML Core), so a page shows its equations without the network and the
same source always gives the same page. Inline ``$…$`` follows pandoc's rule (no space inside
the dollars, no digit after the closing one), so ``$REPRO_CACHE_DIR`` in a path or two prices
in one sentence stay text. A formula latex2mathml cannot read stays as its TeX, with a
warning, where ``scripts/check_rendered.py`` finds it.

The notebook exporter (:func:`notebook_exporter`) is nbconvert's lab template without the
scripts it fetches from a CDN (MathJax, require.js, mermaid); ``text/latex`` outputs are
typeset like Markdown math.
"""

from __future__ import annotations

import html
import re
import warnings
from typing import Any

from jinja2 import DictLoader, pass_context
from latex2mathml.converter import convert as latex_to_mathml
from nbconvert import HTMLExporter
from nbconvert.filters.markdown_mistune import (
    IPythonRenderer,
    MarkdownWithMath,
    MathInlineParser,
)

#: inline ``$…$`` as pandoc reads it: a non-space after the opening dollar, a non-space before
#: the closing one, no digit after it (``$5 and $10`` is text); no ``$`` or backtick inside
INLINE_DOLLARS = (r"(?s:(?<![$\\\w])\$(?=[^\s$])(?P<math_inline_tex>(?:[^$`\\]|\\.)+?)"
                  r"(?<![\s\\])\$(?!\d))")


class StrictMathInlineParser(MathInlineParser):
    """nbconvert's math-aware inline parser with pandoc's rule for ``$…$``."""

    SPECIFICATION = {**MathInlineParser.SPECIFICATION, "inline_math_tex": INLINE_DOLLARS}


def mathml(tex: str, *, display: bool = False) -> str:
    """``tex`` as a MathML ``<math>`` element; on TeX latex2mathml cannot read, the TeX in its
    delimiters (escaped) and a warning, so the check of the rendered page fails on it."""
    try:
        return latex_to_mathml(tex, display="block" if display else "inline")
    except Exception as error:  # latex2mathml raises several types on bad input
        warnings.warn(f"formula left as TeX ({type(error).__name__}: {error}): {tex!r}",
                      stacklevel=2)
        return html.escape(f"$${tex}$$" if display else f"${tex}$", quote=False)


class MathMLRenderer(IPythonRenderer):
    """nbconvert's Markdown renderer, its math written as MathML."""

    def block_math(self, body: str) -> str:
        return mathml(body, display=True)

    def inline_math(self, body: str) -> str:
        return mathml(body)

    def latex_environment(self, name: str, body: str) -> str:
        return mathml(f"\\begin{{{name}}}{body}\\end{{{name}}}", display=True)


def slug(text: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces as ``-``
    (``GMD-A3 — inconclusive`` → ``gmd-a3--inconclusive``)."""
    plain = html.unescape(re.sub(r"<[^>]+>", "", text)).strip().lower()
    return re.sub(r"[^\w\- ]", "", plain).replace(" ", "-")


class ReportRenderer(MathMLRenderer):
    """The report's renderer: headings carry GitHub's anchors (a second equal one ``-1``),
    so a link written for REPORT.md on GitHub works in REPORT.html too."""

    def __init__(self) -> None:
        super().__init__(escape=False, exclude_anchor_links=True)
        self._seen: dict[str, int] = {}

    def heading(self, text: str, level: int, **attrs: Any) -> str:
        anchor = slug(text)
        count = self._seen.get(anchor, 0)
        self._seen[anchor] = count + 1
        anchor = f"{anchor}-{count}" if count else anchor
        return f'<h{level} id="{html.escape(anchor)}">{text}</h{level}>\n'


def markdown_html(markdown: str) -> str:
    """The HTML body of ``markdown`` (GitHub's tables and heading anchors, math as MathML;
    HTML written in the Markdown is kept)."""
    return MarkdownWithMath(renderer=ReportRenderer(),
                            inline=StrictMathInlineParser(hard_wrap=False)).render(markdown)


REPORT_STYLE = """
body{font-family:system-ui,sans-serif;line-height:1.45;max-width:78rem;margin:auto;
padding:0 1rem;color:#1f2328}
table{border-collapse:collapse;display:block;overflow-x:auto;font-size:.9rem;margin:.5rem 0}
td,th{border:1px solid #d0d7de;padding:.25rem .5rem;vertical-align:top;text-align:left}
td:first-child{white-space:nowrap}
th{background:#f6f8fa}
img{max-width:100%}
code{background:#f6f8fa;padding:0 .2rem;border-radius:3px;overflow-wrap:anywhere}
h2{border-bottom:1px solid #d0d7de;padding-bottom:.2rem;margin-top:2.5rem}
math[display=block]{margin:.5rem 0}
"""


def report_page(markdown: str, title: str) -> str:
    """A whole page of ``markdown`` (:func:`markdown_html`) with a small style sheet."""
    return ("<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{html.escape(title)}</title>\n<style>{REPORT_STYLE}</style>\n</head>\n"
            f"<body>\n{markdown_html(markdown)}</body>\n</html>\n")


#: nbconvert's lab template without the scripts it loads from a CDN; LaTeX outputs typeset
OFFLINE_TEMPLATE = """{%- extends 'lab/index.html.j2' -%}
{%- block html_head_js_requirejs -%}{%- endblock html_head_js_requirejs -%}
{%- block html_head_js_mathjax -%}{%- endblock html_head_js_mathjax -%}
{%- block html_head_js_mermaidjs -%}{%- endblock html_head_js_mermaidjs -%}
{% block data_latex scoped %}
<div class="jp-RenderedLatex jp-OutputArea-output {{ extra_class }}" data-mime-type="text/latex">
{{ output.data['text/latex'] | markdown2html }}
</div>
{%- endblock data_latex %}
"""


class OfflineHTMLExporter(HTMLExporter):
    """nbconvert's HTML exporter whose pages need no network: Markdown math as MathML
    (:class:`MathMLRenderer`), no script from a CDN (:data:`OFFLINE_TEMPLATE`)."""

    @pass_context
    def markdown2html(self, context: Any, source: str) -> str:
        cell = context.get("cell", {})
        renderer = MathMLRenderer(
            escape=False, attachments=cell.get("attachments", {}),
            embed_images=self.embed_images,
            path=context.get("resources", {}).get("metadata", {}).get("path", ""),
            anchor_link_text=self.anchor_link_text,
            exclude_anchor_links=self.exclude_anchor_links, **self.lexer_options)
        return MarkdownWithMath(renderer=renderer,
                                inline=StrictMathInlineParser(hard_wrap=False)).render(source)


def notebook_exporter() -> HTMLExporter:
    """The exporter of the executed notebooks: :class:`OfflineHTMLExporter`, figures
    embedded."""
    exporter = OfflineHTMLExporter(
        extra_loaders=[DictLoader({"offline.html.j2": OFFLINE_TEMPLATE})],
        template_file="offline.html.j2")
    exporter.embed_images = True
    return exporter
