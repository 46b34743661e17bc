"""Fits by output error: the skeleton simulated against the measured record.

:mod:`.shooting` fits by multiple shooting (windows of the record, each with
its own initial state, joined by continuity); :mod:`.whole_record` simulates
every experiment whole; :mod:`.hidden` fits skeletons with states no sensor
reads, from starting values found by :mod:`.projected_start` and
:mod:`.swapped_speeds`; :mod:`.noise_model` whitens the output error by a
fitted model of coloured noise.
"""
