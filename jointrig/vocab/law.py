"""The joint law, written once as a linear combination of basis terms (paper eq. 1-2, 8-9).

The torque the joint transmits (positive torque opposes a positive relative angle) is

    M_v(phi, phi') = sum_j theta_j * b_j(phi, phi')

with ``phi = phi1 - phi2`` in rad and ``phi'`` in rad/s. The same :class:`JointLaw` is
evaluated by the rig's MuJoCo passive callback (ground truth) and supplies the columns
of the harmonic-balance regression (identification), so the law lives in one place.

Terms:
  * :class:`Viscous`     ``b = phi'``                  -> ``c_Nms_per_rad``
  * :class:`ContactDamping` ``b = phi'`` beyond a free play ``|phi| > gap``, 0 within it
                                                       -> ``contact_c_Nms_per_rad``
  * :class:`Power`       ``b = phi**p``                -> ``constant_Nm`` (p=0), ``k_Nm_per_rad``
                                                          (1), ``a_Nm_per_rad2`` (2),
                                                          ``gamma_Nm_per_rad3`` (3), ...
  * :class:`Monomial`    ``b = phi**p * phi'**q``      -> ``c_p{p}_q{q}`` (N m / (rad^p (rad/s)^q)),
                                                          e.g. cubic damping (0, 3), amplitude-
                                                          dependent damping (2, 1)
  * :class:`AngleHat`    ``b = hat_i(phi)``  (eq. 8)   -> ``g{i}_Nm``: restoring torque at knot i
  * :class:`RateHat`     ``b = hat_i(phi')`` (eq. 9 f) -> ``f{i}_Nm``: damping torque at knot i
  * :class:`Cogging`     ``b = sin(z phi)``, ``cos(z phi)`` -> ``cogging_sin_Nm``, ``cogging_cos_Nm``: a torque
                                                          periodic in the angle (a gear's mesh, a
                                                          motor's cogging), ``A sin(z phi + p)``
  * :class:`Coulomb`, :class:`Stribeck` (velocity-weakening friction), :class:`QuadraticDamping`,
    :class:`Jenkins` (one slider) and :class:`Iwan` (Segalman's four-parameter distribution of
    sliders): the catalogued effects

Hat functions are the cardinal basis of piecewise-linear interpolation on sorted knots,
extended linearly beyond the end knots (so a hat law continues its end slopes rather
than dropping to zero outside the knot range).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import ClassVar, Optional, Sequence, Union

import numpy as np

__all__ = [
    "Term",
    "NativeTerm",
    "FieldError",
    "TERM_CLASSES",
    "duplicate_names",
    "law_terms_from_fields",
    "Viscous",
    "ContactDamping",
    "Power",
    "Coulomb",
    "Constant",
    "QuadraticDamping",
    "Jenkins",
    "Iwan",
    "Stribeck",
    "TanhFriction",
    "Cogging",
    "law_parameters",
    "dead_zone",
    "play",
    "monotone_runs",
    "AngleHat",
    "Monomial",
    "RateHat",
    "JointLaw",
    "hat_matrix",
    "polynomial_law",
    "hat_law",
    "angle_hats",
    "rate_hats",
]

ArrayLike = Union[float, np.ndarray]

_POWER_NAMES = {0: "constant_Nm", 1: "k_Nm_per_rad", 2: "a_Nm_per_rad2", 3: "gamma_Nm_per_rad3"}


def _check_knots(knots: Sequence[float], what: str) -> tuple[float, ...]:
    k = tuple(float(v) for v in knots)
    if len(k) < 2:
        raise ValueError(f"{what}: need at least 2 knots, got {len(k)}")
    if not all(math.isfinite(v) for v in k):
        raise ValueError(f"{what}: knots must be finite, got {k}")
    if any(b <= a for a, b in zip(k, k[1:])):
        raise ValueError(f"{what}: knots must be strictly increasing, got {k}")
    return k


def _segment(x: np.ndarray, knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segment index j (end segments extended) and local coordinate s in x_j..x_{j+1}."""
    j = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, len(knots) - 2)
    s = (x - knots[j]) / (knots[j + 1] - knots[j])
    return j, s


def hat_matrix(x: np.ndarray, knots: Sequence[float]) -> np.ndarray:
    """All hat functions at once: shape ``(len(x), len(knots))``; rows sum to 1."""
    kn = np.asarray(_check_knots(knots, "hat_matrix"))
    x = np.atleast_1d(np.asarray(x, dtype=float))
    j, s = _segment(x, kn)
    out = np.zeros((x.size, kn.size))
    rows = np.arange(x.size)
    out[rows, j] = 1.0 - s
    out[rows, j + 1] += s
    return out


def _hat_scalar(x: float, knots: tuple[float, ...], i: int) -> float:
    # Pure-Python path for the per-step MuJoCo callback (numpy costs ~us per call).
    n = len(knots)
    j = 0
    while j < n - 2 and x >= knots[j + 1]:
        j += 1
    s = (x - knots[j]) / (knots[j + 1] - knots[j])
    if i == j:
        return 1.0 - s
    if i == j + 1:
        return s
    return 0.0


def _hat(x: ArrayLike, knots: tuple[float, ...], i: int) -> ArrayLike:
    if isinstance(x, float):
        return _hat_scalar(x, knots, i)
    kn = np.asarray(knots)
    xa = np.asarray(x, dtype=float)
    j, s = _segment(xa, kn)
    return np.where(j == i, 1.0 - s, 0.0) + np.where(j + 1 == i, s, 0.0)


class FieldError(ValueError):
    """A model file's ``jointrig_*`` fields do not make a law term (names the field)."""


