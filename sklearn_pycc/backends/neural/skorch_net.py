"""The skorch side of the neural backend: the net, its batches and callbacks.

Imported only when a :class:`~sklearn_pycc.NeuralCCRegressor` is fitted, so
``import sklearn_pycc`` does not load torch.
"""

from __future__ import annotations

import torch
from skorch import NeuralNet
from skorch.callbacks import Callback

__all__ = ["CurvesSettled", "EpochProgress", "SkeletonNet"]


class _TensorBatches:
    """Batches of tensors already on the device: no per-sample collation.

    skorch's default ``DataLoader`` gathers samples one by one; for full-batch
    training of small networks that costs more than the step itself.
    """

    def __init__(self, X: torch.Tensor, y: torch.Tensor, batch_size: int | None,
                 generator: torch.Generator | None) -> None:
        self.X, self.y = X, y
        self.batch_size = batch_size
        self.generator = generator

    def __iter__(self):
        n = self.X.shape[0]
        if self.batch_size is None or self.batch_size >= n:
            yield self.X, self.y
            return
        if self.generator is not None:
            order = torch.randperm(n, generator=self.generator).to(self.X.device)
        else:
            order = torch.arange(n, device=self.X.device)
        for start in range(0, n, self.batch_size):
            idx = order[start:start + self.batch_size]
            yield self.X[idx], self.y[idx]

    def __len__(self) -> int:
        n = self.X.shape[0]
        if self.batch_size is None or self.batch_size >= n:
            return 1
        return -(-n // self.batch_size)


def _tensors(dataset):
    """``(X, y)`` tensors of a skorch ``Dataset`` or a ``Subset`` of one."""
    if isinstance(dataset, torch.utils.data.Subset):
        X, y = _tensors(dataset.dataset)
        idx = torch.as_tensor(dataset.indices, device=X.device)
        return X[idx], y[idx]
    return dataset.X, dataset.y


class SkeletonNet(NeuralNet):
    """A skorch ``NeuralNet`` over a :class:`SkeletonModule`.

    The module returns weighted equation residuals and the criterion drives
    them to zero. Soft-constraint penalties are added in :meth:`get_loss`,
    only when training. Batches are slices of tensors already on the device,
    shuffled by a private generator.

    Parameters
    ----------
    penalty_weight : float
        Weight of the soft-constraint penalty (0 when constraints are exact).
    shuffle_generator : torch.Generator or None
        Generator of the minibatch order (None for full batches).
    **kwargs
        Passed to :class:`skorch.NeuralNet`.
    """

    def __init__(self, *args, penalty_weight: float = 0.0,
                 shuffle_generator: torch.Generator | None = None, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.penalty_weight = penalty_weight
        self.shuffle_generator = shuffle_generator

    def _set_training(self, training: bool = True) -> None:
        """Switch the module and criterion only when their mode changes.

        skorch sets the mode before every closure evaluation of L-BFGS; the
        recursive ``train()`` over a module tree then costs a tenth of the
        fit. Nothing here switches a submodule on its own, so the top
        modules' flags tell the mode.
        """
        modules = [getattr(self, name + "_", None) for name in self._modules + self._criteria]
        if all(not isinstance(m, torch.nn.Module) or m.training == training for m in modules):
            return
        super()._set_training(training)

    def get_loss(self, y_pred, y_true, X=None, training=False):
        """Criterion on the residuals, plus the constraint penalty in training."""
        loss = super().get_loss(y_pred, y_true, X=X, training=training)
        if training and self.penalty_weight:
            loss = loss + self.penalty_weight * self.module_.penalty()
        return loss

    def get_iterator(self, dataset, training=False):
        """Device-resident batches (one full batch unless ``batch_size`` is set)."""
        cached = getattr(dataset, "_pycc_tensors", None)
        if cached is None:
            # skorch hands the same dataset every epoch; gather a subset once
            cached = _tensors(dataset)
            dataset._pycc_tensors = cached
        X, y = cached
        size = None if self.batch_size in (None, -1) else int(self.batch_size)
        return _TensorBatches(X, y, size, self.shuffle_generator if training else None)


class EpochProgress(Callback):
    """A progress bar over epochs showing the training loss (``verbose=1``)."""

    def __init__(self, total: int) -> None:
        self.total = total

    def on_train_begin(self, net, X=None, y=None, **kwargs) -> None:
        """Open the progress bar."""
        from tqdm.auto import tqdm

        self.bar_ = tqdm(total=self.total, desc="epochs", unit="epoch", leave=False)

    def on_epoch_end(self, net, **kwargs) -> None:
        """Advance the bar by one epoch and show the loss."""
        self.bar_.update(1)
        self.bar_.set_postfix(loss=f"{net.history[-1, 'train_loss']:.3g}", refresh=False)

    def on_train_end(self, net, X=None, y=None, **kwargs) -> None:
        """Close the progress bar."""
        self.bar_.close()


class CurvesSettled(Callback):
    """Stop training once the fitted model has stopped changing.

    After every epoch each curve is read on 65 points across its scaled
    argument's range and each parameter is read; when, for ``patience``
    epochs in a row, no curve moved by more than ``tol`` of its own range
    (root mean square of the change) and no parameter by more than ``tol``
    of its value, further epochs would only polish digits the data cannot
    confirm, and training ends. ``stopped_at_`` holds the epoch (None when
    training ran to its end).
    """

    def __init__(self, tol: float, patience: int = 2) -> None:
        self.tol = tol
        self.patience = patience

    def on_train_begin(self, net, X=None, y=None, **kwargs) -> None:
        """Forget any earlier run."""
        self.previous_ = None
        self.calm_ = 0
        self.stopped_at_ = None

    def _snapshot(self, module) -> tuple[dict, dict]:
        curves = {}
        with torch.no_grad():
            for name, curve in module.curves.items():
                grid = torch.linspace(-1.0, 1.0, 65, dtype=module.weights.dtype,
                                      device=module.weights.device)
                curves[name] = curve(curve.center + curve.scale * grid).double().cpu()
            params = {name: float(module.params[name]) for name in module.params}
        return curves, params

    def _change(self, before, after) -> float:
        worst = 0.0
        for name, new in after[0].items():
            old = before[0][name]
            spread = float(new.max() - new.min())
            moved = float(torch.sqrt(torch.mean((new - old) ** 2)))
            worst = max(worst, moved / spread if spread > 0 else moved)
        for name, new in after[1].items():
            worst = max(worst, abs(new - before[1][name]) / max(abs(new), 1e-12))
        return worst

    def on_epoch_end(self, net, **kwargs) -> None:
        """Compare the curves with the last epoch's; stop once they have settled."""
        current = self._snapshot(net.module_)
        if self.previous_ is not None:
            change = self._change(self.previous_, current)
            self.calm_ = self.calm_ + 1 if change <= self.tol else 0
        self.previous_ = current
        if self.calm_ >= self.patience:
            self.stopped_at_ = len(net.history)
            raise KeyboardInterrupt  # skorch ends training gracefully on it
