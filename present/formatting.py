"""Numbers for people: units read from SI quantity names, values rounded to their standard errors.

Every quantity in jointrig carries its SI unit in its name (``k_Nm_per_rad``,
``quadratic_damping_Nms2_per_rad2``, ``omega_rad_s``). :func:`unit_of` reads that suffix back
as a unit a person writes (``N m/rad``); :func:`with_se` prints a value to the precision its
standard error supports (the error to two significant digits, the value to the same decimal).
Pure functions, used by the text and HTML reports.
"""

from __future__ import annotations

import math
import re

__all__ = ["unit_of", "quantity_of", "with_se", "sig"]

# Unit atoms as they appear in names, longest first, and how a person writes them.
_ATOMS = (("kgm2", "kg m^2"), ("Nms2", "N m s^2"), ("Nms", "N m s"), ("Nm", "N m"), ("rad", "rad"),
          ("Hz", "Hz"), ("V", "V"), ("s", "s"), ("J", "J"), ("W", "W"))
_ATOM = "(?:" + "|".join(a for a, _ in _ATOMS) + r")\d?"
# ``<quantity>_<units>`` where units are ``A``, ``A_B`` (a product, as ``rad_s`` = rad/s for a
# rate: see below) or ``A_per_B``.
_SUFFIX = re.compile(rf"^(?P<q>.+?)_(?P<num>{_ATOM})(?:_(?P<per>per)_(?P<den>{_ATOM})|_(?P<den2>{_ATOM}))?$")
_SUP = {"2": "²", "3": "³", "4": "⁴", "5": "⁵"}


def _atom(a: str) -> str:
    power = a[-1] if a[-1].isdigit() and not a.endswith("kgm2") else ""
    base = a[:-1] if power else a
    text = dict(_ATOMS)[base]
    text = text.replace("^2", _SUP["2"])
    return text + (_SUP.get(power, f"^{power}") if power else "")


def _split(name: str):
    m = _SUFFIX.match(name)
    if not m:
        return name, ""
    num = _atom(m["num"])
    den = m["den"] or m["den2"]
    # ``omega_rad_s``, ``rate1_rad_s``: the project writes rates as ``<unit>_s`` (per second).
    return m["q"], (f"{num}/{_atom(den)}" if den else num)


def unit_of(name: str) -> str:
    """The unit a quantity name carries, as written by a person ("" if the name has none):
    ``k_Nm_per_rad`` -> ``N m/rad``, ``omega_rad_s`` -> ``rad/s``, ``J1_kgm2`` -> ``kg m²``."""
    return _split(name)[1]


def quantity_of(name: str) -> str:
    """The quantity without its unit suffix: ``coulomb_torque_Nm`` -> ``coulomb_torque``."""
    return _split(name)[0]


def sig(value: float, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits (no trailing noise, "nan" if not finite)."""
    if not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return f"{value:.{digits}g}"


def with_se(value: float, se: float) -> str:
    """``value ± se`` with the standard error to two significant digits and the value to the same
    decimal place (the digits beyond carry no information). A common power of ten is factored
    out when the value is below 1e-3 or at least 1e5. Without a finite positive standard error
    the value is printed to 6 significant digits."""
    if not math.isfinite(value):
        return sig(value)
    if not (math.isfinite(se) and se > 0):
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
