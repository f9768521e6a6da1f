"""Bounded minimisation of a function of one variable: Brent's method (golden section with
parabolic steps), as ``scipy.optimize.minimize_scalar(method="bounded")``.

A port of scipy's ``_minimize_scalar_bounded`` (scipy 1.17, BSD-3-Clause, after Forsythe,
Malcolm and Moler's ``fmin``), step for step and in the same floating-point operations, so it
visits the same points and returns the same minimum bit for bit (``tests/test_scalar.py``
holds it against scipy). Why not scipy's own: ``scipy.optimize`` imports linear programming,
global optimisers and sparse algebra with it, 0.15 s of every diagnosis's start on the 2-core
machine (``.venv/bin/python -X importtime -m jointrig diagnose ...``), for the one search every
profile of the diagnosis and the drive-frequency estimate use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

__all__ = ["BoundedMinimum", "minimize_bounded"]

_SQRT_EPS = math.sqrt(2.2e-16)
_GOLDEN = 0.5 * (3.0 - math.sqrt(5.0))


@dataclass(frozen=True)
class BoundedMinimum:
    """The search's best point ``x``, its value ``fun``, the evaluations ``nfev``, and
    ``success`` (False: the evaluation budget ran out, or the function gave NaN)."""

    x: float
    fun: float
    nfev: int
    success: bool


def _sign(v: float) -> float:
    return float((v > 0) - (v < 0))


def minimize_bounded(fun: Callable[[float], float], bounds: tuple[float, float], *, xatol: float = 1e-5,
                     maxiter: int = 500) -> BoundedMinimum:
    """Minimum of ``fun`` on ``bounds = (lo, hi)`` (finite, lo <= hi) to ``xatol`` in x, in at
    most ``maxiter`` evaluations."""
    lo, hi = (float(b) for b in bounds)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"bounds must be finite, got {bounds!r}")
    if lo > hi:
        raise ValueError(f"the lower bound exceeds the upper bound: {bounds!r}")
    a, b = lo, hi
    fulc = a + _GOLDEN * (b - a)
    nfc = xf = fulc
    rat = e = 0.0
    fx = fun(xf)
    num = 1
    fu = math.inf
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = _SQRT_EPS * abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    failed = False
    while abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = True
        if abs(e) > tol1:  # try a parabola through the three best points
            golden = False
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r = e
            e = rat
            if abs(p) < abs(0.5 * q * r) and p > q * (a - xf) and p < q * (b - xf):
                rat = (p + 0.0) / q
                x = xf + rat
                if (x - a) < tol2 or (b - x) < tol2:
                    rat = tol1 * (_sign(xm - xf) + ((xm - xf) == 0))
            else:
                golden = True
        if golden:
            e = (a - xf) if xf >= xm else (b - xf)
            rat = _GOLDEN * e
        x = xf + (_sign(rat) + (rat == 0)) * max(abs(rat), tol1)
        fu = fun(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if fu <= fnfc or nfc == xf:
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif fu <= ffulc or fulc == xf or fulc == nfc:
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = _SQRT_EPS * abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            failed = True
            break
    if math.isnan(xf) or math.isnan(fx) or math.isnan(fu):
        failed = True
    return BoundedMinimum(xf, fx, num, not failed)
