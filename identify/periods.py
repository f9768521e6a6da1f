"""Whole periods from a bench's record: the clock, the fundamental, and the periods themselves.

Pure functions (arrays in, frozen dataclasses out) behind :mod:`measured.runs`. A bench logs
samples on its own clock, at its own rate, from an arbitrary phase of the drive, with time
stamps rounded to the logger's resolution. The identifier needs whole periods sampled
uniformly (:class:`vocab.records.SteadyStateRecord`). The steps:

1. **Clock** (:func:`uniform_clock`): the sample times as ``t0 + k dt`` by least squares; the
   time stamps' deviation from that clock (rounding, jitter) is measured and reported, and a
   record whose stamps miss the clock by more than :data:`MAX_CLOCK_DEVIATION` of a step
   (a gap, a missing sample, a restart) is refused.
2. **Fundamental** (:func:`estimate_fundamental`): the frequency that minimises the residual of
   a periodic model with harmonics 0..H (multi-harmonic least squares, started from the
   periodogram peak), with its standard error from the curvature of the residual.
3. **Does it repeat?** (:func:`repeat_statistic`): how much worse a periodic model at a
   *stated* frequency (an ``omega`` column, or ``2 pi / (N dt)`` for a whole number N of
   samples per period) fits than at the best one, in units of the noise variance (a
   likelihood-ratio statistic, about chi-square(1) per channel when the stated frequency is
   right). A frequency estimated from noisy data is never used to decide that a record is not
   whole periods: the test is whether the data repeat at the candidate period.
4. **Periods** (:func:`periods_by_least_squares`): for a record whose period is not a whole
   number of samples (a fixed-rate DAQ), the harmonics 0..H of each whole period are estimated
   by least squares on that period's own samples and synthesised on a uniform grid: every
   sample is used, the period-to-period variation (the noise estimate) is kept, and the
   residual of the fit is reported.
5. **Drift** (:func:`linear_drift`): a linear trend under the periodic model (a slipping
   encoder, an unsettled transient, a rotating shaft), with its t-statistic.
6. **Noise** (:func:`period_spectra`): the one noise estimator of every identifier: the mean
   period's spectrum and the variance of that mean at each harmonic from the period-to-period
   variation; :func:`white_variance` sums it into the variance per sample of the mean period
   (Parseval), :func:`raw_noise_std` into a robust standard deviation per raw sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np


__all__ = [
    "MAX_CLOCK_DEVIATION", "UniformClock", "uniform_clock", "Fundamental", "estimate_fundamental", "with_second_channel", "AGREE_SE", "fit_at",
    "periodic_rss", "repeat_statistic", "RESOLVED_SIGMA", "pooled", "pooled_period_spectra", "PeriodFit",
    "MAX_LS_HARMONICS", "ls_harmonics", "periods_by_least_squares",
    "Drift", "linear_drift", "period_spectra", "white_variance", "raw_noise_std",
]

#: Largest deviation of a time stamp from the fitted uniform clock, in sample steps. Rounding
#: to the logger's resolution and clock jitter stay far below it; a missing sample is a whole step.
MAX_CLOCK_DEVIATION = 0.05


@dataclass(frozen=True)
class UniformClock:
    """``t_k = t0_s + k dt_s``; ``max_deviation`` is the largest |stamp - clock| in steps,
    at sample ``worst_index``."""

    t0_s: float
    dt_s: float
    max_deviation: float
    worst_index: int

    def times(self, n: int) -> np.ndarray:
        return self.t0_s + np.arange(n) * self.dt_s


def uniform_clock(time_s: np.ndarray) -> UniformClock:
    """Least-squares uniform clock through the time stamps (shape (n,), n >= 2).

    Raises:
      ValueError: stamps not strictly increasing (names the first offending sample).
    """
    t = np.asarray(time_s, dtype=float)
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0])
        raise ValueError(f"time must increase strictly: sample {i + 1} at {float(t[i + 1]):.10g} s follows "
                         f"{float(t[i]):.10g} s")
    k = np.arange(t.size, dtype=float)
    kc = k - k.mean()
    tm = t.mean()
    dt = float(np.dot(kc, t - tm) / np.dot(kc, kc))
    t0 = float(tm - dt * k.mean())
    dev = np.abs(t - (t0 + k * dt)) / dt
    i = int(np.argmax(dev))
    return UniformClock(t0, dt, float(dev[i]), i)


def _basis(t: np.ndarray, omega: float, H: int, *, trend: bool = False) -> np.ndarray:
    """Columns 1, cos(n w t), sin(n w t) for n = 1..H (and t - mean(t) if ``trend``)."""
    B = np.empty((t.size, 2 * H + 1 + (1 if trend else 0)))
    B[:, 0] = 1.0
    if H:
        # exp(i n w t) as powers of exp(i w t): a tenth of the time of 2 H n cosines and sines,
        # round-off ~H eps
        z = np.empty((t.size, H), complex)
        z[:] = np.exp(1j * omega * t)[:, None]
        np.cumprod(z, axis=1, out=z)
        B[:, 1: H + 1] = z.real
        B[:, H + 1: 2 * H + 1] = z.imag
    if trend:
        B[:, -1] = t - t.mean()
    return B


def periodic_rss(t: np.ndarray, x: np.ndarray, omega: float, H: int) -> float:
    """Residual sum of squares of ``x`` (n,) about its best periodic model with harmonics
    0..H of ``omega`` (t relative to any origin; shape (n,)).

    The coefficients by the normal equations (the basis is near-orthogonal: whole or nearly
    whole periods of harmonics below Nyquist), the residual formed explicitly, so a noise-free
    record keeps its round-off floor; least squares by SVD where the normal matrix is
    ill-conditioned (a record of few samples per period)."""
    B = _basis(t, omega, H)
    r = x - B @ _least_squares(B, x)
    return float(r @ r)


def _least_squares(B: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Coefficients of ``x`` on the columns of ``B`` (see :func:`periodic_rss`): normal
    equations where their column-scaled matrix is well conditioned, else SVD."""
    G = B.T @ B
    d = np.sqrt(np.diag(G))
    if np.all(d > 0) and np.linalg.cond(G / np.outer(d, d)) < 1e6:
        return np.linalg.solve(G, B.T @ x)
    return np.linalg.lstsq(B, x, rcond=None)[0]


