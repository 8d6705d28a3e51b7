"""Residual diagnosis: candidate effects, selection, report."""