@dataclass(frozen=True)
class NativeTerm:
    """How the C callback (rig/native/jointrig_law.c) evaluates a term: its ``kind`` (the C
    ``case``), three integers and a float it reads, knots (stored in a shared array; their
    offset becomes ``ints[1]``) and sliders (``(slip angle rad, stiffness)`` each; the first
    one's index becomes ``ints[0]``, their count ``ints[2]``)."""

    kind: int
    ints: tuple[int, int, int] = (0, 0, 0)
    dpar: float = 0.0
    knots: tuple[float, ...] = ()
    sliders: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class Term:
    """One basis function ``b(phi, phi')`` of the joint torque, in N m per unit parameter.

    A term describes itself once: its mathematics (``__call__``, and for a term with memory
    ``step_torque``/``commit``), its C case (:meth:`native`), its model-file fields
    (``MJCF_FIELDS``, :meth:`read_fields`, :meth:`fields`), the sign its parameter must keep
    (``dissipative``) and the parameters derived from it (:meth:`derived_parameters`). The
    rig, the model reader and writer and the diagnosis ask these; adding a term is its class
    here (listed in :data:`TERM_CLASSES`) and its ``case`` in the C callback.
    """

    #: ``jointrig_*`` fields (without the prefix) this class reads from a model file
    MJCF_FIELDS: ClassVar[tuple[str, ...]] = ()
    #: a positive parameter dissipates energy: a negative one feeds energy in (refused in a
    #: model file, never adopted by the diagnosis)
    dissipative: ClassVar[bool] = False

    def native(self) -> Optional[NativeTerm]:
        """The C callback's description of this term, or None (no C case: Python callback only)."""
        return None

    @classmethod
    def read_fields(cls, fields: dict) -> list[tuple["Term", float]]:
        """The terms (and values) this class reads from a model's fields (name without the
        prefix -> array); [] when none of its fields is there. Raises :class:`FieldError`."""
        return []

    def fields(self, value: float) -> dict[str, list[float]]:
        """The model-file fields that declare this term with parameter ``value``."""
        raise FieldError(f"the law term {self.name!r} has no jointrig_* field to write")

    def derived_parameters(self, value: float) -> dict[str, float]:
        """Named parameters that follow from the term and its value (a slip angle, a stiffness)."""
        return {}

    def combined_parameters(self, values: dict[str, float]) -> dict[str, float]:
        """Named parameters that follow from several of the law's values (by term name): a
        periodic torque's amplitude from its sine and cosine parts. Default: none."""
        return {}

    def dry_friction(self, value: float) -> Optional[tuple[float, list[tuple["Term", float]]]]:
        """For a term with a jump at zero rate: ``(static friction N m, continuous remainder)``,
        the torque that holds the joint at rest and the terms (with values) that make up the
        rest of the term's torque, continuous at zero rate. The rig holds the first as a
        constraint (:func:`rig.simulate.dry_friction_split`) and evaluates the second in its
        callback. None for a term continuous in the rate."""
        return None

    #: True for a term with memory (:class:`Jenkins`, :class:`Iwan`): no scalar ``__call__``;
    #: the rig keeps ``n_states`` floats for it and calls :meth:`step_torque` and :meth:`commit`.
    stateful = False
    n_states = 0

    @property
    def name(self) -> str:  # parameter name with unit
        raise NotImplementedError

    @property
    def elastic(self) -> bool:
        """True if the term depends on the angle only (part of the restoring force g(phi))."""
        raise NotImplementedError

    def __call__(self, phi: ArrayLike, rate: ArrayLike) -> ArrayLike:
        raise NotImplementedError


def _scalar(fields: dict, name: str, *, nonnegative: bool = False, dissipates: bool = False,
            default: Optional[float] = None) -> Optional[float]:
    """One finite number from field ``name`` (None, or ``default``, if absent); ``>= 0`` when
    ``nonnegative`` or ``dissipates`` (then the message says why)."""
    if name not in fields:
        return default
    data = np.asarray(fields[name], dtype=float).ravel()
    if data.size != 1 or not math.isfinite(data[0]):
        raise FieldError(f"jointrig_{name} must hold one finite number, got {data}")
    if dissipates and not data[0] >= 0:
        raise FieldError(f"jointrig_{name} must be >= 0 (a negative one feeds energy in), got {data[0]:g}")
    if nonnegative and not data[0] >= 0:
        raise FieldError(f"jointrig_{name} must hold one finite number >= 0, got {data[0]:g}")
    return float(data[0])


def _pair(fields: dict, first: str, second: str) -> bool:
    """True if both fields are there; refuses one without the other."""
    if (first in fields) != (second in fields):
        raise FieldError(f"jointrig_{first} and jointrig_{second} go together")
    return first in fields


class _OneField:
    """A parameterless term declared by the one model-file field that holds its value
    (``MJCF_FIELDS[0]``, refused negative when the term dissipates); C kind ``NATIVE_KIND``."""

    NATIVE_KIND: ClassVar[int]

    def native(self):
        return NativeTerm(self.NATIVE_KIND)

    @classmethod
    def read_fields(cls, fields):
        v = _scalar(fields, cls.MJCF_FIELDS[0], dissipates=cls.dissipative)
        return [] if v is None else [(cls(), v)]

    def fields(self, value):
        return {self.MJCF_FIELDS[0]: [value]}


@dataclass(frozen=True)
class Viscous(_OneField, Term):
    """Viscous damping ``c * phi'``."""

    MJCF_FIELDS = ("c_Nms_per_rad",)
    NATIVE_KIND = 0
    dissipative = True

    @property
    def name(self) -> str:
        return "c_Nms_per_rad"

    @property
    def elastic(self) -> bool:
        return False

    def __call__(self, phi, rate):
        return rate if isinstance(rate, float) else np.asarray(rate, dtype=float)


class _DampingNamedByItsField:
    """A damping or a friction (a term of the motion, not of the angle alone) whose parameter is
    named by its first model-file field."""

    @property
    def name(self) -> str:
        return self.MJCF_FIELDS[0]

    @property
    def elastic(self) -> bool:
        return False


@dataclass(frozen=True)
class ContactDamping(_DampingNamedByItsField, Term):
    """Damping that acts only in contact: ``phi'`` where the free play is taken up
    (``|phi| > gap_rad``), 0 within it -> ``contact_c_Nms_per_rad``.

    A coupling with play whose elastic element also damps (a rubber insert) damps only while it
    is engaged; a lubricated play damps within the gap too (:class:`Viscous`). A law may hold
    both, each with its own coefficient. In a model file it shares the free play's field
    ``backlash_half_gap_rad`` with the elastic terms; its C case reads the gap as its float.
    """

    gap_rad: float

    MJCF_FIELDS = ("contact_c_Nms_per_rad",)
    NATIVE_KIND = 12
    dissipative = True

    def __post_init__(self):
        gap = float(self.gap_rad)
        if not (math.isfinite(gap) and gap > 0):
            raise ValueError(f"ContactDamping.gap_rad must be a finite number > 0, got {self.gap_rad!r}")
        object.__setattr__(self, "gap_rad", gap)

    def native(self):
        return NativeTerm(self.NATIVE_KIND, dpar=self.gap_rad)

    @classmethod
    def read_fields(cls, fields):
        v = _scalar(fields, cls.MJCF_FIELDS[0], dissipates=True)
        if v is None:
            return []
        gap = _scalar(fields, "backlash_half_gap_rad", nonnegative=True, default=0.0)
        if not gap > 0:
            raise FieldError(f"jointrig_{cls.MJCF_FIELDS[0]} needs jointrig_backlash_half_gap_rad > 0: "
                             "damping in contact is damping beyond a free play")
        return [(cls(gap), v)]

    def fields(self, value):
        return {self.MJCF_FIELDS[0]: [value], "backlash_half_gap_rad": [self.gap_rad]}

    def __call__(self, phi, rate):
        if isinstance(phi, float):
            return rate if abs(phi) > self.gap_rad else 0.0
        return contact_share(np.asarray(phi, dtype=float), self.gap_rad) * np.asarray(rate, dtype=float)


