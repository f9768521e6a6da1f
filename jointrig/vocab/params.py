"""Parameters by typed name: every quantity in jointrig carries its SI unit in its name.

``k_Nm_per_rad``, ``quadratic_damping_Nms2_per_rad2``, ``omega_rad_s``: :func:`unit_of` reads the
suffix back as a unit a person writes (``N m/rad``), :func:`quantity_of` gives the quantity
without it. :class:`Param` is such a name as a type (a ``str``, so it keys dictionaries and
compares with the plain names files and JSON hold) that knows its unit; the parameters outside
the joint law (inertias, bearing drag, drive delay) are named once here, and a law term names
its own (``Term.name``).
"""

from __future__ import annotations

import re

__all__ = ["Param", "unit_of", "quantity_of", "J1", "J2", "JE", "BEARING1", "BEARING2", "DRIVE_DELAY"]

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


class Param(str):
    """A parameter's name, typed: equal to (and hashed as) the plain string, with its unit.

    >>> Param("k_Nm_per_rad").unit
    'N m/rad'
    """

    __slots__ = ()

    @property
    def unit(self) -> str:
        return unit_of(self)

    @property
    def quantity(self) -> str:
        return quantity_of(self)


#: Flywheel inertias of the two-degree-of-freedom form, and the equivalent inertia J1 J2/(J1 + J2).
J1, J2, JE = Param("J1_kgm2"), Param("J2_kgm2"), Param("Je_kgm2")
#: Viscous drag of each flywheel to ground (bearing friction).
BEARING1, BEARING2 = Param("bearing1_damping_Nms_per_rad"), Param("bearing2_damping_Nms_per_rad")
#: The drive acts this long after it is recorded.
DRIVE_DELAY = Param("drive_delay_s")
