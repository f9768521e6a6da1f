"""Harmonic balance for a drive train: N flywheels in a chain, N - 1 joints, all unknown.

Flywheel i (1..N) turns by ``phi_i``; joint j (1..N-1) joins flywheels j and j+1 and carries
the torque ``M_j(phi_j - phi_(j+1), phi_j' - phi_(j+1)')`` (its own law, any terms of
:mod:`vocab.law`). Flywheel i's equation of motion (paper eq. 1, one per flywheel) is

    J_i phi_i'' + b_i phi_i' + M_i - M_(i-1) = T_i(t),

with ``M_0 = M_N = 0``, ``b_i`` an optional drag to ground (bearing) and ``T_i`` the drive
torque on flywheel i (0 where there is no drive). Every unknown (all inertias, all law
parameters, the bearings) enters linearly, so balancing harmonics 0..H of every equation
gives [A]{S} = {F} as in the two-flywheel case (paper eq. 5-7).

**Block structure.** Flywheel i's rows touch only ``J_i``, ``b_i`` and the laws of joints
i-1 and i. With the unknowns ordered ``J_1, b_1, law_1, J_2, b_2, law_2, ..., J_N, b_N``
each flywheel's rows occupy one contiguous band of columns, so [A] is block-banded and is
reduced by a sequence of small QR factorisations, one per flywheel
(:func:`solve_banded`), at a cost linear in N; the p x p triangle left is then solved by SVD
for the condition number and the covariance (the same quantities as :func:`identify.solve.solve`).

**What the data identify.** A joint's law is a function of its relative angle, so both of its
flywheels' angles must be measured; a flywheel's equation needs its own angle and its
neighbours'. With every angle measured and a drive torque recorded on at least one flywheel,
all inertias and all laws are identifiable (the equations of flywheels 1..i determine joint
i's torque from the drive inwards). :func:`identifiability` says what is missing otherwise,
and :func:`chain_system` refuses such data with that reason.

Names: ``J{i}_kgm2``, ``bearing{i}_damping_Nms_per_rad`` and ``joint{j}_<term name>``
(``joint2_k_Nm_per_rad``), 1-based as on the drawing of the train.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional, Sequence

import numpy as np

from .estimates import equilibrated_condition
from .balance import LinearSystem, harmonic_rows, law_rows, memo_arrays, spectral_rate, upsample
from jointrig.vocab.law import Constant, JointLaw, Term
from jointrig.vocab.params import DRIVE_DELAY
from .harmonics import fourier_coefficients, max_harmonic, shift_periodic
from .periods import period_spectra, white_variance
from jointrig.vocab.records import RecordError, SteadyStateRecord, WholePeriods
from .solve import COND_WARN, IdentificationResult

__all__ = ["ChainRecord", "ChainSpec", "ChainIdentifiabilityError", "identifiability", "chain_system",
           "solve_banded", "identify_chain", "joint_law", "ChainPlant", "plant_of_values", "BandedSystem",
           "fisher_per_period", "row_covariance", "noise_cross_covariance", "constant_loads", "average_chain", "ml_identify_chain", "inertia_name", "bearing_name", "joint_prefix",
           "ground_prefix", "channel_corrected", "stick_mask", "rest_share", "rests", "sticks_to_ground", "jumps_at_rest", "STICK_RATE_FRACTION",
           "REST_RATE_FRACTION", "REST_DWELL"]


class ChainIdentifiabilityError(ValueError):
    """The measured angles and drives do not determine the unknowns (the message says why)."""


def inertia_name(i: int) -> str:
    return f"J{i}_kgm2"


def bearing_name(i: int) -> str:
    return f"bearing{i}_damping_Nms_per_rad"


def joint_prefix(j: int) -> str:
    return f"joint{j}_"


def ground_prefix(i: int) -> str:
    """Body i's law to ground (a guide's friction, a spring to ground): ``ground1_coulomb_torque_Nm``."""
    return f"ground{i}_"


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _opt_rows(name: str, rows, n: Optional[int], count: int, src: str) -> tuple:
    if rows is None:
        return (None,) * count
    rows = tuple(rows)
    if len(rows) != count:
        raise RecordError(f"{src}: '{name}' holds {len(rows)} channels, expected one per flywheel ({count})")
    out = []
    for i, r in enumerate(rows, start=1):
        if r is None:
            out.append(None)
            continue
        # a read-only float array is kept as it is (a record rebuilt with one channel replaced
        # shares the others, and the columns memoised by their identity)
        a = r if isinstance(r, np.ndarray) and r.dtype == np.float64 and not r.flags.writeable else np.array(r, dtype=float)
        if a.ndim != 1 or (n is not None and a.size != n):
            raise RecordError(f"{src}: '{name}' of flywheel {i} has shape {a.shape}, expected ({n},) like 'time_s'")
        if not np.all(np.isfinite(a)):
            raise RecordError(f"{src}: '{name}' of flywheel {i} holds non-finite values")
        a.setflags(write=False)
        out.append(a)
    return tuple(out)


@dataclass(frozen=True)
class ChainRecord(WholePeriods):
    """Whole periods of one steady-state run of a chain, sampled uniformly.

    Attributes:
      omega_rad_s: drive fundamental (rad/s).
      time_s: sample times (s), ``(n_samples,)``, whole periods (checked as for
        :class:`vocab.records.SteadyStateRecord`).
      torques_Nm: per flywheel 1..N, the drive torque applied to it (N m, ``(n_samples,)``), or
        None where no drive acts.
      angles_rad: per flywheel, its angle (rad), or None where it is not measured.
      rates_rad_s: per flywheel, its rate (rad/s), or None (spectral derivative of the angle).
      n_periods: whole periods held.
      drive_amplitude_Nm: nominal amplitude, for labels (NaN if unknown).
      source: where the record came from (used in error messages).
    """

    omega_rad_s: float
    time_s: np.ndarray
    torques_Nm: tuple
    angles_rad: tuple
    rates_rad_s: Optional[tuple] = None
    n_periods: int = 1
    drive_amplitude_Nm: float = float("nan")
    source: str = field(default="chain record", compare=False)

    def __post_init__(self):
        src = self.source
        N = len(tuple(self.angles_rad))
        if N < 1:
            raise RecordError(f"{src}: a chain has at least 1 body, got no angle channel")
        t = np.array(self.time_s, dtype=float)
        n = t.size
        angles = _opt_rows("angles_rad", self.angles_rad, n, N, src)
        torques = _opt_rows("torques_Nm", self.torques_Nm, n, N, src)
        rates = _opt_rows("rates_rad_s", self.rates_rad_s, n, N, src)
        # The clock check lives once, in SteadyStateRecord: whole periods, uniform samples.
        any_angle = next((a for a in angles if a is not None), None)
        if any_angle is None:
            raise RecordError(f"{src}: no angle is measured")
        SteadyStateRecord(self.omega_rad_s, t, np.zeros(n), any_angle, None, n_periods=self.n_periods, source=src)
        t.setflags(write=False)
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "angles_rad", angles)
        object.__setattr__(self, "torques_Nm", torques)
        object.__setattr__(self, "rates_rad_s", rates)
        object.__setattr__(self, "omega_rad_s", float(self.omega_rad_s))
        object.__setattr__(self, "n_periods", int(self.n_periods))

    @classmethod
    def of_two_flywheels(cls, rec: SteadyStateRecord, driven: int = 1) -> "ChainRecord":
        """A run of the two-flywheel rig (:mod:`rig.simulate`, both angles) as a run of the line
        of its two bodies, the torque on body ``driven`` (pure)."""
        if rec.phi2_rad is None:
            raise RecordError(f"{rec.source}: the relative angle only ('phi'); a train needs each body's angle")
        rates = None if rec.rate1_rad_s is None and rec.rate2_rad_s is None else (rec.rate1_rad_s, rec.rate2_rad_s)
        return cls(rec.omega_rad_s, rec.time_s, (rec.torque_Nm, None) if driven == 1 else (None, rec.torque_Nm),
                   (rec.phi1_rad, rec.phi2_rad), rates, rec.n_periods, rec.drive_amplitude_Nm, source=rec.source)

    @property
    def n_flywheels(self) -> int:
        return len(self.angles_rad)

    @property
    def measured(self) -> tuple[bool, ...]:
        return tuple(a is not None for a in self.angles_rad)

    @property
    def driven(self) -> tuple[bool, ...]:
        return tuple(t is not None for t in self.torques_Nm)

    def rate(self, i: int) -> np.ndarray:
        """Rate of flywheel i (0-based index) (rad/s): measured, else the spectral derivative."""
        r = self.rates_rad_s[i]
        if r is not None:
            return r
        a = self.angles_rad[i]  # memoised by the angle's identity (read-only): asked for in every column
        return memo_arrays((a,), ("spectral_rate", self.omega_rad_s, self.n_periods),
                           lambda: _read_only(spectral_rate(a, self.omega_rad_s, self.n_periods)))

    def relative(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Relative angle and rate of joint j (0-based: flywheels j and j+1)."""
        return (self.angles_rad[j] - self.angles_rad[j + 1], self.rate(j) - self.rate(j + 1))


