"""Seeds drawn inside ``fit`` from the ``random_state`` hyperparameter.

``None`` draws fresh entropy without touching numpy's global generator, an
integer gives the same seeds on every call (and in every joblib worker), and
a ``RandomState`` or a ``Generator`` is honoured: its stream is advanced, as
scikit-learn does with the generators it is given.
"""

from __future__ import annotations

from collections.abc import Iterator
from numbers import Integral

import numpy as np

__all__ = ["check_seed_source", "seeds"]

_HIGH = 2**31 - 1


def check_seed_source(random_state, name: str = "random_state") -> None:
    """Refuse anything but None, a non-negative integer, a RandomState or a Generator."""
    if random_state is None or isinstance(random_state, (np.random.RandomState,
                                                         np.random.Generator)):
        return
    if isinstance(random_state, Integral) and not isinstance(random_state, bool) \
            and 0 <= random_state < 2**32:
        return
    raise ValueError(f"{name} must be None, an integer in [0, 2**32), a numpy RandomState or "
                     f"a numpy Generator, got {random_state!r}")


def seeds(random_state) -> Iterator[int]:
    """An endless stream of integer seeds in ``[0, 2**31 - 1)`` from ``random_state``."""
    check_seed_source(random_state)
    if isinstance(random_state, np.random.Generator):
        while True:
            yield int(random_state.integers(0, _HIGH))
    if random_state is None:  # fresh entropy; numpy's global generator is left alone
        random_state = np.random.RandomState(np.random.SeedSequence().generate_state(4))
    elif not isinstance(random_state, np.random.RandomState):
        # an integer seeds the stream scikit-learn's check_random_state would give
        random_state = np.random.RandomState(random_state)
    while True:
        yield int(random_state.randint(0, _HIGH))
