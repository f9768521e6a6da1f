"""Harmonic balance on noisy periodic records: errors in variables, maximum likelihood, CRLB.

A bench measures angles and torque with noise. The angle noise enters the regression matrix
[A] itself (the inertia column is (i n w)^2 Phi_n, the law's columns are functions of phi),
so plain least squares on eq. (7) is biased: E[A'A] = A0'A0 + E[dA'dA]. This module uses
the periods instead:

1. **Average** the P measured periods of every run (:func:`average_periods`). The noise of
   the mean has variance sigma^2 / P per sample; sigma^2 of each channel (relative angle,
   torque) comes from the period-to-period variation, pooled over the period's samples
   (white noise: N (P - 1) degrees of freedom per run and channel, so the variance is known
   to ~1/sqrt(N (P - 1)) = 3% at N = 256, P = 8).
2. **Propagate** that noise to the balance residual ``e(theta) = A(phi) theta - s M u``
   (rows: harmonics 0..H, cosine and sine) to first order:
   ``de = M [Je D2 + diag(sum_j theta_j db_j/dphi) + diag(sum_j theta_j db_j/dphi') D1] dphi
   - s M du``, with M the Fourier-row operator and D1, D2 the (band-limited) spectral
   derivatives. Its covariance ``C(theta)`` is full: a nonlinear term couples harmonics.
   The law's columns are debiased to second order (:func:`_debiased`): a nonlinear term of
   a noisy angle has a biased mean (E[(x + n)^3] = x^3 + 3 s^2 x), which no weighting removes.
3. **Maximum likelihood** (frequency-domain errors-in-variables ML, with the true signals
   eliminated): minimise ``V(theta) = sum_runs e' C(theta)^-1 e``. The theta in C is what
   removes the bias (as in total least squares); weighting alone would not. Solved by
   Levenberg-Marquardt on the whitened residuals from two starts, iterated generalised least
   squares and instrumental variables (rows from one half of the periods, instruments from the
   other: consistent), keeping the lower cost: under heavy noise the likelihood can hold a
   spurious minimum near the attenuated least-squares start.
4. **Uncertainty**: ``cov = (J' J)^-1`` with J the Jacobian of the whitened residuals at
   the optimum; at the true noiseless signals the same expression is the (small-noise)
   Cramer-Rao lower bound (:func:`crlb`), which the Monte Carlo of
   ``scripts/bench_identification.py`` compares the estimator against.

Only angles and torque are needed (rates are derived). The unknowns are the equivalent
form's: ``Je_kgm2`` and the law's parameters, with the drive share ``s = J2 / (J1 + J2)``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from scipy import linalg, optimize, stats

from jointrig.vocab.law import Term
from .estimates import Estimates, equilibrated_condition
from .harmonics import fourier_coefficients, max_harmonic
from .periods import period_spectra, white_variance
from jointrig.vocab.records import RecordError, SteadyStateRecord
from jointrig.vocab.params import JE

__all__ = ["PeriodAverage", "average_periods", "EivResult", "ml_identify", "crlb", "DEFAULT_RATE_BAND",
           "prepare_eiv_runs", "linearised", "iterated_gls", "scaled_ls_start", "solve_penalised",
           "fisher_per_period"]

#: Harmonics kept in the derived rate (the noise of a spectral derivative grows with n).
DEFAULT_RATE_BAND = 20


@dataclass(frozen=True)
class PeriodAverage:
    """One run reduced to its mean period and the noise of that mean.

    Attributes:
      omega_rad_s: fundamental (rad/s).
      phi_rad, torque_Nm: mean period of the relative angle and the torque, ``(N,)``.
      var_phi_rad2, var_torque_Nm2: noise variance per sample of the *mean* (sigma^2 / P).
      n_periods: P periods averaged.
      source: the record's source.
    """

    omega_rad_s: float
    phi_rad: np.ndarray
    torque_Nm: np.ndarray
    var_phi_rad2: float
    var_torque_Nm2: float
    n_periods: int
    source: str

    @property
    def n_samples(self) -> int:
        return self.phi_rad.size


def average_periods(record: SteadyStateRecord, *, noise_free: bool = False,
                    periods: slice = slice(None)) -> PeriodAverage:
    """Mean period and noise variance of the mean from the period-to-period variation.

    ``noise_free=True`` (simulated records without noise, one period allowed) sets both
    variances to 0. Otherwise at least 2 periods are needed. ``periods`` selects the periods
    to use (all by default).
    """
    P, N = record.n_periods, record.samples_per_period
    phi = record.phi_rad.reshape(P, N)[periods]
    u = record.torque_Nm.reshape(P, N)[periods]
    k = phi.shape[0]
    if noise_free:
        return PeriodAverage(record.omega_rad_s, phi.mean(axis=0), u.mean(axis=0), 0.0, 0.0, k, record.source)
    if k < 2:
        raise RecordError(f"{record.source}: {k} period(s); the noise estimate needs at least 2 "
                          f"measured periods (8 give 7 degrees of freedom per sample)")
    var_phi = white_variance(period_spectra(phi, k)[2], N)
    var_u = white_variance(period_spectra(u, k)[2], N)
    return PeriodAverage(record.omega_rad_s, phi.mean(axis=0), u.mean(axis=0), var_phi, var_u, k, record.source)


def _halves(record: SteadyStateRecord) -> Optional[tuple[PeriodAverage, PeriodAverage]]:
    """Mean periods of the first and the second half of the periods (independent noise), with
    the noise of each from its own periods; None below 4 periods."""
    P = record.n_periods
    if P < 4:
        return None
    return average_periods(record, periods=slice(0, P // 2)), average_periods(record, periods=slice(P // 2, P))


@functools.lru_cache(maxsize=32)
def _row_operator(n_samples: int, n_harmonics: int) -> np.ndarray:
    """Real Fourier rows M, ``(2H + 1, N)``: Re C_0, then Re C_n, Im C_n for n = 1..H."""
    C = fourier_coefficients(np.eye(n_samples), 1, n_harmonics).T  # (H + 1, N)
    rows = [C[0].real]
    for n in range(1, n_harmonics + 1):
        rows += [C[n].real, C[n].imag]
    out = np.array(rows)
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=64)
def _unit_derivative(n_samples: int, order: int, band: int) -> np.ndarray:
    F = np.fft.rfft(np.eye(n_samples), axis=0)
    n = np.arange(F.shape[0])
    gain = (1j * n) ** order * (n <= band)
    out = np.fft.irfft(F * gain[:, None], n=n_samples, axis=0)
    out.flags.writeable = False
    return out


def _derivative_operator(n_samples: int, omega: float, order: int, band: int) -> np.ndarray:
    """Spectral derivative of a periodic signal, harmonics 1..band kept, ``(N, N)``."""
    return _unit_derivative(n_samples, order, band) * omega**order


@dataclass
class _Run:
    """Precomputed pieces of one run (independent of theta).

    The noise map is linear in theta: ``G(theta) = sum_i theta_i B_i`` with ``B_0 = M D2``
    (inertia) and ``B_j = M diag(db_j/dphi) + M diag(db_j/dphi') D1``, so
    ``C(theta) = var_phi G G' + var_u s^2 M M'``. ``G`` is formed for each theta (p R N
    multiply-adds) rather than the products ``B_i B_j'`` kept (p^2 R^2 of them): for a law on
    41 hat functions those are 5 MB a run, read at every evaluation of the likelihood
    (``time .venv/bin/jointrig unknown-law``: 12.9 -> 5.4 s, the same printed figures).
    """

    A: np.ndarray          # (R, p) regression rows: Je column, then the law's columns
    F: np.ndarray          # (R,) share * M u
    B: np.ndarray          # (p, R, N) the noise map's pieces B_i
    U: np.ndarray          # (R, R) torque-noise covariance of the rows
    var_phi: float
    var_u: float

    def covariance(self, theta: np.ndarray) -> np.ndarray:
        G = np.tensordot(theta, self.B, axes=1)
        return self.var_phi * (G @ G.T) + self.U


def _derivative(term: Term, phi: np.ndarray, rate: np.ndarray, wrt: str) -> np.ndarray:
    """Central difference of a term along phi or phi' (a kink is met at isolated samples only)."""
    x = phi if wrt == "phi" else rate
    h = 1e-6 * max(float(np.max(np.abs(x))), 1e-12)
    if wrt == "phi":
        return (np.asarray(term(phi + h, rate), float) - np.asarray(term(phi - h, rate), float)) / (2 * h)
    return (np.asarray(term(phi, rate + h), float) - np.asarray(term(phi, rate - h), float)) / (2 * h)


#: Gauss-Hermite rule for E[f(z)], z ~ N(0, 1): exact for polynomials of degree <= 5.
_GH_NODES = (0.0, math.sqrt(3.0), -math.sqrt(3.0))
_GH_WEIGHTS = (2 / 3, 1 / 6, 1 / 6)


def _debiased(term: Term, phi: np.ndarray, rate: np.ndarray, var_phi: float, var_rate: float) -> np.ndarray:
    """A law column with its noise bias removed to second order: ``2 b(x) - E_n[b(x + n)]``.

    A nonlinear term of a noisy signal is biased: E[(x + n)^3] = x^3 + 3 s^2 x, a phantom
    linear stiffness. With n distributed as the noise of the mean (the angle's, and the
    derived rate's, uncorrelated at equal times), ``E[2 b(x) - b(x + n')]`` with an
    independent n' equals b(x) up to O(s^4) (exactly for the cube); the expectation over n'
    is a 3 x 3 Gauss-Hermite rule. Linear terms are returned unchanged.
    """
    b = np.broadcast_to(np.asarray(term(phi, rate), float), phi.shape)
    if var_phi <= 0 and var_rate <= 0:
        return b
    sp, sr = math.sqrt(max(var_phi, 0.0)), math.sqrt(max(var_rate, 0.0))
    mean = np.zeros_like(b)
    for zp, wp in zip(_GH_NODES, _GH_WEIGHTS):
        for zr, wr in zip(_GH_NODES, _GH_WEIGHTS):
            mean = mean + wp * wr * np.asarray(term(phi + zp * sp, rate + zr * sr), float)
    return 2 * b - mean


def _prepare(avg: PeriodAverage, terms: Sequence[Term], n_harmonics: int, share: float, rate_band: int,
             noisy: bool = True) -> _Run:
    """Rows, noise map and covariance pieces of one run; ``noisy=False``: the signals are the
    true ones (the CRLB), so the columns are not debiased."""
    N = avg.n_samples
    if n_harmonics > max_harmonic(N):
        raise RecordError(f"{avg.source}: n_harmonics={n_harmonics} needs more than {N} samples per period")
    band = min(max(rate_band, n_harmonics), max_harmonic(N))
    M = _row_operator(N, n_harmonics)
    D1 = _derivative_operator(N, avg.omega_rad_s, 1, band)
    D2 = _derivative_operator(N, avg.omega_rad_s, 2, band)
    phi = avg.phi_rad
    rate = D1 @ phi
    var_rate = avg.var_phi_rad2 * float(np.sum(D1[:, 0] ** 2))  # per-sample variance of D1 noise
    if not noisy:
        var_rate = 0.0
    cols = [M @ (D2 @ phi)] + [M @ _debiased(t, phi, rate, avg.var_phi_rad2 if noisy else 0.0, var_rate)
                               for t in terms]
    A = np.column_stack(cols)
    F = share * (M @ avg.torque_Nm)
    B = [M @ D2]
    for t in terms:
        B.append(M * _derivative(t, phi, rate, "phi") + (M * _derivative(t, phi, rate, "rate")) @ D1)
    B = np.array(B)
    U = avg.var_torque_Nm2 * share**2 * (M @ M.T)
    return _Run(A, F, B, U, avg.var_phi_rad2, avg.var_torque_Nm2)


@dataclass(frozen=True)
class EivResult(Estimates):
    """Maximum-likelihood harmonic balance on noisy periodic records.

    Attributes:
      names, values, std_errors, covariance: parameters (``Je_kgm2`` first) with units in the names.
      start: the iterated generalised least-squares start (biased by the noise in [A]).
      cost: ``V = sum e' C^-1 e`` at the optimum; ``dof = rows - parameters``. For a model
        that holds, V / dof ~ 1: ``p_value`` is the chi-square probability of a V this large.
      n_rows, n_runs, success, message.
    """

    names: tuple[str, ...]
    values: np.ndarray
    std_errors: np.ndarray
    covariance: np.ndarray
    start: np.ndarray
    cost: float
    dof: int
    p_value: float
    n_rows: int
    n_runs: int
    success: bool
    message: str
    #: of the whitened Jacobian at the optimum, columns equilibrated
    condition_number: float = math.nan


def _whitened(runs: Sequence[_Run], theta: np.ndarray) -> np.ndarray:
    """``L^-1 (A theta - F)`` per run, C(theta) = L L' (the ML residual; one triangular solve of a
    vector per run, where :func:`linearised` solves the whole [A])."""
    out = []
    for r in runs:
        L = linalg.cholesky(r.covariance(theta), lower=True)
        out.append(linalg.solve_triangular(L, r.A @ theta - r.F, lower=True))
    return np.concatenate(out)


def iterated_gls(runs: Sequence[_Run], theta: np.ndarray, iterations: int = 6, penalty: Optional[np.ndarray] = None
         ) -> np.ndarray:
    """Iterated generalised least squares: rows weighted by C(theta) of the previous iterate.

    Still biased by the noise in [A] (C does not vary with the unknowns inside one solve),
    but it down-weights the rows the noise dominates (the inertia column (n w)^2 Phi_n at high
    harmonics), which plain least squares trusts as much as any other: a start near the
    likelihood's global minimum. ``penalty`` rows (already scaled by sqrt(lambda)) are appended.
    """
    for _ in range(iterations):
        A, F = linearised(runs, theta)
        if penalty is not None:
            A, F = np.vstack([A, penalty]), np.concatenate([F, np.zeros(penalty.shape[0])])
        d = 1 / np.where(np.linalg.norm(A, axis=0) > 0, np.linalg.norm(A, axis=0), 1)
        theta = np.linalg.lstsq(A * d, F, rcond=None)[0] * d
    return theta


def _instrumental(runs: Sequence[_Run], halves: Sequence[tuple[_Run, _Run]], theta: np.ndarray) -> np.ndarray:
    """Instrumental variables: the rows built from one half of the periods are regressed with
    the rows of the other half as instruments (their noise is independent, so the noise in
    [A] no longer biases the estimate), both ways round, weighted by C(theta)^-1."""
    lhs, rhs = 0.0, 0.0
    for full, (h1, h2) in zip(runs, halves):
        W = np.linalg.inv(full.covariance(theta))
        for a, z in ((h1, h2), (h2, h1)):
            lhs = lhs + z.A.T @ W @ a.A
            rhs = rhs + z.A.T @ W @ a.F
    return np.linalg.solve(lhs, rhs)


def scaled_ls_start(runs: Sequence[_Run]) -> np.ndarray:
    """Start: least squares with each run's rows scaled by its rhs size (columns equilibrated); a
    run whose rhs is zero (no drive reached it) is kept unscaled."""
    size = [float(np.linalg.norm(r.F)) or 1.0 for r in runs]
    A = np.vstack([r.A / s for r, s in zip(runs, size)])
    F = np.concatenate([r.F / s for r, s in zip(runs, size)])
    d = 1 / np.where(np.linalg.norm(A, axis=0) > 0, np.linalg.norm(A, axis=0), 1)
    return np.linalg.lstsq(A * d, F, rcond=None)[0] * d


def ml_identify(records: Sequence[SteadyStateRecord], terms: Sequence[Term], *, n_harmonics: int,
                torque_share: float, rate_band: int = DEFAULT_RATE_BAND) -> EivResult:
    """Errors-in-variables maximum-likelihood harmonic balance (equivalent form).

    Args:
      records: measured runs, each with at least 2 whole periods (noise from their variation).
      terms: the law's basis terms (vocab.law).
      n_harmonics: harmonics 0..H balanced.
      torque_share: J2 / (J1 + J2), the drive's share on the relative coordinate.
      rate_band: harmonics kept in the derived rate.
    """
    runs = prepare_eiv_runs(records, terms, n_harmonics=n_harmonics, torque_share=torque_share, rate_band=rate_band)
    split = [_halves(r) for r in records]
    halves = None if any(h is None for h in split) else [
        tuple(_prepare(h, terms, n_harmonics, torque_share, rate_band) for h in pair) for pair in split]
    return _solve(runs, terms, halves)


def _solve(runs: Sequence[_Run], terms: Sequence[Term], halves=None, penalty: Optional[np.ndarray] = None
           ) -> EivResult:
    """ML fit; ``penalty`` (rows over theta, scaled by sqrt(lambda)) adds ``|penalty theta|^2`` to
    the cost (a smoothness prior); the covariance is then the posterior one,
    ``(J'J + penalty'penalty)^-1``, and ``cost`` is the data part only."""
    names = (JE,) + tuple(t.name for t in terms)
    start = iterated_gls(runs, scaled_ls_start(runs), penalty=penalty)
    starts = [start] + ([_instrumental(runs, halves, start)] if halves is not None and penalty is None else [])
    # Scale each unknown by its whitened column norm at the start (steps of ~1 standard
    # error), not by its start value: a start near 0 (gamma under heavy noise) would freeze it.
    norms = np.linalg.norm(linearised(runs, start)[0], axis=0)
    scale = 1 / np.where(norms > 0, norms, 1.0)
    n_rows = sum(r.F.size for r in runs)

    def residual(z):
        theta = z * scale
        w = _whitened(runs, theta)
        return w if penalty is None else np.concatenate([w, penalty @ theta])

    # The likelihood can hold a spurious minimum near the attenuated start (gamma ~ 0 under
    # heavy noise); the instrumental-variables start lies near the consistent one. Both are
    # refined and the lower cost kept.
    sols = [optimize.least_squares(residual, s0 / scale, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                   max_nfev=400 * len(names)) for s0 in starts]
    sol = min(sols, key=lambda x: float(np.sum(x.fun**2)))
    theta = sol.x * scale
    J = sol.jac / scale  # d residual / d theta (data rows, then penalty rows)
    cov = np.linalg.inv(J.T @ J)
    cost = float(np.sum(sol.fun[:n_rows] ** 2))
    dof = n_rows - len(names)
    p_value = float(stats.chi2.sf(cost, dof)) if dof > 0 and penalty is None else math.nan
    return EivResult(names, theta, np.sqrt(np.diag(cov)), cov, start, cost, dof, p_value, n_rows, len(runs),
                     bool(sol.success), str(sol.message), equilibrated_condition(J[:n_rows]))


def prepare_eiv_runs(records: Sequence[SteadyStateRecord], terms: Sequence[Term], *, n_harmonics: int,
                 torque_share: float, rate_band: int = DEFAULT_RATE_BAND) -> list:
    """The per-run pieces of :func:`ml_identify` (for estimators built on it, e.g. identify.hat):
    the errors-in-variables rows and covariance of every run. (The diagnosis's run preparation,
    :func:`identify.chain_diagnose.prepare_chain_runs`, averages and band-limits for the causes
    instead.)"""
    if not records:
        raise ValueError("at least one record is needed")
    if not 0 < torque_share <= 1:
        raise ValueError(f"torque_share must be in (0, 1], got {torque_share}")
    runs = [_prepare(average_periods(r), terms, n_harmonics, torque_share, rate_band) for r in records]
    for rec, r in zip(records, runs):
        if not (r.var_phi > 0 and r.var_u > 0):
            raise RecordError(f"{rec.source}: the periods are identical (no noise to estimate); "
                              f"use identify.identify for noise-free records")
    return runs


def linearised(runs: Sequence, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whitened regression ``(L^-1 A, L^-1 F)`` with C(theta) = L L' held fixed (for model
    selection criteria on the locally linear problem)."""
    As, Fs = [], []
    for r in runs:
        L = linalg.cholesky(r.covariance(theta), lower=True)
        As.append(linalg.solve_triangular(L, r.A, lower=True))
        Fs.append(linalg.solve_triangular(L, r.F, lower=True))
    return np.vstack(As), np.concatenate(Fs)


def solve_penalised(runs: Sequence, terms: Sequence[Term], penalty: Optional[np.ndarray]) -> EivResult:
    """:func:`ml_identify` on prepared runs with a quadratic penalty (see :func:`_solve`)."""
    return _solve(runs, terms, None, penalty)


def fisher_per_period(noiseless: Sequence[SteadyStateRecord], terms: Sequence[Term], theta: Sequence[float], *,
                      var_phi_rad2: Sequence[float], var_torque_Nm2: Sequence[float], n_harmonics: int,
                      torque_share: float, rate_band: int = DEFAULT_RATE_BAND) -> list[np.ndarray]:
    """Fisher information of ``(Je, law...)`` carried by ONE measured period of each run, with
    white Gaussian noise of the given per-sample variances: ``A0' C(theta)^-1 A0`` (small-noise,
    true signals as nuisance parameters). P periods carry P times as much (C scales as 1/P)."""
    theta = np.asarray(theta, dtype=float)
    out = []
    for rec, vp, vu in zip(noiseless, var_phi_rad2, var_torque_Nm2, strict=True):
        avg = average_periods(rec, noise_free=True)
        avg = PeriodAverage(avg.omega_rad_s, avg.phi_rad, avg.torque_Nm, vp, vu, 1, avg.source)
        W, _ = linearised([_prepare(avg, terms, n_harmonics, torque_share, rate_band, noisy=False)], theta)
        out.append(W.T @ W)
    return out


def crlb(noiseless: Sequence[SteadyStateRecord], terms: Sequence[Term], theta: Sequence[float], *,
         var_phi_rad2: Sequence[float], var_torque_Nm2: Sequence[float], n_periods, n_harmonics: int,
         torque_share: float, rate_band: int = DEFAULT_RATE_BAND) -> np.ndarray:
    """Cramer-Rao lower bound (covariance, ``(p, p)``) of ``(Je, law...)`` from ``n_periods``
    measured periods of these runs (one number for all, or one per run) with white Gaussian
    noise of the given per-sample variances (one per run).

    Small-noise bound of the errors-in-variables problem with the true signals as nuisance
    parameters: ``(sum_runs P_run A0' C1(theta)^-1 A0)^-1`` with A0 the noiseless regression
    rows and C1 the residual covariance of one period (:func:`fisher_per_period`).
    """
    F = fisher_per_period(noiseless, terms, theta, var_phi_rad2=var_phi_rad2, var_torque_Nm2=var_torque_Nm2,
                          n_harmonics=n_harmonics, torque_share=torque_share, rate_band=rate_band)
    periods = [n_periods] * len(F) if np.isscalar(n_periods) else list(n_periods)
    if len(periods) != len(F):
        raise ValueError(f"n_periods: {len(periods)} values for {len(F)} runs")
    return np.linalg.inv(sum(p * f for p, f in zip(periods, F)))
