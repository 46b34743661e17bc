"""Thread policy: small dense problems run on one thread inside ``fit``.

On 2-core machines, a tall-skinny least-squares solve with two OpenBLAS
threads was measured 100x slower than with one while the other core was
busy (as in ``GridSearchCV(n_jobs=2)``), and small torch networks train
fastest on one intra-op thread. The limits are applied for the duration of
``fit`` and the previous settings restored afterwards.

Both settings belong to the whole process, so fits running at once in
several threads share one limit: the first to enter saves the setting and
applies the limit, the last to leave restores what the first saved (a
plain save-and-restore per fit would leave the limit in place when two fits
overlap).
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["blas_threads", "torch_threads"]


class _SharedLimit:
    """A process-wide setting limited while at least one block is inside."""

    def __init__(self, apply: Callable[[int], Callable[[], None]]) -> None:
        self._apply = apply  # applies a limit, returns how to restore the previous setting
        self._lock = threading.Lock()
        self._inside = 0
        self._restore: Callable[[], None] | None = None

    @contextmanager
    def __call__(self, n: int) -> Iterator[None]:
        with self._lock:
            if self._inside == 0:
                self._restore = self._apply(n)
            self._inside += 1
        try:
            yield
        finally:
            with self._lock:
                self._inside -= 1
                if self._inside == 0:
                    restore, self._restore = self._restore, None
                    restore()


#: the BLAS libraries found, and how many modules were imported when they were looked for:
#: finding them reads the process's memory map (milliseconds, more than a small fit's
#: solve), and only an import can load a new one
_controller: list = [None, -1]


def _limit_blas(n: int) -> Callable[[], None]:
    from threadpoolctl import ThreadpoolController

    if _controller[1] != len(sys.modules):
        _controller[:] = [ThreadpoolController(), len(sys.modules)]
    limiter = _controller[0].limit(limits=n, user_api="blas")
    return limiter.restore_original_limits


def _limit_torch(n: int) -> Callable[[], None]:
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(n)
    return lambda: torch.set_num_threads(previous)


_blas = _SharedLimit(_limit_blas)
_torch = _SharedLimit(_limit_torch)


@contextmanager
def blas_threads(n: int = 1) -> Iterator[None]:
    """Limit BLAS threads to ``n`` inside the block, restoring the setting after."""
    with _blas(n):
        yield


@contextmanager
def torch_threads(n: int | None) -> Iterator[None]:
    """Run the block with ``n`` intra-op torch threads (None: leave them), restoring after."""
    if n is None:
        yield
        return
    with _torch(n):
        yield
