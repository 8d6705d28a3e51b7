"""Bags, datasets, the state/feature extraction and normalisation."""
