"""Self-contained HTML: fitted equations as MathML, tables, figures as embedded PNG.

Everything a page needs is inside it: figures are base64 PNG, styles are
inline, and the maths is MathML, which browsers render themselves, so a
report opens offline and reads the same years later.
"""

from __future__ import annotations

import base64
import html
import io
import re
from html.entities import html5

import pandas as pd

__all__ = ["equations_html", "figure_html", "page", "preformatted", "table_html"]

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 70em; padding: 0 1em; color: #222; line-height: 1.45; }
h1, h2, h3 { font-weight: 600; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
pre { background: #f6f6f6; padding: .8em; font-size: .85em; white-space: pre-wrap; }
.pycc-scroll { overflow-x: auto; }
table.pycc { border-collapse: collapse; font-size: .85em; margin: .6em 0; }
table.pycc th, table.pycc td { border-bottom: 1px solid #ddd; padding: .25em .6em;
                               text-align: right; white-space: nowrap; }
table.pycc td:last-child { white-space: normal; min-width: 14em; text-align: left; }
table.pycc th { background: #f0f0f0; }
figure { margin: 1em 0; }
figure img { max-width: 100%; }
figcaption { font-size: .85em; color: #555; }
.pycc-equations { margin: .6em 0 .6em 1em; }
.pycc-note { font-size: .85em; color: #555; }
"""


def preformatted(text: str) -> str:
    """``text`` as an escaped ``<pre>`` block."""
    return f"<pre>{html.escape(text)}</pre>"


def table_html(frame: pd.DataFrame, precision: int = 4) -> str:
    """A DataFrame as an HTML table (numbers to ``precision`` significant digits)."""
    def number(value: float) -> str:
        return f"{value:.{precision}g}"

    table = frame.to_html(classes="pycc", border=0, float_format=number, na_rep="",
                          escape=True)
    return f'<div class="pycc-scroll">{table}</div>'


def figure_html(fig, caption: str = "", dpi: int = 100) -> str:
    """A matplotlib figure as an embedded PNG (the figure is closed)."""
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    data = base64.b64encode(buffer.getvalue()).decode("ascii")
    alt = html.escape(caption or "figure")
    text = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return f'<figure><img alt="{alt}" src="data:image/png;base64,{data}"/>{text}</figure>'


def _numeric_entities(markup: str) -> str:
    """Named character references as numeric ones (XML parsers know no ``&InvisibleTimes;``)."""
    def replace(match: re.Match) -> str:
        name = match.group(1)
        if name in ("amp", "lt", "gt", "quot", "apos"):
            return match.group(0)
        text = html5.get(name + ";")
        return "".join(f"&#{ord(c)};" for c in text) if text else match.group(0)

    return re.sub(r"&([A-Za-z][A-Za-z0-9]*);", replace, markup)


def _identifier(name: str) -> str:
    """MathML of a variable name: ``x2`` as x with subscript 2, ``x2_dot`` with a dot."""
    dot = name.endswith("_dot")
    base = name[:-4] if dot else name
    match = re.fullmatch(r"([A-Za-z]+)_?(\d+)", base) or re.fullmatch(
        r"([A-Za-z]+)_([A-Za-z0-9]+)", base)
    letters, index = (match.group(1), match.group(2)) if match else (base, "")
    core = f"<mi>{html.escape(letters)}</mi>"
    if dot:
        core = f"<mover accent=\"true\">{core}<mo>&#729;</mo></mover>"
    if index:
        tag = "mn" if index.isdigit() else "mi"
        core = f"<msub>{core}<{tag}>{html.escape(index)}</{tag}></msub>"
    return core


def _mathml(expression) -> str:
    import sympy
    from sympy.printing.mathml import mathml

    if isinstance(expression, sympy.Symbol):
        return _identifier(expression.name)
    expression = expression.evalf(6)
    # every name through our own form (x2_dot with a dot, x2 with a subscript)
    names = {s: sympy.Symbol(f"PYCCNAME{_letters(k)}") for k, s in enumerate(
        sorted(expression.free_symbols, key=lambda s: s.name))}
    markup = mathml(expression.xreplace(names), printer="presentation")
    for original, placeholder in names.items():
        markup = markup.replace(f"<mi>{placeholder.name}</mi>", _identifier(original.name))
    return _numeric_entities(markup)


def _letters(k: int) -> str:
    """``k`` written in letters (sympy would read digits in a name as a subscript)."""
    out = ""
    while True:
        k, digit = divmod(k, 26)
        out += chr(ord("a") + digit)
        if k == 0:
            return out


def equations_html(model) -> str:
    """The fitted equations of ``model`` as MathML, one block per equation."""
    blocks = []
    for equation in model.to_sympy():
        blocks.append(f'<math display="block" style="margin: .5em 0; font-size: 1.15em">'
                      f"{_mathml(equation.lhs)}<mo>=</mo>{_mathml(equation.rhs)}</math>")
    notes = []
    for name, curve in model.functions_.items():
        if curve.to_sympy(_placeholder()) is None:
            notes.append(f"{name} has no closed form ({type(curve).__name__}, "
                         f"{curve.n_numbers} fitted numbers)")
    note = (f'<p class="pycc-note">{html.escape("; ".join(notes))}.</p>' if notes else "")
    return f'<div class="pycc-equations">{"".join(blocks)}{note}</div>'


def _placeholder():
    import sympy

    return sympy.Symbol("u")


def page(title: str, body: str) -> str:
    """A whole HTML document: ``body`` with the styles inline, nothing fetched."""
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"/>'
            f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>"
            f"<body>{body}</body></html>\n")