@dataclass(frozen=True)
class ChainSpec:
    """A chain's model structure: the terms of every joint's law, and which flywheels have a
    drag to ground (1-based numbers).

    Attributes:
      joints: one tuple of :class:`vocab.law.Term` per joint (N - 1 of them).
      bearings: flywheel numbers with an unknown viscous drag to ground.
      offsets_rad: per joint, the zero error of its measured twist (rad; the law sees the
        measured twist minus it): encoders not zeroed together. Default: none.
      grounds: per body, the terms of its law to ground, a function of its own angle and rate
        (a guide's or a seal's friction, a spring to ground); () where it has none. A single body
        (no joints) is a chain of N = 1.
      drive_delay_s: the drives act this long after they are recorded (s; every drive channel
        alike: one amplifier's or DAQ's lag): the torque ``T_i(t - tau)`` acts at ``t``.
      channel_delays_s, channel_gains: per body, its angle channel as read against the drive's
        and body 1's (a DAQ's channel skew, an encoder's line count or a gear ratio set wrong):
        read ``delay`` late and ``1 + gain`` times too large (:func:`channel_corrected`).
        Default: none. Sensors, not the plant: the rig does not simulate them.
    """

    joints: tuple
    bearings: tuple = ()
    offsets_rad: tuple = ()
    grounds: tuple = ()
    drive_delay_s: float = 0.0
    channel_delays_s: tuple = ()
    channel_gains: tuple = ()

    def __post_init__(self):
        joints = tuple(tuple(j) for j in self.joints)
        for j, terms in enumerate(joints, start=1):
            if not terms or not all(isinstance(t, Term) for t in terms):
                raise ValueError(f"ChainSpec: joint {j} needs at least one law term (vocab.law.Term)")
        N = len(joints) + 1
        grounds = tuple(tuple(g) for g in self.grounds) or ((),) * N
        if len(grounds) != N or not all(isinstance(t, Term) for g in grounds for t in g):
            raise ValueError(f"ChainSpec.grounds must hold one tuple of law terms per body ({N}), got {self.grounds}")
        object.__setattr__(self, "grounds", grounds)
        bearings = tuple(sorted(set(int(b) for b in self.bearings)))
        if any(not 1 <= b <= N for b in bearings):
            raise ValueError(f"ChainSpec.bearings must be flywheel numbers 1..{N}, got {self.bearings}")
        offsets = tuple(float(o) for o in self.offsets_rad) or (0.0,) * len(joints)
        if len(offsets) != len(joints) or not all(math.isfinite(o) for o in offsets):
            raise ValueError(f"ChainSpec.offsets_rad must hold one finite number per joint ({len(joints)}), got "
                             f"{self.offsets_rad}")
        if not math.isfinite(self.drive_delay_s):
            raise ValueError(f"ChainSpec.drive_delay_s must be finite, got {self.drive_delay_s}")
        for name in ("channel_delays_s", "channel_gains"):
            v = tuple(float(x) for x in getattr(self, name)) or (0.0,) * N
            if len(v) != N or not all(math.isfinite(x) for x in v) or v[0] != 0.0:
                raise ValueError(f"ChainSpec.{name} must hold one finite number per body ({N}), 0 for body 1 (the "
                                 f"reference of the others), got {getattr(self, name)}")
            if name == "channel_gains" and min(v) <= -1.0:
                raise ValueError(f"ChainSpec.channel_gains must be > -1 (a channel reads 1 + gain times its body's "
                                 f"motion), got {v}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "bearings", bearings)
        object.__setattr__(self, "offsets_rad", offsets)
        object.__setattr__(self, "drive_delay_s", float(self.drive_delay_s))

    @property
    def n_flywheels(self) -> int:
        return len(self.joints) + 1

    @property
    def reads_channels(self) -> bool:
        """Whether some angle channel is read skewed or scaled (:func:`channel_corrected`)."""
        return any(self.channel_delays_s) or any(self.channel_gains)

    def blocks(self) -> list[tuple[str, int, tuple[str, ...]]]:
        """The unknowns in banded order, grouped: ("flywheel", i, names) and ("joint", j, names)."""
        out = []
        for i in range(1, self.n_flywheels + 1):
            names = (inertia_name(i),) + ((bearing_name(i),) if i in self.bearings else ()) \
                + tuple(ground_prefix(i) + t.name for t in self.grounds[i - 1])
            out.append(("flywheel", i, names))
            if i < self.n_flywheels:
                out.append(("joint", i, tuple(joint_prefix(i) + t.name for t in self.joints[i - 1])))
        return out

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for _, _, names in self.blocks() for n in names)


def _channel(x: Optional[np.ndarray], rec: "ChainRecord", gain: float, delay_s: float, read: bool):
    """One channel as read (``read``: ``(1 + gain) x(t - delay)``) or as its body moved (the inverse)."""
    if x is None or (gain == 0.0 and delay_s == 0.0):
        return x
    P, w = rec.n_periods, rec.omega_rad_s

    def compute():
        if read:
            return _read_only((1.0 + gain) * (shift_periodic(x, P, w, delay_s) if delay_s else x))
        return _read_only((shift_periodic(x, P, w, -delay_s) if delay_s else x) / (1.0 + gain))
    return memo_arrays((x,), ("channel", read, gain, delay_s, w, P), compute)


