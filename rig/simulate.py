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
import logging
import math
import threading
import time as _time
from dataclasses import dataclass
from typing import Callable, Iterator, Optional, Union

import mujoco
import numpy as np

from identify.basis import JointLaw, play
from identify.plant import PeriodicDrive, Plant
from identify.records import SteadyStateRecord

from .model import RigModel

__all__ = [
    "SimulationConfig",
    "SettleInfo",
    "SimulationError",
    "SteadyStateNotReached",
    "passive_callback",
    "make_callback",
    "commit_state",
    "simulate_steady_state",
]

log = logging.getLogger(__name__)

_lock = threading.Lock()


class SimulationError(RuntimeError):
    """The simulation diverged or MuJoCo warned (warnings are errors in a test rig)."""


class SteadyStateNotReached(SimulationError):
    """The period-to-period change did not fall below the tolerance in time."""


@dataclass(frozen=True)
class SimulationConfig:
    """How the rig integrates and logs.

    Attributes:
      max_step_s: largest integrator step; the step is ``T / (samples_per_period * k)`` with
        the smallest integer k that respects it, so every period holds whole steps.
      samples_per_period: logged samples per period (uniform).
      settle_tol: steady state is declared when, for every logged channel, the largest
        change between two consecutive periods is below ``settle_tol`` times that channel's
        peak-to-peak swing. A residual transient of relative size eps perturbs the
        harmonic-balance rows by about eps, so 1e-9 keeps it 5 decades below the 1e-4
        identification target; transients decay exponentially, so this costs a few periods.
      min_periods: periods simulated before the first comparison.
      max_periods: give up (SteadyStateNotReached) after this many periods.
      n_periods: steady periods logged into the record.
      integrator: MuJoCo integrator, case-insensitive ("RK4", "Euler", "implicitfast", ...).
      absolute_angles_periodic: require the absolute angles to repeat too. False checks the
        relative angle and the rates only: a drive replayed from many measured harmonics
        leaves the free rotation an integration-error drift (~1e-8 of the swing per period)
        that has no bearing on the joint.
    """

    max_step_s: float = 5e-4
    samples_per_period: int = 256
    settle_tol: float = 1e-9
    min_periods: int = 2
    max_periods: int = 2000
    n_periods: int = 1
    integrator: str = "RK4"
    absolute_angles_periodic: bool = True

    def __post_init__(self):
        if not (self.max_step_s > 0 and math.isfinite(self.max_step_s)):
            raise ValueError(f"max_step_s must be > 0, got {self.max_step_s}")
        if self.samples_per_period < 8:
            raise ValueError(f"samples_per_period must be >= 8, got {self.samples_per_period}")
        if not 0 < self.settle_tol < 1:
            raise ValueError(f"settle_tol must be in (0, 1), got {self.settle_tol}")
        if self.min_periods < 2 or self.max_periods < self.min_periods:
            raise ValueError(f"need 2 <= min_periods <= max_periods, got {self.min_periods}, {self.max_periods}")
        if self.n_periods < 1:
            raise ValueError(f"n_periods must be >= 1, got {self.n_periods}")
        if self.mj_integrator_name not in mujoco.mjtIntegrator.__members__:
            raise ValueError(f"unknown integrator {self.integrator!r}; expected one of "
                             f"{[n[6:] for n in mujoco.mjtIntegrator.__members__]}")

    @property
    def mj_integrator_name(self) -> str:
        return "mjINT_" + self.integrator.upper()

    def steps_per_sample(self, omega_rad_s: float) -> int:
        period = 2 * math.pi / omega_rad_s
        return max(1, math.ceil(period / (self.samples_per_period * self.max_step_s) - 1e-9))

    def timestep_s(self, omega_rad_s: float) -> float:
        period = 2 * math.pi / omega_rad_s
        return period / (self.samples_per_period * self.steps_per_sample(omega_rad_s))


@dataclass(frozen=True)
class SettleInfo:
    """How a run reached steady state: periods simulated, last relative change, wall time."""

    periods_simulated: int
    last_change: float
    timestep_s: float
    wall_time_s: float