def _share_above(a: np.ndarray, b: np.ndarray, level: float) -> np.ndarray:
    """The share of the straight segment from ``a`` to ``b`` that lies above ``level``."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    span = hi - lo
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(span > 0, np.clip((hi - level) / span, 0.0, 1.0), (lo > level).astype(float))


def contact_share(phi: np.ndarray, gap_rad: float) -> np.ndarray:
    """Per sample of a periodic record (the last axis wraps round), the share of its interval
    (half-way to each neighbour, the angle straight between samples) where ``|phi| > gap_rad``.

    The bare indicator steps once per sample as the gap or the twist's zero moves, and a
    harmonic balance's profile search over them then stalls on the steps (on 4096 samples per
    period the paper joint's zero stuck at its grid point, its gap read 8 standard errors off);
    the share moves smoothly and has the indicator's integral to second order."""
    left = 0.5 * (phi + np.roll(phi, 1, axis=-1))
    right = 0.5 * (phi + np.roll(phi, -1, axis=-1))
    half = [_share_above(a, phi, gap_rad) + _share_above(-a, -phi, gap_rad) for a in (left, right)]
    return 0.5 * (half[0] + half[1])


def ipow(x: float, p: int) -> float:
    """``x**p`` for an integer ``p >= 0`` by repeated multiplication, left to right (scalar path).

    The native callback (rig/native/jointrig_law.c) computes the same products in the same
    order, so both give the same bits without a ``pow`` call per force evaluation; the array
    path (:func:`ipow_array`) too. Within 2 ulp of the correctly rounded power.
    """
    if p == 1:
        return x
    if p == 3:
        return x * x * x
    out = 1.0 if p == 0 else x
    for _ in range(p - 1):
        out = out * x
    return out


def ipow_array(x: np.ndarray, p: int) -> np.ndarray:
    """:func:`ipow` on an array: the same products in the same order, so the array path gives the
    scalar path's bits. numpy's ``x ** 3`` calls ``pow`` per element (measured 9.4 ms for 164k
    samples against 0.065 ms for ``x * x * x``, README "Speed and scale"), which dominated the
    steady-state solver."""
    if p == 0:
        return np.ones_like(x)
    return ipow(x, p)


def dead_zone(phi: ArrayLike, gap_rad: float) -> ArrayLike:
    """Backlash: the angle the elastic element feels when it has a free play of
    ``+-gap_rad`` (rad) about zero: ``phi - gap`` above, ``phi + gap`` below, 0 inside."""
    if isinstance(phi, float):
        if phi > gap_rad:
            return phi - gap_rad
        if phi < -gap_rad:
            return phi + gap_rad
        return 0.0
    x = np.asarray(phi, dtype=float)
    return x - np.clip(x, -gap_rad, gap_rad)


@dataclass(frozen=True)
class Power(Term):
    """Polynomial stiffness term ``phi**power`` (power 0 is a constant preload torque).

    With ``gap_rad > 0`` (backlash, power >= 1) the element engages only beyond the free
    play: ``dead_zone(phi, gap_rad)**power``. The parameter keeps its name: a law with
    backlash has the same ``k`` and ``gamma``, acting on the engaged angle.
    """

    power: int
    gap_rad: float = 0.0

    def __post_init__(self):
        if not isinstance(self.power, int) or self.power < 0:
            raise ValueError(f"Power.power must be an int >= 0, got {self.power!r}")
        gap = float(self.gap_rad)
        if not (math.isfinite(gap) and gap >= 0):
            raise ValueError(f"Power.gap_rad must be a finite number >= 0, got {self.gap_rad!r}")
        if gap > 0 and self.power == 0:
            raise ValueError("Power.gap_rad needs power >= 1 (a preload has no free play)")
        object.__setattr__(self, "gap_rad", gap)

    MJCF_FIELDS = tuple(_POWER_NAMES.values()) + ("backlash_half_gap_rad",)

    def native(self):
        return NativeTerm(1, (self.power, 0, 0), self.gap_rad)

    @classmethod
    def read_fields(cls, fields):
        gap = _scalar(fields, "backlash_half_gap_rad", nonnegative=True, default=0.0)
        out = []
        for p, name in _POWER_NAMES.items():
            v = _scalar(fields, name)
            if v is not None:
                out.append((cls(p, gap if p >= 1 else 0.0), v))
        return out

    def fields(self, value):
        if self.power not in _POWER_NAMES:
            return super().fields(value)
        out = {self.name: [value]}
        if self.gap_rad > 0:
            out["backlash_half_gap_rad"] = [self.gap_rad]
        return out

    @property
    def name(self) -> str:
        return _POWER_NAMES.get(self.power, f"p{self.power}_Nm_per_rad{self.power}")

    @property
    def elastic(self) -> bool:
        return True

    def __call__(self, phi, rate):
        if self.gap_rad > 0:
            phi = dead_zone(phi, self.gap_rad)
        if isinstance(phi, float):
            return ipow(phi, self.power)
        return ipow_array(np.asarray(phi, dtype=float), self.power)


@dataclass(frozen=True)
class Coulomb(_OneField, Term):
    """Dry (Coulomb) friction in the joint: ``sign(phi')`` -> ``coulomb_torque_Nm``."""

    MJCF_FIELDS = ("coulomb_torque_Nm",)
    NATIVE_KIND = 5
    dissipative = True

    @property
    def name(self) -> str:
        return "coulomb_torque_Nm"

    @property
    def elastic(self) -> bool:
        return False

    def __call__(self, phi, rate):
        if isinstance(rate, float):
            return (rate > 0.0) - (rate < 0.0) + 0.0
        return np.sign(np.asarray(rate, dtype=float))

    def dry_friction(self, value):
        return value, []


@dataclass(frozen=True)
class _RateFriction(_DampingNamedByItsField, Term):
    """A friction term of the rate alone, shaped by one transition rate ``velocity_rad_s``
    (> 0), declared in a model file by the pair ``MJCF_FIELDS = (torque field, rate field)``;
    the torque field names its parameter (dissipative: refused negative). Its C case
    ``NATIVE_KIND`` reads the transition rate as its float."""

    velocity_rad_s: float

    NATIVE_KIND: ClassVar[int]
    dissipative: ClassVar[bool] = True

    def __post_init__(self):
        v = float(self.velocity_rad_s)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{type(self).__name__}.velocity_rad_s must be a finite number > 0, "
                             f"got {self.velocity_rad_s!r}")
        object.__setattr__(self, "velocity_rad_s", v)

    def native(self):
        return NativeTerm(self.NATIVE_KIND, dpar=self.velocity_rad_s)

    @classmethod
    def read_fields(cls, fields):
        torque_field, rate_field = cls.MJCF_FIELDS
        if not _pair(fields, torque_field, rate_field):
            return []
        torque = _scalar(fields, torque_field, dissipates=True)
        velocity = _scalar(fields, rate_field, nonnegative=True)
        if not velocity > 0:
            raise FieldError(f"jointrig_{rate_field} must be > 0, got {velocity:g}")
        return [(cls(velocity), torque)]

    def fields(self, value):
        return {self.MJCF_FIELDS[0]: [value], self.MJCF_FIELDS[1]: [self.velocity_rad_s]}

    def derived_parameters(self, value):
        return {self.MJCF_FIELDS[1]: self.velocity_rad_s}


