"""Reading the paper's ``params`` dicts: known keys, defaults, notes, and no silent typos."""

from __future__ import annotations

import difflib
import math
import warnings
from collections.abc import Mapping
from numbers import Integral, Real

__all__ = ["Params"]


class Params:
    """One ``params`` dict of the functional API, checked against the keys it may hold.

    Every key the published package reads is known: it is either mapped
    onto an estimator or accepted with a note saying why it has no effect
    here. Notes are collected and said in one warning per call
    (:meth:`warn`); a key the published package never read is an error
    naming the nearest known key.

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
        why; giving one adds a note naming it and the reason.
    name : str, default="params"
        What the dict is called, for messages (``"params_simul"``).
    """

    REQUIRED = object()

    def __init__(self, params: Mapping | None, known: Mapping, where: str,
                 ignored: Mapping[str, str] | None = None, name: str = "params") -> None:
        if params is None:
            params = {}
        if not isinstance(params, Mapping):
            raise TypeError(f"{where}: {name} must be a dict, got {type(params).__name__}")
        ignored = dict(ignored or {})
        accepted = [*known, *ignored]
        for key in params:
            if key not in accepted:
                close = difflib.get_close_matches(str(key), accepted, n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise ValueError(f"{where}: {name} has the unknown key {key!r}{hint} "
                                 f"Known keys: {', '.join(sorted(accepted))}")
        for key, default in known.items():
            if default is self.REQUIRED and key not in params:
                raise ValueError(f"{where}: {name} must give {key!r}")
        self.where = where
        self.notes: list[str] = []
        by_reason: dict[str, list[str]] = {}
        for key in params:
            if key in ignored:
                by_reason.setdefault(ignored[key], []).append(repr(key))
        for reason, keys in by_reason.items():
            verb = "has" if len(keys) == 1 else "have"
            self.note(f"{', '.join(keys)} {verb} no effect ({reason})")
        self._values = {key: params.get(key, default) for key, default in known.items()}
        self._supplied = set(params)

    def __getitem__(self, key: str):
        return self._values[key]

    def get(self, key: str, default=None):
        """The value of ``key``, or ``default`` for a key this call does not take."""
        return self._values.get(key, default)

    def integer(self, key: str, least: int = 0) -> int:
        """``key``'s value as a whole number of at least ``least``, or an error naming it.

        ``2.0`` is 2; ``2.7``, ``"five"``, NaN and booleans are refused rather
        than truncated or converted.
        """
        value = self._values[key]
        number = value
        if isinstance(value, Real) and not isinstance(value, (bool, Integral)) \
                and math.isfinite(value) and float(value).is_integer():
            number = int(value)
        if isinstance(number, bool) or not isinstance(number, Integral) or number < least:
            raise ValueError(f"{self.where}: {key!r} must be a whole number of at least "
                             f"{least}, got {value!r}")
        return int(number)

    def number(self, key: str, positive: bool = False) -> float:
        """``key``'s value as a finite float (positive when asked), or an error naming it."""
        value = self._values[key]
        if isinstance(value, bool) or not isinstance(value, Real) \
                or not math.isfinite(value) or (positive and value <= 0):
            kind = "a positive finite number" if positive else "a finite number"
            raise ValueError(f"{self.where}: {key!r} must be {kind}, got {value!r}")
        return float(value)

    def supplied(self, key: str) -> bool:
        """Whether the user gave ``key``."""
        return key in self._supplied

    def given(self, key: str) -> bool:
        """Whether ``key`` holds something other than None."""
        return self._values.get(key) is not None

    def note(self, text: str) -> None:
        """Add ``text`` to what :meth:`warn` will say (said once, however often added)."""
        if text not in self.notes:
            self.notes.append(text)

    def warn(self, stacklevel: int = 3) -> None:
        """Say every note in one ``UserWarning``, then forget them.

        Parameters
        ----------
        stacklevel : int, default=3
            As for :func:`warnings.warn`, counted from this method: 3 names
            the line that called the public function calling this one.
        """
        if not self.notes:
            return
        text = "; ".join(self.notes)
        self.notes = []
        warnings.warn(f"{self.where}: params that work differently here: {text}",
                      UserWarning, stacklevel=stacklevel)