@dataclass(frozen=True)
class Fundamental:
    """Best periodic fit's frequency ``omega_rad_s`` +- ``std_error_rad_s``; ``noise_var``: the
    residual variance per sample there (signal units squared), with ``dof`` degrees of freedom."""

    omega_rad_s: float
    std_error_rad_s: float
    rss: float
    noise_var: float
    dof: int
    harmonics: int


def _noise_floor(x: np.ndarray) -> float:
    """Variance below which a residual is round-off, not noise: (1e-9 of the RMS)^2. A
    noise-free record must not make a 1e-12 frequency difference look significant."""
    return (1e-9 * float(np.sqrt(np.mean((x - x.mean()) ** 2))) + 1e-300) ** 2


def estimate_fundamental(t: np.ndarray, x: np.ndarray, *, harmonics: int = 10) -> Fundamental:
    """The drive's fundamental from one channel (usually the torque), shapes (n,).

    Periodogram peak (zero-padded 8x), then the frequency minimising :func:`periodic_rss`
    with harmonics 0..H within +-2 padded bins. Standard error from the curvature of the RSS:
    ``var(omega) = 2 sigma^2 / RSS''``.

    Raises:
      ValueError: no periodic component (a constant signal).
    """
    t = np.asarray(t, float) - float(t[0])
    x = np.asarray(x, float)
    n = x.size
    xc = x - x.mean()
    if not np.any(xc):
        raise ValueError("the signal is constant: it has no fundamental")
    dt = float((t[-1] - t[0]) / (n - 1))
    spec = np.abs(np.fft.rfft(xc, 8 * n)) ** 2
    k = int(np.argmax(spec[1:])) + 1
    w0 = 2 * math.pi * k / (8 * n * dt)
    dw = 2 * math.pi / (8 * n * dt)
    H = max(1, min(harmonics, int(math.pi / (w0 * dt)) - 1))
    lo = max(w0 - 2 * dw, 0.5 * w0)
    return _least_squares_fundamental(t, x, H, lo, w0 + 2 * dw, dw)


