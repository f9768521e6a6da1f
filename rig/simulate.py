"""Driving the rig to steady state and logging whole periods.

The joint law and the drive act through one MuJoCo passive-force callback:

* joint: ``qfrc_passive[phi1] -= M_v(phi, phi')`` and ``qfrc_passive[phi2] += M_v``;
* drive: ``ctrl[drive] = M0 cos(omega t)`` with ``t = d.time``. MuJoCo calls the passive
  callback at every force evaluation, before actuation, with ``d.time`` at the stage time
  (RK4 evaluates at t, t + h/2, t + h/2, t + h), so the drive is evaluated at continuous
  time, with no zero-order hold; the ``drive_torque`` sensor records what was applied.

The callback is global MuJoCo state. :func:`passive_callback` installs it only around a
simulation (models are compiled before, never while it is installed), refuses to replace a
callback somebody else installed, and restores the previous one afterwards.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import logging
import math
import time as _time
from dataclasses import dataclass
from typing import Callable, Iterator, Optional, Sequence, Union

import mujoco
import numpy as np
from mujoco import rollout

from jointrig.vocab.law import JointLaw, Viscous
from jointrig.vocab.plant import PeriodicDrive, Plant
from jointrig.vocab.records import SteadyStateRecord

from .callback import passive_callback
from .model import TWIST_TENDON, RigModel
from .native_callback import BACKENDS as _CALLBACK_BACKENDS, NativeLaw, choose_native, session_active

__all__ = [
    "SimulationConfig",
    "SettleInfo",
    "StartState",
    "settle_bound",
    "settles_in_time",
    "relative_departure",
    "SimulationError",
    "SteadyStateNotReached",
    "passive_callback",
    "make_callback",
    "commit_state",
    "simulate_steady_state",
    "coherent_omega",
    "dry_friction_split",
    "sticks",
    "set_inertias",
    "BACKENDS",
]

log = logging.getLogger(__name__)

#: How a two-flywheel run is integrated (``simulate_steady_state(..., backend=...)``): the
#: backends every simulation takes (:data:`rig.native_callback.BACKENDS`: auto, native, python)
#: and ``"native-stepped"``, the C callback stepped from Python (what the native one is checked
#: against, bit for bit, and what benchmarks time it against). ``"native"`` integrates a whole
#: period per ``mujoco.rollout`` call for a law without sliders, else steps in C with the sliders
#: committed after each step.
BACKENDS = _CALLBACK_BACKENDS + ("native-stepped",)


#: How the rig simulates a law, versioned: a sweep store (studies/sweep.py) is keyed by it, so a
#: resumed sweep never reuses points of an older simulation of the same law. 2: dry friction
#: held as a constraint on the twist tendon (:func:`dry_friction_split`). 3: a train's joint's
#: dry friction held so too (the tendon ``jointrig_twist<j>`` of :func:`rig.chain.load_chain`).
SIMULATOR_VERSION = 3


class SimulationError(RuntimeError):
    """The simulation diverged or MuJoCo warned (warnings are errors in a test rig)."""


class SteadyStateNotReached(SimulationError):
    """The period-to-period change did not fall below the tolerance in time."""


class Diverged(SimulationError):
    """MuJoCo warned while the rig stepped: the simulation diverged or is invalid. ``warnings``
    names each warning with its count and last info (``"mjWARN_BADQACC x1 (info 0)"``). The
    message advises the rig's own user (a smaller ``max_step_s`` or drive); a diagnosis that
    replays a fitted model words it as that model's instability (present.notes.no_replay_text)."""

    def __init__(self, message: str, warnings: str):
        super().__init__(message)
        self.warnings = warnings


