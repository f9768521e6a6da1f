"""Hidden-effect cases of the chain diagnosis on the independent bench (tests/bench_chain_sim.py).

Each case hides one catalogued effect at one joint of the bench's 4-inertia train (or bearing
drag at one flywheel); the bench measures estimation runs and held-out runs of another level
at 40 dB; the diagnosis (which knows only the nominal structure) must rank the right cause at
the right place first, and the extended model must beat the nominal one on the held-out runs,
replayed in the MuJoCo chain rig, by a gain >= 5. Used by tests/test_chain_diagnose.py (a
subset) and scripts/bench_chain_cases.py (every effect at every joint).

Magnitudes are a few percent of the joint's torque at resonance (joint 2 is half as stiff,
its torque-like effects are halved), what a worn or fretting coupling shows.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from bench_chain_sim import TRAIN, measured_runs, with_effect

from jointrig.identify.chain import ChainRecord
from jointrig.identify.chain_diagnose import diagnose_chain, prepare_chain_runs
from jointrig.rig.chain import load_chain
from jointrig.studies.chain_validate import validate_chain
from jointrig.rig.simulate import SimulationConfig

#: (omega rad/s, amplitude N m, driven flywheel): around the modes (66, 173, 214 rad/s), from both ends.
ESTIMATION = ((40.0, 100.0, 1), (66.0, 100.0, 1), (110.0, 100.0, 1), (175.0, 100.0, 1), (215.0, 100.0, 1),
              (66.0, 100.0, 4), (175.0, 100.0, 4))
#: Held out: another level (150 N m) at other frequencies.
HELD_OUT = ((80.0, 150.0, 1), (140.0, 150.0, 4))
#: Periods measured per held-out run (8 per estimation run). The gain cannot exceed the nominal
#: error over the noise floor of the averaged held-out twists; 16 periods lower that floor by
#: sqrt(2) (at 8, quadratic damping of 10 N m s^2/rad^2 at joint 1 gave 4.9 with the extended
#: model at the floor).
HELD_OUT_PERIODS = 16

#: cause -> bench effect at a joint of stiffness 1e4 N m/rad (scaled by k / 1e4 for torques)
EFFECTS = {
    "coulomb_friction": lambda s: {"Fc": 4.0 * s},
    "backlash": lambda s: {"gap": 0.003},
    "asymmetric_stiffness": lambda s: {"a": 6.0e4 * s},
    "hysteresis": lambda s: {"Fs": 10.0 * s, "r": 0.004},
    "micro_slip": lambda s: {"Fi": 20.0 * s, "smax": 0.01},
    "stribeck_friction": lambda s: {"Fc": 3.0 * s, "Fx": 3.0 * s, "vs": 0.5},
    "quadratic_damping": lambda s: {"q": 10.0 * s},
}

#: The nominal chain model whose bodies and drives replay the held-out runs (inertias replaced).
RIG_CONFIG = SimulationConfig(samples_per_period=128, max_step_s=5e-4)


@dataclass(frozen=True)
class CaseResult:
    cause: str
    place: str
    found: str
    first: str
    gain: float
    magnitude: tuple
    seconds: float
    diagnosis: object = None
    validation: object = None


def records(runs) -> list[ChainRecord]:
    return [ChainRecord(r.omega_rad_s, r.time_s, r.torques_Nm, r.angles_rad, None, r.n_periods, r.amplitude_Nm,
                        source=f"bench chain at {r.omega_rad_s:g} rad/s") for r in runs]


def train_for(cause: str, place: int):
    if cause == "none":
        return TRAIN
    if cause == "bearing_friction":
        b = [0.0] * TRAIN.N
        b[place - 1] = 4.0
        from dataclasses import replace
        return replace(TRAIN, b=tuple(b))
    s = TRAIN.joints[place - 1].k / 1.0e4
    return with_effect(TRAIN, place, **EFFECTS[cause](s))


def run_case(cause: str, place: int, *, snr_db: float = 40.0, seed: int = 0) -> CaseResult:
    t0 = time.perf_counter()
    train = train_for(cause, place)
    est = records(measured_runs(train, ESTIMATION, snr_db=snr_db, seed=seed))
    held = records(measured_runs(train, HELD_OUT, snr_db=snr_db, seed=seed + 1000, n_periods=HELD_OUT_PERIODS))
    d = diagnose_chain(prepare_chain_runs(est))
    # "auto": native wherever a C compiler builds it (bit-identical, 4x faster), else Python
    v = validate_chain(load_chain(_pump_train()), d, held, config=RIG_CONFIG, backend="auto") if d.steps else None
    found = d.steps[0].label if d.steps else "nothing"
    where = "nowhere" if cause == "none" else f"{'flywheel' if cause == 'bearing_friction' else 'joint'} {place}"
    return CaseResult(cause, where, found, d.first_round[0].label, v.gain if v else math.nan,
                      d.steps[0].magnitude if d.steps else (), time.perf_counter() - t0, d, v)


def _pump_train():
    from pathlib import Path
    return Path(__file__).resolve().parent.parent / "models" / "pump_train.xml"
