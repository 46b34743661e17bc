"""Functions generated as Python source by the package itself, compiled once per source.

The right-hand side of a skeleton and the Runge-Kutta loop around it are
written out as statements (see :mod:`sklearn_pycc.skeleton.python_source`)
from the tree the package's own parser built: a variable is a numbered
local, every number and function is bound by a generated name in the
namespace. No text of the user's is ever compiled here.
"""

from __future__ import annotations

from collections.abc import Callable
from types import CodeType

__all__ = ["generated_function"]

#: source -> its compiled code: a fit compiles the same skeleton for every trial of its
#: numbers, which only the namespace holds
_CODE: dict[str, CodeType] = {}
_MOST_CODES = 256


def generated_function(source: str, namespace: dict, name: str) -> Callable:
    """The function ``name`` that ``source`` defines, its globals ``namespace`` (a copy)."""
    code = _CODE.get(source)
    if code is None:
        if len(_CODE) >= _MOST_CODES:
            _CODE.clear()
        code = _CODE[source] = compile(source, f"<generated {name}>", "exec")
    scope = dict(namespace)
    exec(code, scope)
    return scope[name]