@dataclass(frozen=True)
class SimulationConfig:
    """How the rig integrates and logs.

    Attributes:
      max_step_s: largest integrator step; the step is ``T / (samples_per_period * k)`` with
        the smallest integer k that respects it, so every period holds whole steps.
      samples_per_period: logged samples per period (uniform), unless ``sample_rate_Hz``.
      sample_rate_Hz: a bench's fixed sampling rate instead: every run logs
        ``N = fs 2 pi / omega`` samples per period, which must be a whole number (coherent
        sampling, as a bench engineer sets it up: :func:`coherent_omega` snaps a frequency).
        The integrator step stays independent: ``T / (N k)`` with k from ``max_step_s``.
      settle_tol: bound on the distance of the logged periods from the exact periodic steady
        state, relative to each channel's peak-to-peak swing (adaptive detection; channels:
        the relative angle, both rates, and both absolute angles when
        ``absolute_angles_periodic``). After
        every period the largest change from the previous one, c_p, is measured; a decaying
        transient shrinks geometrically, c_p ~ r^p, so the distance still to go is at most
        ``c_p r / (1 - r)`` with r the larger of the last two ratios c_p / c_(p-1). Steady
        state is declared when that bound is below ``settle_tol``; see :func:`settle_bound`
        for the round-off and drift floors. A
        residual transient of relative size eps perturbs the harmonic-balance rows by about
        eps, so 1e-9 keeps it 5 decades below the 1e-4 identification target;
        ``tests/test_speed.py`` checks the bound against a run settled to 1e-13.
      min_periods: periods simulated before the first comparison.
      max_periods: give up (SteadyStateNotReached) after this many periods.
      max_wall_s: give up (SteadyStateNotReached) after this much wall-clock time (s); None:
        no cap. The diagnosis caps each validation run, so a model that settles slowly is a
        finding about that model, not a hang.
      n_periods: steady periods logged into the record.
      integrator: MuJoCo integrator, case-insensitive ("RK4", "Euler", "implicitfast", ...).
      absolute_angles_periodic: require the absolute angles to repeat too. False checks the
        relative angle and the rates only: a drive replayed from many measured harmonics
        leaves the free rotation an integration-error drift (~1e-8 of the swing per period)
        that has no bearing on the joint.
      accelerate: jump toward the periodic steady state by reduced rank extrapolation of the
        period map (:func:`extrapolated_fixed_point`) every few periods while the transient
        decays, for laws without sliders; steady state is still declared only by the settle
        test on simulated periods after the last jump, so ``settle_tol`` holds either way. The
        default sweep of a lightly damped joint (c = 5 N m s/rad) settles in 329 periods
        instead of 1023 (``scripts/bench_steady.py``). False: plain period-by-period settling.
      settle: False logs the first ``n_periods`` periods from the start as they come, no
        steady state sought: a replay over a measured record's own span from its measured
        state, for a model that reaches no steady state in the rig (a joint that sticks for
        hundreds of periods before it settles, a quasi-periodic response) but may still
        follow the record.
    """

    max_step_s: float = 5e-4
    samples_per_period: int = 256
    sample_rate_Hz: Optional[float] = None
    settle_tol: float = 1e-9
    min_periods: int = 2
    max_periods: int = 2000
    max_wall_s: Optional[float] = None
    n_periods: int = 1
    integrator: str = "RK4"
    settle: bool = True
    absolute_angles_periodic: bool = True
    accelerate: bool = True

    def __post_init__(self):
        if not (self.max_step_s > 0 and math.isfinite(self.max_step_s)):
            raise ValueError(f"max_step_s must be > 0, got {self.max_step_s}")
        if self.samples_per_period < 8:
            raise ValueError(f"samples_per_period must be >= 8, got {self.samples_per_period}")
        if self.sample_rate_Hz is not None and not (math.isfinite(self.sample_rate_Hz) and self.sample_rate_Hz > 0):
            raise ValueError(f"sample_rate_Hz must be a finite number > 0 or None, got {self.sample_rate_Hz}")
        if not 0 < self.settle_tol < 1:
            raise ValueError(f"settle_tol must be in (0, 1), got {self.settle_tol}")
        if self.min_periods < 2 or self.max_periods < self.min_periods:
            raise ValueError(f"need 2 <= min_periods <= max_periods, got {self.min_periods}, {self.max_periods}")
        if self.n_periods < 1:
            raise ValueError(f"n_periods must be >= 1, got {self.n_periods}")
        if self.max_wall_s is not None and not (math.isfinite(self.max_wall_s) and self.max_wall_s > 0):
            raise ValueError(f"max_wall_s must be a finite number > 0 or None, got {self.max_wall_s}")
        if self.mj_integrator_name not in mujoco.mjtIntegrator.__members__:
            raise ValueError(f"unknown integrator {self.integrator!r}; expected one of "
                             f"{[n[6:] for n in mujoco.mjtIntegrator.__members__]}")

    @property
    def mj_integrator_name(self) -> str:
        return "mjINT_" + self.integrator.upper()

    def samples_for(self, omega_rad_s: float) -> int:
        """Samples per period at this drive frequency.

        Raises:
          ValueError: with ``sample_rate_Hz``, a frequency whose period holds no whole number
            of samples (or fewer than 8).
        """
        if self.sample_rate_Hz is None:
            return self.samples_per_period
        exact = self.sample_rate_Hz * 2 * math.pi / omega_rad_s
        n = round(exact)
        if abs(exact - n) > 1e-9 * exact or n < 8:
            raise ValueError(f"omega {omega_rad_s:.12g} rad/s is not coherent with sample_rate_Hz "
                             f"{self.sample_rate_Hz:g}: a period holds {exact:.6g} samples; use "
                             f"rig.simulate.coherent_omega({omega_rad_s:g}, {self.sample_rate_Hz:g}) = "
                             f"{coherent_omega(omega_rad_s, self.sample_rate_Hz):.12g} rad/s"
                             + (" (and at least 8 samples per period)" if n < 8 else ""))
        return n

    def steps_per_sample(self, omega_rad_s: float) -> int:
        period = 2 * math.pi / omega_rad_s
        return max(1, math.ceil(period / (self.samples_for(omega_rad_s) * self.max_step_s) - 1e-9))

    def timestep_s(self, omega_rad_s: float) -> float:
        period = 2 * math.pi / omega_rad_s
        return period / (self.samples_for(omega_rad_s) * self.steps_per_sample(omega_rad_s))


def dry_friction_split(plant: Union[Plant, JointLaw]) -> tuple[Plant, float]:
    """The plant the passive callback evaluates and the static friction (N m) the rig holds as a
    constraint on the twist (pure).

    Dry friction jumps at zero rate: as a force in the callback it chatters while the joint
    sticks, and a fixed step across the jump of ``sign(rate)`` leaves an error of the order of a
    step. Each term with a jump (``Term.dry_friction``: Coulomb, Stribeck) gives its static
    friction to the :data:`rig.model.TWIST_TENDON`'s ``frictionloss``, which MuJoCo's
    constraint solver holds exactly while the joint sticks and applies fully while it slides,
    and leaves its continuous remainder to the callback. Without dry friction, or with a static
    friction that is not positive (a fit's nonphysical value), the plant is returned as it is
    and the static friction is 0."""
    plant = Plant.of(plant)
    static, merged = 0.0, {}
    for term, value in zip(plant.law.terms, plant.law.values):
        split = term.dry_friction(value)
        if split is None:
            pieces = [(term, value)]
        else:
            static += split[0]
            pieces = split[1]
        for t, v in pieces:
            old = merged.get(t.name)
            merged[t.name] = (t, v + (old[1] if old else 0.0))
    if not static > 0:
        return plant, 0.0
    kept = [(t, v) for t, v in merged.values() if v != 0.0] or [(Viscous(), 0.0)]
    law = JointLaw(tuple(t for t, _ in kept), tuple(v for _, v in kept))
    return dataclasses.replace(plant, law=law), static


def coherent_omega(omega_rad_s: float, sample_rate_Hz: float) -> float:
    """The drive frequency nearest ``omega_rad_s`` whose period holds a whole number of samples
    at ``sample_rate_Hz``: ``2 pi fs / round(2 pi fs / omega)`` (rad/s)."""
    return 2 * math.pi * sample_rate_Hz / max(1, round(2 * math.pi * sample_rate_Hz / omega_rad_s))


@dataclass(frozen=True)
class SettleInfo:
    """How a run reached steady state.

    Attributes:
      periods_simulated: periods integrated (settling plus logged).
      last_change: largest period-to-period change at the end, relative to the swing.
      timestep_s: integrator step.
      wall_time_s: wall-clock time of the run.
      error_bound: estimated bound on the logged periods' distance from the exact steady
        state, relative to the swing (see ``SimulationConfig.settle_tol``); NaN if unknown.
      decay_ratio: the per-period decay ratio r used for the bound (NaN at round-off level).
    """

    periods_simulated: int
    last_change: float
    timestep_s: float
    wall_time_s: float
    error_bound: float = math.nan
    decay_ratio: float = math.nan


