"""Numbers for people: units read from SI quantity names, values rounded to their standard errors.

Every quantity in jointrig carries its SI unit in its name; :func:`unit_of` and
:func:`quantity_of` (from :mod:`jointrig.vocab.params`, where the names are typed) read it
back as a unit a person writes (``N m/rad``); :func:`with_se` prints a value to the precision its
standard error supports (the error to two significant digits, the value to the same decimal).
Pure functions, used by the text and HTML reports.
"""

from __future__ import annotations

import math

from jointrig.vocab.params import quantity_of, unit_of

__all__ = ["unit_of", "quantity_of", "with_se", "with_se_or", "sig", "sig_or"]


def sig(value: float, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits (no trailing noise, "nan" if not finite)."""
    if not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return f"{value:.{digits}g}"


def sig_or(value: float, words: str, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits, or ``words`` (why there is no number) if it
    is not finite: no "inf" or "nan" reaches a table."""
    return f"{value:.{digits}g}" if math.isfinite(value) else words


def with_se_or(value: float, se: float, words: str) -> str:
    """:func:`with_se`, or ``words`` (why there is no number) if the value is not finite."""
    return with_se(value, se) if math.isfinite(value) else words


def interval_text(half_width: float, dof: float) -> str:
    """A 95% interval's half width to two significant digits, with the degrees of freedom of the
    standard error it is made from where they are finite ("± 7.4 (11 dof)"); "-" without one."""
    if not (math.isfinite(half_width) and half_width > 0):
        return "-"
    x = float(f"{half_width:.2g}")
    text = f"{x:.{max(0, 1 - math.floor(math.log10(x)))}f}" if 1e-3 <= x < 1e5 else f"{x:.2g}"
    return f"± {text}" + (f" ({dof:.0f} dof)" if math.isfinite(dof) else "")


def with_se(value: float, se: float) -> str:
    """``value ± se`` with the standard error to two significant digits and the value to the same
    decimal place (the digits beyond carry no information). A common power of ten is factored
    out when the value is below 1e-3 or at least 1e5. Without a finite positive standard error, or
    with one at round-off level (below 1e-9 of the value: a model's exact figure), the value is
    printed to 6 significant digits."""
    if not math.isfinite(value):
        return sig(value)
    if not (math.isfinite(se) and se > 1e-9 * abs(value)):
        return f"{value:.6g}"
    scale = abs(value) if value != 0 else se
    power = math.floor(math.log10(scale)) if (scale < 1e-3 or scale >= 1e5) else 0
    v, s = value / 10.0 ** power, se / 10.0 ** power
    # Round the error first (0.0995 -> 0.10 moves the decimal place), then the value to the
    # error's second significant digit.
    s_r = float(f"{s:.2g}")
    place = math.floor(math.log10(s_r)) - 1
    if place < 0:
        text = f"{v:.{-place}f} ± {s_r:.{-place}f}"
    else:
        q = 10 ** place
        text = f"{int(round(v / q)) * q:d} ± {int(round(s_r / q)) * q:d}"
    return f"({text})e{power}" if power else text