def channel_corrected(rec: "ChainRecord", spec: ChainSpec, *, read: bool = False) -> "ChainRecord":
    """The record as its bodies moved, each body's angle (and a rate given with it) divided by
    ``1 + channel_gains[i]`` and moved ``channel_delays_s[i]`` earlier, exactly on its harmonics
    (gain and shift are linear, so a rate is corrected as its angle); ``read``: the other way, a
    simulated record as the channels would read it. The record itself where nothing is skewed
    or scaled."""
    if not spec.reads_channels:
        return rec
    rates = rec.rates_rad_s
    return replace(rec, angles_rad=tuple(_channel(a, rec, g, d, read) for a, g, d in
                                         zip(rec.angles_rad, spec.channel_gains, spec.channel_delays_s)),
                   rates_rad_s=tuple(_channel(r, rec, g, d, read) for r, g, d in
                                     zip(rates, spec.channel_gains, spec.channel_delays_s)))


def identifiability(n_flywheels: int, measured: Sequence[bool], driven: Sequence[bool]) -> list[str]:
    """Why the unknowns of a chain are not identifiable from these channels ([] if they are).

    Every joint's law needs both of its flywheels' angles; a recorded drive torque on at
    least one flywheel fixes the scale (without one, [A]{S} = 0 has only S = 0 or a
    one-parameter family).
    """
    measured, driven = list(measured), list(driven)
    reasons = []
    for j in range(1, n_flywheels):
        missing = [i for i in (j, j + 1) if not measured[i - 1]]
        if missing:
            reasons.append(
                f"joint {j} (flywheels {j}-{j + 1}): its law is a function of phi{j} - phi{j + 1}, and "
                + " and ".join(f"phi{i}" for i in missing) + " is not measured; add an angle sensor on flywheel "
                + " and ".join(str(i) for i in missing))
    if not any(driven):
        reasons.append("no flywheel has a recorded drive torque: without a known torque the equations are "
                       "homogeneous and fix no scale; record the drive torque")
    return reasons


def _law_coeffs(rec: "ChainRecord", j: int, terms: Sequence[Term], n_harmonics: int, oversample: int,
                offset_rad: float = 0.0, weight: Optional[np.ndarray] = None) -> np.ndarray:
    """Fourier coefficients of joint j's terms (0-based) along the record's twist minus
    ``offset_rad`` (:func:`identify.balance.law_rows`, keyed by the record's arrays, which are
    read-only, and the offset): a profile search that varies one term's nonlinear parameter, or
    the offset, re-evaluates only what changed."""
    return law_rows(terms, (rec.angles_rad[j], rec.angles_rad[j + 1]), (rec.rates_rad_s[j], rec.rates_rad_s[j + 1]),
                    lambda: upsample(rec.relative(j)[0] - offset_rad, oversample),
                    lambda: upsample(rec.relative(j)[1], oversample),
                    rec.n_periods, n_harmonics, oversample, tag=(offset_rad,) if offset_rad else (), weight=weight)


@dataclass(frozen=True)
class BandedSystem:
    """[A]{S} = {F} of a chain, held as one dense block of rows per flywheel.

    Attributes:
      system: all rows (dense; rows of flywheel 1 first, then 2, ...), for residuals and tests.
      spans: per flywheel, ``(first row, end row, first column, end column)``: its rows are
        zero outside those columns (the banded structure :func:`solve_banded` uses).
    """

    system: LinearSystem
    spans: tuple
    #: ``(record, equation) -> ((body, mask or None), ...)``: the bodies (0-based) whose equations
    #: a row of that record and equation label sums, each weighted in time by its mask
    #: (:func:`masked_noise_covariance` propagates the noise through them)
    bodies: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def density(self) -> float:
        """Fraction of [A] inside the bands (the rest is structurally zero)."""
        A = self.system.A
        inside = sum((r1 - r0) * (c1 - c0) for r0, r1, c0, c1 in self.spans)
        return inside / A.size if A.size else 0.0


