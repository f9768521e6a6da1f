"""Periodic steady state of a one-degree-of-freedom oscillator under a periodic input, in the
frequency domain (harmonic balance solved for the response instead of the parameters).

    J x'' + M_v(x, x') = u(t - delay)

The linear part of the law (:class:`Viscous` c, ``Power(1)`` k) forms
``L(w) = k - J w^2 + i c w``; the rest ``g(x, x')`` is evaluated in the time domain on a grid
``oversample`` times finer than the samples (limits aliasing of the harmonics that g creates)
and balanced line by line:

    X = (U e^{-i w delay} - G(X) + dK X) / (L + dK),      dK = k_eq - k (+ i w (c_eq - c))

a fixed-point iteration around the equivalent linearisation (``k_eq``, ``c_eq`` = mean slopes
of g over the current response), relaxed (step halved whenever the change grows), which
converges for the mildly nonlinear systems it is meant for; it stops with
:class:`SteadyStateError` when it does not.

Spectra use numpy's unnormalised ``rfft`` convention, shape ``(n_records, n_samples // 2 + 1)``.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from jointrig.vocab.law import JointLaw, Power, Viscous

__all__ = ["periodic_response", "SteadyStateError", "split_law"]


#: relative change below which the iteration keeps its equivalent linearisation (see _iterate)
SLOPES_FROZEN_BELOW = 1e-4


class SteadyStateError(RuntimeError):
    """The steady-state iteration did not converge (response too nonlinear or unstable model)."""


def split_law(law: JointLaw) -> tuple[float, float, JointLaw | None]:
    """``(c, k, rest)``: viscous and linear stiffness coefficients and the remaining terms."""
    c = k = 0.0
    rest_terms, rest_values = [], []
    for term, value in zip(law.terms, law.values):
        if isinstance(term, Viscous):
            c += value
        elif isinstance(term, Power) and term.power == 1:
            k += value
        else:
            rest_terms.append(term)
            rest_values.append(value)
    rest = JointLaw(tuple(rest_terms), tuple(rest_values)) if rest_terms else None
    return c, k, rest


def _upsampled(X: np.ndarray, n: int, oversample: int) -> np.ndarray:
    pad = np.zeros(X.shape[:-1] + (oversample * n // 2 + 1,), dtype=complex)
    pad[..., : X.shape[-1]] = X
    if n % 2 == 0:
        pad[..., n // 2] *= 0.5  # split the Nyquist bin between +- so the fine grid stays real-consistent
    return np.fft.irfft(pad, n=oversample * n, axis=-1) * oversample


def periodic_response(
    *,
    inertia: float,
    law: JointLaw,
    input_spectra: np.ndarray,
    fundamental_rad_s: float,
    n_samples: int,
    delay_s: float = 0.0,
    oversample: int = 2,
    tol: float = 1e-12,
    max_iter: int = 400,
    initial: Optional[np.ndarray] = None,
) -> np.ndarray:
    """Steady-state response spectra for periodic inputs.

    Args:
      inertia: J (units of the input per unit acceleration).
      law: the restoring/damping law M_v(x, x').
      input_spectra: ``rfft`` of one period of each input record, ``(R, n_samples//2 + 1)``.
      fundamental_rad_s: 2 pi / period.
      delay_s: the input acts ``delay_s`` late.
      initial: starting response spectra (warm start), same shape as ``input_spectra``.

    Returns:
      ``rfft`` of one period of the response, same shape as ``input_spectra``.

    Raises:
      SteadyStateError: no convergence to ``tol`` (relative change of the spectrum) in
        ``max_iter`` iterations, or a non-finite response.
    """
    U = np.atleast_2d(np.asarray(input_spectra, dtype=complex))
    n_bins = U.shape[-1]
    if n_bins != n_samples // 2 + 1:
        raise ValueError(f"input_spectra has {n_bins} bins, expected n_samples // 2 + 1 = {n_samples // 2 + 1}")
    w = fundamental_rad_s * np.arange(n_bins)
    c, k, rest = split_law(law)
    L = k - inertia * w**2 + 1j * c * w
    Ue = U * np.exp(-1j * w * delay_s)
    if rest is None:
        if np.any(L == 0):
            raise SteadyStateError("linear law with a zero of k - J w^2 + i c w on a line (no damping?)")
        return Ue / L
    X = np.array(initial, dtype=complex) if initial is not None else np.where(L != 0, Ue / np.where(L != 0, L, 1), 0)
    jw = 1j * w
    scale = np.max(np.abs(Ue / np.where(L != 0, L, np.inf))) or 1.0
    eps = 1e-6
    with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported as SteadyStateError
        return _iterate(X, Ue, L, jw, rest, n_samples, n_bins, oversample, scale, eps, tol, max_iter)


def _iterate(X, Ue, L, jw, rest, n_samples, n_bins, oversample, scale, eps, tol, max_iter):
    change = float("inf")
    # Relaxation: a full step while the change shrinks; halved (down to 1/64) whenever it grows,
    # which tames the iteration for strongly nonlinear responses without moving its fixed point.
    beta = 1.0
    for it in range(max_iter):
        x = _upsampled(X, n_samples, oversample)
        v = _upsampled(jw * X, n_samples, oversample)
        g = rest.torque(x, v)
        if change > SLOPES_FROZEN_BELOW:
            # the equivalent linearisation only steers the iteration (its fixed point does not
            # depend on it): once the response has nearly settled it is kept, which saves two of
            # the three law evaluations of every later step
            span = max(float(np.std(x)), 1e-300)
            vspan = max(float(np.std(v)), 1e-300)
            dk = float(np.mean((rest.torque(x + eps * span, v) - g))) / (eps * span)
            dc = float(np.mean((rest.torque(x, v + eps * vspan) - g))) / (eps * vspan)
            dK = dk + jw * dc
            denom = L + dK
            denom = np.where(denom != 0, denom, np.inf)
        G = np.fft.rfft(np.broadcast_to(g, x.shape), axis=-1)[..., :n_bins] / oversample
        X_new = (Ue - G + dK * X) / denom
        if not np.all(np.isfinite(X_new)):
            raise SteadyStateError(f"non-finite response at iteration {it}: the model diverges under this input")
        new_change = float(np.max(np.abs(X_new - X))) / scale
        if new_change > change and beta > 1 / 64:
            beta *= 0.5
        change = new_change
        X = X_new if beta == 1.0 else X + beta * (X_new - X)
        if change < tol:
            return X
    raise SteadyStateError(f"no steady state after {max_iter} iterations (last relative change {change:.2e} "
                           f"> tol {tol:g}): response too nonlinear for the fixed-point solver")
