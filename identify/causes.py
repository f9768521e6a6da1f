"""The cause catalogue: what a nominal model may be missing, once for every pipeline.

A :class:`Cause` extends a :class:`ModelSpec` (joint terms, bearing drag, a drive delay, the
sensors' zero, skew and scale) with its columns and at most one nonlinear parameter, found by a
profile search within ``bounds``. :data:`CATALOGUE` holds every cause; the diagnosis of every
bench (:mod:`identify.chain_diagnose`: two flywheels, trains, a single axis) scores the causes
sought at each place (:func:`at`), the one-coordinate oscillator's extension
(:mod:`identify.extend`, the Silverbox) :data:`OSCILLATOR_CAUSES`, and both judge a cause by :func:`evidence` into one
:class:`CauseScore`. Adding a cause is one entry here: it carries where it is sought, how its
magnitude reads, its search and its degeneracy rule, so no diagnosis names it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Generic, Optional, Sequence, TypeVar

import numpy as np

from jointrig.vocab.law import (Cogging, ContactDamping, Coulomb, Iwan, Jenkins, Monomial, Power, QuadraticDamping,
                                Stribeck, Term, Viscous)
from jointrig.vocab.params import BEARING1, BEARING2, DRIVE_DELAY

from .balance import spectral_rate
from .defaults import DEFAULT_ALPHA
from .estimates import satterthwaite

__all__ = ["ModelSpec", "NOMINAL", "Cause", "Limits", "Place", "CauseScore", "Ambiguity", "CATALOGUE",
           "OSCILLATOR_CAUSES", "at", "by_name", "evidence", "effective_dof", "chi2_survival", "detection_limit", "DETECTION_POWER",
           "SEPARATING_EXCITATION", "DEFAULT_SEPARATION", "SAME_PLACE", "separating_excitation", "told_from_zero", "DIMENSIONLESS", "IWAN_CHI",
           "IWAN_BETA", "rate_amplitudes", "Selection", "forward_select", "harmonic_shares", "fundamental_quadrature",
           "resolved"]


@dataclass(frozen=True)
class ModelSpec:
    """A model structure: joint terms, bearing drag columns, a drive delay."""

    terms: tuple[Term, ...]
    bearings: bool = False
    drive_delay_s: float = 0.0
    #: measurement: the relative angle's zero is off by this much; the law sees phi - offset
    angle_offset_rad: float = 0.0
    #: measurement: flywheel 2's angle reading lags the truth by this much (s; negative: leads),
    #: the channel skew of a multiplexed DAQ or a filter's group delay: recorded phi2(t) =
    #: phi2(t - tau)
    angle2_delay_s: float = 0.0
    #: measurement: flywheel 2's angle reads (1 + angle2_gain_error) times the truth (an
    #: encoder's lines per revolution or a gear ratio set wrong): recorded phi2 = (1 + e) phi2
    angle2_gain_error: float = 0.0


NOMINAL = ModelSpec((Viscous(), Power(1), Power(3)))



@dataclass(frozen=True)
class Cause:
    """A physical cause: how it extends a model, with at most one nonlinear parameter.

    ``extend(spec, h)`` returns the extended structure for nonlinear parameter ``h`` (ignored
    when ``bounds`` is None); ``bounds(runs)`` gives its search interval; ``magnitude`` names
    the parameter that says how strong the effect is.
    """

    name: str
    description: str
    extend: Callable[[ModelSpec, float], ModelSpec]
    magnitude: str
    n_linear: int
    bounds: Optional[Callable[[Sequence], tuple[float, float]]] = None  # of the prepared runs (their .average)
    log_scale: bool = False
    nonnegative: bool = True  # a negative magnitude is unphysical (friction, damping, delay)
    profiled: Optional[str] = None  # name of the nonlinear parameter the profile search finds
    #: "dynamic" (in the plant: the rig simulates it) or "measurement" (in the sensors: the data
    #: are corrected for it; checked first, as a test engineer checks the instrumentation first)
    kind: str = "dynamic"
    #: sought only in the first round, against the nominal model. A channel skew shifts a whole
    #: angle in time, which also bends a model whose friction or free play is a little off: on
    #: the rig's dry friction with free play it drew a 0.1 ms skew as a third cause (p = 2e-5)
    #: that made the held-out runs worse (gain 5.1 with it, 6.5 without). A real skew is a
    #: misfit of the whole record and shows first.
    first_only: bool = False
    #: the simpler cause this one reduces to when its extra parameters vanish (a Stribeck friction
    #: without its peak is dry friction): where both are significant in one round, this one is
    #: adopted over the simpler only if its extra parameters are significant by themselves (a
    #: nested chi-square test at the round's alpha), so pure dry friction is named as such.
    reduces_to: Optional[str] = None
    #: where the cause is sought: ``"joint"`` (a law of a joint's twist: every joint of a train,
    #: two flywheels' one; and a body's elastic law to the frame), ``"ground"`` (a single body's
    #: law to the frame), ``"drive"`` (the drive channels: their lag), ``"flywheel"`` (a body's
    #: viscous drag to ground, at every body), ``"channel"`` (a train's angle channel of body 2..N,
    #: read against the drive's and body 1's: its skew and scale; named for flywheel 2, renamed
    #: per body by :func:`vocab.params.channel_name`) and
    #: ``"oscillator"`` (the one-coordinate extension, the Silverbox)
    places: frozenset = frozenset({"joint"})
    #: the profile grid's spacing in the nonlinear parameter, from the runs (None: the fixed
    #: :data:`PROFILE_GRID_POINTS`): a parameter whose chi-square oscillates in it (a periodic
    #: torque's order: one oscillation per period of z across the largest swing) needs a grid
    #: finer than the oscillation, whatever the range
    grid_step: Optional[Callable[[Sequence], float]] = None
    #: ``degenerate(value, limits)``: why a fitted nonlinear parameter means the cause is another
    #: or nothing (a slip angle below the angle resolution is dry friction), None if it stands
    #: (:class:`Limits` says what the data resolve)
    degenerate: Optional[Callable[[float, "Limits"], Optional["Rejection"]]] = None
    #: ``trials(runs)``: independent values the profile search in effect tries (None: 1, a
    #: parameter whose chi-square has one basin or a few): a free frequency tries one per
    #: oscillation of chi-square over its range, and its best drop is the largest of that many;
    #: the significance level is divided by it as by the number of causes (look-elsewhere)
    trials: Optional[Callable[[Sequence], float]] = None
    #: the magnitude is made of these parameters (() when it is a parameter itself): the length of
    #: their vector (``magnitude_is = "length"``: a periodic torque's sine and cosine parts make its
    #: amplitude, the standard error by the delta method), or the largest of them (``"largest"``:
    #: two flywheels' bearing drags, named by the one)
    magnitude_parts: tuple = ()
    magnitude_is: str = "length"
    #: the cause in a few plain words, for the verdict a user reads ("dry friction"; the name
    #: where empty)
    plain: str = ""
    #: its bounds read the smallest swing of the runs too, not only the largest (a periodic
    #: torque's highest order is the one its smallest swing still resolves); a train's joint may
    #: barely twist in some runs, so there only runs within ``identify.chain_diagnose.BOUNDS_SPAN``
    #: of the largest swing are read
    bounds_read_smallest: bool = False
    #: an even stiffness beside a cubic ``gamma phi^3`` is, to first order, what a constant zero
    #: offset ``-a / (3 gamma)`` of the angle makes of the cubic: the report names that offset
    #: (``present.train_report.offset_readings``)
    reads_as_offset: bool = False

    def magnitude_of(self, params: dict, std_error: Callable[[str], float], prefix: str = ""
                     ) -> tuple[str, float, float]:
        """``(name, value, standard error)`` of the magnitude from a fit's parameters and its
        ``std_error(name)``, the names carrying ``prefix`` (a joint's or a body's in a train)."""
        if not self.magnitude_parts:
            name = prefix + self.magnitude
            return name, float(params.get(name, math.nan)), std_error(name)
        names = [prefix + n for n in self.magnitude_parts]
        parts = np.array([params.get(n, math.nan) for n in names])
        errs = np.array([std_error(n) for n in names])
        if self.magnitude_is == "largest":
            i = int(np.argmax(np.abs(parts)))
            return names[i], float(parts[i]), float(errs[i])
        size = float(np.sqrt(np.sum(parts**2)))
        se = float(np.sqrt(np.sum((parts * errs) ** 2)) / size) if size > 0 else float(np.sqrt(np.mean(errs**2)))
        return prefix + self.magnitude, size, se

    def n_trials(self, runs) -> float:
        """See ``trials``."""
        return 1.0 if self.trials is None else float(self.trials(runs))

    def grid_points(self, runs, lo: float, hi: float) -> int:
        """Points of the profile search's grid over [lo, hi] (see ``grid_step``)."""
        if self.grid_step is None:
            return PROFILE_GRID_POINTS
        return max(PROFILE_GRID_POINTS, int(math.ceil((hi - lo) / self.grid_step(runs))) + 1)


