"""Projection (BOUND, alpha-PROJ), sequential rollout and its metrics."""