@dataclass(frozen=True)
class StartState:
    """A state to start a run from instead of rest (continuation: the previous point's steady
    state at drive phase 0). Angles in rad, rates in rad/s, for flywheels 1 and 2."""

    phi1_rad: float
    phi2_rad: float
    rate1_rad_s: float
    rate2_rad_s: float

    @classmethod
    def of_record(cls, record: SteadyStateRecord) -> "StartState":
        """The state at a record's first sample (a whole number of periods: drive phase 0)."""
        return cls(float(record.phi1_rad[0]), float(record.phi2_rad[0]),
                   float(record.rate1_rad_s[0]), float(record.rate2_rad_s[0]))


#: A run that starts on its steady state shows no decay, only the round-off floor: settled once
#: this many periods in a row change by at most FLOOR_SHARE of ``settle_tol`` (a single body on
#: a slide started at its linear steady state: 1.5e-12 rising to 7e-11 over 100 periods, above
#: the 1e-12 that counts as round-off at once).
FLOOR_PERIODS = 5
FLOOR_SHARE = 0.1


def settle_bound(changes: list[float], settle_tol: float, decay_seen: float = math.nan) -> tuple[bool, float, float]:
    """Adaptive steady-state test on the history of period-to-period changes (pure).

    ``changes`` are the largest relative period-to-period changes so far; r is the larger of
    the last two ratios of consecutive changes. Returns ``(settled, error_bound, r)``:

    * change <= settle_tol * 1e-3: settled, bound = the change (round-off level);
    * r < 0.9 (a decaying transient): bound = change * r / (1 - r), the rest of a geometric
      series; settled if below ``settle_tol``;
    * r >= 0.9 after the changes had decayed at a rate r_d < 0.9 (the last such pair of
      ratios): the changes have reached the floor of integration round-off and of the free
      rotation's drift (~1e-12..4e-11 of the swing per period here), with whatever transient
      is left beneath it still decaying at r_d: bound = change / (1 - r_d) (the floor plus
      the transient's geometric rest), settled if below ``settle_tol``;
    * no decay seen, but the last :data:`FLOOR_PERIODS` changes all at most ``FLOOR_SHARE *
      settle_tol``: a run started on its steady state, at the floor: settled;
    * otherwise (no decay seen yet, or a transient slower than r = 0.9): not settled.

    ``decay_seen``: a decay ratio below 0.9 measured before the history restarted (after an
    extrapolation jump, ``SimulationConfig.accelerate``): a jump that lands beneath the floor
    shows no decay of its own, and the transient left beneath the floor decays at the rate
    seen before it.
    """
    c = changes[-1]
    if c <= settle_tol * 1e-3:
        return True, c, math.nan

    def ratio(a: float, b: float) -> float:
        return a / b if b > 0 else math.inf

    ratios = [ratio(changes[i], changes[i - 1]) for i in range(1, len(changes))]
    if not ratios:
        return False, math.inf, math.nan
    r = max(ratios[-2:])
    if r < 0.9:
        bound = c * r / (1 - r)
        return bound < settle_tol, bound, r
    decayed = [max(ratios[i - 1:i + 1]) for i in range(1, len(ratios)) if max(ratios[i - 1:i + 1]) < 0.9]
    if not decayed and not decay_seen < 0.9:
        recent = changes[-FLOOR_PERIODS:]
        if len(recent) == FLOOR_PERIODS and max(recent) <= settle_tol * FLOOR_SHARE:
            # started on the steady state: no transient to see decay, only the floor of round-off
            # (the drive's time accumulated step by step drifts its phase by ~1e-16 per step)
            return True, max(recent), r
        return False, math.inf, r
    r_d = decayed[-1] if decayed else decay_seen
    bound = c / (1 - r_d)
    return bound < settle_tol, bound, r_d


#: Periods over which :func:`settles_in_time` measures the decay of the changes.
DECAY_WINDOW = 100


def settles_in_time(changes: list[float], settle_tol: float, periods_left: int) -> bool:
    """Whether a run can still settle before its cap (pure): False when, at the average decay of
    the changes over the last :data:`DECAY_WINDOW` periods, they would need more than twice the
    ``periods_left`` to fall to ``settle_tol``, or did not decay at all over the window (a model
    without a periodic response under this drive, or changes that hover below ``settle_tol``
    without the decay :func:`settle_bound` needs to certify them: an undamped mode whose
    transient an extrapolation jump took away). True while the history is shorter, or at the
    round-off level (``settle_tol * 1e-3``) where :func:`settle_bound` settles outright.

    A run that is stopped here would have run to its cap and failed there, unless its decay sped
    up more than twofold later: the answer is the same, only sooner (a fitted Stribeck friction
    under cogging, which has no periodic response, took 1000 periods per held-out run).
    """
    if len(changes) <= DECAY_WINDOW:
        return True
    now, then = changes[-1], changes[-1 - DECAY_WINDOW]
    if now <= settle_tol * 1e-3 or not then > 0:
        return True
    r = (now / then) ** (1.0 / DECAY_WINDOW)
    if r >= 1.0:
        return False
    return math.log(settle_tol / now) / math.log(r) <= 2 * periods_left


def extrapolated_fixed_point(states: Sequence[np.ndarray]) -> Optional[np.ndarray]:
    """Reduced rank extrapolation (Sidi 1986) of a map's iterates ``states`` (z_0, z_1, ...):
    the combination ``sum g_i z_(i+1)`` with ``sum g_i = 1`` whose differences
    ``sum g_i (z_(i+1) - z_i)`` cancel best, each component scaled by its largest magnitude.
    Exact for a linear map ``z -> A z + b`` once there are dim + 1 differences; near the fixed
    point of a smooth map the error is second order in the distance (pure). None when the
    iterates do not determine a combination (no movement, or a singular system)."""
    Z = np.asarray(states, dtype=float)
    U = np.diff(Z, axis=0)
    scale = np.max(np.abs(Z), axis=0) + 1e-300
    Us = U / scale
    G = Us @ Us.T
    tr = float(np.trace(G))
    if not (tr > 0 and math.isfinite(tr)):
        return None
    try:
        x = np.linalg.solve(G + 1e-14 * tr * np.eye(len(U)), np.ones(len(U)))
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(x)) or abs(x.sum()) < 1e-300:
        return None
    return (x / x.sum()) @ Z[1:]


