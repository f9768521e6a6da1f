"""The kinks a dry friction puts into a band-limited rate, restored in closed form.

Dry friction makes the acceleration jump at every rate reversal, so the rate has kinks whose
harmonics lie above the band a harmonic balance keeps: the band-limited rate crosses zero late
and shifts every harmonic of the friction torque. :func:`kink_corrected_rate` adds the kinks'
out-of-band part back from the crossing times and the jump (two passes converge); the
diagnosis (:mod:`identify.chain_diagnose`) refits with the jump its fit implies until the jump
settles to :data:`KINK_RTOL`. Pure functions on arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .balance import spectral_rate

__all__ = ["FINE_SAMPLES", "KINK_RTOL", "KinkPass", "kink_corrected_rate", "kink_first_pass", "OVERSAMPLE", "SwitchShifts",
           "switch_shifts"]


#: Law columns are evaluated on 16x the samples (trigonometric interpolation of the band-limited
#: angle): a jump (dry friction) on 256 samples per period aliases at ~1/256 of its size,
#: enough to be "significant" at 40 dB; 16x brings that to ~2e-4.
OVERSAMPLE = 16

#: Samples per period of the fine grid (OVERSAMPLE times the rig's default 256).
FINE_SAMPLES = OVERSAMPLE * 256


def kink_corrected_rate(phi_rad: np.ndarray, omega_rad_s, band: int, jump_rad_s2: float,
                        iterations: int = 2, *, band_limited_rate: Optional[np.ndarray] = None,
                        first_pass: Optional["KinkPass"] = None) -> np.ndarray:
    """The relative rate of one band-limited period with its dry-friction kinks restored.

    Dry friction makes the relative acceleration jump by ``jump_rad_s2`` (2 F_c / Je) each
    time the rate crosses zero, so the rate has a kink there; its harmonics above ``band``
    are missing from a band-limited record and the band-limited rate crosses zero late (by
    ~1e-3 of a period at band 20), which shifts every harmonic of the friction torque. The
    kinks' out-of-band part is known in closed form from the crossing times t_i and jumps
    d_i: the rate's second derivative holds sum_i d_i delta(t - t_i), whose coefficients
    are (2/T) sum_i d_i exp(-i n w t_i); dividing by (i n w)^2 gives the rate's. Adding the
    harmonics above ``band`` back and locating the crossings again converges in two passes.

    Args:
      phi_rad: one period, band-limited to ``band`` harmonics, shape (M,); or several periods
        of the same size at once, ``(n, M)``, with ``omega_rad_s`` one per period ``(n,)``.
      jump_rad_s2: size of the jump of the relative acceleration (>= 0; 0 returns the
        band-limited rate).
      band_limited_rate: ``spectral_rate(phi_rad, omega_rad_s, 1)`` if the caller has it
        (it does not depend on the jump: a profile search reuses it for every trial).
      first_pass: :func:`kink_first_pass` of the same records, if the caller has it: the first
        pass locates the crossings of the band-limited rate, which do not depend on the jump,
        so its correction is the jump times a fixed one (a profile search reuses it for every
        trial; half of this function's time).

    A period whose rate does not cross zero an even, non-zero number of times keeps its
    band-limited rate.
    """
    phi = np.atleast_2d(phi_rad)
    if jump_rad_s2 <= 0 or iterations < 1:
        return _band_limited_rate(phi, _omegas(omega_rad_s, phi.shape[0]), band_limited_rate).reshape(np.shape(phi_rad))
    if first_pass is None:
        first_pass = kink_first_pass(phi, omega_rad_s, band, band_limited_rate=band_limited_rate)
    return _kinked(first_pass, band, jump_rad_s2, iterations).rate_rad_s.reshape(np.shape(phi_rad))


@dataclass(frozen=True)
class KinkPass:
    """The first pass of :func:`kink_corrected_rate` over records ``(n, M)``: their band-limited
    rate, the correction it gives for a unit jump (1 rad/s^2), and which periods crossed zero an
    even, non-zero number of times."""
    rate_rad_s: np.ndarray
    omega_rad_s: np.ndarray
    unit_correction: np.ndarray
    kept: np.ndarray


def _omegas(omega_rad_s, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(omega_rad_s, dtype=float).reshape(-1), (n,))


def _band_limited_rate(phi: np.ndarray, omega: np.ndarray, given: Optional[np.ndarray]) -> np.ndarray:
    """The records' band-limited rate ``(n, M)``: ``given`` if the caller has it, else computed."""
    return spectral_rate(phi, omega[:, None], 1) if given is None else np.atleast_2d(given)


def kink_first_pass(phi_rad: np.ndarray, omega_rad_s, band: int, *,
                    band_limited_rate: Optional[np.ndarray] = None) -> KinkPass:
    """The jump-free first pass of :func:`kink_corrected_rate` (arguments as there)."""
    phi = np.atleast_2d(phi_rad)
    omega = _omegas(omega_rad_s, phi.shape[0])
    v_bl = _band_limited_rate(phi, omega, band_limited_rate)
    correction, crossings = _kink_pass(v_bl, omega, band, np.ones(phi.shape[0], bool))
    return KinkPass(v_bl, omega, correction, crossings.kept)


@dataclass(frozen=True)
class _Crossings:
    """Where a pass of :func:`_kink_pass` found the rate crossing zero: record ``rec``, between
    samples ``idx`` and ``idx + 1`` (cyclic), at time ``t_s`` from the record's start; only the
    crossings of the periods it ``kept``."""
    rec: np.ndarray
    idx: np.ndarray
    t_s: np.ndarray
    kept: np.ndarray


def _crossing_times(v: np.ndarray, rec: np.ndarray, idx: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Times (s) of the zero crossings of ``v`` (``(n, M)``) between samples ``idx`` and
    ``idx + 1`` of records ``rec`` (linear interpolation); ``T``: the records' periods (s)."""
    M = v.shape[1]
    now, nxt = v[rec, idx], v[rec, (idx + 1) % M]
    return (idx + now / (now - nxt)) * T[rec] / M


def _kink_pass(v: np.ndarray, omega: np.ndarray, band: int, kept: np.ndarray) -> tuple[np.ndarray, _Crossings]:
    """One pass: the out-of-band correction of the rate for a unit jump at the zero crossings of
    ``v`` (``(n, M)``), and those crossings, with ``kept`` narrowed to the periods whose crossings
    are even and non-zero."""
    n_rec, M = v.shape
    # Harmonics band+1 .. M/2-1 of sum_i d_i delta(t - t_i) / (i n w)^2, scaled for irfft:
    # (2/T) (M/2) / (i n w)^2 = -(M/T) / (n w)^2, real.
    T = 2 * math.pi / omega
    n_out = np.arange(band + 1, M // 2)
    scale = -(M / T)[:, None] / (n_out * omega[:, None]) ** 2
    up = v > 0
    flips = np.empty_like(up)
    np.not_equal(up[:, :-1], up[:, 1:], out=flips[:, :-1])
    np.not_equal(up[:, -1], up[:, 0], out=flips[:, -1])  # the period wraps round
    rec, i = np.nonzero(flips)
    counts = np.bincount(rec, minlength=n_rec)
    kept = kept & (counts > 0) & (counts % 2 == 0)
    on = kept[rec]
    rec, i = rec[on], i[on]
    t = _crossing_times(v, rec, i, T)
    d = -np.sign(v[rec, (i + 1) % M] - v[rec, i])  # friction always steepens the approach
    # exp(-i n w t) for n = band+1 .. M/2-1 as exp(-i (band+1) w t) z^k, z = exp(-i w t), with
    # z^k = z^(B q) z^r (k = B q + r, B = 64): two short power tables and one product (a complex
    # exponential per term would take ten times as long; round-off ~1e-14)
    K = n_out.size
    B = 64
    z = np.exp(-1j * omega[rec] * t)
    low = np.empty((rec.size, B), complex)
    low[:, 0] = np.exp(-1j * n_out[0] * omega[rec] * t)
    low[:, 1:] = z[:, None]
    np.cumprod(low, axis=1, out=low)  # exp(-i (band+1) w t) z^r, r < B
    high = np.empty((rec.size, -(-K // B)), complex)
    high[:, 0] = 1.0
    high[:, 1:] = (low[:, -1] * z / low[:, 0])[:, None]  # z^B
    np.cumprod(high, axis=1, out=high)
    E = (high[:, :, None] * low[:, None, :]).reshape(rec.size, -1)[:, :K]
    # each period's sum over its own crossings, as a (periods x crossings) matrix of the jumps
    # times E (real, on E's real and imaginary parts side by side); zero for a period not kept
    S = np.zeros((n_rec, rec.size))
    S[rec, np.arange(rec.size)] = d
    V = np.zeros((n_rec, M // 2 + 1), complex)
    V[:, band + 1: M // 2] = scale * (S @ np.ascontiguousarray(E).view(float)).view(complex)
    return np.fft.irfft(V, n=M, axis=1), _Crossings(rec, i, t, kept)


@dataclass(frozen=True)
class _Kinked:
    """:func:`kink_corrected_rate`'s result with what its last pass saw: the rate it corrected
    (``seen``, the band-limited rate plus the previous pass's correction), that rate's crossings,
    and the largest magnitude of the last pass's unit-jump correction in every record (s)."""
    rate_rad_s: np.ndarray
    seen: np.ndarray
    crossings: _Crossings
    correction_max_s: np.ndarray


def _kinked(first_pass: KinkPass, band: int, jump_rad_s2: float, iterations: int = 2) -> _Kinked:
    """:func:`kink_corrected_rate` for ``jump_rad_s2 > 0`` and ``iterations >= 1``, from its first pass."""
    v_bl, kept = first_pass.rate_rad_s, first_pass.kept
    correction = first_pass.unit_correction
    seen, crossings = v_bl, None
    for _ in range(iterations - 1):
        seen = v_bl + jump_rad_s2 * correction
        correction, crossings = _kink_pass(seen, first_pass.omega_rad_s, band, kept)
        kept = crossings.kept
    v = np.where(kept[:, None], v_bl + jump_rad_s2 * correction, v_bl)
    return _Kinked(v, seen, crossings, np.abs(correction).max(axis=1))


#: The kink iteration of a diagnosis's fit stops when the next jump is within this of the one
#: the fit used (relative). The whole kink correction moves a friction torque by 4e-5 (the worn
#: joint's Coulomb friction) to 1e-2 (a Stribeck law's excess) of itself, so a jump this close
#: changes no fitted value beyond ~1e-8 of it.
KINK_RTOL = 1e-6


@dataclass(frozen=True)
class SwitchShifts:
    """Where a period's noise moves dry friction's switches, to first order about the periods'
    average (:func:`switch_shifts`).

    A column that jumps by ``J`` where the rate crosses zero (``sign(rate)``: ``J = 2``) changes,
    when a crossing at ``t_c`` moves by ``tau``, by an impulse of area ``-J tau sign(rate')`` at
    ``t_c``: with ``tau = -dr(t_c) / rate'(t_c)`` that is ``J dr(t_c) / |rate'(t_c)|`` whichever
    way the rate crosses. In one noisy period the rate crosses zero several times near a reversal,
    in the average once, and the sign of an average is not the average of the signs: the average's
    switch moves with its noise by the periods' mean shift, which each period's own sign column
    does not show (docs/noisy-measurements.md)."""
    #: (C,) the average's crossings (s from the period's start)
    at_s: np.ndarray
    #: (P, C) per period and crossing: the moved switch's impulse per unit jump, ``dr / |rate'|`` (s)
    area_s: np.ndarray
    period_s: float

    def coefficients(self, n_harmonics: int, jump: float = 2.0, weight: Optional[np.ndarray] = None) -> np.ndarray:
        """``(P, H + 1)`` complex: each period's change of a column that jumps by ``jump`` at the
        crossings, in :func:`identify.harmonics.fourier_coefficients`' convention (``C_0`` the
        mean, ``C_h = 2/T * area * exp(-i h w t_c)``); ``weight``: samples of one period that
        multiply the column (a stick mask), read at each crossing."""
        T = self.period_s
        h = np.arange(n_harmonics + 1)
        E = np.exp(-2j * math.pi * np.outer(self.at_s / T, h)) * np.where(h == 0, 1.0, 2.0) / T  # (C, H + 1)
        area = jump * self.area_s
        if weight is not None and self.at_s.size:
            w = np.asarray(weight, dtype=float)
            M = w.size
            x = self.at_s / T * M
            n = np.floor(x).astype(int)
            f = x - n
            area = area * ((1.0 - f) * w[n % M] + f * w[(n + 1) % M])
        return area @ E


def switch_shifts(average_rate: np.ndarray, period_rates: np.ndarray, period_s: float) -> SwitchShifts:
    """:class:`SwitchShifts` of the rate ``average_rate`` (one period, ``M`` samples) against each
    of ``period_rates`` (``(P, M)``; their mean is the average). The slope at a crossing is read on
    the side the switch moves to (dry friction kinks the rate there), its chord across the crossing
    where that side's sample slope has the wrong sign; a shift is held within half the way to the
    neighbouring crossing, beyond which no first order holds."""
    v = np.asarray(average_rate, dtype=float)
    d = np.atleast_2d(np.asarray(period_rates, dtype=float)) - v
    M = v.size
    dt = period_s / M
    up = v > 0
    i = np.flatnonzero(up != np.roll(up, -1))
    if i.size == 0:
        return SwitchShifts(np.zeros(0), np.zeros((d.shape[0], 0)), period_s)
    now, nxt = v[i], v[(i + 1) % M]
    at = _crossing_times(v[None, :], np.zeros(i.size, dtype=int), i, np.array([period_s]))
    frac = at / dt - i
    dr = (1.0 - frac) * d[:, i] + frac * d[:, (i + 1) % M]  # (P, C)
    chord = (nxt - now) / dt
    left = (v[i] - v[(i - 1) % M]) / dt
    right = (v[(i + 2) % M] - v[(i + 1) % M]) / dt
    side = np.where(dr * chord > 0, left, right)  # the switch moves earlier where dr and the slope agree
    slope = np.abs(np.where(side * chord > 0, side, chord))
    gap = np.diff(np.concatenate((at, [at[0] + period_s])))  # to the next crossing, cyclic
    room = 0.5 * np.minimum(gap, np.roll(gap, 1))
    area = np.clip(dr / slope, -room, room)
    return SwitchShifts(at, area, period_s)