@dataclass(frozen=True)
class Limits:
    """What the data resolve where a cause is sought, for its ``degenerate`` rule.

    Attributes:
      resolution_rad: the smallest angle (or twist) the motion resolves.
      rate_top_rad_s: the largest rate the runs reach there.
      friction: how the dry-friction cause at that place is named ("coulomb_friction",
        "coulomb_friction at joint 2"), for the text of a rule that hands over to it.
    """

    resolution_rad: float
    rate_top_rad_s: float
    friction: str = "coulomb_friction"
    #: how much chi-square rises when the profiled size goes to the lower end of its search (its
    #: zero: no play; a slip angle's dry friction), at the fit's weights (NaN where not computed):
    #: what the whole fit resolves, where ``resolution_rad`` is what one sample does
    zero_rise: float = math.nan


@dataclass(frozen=True)
class Unphysical:
    """A rejection: a cause that only takes energy out fitted with a negative size."""

    #: the size parameter (the project's, a hinge's, name)
    name: str
    value: float


@dataclass(frozen=True)
class FeedsEnergy:
    """A rejection: the extended model would hold a dissipative parameter significantly below
    zero (more than two standard errors, or with none): it would feed energy in."""

    name: str
    value: float
    std_error: float


@dataclass(frozen=True)
class BelowResolution:
    """A rejection: a cause's profiled size below the smallest motion the runs resolve there. A
    free play is then none; an element that slips (``slips``) and never sticks is dry friction at
    its place (``friction``, that cause's label)."""

    #: which size, as the catalogue names it ("half gap", "slip angle")
    size: str
    #: the size and the resolution, in the coordinate's unit (rad; m on a slide)
    value: float
    resolution: float
    #: the element that never sticks below it ("a Jenkins element"); "" for a free play
    slips: str = ""
    friction: str = "coulomb_friction"


@dataclass(frozen=True)
class NoFalloff:
    """A rejection: a Stribeck rate above every run's rate amplitude: the friction does not fall off
    within the data; it is dry friction (``friction``, that cause's label)."""

    velocity: float
    rate_top: float
    friction: str = "coulomb_friction"


#: Why a cause the evidence calls significant is rejected all the same (its score's ``note``; in
#: words: :func:`present.notes.rejection_text`).
Rejection = Unphysical | FeedsEnergy | BelowResolution | NoFalloff


def told_from_zero(rise: float, alpha: float = DEFAULT_ALPHA) -> bool:
    """Whether chi-square's ``rise`` from a profiled size to its zero (:attr:`Limits.zero_rise`)
    is significant at the level ``alpha``: a likelihood-ratio test of one parameter (10.8 at
    1e-3) (pure). The profile's curvature at its minimum does not answer it: a Jenkins element
    fitted to dry friction at 10% noise read a slip angle of 0.00053 +- 0.00009 rad, 5.9 errors
    from zero, with chi-square no lower than dry friction's."""
    return bool(math.isfinite(rise) and chi2_survival(rise, 1) < alpha)


def _below_resolution(size: str, slips: str = "") -> Callable[[float, Limits], Optional[BelowResolution]]:
    """A rule for a slip angle or a free play: below the resolution it is dry friction (an element
    that ``slips``) or nothing (a free play), unless the whole fit tells it from that zero
    (:func:`told_from_zero`). At 10% noise on every channel a half gap of 0.02 rad read 0.0197 +-
    0.0014 rad beside a one-sample resolution of 0.043, and refused, its misfit was named a
    cogging; a Jenkins element's slip angle of 0.05 rad read 0.035, and refused, the element was
    named an Iwan element."""
    def rule(h: float, lim: Limits) -> Optional[BelowResolution]:
        if not h < lim.resolution_rad or told_from_zero(lim.zero_rise):
            return None
        return BelowResolution(size, h, lim.resolution_rad, slips, lim.friction)
    return rule


def _stribeck_degenerate(v: float, lim: Limits) -> Optional[NoFalloff]:
    return NoFalloff(v, lim.rate_top_rad_s, lim.friction) if v > lim.rate_top_rad_s else None


def _amplitude(runs) -> float:
    """Smallest relative-angle amplitude over the runs (rad)."""
    return min(float(np.max(np.abs(r.average.phi_rad - r.average.phi_rad.mean()))) for r in runs)


def _with_terms(spec: ModelSpec, extra: tuple[Term, ...]) -> ModelSpec:
    have = {t.name for t in spec.terms}
    return replace(spec, terms=spec.terms + tuple(t for t in extra if t.name not in have))


def _with_gap(spec: ModelSpec, gap: float) -> ModelSpec:
    """The elastic terms (and a damping in contact) beyond a free play of +-``gap`` rad."""
    terms = tuple(Power(t.power, gap) if isinstance(t, Power) and t.power >= 1
                  else ContactDamping(gap) if isinstance(t, ContactDamping) else t for t in spec.terms)
    return replace(spec, terms=terms)


def _with_contact_damping(spec: ModelSpec, gap: float) -> ModelSpec:
    """A free play of +-``gap`` rad whose damping acts only beyond it: the law's viscous damping
    becomes :class:`ContactDamping` (a law without damping is left as it is)."""
    if not any(isinstance(t, (Viscous, ContactDamping)) for t in spec.terms):
        return spec
    spec = _with_gap(spec, gap)
    return replace(spec, terms=tuple(ContactDamping(gap) if isinstance(t, Viscous) else t for t in spec.terms))


def _with_jenkins(spec: ModelSpec, slip: float) -> ModelSpec:
    terms = tuple(t for t in spec.terms if not isinstance(t, Jenkins)) + (Jenkins(slip),)
    return replace(spec, terms=terms)


def _with_iwan(spec: ModelSpec, slip: float) -> ModelSpec:
    terms = tuple(t for t in spec.terms if not isinstance(t, Iwan)) + (Iwan(slip, IWAN_CHI, IWAN_BETA),)
    return replace(spec, terms=terms)


#: The micro-slip cause's Iwan shape, fixed: chi = -0.5 (the middle of Segalman's range (-1, 0])
#: and beta = 0.1; only the largest slip angle is profiled, the macroslip torque is linear.
IWAN_CHI, IWAN_BETA = -0.5, 0.1


def _with_stribeck(spec: ModelSpec, velocity: float) -> ModelSpec:
    terms = tuple(t for t in spec.terms if not isinstance(t, Stribeck))
    if not any(isinstance(t, Coulomb) for t in terms):
        terms += (Coulomb(),)
    return replace(spec, terms=terms + (Stribeck(velocity),))