class _Jump:
    """The period map's state as :func:`_settle` extrapolates it: ``state()`` reads the relative
    angles and the rates from the MjData, ``put(z)`` writes an extrapolated one back. The free
    rotation is kept as it is: the first flywheel's absolute angle, and the angular momentum
    (the rates are shifted together to the momentum before the jump; the extrapolation's
    round-off in it would otherwise leave the absolute angles a drift that never decays).
    ``free`` False: a drag to ground takes momentum out, and the common rate decays to its own
    steady state (the slowest mode, over J_total / b: thousands of periods for a small drag);
    the rates are then extrapolated as they are."""

    def __init__(self, d: mujoco.MjData, qpos_adr: Sequence[int], dof_adr: Sequence[int],
                 inertias_kgm2: Sequence[float], free: bool = True):
        self.d, self.q, self.v = d, list(qpos_adr), list(dof_adr)
        self.J = np.asarray(inertias_kgm2, dtype=float)
        self.dim = 2 * len(self.q) - 1
        self.free = free

    def state(self) -> np.ndarray:
        pos = self.d.qpos[self.q]
        return np.concatenate([pos[:-1] - pos[1:], self.d.qvel[self.v]])

    def put(self, z: np.ndarray) -> None:
        n = len(self.q)
        pos = self.d.qpos[self.q].copy()
        for i in range(1, n):
            pos[i] = pos[i - 1] - z[i - 1]
        self.d.qpos[self.q] = pos
        rates = np.asarray(z[n - 1:], dtype=float)
        if not self.free:
            self.d.qvel[self.v] = rates
            return
        momentum = float(self.J @ self.d.qvel[self.v])
        self.d.qvel[self.v] = rates + (momentum - float(self.J @ rates)) / float(self.J.sum())


def relative_departure(record: SteadyStateRecord, reference: SteadyStateRecord) -> float:
    """Largest difference of the relative angle and of both rates between two records of the
    same samples, relative to each channel's swing in ``reference`` (the measure of
    ``SimulationConfig.settle_tol``, without the absolute angles)."""
    pairs = ((record.phi_rad, reference.phi_rad), (record.rate1_rad_s, reference.rate1_rad_s),
             (record.rate2_rad_s, reference.rate2_rad_s))
    return max(float(np.max(np.abs(a - b)) / np.ptp(b)) for a, b in pairs)


def make_callback(rig: RigModel, plant: Union[Plant, JointLaw], drive: PeriodicDrive, errors: list,
                  slider_state: Optional[list] = None) -> Callable:
    """The passive callback: joint law between the flywheels, bearing drag, and the drive.

    The drive is ``drive(d.time - plant.drive_delay_s)``. Stateful law terms
    (:class:`vocab.law.Jenkins`) take their state from ``slider_state`` (one float per
    stateful term, in law order), which the caller commits after every step with
    :func:`commit_state`. Exceptions raised inside are stored in ``errors`` (MuJoCo cannot
    propagate them) and the caller raises them after the step.
    """
    plant = Plant.of(plant)
    law = plant.law
    stateless = [(t, v) for t, v in zip(law.terms, law.values) if not t.stateful]
    stateful = [(t, v) for t, v in zip(law.terms, law.values) if t.stateful]
    n_states = sum(t.n_states for t, _ in stateful)
    if stateful and (slider_state is None or len(slider_state) != n_states):
        raise ValueError(f"the law's stateful term(s) hold {n_states} state(s): pass slider_state with one float each")
    torque = JointLaw(tuple(t for t, _ in stateless), tuple(v for _, v in stateless)).torque \
        if stateless else (lambda phi, rate: 0.0)
    q1, q2 = rig.qpos_adr
    v1, v2 = rig.dof_adr
    act = rig.actuator_id
    b1, b2 = plant.bearing1_damping_Nms_per_rad, plant.bearing2_damping_Nms_per_rad
    drive_at = drive.evaluator(plant.drive_delay_s)
    hyst, at = [], 0
    for t, v in stateful:
        hyst.append((t.step_torque, v, at))
        at += t.n_states

    def callback(m, d):
        try:
            qpos, qvel = d.qpos, d.qvel
            phi = float(qpos[q1] - qpos[q2])
            tau = torque(phi, float(qvel[v1] - qvel[v2]))
            for f, v, i in hyst:
                tau += v * f(phi, slider_state, i)
            frc = d.qfrc_passive
            frc[v1] -= tau
            frc[v2] += tau
            if b1:
                frc[v1] -= b1 * qvel[v1]
            if b2:
                frc[v2] -= b2 * qvel[v2]
            d.ctrl[act] = drive_at(d.time)
        except Exception as err:  # noqa: BLE001 - re-raised by the caller after the step
            if not errors:
                errors.append(err)

    return callback


def commit_state(plant: Union[Plant, JointLaw], slider_state: list, phi_rad: float) -> None:
    """Advance the stateful terms' memory to the accepted angle ``phi_rad`` (after a step)."""
    at = 0
    for t in Plant.of(plant).law.terms:
        if t.stateful:
            t.commit(phi_rad, slider_state, at)
            at += t.n_states


@contextlib.contextmanager
def _activated(native_law, d) -> Iterator[None]:
    """Register this simulation's native parameters under its MjData for the block (no-op for None)."""
    if native_law is None:
        yield
        return
    native_law.activate(d)
    try:
        yield
    finally:
        native_law.deactivate(d)


def set_inertias(m: mujoco.MjModel, dofs, targets_kgm2, current_kgm2) -> None:
    """Give the hinge at each dof of ``m`` (a private copy) the inertia about its axis in
    ``targets_kgm2`` (kg m^2), scaling its body's inertia tensor (a slide: its body's mass, in
    kg), and recompute the model's
    constants. MuJoCo 4 precomputes the mass matrix of simple bodies (``dof_M0``, in
    ``mj_setConst``): scaling ``body_inertia`` alone leaves the simulated inertia unchanged.
    Call it before any passive callback is installed (``mj_setConst`` runs the pipeline)."""
    for dof, target, now in zip(dofs, targets_kgm2, current_kgm2):
        body = m.jnt_bodyid[m.dof_jntid[dof]]
        if m.jnt_type[m.dof_jntid[dof]] == mujoco.mjtJoint.mjJNT_SLIDE:
            m.body_mass[body] *= target / now  # a slide's "inertia" is its body's mass (kg)
        else:
            m.body_inertia[body] *= target / now
    mujoco.mj_setConst(m, mujoco.MjData(m))


