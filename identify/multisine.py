"""Odd random-phase multisines and what their non-excited lines tell (Schoukens, Pintelon).

One periodic record excites many frequencies at once: ``T(t) = sum_k A cos(k w0 t + p_k)``
over odd harmonics k of the fundamental w0, with independent uniform random phases and a
flat amplitude spectrum. In every group of three consecutive odd lines one, chosen at random,
is left out (a *detection line*). The response of a nonlinear joint then shows:

* at the excited lines: the (linearised) transfer plus nonlinear contributions;
* at the odd detection lines: odd nonlinear distortion only (a cubic spring mixes three odd
  lines into an odd line), above the noise when the joint is nonlinear at that level;
* at the even lines: even nonlinear distortion only (a quadratic term, an offset, asymmetry);
* everywhere: the noise, whose level the period-to-period variation gives independently.

:func:`line_levels` measures those groups for one record (pure): mean power of the angle's
Fourier coefficients per group, and the noise power of the mean estimated from the periods.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .harmonics import fourier_coefficients, max_harmonic
from .periods import period_spectra
from jointrig.vocab.plant import PeriodicDrive
from jointrig.vocab.records import SteadyStateRecord

__all__ = ["OddMultisine", "odd_multisine", "LineLevels", "line_levels"]


@dataclass(frozen=True)
class OddMultisine:
    """An odd random-phase multisine: the drive and which lines it excites.

    Attributes:
      drive: the periodic drive (torque in N m) at fundamental ``drive.omega_rad_s``.
      excited: excited harmonic numbers (odd), ascending.
      detection: odd harmonics left out (one per group of three), ascending.
      rms_Nm: RMS of the drive torque.
    """

    drive: PeriodicDrive
    excited: tuple[int, ...]
    detection: tuple[int, ...]
    rms_Nm: float


def odd_multisine(omega0_rad_s: float, max_harmonic_excited: int, rms_Nm: float, *,
                  seed: int = 0) -> OddMultisine:
    """Flat-spectrum odd random-phase multisine on lines 1, 3, ..., <= ``max_harmonic_excited``,
    one of every three consecutive odd lines left out at random, scaled to ``rms_Nm``.

    Raises:
      ValueError: fewer than 3 odd lines, or a non-positive rms / fundamental.
    """
    if not (math.isfinite(omega0_rad_s) and omega0_rad_s > 0):
        raise ValueError(f"omega0_rad_s must be a finite number > 0, got {omega0_rad_s}")
    if not (math.isfinite(rms_Nm) and rms_Nm > 0):
        raise ValueError(f"rms_Nm must be a finite number > 0, got {rms_Nm}")
    odd = list(range(1, int(max_harmonic_excited) + 1, 2))
    if len(odd) < 3:
        raise ValueError(f"max_harmonic_excited={max_harmonic_excited} gives {len(odd)} odd line(s); "
                         f"an odd multisine needs at least 3 (one group with a detection line)")
    rng = np.random.default_rng(seed)
    detection = []
    for g in range(0, len(odd) - len(odd) % 3, 3):
        detection.append(odd[g + int(rng.integers(3))])
    excited = [k for k in odd if k not in detection]
    phases = rng.uniform(0, 2 * np.pi, len(excited))
    amp = rms_Nm * math.sqrt(2 / len(excited))  # each line contributes A^2 / 2 to the mean square
    coeffs = np.zeros(max(excited) + 1, dtype=complex)
    coeffs[excited] = amp * np.exp(1j * phases)
    return OddMultisine(PeriodicDrive(omega0_rad_s, tuple(coeffs)), tuple(excited), tuple(detection), float(rms_Nm))


@dataclass(frozen=True)
class LineLevels:
    """Mean power (rad^2) of the relative angle's Fourier coefficients by line group, and the
    noise power of the period mean at one line (rad^2; 0 for a single or noise-free period).

    ``odd_distortion_db`` / ``even_distortion_db``: detection and even lines over the noise
    (dB; +inf without noise); above ~10 dB the joint is visibly nonlinear at this level.
    """

    excited: float
    odd_detection: float
    even: float
    noise: float
    n_harmonics: int

    @property
    def odd_distortion_db(self) -> float:
        return 10 * math.log10(self.odd_detection / self.noise) if self.noise > 0 else math.inf

    @property
    def even_distortion_db(self) -> float:
        return 10 * math.log10(self.even / self.noise) if self.noise > 0 else math.inf


def line_levels(record: SteadyStateRecord, excitation: OddMultisine, n_harmonics: Optional[int] = None) -> LineLevels:
    """Levels of the relative angle at excited, odd detection and even lines up to
    ``n_harmonics`` (default: three times the highest excited line, within Nyquist)."""
    N, P = record.samples_per_period, record.n_periods
    H = min(n_harmonics or 3 * max(excitation.excited), max_harmonic(N))
    C = fourier_coefficients(record.phi_rad, P, H)
    power = np.abs(C) ** 2 / 2
    ex = [k for k in excitation.excited if k <= H]
    det = [k for k in range(1, H + 1, 2) if k not in excitation.excited]
    even = list(range(2, H + 1, 2))
    noise = 0.0
    if P >= 2:
        # of the power |C_n|^2 / 2 of each line, C_n = 2 X_n: 4 var(X_n) / 2
        noise = 2.0 * float(np.mean(period_spectra(record.phi_rad, P)[2][1:H + 1]))
    return LineLevels(float(power[ex].mean()), float(power[det].mean()) if det else 0.0,
                      float(power[even].mean()) if even else 0.0, noise, H)
