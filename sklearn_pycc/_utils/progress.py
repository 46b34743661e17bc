"""What long work says while it runs (``verbose``): its stages, and a bar over its steps.

Nothing is shown at ``verbose=0``. At 1 each stage is written as it starts,
with the seconds since the work began, through tqdm (a line in a terminal,
under the cell's bar in a notebook), and :meth:`Progress.bar` draws a bar
over a stage's steps (tqdm's notebook widget where one runs).
"""

from __future__ import annotations

import contextlib
import time

__all__ = ["Progress", "duration"]


def duration(seconds: float) -> str:
    """A duration in words: seconds, minutes or hours."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class Progress:
    """The stages of one piece of work, said as they start where ``verbose`` asks.

    Parameters
    ----------
    who : str
        What works, at the head of each line (``"PolyCCRegressor.fit"``).
    verbose : int
        0: silent; 1 or more: stages and bars.
    """

    def __init__(self, who: str, verbose: int) -> None:
        self.who = who
        self.verbose = int(verbose or 0)
        self.start = time.perf_counter()

    @property
    def shown(self) -> bool:
        """Whether anything is shown."""
        return self.verbose >= 1

    def stage(self, text: str) -> None:
        """Say that a stage starts."""
        if not self.shown:
            return
        from tqdm.auto import tqdm

        tqdm.write(f"{self.who}: {text} [{time.perf_counter() - self.start:.1f} s]")

    @contextlib.contextmanager
    def bar(self, total: int | None, unit: str, desc: str):
        """A ``step(n=1)`` callback drawing a bar over ``total`` steps (a no-op when silent)."""
        if not self.shown:
            yield lambda n=1: None
            return
        from tqdm.auto import tqdm

        bar = tqdm(total=total, unit=unit, desc=desc, leave=False)
        try:
            yield bar.update
        finally:
            bar.close()