def _check_warnings(d: mujoco.MjData, where: str) -> None:
    raised = [(mujoco.mjtWarning(i).name, w.number, w.lastinfo) for i, w in enumerate(d.warning)
              if w.number > 0]
    if raised:
        desc = ", ".join(f"{name} x{n} (info {info})" for name, n, info in raised)
        raise Diverged(f"{where}: MuJoCo warned: {desc}; the simulation diverged or is "
                       f"invalid (reduce max_step_s or the drive amplitude)", desc)


def simulate_steady_state(
    rig: RigModel,
    omega_rad_s: float,
    amplitude_Nm: float,
    config: SimulationConfig = SimulationConfig(),
    *,
    law: Optional[Union[JointLaw, Plant]] = None,
    drive: Optional[PeriodicDrive] = None,
    inertias_kgm2: Optional[tuple[float, float]] = None,
    start: Optional[StartState] = None,
    backend: str = "auto",
) -> tuple[SteadyStateRecord, SettleInfo]:
    """Drive flywheel 1 with ``amplitude_Nm * cos(omega_rad_s * t)`` from rest at t = 0 until
    steady state, then log ``config.n_periods`` whole periods.

    Starting from rest with a cosine drive makes the rigid-body rotation periodic too
    (its velocity is ``M0 sin(omega t) / (omega (J1 + J2))``), so both absolute angles are.
    For any other drive (or a delay) both flywheels start with the common velocity
    :meth:`PeriodicDrive.mean_free_impulse` / (J1 + J2) that keeps the rotation periodic.

    The work is done in four parts: the arguments are checked (:func:`_checked_drive`), a
    private copy of the model gets the run's step and inertias (:func:`_run_model`), the
    initial state is set (:func:`_set_initial_state`), a backend is chosen once
    (:func:`_backend`) and the settle loop (:func:`_settle`) advances it period by period.

    Args:
      law: joint law, or a :class:`vocab.plant.Plant` (law + bearing drag + drive delay),
        to simulate; default the model's own.
      drive: a general periodic drive (its fundamental must be ``omega_rad_s``) instead of the
        cosine; ``amplitude_Nm`` is then only a label.
      inertias_kgm2: (J1, J2) to simulate instead of the model's (each body's inertia tensor
        is scaled, so the moment about the hinge becomes the given value).
      backend: one of :data:`BACKENDS`: ``"native"``, the compiled C callback
        (:mod:`rig.native_callback`): the same numbers, without the Python interpreter in every
        force evaluation. A law without stateful terms is then integrated a whole period per
        ``mujoco.rollout`` call (no Python between steps, the GIL released); a law with sliders
        (Jenkins, Iwan) is stepped in C with its sliders committed after every step; the
        records are bit-identical to stepping. ``"python"``: the Python callback;
        ``"native-stepped"``: the C callback stepped from Python (what the other two are checked
        against); ``"auto"`` (the default): native wherever the machine can build it and it
        knows every term of the law (:func:`rig.native_callback.choose_native`), else Python.
      start: start from this state at t = 0 instead of rest (continuation from the previous
        sweep point's steady state). Its rigid-body velocity is replaced by the one that
        keeps the rotation periodic under this drive; the relative motion is kept.

    The record's torque is the drive as recorded: with a drive delay it is the torque before
    the delay (what a torque cell upstream of the delay reads), otherwise the actuator force.

    Returns:
      The record (angles, rates and applied torque at the sample times) and settle info.

    Raises:
      SimulationError: MuJoCo warned, values went non-finite, or the callback failed.
      SteadyStateNotReached: no steady state within ``config.max_periods``.
    """
    plant = rig.plant if law is None else Plant.of(law)
    drive = _checked_drive(omega_rad_s, amplitude_Nm, drive, inertias_kgm2, start)
    t_start = _time.perf_counter()
    held, static_friction = dry_friction_split(plant)
    if not static_friction:
        return _simulate(rig, omega_rad_s, amplitude_Nm, config, plant, 0.0, drive, inertias_kgm2, start, backend,
                         t_start)
    # One period under the constraint tells whether the joint sticks; the periods asked for are
    # logged by the run that stands (the constraint's again, or the callback's).
    probe, info = _simulate(rig, omega_rad_s, amplitude_Nm, dataclasses.replace(config, n_periods=1), held,
                            static_friction, drive, inertias_kgm2, start, backend, t_start)

    def going_on(plant_now: Plant, static_now: float) -> tuple[SteadyStateRecord, SettleInfo]:
        record, more = _simulate(rig, omega_rad_s, amplitude_Nm, config, plant_now, static_now, drive, inertias_kgm2,
                                 StartState.of_record(probe), backend, t_start)
        return record, dataclasses.replace(more, periods_simulated=info.periods_simulated + more.periods_simulated)

    if sticks(probe):
        return (probe, info) if config.n_periods == 1 else going_on(held, static_friction)
    # The joint only slides through zero rate: the constraint's softness switches the friction
    # about a step early, while sign(rate) in the callback switches within the step; from the
    # constraint's steady state the callback settles in a few periods. Should it not (it
    # sticks after all), the constraint's steady state stands.
    try:
        return going_on(plant, 0.0)
    except SimulationError:
        return (probe, info) if config.n_periods == 1 else going_on(held, static_friction)


#: A joint with dry friction counts as sticking when two successive samples of its steady state
#: have a relative rate below this share of the largest: stuck under the constraint, the rate
#: creeps at <= 1e-7 of it; sliding through zero, two successive samples of a period of N are
#: about 2 pi / N of it apart (measured on the independent bench's points of
#: tests/test_dry_friction_rig.py: 8e-5 at N = 2048 for the smaller of the two).
STICK_RATE = 1e-5


def sticks(record: SteadyStateRecord) -> bool:
    """Whether the joint sticks somewhere in a steady-state record (:data:`STICK_RATE`)."""
    v = np.abs(record.rate1_rad_s - record.rate2_rad_s)
    r = v / max(float(np.max(v)), 1e-300)
    return bool(np.any(np.maximum(r, np.roll(r, -1)) < STICK_RATE))


