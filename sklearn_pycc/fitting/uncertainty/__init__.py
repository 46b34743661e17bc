"""What a fit's numbers are worth: covariances, intervals and refits on resamples.

:mod:`.covariance` (sandwich estimates with long-run scores), :mod:`.linearized`
(flexible curves read through their last layer), :mod:`.intervals`,
:mod:`.resampling` (block refits of any backend) and
:mod:`.hidden_bootstrap` (refits of a skeleton with hidden states).
"""