@dataclass(frozen=True)
class Stribeck(_RateFriction):
    """The Stribeck part of dry friction: ``sign(phi') exp(-(phi'/v_s)^2)`` ->
    ``stribeck_torque_Nm``, the static friction's excess over the sliding one (with
    :class:`Coulomb` of torque ``F_c``: ``F(phi') = sign(phi') (F_c + F_x exp(-(phi'/v_s)^2))``,
    velocity-weakening below the Stribeck rate ``velocity_rad_s``)."""

    MJCF_FIELDS = ("stribeck_torque_Nm", "stribeck_velocity_rad_s")
    NATIVE_KIND = 9

    def dry_friction(self, value):
        # F_x sign(v) exp(-(v/v_s)^2) = F_x sign(v) - F_x sign(v) (1 - exp(-(v/v_s)^2)): the jump
        # F_x at rest, and a remainder that is continuous at v = 0 (the two signs cancel there).
        return value, [(Coulomb(), -value), (self, value)]

    def __call__(self, phi, rate):
        if isinstance(rate, float):
            r = rate / self.velocity_rad_s
            return ((rate > 0.0) - (rate < 0.0)) * math.exp(-(r * r))
        x = np.asarray(rate, dtype=float)
        r = x / self.velocity_rad_s
        return np.sign(x) * np.exp(-(r * r))


@dataclass(frozen=True)
class TanhFriction(_RateFriction):
    """Regularised dry friction ``tanh(phi' / v_t)`` -> ``tanh_friction_torque_Nm``: sliding
    friction that builds up smoothly over the transition rate ``velocity_rad_s`` instead of
    jumping at rest (the form many multibody and robot models use, so a test engineer can
    state their simulation's law as it is; ``F tanh(phi'/v_t)`` tends to :class:`Coulomb`'s
    ``F sign(phi')`` as ``v_t -> 0``)."""

    MJCF_FIELDS = ("tanh_friction_torque_Nm", "tanh_friction_velocity_rad_s")
    NATIVE_KIND = 10

    def __call__(self, phi, rate):
        if isinstance(rate, float):
            return math.tanh(rate / self.velocity_rad_s)
        return np.tanh(np.asarray(rate, dtype=float) / self.velocity_rad_s)


@dataclass(frozen=True)
class QuadraticDamping(_OneField, Term):
    """Quadratic (turbulent) damping ``phi' |phi'|`` -> ``quadratic_damping_Nms2_per_rad2``."""

    MJCF_FIELDS = ("quadratic_damping_Nms2_per_rad2",)
    NATIVE_KIND = 6
    dissipative = True

    @property
    def name(self) -> str:
        return "quadratic_damping_Nms2_per_rad2"

    @property
    def elastic(self) -> bool:
        return False

    def __call__(self, phi, rate):
        if isinstance(rate, float):
            return rate * abs(rate)
        r = np.asarray(rate, dtype=float)
        return r * np.abs(r)


@dataclass(frozen=True)
class Constant(Term):
    """A constant torque (force) on a body, the same in every run: ``1`` -> ``constant_torque_Nm``,
    the drive cell's offset plus a constant load where the drive acts (gravity on an axis, a
    cable's drag, a pump's mean load). Harmonic balance leaves every record's mean out, so it
    is fitted only where a body's equation is balanced while it slides alone (a stick mask
    multiplies it: ``identify.chain.chain_system``); there the constant has every harmonic of
    the mask, and left out it would bend the friction and the mass it is fitted beside. No
    model-file field: the rig holds it as a constant load (``rig.chain.simulate_chain``'s
    ``loads_Nm``), not in a law."""

    @property
    def name(self) -> str:
        return "constant_torque_Nm"

    @property
    def elastic(self) -> bool:
        return False

    def __call__(self, phi, rate):
        if isinstance(rate, float):
            return 1.0
        return np.ones_like(np.asarray(phi, dtype=float))


def play(phi: float, state_rad: float, slip_rad: float) -> float:
    """The play operator (rate-independent memory): the slider position after the angle
    moved to ``phi``, given its position ``state_rad`` before; it follows ``phi`` at a lag of
    at most ``slip_rad``."""
    return min(max(state_rad, phi - slip_rad), phi + slip_rad)


@dataclass(frozen=True)
class Jenkins(Term):
    """Hysteresis: a Jenkins element (the one-element Iwan model), a spring in series with a
    dry-friction slider, in parallel with the rest of the joint.

    The slider sits at ``z`` (rad) and moves only when the spring torque reaches the slip
    torque ``F`` (the parameter, ``hysteresis_slip_torque_Nm``); the spring stiffness is
    ``F / slip_rad``. Unit-parameter torque: ``(phi - z) / slip_rad`` in [-1, 1] with
    ``z = play(phi, z_before, slip_rad)``. Below ``slip_rad`` amplitude it is a stiffness;
    above, it traces a parallelogram loop whose area is the energy lost per cycle.

    The term has state: the rig keeps ``z`` between steps (:meth:`torque` from the state at
    the start of the step, :func:`play` to commit it); on a periodic record the array path
    runs the operator over the record twice and returns the second, periodic pass.
    """

    slip_rad: float

    def __post_init__(self):
        slip = float(self.slip_rad)
        if not (math.isfinite(slip) and slip > 0):
            raise ValueError(f"Jenkins.slip_rad must be a finite number > 0, got {self.slip_rad!r}")
        object.__setattr__(self, "slip_rad", slip)

    stateful = True
    MJCF_FIELDS = ("hysteresis_slip_torque_Nm", "hysteresis_slip_angle_rad")
    dissipative = True

    def native(self):
        return NativeTerm(7, dpar=self.slip_rad, sliders=((self.slip_rad, 0.0),))

    @classmethod
    def read_fields(cls, fields):
        if not _pair(fields, "hysteresis_slip_torque_Nm", "hysteresis_slip_angle_rad"):
            return []
        torque = _scalar(fields, "hysteresis_slip_torque_Nm", dissipates=True)
        slip = _scalar(fields, "hysteresis_slip_angle_rad", nonnegative=True)
        return [(cls(slip), torque)] if slip > 0 else []

    def fields(self, value):
        return {"hysteresis_slip_torque_Nm": [value], "hysteresis_slip_angle_rad": [self.slip_rad]}

    def derived_parameters(self, value):
        return {"hysteresis_slip_angle_rad": self.slip_rad, "hysteresis_stiffness_Nm_per_rad": value / self.slip_rad}

    @property
    def name(self) -> str:
        return "hysteresis_slip_torque_Nm"

    @property
    def elastic(self) -> bool:
        return False

    n_states = 1

    def torque(self, phi: float, state_rad: float) -> float:
        """Unit-parameter torque at angle ``phi`` with the slider at ``state_rad`` before."""
        return (phi - play(phi, state_rad, self.slip_rad)) / self.slip_rad

    def step_torque(self, phi: float, state: list, at: int) -> float:
        """Unit-parameter torque at ``phi`` with the slider at ``state[at]`` (the rig's path)."""
        return (phi - play(phi, state[at], self.slip_rad)) / self.slip_rad

    def commit(self, phi: float, state: list, at: int) -> None:
        """Move the slider ``state[at]`` to the accepted angle ``phi`` (after a step)."""
        state[at] = play(phi, state[at], self.slip_rad)

    def __call__(self, phi, rate):
        if isinstance(phi, float):
            raise TypeError("Jenkins has state: the rig evaluates it with Jenkins.torque(phi, state)")
        x = np.asarray(phi, dtype=float)
        return self.along(x, monotone_runs(x))

    def along(self, x: np.ndarray, runs: Optional[list[tuple[int, int, bool]]]) -> np.ndarray:
        """The column along one period ``x`` whose monotone runs (:func:`monotone_runs`) are
        known (a profile search's trials share them): the play operator in its periodic state,
        started where a first pass from rest ends (:func:`_play_end`). The numbers of ``self(x, None)``."""
        z = _play_array(x, self.slip_rad, _play_end(x, self.slip_rad, 0.0, runs), runs)
        return (x - z) / self.slip_rad


