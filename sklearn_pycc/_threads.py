"""Thread policy: small dense problems run on one BLAS thread inside ``fit``.

On 2-core machines, a tall-skinny least-squares solve with two OpenBLAS
threads was measured 100x slower than with one while the other core was
busy (as in ``GridSearchCV(n_jobs=2)``). The limit is applied for the
duration of ``fit`` and the previous setting restored afterwards.
"""

from __future__ import annotations

from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

__all__ = ["blas_threads"]

_controller: ThreadpoolController | None = None


@contextmanager
def blas_threads(n: int = 1):
    """Limit BLAS threads to ``n`` inside the block, restoring the setting after."""
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    with _controller.limit(limits=n, user_api="blas"):
        yield
