"""asv benchmarks of sklearn-pycc."""