def rate_amplitudes(runs) -> list[float]:
    """Relative-rate amplitude of every run (rad/s), from the averaged period."""
    out = []
    for r in runs:
        phi = r.average.phi_rad
        out.append(float(np.max(np.abs(spectral_rate(phi - phi.mean(), r.average.omega_rad_s, 1)))))
    return out


def _largest_amplitude(runs) -> float:
    return max(float(np.max(np.abs(r.average.phi_rad - r.average.phi_rad.mean()))) for r in runs)


def _gap_bounds(runs) -> tuple[float, float]:
    """A free play's half gap is sought from 1e-4 of the smallest swing to 0.8 of the largest (rad)."""
    return 1e-4 * _amplitude(runs), 0.8 * _largest_amplitude(runs)


_JOINT_GROUND = frozenset({"joint", "ground"})
_OSCILLATOR = frozenset({"oscillator"})

#: The cogging profile's grid spacing in z, in radians of phase at the largest amplitude: chi-square
#: oscillates over z with a period near 2 pi / (largest amplitude); one radian samples it about 6
#: times per oscillation, and Brent's search refines the best basins. Half a radian and a quarter
#: found the same orders on the open-world bench to 1e-7 of themselves, at more cost: the worn
#: example's command took 2.66 s and 3.0 s against 2.48 s (1.85 s before cogging).
COGGING_GRID = 1.0
#: The highest order sought, as radians of phase z A at the smallest amplitude A: a sine of z phi
#: swinging over +-z A radians has harmonics up to about z A of the drive's, and the diagnosis
#: balances 20; the larger runs' torque then reaches beyond the band, their part within it still
#: tells z.
COGGING_MAX_PHASE = 20.0
#: The lowest order sought, as radians of phase z A at the largest amplitude A: two whole periods
#: between rest and the largest swing (four across it). With fewer a sine of the angle is only a
#: smooth bend of the stiffness, and takes the place of another cause: on the pump train's worn
#: coupling (+-1 mrad of free play, 5.6 mrad of twist) one of 1.2 periods (z A = 7.8) out-scored the
#: free play.
COGGING_MIN_PHASE = 4 * math.pi


def _cogging_bounds(runs) -> tuple[float, float]:
    """Orders z from :data:`COGGING_MIN_PHASE` radians of phase z A at the largest amplitude A to
    :data:`COGGING_MAX_PHASE` at the smallest (whose run then holds the torque within the band)."""
    return COGGING_MIN_PHASE / _largest_amplitude(runs), COGGING_MAX_PHASE / _amplitude(runs)


def _cogging_trials(runs) -> float:
    """Oscillations of chi-square over the orders searched (one per pi / A of z, A the largest
    amplitude): the independent orders the search tries."""
    lo, hi = _cogging_bounds(runs)
    return max(1.0, (hi - lo) * _largest_amplitude(runs) / math.pi)


def _with_cogging(spec: ModelSpec, order: float) -> ModelSpec:
    terms = tuple(t for t in spec.terms if not isinstance(t, Cogging))
    return replace(spec, terms=terms + (Cogging(order), Cogging(order, quadrature=True)))


#: Every cause the project knows, once. Each pipeline takes the causes sought at its places
#: (:func:`at`): every bench's joints, bodies and channels (``identify.chain_diagnose``), the
#: one-coordinate oscillator's extension (the Silverbox) :data:`OSCILLATOR_CAUSES`.
CATALOGUE: tuple[Cause, ...] = (
    Cause("coulomb_friction", "dry friction in the joint: a torque of constant size opposing the relative rate",
          lambda s, h: _with_terms(s, (Coulomb(),)), "coulomb_torque_Nm", 1, places=_JOINT_GROUND,
          plain="dry friction"),
    Cause("backlash", "free play in the elastic element: no stiffness within +-half gap",
          _with_gap, "backlash_half_gap_rad", 0, bounds=_gap_bounds,
          profiled="backlash_half_gap_rad", degenerate=_below_resolution("half gap"),
          plain="free play"),
    Cause("contact_damping", "free play whose element damps only in contact: no stiffness and no damping within "
          "+-half gap (a rubber insert with play; a lubricated play, which damps within it too, is backlash)",
          _with_contact_damping, "backlash_half_gap_rad", 0, bounds=_gap_bounds, profiled="backlash_half_gap_rad",
          degenerate=_below_resolution("half gap"),
          plain="free play with damping only in contact"),
    Cause("asymmetric_stiffness", "an even stiffness term a phi^2 (an asymmetric restoring force): even harmonics",
          lambda s, h: _with_terms(s, (Power(2),)), "a_Nm_per_rad2", 1, nonnegative=False,
          places=frozenset({"joint", "oscillator"}), plain="an asymmetric stiffness (a phi^2)", reads_as_offset=True),
    Cause("hysteresis", "a Jenkins (one-element Iwan) element: spring and dry-friction slider in series",
          _with_jenkins, "hysteresis_slip_torque_Nm", 1,
          bounds=lambda runs: (1e-3 * _amplitude(runs), 0.9 * _amplitude(runs)), log_scale=True,
          profiled="hysteresis_slip_angle_rad",
          degenerate=_below_resolution("slip angle", "a Jenkins element"),
          plain="hysteresis (a Jenkins element)"),
    Cause("micro_slip", "micro-slip: an Iwan element (Segalman's four-parameter distribution of Jenkins elements, "
          f"chi = {IWAN_CHI}, beta = {IWAN_BETA}), as in bolted and clamped joints",
          _with_iwan, "iwan_slip_torque_Nm", 1,
          bounds=lambda runs: (1e-3 * _amplitude(runs), 2.0 * _largest_amplitude(runs)), log_scale=True,
          profiled="iwan_slip_angle_rad", degenerate=_below_resolution("largest slip angle", "an Iwan element"),
          plain="micro-slip (an Iwan element)"),
    Cause("stribeck_friction", "dry friction with a Stribeck peak: static friction above the sliding one, falling "
          "off with the rate (velocity weakening)",
          _with_stribeck, "stribeck_torque_Nm", 2,
          bounds=lambda runs: (0.02 * min(rate_amplitudes(runs)), 2.0 * max(rate_amplitudes(runs))), log_scale=True,
          profiled="stribeck_velocity_rad_s", reduces_to="coulomb_friction", places=_JOINT_GROUND,
          degenerate=_stribeck_degenerate, plain="dry friction with a Stribeck peak"),
    Cause("quadratic_damping", "damping torque proportional to the rate squared",
          lambda s, h: _with_terms(s, (QuadraticDamping(),)), "quadratic_damping_Nms2_per_rad2", 1,
          places=_JOINT_GROUND, plain="quadratic damping"),
    Cause("drive_delay", "the drive acts later than it is recorded: a phase lag growing linearly with frequency",
          lambda s, h: replace(s, drive_delay_s=float(h)), DRIVE_DELAY, 0,
          bounds=lambda runs: (0.0, 0.1 * min(2 * math.pi / r.average.omega_rad_s for r in runs)),
          profiled=DRIVE_DELAY, places=frozenset({"oscillator", "drive"}), plain="a lag of the drive"),
    Cause("bearing_friction", "viscous drag of a flywheel to ground (not through the joint)",
          lambda s, h: replace(s, bearings=True), "bearing_damping_Nms_per_rad", 2,
          places=frozenset({"flywheel"}), magnitude_parts=(BEARING1, BEARING2), magnitude_is="largest",
          plain="bearing drag"),
    Cause("angle_offset", "measurement: the zero of the relative angle is off (an encoder's zero); under a cubic "
          "term it creates even harmonics as an asymmetric spring would",
          lambda s, h: replace(s, angle_offset_rad=float(h)), "angle_offset_rad", 0,
          bounds=lambda runs: (-_zero_bound(runs), _zero_bound(runs)), nonnegative=False,
          profiled="angle_offset_rad", kind="measurement", plain="an angle sensor's zero offset"),
    Cause("angle_skew", "measurement: flywheel 2's angle is read later (or earlier) than the torque and flywheel 1's "
          "angle (a multiplexed DAQ's channel skew, a filter's group delay)",
          lambda s, h: replace(s, angle2_delay_s=float(h)), "angle2_delay_s", 0,
          bounds=lambda runs: (-_skew_bound(runs), _skew_bound(runs)), nonnegative=False,
          profiled="angle2_delay_s", kind="measurement", first_only=True, places=frozenset({"channel"}),
          plain="a time skew"),
    Cause("angle_gain", "measurement: flywheel 2's angle reads a fixed factor too large or too small (an encoder's "
          "lines per revolution or a gear ratio set wrong)",
          lambda s, h: replace(s, angle2_gain_error=float(h)), "angle2_gain_error", 0,
          bounds=lambda runs: (-ANGLE_GAIN_TOLERANCE, ANGLE_GAIN_TOLERANCE), nonnegative=False,
          profiled="angle2_gain_error", kind="measurement", first_only=True,
          places=frozenset({"channel"}), plain="a scale error"),
    # Laws of the one-coordinate oscillator's extension (the Silverbox: y'' + law(y, y') = u),
    # not sought at a joint.
    Cause("quintic_stiffness", "stiffening beyond cubic: odd lines growing with amplitude",
          lambda s, h: _with_terms(s, (Power(5),)), "p5_Nm_per_rad5", 1, nonnegative=False, places=_OSCILLATOR,
          plain="a quintic stiffness"),
    Cause("cubic_damping", "damping growing with the rate, x'^3",
          lambda s, h: _with_terms(s, (Monomial(0, 3),)), "c_p0_q3", 1, nonnegative=False, places=_OSCILLATOR,
          plain="cubic damping"),
    Cause("amplitude_damping", "damping growing with the amplitude, x^2 x'",
          lambda s, h: _with_terms(s, (Monomial(2, 1),)), "c_p2_q1", 1, nonnegative=False, places=_OSCILLATOR,
          plain="damping growing with the amplitude"),
    Cause("cogging", "a torque periodic in the angle, A sin(z phi + p): a gear's mesh, a motor's cogging, detents; "
          "z periods per revolution",
          _with_cogging, "cogging_amplitude_Nm", 2, bounds=_cogging_bounds, profiled="cogging_order_rad_per_rad",
          grid_step=lambda runs: COGGING_GRID / _largest_amplitude(runs), places=_JOINT_GROUND,
          trials=_cogging_trials, magnitude_parts=("cogging_sin_Nm", "cogging_cos_Nm"), bounds_read_smallest=True,
          plain="a torque periodic in the angle (cogging, a gear mesh)"),
)