def chain_system(records: Sequence[ChainRecord], spec: ChainSpec, *, n_harmonics: int, first_harmonic: int = 0,
                 oversample: int = 1, masks: Optional[Sequence] = None,
                 merged: Optional[Sequence] = None, slipping: Optional[Sequence] = None) -> BandedSystem:
    """The harmonic-balance rows of every flywheel of every record (harmonics
    ``first_harmonic..n_harmonics``), ordered for :func:`solve_banded`.

    ``masks``: per record, one entry per body, None or samples (0..1, like ``time_s``) that
    multiply that body's whole equation before it is balanced: the equation is balanced only
    where it holds with the law's torque. While a body sticks to ground its dry friction is a
    reaction (whatever holds it), not the law's ``F_c sign(rate)``; masked out there, what is
    left is exact (:func:`stick_mask`).

    ``merged``: per record, the joints (0-based) whose two bodies' equations are balanced as
    their sum alone. While a joint sticks its torque is a reaction, not its law's; the sum of its
    bodies' equations holds no joint torque of its own and is exact in every harmonic (a mask
    would mix the stiff neighbours' harmonics above the band into it). The sum's rows sit with
    the first body's, whose column band then reaches the last merged body's.

    ``slipping``: per record, one entry per joint, None or samples (0..1) that are 1 where that
    merged joint's twist slides. Every body of bodies summed into one but one (the driven one,
    else the first: the sum holds it) then also keeps its own equation, weighted by the product
    of the slip masks of the merged joints beside it (and its own stick mask): where they slide
    their torques are their laws', so a joint that sticks most of the cycle is still fitted on
    the rest. These rows are equation ``N + body`` (0-based), apart from the sum's. A body beside
    a merged joint without a slip mask (stuck the whole period) keeps no equation of its own.

    Raises:
      ChainIdentifiabilityError: a record lacks an angle a joint needs, or has no drive torque.
      RecordError: a record with too few samples per period for ``n_harmonics``, or whose
        flywheel count differs from the spec's.
    """
    if not records:
        raise ValueError("no records to identify from")
    N = spec.n_flywheels
    for r in records:
        if not isinstance(r, ChainRecord):
            raise TypeError(f"expected ChainRecord, got {type(r).__name__}")
        if r.n_flywheels != N:
            raise RecordError(f"{r.source}: {r.n_flywheels} flywheels, but the model has {N}")
        why = identifiability(N, r.measured, r.driven)
        if why:
            raise ChainIdentifiabilityError(f"{r.source}: not identifiable by harmonic balance: " + "; ".join(why))
        top = max_harmonic(r.samples_per_period)
        if not 0 <= n_harmonics <= top:
            raise RecordError(f"{r.source}: n_harmonics={n_harmonics} needs more than the record's "
                              f"{r.samples_per_period} samples per period (at most {top} harmonics)")
    records = [channel_corrected(r, spec) for r in records]
    names = spec.names
    col = {n: k for k, n in enumerate(names)}
    p = len(names)
    rows_by_fw: list[list] = [[] for _ in range(N)]
    reach = list(range(N))  # per body: the last body whose equation its rows hold
    bodies: dict = {}
    for ri, rec in enumerate(records):
        P, H = rec.n_periods, n_harmonics
        jw = 1j * np.arange(H + 1) * rec.omega_rad_s
        laws = [_law_coeffs(rec, j, spec.joints[j], H, oversample, spec.offsets_rad[j]) for j in range(N - 1)]
        rec_masks = masks[ri] if masks is not None else (None,) * N

        def rows(i, m, rec=rec, P=P, H=H, jw=jw, laws=laws):
            """Body i's rows, its equation weighted by the samples ``m`` (or whole with None)."""
            if m is not None and oversample != 1:
                raise ValueError("chain_system: masks need oversample 1")
            cols = np.zeros((p, H + 1), dtype=complex)
            keys = (rec.angles_rad[i],) + ((rec.rates_rad_s[i],) if rec.rates_rad_s[i] is not None else ())
            if m is None:
                rate_c = memo_arrays(keys, ("chain_rate", P, H), lambda: fourier_coefficients(rec.rate(i), P, H))
                acc_c = jw * rate_c
            else:  # the masked rate and acceleration as samples (a product's harmonics mix)
                rate_c, acc_c = memo_arrays(keys + (m,), ("chain_masked_motion", P, H), lambda: tuple(
                    fourier_coefficients(x * m, P, H) for x in (rec.rate(i), spectral_rate(
                        rec.rate(i), rec.omega_rad_s, P))))
            cols[col[inertia_name(i + 1)]] = acc_c
            if i + 1 in spec.bearings:
                cols[col[bearing_name(i + 1)]] = rate_c
            if spec.grounds[i]:  # body i+1's law to ground acts with +G on it
                a, r = rec.angles_rad[i], rec.rates_rad_s[i]
                got = law_rows(spec.grounds[i], (a,), (r,), lambda: upsample(a, oversample),
                               lambda: upsample(rec.rate(i), oversample), P, H, oversample, weight=m)
                for t, c in zip(spec.grounds[i], got):
                    cols[col[ground_prefix(i + 1) + t.name]] += c
            if i < N - 1:  # joint i+1 (between i+1 and i+2) acts with +M on flywheel i+1
                own = laws[i] if m is None else _law_coeffs(rec, i, spec.joints[i], H, 1, spec.offsets_rad[i], m)
                for t, c in zip(spec.joints[i], own):
                    cols[col[joint_prefix(i + 1) + t.name]] += c
            if i > 0:  # joint i acts with -M on flywheel i+1
                own = laws[i - 1] if m is None else _law_coeffs(rec, i - 1, spec.joints[i - 1], H, 1,
                                                                 spec.offsets_rad[i - 1], m)
                for t, c in zip(spec.joints[i - 1], own):
                    cols[col[joint_prefix(i) + t.name]] -= c
            torque = rec.torques_Nm[i]
            if torque is None:
                rhs = np.zeros(H + 1, dtype=complex)
            else:
                held = (torque,) if m is None else (torque, m)
                tau = spec.drive_delay_s
                rhs = memo_arrays(held, ("chain_torque", P, H, tau), lambda: fourier_coefficients(
                    (shift_periodic(torque, P, rec.omega_rad_s, tau) if tau else torque)
                    * (1.0 if m is None else m), P, H))
            A, F, harm, part = harmonic_rows(cols, rhs, H)
            keep = harm >= first_harmonic
            return A[keep], F[keep], harm[keep], part[keep], ri, i

        for i in range(N):
            rows_by_fw[i].append(rows(i, rec_masks[i]))
            bodies[(ri, i)] = ((i, rec_masks[i]),)
        # Bodies joined by a merged joint: their equations summed, in the first one's rows.
        joined = set(merged[ri]) if merged is not None else set()
        for j in sorted(joined, reverse=True):  # from the far end: a run of merged joints sums into one
            A2, F2, _, _, _, _ = rows_by_fw[j + 1].pop()
            A1, F1, harm, part, _, _ = rows_by_fw[j].pop()
            rows_by_fw[j].append((A1 + A2, F1 + F2, harm, part, ri, j))
            reach[j] = max(reach[j], reach[j + 1], j + 1)
            bodies[(ri, j)] = bodies[(ri, j)] + bodies.pop((ri, j + 1))
        # Each summed body's own equation where its merged joints slide, but one (the driven one,
        # else the first): the sum holds it. Its rows are equation N + body (not the sum's).
        slips = slipping[ri] if slipping is not None else (None,) * (N - 1)
        for a, b in _merged_blocks(joined):
            driven = [i for i in range(a, b + 1) if rec.torques_Nm[i] is not None]
            for i in range(a, b + 1):
                beside = [j for j in (i - 1, i) if j in joined]
                if i == (driven[0] if driven else a) or any(slips[j] is None for j in beside):
                    continue
                factors = [slips[j] for j in beside] + ([rec_masks[i]] if rec_masks[i] is not None else [])
                m = factors[0] if len(factors) == 1 else np.prod(factors, axis=0)
                m.setflags(write=False)
                rows_by_fw[i].append(rows(i, m)[:5] + (N + i,))
                bodies[(ri, N + i)] = ((i, m),)
    # Column band of each flywheel: its own block, and the joints on either side.
    blocks = spec.blocks()
    start = {}
    k = 0
    for kind, idx, bnames in blocks:
        start[(kind, idx)] = (k, k + len(bnames))
        k += len(bnames)
    As, Fs, rec_idx, harms, parts, eqs, spans = [], [], [], [], [], [], []
    r0 = 0
    for i in range(N):
        lo = start[("joint", i)][0] if i > 0 else start[("flywheel", 1)][0]
        last = reach[i]
        hi = start[("joint", last + 1)][1] if last < N - 1 else start[("flywheel", N)][1]
        for A, F, harm, part, ri, eq in rows_by_fw[i]:
            As.append(A)
            Fs.append(F)
            harms.append(harm)
            parts.append(part)
            rec_idx.append(np.full(F.size, ri))
            eqs.append(np.full(F.size, eq))
        r1 = r0 + sum(F.size for _, F, *_ in rows_by_fw[i])
        spans.append((r0, r1, lo, hi))
        r0 = r1
    system = LinearSystem(np.vstack(As), np.concatenate(Fs), names, np.concatenate(rec_idx),
                          np.concatenate(harms), np.concatenate(parts), np.concatenate(eqs))
    return BandedSystem(system, tuple(spans), bodies)


def _merged_blocks(joined) -> list[tuple[int, int]]:
    """The bodies (first, last; 0-based) that merged joints (0-based) join into one block each."""
    out = []
    for j in sorted(joined):
        if out and out[-1][1] == j:
            out[-1] = (out[-1][0], j + 1)
        else:
            out.append((j, j + 1))
    return out


