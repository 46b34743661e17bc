"""Helpers every layer may use: seeds, threads, HTML, time blocks, band-limited signals.

Nothing here knows of skeletons, records or estimators; the package's other
modules import from here, never the other way round.
"""
