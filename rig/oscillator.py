"""A one-degree-of-freedom rig for free-run simulation of an identified law under a measured input.

``J x'' + M_v(x, x') = u(t - delay)`` on the hinge of the drive train of one body
(:func:`rig.chain.chain_model_xml`, the model every train's rig is written from, with N = 1 and
the law to ground): the law and the input act through the same scoped passive callback as the
two-flywheel rig
(:func:`rig.callback.passive_callback`), the input evaluated at ``d.time`` (RK4 stage times).
:func:`simulate_free_run_reference` integrates the same equation with scipy as an independent check.
"""

from __future__ import annotations

import math
from typing import Callable

import mujoco
import numpy as np
from scipy.integrate import odeint

from jointrig.vocab.law import JointLaw

from .callback import passive_callback
from .simulate import SimulationError, _check_warnings

__all__ = ["simulate_free_run", "simulate_free_run_reference"]

def _compile(inertia: float) -> mujoco.MjModel:
    """The train of one body with inertia ``inertia`` (its hinge ``phi1``), compiled."""
    from jointrig.identify.chain import ChainPlant

    from .chain import chain_model_xml

    if not (math.isfinite(inertia) and inertia > 0):
        raise ValueError(f"inertia must be finite and > 0, got {inertia}")
    return mujoco.MjModel.from_xml_string(chain_model_xml(ChainPlant((), (0.0,), (None,)), (inertia,), (1,)))


def simulate_free_run(
    law: JointLaw,
    inertia: float,
    u: Callable[[float], float],
    n_samples: int,
    fs_Hz: float,
    *,
    substeps: int = 4,
    delay_s: float = 0.0,
    backend: str = "auto",
) -> np.ndarray:
    """Free-run response x at the sample times ``n / fs_Hz``, n = 0..n_samples-1, from rest.

    Args:
      u: input as a function of time (s), e.g. :class:`identify.signals.BandlimitedInput`.
      substeps: RK4 steps per sample.
      backend: ``"native"`` (the C callback, :class:`rig.native_callback.NativeOscillator`,
        stepped in C: for a :class:`~identify.signals.BandlimitedInput` and a law without
        sliders), ``"python"`` (the callback in Python), or ``"auto"``: native where it
        applies and a C compiler builds it, else Python. The same numbers either way
        (tests/test_native_callback.py); native is ~40x faster.

    Raises:
      SimulationError: MuJoCo warned or the response went non-finite (diverging model).
    """
    m = _compile(inertia)  # compiled before the callback is installed
    m.opt.timestep = 1.0 / (fs_Hz * substeps)
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    d = mujoco.MjData(m)
    adr = int(m.sensor_adr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "phi1")])
    where = f"free run of {n_samples} samples at {fs_Hz:g} Hz"
    if backend not in ("auto", "native", "python"):
        raise ValueError(f"backend must be 'auto', 'native' or 'python', got {backend!r}")
    if backend != "python":
        from jointrig.identify.signals import BandlimitedInput

        from .native_callback import NativeBuildError, NativeOscillator

        fits = isinstance(u, BandlimitedInput) and not any(t.stateful for t in law.terms)
        if backend == "native" and not fits:
            raise ValueError("the native free run needs a BandlimitedInput and a law without sliders")
        if fits:
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "phi1")
            try:
                nat = NativeOscillator(law, m.jnt_qposadr[j], m.jnt_dofadr[j], u.grid, u.fs_Hz * u.upsample, delay_s)
            except NativeBuildError:
                if backend == "native":
                    raise
            else:
                return _native_free_run(nat, m, d, adr, n_samples, substeps, where)
    torque = law.torque
    errors: list = []

    def callback(m_, d_):
        try:
            d_.qfrc_passive[0] += u(d_.time - delay_s) - torque(float(d_.qpos[0]), float(d_.qvel[0]))
        except Exception as err:  # noqa: BLE001 - re-raised below
            if not errors:
                errors.append(err)

    out = np.empty(n_samples)
    with passive_callback(callback):
        for i in range(n_samples):
            mujoco.mj_step(m, d)  # sensordata: state at t = i / fs
            out[i] = d.sensordata[adr]
            if substeps > 1:
                mujoco.mj_step(m, d, nstep=substeps - 1)
            if i % 1024 == 0 or i == n_samples - 1:
                if errors:
                    raise SimulationError(f"{where}: callback failed: {errors[0]!r}") from errors[0]
                _check_warnings(d, where)
                if not math.isfinite(out[i]) or abs(out[i]) > 1e6:
                    raise SimulationError(f"{where}: response diverged at sample {i}")
    return out