def solve_banded(banded: BandedSystem, *, row_weights: Optional[np.ndarray] = None) -> IdentificationResult:
    """Weighted least squares of a chain's banded system by one QR per flywheel block.

    The columns are equilibrated (unit 2-norm after row weighting) as in
    :func:`identify.solve.solve`. Block i's rows, stacked on the rows carried over from block
    i-1, are factorised over block i's columns; the triangle's rows whose leading column no
    later block touches are final, the others are carried on. The p x p triangle R left has
    the singular values of the equilibrated [A]: its SVD gives the solution, the condition
    number and the covariance ``s^2 (A'WA)^-1`` with ``s^2 = r'Wr / (m - p)``.
    """
    system = banded.system
    A, F = system.A, system.F
    m, p = A.shape
    if m < p:
        raise ValueError(f"{m} equations for {p} unknowns {list(system.names)}: add harmonics or runs")
    w = np.ones(m) if row_weights is None else np.asarray(row_weights, dtype=float)
    if w.shape != (m,) or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ValueError(f"row_weights must be {m} finite numbers > 0")
    sw = np.sqrt(w)
    norms = np.zeros(p)
    for r0, r1, c0, c1 in banded.spans:
        norms[c0:c1] += np.sum((A[r0:r1, c0:c1] * sw[r0:r1, None]) ** 2, axis=0)
    norms = np.sqrt(norms)
    if np.any(norms == 0):
        bad = [system.names[i] for i in np.flatnonzero(norms == 0)]
        raise ValueError(f"parameters {bad} have an all-zero column: the data do not excite them")
    D = 1.0 / norms
    R = np.zeros((p, p))
    g = np.zeros(p)
    carry_A = np.zeros((0, 0))
    carry_F = np.zeros(0)
    carry_lo = 0
    done = 0  # rows of R finished
    for b, (r0, r1, c0, c1) in enumerate(banded.spans):
        lo = min(carry_lo, c0) if carry_A.size else c0
        if lo != done:
            raise ValueError("solve_banded: the blocks' columns are not banded in order")
        width = c1 - lo
        stack = np.zeros((carry_A.shape[0] + (r1 - r0), width))
        stack[:carry_A.shape[0], :carry_A.shape[1]] = carry_A
        stack[carry_A.shape[0]:, c0 - lo:] = A[r0:r1, c0:c1] * sw[r0:r1, None] * D[c0:c1]
        rhs = np.concatenate([carry_F, F[r0:r1] * sw[r0:r1]])
        # The reduced factorisation: a complete Q of a block with many rows (a multisine's
        # thousands of lines) would be rows x rows.
        q, r = np.linalg.qr(stack)
        qtf = q.T @ rhs
        k = min(width, stack.shape[0])
        # Columns no later block touches: the next block's band starts at its c0.
        nxt = banded.spans[b + 1][2] if b + 1 < len(banded.spans) else c1
        final = min(nxt - lo, k)
        R[lo:lo + final, lo:c1] = r[:final]
        g[lo:lo + final] = qtf[:final]
        done = lo + final
        carry_A = r[final:k, final:]
        carry_F = qtf[final:k]
        carry_lo = lo + final
    if done < p:
        R[done:, done:] = carry_A[: p - done]
        g[done:] = carry_F[: p - done]
    U, sv, Vt = np.linalg.svd(R)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    rank_tol = sv[0] * max(m, p) * np.finfo(float).eps
    rank = int(np.sum(sv > rank_tol))
    inv_sv = np.where(sv > rank_tol, 1.0 / np.where(sv > 0, sv, 1.0), 0.0)
    y = Vt.T @ (inv_sv * (U.T @ g))
    S = D * y
    r = (A @ S - F) * sw
    dof = m - p
    s2 = float(r @ r) / dof if dof > 0 else math.nan
    cov = s2 * (D[:, None] * ((Vt.T * inv_sv**2) @ Vt) * D[None, :])
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    success = rank == p
    if not success:
        message = f"rank-deficient: rank {rank} < {p} unknowns (condition number {cond:.3g})"
    elif cond > COND_WARN:
        message = f"ill-conditioned: condition number {cond:.3g} > {COND_WARN:.0e}; check the standard errors"
    else:
        message = "ok"
    normF = float(np.linalg.norm(F * sw))
    result = IdentificationResult(
        names=tuple(system.names), values=S, std_errors=std, covariance=cov, condition_number=cond,
        residual_rms=float(np.sqrt(np.mean(r**2))), relative_residual=float(np.linalg.norm(r) / normF) if normF else math.inf,
        n_rows=m, dof=dof, success=success, message=message)
    for arr in (result.values, result.std_errors, result.covariance):
        arr.setflags(write=False)
    return result


#: A body's rate below this share of its run's peak rate is masked out of its equation where it
#: rests (:func:`stick_mask`). On a band-limited record (harmonics 1..20) the rate of a carriage
#: that truly sticks 6% of its cycle stays below 3% of its peak over 12% of it (the band's ripple
#: about rest), and its acceleration's jump rings past that.
STICK_RATE_FRACTION = 0.1
#: ... unless a stretch above it never reaches this share of the peak: then it is the band's
#: ripple about rest while the body or joint sticks (the independent bench's joint that sticks
#: 62% of its cycle rings to 12-15% of its peak twist rate there, its slides reach 100%).
SLIP_PEAK_FRACTION = 0.3
#: A run's body rests (it may stick) when its rate stays below ``REST_RATE_FRACTION`` of its peak
#: for more than ``REST_DWELL`` times as long as a sinusoid's would ((2 / pi) asin 0.03 = 1.9% of
#: the period). The independent carriage: 12.1% where it sticks 6% of the cycle, 1.8-2.6% at the
#: levels where it only slides through rest.
REST_RATE_FRACTION = 0.03
REST_DWELL = 2.0


def sticks_to_ground(spec: ChainSpec, i: int) -> bool:
    """True when body ``i`` (0-based) has a law to ground with a jump at rest (dry friction, a
    Stribeck law's): it can stick, and its equation while it does holds a reaction."""
    return jumps_at_rest(spec.grounds[i])


def jumps_at_rest(terms) -> bool:
    """True when a law's terms jump at zero rate (dry friction, a Stribeck law's): a body or
    joint with it can stick, and its force while it does is a reaction, not the law's."""
    return any(t.dry_friction(1.0) is not None for t in terms)


def rest_share(rate: np.ndarray) -> float:
    """The share of a period whose ``|rate|`` stays below :data:`REST_RATE_FRACTION` of its peak."""
    rate = np.asarray(rate, dtype=float)
    top = float(np.max(np.abs(rate))) if rate.size else 0.0
    return float(np.mean(np.abs(rate) < REST_RATE_FRACTION * top)) if top > 0 else 0.0


def rests(rate: np.ndarray) -> bool:
    """Whether a period's rate (a body's, or a joint's twist rate) rests: it stays below
    :data:`REST_RATE_FRACTION` of its peak more than :data:`REST_DWELL` times as long as a
    sinusoid's would. It may stick there."""
    return rest_share(rate) > REST_DWELL * (2.0 / math.pi) * math.asin(REST_RATE_FRACTION)


def stick_mask(rate: np.ndarray, fraction: float = STICK_RATE_FRACTION) -> Optional[np.ndarray]:
    """The weight of a body's equation in :func:`chain_system` over one period of its ``rate``:
    0 where ``|rate|`` is below ``fraction`` of its largest value, 1 elsewhere, when the body
    rests there (module constants :data:`REST_RATE_FRACTION`, :data:`REST_DWELL`: it may stick,
    held by whatever force its dry friction supplies, not the law's); None when it only slides
    through rest, whose harmonic balance is exact."""
    rate = np.asarray(rate, dtype=float)
    if not rests(rate):
        return None
    speed = np.abs(rate)
    top = float(np.max(speed))
    out = (speed >= fraction * top).astype(float)
    # A stretch above the threshold whose speed never reaches SLIP_PEAK_FRACTION of the peak is
    # the band's ripple about rest, not a slide (the period is a circle: it is cut where it rests).
    cut = int(np.argmin(out))
    ring, fast = np.roll(out, -cut), np.roll(speed, -cut)
    edges = np.flatnonzero(np.diff(np.concatenate(([0.0], ring, [0.0]))))
    for a, b in zip(edges[::2], edges[1::2]):
        if np.max(fast[a:b]) < SLIP_PEAK_FRACTION * top:
            ring[a:b] = 0.0
    out = np.roll(ring, cut)
    out.setflags(write=False)
    return out


