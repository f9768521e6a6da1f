"""Parameters by typed name: every quantity in jointrig carries its SI unit in its name.

``k_Nm_per_rad``, ``quadratic_damping_Nms2_per_rad2``, ``omega_rad_s``: :func:`unit_of` reads the
suffix back as a unit a person writes (``N m/rad``), :func:`quantity_of` gives the quantity
without it. :class:`Param` is such a name as a type (a ``str``, so it keys dictionaries and
compares with the plain names files and JSON hold) that knows its unit; the parameters outside
the joint law (inertias, bearing drag, drive delay) are named once here, and a law term names
its own (``Term.name``).
"""

from __future__ import annotations

import math
import re

__all__ = ["Param", "unit_of", "quantity_of", "J1", "J2", "JE", "BEARING1", "BEARING2", "DRIVE_DELAY", "ANGLE2_DELAY",
           "ANGLE2_GAIN", "channel_name", "train_name", "linear_name", "rotational_name", "Coordinate", "HINGE",
           "SLIDE"]

# Unit atoms as they appear in names, longest first, and how a person writes them.
_ATOMS = (("kgm2", "kg m^2"), ("kg", "kg"), ("Nms2", "N m s^2"), ("Nms", "N m s"), ("Nm", "N m"), ("Ns", "N s"),
          ("N", "N"), ("rad", "rad"), ("Hz", "Hz"), ("V", "V"), ("s", "s"), ("J", "J"), ("W", "W"), ("m", "m"))
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
#: Flywheel 2's angle channel read late, or a fixed factor too large (the two-flywheel names of
#: a sensor's skew and scale error, :func:`channel_name` for body i of a train).
ANGLE2_DELAY, ANGLE2_GAIN = Param("angle2_delay_s"), Param("angle2_gain_error")


def train_name(name: str) -> Param:
    """A two-flywheel parameter's name in the train of two bodies (the one model of every bench):
    a law's at joint 1 (``coulomb_torque_Nm`` -> ``joint1_coulomb_torque_Nm``); inertias, bearings,
    the drive's lag and flywheel 2's channel keep theirs."""
    if name.startswith(("J1_", "J2_", "bearing", "drive_", "angle2_")):
        return Param(name)
    return Param("joint1_" + name)


def channel_name(i: int, name: str) -> Param:
    """A sensor parameter of body i's angle channel from its flywheel-2 name:
    ``channel_name(3, "angle2_delay_s")`` -> ``angle3_delay_s``."""
    if not name.startswith("angle2_"):
        raise ValueError(f"{name!r} is not a channel's parameter (angle2_...)")
    return Param(f"angle{int(i)}_" + name[len("angle2_"):])


# A body on a slide has the laws of a body on a hinge in other units: N and m where a hinge has
# N m and rad, a mass in kg for an inertia in kg m^2. The project computes in the hinge's names;
# a slide's are these, at the edges (its files, its MJCF fields, what a user reads). Applied in
# order; each pattern acts on a name's end (its unit) or its start (an inertia, a guide).
_TO_LINEAR = ((r"_Nms2_per_rad2$", "_Ns2_per_m2"), (r"_Nms_per_rad$", "_Ns_per_m"),
              (r"_Nm_per_rad(\d?)$", r"_N_per_m\1"), (r"_rad_s$", "_m_s"), (r"^J(\d+)_kgm2$", r"m\1_kg"),
              (r"torque_Nm$", "force_N"), (r"angle_offset_rad$", "position_offset_m"),
              (r"angle_rad$", "displacement_m"), (r"^angle(\d+)_", r"position\1_"), (r"_Nm$", "_N"), (r"_rad$", "_m"),
              (r"^bearing(\d+)_", r"guide\1_"))
_TO_ROTATIONAL = ((r"_Ns2_per_m2$", "_Nms2_per_rad2"), (r"_Ns_per_m$", "_Nms_per_rad"),
                  (r"_N_per_m(\d?)$", r"_Nm_per_rad\1"), (r"_m_s$", "_rad_s"), (r"^m(\d+)_kg$", r"J\1_kgm2"),
                  (r"force_N$", "torque_Nm"), (r"position_offset_m$", "angle_offset_rad"),
                  (r"displacement_m$", "angle_rad"), (r"^position(\d+)_", r"angle\1_"), (r"_N$", "_Nm"), (r"_m$", "_rad"),
                  (r"^guide(\d+)_", r"bearing\1_"))


