"""Fitting a skeleton to a record, whatever the backend: the layer under the estimators.

- :mod:`.problem`: the :class:`~.problem.Problem` a backend fits (the parsed
  skeleton, the record, constraints and bounds) and the
  :class:`~.problem.FitResult` it returns;
- :mod:`.lstsq`: least squares under linear equalities, inequalities and bounds;
- :mod:`.output_error`: fits by simulation (multiple shooting, the whole
  record, hidden states and their starting values, coloured-noise whitening);
- :mod:`.uncertainty`: covariances, intervals and refits on resamples;
- :mod:`.fingerprint`: what a fit saw, so a later step need not fit again.

Nothing here imports a backend or an estimator.
"""