def at(*places: str) -> tuple[Cause, ...]:
    """The catalogue's causes sought at any of ``places`` (``Cause.places``), in catalogue order."""
    return tuple(c for c in CATALOGUE if c.places & set(places))


#: The one-coordinate oscillator's candidate extensions (scripts/silverbox.py): an even and a
#: quintic stiffness, damping growing with the rate or with the amplitude, a late input.
OSCILLATOR_CAUSES: tuple[Cause, ...] = at("oscillator")


def by_name(name: str) -> Cause:
    """The catalogued cause called ``name``."""
    for c in CATALOGUE:
        if c.name == name:
            return c
    raise KeyError(f"no cause {name!r}; the catalogue has {[c.name for c in CATALOGUE]}")


def chi2_survival(x: float, dof: int) -> float:
    """P(X > x) for X chi-square distributed with ``dof`` degrees of freedom (a whole number >= 1:
    the parameters a cause adds): ``scipy.special.chdtrc``."""
    if not (isinstance(dof, (int, np.integer)) and dof >= 1):
        raise ValueError(f"chi2_survival: dof must be a whole number >= 1, got {dof!r}")
    from scipy.special import chdtrc

    return float(chdtrc(dof, x)) if x > 0 else 1.0


def effective_dof(energies, nu: float) -> float:
    """The degrees of freedom of the weights under a drop in chi-square (Satterthwaite):
    ``energies`` per group of rows that share one variance estimate of ``nu`` degrees of freedom
    (a run's harmonic of one equation: its cosine and sine rows), each the weighted square of
    what the cause changes in those rows' fitted values (they sum to the drop). A drop in one
    group carries that group's ``nu`` alone; spread evenly over K groups, K nu. inf where
    nothing changes or ``nu`` is not finite."""
    return max(satterthwaite(energies, nu), float(nu))


def _drop_scale(nu: float, nu_eff: float) -> float:
    """What a drop in the corrected chi-square is multiplied by before its test (see
    :func:`evidence`): 1 in one group of rows; ``(nu - 4) / (nu - 2)`` spread over many (``nu``
    held at 6 or more: below, the drop's mean is not finite)."""
    if not (math.isfinite(nu) and math.isfinite(nu_eff)):
        return 1.0
    n = max(nu, 6.0)
    return 1.0 - 2.0 / (n - 2.0) * (1.0 - nu / nu_eff)


def _drop_threshold(q: int, level: float, nu: float = math.inf, nu_eff: float = math.inf) -> float:
    """The drop in (corrected) chi-square that a cause of ``q`` parameters exceeds with
    probability ``level`` when absent (see :func:`evidence`)."""
    from scipy.stats import chi2, f

    if not (math.isfinite(nu_eff) and nu_eff > 2.0):
        return float(chi2.isf(level, q))
    return float(q * (nu_eff - 2.0) / nu_eff * f.isf(level, q, nu_eff)) / _drop_scale(nu, nu_eff)


def evidence(delta_chi2: float, q: int, n_rows: int, alpha: float = DEFAULT_ALPHA, n_causes: float = 1,
             nu: float = math.inf, nu_eff: float = math.inf) -> tuple[float, float, bool]:
    """One evidence measure for every pipeline: a cause with ``q`` parameters lowers chi-square
    by ``delta_chi2`` over ``n_rows`` equations. Returns ``(score, p, significant)``: the BIC
    score ``delta - q ln(n_rows)`` (twice the log Bayes factor against the model without it),
    the probability of a drop this large without the cause, and whether it is significant at the
    family-wise ``alpha`` over ``n_causes`` (Bonferroni) with a positive score.

    With known weights the drop is chi-square(q). With each group of rows weighted by a variance
    estimated from ``nu`` degrees of freedom (the periods' spread), and ``nu_eff`` those of the
    drop (:func:`effective_dof`), the drop is heavier-tailed and larger: in one group it is
    ``q (nu - 2) / nu F(q, nu)`` (the chi-square's correction keeps its mean at q); spread over
    many, the weights that fit it also weigh it, and its mean grows to ``q (nu - 2) / (nu - 4)``
    (1.33 q at six periods). It is scaled back (:func:`_drop_scale`) and tested as
    ``q (nu_eff - 2) / nu_eff F(q, nu_eff)``: false alarms 1.0-1.8 times alpha at nu = 10 where
    chi-square(q) gave 1.7-5.4 times at alpha = 1e-2..1e-3
    (``tests/test_causes.py::test_a_drop_with_estimated_weights_is_tested_near_its_level``).
    A cause that adds no parameter (``q = 0``: it is in the model already, as dry friction is in
    a Stribeck law) is never significant, whatever round-off its refit leaves in ``delta_chi2``."""
    if q <= 0:
        return float(delta_chi2), 1.0, False
    if math.isfinite(nu_eff) and nu_eff > 2.0:
        from scipy.stats import f

        scaled = max(delta_chi2, 0.0) * _drop_scale(nu, nu_eff)
        p = float(f.sf(scaled / (q * (nu_eff - 2.0) / nu_eff), q, nu_eff))
    else:
        p = chi2_survival(max(delta_chi2, 0.0), q)
    score = delta_chi2 - q * math.log(n_rows)
    return float(score), p, bool(p < alpha / n_causes and score > 0)


