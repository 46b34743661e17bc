"""Tokenizer of the skeleton language.

Only numbers, names, the operators ``+ - * / ^ **``, parentheses, commas and
``=`` exist; any other character (quotes, dots outside numbers, brackets,
colons, ...) is an error, so no Python construct can be smuggled through.
"""

from __future__ import annotations

import keyword
from dataclasses import dataclass

from ..exceptions import SkeletonError

__all__ = ["Token", "tokenize"]

_OPERATORS = {"+", "-", "*", "/", "^", "(", ")", "=", ","}


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
    while j < n and text[j].isdigit():
        j += 1
    if j < n and text[j] == ".":
        j += 1
        while j < n and text[j].isdigit():
            j += 1
    if j < n and text[j] in "eE":
        k = j + 1
        if k < n and text[k] in "+-":
            k += 1
        if k < n and text[k].isdigit():
            while k < n and text[k].isdigit():
                k += 1
            j = k
    return j


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
        elif ch.isdigit() or (ch == "." and i + 1 < n and text[i + 1].isdigit()):
            j = _scan_number(text, i)
            if j < n and text[j] == ".":
                raise _error("malformed number", text, j, index, kind)
            tokens.append(Token("NUMBER", text[i:j], i))
            i = j
        elif ch.isalpha() or ch == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            name = text[i:j]
            if not name.isascii():
                raise _error(f"names must be ASCII, got {name!r}", text, i, index, kind)
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