def _simulate(rig: RigModel, omega_rad_s: float, amplitude_Nm: float, config: SimulationConfig, plant: Plant,
              static_friction: float, drive: PeriodicDrive, inertias_kgm2, start: Optional[StartState], backend: str,
              t_start: float) -> tuple[SteadyStateRecord, SettleInfo]:
    """One run of :func:`simulate_steady_state` with ``plant`` in the callback and
    ``static_friction`` (N m) held by the twist tendon."""
    if choose_native(backend, (plant,), BACKENDS):
        backend = "native-stepped" if backend == "native-stepped" else "native"
    else:
        backend = "python"
    where = f"{rig.path.name} at omega = {omega_rad_s:g} rad/s, M0 = {amplitude_Nm:g} N m"
    m = _run_model(rig, config, omega_rad_s, inertias_kgm2)
    if static_friction:
        if rig.twist_tendon < 0:
            raise SimulationError(f"{where}: the law has dry friction but the model has no '{TWIST_TENDON}' tendon "
                                  f"to hold it (load the model with rig.model.load_rig)")
        m.tendon_frictionloss[rig.twist_tendon] = static_friction
    d = mujoco.MjData(m)
    J = (rig.J1_kgm2, rig.J2_kgm2) if inertias_kgm2 is None else inertias_kgm2
    _set_initial_state(rig, d, drive, plant, J, start)
    n, k = config.samples_for(omega_rad_s), config.steps_per_sample(omega_rad_s)
    stepper = _backend(backend, rig, plant, drive, m, d, n, k)
    watched, names = _watched_two_flywheels(config)
    jump = (_Jump(d, rig.qpos_adr, rig.dof_adr, J)
            if config.accelerate and not any(t.stateful for t in plant.law.terms) else None)
    with stepper.installed():
        periods, settle = _settle(stepper.advance, watched, names, lambda pl: bool(np.all(np.isfinite(pl[0]))),
                                  lambda: stepper.errors[0] if stepper.errors else None, config, d, where, t_start,
                                  jump)
    data = np.vstack([pl[0] for pl in periods])
    t_rec = np.concatenate([pl[1] for pl in periods])
    torque = data[:, 4] if plant.drive_delay_s == 0 else drive(t_rec)
    record = SteadyStateRecord(
        omega_rad_s=float(omega_rad_s), time_s=t_rec, torque_Nm=torque,
        phi1_rad=data[:, 0], phi2_rad=data[:, 1], rate1_rad_s=data[:, 2], rate2_rad_s=data[:, 3],
        n_periods=config.n_periods, drive_amplitude_Nm=float(amplitude_Nm), source=where,
    )
    p, change, bound, ratio = settle
    info = SettleInfo(periods_simulated=p, last_change=change, timestep_s=m.opt.timestep,
                      wall_time_s=_time.perf_counter() - t_start, error_bound=bound, decay_ratio=ratio)
    log.debug("%s: steady after %d periods (change %.2g), dt %.3g s, %.2f s wall", where,
              p - config.n_periods + 1, change, m.opt.timestep, info.wall_time_s)
    return record, info


def _checked_drive(omega_rad_s: float, amplitude_Nm: float, drive: Optional[PeriodicDrive],
                   inertias_kgm2: Optional[tuple[float, float]], start: Optional[StartState]) -> PeriodicDrive:
    """The run's drive (the cosine unless given), after checking every argument of a run."""
    if not (math.isfinite(omega_rad_s) and omega_rad_s > 0):
        raise ValueError(f"omega_rad_s must be a finite number > 0, got {omega_rad_s}")
    if not math.isfinite(amplitude_Nm):
        raise ValueError(f"amplitude_Nm must be finite, got {amplitude_Nm}")
    if drive is None:
        drive = PeriodicDrive.cosine(omega_rad_s, amplitude_Nm)
    elif abs(drive.omega_rad_s - omega_rad_s) > 1e-12 * omega_rad_s:
        raise ValueError(f"drive fundamental {drive.omega_rad_s} rad/s differs from omega_rad_s {omega_rad_s}")
    if inertias_kgm2 is not None:
        for name, target in zip(("J1", "J2"), inertias_kgm2):
            if not (math.isfinite(target) and target > 0):
                raise ValueError(f"inertias_kgm2: {name} must be a finite number > 0, got {target}")
    if start is not None:
        vals = (start.phi1_rad, start.phi2_rad, start.rate1_rad_s, start.rate2_rad_s)
        if not all(math.isfinite(v) for v in vals):
            raise ValueError(f"start state must be finite, got {start}")
    return drive


def _run_model(rig: RigModel, config: SimulationConfig, omega_rad_s: float,
               inertias_kgm2: Optional[tuple[float, float]]) -> mujoco.MjModel:
    """A private copy of the rig's model with the run's integrator, step and inertias (the
    shared MjModel stays untouched)."""
    m = copy.copy(rig.model)
    if inertias_kgm2 is not None:
        set_inertias(m, rig.dof_adr, inertias_kgm2, (rig.J1_kgm2, rig.J2_kgm2))
    m.opt.integrator = mujoco.mjtIntegrator.__members__[config.mj_integrator_name]
    m.opt.timestep = config.timestep_s(omega_rad_s)
    return m


def _set_initial_state(rig: RigModel, d: mujoco.MjData, drive: PeriodicDrive, plant: Plant,
                       J_kgm2: tuple[float, float], start: Optional[StartState]) -> None:
    """Rest (or ``start``'s relative motion) plus the rigid-body velocity that keeps the
    rotation periodic under this drive (0 for a cosine)."""
    J1, J2 = J_kgm2
    v_rigid = drive.mean_free_impulse(0.0, plant.drive_delay_s) / (J1 + J2)
    if start is None:
        d.qvel[list(rig.dof_adr)] = v_rigid
        return
    q1, q2 = rig.qpos_adr
    rel_rate = start.rate1_rad_s - start.rate2_rad_s
    d.qpos[q1], d.qpos[q2] = start.phi1_rad, start.phi2_rad
    d.qvel[rig.dof_adr[0]] = v_rigid + J2 / (J1 + J2) * rel_rate
    d.qvel[rig.dof_adr[1]] = v_rigid - J1 / (J1 + J2) * rel_rate