def _play_array(x: np.ndarray, slip, z0, runs: Optional[list[tuple[int, int, bool]]]) -> np.ndarray:
    """:func:`play` applied along ``x`` from slider state ``z0``, vectorised by monotone runs
    (:func:`_slide`; the same numbers as stepping :func:`play` sample by sample).
    ``slip`` and ``z0`` may be arrays of shape (m,) (m sliders along the same ``x``, as in an
    Iwan element): the result is then (m, x.size). ``runs``: :func:`monotone_runs` of ``x``."""
    slip_a = np.asarray(slip, dtype=float)[..., None]
    z = np.empty(slip_a.shape[:-1] + x.shape)
    if x.size == 0:
        return z
    z[..., 0] = _play_start(x, slip_a, z0)
    if runs is None:
        z[..., 1:] = z[..., :1]
        return z
    before = z[..., 0:1]
    for a, b, rising in runs:
        z[..., a:b] = _slide(before, x[a:b], slip_a, rising)
        before = z[..., b - 1:b]
    return z


def _slide(before, x, slip, rising: bool):
    """The play operator over a monotone run ``x`` from slider state ``before``: while x rises
    the slider is ``max(before, x - slip)``, while it falls ``min(before, x + slip)`` (the one
    place of that rule for :func:`_play_array`, :func:`_play_end` and :func:`_play_sum`)."""
    return np.maximum(before, x - slip) if rising else np.minimum(before, x + slip)


def _play_end(x: np.ndarray, slip, z0, runs: Optional[list[tuple[int, int, bool]]]) -> np.ndarray:
    """The last sample of :func:`_play_array` (``(m,)`` or a scalar array), the same numbers: a
    run moves the slider only towards its last sample's bound, so each run's last sample is all
    it needs (the periodic state for the second pass at a tenth of a pass's cost). ``runs`` as
    in :func:`_play_array`."""
    slip_a = np.asarray(slip, dtype=float)[..., None]
    if x.size == 0:
        raise ValueError("_play_end: an empty record has no last sample")
    before = _play_start(x, slip_a, z0)[..., None]
    for a, b, rising in runs or ():
        before = _slide(before, x[b - 1:b], slip_a, rising)
    return before[..., 0]


def _play_sum(x: np.ndarray, slip: np.ndarray, weight: np.ndarray, z0: np.ndarray,
              runs: Optional[list[tuple[int, int, bool]]]) -> np.ndarray:
    """``sum_i weight_i (x - z_i)`` along ``x`` for the sliders ``z_i`` of :func:`_play_array`
    (slip angles ``slip`` and states ``z0``, shape (m,)), without forming them: an Iwan element's
    torque at a fraction of the cost for its 129 sliders (round-off ~2e-14 of the torque).

    Within a monotone run the sliders that have started to slip stay slipping: rising from state
    z_i, slider i holds (``x - z_i``) while ``x <= z_i + s_i`` and slips (``s_i``) beyond; falling,
    it holds while ``x >= z_i - s_i`` and slips (``-s_i``) below. With the thresholds sorted, a
    sample's sum is read from cumulative sums at its place among them. ``runs`` as in
    :func:`_play_array`."""
    s = np.asarray(slip, dtype=float)
    k = np.asarray(weight, dtype=float)
    out = np.empty(x.shape)
    if x.size == 0:
        return out
    z = _play_start(x, s[:, None], z0)
    out[0] = k @ (x[0] - z)
    if runs is None:
        out[1:] = out[0]
        return out
    for a, b, rising in runs:
        seg = x[a:b]
        thr = z + s if rising else z - s
        order = np.argsort(thr, kind="stable")
        cum = np.zeros((3, s.size + 1))
        np.cumsum(np.stack([k, k * z, k * s])[:, order], axis=1, out=cum[:, 1:])
        K, KZ, KS = cum
        if rising:  # the first j sorted (thresholds below x) slip
            j = np.searchsorted(thr[order], seg, side="left")
            out[a:b] = (K[-1] - K[j]) * seg - (KZ[-1] - KZ[j]) + KS[j]
        else:  # the first j sorted (thresholds at or below x) hold
            j = np.searchsorted(thr[order], seg, side="right")
            out[a:b] = K[j] * seg - KZ[j] - (KS[-1] - KS[j])
        z = _slide(z, x[b - 1], s, rising)
    return out


def _play_start(x: np.ndarray, slip_a: np.ndarray, z0) -> np.ndarray:
    x0 = float(x[0])
    return np.minimum(np.maximum(np.asarray(z0, dtype=float), x0 - slip_a[..., 0]), x0 + slip_a[..., 0])


def monotone_runs(x: np.ndarray) -> Optional[list[tuple[int, int, bool]]]:
    """``(first, end, rising)`` of the monotone runs of ``x`` after its first sample (a flat step
    keeps the direction of the step before it); None when ``x`` is constant or a single sample."""
    if x.size < 2:
        return None
    d = np.sign(np.diff(x))
    nz = np.flatnonzero(d)
    if nz.size == 0:
        return None
    # A flat step keeps the direction of the step before it (forward fill of the sign).
    fill = np.maximum.accumulate(np.where(d != 0, np.arange(d.size), 0))
    d = d[fill]
    d[: nz[0]] = d[nz[0]]
    starts = np.concatenate([[1], np.flatnonzero(d[1:] != d[:-1]) + 2])
    ends = np.concatenate([starts[1:], [x.size]])
    return [(a, b, bool(d[a - 1] > 0)) for a, b in zip(starts.tolist(), ends.tolist())]