def _least_squares_fundamental(t: np.ndarray, x: np.ndarray, H: int, lo: float, hi: float, dw: float) -> Fundamental:
    """The frequency in [lo, hi] minimising :func:`periodic_rss` with harmonics 0..H (``t`` from
    0; ``dw``: the scale of the step for the RSS's curvature), and its standard error."""
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(lambda w: periodic_rss(t, x, w, H), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-12 * hi})
    w = float(res.x)
    # Two parabolic steps on the RSS (the bounded search stops at ~1e-8 relative; noise-free
    # records deserve the round-off limit).
    h = max(1e-3 * dw, 1e-9 * w)
    for _ in range(2):
        r0, rp, rm = (periodic_rss(t, x, v, H) for v in (w, w + h, w - h))
        curv = rp - 2 * r0 + rm
        if curv <= 0:
            break
        step = -0.5 * h * (rp - rm) / curv
        if abs(step) > 2 * h:
            break
        w += step
        h = max(abs(step), 1e-12 * w)
    rss = periodic_rss(t, x, w, H)
    dof = max(x.size - (2 * H + 1) - 1, 1)
    var = max(rss / dof, _noise_floor(x))
    h = max(1e-3 * dw, 1e-9 * w)
    curv = (periodic_rss(t, x, w + h, H) - 2 * rss + periodic_rss(t, x, w - h, H)) / h**2
    se = math.sqrt(2 * var / curv) if curv > 0 else math.nan
    return Fundamental(w, se, rss, var, dof, H)


#: The most combined standard errors by which another channel's frequency may differ from the
#: drive's and still sharpen it (:func:`with_second_channel`).
AGREE_SE = 4.0


def with_second_channel(t: np.ndarray, drive: np.ndarray, other: np.ndarray, best: Fundamental) -> Fundamental:
    """``best``, the drive channel's fundamental, sharpened by another channel of the same record
    that repeats at the drive's period (the motion): that channel's own least-squares frequency
    within 8 of ``best``'s standard errors, combined with ``best``'s by inverse variance where
    the two agree within :data:`AGREE_SE` combined errors; else ``best`` as it is. Returns the
    drive channel's fit at the combined frequency (pure).

    A torque transducer is often far noisier than an encoder. At 10% noise on the torque and
    0.1% on the angles, the torque's frequency alone was off by about 2e-4 of itself, and a right
    model read chi2/dof 1.5-1.8: the undriven body's equation holds the angles' noise alone, and
    its rows saw the periods cut at the wrong length."""
    if not (math.isfinite(best.std_error_rad_s) and best.std_error_rad_s > 0):
        return best
    t = np.asarray(t, float) - float(t[0])
    x = np.asarray(other, float)
    if x.size < 2 * best.harmonics + 3 or not np.any(x - x.mean()):
        return best
    w1, s1, H = best.omega_rad_s, best.std_error_rad_s, best.harmonics
    dw = 2 * math.pi / (8 * x.size * float((t[-1] - t[0]) / (x.size - 1)))
    own = _least_squares_fundamental(t, x, H, w1 - 8 * s1, w1 + 8 * s1, dw)
    s2 = own.std_error_rad_s
    if not (math.isfinite(s2) and s2 > 0) or abs(own.omega_rad_s - w1) > AGREE_SE * math.hypot(s1, s2):
        return best
    a1, a2 = s1 ** -2, s2 ** -2
    w = (a1 * w1 + a2 * own.omega_rad_s) / (a1 + a2)
    rss = periodic_rss(t, np.asarray(drive, float), w, H)
    return Fundamental(w, (a1 + a2) ** -0.5, rss, max(rss / best.dof, _noise_floor(np.asarray(drive, float))),
                       best.dof, H)


