"""Cross-validation splitters for trajectories."""

from __future__ import annotations

from collections.abc import Iterator
from numbers import Integral

import numpy as np
import pandas as pd
from sklearn.model_selection import BaseCrossValidator

from ..measurements.experiments import TRAJECTORY

__all__ = ["BlockSplit", "ExperimentSplit"]


def _labels(X, groups, who: str) -> np.ndarray:
    if groups is not None:
        labels = np.asarray(groups, dtype=object)
    elif isinstance(X, pd.DataFrame) and TRAJECTORY in X.columns:
        labels = X[TRAJECTORY].to_numpy(dtype=object)
    else:
        return None
    if pd.isna(labels).any():
        row = int(np.flatnonzero(pd.isna(labels))[0])
        raise ValueError(f"{who}: the experiment label is missing at row {row}")
    return labels


def _experiments(labels: np.ndarray) -> list[np.ndarray]:
    codes, uniques = pd.factorize(labels, sort=False)
    return [np.flatnonzero(codes == k) for k in range(len(uniques))]


class ExperimentSplit(BaseCrossValidator):
    """Folds made of whole experiments (rows sharing a ``trajectory`` label).

    An experiment is never split between training and test, so a model is
    always scored on trajectories it has not seen.

    Parameters
    ----------
    n_splits : int, optional
        Number of folds; by default one per experiment (leave one
        experiment out). Experiments are dealt to folds in the order they
        appear, in contiguous runs.

    Examples
    --------
    >>> import pandas as pd
    >>> X = pd.DataFrame({"trajectory": [0, 0, 1, 1, 2, 2]})
    >>> [test.tolist() for _, test in ExperimentSplit().split(X)]
    [[0, 1], [2, 3], [4, 5]]
    """

    def __init__(self, n_splits: int | None = None) -> None:
        self.n_splits = n_splits

    def _groups(self, X, groups) -> list[np.ndarray]:
        labels = _labels(X, groups, "ExperimentSplit")
        if labels is None:
            raise ValueError("ExperimentSplit needs experiment labels: a 'trajectory' column in "
                             "X, or groups=")
        experiments = _experiments(labels)
        n = self._n(len(experiments))
        if n > len(experiments) or n < 2:
            raise ValueError(f"ExperimentSplit needs at least 2 experiments and no more folds "
                             f"than experiments: {len(experiments)} experiment(s), "
                             f"n_splits={n}")
        return experiments

    def _n(self, n_experiments: int) -> int:
        if self.n_splits is None:
            return n_experiments
        if not isinstance(self.n_splits, Integral) or isinstance(self.n_splits, bool):
            raise ValueError(f"n_splits must be an integer or None, got {self.n_splits!r}")
        return int(self.n_splits)

    def get_n_splits(self, X=None, y=None, groups=None) -> int:
        """Number of folds (needs ``X`` or ``groups`` when ``n_splits`` is None)."""
        if self.n_splits is not None:
            return self._n(0)
        if X is None and groups is None:
            raise ValueError("ExperimentSplit(n_splits=None) needs X or groups to count the "
                             "experiments")
        return len(self._groups(X, groups))

    def split(self, X, y=None, groups=None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """Yield ``(train, test)`` row positions, test being whole experiments."""
        experiments = self._groups(X, groups)
        n_rows = sum(len(rows) for rows in experiments)
        for fold in np.array_split(np.arange(len(experiments)), self._n(len(experiments))):
            test = np.sort(np.concatenate([experiments[k] for k in fold]))
            mask = np.ones(n_rows, dtype=bool)
            mask[test] = False
            yield np.flatnonzero(mask), test

    def _iter_test_indices(self, X=None, y=None, groups=None):
        for _, test in self.split(X, y, groups):
            yield test


class BlockSplit(BaseCrossValidator):
    """Contiguous blocks of long records as folds.

    Each experiment (or the whole record, without a ``trajectory`` column)
    is cut into ``n_splits`` blocks of consecutive rows; fold ``k`` tests on
    block ``k`` of every experiment and trains on the rest. Estimators treat
    the pause in ``t`` left by a held-out block as the end of a stretch, so
    nothing is differentiated or simulated across it.

    Parameters
    ----------
    n_splits : int, default=5
        Number of blocks, at least 2.
    gap : int, default=0
        Rows dropped from training on each side of the test block, so that
        smoothing windows of the two do not overlap.

    Examples
    --------
    >>> import numpy as np
    >>> [test.tolist() for _, test in BlockSplit(n_splits=3).split(np.zeros((6, 1)))]
    [[0, 1], [2, 3], [4, 5]]
    """

    def __init__(self, n_splits: int = 5, gap: int = 0) -> None:
        self.n_splits = n_splits
        self.gap = gap

    def _check(self) -> None:
        if not isinstance(self.n_splits, Integral) or isinstance(self.n_splits, bool) \
                or self.n_splits < 2:
            raise ValueError(f"n_splits must be an integer of at least 2, got {self.n_splits!r}")
        if not isinstance(self.gap, Integral) or isinstance(self.gap, bool) or self.gap < 0:
            raise ValueError(f"gap must be a non-negative integer, got {self.gap!r}")

    def get_n_splits(self, X=None, y=None, groups=None) -> int:
        """Number of folds."""
        self._check()
        return int(self.n_splits)

    def split(self, X, y=None, groups=None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """Yield ``(train, test)`` row positions; test is one block of each experiment."""
        self._check()
        n_rows = len(X)
        labels = _labels(X, groups, "BlockSplit")
        experiments = [np.arange(n_rows)] if labels is None else _experiments(labels)
        for rows in experiments:
            if len(rows) < self.n_splits:
                raise ValueError(f"BlockSplit: an experiment has {len(rows)} rows, fewer than "
                                 f"n_splits={self.n_splits}")
        for k in range(self.n_splits):
            test_parts, dropped = [], []
            for rows in experiments:
                blocks = np.array_split(np.arange(len(rows)), self.n_splits)
                block = blocks[k]
                test_parts.append(rows[block])
                lo, hi = max(block[0] - self.gap, 0), min(block[-1] + 1 + self.gap, len(rows))
                dropped.append(rows[lo:hi])
            test = np.sort(np.concatenate(test_parts))
            mask = np.ones(n_rows, dtype=bool)
            mask[np.concatenate(dropped)] = False
            yield np.flatnonzero(mask), test

    def _iter_test_indices(self, X=None, y=None, groups=None):
        for _, test in self.split(X, y, groups):
            yield test
