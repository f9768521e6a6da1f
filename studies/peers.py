"""Peer identification methods on the rig's records, for benchmarks (scripts/bench_rig.py).

* :func:`sysid_identify`: ``mujoco.sysid`` (MuJoCo 4's time-domain identification: rollouts of
  a model whose parameters are edited in its ``MjSpec``, nonlinear least squares on the sensor
  residual). The peer model is the rig with flywheel 2 mounted on flywheel 1 by a relative
  hinge whose native polynomial stiffness ``stiffness="k 0 gamma"`` and damping ``c`` are the
  joint law; both inertias are given. It is given each record's initial state and the exact
  drive averaged over every integrator step (Simpson's rule: what a held control can carry
  of a continuous drive), and the measured sensor times are shifted by one step, because a
  rollout's sensor row is computed before its step but stamped with the time after it.
* :func:`sindy_identify`: pysindy (sparse regression on a polynomial library of the relative
  angle, relative rate and drive torque, derivatives by finite differences), with J1, J2
  given, mapping its coefficients to k, c and gamma.

Both need the optional ``peers`` extras (``pip install -e ".[peers]"``: ``mujoco[sysid]`` and
``pysindy``); without them they raise ImportError with that instruction.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from jointrig.vocab.records import SteadyStateRecord

__all__ = ["PeerResult", "peer_model_xml", "sysid_identify", "sindy_identify"]

NAMES = ("k_Nm_per_rad", "c_Nms_per_rad", "gamma_Nm_per_rad3")


@dataclass(frozen=True)
class PeerResult:
    """Identified joint parameters (k in N m/rad, c in N m s/rad, gamma in N m/rad^3), wall time."""

    method: str
    parameters: dict
    wall_time_s: float


def peer_model_xml(J1_kgm2: float, J2_kgm2: float, k: float, c: float, gamma: float, timestep_s: float) -> str:
    """The rig as MuJoCo sees it natively: flywheel 2 on a relative hinge of flywheel 1 with
    polynomial stiffness (k phi_rel + gamma phi_rel^3) and damping c; drive on flywheel 1."""
    return f"""<mujoco model="two_flywheels_native_law">
  <option timestep="{timestep_s!r}" integrator="RK4" gravity="0 0 0"><flag contact="disable"/></option>
  <worldbody>
    <body name="flywheel1">
      <joint name="phi1" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="1" diaginertia="1 1 {J1_kgm2!r}"/>
      <body name="flywheel2">
        <joint name="phi_rel" type="hinge" axis="0 0 1" stiffness="{k!r} 0 {gamma!r}" damping="{c!r}"/>
        <inertial pos="0 0 0" mass="1" diaginertia="1 1 {J2_kgm2!r}"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor name="drive" joint="phi1" gear="1" ctrllimited="false"/></actuator>
  <sensor>
    <jointpos name="phi_rel" joint="phi_rel"/>
    <jointvel name="rate_rel" joint="phi_rel"/>
  </sensor>
