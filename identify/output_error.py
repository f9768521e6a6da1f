"""Output-error refinement on periodic records: minimise the simulation error of the
steady-state response (computed by :func:`identify.steady.periodic_response`) over the
parameters, starting from a harmonic-balance estimate.

Harmonic balance is an equation-error method: noise on the measured response enters the
regression matrix and biases it. Output error compares the model's simulated response with
the measured one, the error that a free-run simulation shows, and is unbiased for output
noise; it needs a good start, which harmonic balance gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from scipy.optimize import least_squares

from .estimates import Estimates, equilibrated_condition
from jointrig.vocab.law import JointLaw, Term
from .solve import IdentificationResult
from .steady import periodic_response

__all__ = ["OutputErrorResult", "refine_output_error", "simulate_periods", "harmonic_balance_start", "steady_rms",
           "input_noise_rms"]


@dataclass(frozen=True)
class OutputErrorResult(Estimates):
    """Refined parameters ``(inertia, law values..., [delay_s])`` with standard errors.

    Attributes:
      names, values, std_errors: parameters (``inertia`` first, ``delay_s`` last if estimated).
      law: the refined law; inertia, delay_s: the refined inertia and delay.
      rms_error: RMS of simulated minus measured response over all samples.
      success, message, nfev: optimiser status.
    """

    names: tuple[str, ...]
    values: np.ndarray
    std_errors: np.ndarray
    law: JointLaw
    inertia: float
    delay_s: float
    rms_error: float
    success: bool
    message: str
    nfev: int
    #: of the simulation-error Jacobian at the optimum, columns equilibrated
    condition_number: float = math.nan


def simulate_periods(inertia: float, law: JointLaw, u_periods: np.ndarray, fs_Hz: float, *,
                     delay_s: float = 0.0, initial: Optional[np.ndarray] = None) -> tuple[np.ndarray, np.ndarray]:
    """Steady-state response to each periodic input record.

    Args:
      u_periods: one period of each input, ``(R, N)``.

    Returns:
      ``(y, Y)``: response samples ``(R, N)`` and their ``rfft`` spectra.
    """
    u = np.atleast_2d(u_periods)
    n = u.shape[-1]
    Y = periodic_response(inertia=inertia, law=law, input_spectra=np.fft.rfft(u, axis=-1),
                          fundamental_rad_s=2 * math.pi * fs_Hz / n, n_samples=n, delay_s=delay_s,
                          initial=initial)
    return np.fft.irfft(Y, n=n, axis=-1), Y


def harmonic_balance_start(u_periods: np.ndarray, y_periods: np.ndarray, fs_Hz: float, terms: Sequence[Term], *,
                           n_harmonics: int) -> tuple[float, JointLaw, IdentificationResult]:
    """The harmonic balance (paper eq. 1-12) of periodic input/output records of one coordinate,
    ``m y'' + law(y, y') = u``: the drive train of one body whose law to ground is ``terms``
    (:mod:`identify.chain`, the identifier of every train), balanced on lines 0..``n_harmonics``
    of every record (each ``(R, N)`` array holds one period per row). Returns the inertia ``m``,
    the law and the solver's result: the start of :func:`refine_output_error`."""
    from .chain import ChainRecord, ChainSpec, chain_system, solve_banded

    u, y = np.atleast_2d(u_periods), np.atleast_2d(y_periods)
    n = u.shape[-1]
    w0 = 2 * math.pi * fs_Hz / n
    t = np.arange(n) / fs_Hz
    records = [ChainRecord(w0, t, (u[r],), (y[r],), source=f"record {r + 1}") for r in range(u.shape[0])]
    res = solve_banded(chain_system(records, ChainSpec((), grounds=(tuple(terms),)), n_harmonics=n_harmonics))
    return float(res.values[0]), JointLaw(tuple(terms), tuple(res.values[1:])), res


def steady_rms(inertia: float, law: JointLaw, u_periods: np.ndarray, y_periods: np.ndarray, fs_Hz: float, *,
               delay_s: float = 0.0) -> float:
    """RMS of the steady-state simulation error (data units) on periodic records; NaN when the
    frequency-domain solver finds no steady state for the model."""
    from .steady import SteadyStateError

    try:
        ys, _ = simulate_periods(inertia, law, u_periods, fs_Hz, delay_s=delay_s)
    except SteadyStateError:
        return math.nan
    return float(np.sqrt(np.mean((ys - y_periods) ** 2)))


def input_noise_rms(u_periods: np.ndarray, excited_max_bin: int) -> float:
    """RMS noise of a periodic input (data units) from its non-excited even lines below
    ``excited_max_bin``: an odd multisine puts nothing there, so what is there is noise, spread
    evenly over the lines (white)."""
    u = np.atleast_2d(u_periods)
    n = u.shape[-1]
    U = np.fft.rfft(u, axis=-1) / n
    k = np.arange(U.shape[-1])
    even = (k > 0) & (k <= excited_max_bin) & (k % 2 == 0)
    return float(np.sqrt(np.mean(np.abs(U[:, even]) ** 2) * n / 2))


def refine_output_error(
    u_periods: np.ndarray,
    y_periods: np.ndarray,
    fs_Hz: float,
    *,
    inertia: float,
    law: JointLaw,
    estimate_delay: bool = False,
    delay_s: float = 0.0,
    delay_scale_s: Optional[float] = None,
) -> OutputErrorResult:
    """Refine ``inertia``, the law's values (and the input delay) by output error.

    Args:
      u_periods, y_periods: one steady period per record, ``(R, N)``.
      inertia, law, delay_s: starting point (e.g. from harmonic balance).
      estimate_delay: also estimate the input delay (starting at ``delay_s``).
      delay_scale_s: typical delay magnitude for the optimiser's scaling (default 0.1 / fs).
    """
    u = np.atleast_2d(np.asarray(u_periods, dtype=float))
    y = np.atleast_2d(np.asarray(y_periods, dtype=float))
    if u.shape != y.shape:
        raise ValueError(f"u_periods {u.shape} and y_periods {y.shape} differ")
    names = ("inertia",) + law.names + (("delay_s",) if estimate_delay else ())
    x0 = np.array([inertia, *law.values] + ([delay_s] if estimate_delay else []), dtype=float)
    scale = np.abs(x0)
    if estimate_delay:
        scale[-1] = delay_scale_s if delay_scale_s is not None else 0.1 / fs_Hz
    scale = np.where(scale > 0, scale, 1.0)
    state = {"Y": None}

    def unpack(q):
        x = q * scale
        return x[0], JointLaw(law.terms, tuple(x[1:1 + len(law.terms)])), (x[-1] if estimate_delay else delay_s)

    def residual(q):
        J, lw, tau = unpack(q)
        ysim, Y = simulate_periods(J, lw, u, fs_Hz, delay_s=tau, initial=state["Y"])
        state["Y"] = Y
        return (ysim - y).ravel()

    sol = least_squares(residual, x0 / scale, method="trf", x_scale=1.0, diff_step=1e-7)
    J, lw, tau = unpack(sol.x)
    r = sol.fun
    dof = max(r.size - sol.x.size, 1)
    s2 = float(r @ r) / dof
    try:
        cov = s2 * np.linalg.inv(sol.jac.T @ sol.jac)
        std = np.sqrt(np.clip(np.diag(cov), 0, None)) * scale
    except np.linalg.LinAlgError:
        std = np.full(sol.x.size, np.nan)
    return OutputErrorResult(names=names, values=sol.x * scale, std_errors=std, law=lw, inertia=float(J),
                             delay_s=float(tau), rms_error=float(np.sqrt(np.mean(r**2))), success=bool(sol.success),
                             message=str(sol.message), nfev=int(sol.nfev),
                             condition_number=equilibrated_condition(sol.jac))
