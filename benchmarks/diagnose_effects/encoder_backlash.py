"""A custom effect for the diagnosis sanity check (``benchmarks/diagnose/diagnose.md``): gear
backlash between the joint and its encoder.

The reported joint angle follows the true one through a dead band of ``width`` rad (the play
operator: it stays put after a reversal until the play is taken up). Only the 100 Hz reading is
affected (``measure`` hook); the servo's own 500 Hz loop and the reported rates are not. Used as
``class: benchmarks/diagnose_effects/encoder_backlash.py:EncoderBacklash`` (a path relative to
the YAML file).
"""
from __future__ import annotations

import numpy as np


class EncoderBacklash:
    def __init__(self, width: float = 0.02) -> None:
        if width <= 0:
            raise ValueError("EncoderBacklash: width must be positive")
        self.width = float(width)
        self._y: np.ndarray | None = None

    def reset(self, sim) -> None:
        self._y = None

    def measure(self, obs: dict, t: float) -> dict:
        q = np.asarray(obs["q"], dtype=float)
        if self._y is None:
            self._y = q.copy()
        half = 0.5 * self.width
        self._y = np.minimum(np.maximum(self._y, q - half), q + half)
        out = dict(obs)
        out["q"] = self._y.copy()
        return out
