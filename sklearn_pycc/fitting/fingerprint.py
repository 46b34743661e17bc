"""What a fit saw: a digest of its data and settings, to know a refit would repeat it."""

from __future__ import annotations

import hashlib

from ..measurements.measurement import Measurement, values_digest

__all__ = ["fit_fingerprint", "fitted_on"]

#: settings that do not change the point estimate of a fit already made by output error
_IRRELEVANT = ("fit_mode", "n_bootstrap", "n_jobs", "verbose")


def fit_fingerprint(estimator, X, y=None) -> str | None:
    """A digest of ``X``, ``y`` and ``estimator``'s settings; None where the data have none.

    Two fits with the same fingerprint give the same point estimate, whatever
    their ``fit_mode`` was once output error was chosen (and however many
    refits on resamples they made). A setting whose text names an object
    (a random generator) makes every fingerprint differ, which is safe.
    """
    data = values_digest(X.X, X.y) if isinstance(X, Measurement) else values_digest(X, y)
    if data is None:
        return None
    settings = {k: v for k, v in estimator.get_params(deep=False).items()
                if k not in _IRRELEVANT}
    digest = hashlib.blake2b(data, digest_size=16)
    digest.update(repr(sorted(settings.items())).encode())
    return digest.hexdigest()


def fitted_on(estimator, X, y=None) -> bool:
    """Whether fitting ``estimator`` again on ``X`` and ``y`` would give its estimate again."""
    own = getattr(estimator, "_fingerprint", None)
    return own is not None and own == fit_fingerprint(estimator, X, y)