def resolved(size: float, std_error: float, alpha: float = DEFAULT_ALPHA) -> bool:
    """Whether a cause's size is told from zero by its standard error at the level ``alpha``
    (two-sided, the normal quantile: 3.29 standard errors at 1e-3) (pure). A richer cause whose
    extra parameters lower chi-square significantly may still not resolve what makes it richer: a
    Stribeck excess of 25.5 +- 13.0 N m beside a sliding friction of 34.8 +- 12.9 is level
    friction by another name (:func:`identify.chain_diagnose._reduced`)."""
    from scipy.stats import norm

    return bool(math.isfinite(size) and math.isfinite(std_error) and abs(size) > norm.isf(alpha / 2) * std_error)


#: The probability with which a cause at its detection limit is found (:func:`detection_limit`).
DETECTION_POWER = 0.95


def detection_limit(score: "CauseScore", n_rows: int, alpha: float = DEFAULT_ALPHA, n_causes: float = 1) -> float:
    """The smallest size of a cause that these data would have found significant with
    probability :data:`DETECTION_POWER` (pure): its drop in chi-square is about ``(m / SE)^2``
    (non-central chi-square), and :func:`evidence` asks it to pass both its quantile at
    ``alpha / n_causes`` (chi-square(q), or the scaled F of the score's ``nu_eff``) and the BIC's ``q ln(n_rows)``; so ``m = SE (sqrt(threshold)
    + z)`` with ``z`` the normal quantile of the power, from the magnitude's standard error where
    it was scored. NaN where the score holds no finite standard error (a cause rejected, or one
    without a size)."""
    from scipy.stats import norm

    if not score.magnitude or score.n_params <= 0:
        return math.nan
    se = float(score.magnitude[2])
    if not (math.isfinite(se) and se > 0):
        return math.nan
    q = score.n_params
    threshold = max(_drop_threshold(q, alpha / n_causes, score.nu, score.nu_eff), q * math.log(n_rows))
    return se * (math.sqrt(threshold) + float(norm.isf(1.0 - DETECTION_POWER)))


def harmonic_shares(row_drop: np.ndarray, row_harmonic: np.ndarray) -> dict:
    """Where a cause's improvement lies, for every diagnosis: the share of its chi-square drop
    ``row_drop`` (per balance row) on the mean, the fundamental, the even harmonics and the odd
    ones from 3 up (``row_harmonic``: each row's harmonic)."""
    h = np.asarray(row_harmonic)
    classes = {"mean": h == 0, "fundamental": h == 1, "even": (h % 2 == 0) & (h > 0), "odd>=3": (h % 2 == 1) & (h > 1)}
    total = float(np.sum(row_drop)) or 1.0
    return {k: float(np.sum(row_drop[m]) / total) for k, m in classes.items()}


def fundamental_quadrature(torques: Sequence[np.ndarray], motions: Sequence[np.ndarray]) -> Optional[float]:
    """How dissipative a cause's own torque is along the measured motion, over the runs (one period
    each): at the fundamental, 0 in phase with the motion (elastic), 1 in quadrature
    (dissipative); None when it has no fundamental."""
    num = den = 0.0
    for torque, motion in zip(torques, motions):
        T1, P1 = np.fft.rfft(torque)[1], np.fft.rfft(motion)[1]
        num += abs((T1 * np.conj(P1)).imag)
        den += abs(T1) * abs(P1)
    return float(num / den) if den > 0 else None


@dataclass(frozen=True)
class Place:
    """Where in a train a cause is sought: ``"joint"`` j (its twist), ``"flywheel"`` i (a viscous
    drag to ground, a bearing), ``"ground"`` i (body i's own law to the frame), ``"channel"`` i
    (body i's angle sensor) or ``"drive"`` (the drives' channels, number None)."""

    kind: str
    number: Optional[int]

    def __post_init__(self):
        if self.kind not in PLACE_WORDS:
            raise ValueError(f"a place is one of {sorted(PLACE_WORDS)}, got {self.kind!r}")

    def describe(self) -> str:
        """Where, in a label's words: "at joint 2", "to ground at body 1", "at the drives"."""
        return PLACE_WORDS[self.kind].format(n=self.number)

    @property
    def at_joint(self) -> bool:
        return self.kind == "joint"

    @property
    def to_ground(self) -> bool:
        """Body i's own law to the frame."""
        return self.kind == "ground"

    @property
    def at_bearing(self) -> bool:
        """A flywheel's viscous drag to ground."""
        return self.kind == "flywheel"

    @property
    def at_drive(self) -> bool:
        return self.kind == "drive"

    @property
    def at_channel(self) -> bool:
        return self.kind == "channel"


#: How each kind of place reads in a cause's label (``{n}``: its number).
PLACE_WORDS = {"joint": "at joint {n}", "flywheel": "at flywheel {n}", "ground": "to ground at body {n}",
               "channel": "at body {n}'s angle channel", "drive": "at the drives"}


@dataclass(frozen=True)
class CauseScore:
    """The evidence for one cause on top of a base model, in every diagnosis (two flywheels, a
    train; ``where`` says where in a train, None on the two-flywheel joint).

    Attributes:
      effect: the cause's name; delta_chi2: the drop in (corrected) chi-square it brings;
      n_params: parameters it adds (its nonlinear one included); score: ``delta_chi2 - n_params
      ln(n_rows)``, the ranking (BIC); p_value: of ``delta_chi2`` if the cause were absent
      (:func:`evidence`: chi-square(n_params), or the scaled F of estimated weights); significant: by :func:`evidence` and no rule rejected it (``note``
      says why one did); fit: the extended fit; magnitude: ``(name, value, standard error)`` of
      the size parameter; signature: where the drop lies (the two-flywheel diagnosis: share by
      harmonic class and the dissipative share), {} where not measured.
    """

    effect: str
    delta_chi2: float
    n_params: int
    score: float
    p_value: float
    significant: bool
    fit: object
    magnitude: tuple
    signature: dict = field(default_factory=dict)
    #: why a rule rejected it although the evidence is significant (:data:`Rejection`), or None
    note: Optional[Rejection] = None
    where: Optional[Place] = None
    #: the degrees of freedom of each row group's weight, and the drop's (:func:`effective_dof`;
    #: inf: weights taken as known)
    nu: float = math.inf
    nu_eff: float = math.inf

    @property
    def label(self) -> str:
        """The cause, and where: ``backlash at joint 2`` (the name alone on two flywheels)."""
        return self.effect if self.where is None else f"{self.effect} {self.where.describe()}"

    @property
    def place(self) -> Optional[int]:
        return None if self.where is None else self.where.number

    @property
    def at_joint(self) -> bool:
        return self.where is None or self.where.at_joint

    @property
    def ground(self) -> bool:
        return self.where is not None and self.where.to_ground

    def as_json(self) -> dict:
        """The score in a diagnosis's JSON (``present.diagnosis_json.CAUSE_KEYS``): ``place`` is
        ``{"kind", "number"}`` in a train, null on the two-flywheel joint; ``note`` is null here, its
        words are the report's (:func:`present.diagnosis_json.cause_json`)."""
        return {"label": self.label, "effect": self.effect,
                "place": None if self.where is None else {"kind": self.where.kind, "number": self.where.number},
                "score": self.score, "significant": self.significant, "delta_chi2": self.delta_chi2,
                "n_params": self.n_params, "p_value": self.p_value,
                "magnitude": {"name": self.magnitude[0], "value": self.magnitude[1], "std_error": self.magnitude[2]},
                "signature": dict(self.signature), "note": None,
                "parameters": self.fit.parameters() if self.fit is not None else {}}


