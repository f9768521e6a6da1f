"""Unknown joint law: piecewise-linear ("hat") restoring torque g(phi) of eq. (8), and optionally
damping torque f(phi') of eq. (9), from noisy runs.

When the form of the law is unknown, g(phi) is represented by its values g_i at knots spread
uniformly over the measured range of phi (hat functions interpolate linearly between them),
beside viscous damping (or hat functions of phi', eq. 9). The unknowns are identified by the
errors-in-variables maximum-likelihood harmonic balance of :mod:`identify.eiv`, with an
optional smoothness penalty ``lambda |D2 g|^2`` on the second differences of the knot values.

lambda is chosen by generalised cross-validation (GCV) on the whitened problem linearised at a
lightly penalised start: ``GCV(lambda) = n |r|^2 / (n - tr H)^2`` over a logarithmic grid, with
H the influence matrix. GCV estimates the prediction error without a held-out run and needs
no noise level (the whitening already carries it). With ``lam=0`` no penalty is used.

The confidence band is the posterior one of the penalised fit, ``g(phi) +- 1.96 sqrt(h' C h)``
with h the hat functions at phi and C the posterior covariance ``(J'J + lambda P'P)^-1``:
Bayesian intervals of penalised splines, whose coverage is nominal on average over the curve
(Wahba 1983, Nychka 1988) rather than at every point.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from jointrig.vocab.law import Term, Viscous, angle_hats, hat_matrix, rate_hats
from .eiv import (EivResult, average_periods, iterated_gls, linearised, prepare_eiv_runs, scaled_ls_start,
                  solve_penalised)
from .harmonics import fourier_coefficients, synthesize
from jointrig.vocab.records import SteadyStateRecord

__all__ = ["HatFit", "fit_hat_law", "knots_from_range", "rate_knots_from_range", "LAMBDA_GRID"]

#: Candidate penalty weights (relative to the data's whitened scale, see fit_hat_law).
LAMBDA_GRID = tuple(float(x) for x in np.logspace(-8, 2, 21))


def _trusted_signals(records: Sequence[SteadyStateRecord], n_harmonics: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(phi, phi')`` of each run's mean period band-limited to harmonics 0..H (what the balance
    sees), for the runs whose angle swing stands out of its noise (20 x the band-limited
    noise's standard deviation): with noise set relative to each encoder's own swing, the
    relative angle of a slow run (large rigid rotation) can be mostly noise."""
    out = []
    for r in records:
        avg = average_periods(r, noise_free=r.n_periods < 2)
        N = avg.n_samples
        C = fourier_coefficients(avg.phi_rad, 1, n_harmonics)
        phi = synthesize(C, N)
        if np.ptp(phi) > 20 * np.sqrt(avg.var_phi_rad2 * (2 * n_harmonics + 1) / N):
            out.append((phi, synthesize(1j * np.arange(n_harmonics + 1) * avg.omega_rad_s * C, N)))
    if not out:
        raise ValueError("no record's relative angle stands out of its noise: no range to place knots on")
    return out


def knots_from_range(records: Sequence[SteadyStateRecord], n_knots: int, n_harmonics: int) -> np.ndarray:
    """``n_knots`` knots spread uniformly over the measured range of phi (rad), from the
    runs whose angle stands out of its noise (:func:`_trusted_signals`)."""
    if n_knots < 3:
        raise ValueError(f"n_knots must be >= 3, got {n_knots}")
    sig = _trusted_signals(records, n_harmonics)
    return np.linspace(min(float(phi.min()) for phi, _ in sig), max(float(phi.max()) for phi, _ in sig), n_knots)


def rate_knots_from_range(records: Sequence[SteadyStateRecord], n_knots: int, n_harmonics: int) -> np.ndarray:
    """An odd number of knots (rad/s) symmetric about 0 over the largest measured |phi'|, from
    the same runs as :func:`knots_from_range`."""
    if n_knots < 3 or n_knots % 2 == 0:
        raise ValueError(f"n_rate_knots must be odd and >= 3 (0 is the middle knot), got {n_knots}")
    top = max(float(np.max(np.abs(rate))) for _, rate in _trusted_signals(records, n_harmonics))
    return np.linspace(-top, top, n_knots)