def iwan_elements(slip_rad: float, chi: float, beta: float, elements: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Slip angles (rad) and stiffnesses (N m/rad per N m of macroslip torque) of the Jenkins
    elements that discretise Segalman's four-parameter Iwan density.

    The density of slip angles is ``R s**chi`` on (0, slip_rad] plus a Dirac of stiffness
    ``S = beta * K_d`` at ``slip_rad``, where ``K_d = R slip_rad**(chi+1)/(chi+1)`` is the
    distributed stiffness (Segalman 2005, J. Appl. Mech. 72). The interval is cut into
    ``elements`` pieces of equal stiffness (edges ``slip_rad (j/n)**(1/(chi+1))``); each
    piece becomes one element of that stiffness at the piece's stiffness-weighted mean slip,
    so the total stiffness and the macroslip torque are exact. The last element is the Dirac.
    Normalised so that the macroslip torque ``sum(k_i s_i)`` is 1.
    """
    kd = 1.0 / (slip_rad * ((chi + 1.0) / (chi + 2.0) + beta))
    e = slip_rad * (np.arange(elements + 1) / elements) ** (1.0 / (chi + 1.0))
    num = (chi + 1.0) / (chi + 2.0) * np.diff(e ** (chi + 2.0))
    den = np.diff(e ** (chi + 1.0))
    slips = num / den
    stiff = np.full(elements, kd / elements)
    if beta > 0:
        slips = np.append(slips, slip_rad)
        stiff = np.append(stiff, beta * kd)
    return tuple(float(v) for v in slips), tuple(float(v) for v in stiff)


@dataclass(frozen=True)
class Iwan(Term):
    """Micro-slip: Segalman's four-parameter Iwan element, a continuum of Jenkins elements
    (springs in series with dry-friction sliders) in parallel with the rest of the joint.

    The parameter is the macroslip torque ``F_S`` (``iwan_slip_torque_Nm``), the torque at
    which every slider slips. The shape is fixed by the term: ``slip_rad`` (``phi_max``, the
    angle at which the last slider slips), ``chi`` in (-1, 0] (the density ``~ s**chi`` of
    slip angles: the micro-slip dissipation per cycle grows as ``A**(3 + chi)``) and ``beta
    >= 0`` (the share of the stiffness that slips last, all at once). The tangential
    stiffness is ``F_S (1 + beta) / (slip_rad (beta + (chi+1)/(chi+2)))``
    (:attr:`stiffness_per_torque`). Discretised by :func:`iwan_elements` into ``elements``
    Jenkins elements (+1 for beta > 0); the rig keeps one slider per element. 128: the
    discretisation's backbone departs from the continuum's as ``1 / elements**2``, and fitted to
    an exact continuum's steady state (the independent bench, noise-free) the slip angle read
    +4.1e-4 of itself high at 32 elements, 1.0e-4 at 64 and 2.4e-5 at 128, against a standard
    error of 5.8e-4 of it at 0.03% noise (70 dB): at 32 its 95% interval held the truth 74% of
    the time. The rig's C step costs the same at 128; the balance's columns are read from
    sorted thresholds (:func:`_play_sum`) and cost no more either.
    """

    slip_rad: float
    chi: float = -0.5
    beta: float = 0.1
    elements: int = 128

    def __post_init__(self):
        slip, chi, beta = float(self.slip_rad), float(self.chi), float(self.beta)
        if not (math.isfinite(slip) and slip > 0):
            raise ValueError(f"Iwan.slip_rad must be a finite number > 0, got {self.slip_rad!r}")
        if not (math.isfinite(chi) and -1.0 < chi <= 0.0):
            raise ValueError(f"Iwan.chi must be in (-1, 0], got {self.chi!r}")
        if not (math.isfinite(beta) and beta >= 0.0):
            raise ValueError(f"Iwan.beta must be a finite number >= 0, got {self.beta!r}")
        if int(self.elements) != self.elements or not 2 <= self.elements <= 200:
            raise ValueError(f"Iwan.elements must be an integer in [2, 200], got {self.elements!r}")
        object.__setattr__(self, "slip_rad", slip)
        object.__setattr__(self, "chi", chi)
        object.__setattr__(self, "beta", beta)
        object.__setattr__(self, "elements", int(self.elements))

    stateful = True
    MJCF_FIELDS = ("iwan_slip_torque_Nm", "iwan_slip_angle_rad", "iwan_chi", "iwan_beta")
    dissipative = True

    def native(self):
        slips, stiff = self.slips_and_stiffnesses
        return NativeTerm(8, sliders=tuple(zip(slips, stiff)))

    @classmethod
    def read_fields(cls, fields):
        if not _pair(fields, "iwan_slip_torque_Nm", "iwan_slip_angle_rad"):
            if "iwan_chi" in fields or "iwan_beta" in fields:
                raise FieldError("jointrig_iwan_chi and jointrig_iwan_beta shape an Iwan element: set "
                                 "jointrig_iwan_slip_torque_Nm and jointrig_iwan_slip_angle_rad too")
            return []
        torque = _scalar(fields, "iwan_slip_torque_Nm", dissipates=True)
        slip = _scalar(fields, "iwan_slip_angle_rad", nonnegative=True)
        chi = _scalar(fields, "iwan_chi", default=-0.5)
        if not -1.0 < chi <= 0.0:
            raise FieldError(f"jointrig_iwan_chi must hold one number in (-1, 0], got {chi}")
        beta = _scalar(fields, "iwan_beta", nonnegative=True, default=0.1)
        return [(cls(slip, chi, beta), torque)] if slip > 0 else []

    def fields(self, value):
        if self.elements != type(self).__dataclass_fields__["elements"].default:
            raise FieldError(f"an Iwan element of {self.elements} elements has no jointrig_* field (the model file's "
                             f"has {type(self).__dataclass_fields__['elements'].default})")
        return {"iwan_slip_torque_Nm": [value], "iwan_slip_angle_rad": [self.slip_rad], "iwan_chi": [self.chi],
                "iwan_beta": [self.beta]}

    def derived_parameters(self, value):
        return {"iwan_slip_angle_rad": self.slip_rad, "iwan_chi": self.chi, "iwan_beta": self.beta,
                "iwan_stiffness_Nm_per_rad": value * self.stiffness_per_torque}

    @property
    def name(self) -> str:
        return "iwan_slip_torque_Nm"

    @property
    def elastic(self) -> bool:
        return False

    @property
    def n_states(self) -> int:  # type: ignore[override]
        return self.elements + (1 if self.beta > 0 else 0)

    @property
    def slips_and_stiffnesses(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return _iwan_cached(self.slip_rad, self.chi, self.beta, self.elements)

    @property
    def stiffness_per_torque(self) -> float:
        """Tangential stiffness (N m/rad) per N m of macroslip torque."""
        return (1.0 + self.beta) / (self.slip_rad * (self.beta + (self.chi + 1.0) / (self.chi + 2.0)))

    def step_torque(self, phi: float, state: list, at: int) -> float:
        """Unit-parameter torque at ``phi`` with the sliders at ``state[at:at + n_states]``."""
        slips, stiff = self.slips_and_stiffnesses
        total = 0.0
        for i in range(len(slips)):
            total = total + stiff[i] * (phi - play(phi, state[at + i], slips[i]))
        return total

    def commit(self, phi: float, state: list, at: int) -> None:
        """Move every slider to the accepted angle ``phi`` (after a step)."""
        slips, _ = self.slips_and_stiffnesses
        for i in range(len(slips)):
            state[at + i] = play(phi, state[at + i], slips[i])

    def __call__(self, phi, rate):
        if isinstance(phi, float):
            raise TypeError("Iwan has state: the rig evaluates it with Iwan.step_torque(phi, state, at)")
        x = np.asarray(phi, dtype=float)
        return self.along(x, monotone_runs(x))

    def along(self, x: np.ndarray, runs: Optional[list[tuple[int, int, bool]]]) -> np.ndarray:
        """The column along one period ``x`` whose monotone runs are known (as :meth:`Jenkins.along`):
        every slider in its periodic state from rest, their weighted sum (:func:`_play_sum`)."""
        slips, stiff = (np.asarray(v) for v in self.slips_and_stiffnesses)
        return _play_sum(x, slips, stiff, _play_end(x, slips, np.zeros(slips.size), runs), runs)


@functools.lru_cache(maxsize=256)
def _iwan_cached(slip_rad: float, chi: float, beta: float, elements: int):
    return iwan_elements(slip_rad, chi, beta, elements)


@dataclass(frozen=True)
class Monomial(Term):
    """Mixed term ``phi**angle_power * phi'**rate_power`` (rate_power >= 1; use :class:`Power`
    for pure stiffness terms and :class:`Viscous` for ``phi'``)."""

    angle_power: int
    rate_power: int

    def __post_init__(self):
        if not (isinstance(self.angle_power, int) and isinstance(self.rate_power, int)
                and self.angle_power >= 0 and self.rate_power >= 1
                and (self.angle_power, self.rate_power) != (0, 1)):
            raise ValueError(f"Monomial needs ints angle_power >= 0, rate_power >= 1, not (0, 1) "
                             f"(that is Viscous); got ({self.angle_power!r}, {self.rate_power!r})")

    def native(self):
        return NativeTerm(2, (self.angle_power, self.rate_power, 0))

    @property
    def name(self) -> str:
        return f"c_p{self.angle_power}_q{self.rate_power}"

    @property
    def elastic(self) -> bool:
        return False

    def __call__(self, phi, rate):
        if isinstance(phi, float) and isinstance(rate, float):
            return ipow(phi, self.angle_power) * ipow(rate, self.rate_power)
        return (ipow_array(np.asarray(phi, dtype=float), self.angle_power)
                * ipow_array(np.asarray(rate, dtype=float), self.rate_power))


@dataclass(frozen=True)
class _Hat(Term):
    knots: tuple[float, ...]
    index: int

    def __post_init__(self):
        what = type(self).__name__
        object.__setattr__(self, "knots", _check_knots(self.knots, f"{what}.knots"))
        if not 0 <= self.index < len(self.knots):
            raise ValueError(f"{what}.index {self.index} outside 0..{len(self.knots) - 1}")


@dataclass(frozen=True)
class AngleHat(_Hat):
    """Hat function ``hat_i(phi)`` on ``knots`` (rad): the restoring torque at knot i (eq. 8)."""

    MJCF_FIELDS = ("knots_rad", "g_Nm")

    def native(self):
        return NativeTerm(3, (self.index, 0, len(self.knots)), knots=self.knots)

    @classmethod
    def read_fields(cls, fields):
        if "k_Nm_per_rad" in fields and "knots_rad" in fields:
            raise FieldError("jointrig_k_Nm_per_rad and jointrig_knots_rad both set the linear stiffness; keep one")
        return _read_hats(fields, "knots_rad", "g_Nm", angle_hats)

    @property
    def name(self) -> str:
        return f"g{self.index}_Nm"

    @property
    def elastic(self) -> bool:
        return True

    def __call__(self, phi, rate):
        return _hat(phi, self.knots, self.index)


@dataclass(frozen=True)
class RateHat(_Hat):
    """Hat function ``hat_i(phi')`` on ``knots`` (rad/s): the damping torque at knot i (eq. 9)."""

    MJCF_FIELDS = ("rate_knots_rad_s", "f_Nm")

    def native(self):
        return NativeTerm(4, (self.index, 0, len(self.knots)), knots=self.knots)

    @classmethod
    def read_fields(cls, fields):
        return _read_hats(fields, "rate_knots_rad_s", "f_Nm", rate_hats)

    @property
    def name(self) -> str:
        return f"f{self.index}_Nm"

    @property
    def elastic(self) -> bool:
        return False

    def __call__(self, phi, rate):
        return _hat(rate, self.knots, self.index)


def _read_hats(fields: dict, knots_name: str, values_name: str, make) -> list[tuple[Term, float]]:
    if not _pair(fields, knots_name, values_name):
        return []
    knots = np.asarray(fields[knots_name], dtype=float).ravel()
    vals = np.asarray(fields[values_name], dtype=float).ravel()
    if knots.size != vals.size:
        raise FieldError(f"jointrig_{knots_name} has {knots.size} entries but jointrig_{values_name} has {vals.size}")
    try:
        hats = make(knots)
    except ValueError as err:
        raise FieldError(f"jointrig_{knots_name}: {err}") from None
    return list(zip(hats, (float(v) for v in vals)))


def angle_hats(knots: Sequence[float]) -> tuple[AngleHat, ...]:
    k = _check_knots(knots, "angle knots")
    return tuple(AngleHat(k, i) for i in range(len(k)))


def rate_hats(knots: Sequence[float]) -> tuple[RateHat, ...]:
    k = _check_knots(knots, "rate knots")
    return tuple(RateHat(k, i) for i in range(len(k)))


@dataclass(frozen=True)
class Cogging(Term):
    """A torque periodic in the angle: ``sin(z phi)``, or ``cos(z phi)`` with ``quadrature``
    -> ``cogging_sin_Nm``, ``cogging_cos_Nm``. The pair is ``A sin(z phi + p)``: a gear's mesh
    stiffness, a motor's cogging, detents. ``order_per_rad`` is z, radians of phase per radian
    of the angle: the periods per revolution (a gear's teeth, a motor's cogging steps); the
    pitch is 2 pi / z. On a slide the same z is in rad/m.
    Both parts share z in a model file (``cogging_order_rad_per_rad``); its C case reads z as its
    float and ``ints[0]`` = 1 for the cosine."""

    order_per_rad: float
    quadrature: bool = False

    MJCF_FIELDS = ("cogging_sin_Nm", "cogging_cos_Nm", "cogging_order_rad_per_rad")
    NATIVE_KIND = 11

    def __post_init__(self):
        z = float(self.order_per_rad)
        if not (math.isfinite(z) and z > 0):
            raise ValueError(f"Cogging.order_per_rad must be a finite number > 0, got {self.order_per_rad!r}")
        object.__setattr__(self, "order_per_rad", z)
        object.__setattr__(self, "quadrature", bool(self.quadrature))

    def native(self):
        return NativeTerm(self.NATIVE_KIND, (int(self.quadrature), 0, 0), dpar=self.order_per_rad)

    @classmethod
    def read_fields(cls, fields):
        sin_f, cos_f, order_f = cls.MJCF_FIELDS
        present = [f for f in (sin_f, cos_f) if f in fields]
        if not present and order_f not in fields:
            return []
        if not present or order_f not in fields:
            raise FieldError(f"jointrig_{order_f} goes with jointrig_{sin_f} and/or jointrig_{cos_f}")
        z = _scalar(fields, order_f, nonnegative=True)
        if not z > 0:
            raise FieldError(f"jointrig_{order_f} must be > 0 (rad of phase per rad), got {z:g}")
        return [(cls(z, f == cos_f), _scalar(fields, f)) for f in present]

    def fields(self, value):
        return {self.name: [value], self.MJCF_FIELDS[2]: [self.order_per_rad]}

    def derived_parameters(self, value):
        return {"cogging_order_rad_per_rad": self.order_per_rad, "cogging_pitch_rad": 2 * math.pi / self.order_per_rad}

    def combined_parameters(self, values):
        return {"cogging_amplitude_Nm": math.hypot(values.get(self.MJCF_FIELDS[0], 0.0),
                                                   values.get(self.MJCF_FIELDS[1], 0.0))}

    @property
    def name(self) -> str:
        return self.MJCF_FIELDS[1] if self.quadrature else self.MJCF_FIELDS[0]

    @property
    def elastic(self) -> bool:
        return True

    def __call__(self, phi, rate):
        if isinstance(phi, float):
            return math.cos(self.order_per_rad * phi) if self.quadrature else math.sin(self.order_per_rad * phi)
        x = self.order_per_rad * np.asarray(phi, dtype=float)
        return np.cos(x) if self.quadrature else np.sin(x)


def law_parameters(terms: Sequence[Term], values: Sequence[float]) -> dict[str, float]:
    """Every parameter a law's terms imply beyond their values (``Term.derived_parameters`` of
    each, ``Term.combined_parameters`` of the whole), by term name: the one place both the rig's
    plants and the chain's fits read them from."""
    by_name = {t.name: v for t, v in zip(terms, values)}
    out: dict[str, float] = {}
    for t, v in zip(terms, values):
        out.update(t.derived_parameters(v))
        out.update(t.combined_parameters(by_name))
    return out


#: Every term a model file can declare, in the order its terms enter the law (the order of the
#: sums in both callbacks, so it is part of the bits of every trajectory).
TERM_CLASSES: tuple[type[Term], ...] = (Viscous, ContactDamping, Power, Coulomb, QuadraticDamping, AngleHat, RateHat,
                                        Jenkins, Iwan, Stribeck, TanhFriction, Cogging)


def law_terms_from_fields(fields: dict) -> list[tuple[Term, float]]:
    """The law's terms and values a model file's ``jointrig_*`` fields declare (names without
    the prefix), in :data:`TERM_CLASSES` order. Raises :class:`FieldError`."""
    out: list[tuple[Term, float]] = []
    for cls in TERM_CLASSES:
        out.extend(cls.read_fields(fields))
    return out


def duplicate_names(terms: Sequence[Term]) -> list[str]:
    """The parameter names more than one of ``terms`` has (sorted; [] when each is once)."""
    names = [t.name for t in terms]
    return sorted({n for n in names if names.count(n) > 1})


@dataclass(frozen=True)
class JointLaw:
    """A joint law: basis terms and their parameter values (SI, names carry the units)."""

    terms: tuple[Term, ...]
    values: tuple[float, ...]

    def __post_init__(self):
        terms = tuple(self.terms)
        values = tuple(float(v) for v in self.values)
        if not terms:
            raise ValueError("JointLaw needs at least one term")
        if len(terms) != len(values):
            raise ValueError(f"JointLaw: {len(terms)} terms but {len(values)} values")
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"JointLaw: values must be finite, got {values}")
        dup = duplicate_names(terms)
        if dup:
            raise ValueError(f"JointLaw: duplicate parameter names {dup}")
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "values", values)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.terms)

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.names, self.values))

    def with_values(self, **values: float) -> "JointLaw":
        """The same terms with some parameters changed, by name (``law.with_values(c_Nms_per_rad=5)``)."""
        unknown = sorted(set(values) - set(self.names))
        if unknown:
            raise ValueError(f"JointLaw.with_values: no parameters {unknown}; the law has {list(self.names)}")
        return JointLaw(self.terms, tuple(values.get(n, v) for n, v in zip(self.names, self.values)))

    def torque(self, phi: ArrayLike, rate: ArrayLike) -> ArrayLike:
        """Joint torque ``M_v`` in N m at relative angle ``phi`` (rad) and rate (rad/s).

        Accepts Python floats (the callback's fast path) or arrays of equal shape.
        """
        total = 0.0
        for term, value in zip(self.terms, self.values):
            total = total + value * term(phi, rate)
        return total

    def elastic_torque(self, phi: ArrayLike) -> ArrayLike:
        """Restoring torque g(phi): the angle-only terms, in N m."""
        total = 0.0 * np.asarray(phi, dtype=float)
        for term, value in zip(self.terms, self.values):
            if term.elastic:
                total = total + value * term(np.asarray(phi, dtype=float), 0.0 * total)
        return total


