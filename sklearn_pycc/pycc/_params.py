"""Reading the paper's ``params`` dicts: known keys, defaults, and no silent typos."""

from __future__ import annotations

import difflib
import warnings
from collections.abc import Mapping

__all__ = ["Params"]


class Params:
    """One ``params`` dict of the functional API, checked against the keys it may hold.

    Parameters
    ----------
    params : dict or None
        What the user gave.
    known : dict
        Every accepted key -> its default (``REQUIRED`` for a key that must
        be given).
    where : str
        The call, for messages (``"train(method='NN')"``).
    ignored : dict, optional
        Keys accepted for compatibility that have no counterpart here ->
        why; giving one warns once, naming it and the reason.
    """

    REQUIRED = object()

    def __init__(self, params: Mapping | None, known: Mapping, where: str,
                 ignored: Mapping[str, str] | None = None) -> None:
        if params is None:
            params = {}
        if not isinstance(params, Mapping):
            raise TypeError(f"{where}: params must be a dict, got {type(params).__name__}")
        ignored = dict(ignored or {})
        accepted = [*known, *ignored]
        for key in params:
            if key not in accepted:
                close = difflib.get_close_matches(str(key), accepted, n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise ValueError(f"{where}: params has the unknown key {key!r}{hint} "
                                 f"Known keys: {', '.join(sorted(accepted))}")
        for key, default in known.items():
            if default is self.REQUIRED and key not in params:
                raise ValueError(f"{where}: params must give {key!r}")
        unused = [key for key in params if key in ignored]
        if unused:
            reasons = "; ".join(f"{key!r}: {ignored[key]}" for key in unused)
            warnings.warn(f"{where}: params keys without a counterpart here are ignored "
                          f"({reasons})", UserWarning, stacklevel=3)
        self._values = {key: params.get(key, default) for key, default in known.items()}
        self._supplied = set(params)
        self.where = where

    def __getitem__(self, key: str):
        return self._values[key]

    def get(self, key: str, default=None):
        """The value of ``key``, or ``default`` for a key this call does not take."""
        return self._values.get(key, default)

    def supplied(self, key: str) -> bool:
        """Whether the user gave ``key``."""
        return key in self._supplied

    def given(self, key: str) -> bool:
        """Whether ``key`` holds something other than None."""
        return self._values.get(key) is not None