def fit_at(t: np.ndarray, x: np.ndarray, best: Fundamental) -> Fundamental:
    """Another channel's periodic fit at ``best``'s frequency and harmonics: its residual and
    noise variance there, the reference :func:`repeat_statistic` compares that channel with."""
    t = np.asarray(t, float) - float(t[0])
    x = np.asarray(x, float)
    rss = periodic_rss(t, x, best.omega_rad_s, best.harmonics)
    return Fundamental(best.omega_rad_s, math.nan, rss, max(rss / best.dof, _noise_floor(x)), best.dof, best.harmonics)


def repeat_statistic(t: np.ndarray, x: np.ndarray, omega: float, best: Fundamental) -> float:
    """``(RSS(omega) - RSS(best)) / noise variance`` for one channel: about chi-square(1)
    when the data repeat at ``omega`` (>= 0 up to the optimiser's tolerance)."""
    t = np.asarray(t, float) - float(t[0])
    return max(periodic_rss(t, x, omega, best.harmonics) - best.rss, 0.0) / best.noise_var


@dataclass(frozen=True)
class PeriodFit:
    """Whole periods synthesised from per-period least-squares harmonics.

    Attributes:
      samples: shape (channels, n_periods * samples_per_period), on the grid
        ``t0 + k T / samples_per_period``.
      harmonics: highest harmonic estimated (limited by the samples in a period).
      residual_rms: per channel, RMS of the data minus the fit (signal units): noise plus
        what lies above the harmonics estimated.
      condition_number: of the first period's least-squares matrix.
    """

    samples: np.ndarray
    n_periods: int
    samples_per_period: int
    harmonics: int
    residual_rms: np.ndarray
    condition_number: float


#: Highest harmonic estimated per period by default: far above what the diagnosis balances
#: (20) or a multisine reaches (105), and it keeps the least-squares problems small.
MAX_LS_HARMONICS = 128


def ls_harmonics(samples_per_period: float, max_share: float = 0.4, cap: int = MAX_LS_HARMONICS) -> int:
    """Harmonics estimated per period from ``samples_per_period`` (non-integer) samples: at most
    ``max_share`` of them, so that a fifth of each period's samples measure the residual
    (noise and content above H) instead of being interpolated, and at most ``cap``."""
    return max(1, min(int(math.floor((samples_per_period - 1) / 2)) - 1, int(max_share * samples_per_period), cap))