#: The logged channels, in the order of a period's columns.
_CHANNELS = ("phi1", "phi2", "rate1", "rate2", "drive_torque")


class _Stepper:
    """A backend: installs its passive callback for the run and advances one period of ``n``
    samples of ``k`` steps, returning the sensors at each sample and the sample times."""

    def __init__(self, rig: RigModel, m: mujoco.MjModel, d: mujoco.MjData, n: int, k: int):
        self.m, self.d, self.n, self.k = m, d, n, k
        self.idx = np.array([rig.sensor_adr[c] for c in _CHANNELS])
        self.q1, self.q2 = rig.qpos_adr
        self.errors: list = []

    def installed(self):
        raise NotImplementedError

    def advance(self) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _stepped(self, commit: Optional[Callable[[float], None]]) -> tuple[np.ndarray, np.ndarray]:
        """One period stepped from Python; ``commit`` (laws with sliders) after every step."""
        m, d, n, k, idx, q1, q2 = self.m, self.d, self.n, self.k, self.idx, self.q1, self.q2
        buf = np.empty((n, len(idx)))
        tbuf = np.empty(n)
        for i in range(n):
            tbuf[i] = d.time
            mujoco.mj_step(m, d)  # sensordata now hold the state at tbuf[i]
            buf[i] = d.sensordata[idx]
            if commit is not None:  # commit the memory at every accepted state
                commit(float(d.qpos[q1] - d.qpos[q2]))
                for _ in range(k - 1):
                    mujoco.mj_step(m, d)
                    commit(float(d.qpos[q1] - d.qpos[q2]))
            elif k > 1:
                mujoco.mj_step(m, d, nstep=k - 1)
        return buf, tbuf


class _PythonStepper(_Stepper):
    """The Python passive callback (:func:`make_callback`), stepped from Python."""

    def __init__(self, rig, plant: Plant, drive: PeriodicDrive, m, d, n, k):
        super().__init__(rig, m, d, n, k)
        self.plant = plant
        self.slider = [0.0] * sum(t.n_states for t in plant.law.terms if t.stateful)
        self.stateful = any(t.stateful for t in plant.law.terms)
        self.callback = make_callback(rig, plant, drive, self.errors, self.slider)

    def installed(self):
        return passive_callback(self.callback)

    def _commit(self, phi: float) -> None:
        commit_state(self.plant, self.slider, phi)

    def advance(self):
        return self._stepped(self._commit if self.stateful else None)


class _NativeStepper(_Stepper):
    """The C callback stepped from Python (sliders committed by the native law)."""

    def __init__(self, rig, plant: Plant, drive: PeriodicDrive, m, d, n, k):
        super().__init__(rig, m, d, n, k)
        self.nat = NativeLaw(rig, plant, drive)
        self.stateful = any(t.stateful for t in plant.law.terms)

    @contextlib.contextmanager
    def installed(self):
        # Inside a native_session the callback is installed already (shared by threads).
        with (contextlib.nullcontext() if session_active() else passive_callback(self.nat.function)), \
                _activated(self.nat, self.d):
            yield

    def advance(self):
        return self._stepped(self.nat.commit if self.stateful else None)


class _NativeRollout(_NativeStepper):
    """A law without sliders: one ``mujoco.rollout`` call per period (no Python between steps)."""

    def __init__(self, *args):
        super().__init__(*args)
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state = np.empty(mujoco.mj_stateSize(self.m, self.spec))

    def advance(self):
        # Row j of `st` is the state after step j, row j of `sd` the sensors computed during
        # step j, i.e. at the state before it (as in _stepped).
        m, d, n, k, state = self.m, self.d, self.n, self.k, self.state
        mujoco.mj_getState(m, d, state, self.spec)
        st, sd = rollout.rollout(m, d, state[None], nstep=n * k)
        tbuf = np.concatenate(([state[0]], st[0, k - 1:-1:k, 0]))
        mujoco.mj_setState(m, d, st[0, -1], self.spec)
        return sd[0, ::k][:, self.idx], tbuf


class _NativeSliders(_NativeStepper):
    """A law with sliders: stepped in C with the sliders committed after every step."""

    def advance(self):
        return self.nat.run(self.m, self.d, self.n, self.k, self.idx)


def _backend(name: str, rig: RigModel, plant: Plant, drive: PeriodicDrive, m, d, n: int, k: int) -> _Stepper:
    """The stepper of a :data:`BACKENDS` name for this plant, chosen once per run."""
    args = (rig, plant, drive, m, d, n, k)
    if name == "python":
        return _PythonStepper(*args)
    if name == "native-stepped":
        return _NativeStepper(*args)
    stateful = any(t.stateful for t in plant.law.terms)
    return _NativeSliders(*args) if stateful else _NativeRollout(*args)