def _translate(name: str, rules) -> str:
    for pattern, repl in rules:
        name = re.sub(pattern, repl, name)
    return name


def linear_name(name: str) -> str:
    """A parameter's name for a body on a slide: ``ground1_coulomb_torque_Nm`` ->
    ``ground1_coulomb_force_N``, ``J1_kgm2`` -> ``m1_kg``, ``joint1_k_Nm_per_rad`` ->
    ``joint1_k_N_per_m`` (the inverse of :func:`rotational_name`)."""
    return _translate(name, _TO_LINEAR)


def rotational_name(name: str) -> str:
    """The project's (a hinge's) name of a slide's parameter (:func:`linear_name`'s inverse)."""
    return _translate(name, _TO_ROTATIONAL)


class Coordinate(str):
    """How the bodies of a bench move, and the words and units that go with it: ``"hinge"`` (each
    body turns) or ``"slide"`` (each moves along a line). A ``str`` (it compares with, and is
    written as, the word files, JSON and MuJoCo use) that knows the rest, so no caller branches on
    the word. The project computes in the hinge's names; :meth:`name` gives a parameter's name as
    this bench's user reads it (a slide's in N and m), :meth:`project_name` takes it back.

    Attributes (hinge, slide): ``position`` a position column's stem (phi, x); ``unit`` its unit
    (rad, m); ``drive`` a drive column's stem (torque, force); ``drive_unit`` (N m, N);
    ``drive_symbol`` an amplitude's (M0, F0); ``inertia`` (inertia, mass); ``drag`` a drag's model
    fields (bearing, guide); ``sensor`` (angle, position); ``line`` the bodies together (train,
    line); ``free_line``: such bodies with no tie to the frame; ``relative_motion`` what their
    positions hold between them (twists, positions); ``units_note`` what a statement of units adds
    (nothing for the project's own); ``bare_position_is_one_body``: the unnumbered position column
    is one body's (a slide's ``x``), not a two-flywheel joint's relative angle (a hinge's ``phi``).

    >>> Coordinate("slide").unit, Coordinate("slide").name("J1_kgm2")
    ('m', 'm1_kg')
    """

    def __new__(cls, kind: str) -> "Coordinate":
        if kind not in _COORDINATES:
            raise ValueError(f"a body moves on a 'hinge' or a 'slide', got {kind!r}")
        out = super().__new__(cls, kind)
        out.__dict__.update(_COORDINATES[kind])
        return out

    def name(self, project_name: str) -> str:
        """A parameter's name as this bench's user reads it."""
        return _translate(project_name, self._to_user)

    def project_name(self, name: str) -> str:
        """The project's (a hinge's) name of a parameter named as this bench's user reads it."""
        return _translate(name, self._to_project)

    def channel(self, project_channel: str) -> str:
        """A channel's name on this bench (``torque1`` -> ``force1``, ``phi2`` -> ``x2`` on a slide)."""
        return project_channel.replace("torque", self.drive).replace("phi", self.position)

    def bodies(self, n: int) -> str:
        """``n`` bodies in words ("a train of 4 bodies", "3 bodies on slides")."""
        return self._bodies.format(n=n)

    def in_degrees(self, value: float, digits: int = 3) -> str:
        """`` (x deg)`` after an angle in rad, nothing after a length."""
        return f" ({math.degrees(value):.{digits}g} deg)" if self.unit == "rad" else ""


_COORDINATES = {
    "hinge": dict(position="phi", unit="rad", drive="torque", drive_unit="N m", drive_symbol="M0", inertia="inertia",
                  drag="bearing", sensor="angle", line="train", free_line="train free to turn",
                  relative_motion="twists", units_note="", bare_position_is_one_body=False,
                  _bodies="a train of {n} bodies", _to_user=(), _to_project=()),
    "slide": dict(position="x", unit="m", drive="force", drive_unit="N", drive_symbol="F0", inertia="mass",
                  drag="guide", sensor="position", line="line", free_line="carriage free to move",
                  relative_motion="positions", units_note=" (bodies on slides: N, m, kg)",
                  bare_position_is_one_body=True, _bodies="{n} bodies on slides", _to_user=_TO_LINEAR,
                  _to_project=_TO_ROTATIONAL),
}

#: The two ways a bench's bodies move.
HINGE, SLIDE = Coordinate("hinge"), Coordinate("slide")
