"""Fourier coefficients of exactly periodic records (paper eq. 3-4).

Convention: a record holding ``n_periods`` whole periods of fundamental ``omega_rad_s``,
sampled uniformly, is written as

    x(t) = sum_{n=0}^{H} Re( C_n exp(i n omega (t - t0)) )

with ``t0`` the time of the first sample. The paper's real coefficients are
``X_n = Re C_n`` (cosine) and ``X_n* = -Im C_n`` (sine). ``C_0`` is the mean.

The DFT of the samples gives the exact coefficients of a band-limited signal; for the
smooth responses of the rig the folded (aliased) harmonics above N/2 are below the
integrator error (see the tests).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "fourier_coefficients",
    "synthesize",
    "to_sine_cosine",
    "max_harmonic",
    "shift_periodic",
]


def max_harmonic(n_samples_per_period: int) -> int:
    """Highest harmonic that a record with this many samples per period resolves without
    folding onto another harmonic (strictly below Nyquist)."""
    return (int(n_samples_per_period) - 1) // 2


def fourier_coefficients(x: np.ndarray, n_periods: int, n_harmonics: int) -> np.ndarray:
    """Complex Fourier coefficients ``C_0 .. C_H`` of a periodic record.

    Args:
      x: samples, shape ``(..., n_samples)``; ``n_samples`` must be a multiple of
        ``n_periods`` and the record must span exactly ``n_periods`` periods
        (the last sample one step before the end of the last period).
      n_periods: number of whole periods the record holds.
      n_harmonics: highest harmonic ``H`` returned.

    Returns:
      Complex array, shape ``(..., H + 1)``. Averaging over periods is implicit: bin
      ``n * n_periods`` of the record's DFT is the mean of the per-period coefficients.
    """
    x = np.asarray(x, dtype=float)
    n_samples = x.shape[-1]
    if n_periods < 1:
        raise ValueError(f"n_periods must be >= 1, got {n_periods}")
    if n_samples % n_periods:
        raise ValueError(
            f"record of {n_samples} samples does not hold {n_periods} whole periods "
            f"(n_samples must be a multiple of n_periods)"
        )
    per_period = n_samples // n_periods
    if n_harmonics < 0 or n_harmonics > max_harmonic(per_period):
        raise ValueError(
            f"n_harmonics={n_harmonics} is outside [0, {max_harmonic(per_period)}] for "
            f"{per_period} samples per period (must stay below Nyquist)"
        )
    # the bins kept, then scaled (the same numbers as scaling the whole spectrum, in less time)
    coeffs = np.fft.rfft(x, axis=-1)[..., : (n_harmonics + 1) * n_periods : n_periods] / n_samples
    coeffs[..., 1:] *= 2.0
    return coeffs


def synthesize(coeffs: np.ndarray, n_samples: int, n_periods: int = 1) -> np.ndarray:
    """Samples of ``sum_n Re(C_n exp(i n omega t))`` over ``n_periods`` periods.

    Inverse of :func:`fourier_coefficients` for band-limited signals.
    ``coeffs`` has shape ``(..., H + 1)``; the result ``(..., n_samples)``.
    """
    coeffs = np.asarray(coeffs, dtype=complex)
    n_harm = coeffs.shape[-1] - 1
    n_bins = n_samples // 2 + 1
    if n_harm * n_periods >= n_bins:
        raise ValueError(f"{n_harm} harmonics over {n_periods} period(s) need more than {n_samples} samples")
    spectrum = np.zeros(coeffs.shape[:-1] + (n_bins,), dtype=complex)
    spectrum[..., 0] = coeffs[..., 0].real * n_samples
    spectrum[..., n_periods: (n_harm + 1) * n_periods: n_periods] = coeffs[..., 1:] * (n_samples / 2)
    if n_samples % 2 == 0 and n_harm * n_periods == n_bins - 1:  # a Nyquist line holds Re(C) only
        spectrum[..., -1] = coeffs[..., -1].real * n_samples
    return np.fft.irfft(spectrum, n=n_samples, axis=-1)


def to_sine_cosine(coeffs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's real form: cosine coefficients ``X_n`` and sine coefficients ``X_n*``."""
    coeffs = np.asarray(coeffs)
    return coeffs.real.copy(), -coeffs.imag.copy()


def shift_periodic(x: np.ndarray, n_periods: int, omega_rad_s, shift_s: float) -> np.ndarray:
    """Whole periods of a band-limited signal moved later in time by ``shift_s`` (negative:
    earlier), exactly on its harmonics: ``x(t - shift_s)``. ``x`` may hold several records
    ``(..., n_samples)``, with one ``omega_rad_s`` each (shape ``(..., 1)``)."""
    C = fourier_coefficients(x, n_periods, max_harmonic(x.shape[-1] // n_periods))
    n = np.arange(C.shape[-1])
    return synthesize(C * np.exp(-1j * n * np.asarray(omega_rad_s) * shift_s), x.shape[-1], n_periods)