def make_callback(rig: RigModel, plant: Union[Plant, JointLaw], drive: PeriodicDrive, errors: list,
                  slider_state: Optional[list] = None) -> Callable:
    """The passive callback: joint law between the flywheels, bearing drag, and the drive.

    The drive is ``drive(d.time - plant.drive_delay_s)``. Stateful law terms
    (:class:`identify.basis.Jenkins`) take their state from ``slider_state`` (one float per
    stateful term, in law order), which the caller commits after every step with
    :func:`commit_state`. Exceptions raised inside are stored in ``errors`` (MuJoCo cannot
    propagate them) and the caller raises them after the step.
    """
    plant = Plant.of(plant)
    law = plant.law
    stateless = [(t, v) for t, v in zip(law.terms, law.values) if not t.stateful]
    stateful = [(t, v) for t, v in zip(law.terms, law.values) if t.stateful]
    if stateful and (slider_state is None or len(slider_state) != len(stateful)):
        raise ValueError(f"the law has {len(stateful)} stateful term(s): pass slider_state with one float each")
    torque = JointLaw(tuple(t for t, _ in stateless), tuple(v for _, v in stateless)).torque \
        if stateless else (lambda phi, rate: 0.0)
    q1, q2 = rig.qpos_adr
    v1, v2 = rig.dof_adr
    act = rig.actuator_id
    b1, b2 = plant.bearing1_damping_Nms_per_rad, plant.bearing2_damping_Nms_per_rad
    drive_at = drive.evaluator(plant.drive_delay_s)
    hyst = [(t.torque, v, i) for i, (t, v) in enumerate(stateful)]

    def callback(m, d):
        try:
            qpos, qvel = d.qpos, d.qvel
            phi = float(qpos[q1] - qpos[q2])
            tau = torque(phi, float(qvel[v1] - qvel[v2]))
            for f, v, i in hyst:
                tau += v * f(phi, slider_state[i])
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
    stateful = [t for t in Plant.of(plant).law.terms if t.stateful]
    for i, t in enumerate(stateful):
        slider_state[i] = play(phi_rad, slider_state[i], t.slip_rad)


@contextlib.contextmanager
def passive_callback(callback: Callable) -> Iterator[None]:
    """Install ``callback`` as MuJoCo's global passive callback for the duration of the block.

    Raises:
      RuntimeError: another passive callback is already installed (another rig, in this
        thread or another, or foreign code): sharing it would silently mix two models' forces.
    """
    if not _lock.acquire(blocking=False):
        raise RuntimeError("another jointrig simulation holds MuJoCo's passive callback; "
                           "run rigs one after another (or use separate processes)")
    try:
        previous = mujoco.get_mjcb_passive()
        if previous is not None:
            raise RuntimeError(f"a MuJoCo passive callback is already installed ({previous!r}); "
                               f"jointrig will not replace or share it")
        mujoco.set_mjcb_passive(callback)
        try:
            yield
        finally:
            mujoco.set_mjcb_passive(previous)
    finally:
        _lock.release()


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


def _check_warnings(d: mujoco.MjData, where: str) -> None:
    raised = [(mujoco.mjtWarning(i).name, w.number, w.lastinfo) for i, w in enumerate(d.warning)
              if w.number > 0]
    if raised:
        desc = ", ".join(f"{name} x{n} (info {info})" for name, n, info in raised)
        raise SimulationError(f"{where}: MuJoCo warned: {desc}; the simulation diverged or is "
                              f"invalid (reduce max_step_s or the drive amplitude)")