def _settle(advance: Callable[[], tuple], watched: Callable[[tuple], np.ndarray], names: tuple[str, ...],
            finite: Callable[[tuple], bool], failure: Callable[[], Optional[BaseException]],
            config: SimulationConfig, d: mujoco.MjData, where: str, t_start: float,
            jump: Optional[_Jump] = None):
    """Advance period by period until steady state (:func:`settle_bound`), then log
    ``config.n_periods``; shared by the two-flywheel rig and the chains (rig/chain.py).

    Args:
      advance: one period's payload (a tuple of arrays, the sample times last).
      watched: the payload's channels the settle test compares (columns; ``names`` names them).
      finite: whether a payload's state is finite.
      failure: the callback's stored exception, if any (MuJoCo cannot propagate one).
      jump: the period map's state, to extrapolate (``SimulationConfig.accelerate``): every
        ``dim + 2`` periods of a transient still well above ``settle_tol`` and decaying, the
        state jumps to :func:`extrapolated_fixed_point` of the period-boundary states, and the
        settle test starts afresh on the periods simulated from there. A jump farther than ten
        times the chunk's own movement is not taken; after one that made the change grow, the
        next waits until the change is a tenth of what it was then (nearer the fixed point,
        where the period map is nearly linear). At most :data:`MAX_JUMPS` per run, so a model
        whose transient does not decay (no attracting periodic response) is still refused by
        :func:`settles_in_time` on its plain periods.

    Returns ``(payloads, (periods simulated, last change, error bound, decay ratio))``.
    """
    def checked(p: int) -> tuple:  # period p's payload, or why the simulation cannot go on
        payload = advance()
        err = failure()
        if err is not None:
            raise SimulationError(f"{where}: the joint-law callback failed: {err!r}") from err
        _check_warnings(d, where)
        if not finite(payload):
            raise SimulationError(f"{where}: non-finite state in period {p}")
        return payload

    if not config.settle:  # the record's own span from its start: no steady state sought
        return [checked(p) for p in range(1, config.n_periods + 1)], (config.n_periods, math.nan, math.nan, math.nan)
    periods: list[tuple] = []
    changes: list[float] = []  # since the last jump: what settle_bound reads
    history: list[float] = []  # every period's change: what settles_in_time reads
    change, bound, ratio = math.inf, math.inf, math.nan
    worst = "?"
    settled_at = None
    p = 0
    boundary = [jump.state()] if jump is not None else None
    before_jump = None  # the change just before the last jump, until the first change after it
    decay_seen = math.nan  # the last decay ratio below 0.9 that settle_bound measured
    jump_below = math.inf  # jump only while the change is below this (a tenth of a failed jump's)
    jumps = 0
    while True:
        p += 1
        payload = checked(p)
        if settled_at is None:
            if periods:
                cur, prev = watched(payload), watched(periods[-1])
                swing = np.ptp(cur, axis=0)
                diff = np.max(np.abs(cur - prev), axis=0)
                rel = diff / np.where(swing > 0, swing, 1.0)
                change = float(np.max(rel))
                worst = names[int(np.argmax(rel))]
                changes.append(change)
                history.append(change)
                if before_jump is not None:
                    if change > before_jump:  # too far from the linear regime: wait for a tenth
                        jump_below = before_jump / 10
                    before_jump = None
                done, bound, ratio = settle_bound(changes, config.settle_tol, decay_seen)
                if ratio < 0.9:
                    decay_seen = ratio
                if p >= config.min_periods and done:
                    settled_at = p
                elif not settles_in_time(history, config.settle_tol, config.max_periods - p):
                    window = history[-1 - DECAY_WINDOW:]
                    raise SteadyStateNotReached(
                        f"{where}: no steady state in sight after {p} periods: over the last {DECAY_WINDOW} "
                        f"periods the period-to-period change went from {window[0]:.3g} to {window[-1]:.3g}, "
                        f"too slow a decay to reach settle_tol {config.settle_tol:g} within max_periods "
                        f"{config.max_periods} (worst channel '{worst}')")
            periods = [payload]
            if settled_at is None and boundary is not None:
                boundary.append(jump.state())
                if len(boundary) == jump.dim + 3:
                    if (jumps < MAX_JUMPS and changes and changes[-1] < jump_below
                            and _jumped(jump, boundary, changes, config.settle_tol)):
                        jumps += 1
                        before_jump, periods, changes = change, [], []
                        boundary = [jump.state()]
                    else:
                        boundary = boundary[-1:]
            if (settled_at is None and config.max_wall_s is not None
                    and _time.perf_counter() - t_start > config.max_wall_s):
                raise SteadyStateNotReached(
                    f"{where}: no steady state within the wall-clock cap of {config.max_wall_s:g} s ({p} periods "
                    f"simulated; period-to-period change {change:.3g}, estimated distance {bound:.3g} > "
                    f"settle_tol {config.settle_tol:g})")
            if settled_at is None and p >= config.max_periods:
                raise SteadyStateNotReached(
                    f"{where}: no steady state after {p} periods: period-to-period change "
                    f"{change:.3g}, estimated distance to steady state {bound:.3g} > settle_tol "
                    f"{config.settle_tol:g} (worst channel '{worst}'; a drifting absolute angle "
                    f"means the integrator does not keep the rigid-body rotation periodic: use RK4)")
        else:
            periods.append(payload)
        if settled_at is not None and len(periods) == config.n_periods:
            return periods, (p, change, bound, ratio)


#: Extrapolation jumps per run (``SimulationConfig.accelerate``): a decaying transient needs
#: two to four (each cuts the change by 10^2..10^4 near the fixed point).
MAX_JUMPS = 6


def _jumped(jump: _Jump, boundary: list[np.ndarray], changes: list[float], settle_tol: float) -> bool:
    """Jump to the extrapolated steady state when the transient is still well above the
    tolerance and fell by at least a tenth over the chunk, and the extrapolation stays within ten times the
    chunk's own movement (a far jump means the map is not yet near its fixed point's linear
    regime). Returns whether it jumped."""
    if len(changes) < 2 or changes[-1] <= 10 * settle_tol:
        return False
    if not changes[-1] < 0.9 * changes[0]:
        # A slow decay (a small drag to ground: the common rate over J_total / b, 1% a period) is
        # what a jump is for, when it is steady: every period's change below the one before. An
        # undamped mode's beat rises and falls, and its orbit is not attracting: no jump.
        steady = len(changes) > 3 and bool(np.all(np.diff(changes) < 0))
        if not (steady and changes[-1] < 0.99 * changes[0]):
            return False
    z = extrapolated_fixed_point(boundary)
    if z is None or not np.all(np.isfinite(z)):
        return False
    Z = np.asarray(boundary)
    scale = np.max(np.abs(Z), axis=0) + 1e-300
    moved = float(np.sum(np.linalg.norm(np.diff(Z, axis=0) / scale, axis=1)))
    # A geometric transient of ratio r a period is moved/(1 - r) per period from its fixed point:
    # ten times that is allowed (a slow mode, r = 0.99, lies 100 periods' movement away)
    r = (changes[-1] / changes[0]) ** (1.0 / (len(changes) - 1))
    if not float(np.linalg.norm((z - Z[-1]) / scale)) <= 10 * moved / max(1.0 - r, 0.01):
        return False
    jump.put(z)
    return True


def _watched_two_flywheels(config: SimulationConfig):
    """The settle test's channels of a two-flywheel period: the relative angle (the joint's)
    and both rates, plus the absolute angles only when they must repeat too."""
    absolute = config.absolute_angles_periodic
    names = ("phi1 - phi2",) + _CHANNELS[2:4] + (_CHANNELS[:2] if absolute else ())

    def watched(payload):
        b = payload[0]
        return np.column_stack([b[:, 0] - b[:, 1], b[:, 2:4]] + ([b[:, :2]] if absolute else []))

    return watched, names