def identify_chain(records: Sequence[ChainRecord], spec: ChainSpec, *, n_harmonics: int = 9,
                   row_weights: Optional[np.ndarray] = None) -> IdentificationResult:
    """All inertias, all joint laws (and the bearings the spec names) of a chain from its records."""
    return solve_banded(chain_system(records, spec, n_harmonics=n_harmonics), row_weights=row_weights)


def joint_law(result_values: dict, spec: ChainSpec, j: int) -> JointLaw:
    """Joint j's law (1-based) from identified values by name."""
    terms = spec.joints[j - 1]
    return JointLaw(terms, tuple(result_values[joint_prefix(j) + t.name] for t in terms))


@dataclass(frozen=True)
class ChainPlant:
    """What a chain rig simulates: every joint's law, every flywheel's drag to ground and each
    body's law to ground.

    Attributes:
      laws: one :class:`vocab.law.JointLaw` per joint (N - 1).
      bearings_Nms_per_rad: drag of each flywheel to ground (N m s/rad, >= 0), N of them.
      grounds: per body, its law to ground (a :class:`vocab.law.JointLaw` of its own angle and
        rate; sliders with memory too: a guide's pre-sliding, the relative-angle form's joint) or
        None.
    """

    laws: tuple
    bearings_Nms_per_rad: tuple
    grounds: tuple = ()
    #: the drives act this long after they are recorded (s): ``T_i(t - tau)`` at ``t``
    drive_delay_s: float = 0.0

    def __post_init__(self):
        if not math.isfinite(self.drive_delay_s):
            raise ValueError(f"ChainPlant.drive_delay_s must be finite, got {self.drive_delay_s}")
        laws = tuple(self.laws)
        if not all(isinstance(law, JointLaw) for law in laws):
            raise TypeError("ChainPlant.laws must be one JointLaw per joint")
        grounds = tuple(self.grounds) or (None,) * (len(laws) + 1)
        if len(grounds) != len(laws) + 1 or not all(g is None or isinstance(g, JointLaw) for g in grounds):
            raise TypeError(f"ChainPlant.grounds must be one JointLaw or None per body ({len(laws) + 1})")
        object.__setattr__(self, "grounds", grounds)
        b = tuple(float(v) for v in self.bearings_Nms_per_rad)
        if len(b) != len(laws) + 1:
            raise ValueError(f"ChainPlant: {len(b)} bearings for {len(laws) + 1} flywheels")
        if not all(math.isfinite(v) and v >= 0 for v in b):
            raise ValueError(f"ChainPlant.bearings_Nms_per_rad must be finite and >= 0, got {b}")
        object.__setattr__(self, "laws", laws)
        object.__setattr__(self, "bearings_Nms_per_rad", b)

    @property
    def n_flywheels(self) -> int:
        return len(self.laws) + 1

    def parameters(self) -> dict[str, float]:
        """Every parameter by its chain name (joint laws, nonzero bearings)."""
        out: dict[str, float] = {}
        for j, law in enumerate(self.laws, start=1):
            out.update({joint_prefix(j) + n: v for n, v in law.as_dict().items()})
        for i, b in enumerate(self.bearings_Nms_per_rad, start=1):
            if b:
                out[bearing_name(i)] = b
        for i, g in enumerate(self.grounds, start=1):
            if g is not None:
                out.update({ground_prefix(i) + n: v for n, v in g.as_dict().items()})
        if self.drive_delay_s:
            out[DRIVE_DELAY] = self.drive_delay_s
        return out

    def spec(self) -> ChainSpec:
        """The model structure that holds this plant exactly."""
        return ChainSpec(tuple(law.terms for law in self.laws),
                         tuple(i for i, b in enumerate(self.bearings_Nms_per_rad, start=1) if b),
                         grounds=tuple(g.terms if g is not None else () for g in self.grounds),
                         drive_delay_s=self.drive_delay_s)


def plant_of_values(values: dict, spec: ChainSpec) -> ChainPlant:
    """The plant an identification names (negative bearing drag within noise is simulated as 0 by
    the caller's choice; here values are taken as they are, bearings clipped at 0)."""
    laws = tuple(joint_law(values, spec, j) for j in range(1, spec.n_flywheels))
    bearings = tuple(max(0.0, values.get(bearing_name(i), 0.0)) for i in range(1, spec.n_flywheels + 1))
    return ChainPlant(laws, bearings, ground_laws(values, spec), spec.drive_delay_s)


def ground_laws(values: dict, spec: ChainSpec) -> tuple:
    """Every body's law to ground for the rig (None where it has none) from identified values by
    name; a constant (:class:`vocab.law.Constant`) is not a law there but a load
    (:func:`constant_loads`)."""
    laws = []
    for i, g in enumerate(spec.grounds, start=1):
        terms = tuple(t for t in g if not isinstance(t, Constant))
        laws.append(JointLaw(terms, tuple(values[ground_prefix(i) + t.name] for t in terms)) if terms else None)
    return tuple(laws)


def constant_loads(values: dict, spec: ChainSpec) -> tuple:
    """Per body, its fitted constant torque to ground (:class:`vocab.law.Constant`; 0 where it has
    none): what the balance reads as the drive cell's offset plus a constant load."""
    return tuple(sum(values[ground_prefix(i) + t.name] for t in g if isinstance(t, Constant))
                 for i, g in enumerate(spec.grounds, start=1))


def dynamic_stiffness(spec: ChainSpec, values: dict, w_rad_s) -> np.ndarray:
    """``Z (F, N, N)`` at each frequency of ``w_rad_s``: body i's balance residual moves by
    ``sum_l Z_il dPhi_l`` when the angles move by ``dPhi e^{i w t}`` (the inertias, the bearings'
    drags and every joint's ``c`` and ``k`` at ``values``; the nonlinear terms' share left out)."""
    N = spec.n_flywheels
    w = np.atleast_1d(np.asarray(w_rad_s, dtype=float))
    J = np.array([values.get(inertia_name(i), 0.0) for i in range(1, N + 1)])
    b = np.array([values.get(bearing_name(i), 0.0) for i in range(1, N + 1)])
    Z = np.zeros((w.size, N, N), dtype=complex)
    Z[:, np.arange(N), np.arange(N)] = -J * w[:, None] ** 2 + 1j * w[:, None] * b
    pair = np.array([[1, -1], [-1, 1]])
    for j in range(N - 1):
        kc = values.get(joint_prefix(j + 1) + "k_Nm_per_rad", 0.0) + 1j * w * values.get(
            joint_prefix(j + 1) + "c_Nms_per_rad", 0.0)
        Z[:, j:j + 2, j:j + 2] += kc[:, None, None] * pair
    return Z