def simulate_steady_state(
    rig: RigModel,
    omega_rad_s: float,
    amplitude_Nm: float,
    config: SimulationConfig = SimulationConfig(),
    *,
    law: Optional[Union[JointLaw, Plant]] = None,
    drive: Optional[PeriodicDrive] = None,
    inertias_kgm2: Optional[tuple[float, float]] = None,
    native: bool = False,
) -> tuple[SteadyStateRecord, SettleInfo]:
    """Drive flywheel 1 with ``amplitude_Nm * cos(omega_rad_s * t)`` from rest at t = 0 until
    steady state, then log ``config.n_periods`` whole periods.

    Starting from rest with a cosine drive makes the rigid-body rotation periodic too
    (its velocity is ``M0 sin(omega t) / (omega (J1 + J2))``), so both absolute angles are.
    For any other drive (or a delay) both flywheels start with the common velocity
    :meth:`PeriodicDrive.mean_free_impulse` / (J1 + J2) that keeps the rotation periodic.

    Args:
      law: joint law, or a :class:`identify.plant.Plant` (law + bearing drag + drive delay),
        to simulate; default the model's own.
      drive: a general periodic drive (its fundamental must be ``omega_rad_s``) instead of the
        cosine; ``amplitude_Nm`` is then only a label.
      inertias_kgm2: (J1, J2) to simulate instead of the model's (each body's inertia tensor
        is scaled, so the moment about the hinge becomes the given value).
      native: use the compiled C callback (:mod:`rig.native_callback`): the same numbers,
        without the Python interpreter in every force evaluation.

    The record's torque is the drive as recorded: with a drive delay it is the torque before
    the delay (what a torque cell upstream of the delay reads), otherwise the actuator force.

    Returns:
      The record (angles, rates and applied torque at the sample times) and settle info.

    Raises:
      SimulationError: MuJoCo warned, values went non-finite, or the callback failed.
      SteadyStateNotReached: no steady state within ``config.max_periods``.
    """
    if not (math.isfinite(omega_rad_s) and omega_rad_s > 0):
        raise ValueError(f"omega_rad_s must be a finite number > 0, got {omega_rad_s}")
    if not math.isfinite(amplitude_Nm):
        raise ValueError(f"amplitude_Nm must be finite, got {amplitude_Nm}")
    plant = rig.plant if law is None else Plant.of(law)
    if drive is None:
        drive = PeriodicDrive.cosine(omega_rad_s, amplitude_Nm)
    elif abs(drive.omega_rad_s - omega_rad_s) > 1e-12 * omega_rad_s:
        raise ValueError(f"drive fundamental {drive.omega_rad_s} rad/s differs from omega_rad_s {omega_rad_s}")
    where = f"{rig.path.name} at omega = {omega_rad_s:g} rad/s, M0 = {amplitude_Nm:g} N m"
    t_start = _time.perf_counter()
    # Per-run settings on a private copy: the shared MjModel stays untouched.
    m = copy.copy(rig.model)
    if inertias_kgm2 is not None:
        for j, (name, target, now) in enumerate(zip(("J1", "J2"), inertias_kgm2, (rig.J1_kgm2, rig.J2_kgm2))):
            if not (math.isfinite(target) and target > 0):
                raise ValueError(f"inertias_kgm2: {name} must be a finite number > 0, got {target}")
            body = m.jnt_bodyid[m.dof_jntid[rig.dof_adr[j]]]
            m.body_inertia[body] *= target / now
    stateful = [t for t in plant.law.terms if t.stateful]
    slider = [0.0] * len(stateful)
    q1, q2 = rig.qpos_adr
    m.opt.integrator = mujoco.mjtIntegrator.__members__[config.mj_integrator_name]
    m.opt.timestep = config.timestep_s(omega_rad_s)
    k = config.steps_per_sample(omega_rad_s)
    n = config.samples_per_period
    d = mujoco.MjData(m)
    # Start the rigid-body rotation with the velocity that keeps it periodic (0 for a cosine).
    v_rigid = drive.mean_free_impulse(0.0, plant.drive_delay_s) / (rig.J1_kgm2 + rig.J2_kgm2
                                                                   if inertias_kgm2 is None else sum(inertias_kgm2))
    d.qvel[list(rig.dof_adr)] = v_rigid
    adr = rig.sensor_adr
    channels = ("phi1", "phi2", "rate1", "rate2", "drive_torque")
    idx = np.array([adr[c] for c in channels])
    errors: list = []
    periods: list[np.ndarray] = []
    times: list[np.ndarray] = []
    change = math.inf
    worst = "?"
    settled_at = None
    if native:
        from .native_callback import NativeLaw, session_active

        nat = NativeLaw(rig, plant, drive)
        # Inside a native_session the callback is installed already (shared by threads).
        installed = contextlib.nullcontext() if session_active() else passive_callback(nat.function)

        def commit(phi):
            nat.commit(phi)
    else:
        nat = None
        installed = passive_callback(make_callback(rig, plant, drive, errors, slider))

        def commit(phi):
            commit_state(plant, slider, phi)
    with installed, _activated(nat, d):
        p = 0
        while True:
            buf = np.empty((n, len(channels)))
            tbuf = np.empty(n)
            for i in range(n):
                tbuf[i] = d.time
                mujoco.mj_step(m, d)  # sensordata now hold the state at tbuf[i]
                buf[i] = d.sensordata[idx]
                if stateful:  # commit the memory at every accepted state
                    commit(float(d.qpos[q1] - d.qpos[q2]))
                    for _ in range(k - 1):
                        mujoco.mj_step(m, d)
                        commit(float(d.qpos[q1] - d.qpos[q2]))
                elif k > 1:
                    mujoco.mj_step(m, d, nstep=k - 1)
            p += 1
            if errors:
                raise SimulationError(f"{where}: the joint-law callback failed: {errors[0]!r}") from errors[0]
            _check_warnings(d, where)
            if not np.all(np.isfinite(buf)):
                raise SimulationError(f"{where}: non-finite state in period {p}")
            if settled_at is None:
                if periods:
                    cur, prev, names = buf[:, :4], periods[-1][:, :4], channels[:4]
                    if not config.absolute_angles_periodic:
                        cur = np.column_stack([cur[:, 0] - cur[:, 1], cur[:, 2:]])
                        prev = np.column_stack([prev[:, 0] - prev[:, 1], prev[:, 2:]])
                        names = ("phi1 - phi2",) + channels[2:4]
                    swing = np.ptp(cur, axis=0)
                    diff = np.max(np.abs(cur - prev), axis=0)
                    rel = diff / np.where(swing > 0, swing, 1.0)
                    change = float(np.max(rel))
                    worst = names[int(np.argmax(rel))]
                    if p >= config.min_periods and change < config.settle_tol:
                        settled_at = p
                periods = [buf]
                times = [tbuf]
                if settled_at is None and p >= config.max_periods:
                    raise SteadyStateNotReached(
                        f"{where}: no steady state after {p} periods: period-to-period change "
                        f"{change:.3g} > settle_tol {config.settle_tol:g} (worst channel '{worst}'; a "
                        f"drifting absolute angle means the integrator does not keep the rigid-body "
                        f"rotation periodic: use RK4)")
            else:
                periods.append(buf)
                times.append(tbuf)
            if settled_at is not None and len(periods) == config.n_periods:
                break
    data = np.vstack(periods)
    t_rec = np.concatenate(times)
    torque = data[:, 4] if plant.drive_delay_s == 0 else drive(t_rec)
    record = SteadyStateRecord(
        omega_rad_s=float(omega_rad_s), time_s=t_rec, torque_Nm=torque,
        phi1_rad=data[:, 0], phi2_rad=data[:, 1], rate1_rad_s=data[:, 2], rate2_rad_s=data[:, 3],
        n_periods=config.n_periods, drive_amplitude_Nm=float(amplitude_Nm), source=where,
    )
    info = SettleInfo(periods_simulated=p, last_change=change, timestep_s=m.opt.timestep,
                      wall_time_s=_time.perf_counter() - t_start)
    log.debug("%s: steady after %d periods (change %.2g), dt %.3g s, %.2f s wall", where,
              settled_at, change, m.opt.timestep, info.wall_time_s)
    return record, info