def periods_by_least_squares(t: np.ndarray, channels: np.ndarray, omega: float, *, samples_per_period: int,
                             harmonics: Optional[int] = None, max_condition: float = 100.0) -> PeriodFit:
    """Whole periods of a record whose period is not a whole number of samples.

    Args:
      t: sample times (n,), uniform; the periods start at ``t[0]``.
      channels: shape (c, n).
      omega: the fundamental (rad/s), already checked against the data.
      samples_per_period: samples per period of the output (> 2H).
      harmonics: highest harmonic H (default :func:`ls_harmonics`).
      max_condition: H is lowered until the first period's least-squares matrix has a condition
        number below this (noise grows by at most this factor on the top harmonics).
    """
    t = np.asarray(t, float)
    x = np.atleast_2d(np.asarray(channels, float))
    T = 2 * math.pi / omega
    dt = float(t[1] - t[0])
    rel = t - t[0]
    P = int(math.floor((rel[-1] + dt) / T + 1e-9))
    if P < 1:
        raise ValueError("the record holds less than one period")
    H = ls_harmonics(T / dt) if harmonics is None else int(harmonics)
    H = max(1, min(H, (samples_per_period - 1) // 2))
    idx = [np.flatnonzero((rel >= p * T - 1e-9 * dt) & (rel < (p + 1) * T - 1e-9 * dt)) for p in range(P)]
    while True:
        s = np.linalg.svd(_basis(rel[idx[0]], omega, H), compute_uv=False)
        cond = float(s[0] / s[-1])
        if cond <= max_condition or H <= 1:
            break
        H = max(1, int(H * 0.9))
    N = samples_per_period
    G = _basis(np.arange(N) * (T / N), omega, H)
    out = np.empty((x.shape[0], P * N))
    ss = np.zeros(x.shape[0])
    for p, sel in enumerate(idx):
        B = _basis(rel[sel], omega, H)
        coef, *_ = np.linalg.lstsq(B, x[:, sel].T, rcond=None)  # (2H+1, c)
        out[:, p * N:(p + 1) * N] = (G @ coef).T
        ss += np.sum((x[:, sel].T - B @ coef) ** 2, axis=0)
    used = sum(sel.size for sel in idx)
    return PeriodFit(out, P, N, H, np.sqrt(ss / max(used, 1)), cond)


#: A record's leading periods are a transient (a record from rest, a drive just switched on) while
#: they depart from its last period by more than this many times the last two periods' own
#: difference, both over the lowest harmonics (:data:`TRANSIENT_HARMONICS`) where a transient
#: shows and each coefficient's noise is the sample noise over the square root of the samples:
#: steady periods differ by their noise alone (over 2 x 11 coefficients per channel the ratio of
#: two such differences exceeds 4 by chance about once in 1e8).
TRANSIENT_FACTOR = 4.0
#: ... and by more than this share of each channel's swing (a simulated record settles to 1e-7
#: of it; no balance sees a transient below this).
TRANSIENT_FLOOR = 1e-6
#: Harmonics 0..this of each period compared (fewer where a period holds fewer samples).
TRANSIENT_HARMONICS = 10


def transient_periods(channels: Sequence[np.ndarray], n_periods: int, own_mean: Sequence[bool] = ()) -> int:
    """How many leading whole periods of a record are a transient (:data:`TRANSIENT_FACTOR`):
    harmonics 0..:data:`TRANSIENT_HARMONICS` of each channel's every period (whole periods,
    ``n_periods`` of them), each over the channel's swing, compared with the last period's. A
    channel marked in ``own_mean`` loses its mean (a free body's position may move from period to
    period; a joint's twist may not). At most all but the last two periods (they measure the
    noise) are cut; 0 with fewer than three periods or no channel (pure)."""
    P = int(n_periods)
    if P < 3 or not channels:
        return 0
    coeffs = []
    for k, x in enumerate(channels):
        per = np.asarray(x, float).reshape(P, -1)
        H = min(TRANSIENT_HARMONICS, per.shape[1] // 2 - 1)
        c = np.fft.rfft(per, axis=1)[:, : H + 1] / per.shape[1]
        if k < len(own_mean) and own_mean[k]:
            c = c[:, 1:]
        coeffs.append(c / max(float(np.ptp(x)), 1e-300))
    C = np.concatenate(coeffs, axis=1)  # (P, coefficients)

    def rms(a) -> float:
        return float(np.sqrt(np.mean(np.abs(a) ** 2)))

    bound = max(TRANSIENT_FACTOR * rms(C[-1] - C[-2]), TRANSIENT_FLOOR)
    k = 0
    while k < P - 2 and rms(C[k] - C[-1]) > bound:
        k += 1
    return k


@dataclass(frozen=True)
class Drift:
    """Linear trend under the periodic model: ``slope`` (units per s) +- ``std_error``,
    ``t_stat`` = slope / std_error, and ``over_record`` = slope times the record's length."""

    slope: float
    std_error: float
    t_stat: float
    over_record: float


def linear_drift(t: np.ndarray, x: np.ndarray, omega: float, *, harmonics: int = 10) -> Drift:
    """Trend of ``x`` (n,) fitted together with harmonics 0..H of ``omega``."""
    t = np.asarray(t, float) - float(t[0])
    x = np.asarray(x, float)
    dt = float(t[1] - t[0])
    H = max(1, min(harmonics, int(math.pi / (omega * dt)) - 1))
    B = _basis(t, omega, H, trend=True)
    coef = _least_squares(B, x)
    r = x - B @ coef
    dof = max(x.size - B.shape[1], 1)
    var = max(float(r @ r) / dof, _noise_floor(x))
    tc = B[:, -1]
    # The trend column is nearly orthogonal to the harmonics over whole periods; its variance
    # from the exact normal equations all the same.
    cov = np.linalg.pinv(B.T @ B)
    se = math.sqrt(var * cov[-1, -1])
    slope = float(coef[-1])
    return Drift(slope, se, slope / se if se > 0 else math.inf, slope * float(tc[-1] - tc[0] + dt))


def period_spectra(x: np.ndarray, n_periods: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The noise estimator shared by the identifiers: ``(X, mean, var_of_mean)``.

    ``x``: ``n_periods`` whole periods of N samples each, ``(P N,)`` or ``(P, N)``. ``X`` holds
    every period's spectrum ``(P, N/2 + 1)`` (rfft divided by N, so ``x`` is the sum over the
    two-sided spectrum), ``mean`` their mean, and ``var_of_mean`` the variance of that mean at
    each harmonic, ``sum_p |X_p - mean|^2 / (P (P - 1))`` (unbiased; needs P >= 2)."""
    x = np.asarray(x, dtype=float)
    P = int(n_periods)
    if P < 2:
        raise ValueError(f"period_spectra: {P} period(s); the period-to-period variation needs at least 2")
    X = np.fft.rfft(x.reshape(P, -1), axis=1) / (x.size // P)
    mean = X.mean(axis=0)
    return X, mean, np.sum(np.abs(X - mean) ** 2, axis=0) / (P * (P - 1))


#: A harmonic stands out of the noise (is resolved) when its period average exceeds this many
#: of its standard errors: a pure-noise harmonic passes with probability about exp(-8) (complex
#: Gaussian). Both diagnoses use it: for the harmonics a model can be asked to predict, and for
#: what a residual's torque is read from.
RESOLVED_SIGMA = 4.0


def pooled(var: np.ndarray, half_width: int = 4) -> np.ndarray:
    """Moving average of a per-harmonic variance over +-half_width harmonics (n >= 1): a steadier
    noise estimate than one harmonic's ``P - 1`` degrees of freedom give."""
    out = var.copy()
    v = var[1:]
    if v.size:  # the window's sum, shifted slices of the zero-padded harmonics: no long running
        # sum whose differences would lose a small line beside a large one, and a window wider
        # than the harmonics there are takes them all
        n, pad = v.size, np.zeros(half_width)
        padded, ones = np.concatenate([pad, v, pad]), np.concatenate([pad, np.ones(n), pad])
        num = sum(padded[j:j + n] for j in range(2 * half_width + 1))
        den = sum(ones[j:j + n] for j in range(2 * half_width + 1))
        out[1:] = num / den
    return out


def pooled_period_spectra(x: np.ndarray, n_periods: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`period_spectra` with the variance of the mean :func:`pooled` over neighbouring harmonics."""
    X, mean, var = period_spectra(x, n_periods)
    return X, mean, pooled(var)


def white_variance(var_of_mean: np.ndarray, samples_per_period: int) -> float:
    """Variance per sample of the mean period (the mean over its samples of each sample's
    variance) from :func:`period_spectra`'s per-harmonic variances, by Parseval: the mean and
    (for even N) the Nyquist line once, every other line twice (it stands for +-n)."""
    v = np.asarray(var_of_mean, dtype=float)
    w = np.full(v.size, 2.0)
    w[0] = 1.0
    if samples_per_period % 2 == 0:
        w[-1] = 1.0
    return float(np.sum(w * v))


def raw_noise_std(var_of_mean: np.ndarray, n_periods: int, samples_per_period: int) -> float:
    """Standard deviation of the noise per raw sample from :func:`period_spectra`'s (or a pooled)
    per-harmonic variance of the mean: the median over the harmonics 1 .. N/2 - 1, so a few lines
    the signal leaks into (a drive's jitter) do not raise it. Each harmonic's variance is a
    chi-square of ``d = 2 (P - 1)`` degrees of freedom over d, whose median lies below its mean
    (0.69 of it at P = 2, 0.93 at P = 6): the median is divided by that ratio, so the variance is
    not read low."""
    from scipy.stats import chi2

    N, d = samples_per_period, 2 * (n_periods - 1)
    return float(np.sqrt(np.median(np.asarray(var_of_mean)[1:N // 2]) / (chi2.median(d) / d) * n_periods * N))