#: Why no drive is named to tell two causes apart (:attr:`Ambiguity.unplaced`): one is a body's
#: law to ground (no linearised drive information for it), a channel's lag or scale (not a
#: place on the line), or both act at the same place (every drive moves them alike).
TO_GROUND, AT_CHANNEL, SAME_PLACE = "to_ground", "at_channel", "same_place"


@dataclass(frozen=True)
class Ambiguity:
    """Two causes (in a train: causes at places) the data cannot tell apart, and what would:
    ``separating_drive``, the body whose drive tells them apart best, with ``information``
    ``((body, Fisher information per run), ...)`` best first; or, where no drive is computed,
    why (``unplaced``: :data:`TO_GROUND`, :data:`AT_CHANNEL`, :data:`SAME_PLACE`); two causes at
    one place are told apart by other runs, not by another drive location: ``excitation`` says
    which (:data:`SEPARATING_EXCITATION`). Its words: :func:`present.notes.separation_text`."""

    effects: tuple
    separating_drive: Optional[int] = None
    information: tuple = ()
    unplaced: str = ""
    excitation: str = ""


Base = TypeVar("Base")
Score = TypeVar("Score")
T = TypeVar("T")


@dataclass(frozen=True)
class Selection(Generic[Base, Score]):
    """What :func:`forward_select` chose.

    Attributes:
      base: the final model (whatever the pipeline's base is: a fit and its weights).
      adopted: the adopted causes' scores, in the order adopted.
      rounds: every round's scores, best first (the first round's rank the causes against the
        nominal model).
    """

    base: Base
    adopted: tuple
    rounds: tuple


def forward_select(base: Base, causes: Sequence[Cause], *,
                   rank: Callable[[Base, list, int], Sequence[Score]],
                   adopt: Callable[[Base, Sequence[Score]], Optional[tuple[Score, Base]]],
                   max_effects: int,
                   after: Optional[Callable[[Base, Score, Sequence[Score], list], None]] = None,
                   name_of: Callable[[Score], str] = lambda s: s.effect) -> Selection:
    """The one extension loop of every pipeline: greedy forward selection over ``causes``.

    Each round ``rank(base, remaining causes, round)`` scores the causes not yet adopted on the
    present model, best first; ``adopt(base, ranked)`` returns the cause it takes with the
    extended (refitted) model, or None to stop. What earns adoption is the pipeline's own: the
    diagnosis (:func:`identify.chain_diagnose.diagnose_chain`) takes the best significant
    :func:`evidence` (its harmonic-balance fits are cheap; the simulated held-out runs judge
    the result afterwards, :mod:`studies.chain_validate`); the oscillator's extension
    (:func:`identify.extend.extend_model`) tries causes in order of evidence and takes the first
    that lowers the simulation error on held-out records (each trial is a full output-error fit).
    A cause adopted leaves the pool, and so does every ``first_only`` cause (sought only against
    the nominal model). ``after(base, adopted, ranked, remaining)`` may look at the round once
    the cause is adopted (the diagnosis checks its rivals there). At most ``max_effects`` rounds
    adopt a cause; the loop also stops when no cause is left.
    """
    remaining = list(causes)
    adopted: list = []
    rounds: list = []
    for rnd in range(max_effects):
        if not remaining:
            break
        ranked = tuple(rank(base, remaining, rnd))
        rounds.append(ranked)
        pick = adopt(base, ranked)
        if pick is None:
            break
        chosen, base = pick
        adopted.append(chosen)
        remaining = [c for c in remaining if c.name != name_of(chosen) and not c.first_only]
        if after is not None:
            after(base, chosen, ranked, remaining)
    return Selection(base, tuple(adopted), tuple(rounds))


#: A profile search's grid of trial values over the cause's bounds (log-spaced for a log-scale
#: parameter), then Brent's bounded search between the best grid point's neighbours to this
#: fraction of the range. A coarser search changes the adopted magnitudes beyond 1e-6 of
#: themselves (``scripts/bench_diagnose.py --coarse-search``).
PROFILE_GRID_POINTS = 17
PROFILE_XATOL = 1e-6
#: Local minima of the grid searched further (the best first).
PROFILE_BASINS = 2
#: Passes of a profiled parameter's standard error over +-1 standard error (:func:`profile`),
#: and the relative change at which two passes agree.
PROFILE_SE_PASSES = 3
PROFILE_SE_AGREE = 0.1


#: A profile's best value within this share of its search range (in the search's coordinate:
#: log for a log-scale parameter) of an end lies on that end; Brent's search stops within
#: PROFILE_XATOL of it, a hundredth of this.
ON_BOUND_SHARE = 1e-4