def masked_noise_covariance(harmonic: np.ndarray, part: np.ndarray, equation: np.ndarray, bodies: dict,
                            spec: ChainSpec, values: dict, omega_rad_s: float, band: int, n_fine: int,
                            sigma_angle, sigma_torque, per_coefficient: float) -> np.ndarray:
    """The covariance ``(m, m)`` of one record's balance residuals (rows given by their
    ``harmonic`` >= 1, ``part`` and ``equation`` label; ``bodies``: label -> ``((body, mask or
    None), ...)``, :attr:`BandedSystem.bodies`) under white noise on its channels (pure).

    A mask multiplies an equation in time, so its rows mix every harmonic of the equation's noise
    and are correlated across harmonics, which a weighting by each row's own variance leaves out.
    Each body's residual noise is written in the real trigonometric basis of harmonics
    ``0..band`` (the band-limited average, ``n_fine`` samples a period): the encoders' and torque
    cells' coefficients are independent with variance ``sigma^2 per_coefficient`` (half that at
    harmonic 0; ``per_coefficient`` = 2 / samples averaged), moved by the dynamic stiffness
    (:func:`dynamic_stiffness`, ``a' = Re Z a + Im Z b``, ``b' = -Im Z a + Re Z b`` for
    ``a cos + b sin``); each row is the balance (:func:`identify.balance.harmonic_rows`) of the
    masked sum of its bodies' residuals, so the covariance is exact to the linearisation."""
    N = spec.n_flywheels
    H = int(np.max(harmonic))
    K = 2 * band + 1  # coefficients: a_0, then (a_h, b_h) for h = 1..band
    theta = 2.0 * np.pi * np.arange(n_fine) / n_fine
    h = np.arange(1, band + 1)
    basis = np.vstack([np.ones(n_fine)] + [f(k * theta) for k in h for f in (np.cos, np.sin)])
    # channel coefficients -> each body's residual coefficients: (N K) x (2 N K): angles, torques
    Z = dynamic_stiffness(spec, values, np.arange(band + 1) * omega_rad_s)
    E = np.zeros((N * K, 2 * N * K))
    for i in range(N):
        for l in range(N):
            E[i * K, l * K] = Z[0, i, l].real
            for k in h:
                z = Z[k, i, l]
                r, c = i * K + 2 * k - 1, l * K + 2 * k - 1
                E[r:r + 2, c:c + 2] = [[z.real, z.imag], [-z.imag, z.real]]
        E[i * K:(i + 1) * K, (N + i) * K:(N + i + 1) * K] = -np.eye(K)
    scale = np.r_[0.5, np.ones(2 * band)] * per_coefficient
    sa = np.broadcast_to(np.asarray(sigma_angle, dtype=float) ** 2, (N,))
    st = np.broadcast_to(np.asarray(sigma_torque, dtype=float) ** 2, (N,))
    var = np.concatenate([np.repeat(sa, K) * np.tile(scale, N), np.repeat(st, K) * np.tile(scale, N)])
    cov_e = (E * var) @ E.T
    # rows <- the bodies' residual coefficients, through each body's mask
    T = np.zeros((harmonic.size, N * K))
    for label in np.unique(equation):
        sel = np.flatnonzero(equation == label)
        for body, mask in bodies[int(label)]:
            weighted = basis if mask is None else basis * mask
            W, _, harm, prt = harmonic_rows(fourier_coefficients(weighted, 1, H), np.zeros(H + 1), H)
            at = {(int(a), int(b)): n for n, (a, b) in enumerate(zip(harm, prt))}
            T[sel, body * K:(body + 1) * K] += W[[at[(int(harmonic[r]), int(part[r]))] for r in sel]]
    return T @ cov_e @ T.T


def noise_cross_covariance(spec: ChainSpec, values: dict, w_rad_s, sigma_angle, sigma_torque,
                           merged: Sequence[int] = ()) -> np.ndarray:
    """The covariance of the balance residuals of every equation at frequency ``w_rad_s`` (a
    number, or an array of them: one matrix each) (pure): ``[Re e_1..e_K, Im e_1..e_K]`` per unit
    coefficient variance, the residual of body i moving by ``sum_l Z_il dPhi_l - dT_i`` with ``Z``
    the dynamic stiffness of the inertias, the bearings' drags and every joint's ``c`` and ``k``
    (the nonlinear terms' share left out, as in :func:`fisher_per_period`), white
    noise of ``sigma_angle`` on each encoder and ``sigma_torque`` on each torque cell (a number, or
    one per body; 0 where none). ``merged``: joints (0-based) whose two bodies' equations are balanced as
    their sum (their second body's rows dropped; K = N minus their number)."""
    N = spec.n_flywheels
    Z = dynamic_stiffness(spec, values, w_rad_s)
    S = np.eye(N)
    for j in sorted(merged, reverse=True):  # from the far end: a run of merged joints sums into one
        S[j] += S[j + 1]
    S = np.delete(S, sorted(j + 1 for j in merged), axis=0)
    SZ = S @ Z  # (F, K, N)
    R, I = SZ.real, SZ.imag
    M = np.concatenate([np.concatenate([R, -I], axis=2), np.concatenate([I, R], axis=2)], axis=1)
    sa2 = np.tile(np.broadcast_to(np.asarray(sigma_angle, dtype=float) ** 2, (N,)), 2)
    S2 = np.block([[S, np.zeros_like(S)], [np.zeros_like(S), S]])
    st = S2 @ np.diag(np.tile(np.broadcast_to(np.asarray(sigma_torque, dtype=float) ** 2, (N,)), 2)) @ S2.T
    out = np.einsum("fik,k,fjk->fij", M, sa2, M) + st
    return out if np.ndim(w_rad_s) else out[0]


def _row_covariance(s: LinearSystem, spec: ChainSpec, vals: dict, omega_rad_s: float, n_samples: int,
                    driven: Sequence[bool], sigma_angle_rad, sigma_torque_Nm, n_harmonics: int) -> np.ndarray:
    """The covariance of the residuals of one record's rows ``s`` (harmonics 1..H), see
    :func:`row_covariance`; ``sigma_*`` a number or one per flywheel."""
    N = spec.n_flywheels
    st = np.broadcast_to(np.asarray(sigma_torque_Nm, dtype=float), (N,)) * np.asarray(driven, dtype=float)
    per = 2.0 / n_samples  # variance of a coefficient's cosine (or sine) part per unit sigma^2
    blocks = per * noise_cross_covariance(spec, vals, np.arange(1, n_harmonics + 1) * omega_rad_s, sigma_angle_rad, st)
    C = np.zeros((s.F.size, s.F.size))
    for n in range(1, n_harmonics + 1):
        rows = np.flatnonzero(s.row_harmonic == n)
        pos = s.row_part[rows] * N + s.row_equation[rows]  # place in [Re e_1..e_N, Im e_1..e_N]
        C[np.ix_(rows, rows)] = blocks[n - 1][np.ix_(pos, pos)]
    return C


