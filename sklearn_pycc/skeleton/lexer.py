"""Tokenizer of the skeleton language.

Only numbers, names, the operators ``+ - * / ^ **``, parentheses, commas and
``=`` exist; any other character (quotes, dots outside numbers, brackets,
colons, ...) is an error, so no Python construct can be smuggled through.
"""

from __future__ import annotations

import keyword
import math
from dataclasses import dataclass

from ..exceptions import SkeletonError

__all__ = ["Token", "tokenize"]

_OPERATORS = {"+", "-", "*", "/", "^", "(", ")", "=", ","}
#: only these digits make numbers (``str.isdigit`` also accepts Arabic-Indic,
#: fullwidth and superscript digits)
_DIGITS = frozenset("0123456789")
_SUPERSCRIPTS = frozenset("⁰¹²³⁴⁵⁶⁷⁸⁹")


@dataclass(frozen=True)
class Token:
    """One lexical token: ``kind`` is NUMBER, NAME, OP or END."""

    kind: str
    text: str
    pos: int


def _error(message: str, text: str, pos: int, index: int | None, kind: str) -> SkeletonError:
    return SkeletonError(message, equation=index, position=pos, text=text, kind=kind)


def _scan_number(text: str, i: int) -> int:
    """Return the end offset of the number starting at ``i``."""
    n = len(text)
    j = i
    while j < n and text[j] in _DIGITS:
        j += 1
    if j < n and text[j] == ".":
        j += 1
        while j < n and text[j] in _DIGITS:
            j += 1
    if j < n and text[j] in "eE":
        k = j + 1
        if k < n and text[k] in "+-":
            k += 1
        if k < n and text[k] in _DIGITS:
            while k < n and text[k] in _DIGITS:
                k += 1
            j = k
    return j


def _check_number(text: str, start: int, end: int, index: int | None, kind: str) -> None:
    """Refuse literals that overflow to infinity or underflow to zero."""
    value = float(text[start:end])
    if math.isinf(value):
        raise _error(f"the number {text[start:end]} is too large for double precision",
                     text, start, index, kind)
    mantissa = text[start:end].lower().split("e")[0]
    if value == 0.0 and any(c in "123456789" for c in mantissa):
        raise _error(f"the number {text[start:end]} is too small for double precision "
                     "(it would be read as 0)", text, start, index, kind)


def tokenize(text: str, index: int | None = None, kind: str = "equations") -> list[Token]:
    """Split ``text`` into tokens.

    Parameters
    ----------
    text : str
        One equation or constraint.
    index : int, optional
        Its position in the user's list, for error messages.
    kind : str
        ``"equations"`` or ``"constraints"``, for error messages.

    Returns
    -------
    list of Token
        The tokens, ending with an END token.
    """
    tokens: list[Token] = []
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        if ch.isspace():
            i += 1
        elif ch in _DIGITS or (ch == "." and i + 1 < n and text[i + 1] in _DIGITS):
            j = _scan_number(text, i)
            if j < n and text[j] == ".":
                raise _error("malformed number", text, j, index, kind)
            _check_number(text, i, j, index, kind)
            tokens.append(Token("NUMBER", text[i:j], i))
            i = j
        elif ch in _SUPERSCRIPTS:
            raise _error(f"superscript {ch!r} is not a power: write '^2' or '**2'", text, i,
                         index, kind)
        elif ch.isdigit():
            raise _error(f"numbers are written with the digits 0-9, got {ch!r}", text, i,
                         index, kind)
        elif ch.isalpha() or ch == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            name = text[i:j]
            if not name.isascii():
                odd = next(k for k in range(i, j) if not text[k].isascii())
                hint = (": a superscript is not a power, write '^2'"
                        if text[odd] in _SUPERSCRIPTS else "")
                raise _error(f"names must be ASCII, got {name!r}{hint}", text, odd, index,
                             kind)
            if name.startswith("__"):
                raise _error(f"names may not start with '__' ({name!r})", text, i, index, kind)
            if keyword.iskeyword(name) or keyword.issoftkeyword(name):
                raise _error(f"{name!r} is a reserved word", text, i, index, kind)
            tokens.append(Token("NAME", name, i))
            i = j
        elif text.startswith("**", i):
            tokens.append(Token("OP", "^", i))
            i += 2
        elif ch in _OPERATORS:
            tokens.append(Token("OP", ch, i))
            i += 1
        elif ch in "<>" and kind == "constraints":  # bounds: "a2 >= 0", "0 <= a3 <= 10"
            width = 2 if text.startswith("=", i + 1) else 1
            tokens.append(Token("OP", text[i:i + width], i))
            i += width
        else:
            raise _error(f"unexpected character {ch!r}", text, i, index, kind)
    tokens.append(Token("END", "", n))
    return tokens