def on_search_bound(value: float, lo: float, hi: float, log_scale: bool = False) -> str:
    """``"lower"`` or ``"upper"`` where a profile's best ``value`` lies on that end of its search
    range [lo, hi] (:data:`ON_BOUND_SHARE`), else ``""`` (pure). On a bound the runs do not
    rule out a value beyond it, and the standard error is chi-square's curvature on one side:
    a carriage's Stribeck speed read 0.0676 +- 0.0003 m/s on the lower end of its search, the
    truth 0.01 (``scripts/bench_stribeck.py``)."""
    if not (math.isfinite(value) and math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        return ""
    if log_scale and lo > 0 and value > 0:
        value, lo, hi = math.log(value), math.log(lo), math.log(hi)
    tol = ON_BOUND_SHARE * (hi - lo)
    return "lower" if value <= lo + tol else "upper" if value >= hi - tol else ""


@dataclass(frozen=True)
class Profiled(Generic[T]):
    """A profile search's result: the best value of the nonlinear parameter, the fit there, and
    the parameter's standard error from the curvature of chi-square (NaN if it is not convex)."""

    value: float
    fit: T
    std_error: float
    #: d(linear parameters)/d(value) along the profile (the fits' ``values`` either side), for
    #: the linear parameters' standard errors with the profiled one's uncertainty carried in
    #: (:func:`widened`); None where the fits hold no ``values``
    slope: Optional[np.ndarray] = None



def widened(fit: T, slopes: Sequence[np.ndarray], errors: Sequence[float], correlation: Optional[np.ndarray] = None
            ) -> T:
    """``fit`` with each linear parameter's variance (and covariance) widened by what the profiled
    parameters' own uncertainty moves it (pure): ``+ G S G^T``, ``G`` the slopes
    (:attr:`Profiled.slope`, one column each), ``S`` their covariance: ``errors`` and their
    ``correlation`` (default none); first order. At fixed profiled values the fit alone
    understates them: a Stribeck excess read 4.75 +- 0.12 N against a true 10 N. A parameter
    without a finite error is left out; without a covariance the fit is returned as it is. A fit
    with its errors' degrees of freedom (``std_error_dofs``) has them raised by the added part,
    taken as known."""
    keep = [k for k, e in enumerate(errors) if math.isfinite(e)]
    if not keep or getattr(fit, "covariance", None) is None:
        return fit
    R = np.eye(len(errors)) if correlation is None else np.asarray(correlation, dtype=float)
    GS = np.column_stack([slopes[k] for k in keep]) * np.array([errors[k] for k in keep])
    extra = GS @ R[np.ix_(keep, keep)] @ GS.T
    before = np.asarray(fit.std_errors, dtype=float) ** 2
    after = before + np.clip(np.diag(extra), 0.0, None)
    out = replace(fit, covariance=np.asarray(fit.covariance) + extra, std_errors=np.sqrt(after))
    dofs = getattr(fit, "std_error_dofs", None)
    if dofs is None:
        return out
    # the profiled errors' part taken as known (Welch-Satterthwaite): the estimated part's share
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(before > 0, after / before, 1.0)
    return replace(out, std_error_dofs=np.asarray(dofs, dtype=float) * share ** 2)


#: Newton steps :func:`joint_minimum` takes at most on several profiled parameters together, and
#: the share of each one's standard error below which a step ends the search.
JOINT_STEPS = 3
JOINT_STEP_TOL = 0.05


@dataclass(frozen=True)
class JointMinimum:
    """Several profiled parameters together (:func:`joint_minimum`): their values at chi-square's
    joint minimum, what each one's standard error (given the others) is multiplied by to be
    marginal, and their correlation matrix."""

    values: np.ndarray
    widen: np.ndarray
    correlation: np.ndarray


def joint_minimum(chi2: Callable[[np.ndarray], float], values, errors, lo, hi) -> JointMinimum:
    """Profiled parameters, each searched one at a time (:func:`profile`: ``values`` with their
    ``errors``, chi-square's curvature along each alone), moved together to chi-square's joint
    minimum within [lo, hi], and their errors made marginal (pure but for ``chi2``'s calls).
    Searched one at a time, two parameters that chi-square couples stop short of the minimum,
    and each one's error is its error given the others: two twist zeros of a 3-body train under
    mean loads, correlated 0.97 through the equation of the body between them, stopped 8 and 9
    of those errors off the truth (0.4 and 0.5 of the marginal errors at the joint minimum).
    From chi-square over +-1 error of each parameter and each pair (the errors' own scale: a
    law's kink makes chi-square rough on a smaller one): Newton steps (:data:`JOINT_STEPS`, each
    kept only where chi-square falls), then each error times ``sqrt(H_ii (H^-1)_ii)``. Where the
    Hessian is not positive definite the values stay and nothing is widened."""
    h, e = np.array(values, dtype=float), np.array(errors, dtype=float)
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    p = h.size

    def curvature(x):
        c0 = chi2(x)
        unit = np.eye(p) * e
        plus, minus = np.array([chi2(x + u) for u in unit]), np.array([chi2(x - u) for u in unit])
        H = np.diag((plus - 2 * c0 + minus) / e**2)
        for i in range(p):
            for j in range(i + 1, p):
                c = [chi2(x + a * unit[i] + b * unit[j]) for a, b in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
                H[i, j] = H[j, i] = (c[0] - c[1] - c[2] + c[3]) / (4 * e[i] * e[j])
        return c0, (plus - minus) / (2 * e), H

    def definite(H) -> bool:
        return bool(np.all(np.isfinite(H)) and np.all(np.linalg.eigvalsh(H) > 0))

    c0, g, H = curvature(h)
    for _ in range(JOINT_STEPS):
        if not definite(H):
            break
        x = np.clip(h - np.linalg.solve(H, g), lo, hi)
        if np.all(np.abs(x - h) < JOINT_STEP_TOL * e) or not chi2(x) < c0:
            break
        h = x
        c0, g, H = curvature(h)
    if not definite(H):
        return JointMinimum(h, np.ones(p), np.eye(p))
    inv = np.linalg.inv(H)
    d = np.diag(inv)
    return JointMinimum(h, np.sqrt(np.diag(H) * d), inv / np.sqrt(np.outer(d, d)))


def profile(solve: Callable[[float], T], cause: "Cause", lo: float, hi: float, *,
            objective: Callable[[T], float] = lambda f: f.chi2,
            solve_aside: Optional[Callable[[float], T]] = None, points: int = PROFILE_GRID_POINTS) -> "Profiled[T]":
    """The one profile search of every diagnosis over a cause's nonlinear parameter in [lo, hi]:
    ``solve(h)`` fits the model extended with the cause at ``h`` (the caller's fit type, with
    ``chi2`` and ``dof``); ``objective`` is what is minimised (chi-square, or a caller's penalty
    of the unphysical region). A grid of ``points`` (:meth:`Cause.grid_points`; log-spaced for a
    log-scale cause), Brent's bounded search between the neighbours of each of its best
    :data:`PROFILE_BASINS` local minima to :data:`PROFILE_XATOL` of the range; the standard error from chi-square's curvature (it rises
    by 1 at one standard error; scaled like the linear ones when the fit is worse than the noise),
    by a central difference in the parameter itself (one-sided at a bound), first at
    1e-3 of the value, then over +-1 standard error until two passes agree
    (:data:`PROFILE_SE_PASSES`), solved by
    ``solve_aside`` (default ``solve``: a caller that warm-starts each trial from the nearest one
    keeps these off its record)."""
    from scipy.optimize import minimize_scalar

    back, (a, b) = (math.exp, (math.log(lo), math.log(hi))) if cause.log_scale else (float, (lo, hi))
    cache: dict = {}

    def obj(u):
        h = back(u)
        if h not in cache:
            cache[h] = solve(h)
        return objective(cache[h])

    grid = np.linspace(a, b, points)
    vals = np.array([obj(u) for u in grid])
    # Brent's search between the neighbours of each of the best PROFILE_BASINS local minima of the
    # grid: chi-square over a slip angle or a gap has several basins, and the best grid point may
    # sit in the shallower one (an Iwan slip angle on the chain bench: 0.026 rad, chi2 1055, from
    # the best grid point; 0.0099 rad, chi2 964, from the second; the truth 0.01)
    lows = [k for k in range(grid.size) if vals[k] <= vals[max(k - 1, 0)] and vals[k] <= vals[min(k + 1, grid.size - 1)]]
    for k in sorted(lows, key=lambda k: vals[k])[:PROFILE_BASINS]:
        minimize_scalar(obj, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]), method="bounded",
                        options={"xatol": PROFILE_XATOL * (b - a)})
    h = min(cache, key=lambda x: objective(cache[x]))
    best = cache[h]
    step = max(1e-3 * abs(h), 1e-6 * (hi - lo))

    aside = solve_aside or solve

    def second_difference(s: float):
        """chi-square's second difference over ``s`` about ``h`` (central; one-sided at a bound),
        and the two fits a slope is taken between with their distance; None where neither fits
        in [lo, hi]."""
        if h - s >= lo and h + s <= hi:
            below, above = aside(h - s), aside(h + s)
            return below.chi2 - 2 * best.chi2 + above.chi2, (below, above, 2 * s)
        if h - s < lo and h + 2 * s <= hi:
            one, two = aside(h + s), aside(h + 2 * s)
            return two.chi2 - 2 * one.chi2 + best.chi2, (best, one, s)
        if h + s > hi and h - 2 * s >= lo:  # on the upper bound: backward (a twist's zero on its
            # 0.01 rad bound read 1.6e-5 rad from a central difference across it)
            one, two = aside(h - s), aside(h - 2 * s)
            return two.chi2 - 2 * one.chi2 + best.chi2, (one, best, s)
        return None

    scale = max(1.0, best.chi2 / max(best.dof, 1))
    first = second_difference(step)
    ends = first[1] if first else (best, best, step)
    se = math.sqrt(2.0 / (first[0] / step**2) * scale) if first and first[0] > 0 else math.nan
    if not math.isfinite(se):  # a flat or noisy valley: where chi-square rises by one, from the trials
        se = _half_width({x: objective(f) for x, f in cache.items()}, h, objective(best) + scale, lo, hi)
    # Again over +-1 standard error, until two passes agree: chi-square is quadratic on the scale
    # of its rise by one, not always at 1e-3 of the value, where a kink of the law (a free play's
    # contact) makes it rough (a free play's twist zero: 0.63 mrad at the small step, 2.4 mrad
    # over +-1 SE, and 16 seeds of the independent bench put the truth up to 6.2 of the former
    # off)
    for _ in range(PROFILE_SE_PASSES if math.isfinite(se) else 0):
        again = second_difference(se)
        if again is None or again[0] <= 0:
            break
        wider = math.sqrt(2.0 / (again[0] / se**2) * scale)
        settled = abs(wider / se - 1.0) < PROFILE_SE_AGREE
        se, ends = wider, again[1]
        if settled:
            break
    slope = None
    if getattr(best, "values", None) is not None and np.shape(ends[0].values) == np.shape(ends[1].values):
        slope = (np.asarray(ends[1].values, dtype=float) - np.asarray(ends[0].values, dtype=float)) / ends[2]
    return Profiled(h, best, se, slope)


