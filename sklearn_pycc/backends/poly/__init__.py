"""Polynomial curves: the bases, and the skeleton's residual written as an affine form."""
