"""Ground-truth plants with one hidden effect each (or none, or two): the diagnosis's test set.

Each effect is modest: where it is a torque it is at most 5% of the peak joint torque over the
plan (the peak of the nominal law along the simulated motion is about 1970 N m at
omega = 25 rad/s, M0 = 3500 N m). ``scripts/diagnose_cases.py`` prints how the diagnosis does
on every case (``jointrig cases``); docs/diagnosis.md lists its figures at 40 and 20 dB.
"""

from __future__ import annotations

import zlib
from typing import Optional

import numpy as np

from jointrig.vocab.law import Coulomb, Iwan, Jenkins, JointLaw, Power, QuadraticDamping, Viscous
from jointrig.vocab.plant import Plant
from jointrig.vocab.records import SteadyStateRecord

from jointrig.rig.measurement import add_noise
from jointrig.rig.model import RigModel
from jointrig.rig.simulate import SimulationConfig, simulate_steady_state
from jointrig.vocab.params import BEARING2, DRIVE_DELAY

__all__ = ["BASE", "VALUES", "POINTS", "HIDDEN_EFFECTS", "simulate_case"]

BASE = (Viscous(), Power(1), Power(3))
VALUES = (100.0, 2000.0, 200.0)
#: omega (rad/s) x M0 (N m): three frequencies around the resonance (44.7 rad/s) x three levels.
POINTS = tuple((w, a) for w in (25.0, 40.0, 55.0) for a in (1500.0, 2500.0, 3500.0))


def _gap(g):
    return (Viscous(), Power(1, g), Power(3, g))


#: case -> (plant, {magnitude parameter: true value}); a case named "a+b" hides both.
HIDDEN_EFFECTS: dict[str, tuple[Plant, dict]] = {
    "none": (Plant(JointLaw(BASE, VALUES)), {}),
    "coulomb_friction": (Plant(JointLaw(BASE + (Coulomb(),), VALUES + (95.0,))), {"coulomb_torque_Nm": 95.0}),
    "backlash": (Plant(JointLaw(_gap(0.02), VALUES)), {"backlash_half_gap_rad": 0.02}),
    "asymmetric_stiffness": (Plant(JointLaw(BASE + (Power(2),), VALUES + (200.0,))), {"a_Nm_per_rad2": 200.0}),
    "hysteresis": (Plant(JointLaw(BASE + (Jenkins(0.05),), VALUES + (50.0,))), {"hysteresis_slip_torque_Nm": 50.0}),
    # Micro-slip: the largest slip angle 0.5 rad is beyond all but one run's amplitude (0.14-0.61 rad).
    "micro_slip": (Plant(JointLaw(BASE + (Iwan(0.5, -0.5, 0.1),), VALUES + (80.0,))), {"iwan_slip_torque_Nm": 80.0}),
    "quadratic_damping": (Plant(JointLaw(BASE + (QuadraticDamping(),), VALUES + (1.0,))),
                          {"quadratic_damping_Nms2_per_rad2": 1.0}),
    "drive_delay": (Plant(JointLaw(BASE, VALUES), drive_delay_s=0.001), {DRIVE_DELAY: 0.001}),
    "bearing_friction": (Plant(JointLaw(BASE, VALUES), bearing2_damping_Nms_per_rad=5.0),
                         {BEARING2: 5.0}),
    "coulomb_friction+backlash": (Plant(JointLaw(_gap(0.02) + (Coulomb(),), VALUES + (95.0,))),
                                  {"coulomb_torque_Nm": 95.0, "backlash_half_gap_rad": 0.02}),
}


def simulate_case(rig: RigModel, case: str, *, snr_db: Optional[float] = 40.0, seed: Optional[int] = None,
                  n_periods: int = 16) -> tuple[list[SteadyStateRecord], float]:
    """Measured records of a case (noise seeded by the case name unless ``seed``) and the peak
    joint torque (N m) of its stateless law terms along the clean motion. Simulated with the
    native callback (the Python one's records to 1e-8 of their peak, tests/conftest.py
    ``CALLBACK_RTOL``; the micro-slip case took 14 s with the Python callback)."""
    plant = HIDDEN_EFFECTS[case][0]
    rng = np.random.default_rng(zlib.crc32(case.encode()) if seed is None else seed)
    clean = [simulate_steady_state(rig, w, a, SimulationConfig(n_periods=n_periods), law=plant)[0]
             for w, a in POINTS]
    law = plant.law
    stateless = JointLaw(tuple(t for t in law.terms if not t.stateful),
                         tuple(v for t, v in zip(law.terms, law.values) if not t.stateful))
    peak = max(float(np.max(np.abs(stateless.torque(r.phi_rad, r.rate_rad_s)))) for r in clean)
    return [add_noise(r, snr_db, rng) for r in clean], peak