def _half_width(tried: dict, h: float, level: float, lo: float, hi: float) -> float:
    """Half the width of the interval about ``h`` where the profile's objective stays below
    ``level`` (its minimum plus one, scaled as the standard errors are), from the values
    ``tried`` (parameter -> objective), each side interpolated linearly to the crossing, or taken
    to the range's end ``lo``/``hi`` where no trial rises above it; NaN where none does on
    either side (flat across the range: not determined) (pure). The standard error of
    a profiled parameter whose chi-square is not convex at its best value: a Stribeck speed that
    the runs fix only in its product with the excess read NaN, and the excess's error stayed that
    of a fixed speed (1.23 +- 0.29 N against a true 10)."""
    xs = sorted(tried)

    def crossing(side: list) -> Optional[float]:  # side: from h outward
        inner = h
        for x in side:
            if tried[x] > level:
                v0, v1 = tried.get(inner, level - 1.0), tried[x]
                return inner + (x - inner) * (level - v0) / (v1 - v0) if v1 != v0 else x
            inner = x
        return None

    left = crossing([x for x in reversed(xs) if x < h])
    right = crossing([x for x in xs if x > h])
    if left is None and right is None:  # flat across the whole range: not determined
        return math.nan
    return ((right if right is not None else hi) - (left if left is not None else lo)) / 2.0


def parsimonious(ranked: list, by_name: dict, n_rows: int, alpha: float, *, name_of=lambda s: s.effect,
                 place_of=lambda s: None) -> list:
    """The ranking with each cause that reduces to a simpler one (``Cause.reduces_to``) placed
    right after it, when the simpler one (at the same place) is significant too and the richer
    one's extra parameters do not lower chi-square significantly beyond it (a nested test: the
    difference of the two drops against chi-square with the difference of their parameter
    counts). A Stribeck friction whose peak the data do not show then never names the extension:
    pure dry friction is named dry friction. ``ranked``: scores with ``delta_chi2``, ``n_params``
    and ``significant``; ``name_of`` and ``place_of`` read a score's cause name and place."""
    out = list(ranked)
    for richer in ranked:
        cause = by_name.get(name_of(richer))
        simpler = next((s for s in out if cause is not None and name_of(s) == cause.reduces_to and s.significant
                        and place_of(s) == place_of(richer)), None)
        if simpler is None or out.index(richer) > out.index(simpler):
            continue
        _, _, extra = evidence(richer.delta_chi2 - simpler.delta_chi2, richer.n_params - simpler.n_params, n_rows,
                               alpha)
        if not extra:
            out.remove(richer)
            out.insert(out.index(simpler) + 1, richer)
    return out


#: Largest zero error of the relative angle that a bench plausibly has (rad): about 0.6 degree.
#: A larger apparent offset is not sought as a sensor error (it would be a preloaded joint).
ANGLE_ZERO_TOLERANCE_RAD = 0.01


#: Largest channel skew sought, as a share of the shortest period: a skew of a few percent of a
#: period is a DAQ's or a filter's; more would be a wiring or clock fault, not a timing detail.
ANGLE_SKEW_SHARE = 0.05


#: Largest scale error of flywheel 2's angle sought (relative): a gear ratio or line count off by
#: up to 20%. A torque sensor's gain error is not sought: it scales every parameter of both
#: equations alike (inertias, damping, stiffness) and no data without a reference can see it;
#: flywheel 1's angle's is the same as flywheel 2's and the torque's together, so one is enough.
ANGLE_GAIN_TOLERANCE = 0.2


def _skew_bound(runs) -> float:
    return ANGLE_SKEW_SHARE * min(2 * math.pi / r.average.omega_rad_s for r in runs)


def _zero_bound(runs) -> float:
    return min(ANGLE_ZERO_TOLERANCE_RAD, 0.1 * _amplitude(runs))

#: Magnitudes without a unit (a relative scale error: recorded over true, minus 1).
DIMENSIONLESS = frozenset({"angle2_gain_error"})

#: What excitation separates two causes the data cannot tell apart.
SEPARATING_EXCITATION = {
    frozenset({"cubic_damping", "amplitude_damping"}): "multisines at several amplitude levels (the damping of one "
    "grows with rate, of the other with amplitude)",
    frozenset({"coulomb_friction", "hysteresis"}): "runs at small amplitude (below the slip angle a Jenkins "
    "element is a pure spring while dry friction still dissipates): add a low-amplitude run",
    frozenset({"hysteresis", "micro_slip"}): "runs at several small amplitudes (a Jenkins element dissipates "
    "nothing below its slip angle, an Iwan element a little at every amplitude, growing as A^(3 + chi))",
    frozenset({"coulomb_friction", "micro_slip"}): "runs at small amplitude (there an Iwan element is mostly a "
    "spring and dissipates as A^(3 + chi); dry friction dissipates 4 F A at every amplitude)",
    frozenset({"coulomb_friction", "stribeck_friction"}): "runs at low rates (an amplitude sweep at a low frequency: "
    "the Stribeck peak acts below its rate, where dry friction alone stays flat)",
    frozenset({"coulomb_friction", "quadratic_damping"}): "an amplitude sweep at one frequency (dry friction "
    "dissipates per cycle in proportion to amplitude, quadratic damping to amplitude cubed)",
    frozenset({"drive_delay", "quadratic_damping"}): "a frequency sweep at constant amplitude (a delay's "
    "phase grows linearly with frequency)",
    frozenset({"backlash", "asymmetric_stiffness"}): "runs at several amplitudes around the free play and a "
    "static preload test (free play is symmetric and vanishes in relative terms at large amplitude)",
    frozenset({"coulomb_friction", "backlash"}): "a low-amplitude run (inside the free play the joint "
    "transmits no elastic torque but still rubs)",
    frozenset({"asymmetric_stiffness", "angle_offset"}): "a reading of the relative angle at rest without torque "
    "(its true zero): under a cubic term gamma, an even term a phi^2 and an angle offset of -a / (3 gamma) give the "
    "same harmonics",
    frozenset({"bearing_friction", "drive_delay"}): "runs at several drive frequencies (at one frequency a "
    "delay tau and a drag b1 of flywheel 1 act alike, b1 = tau omega^2 (J1 + J2); the delay's phase grows "
    "with frequency, the drag's effect falls)",
}
DEFAULT_SEPARATION = ("a sweep over amplitude at fixed frequency and over frequency at fixed amplitude, "
                       "with every body's motion recorded")


def separating_excitation(one: str, two: str) -> str:
    """The runs that tell two causes (by name) apart: :data:`SEPARATING_EXCITATION`'s entry for the
    pair, else :data:`DEFAULT_SEPARATION`."""
    return SEPARATING_EXCITATION.get(frozenset({one, two}), DEFAULT_SEPARATION)