@dataclass(frozen=True)
class HatFit:
    """A piecewise-linear restoring torque with its uncertainty.

    Attributes:
      knots_rad, g_Nm: knot positions and values; covariance_Nm2: of g, ``(m, m)``.
      lam: the penalty weight used (0: none); gcv: ``(lambda, GCV score)`` over the grid
        (empty when lambda was given).
      result: the full ML result (Je, damping and the g_i).
      rate_knots_rad_s, f_Nm, f_covariance_Nm2: the damping torque f(phi') on hat functions of
        the rate (eq. 9) when asked for (f = 0 at the middle knot, phi' = 0: a constant torque
        belongs to g); else empty.
    """

    knots_rad: np.ndarray
    g_Nm: np.ndarray
    covariance_Nm2: np.ndarray
    lam: float
    gcv: tuple[tuple[float, float], ...]
    result: EivResult
    rate_knots_rad_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    f_Nm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    f_covariance_Nm2: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def band(self, phi_rad: np.ndarray, z: float = 1.959963984540054) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(g, lower, upper)`` at ``phi_rad`` (N m); the band is +-z posterior standard deviations."""
        H = hat_matrix(np.asarray(phi_rad, dtype=float), self.knots_rad)
        g = H @ self.g_Nm
        sd = np.sqrt(np.einsum("ij,jk,ik->i", H, self.covariance_Nm2, H))
        return g, g - z * sd, g + z * sd

    def band_f(self, rate_rad_s: np.ndarray, z: float = 1.959963984540054
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(f, lower, upper)`` of the damping torque at ``rate_rad_s`` (N m)."""
        if not self.f_Nm.size:
            raise ValueError("this fit has no hat functions of the rate (pass n_rate_knots)")
        H = hat_matrix(np.asarray(rate_rad_s, dtype=float), self.rate_knots_rad_s)
        H = np.delete(H, self.rate_knots_rad_s.size // 2, axis=1)  # f = 0 at the middle knot
        f = H @ self.f_Nm
        sd = np.sqrt(np.einsum("ij,jk,ik->i", H, self.f_covariance_Nm2, H))
        return f, f - z * sd, f + z * sd


def _second_differences(n_params: int, first: int, n: int, skip: int = -1) -> np.ndarray:
    """Rows (1, -2, 1) over ``n`` consecutive knot values stored from ``first``; the knot
    ``skip`` is fixed at 0 (not a parameter) and the parameters after it shift down by one."""
    def col(j):
        return None if j == skip else first + (j if skip < 0 or j < skip else j - 1)

    rows = []
    for i in range(n - 2):
        row = np.zeros(n_params)
        for j, w in zip((i, i + 1, i + 2), (1.0, -2.0, 1.0)):
            c = col(j)
            if c is not None:
                row[c] = w
        rows.append(row)
    return np.array(rows).reshape(-1, n_params)


def fit_hat_law(records: Sequence[SteadyStateRecord], *, n_knots: int, n_harmonics: int, torque_share: float,
                damping: Sequence[Term] = (Viscous(),), lam: Optional[float] = None,
                knots_rad: Optional[Sequence[float]] = None, n_rate_knots: Optional[int] = None,
                progress: Optional[Callable[[str], None]] = None) -> HatFit:
    """Identify ``g(phi)`` on hat functions (and the damping, and Je) from noisy runs.

    Args:
      records: measured runs with at least 2 periods each (noise from their variation).
      n_knots: number of knots over the measured range of phi (ignored with ``knots_rad``).
      damping: the damping terms beside g (default viscous); ignored with ``n_rate_knots``.
      lam: penalty weight; None chooses it by GCV over :data:`LAMBDA_GRID`; 0 turns it off.
      n_rate_knots: identify the damping torque f(phi') on this many hat functions of the rate
        (odd; eq. 9) instead of ``damping``; the penalty then smooths f too.
      progress: optional callable ``(message) -> None``: the penalty chosen, then the ML fit.
    """
    say = progress or (lambda msg: None)
    knots = (np.asarray(knots_rad, dtype=float) if knots_rad is not None
             else knots_from_range(records, n_knots, n_harmonics))
    hats = angle_hats(knots)
    rknots = np.zeros(0)
    if n_rate_knots is not None:
        rknots = rate_knots_from_range(records, n_rate_knots, n_harmonics)
        rh = rate_hats(rknots)
        damping = tuple(h for i, h in enumerate(rh) if i != len(rh) // 2)  # f(0) = 0
    terms = tuple(damping) + hats
    runs = prepare_eiv_runs(records, terms, n_harmonics=n_harmonics, torque_share=torque_share)
    p = 1 + len(terms)
    first = 1 + len(damping)
    m = len(hats)
    blocks = [_second_differences(p, first, m)]
    if n_rate_knots is not None:
        blocks.append(_second_differences(p, 1, n_rate_knots, skip=n_rate_knots // 2))
    # Make lambda dimensionless: each block on the scale of its columns in the whitened data.
    ls = scaled_ls_start(runs)
    J0, _ = linearised(runs, ls)
    scaled = []
    for D in blocks:
        cols = np.flatnonzero(np.any(D != 0, axis=0))
        scaled.append(D * np.linalg.norm(J0[:, cols]) / max(np.linalg.norm(D), 1e-300))
    P = np.vstack(scaled)
    gcv: list[tuple[float, float]] = []
    if lam is None:
        theta0 = iterated_gls(runs, ls, penalty=np.sqrt(LAMBDA_GRID[0]) * P)
        J, y = linearised(runs, theta0)
        JtJ, Jty, PtP = J.T @ J, J.T @ y, P.T @ P
        n = y.size
        for lg in LAMBDA_GRID:
            M = JtJ + lg * PtP
            th = np.linalg.solve(M, Jty)
            r = y - J @ th
            tr = float(np.trace(np.linalg.solve(M, JtJ)))
            gcv.append((lg, float(n * (r @ r) / (n - tr) ** 2)))
        lam = min(gcv, key=lambda x: x[1])[0]
        say(f"penalty lambda = {lam:.2g}, the least GCV of {len(gcv)} values")
    say(f"maximum likelihood over {p} unknowns and {sum(r.F.size for r in runs)} rows")
    res = solve_penalised(runs, terms, np.sqrt(lam) * P if lam > 0 else None)
    g = res.values[first:]
    cov = res.covariance[first:, first:]
    if n_rate_knots is None:
        return HatFit(knots, g, cov, float(lam), tuple(gcv), res)
    return HatFit(knots, g, cov, float(lam), tuple(gcv), res, rknots, res.values[1:first],
                  res.covariance[1:first, 1:first])