</mujoco>"""


def _step_averaged_drive(record: SteadyStateRecord, h: float, n_steps: int) -> np.ndarray:
    """The rig's drive M0 cos(omega t) averaged over each step by Simpson's rule."""
    from jointrig.vocab.plant import PeriodicDrive

    drive = PeriodicDrive.cosine(record.omega_rad_s, record.drive_amplitude_Nm)
    s = np.arange(n_steps) * h + record.time_s[0]
    return (drive(s) + 4 * drive(s + h / 2) + drive(s + h)) / 6


def sysid_identify(records: Sequence[SteadyStateRecord], J1_kgm2: float, J2_kgm2: float, start: dict,
                   timesteps_s: Sequence[float], _sensor_shift_steps: float = 1.0) -> PeerResult:
    """Identify k, c, gamma with ``mujoco.sysid`` from ``start`` (a dict of NAMES)."""
    try:
        import mujoco
        from mujoco import sysid

        sysid.ParameterDict  # noqa: B018 - the module imports empty without the extras
    except (ImportError, AttributeError) as err:
        raise ImportError("mujoco.sysid needs the extras: pip install 'mujoco[sysid]' "
                          "(or pip install -e '.[peers]')") from err
    t0 = time.perf_counter()
    sequences = []
    for i, (r, h) in enumerate(zip(records, timesteps_s)):
        spec = mujoco.MjSpec.from_string(peer_model_xml(J1_kgm2, J2_kgm2, start["k_Nm_per_rad"],
                                                        start["c_Nms_per_rad"], start["gamma_Nm_per_rad3"], h))
        model = spec.compile()
        n = len(r.time_s)
        steps_per_sample = int(round((r.time_s[1] - r.time_s[0]) / h))
        n_steps = n * steps_per_sample
        ctrl = _step_averaged_drive(r, h, n_steps)[:, None]
        phi_rel = -(r.phi1_rad - r.phi2_rad)        # flywheel 2 relative to flywheel 1
        rate_rel = -(r.rate1_rad_s - r.rate2_rad_s)
        init = sysid.create_initial_state(model, np.array([r.phi1_rad[0], phi_rel[0]]),
                                          np.array([r.rate1_rad_s[0], rate_rel[0]]))
        t_rel = r.time_s - r.time_s[0]
        control = sysid.TimeSeries(np.arange(n_steps) * h, ctrl)
        # Sensor rows of a rollout are stamped one step late: stamp the measurement alike.
        sensors = sysid.TimeSeries.from_names(t_rel + _sensor_shift_steps * h, np.column_stack([phi_rel, rate_rel]), model)
        sequences.append(sysid.ModelSequences(f"run{i}", spec, f"run{i}", init, control, sensors))

    params = sysid.ParameterDict()
    lo, hi = 0.1, 10.0

    def modifier(attribute: str, index: int):
        """Set coefficient ``index`` of the relative hinge's polynomial ``attribute`` in the spec."""
        def modify(s, p):
            values = np.array(getattr(s.joint("phi_rel"), attribute))
            values[index] = p.value[0]
            setattr(s.joint("phi_rel"), attribute, values)
        return modify

    for name, attribute, index in (("k_Nm_per_rad", "stiffness", 0), ("gamma_Nm_per_rad3", "stiffness", 2),
                                   ("c_Nms_per_rad", "damping", 0)):
        params.add(sysid.Parameter(name, nominal=start[name], min_value=lo * start[name], max_value=hi * start[name],
                                   modifier=modifier(attribute, index)))
    residual_fn = sysid.build_residual_fn(models_sequences=sequences)
    opt, _ = sysid.optimize(initial_params=params, residual_fn=residual_fn, optimizer="mujoco", verbose=False)
    out = {name: float(opt[name].value[0]) for name in NAMES}
    return PeerResult("mujoco.sysid", out, time.perf_counter() - t0)


def sindy_identify(records: Sequence[SteadyStateRecord], J1_kgm2: float, J2_kgm2: float) -> PeerResult:
    """Identify k, c, gamma with pysindy (the relative motion, J1 and J2 given)."""
    try:
        import pysindy as ps
    except ImportError as err:
        raise ImportError("pysindy is not installed: pip install pysindy (or pip install -e '.[peers]')") from err
    t0 = time.perf_counter()
    xs, us, ts = [], [], []
    for r in records:
        xs.append(np.column_stack([r.phi_rad, r.rate_rad_s]))
        us.append(r.torque_Nm[:, None])
        ts.append(r.time_s - r.time_s[0])
    model = ps.SINDy(feature_library=ps.PolynomialLibrary(degree=3),
                     optimizer=ps.STLSQ(threshold=1e-6, alpha=0.0),
                     differentiation_method=ps.FiniteDifference(order=2, periodic=True))
    model.fit(xs, t=ts, u=us, feature_names=["phi", "rate", "u"])
    coef = model.coefficients()[1]  # d(rate)/dt
    names = model.get_feature_names()
    g = dict(zip(names, coef))
    s = 1 / J1_kgm2 + 1 / J2_kgm2  # phi'' = u / J1 - (c rate + k phi + gamma phi^3) (1/J1 + 1/J2)
    out = {"k_Nm_per_rad": -g.get("phi", math.nan) / s, "c_Nms_per_rad": -g.get("rate", math.nan) / s,
           "gamma_Nm_per_rad3": -g.get("phi^3", math.nan) / s}
    return PeerResult("pysindy", out, time.perf_counter() - t0)