def row_covariance(record: ChainRecord, spec: ChainSpec, theta: Sequence[float], *, sigma_angle_rad,
                   sigma_torque_Nm, n_harmonics: int = 9) -> tuple[BandedSystem, np.ndarray]:
    """The balance rows of harmonics 1..H of one record and the covariance of their residuals
    (``(m, m)``) under white noise of ``sigma_angle_rad`` on the encoders and ``sigma_torque_Nm``
    on the drives' torque cells (each a number, or one per flywheel), propagated to first order
    through the linear part of the chain (see :func:`fisher_per_period`). The residuals of one
    harmonic are correlated across flywheels (an angle enters its neighbours' equations too) and
    between their cosine and sine parts; different harmonics are independent. The record's
    periods average the noise."""
    banded = chain_system([record], spec, n_harmonics=n_harmonics, first_harmonic=1)
    C = _row_covariance(banded.system, spec, dict(zip(spec.names, (float(v) for v in theta))), record.omega_rad_s,
                        record.n_samples, record.driven, sigma_angle_rad, sigma_torque_Nm, n_harmonics)
    return banded, C


def fisher_per_period(record: ChainRecord, spec: ChainSpec, theta: Sequence[float], *, sigma_angle_rad: float,
                      sigma_torque_Nm: float, n_harmonics: int = 9) -> np.ndarray:
    """Fisher information one measured period of a noise-free chain record carries about the
    unknowns of ``spec`` (``(p, p)``, in the order of ``spec.names``), under white noise of
    ``sigma_angle_rad`` on every encoder and ``sigma_torque_Nm`` on every drive's torque cell.

    The balance rows of harmonics 1..H (the mean is not balanced: a sensor's zero is arbitrary)
    carry the residual covariance of :func:`row_covariance`: flywheel i's residual at harmonic n
    moves by ``sum_l Z_il(n w) dPhi_l - dT_i``, ``Z`` the dynamic stiffness of the inertias, each
    joint's ``c`` and ``k`` and the bearings at ``theta``, and the coefficient of white noise
    over N samples has variance ``2 sigma^2 / N`` in its cosine and in its sine part. Then
    ``F = A' C^-1 A``. (The nonlinear terms' share of the propagation is left out: for the
    pump train's cubic coupling it is 5% of the linear torque at most.)
    """
    banded, C = row_covariance(record, spec, theta, sigma_angle_rad=sigma_angle_rad,
                               sigma_torque_Nm=sigma_torque_Nm, n_harmonics=n_harmonics)
    L = np.linalg.cholesky(C * record.n_periods)
    A = np.linalg.solve(L, banded.system.A)
    return A.T @ A


def average_chain(record: ChainRecord) -> tuple[ChainRecord, np.ndarray, np.ndarray]:
    """A measured record's mean period, and the noise standard deviation of that mean per sample
    on each encoder and each torque cell (``(N,)`` each; 0 where absent), from the
    period-to-period variation (white noise: N (P - 1) degrees of freedom per channel)."""
    P, n = record.n_periods, record.samples_per_period
    if P < 2:
        raise RecordError(f"{record.source}: {P} period(s); the noise estimate needs at least 2 measured periods")

    def split(x):
        if x is None:
            return None, 0.0
        y = x.reshape(P, n)
        return y.mean(axis=0), math.sqrt(white_variance(period_spectra(y, P)[2], n))

    angles = [split(a) for a in record.angles_rad]
    torques = [split(t) for t in record.torques_Nm]
    avg = ChainRecord(record.omega_rad_s, record.time_s[:n], [t for t, _ in torques], [a for a, _ in angles], None,
                      1, record.drive_amplitude_Nm, source=f"{record.source} (period average)")
    return avg, np.array([s for _, s in angles]), np.array([s for _, s in torques])


def ml_identify_chain(records: Sequence[ChainRecord], spec: ChainSpec, *, n_harmonics: int = 9):
    """Errors-in-variables maximum likelihood for a chain, as :func:`identify.eiv.ml_identify`
    for two flywheels: each run's periods averaged and its noise estimated per channel
    (:func:`average_chain`); the balance rows of harmonics 1..H; the residual covariance
    ``C(theta)`` propagated through the chain's linear part (:func:`row_covariance`); then
    ``V(theta) = sum_runs e' C(theta)^-1 e`` minimised by Levenberg-Marquardt on the whitened
    residuals from an iterated generalised least-squares start. The theta in C is what removes
    the bias weighting alone leaves. Standard errors ``(J'J)^-1`` of the whitened residuals'
    Jacobian at the optimum; ``V / dof ~ 1`` for a model that holds (``p_value``).

    Returns an :class:`identify.eiv.EivResult`.
    """
    from scipy import optimize, stats

    from .eiv import EivResult

    if not records:
        raise ValueError("no records to identify from")
    runs = []
    for rec in records:
        avg, sa, st = average_chain(rec)
        sys_ = chain_system([avg], spec, n_harmonics=n_harmonics, first_harmonic=1).system
        runs.append((avg, sa, st, sys_))
    names = spec.names

    def whitened(theta):
        vals = dict(zip(names, theta))
        out = []
        for avg, sa, st, s in runs:
            C = _row_covariance(s, spec, vals, avg.omega_rad_s, avg.n_samples, avg.driven, sa, st, n_harmonics)
            L = np.linalg.cholesky(C)
            out.append(np.linalg.solve(L, s.A @ theta - s.F))
        return np.concatenate(out)

    def gls(theta):
        vals = dict(zip(names, theta))
        As, Fs = [], []
        for avg, sa, st, s in runs:
            L = np.linalg.cholesky(_row_covariance(s, spec, vals, avg.omega_rad_s, avg.n_samples, avg.driven, sa, st,
                                                   n_harmonics))
            As.append(np.linalg.solve(L, s.A))
            Fs.append(np.linalg.solve(L, s.F))
        A, F = np.vstack(As), np.concatenate(Fs)
        D = 1.0 / np.linalg.norm(A, axis=0)
        return D * np.linalg.lstsq(A * D, F, rcond=None)[0]

    A0 = np.vstack([s.A for *_, s in runs])
    F0 = np.concatenate([s.F for *_, s in runs])
    D0 = 1.0 / np.linalg.norm(A0, axis=0)
    theta = D0 * np.linalg.lstsq(A0 * D0, F0, rcond=None)[0]
    for _ in range(4):
        theta = gls(theta)
    start = theta.copy()
    fit = optimize.least_squares(whitened, start, method="lm", x_scale=np.maximum(np.abs(start), 1e-12))
    Jw = fit.jac
    D = 1.0 / np.maximum(np.linalg.norm(Jw, axis=0), 1e-300)  # columns differ by 10 decades (kg m^2 .. N m/rad^3)
    Jd = Jw * D
    cov = D[:, None] * np.linalg.inv(Jd.T @ Jd) * D[None, :]
    m, p = fit.fun.size, len(names)
    cost = float(fit.fun @ fit.fun)
    dof = m - p
    result = EivResult(names=tuple(names), values=fit.x, std_errors=np.sqrt(np.clip(np.diag(cov), 0, None)),
                       covariance=cov, start=start, cost=cost, dof=dof, p_value=float(stats.chi2.sf(cost, dof)),
                       n_rows=m, n_runs=len(runs), success=bool(fit.success), message=str(fit.message),
                       condition_number=equilibrated_condition(Jw))
    return result
