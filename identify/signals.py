"""Continuous-time inputs from sampled records."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import resample_poly

__all__ = ["BandlimitedInput"]


@dataclass(frozen=True, eq=False)
class BandlimitedInput:
    """u(t) from samples ``u[n] = u(n / fs)``: band-limited interpolation onto a grid
    ``upsample`` times finer (scipy's polyphase FIR, Kaiser window), linear in between.

    This is the interpolation harmonic balance assumes (a sampled periodic record stands for its
    band-limited Fourier series), so the free-run simulation sees the input the identified model
    was fitted to. ``u(t) = 0`` before t = 0 (the system starts at rest with zero input).

    Attributes:
      samples: the sampled input, ``(n,)``; fs_Hz: its rate; upsample: grid refinement.
    """

    samples: np.ndarray
    fs_Hz: float
    upsample: int = 8

    def __post_init__(self):
        x = np.asarray(self.samples, dtype=float)
        if x.ndim != 1 or x.size < 2 or not np.all(np.isfinite(x)):
            raise ValueError("BandlimitedInput needs a finite 1-D record of at least 2 samples")
        if self.upsample < 1:
            raise ValueError(f"upsample must be >= 1, got {self.upsample}")
        fine = resample_poly(x, self.upsample, 1) if self.upsample > 1 else x.copy()
        fine.setflags(write=False)
        object.__setattr__(self, "_fine", fine)
        object.__setattr__(self, "_fine_list", fine.tolist())
        object.__setattr__(self, "_rate", self.fs_Hz * self.upsample)

    @property
    def grid(self) -> np.ndarray:
        """The fine grid values, ``(n * upsample,)`` at times ``i / (fs * upsample)``."""
        return self._fine

    def __call__(self, t):
        """u at time(s) t (s): float in, float out (callback path); array in, array out."""
        if isinstance(t, float):
            pos = t * self._rate
            if pos <= 0.0:
                return 0.0 if pos < 0.0 else self._fine_list[0]
            i = int(pos)
            fl = self._fine_list
            if i >= len(fl) - 1:
                return fl[-1]
            f = pos - i
            return fl[i] + f * (fl[i + 1] - fl[i])
        t = np.asarray(t, dtype=float)
        out = np.interp(t * self._rate, np.arange(self._fine.size), self._fine)
        return np.where(t < 0, 0.0, out)