def polynomial_law(
    *, c_Nms_per_rad: float, k_Nm_per_rad: float, a_Nm_per_rad2: float = 0.0,
    gamma_Nm_per_rad3: float = 0.0,
) -> JointLaw:
    """``c phi' + k phi + a phi^2 + gamma phi^3`` (paper eq. 11 with the even term of eq. 2).

    Terms with a zero coefficient other than c and k are left out.
    """
    terms: list[Term] = [Viscous(), Power(1)]
    values = [c_Nms_per_rad, k_Nm_per_rad]
    for p, v in ((2, a_Nm_per_rad2), (3, gamma_Nm_per_rad3)):
        if v != 0.0:
            terms.append(Power(p))
            values.append(v)
    return JointLaw(tuple(terms), tuple(values))


def hat_law(
    *, knots_rad: Sequence[float], g_Nm: Sequence[float], c_Nms_per_rad: float = 0.0
) -> JointLaw:
    """Piecewise-linear restoring torque through ``(knots_rad, g_Nm)`` (eq. 8) plus
    viscous damping (left out when ``c_Nms_per_rad`` is 0)."""
    hats = angle_hats(knots_rad)
    if len(g_Nm) != len(hats):
        raise ValueError(f"hat_law: {len(hats)} knots but {len(g_Nm)} values in g_Nm")
    terms: list[Term] = list(hats)
    values = list(g_Nm)
    if c_Nms_per_rad != 0.0:
        terms.insert(0, Viscous())
        values.insert(0, c_Nms_per_rad)
    return JointLaw(tuple(terms), tuple(values))