def _native_free_run(nat, m, d, adr: int, n_samples: int, substeps: int, where: str) -> np.ndarray:
    """:func:`simulate_free_run` stepped in C, 1024 samples at a time between the checks."""
    from .simulate import _activated

    out = np.empty(n_samples)
    idx = np.array([adr])
    with passive_callback(nat.function), _activated(nat, d):
        for start in range(0, n_samples, 1024):
            n = min(1024, n_samples - start)
            buf, _ = nat.run(m, d, n, substeps, idx)
            out[start: start + n] = buf[:, 0]
            if nat.error:
                raise SimulationError(f"{where}: the native callback met a law term it does not know")
            _check_warnings(d, where)
            bad = np.flatnonzero(~np.isfinite(out[start: start + n]) | (np.abs(out[start: start + n]) > 1e6))
            if bad.size:
                raise SimulationError(f"{where}: response diverged at sample {start + int(bad[0])}")
    return out


def free_run_rms(law: JointLaw, inertia: float, u: np.ndarray, y: np.ndarray, fs_Hz: float,
                 scored: dict, *, substeps: int = 4, delay_s: float = 0.0) -> tuple[dict, np.ndarray]:
    """Free run of the model under the measured input ``u`` (band-limited between samples:
    :class:`identify.signals.BandlimitedInput`) in the rig, and the RMS error against ``y``
    (data units) over each named slice of ``scored``. Returns ``({name: rms}, simulated)``."""
    from jointrig.identify.signals import BandlimitedInput

    sim = simulate_free_run(law, inertia, BandlimitedInput(u, fs_Hz), u.size, fs_Hz, substeps=substeps,
                            delay_s=delay_s)
    return {name: float(np.sqrt(np.mean((sim[s] - y[s]) ** 2))) for name, s in scored.items()}, sim


def simulate_free_run_reference(
    law: JointLaw,
    inertia: float,
    u: Callable[[float], float],
    n_samples: int,
    fs_Hz: float,
    *,
    delay_s: float = 0.0,
    rtol: float = 1e-9,
) -> np.ndarray:
    """The same free run with scipy's LSODA (``scipy.integrate.odeint``, adaptive, ``rtol``): the
    reference path, sampled at ``n / fs_Hz``.

    LSODA is the fastest of scipy's methods here (the piecewise-linear input interpolation has a
    kink at every fine-grid point, which costs the high-order methods many rejected steps), and
    ``odeint`` calls it with a third of ``solve_ivp``'s Python work per right-hand side (1.7 M
    calls on 4096 Silverbox samples: 3.5 s instead of 8.8 s, the same trajectory to 7e-10 V).
    """
    inv_inertia = 1.0 / inertia

    def rhs(s, t):
        x, v = float(s[0]), float(s[1])
        return (v, (u(t - delay_s) - law.torque(x, v)) * inv_inertia)

    t_eval = np.arange(n_samples) / fs_Hz
    y, info = odeint(rhs, (0.0, 0.0), t_eval, rtol=rtol, atol=1e-14, mxstep=1_000_000, full_output=True)
    if info["message"] != "Integration successful.":
        raise SimulationError(f"scipy reference (LSODA) failed: {info['message']}")
    return y[:, 0]
