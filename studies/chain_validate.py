"""The gain of a chain's extended model on held-out runs, measured in the rig.

Each held-out run's recorded drive torques (their harmonics) are replayed in the chain rig on
the nominal fit's plant and on the extended fit's (identified inertias and laws); the
simulated joint twists are compared with the measured ones, harmonics 1..band of the period
average. The error of a model is ``sqrt(sum |sim - meas|^2 / sum |meas|^2)`` over every joint,
harmonic and held-out run; the gain is nominal error / extended error. The measured twists
carry noise: the error an exact model would have (the noise of the averaged harmonics) is
reported beside it as the floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional, Sequence

import numpy as np

from jointrig.identify.chain import ChainRecord
from jointrig.identify.chain_diagnose import ChainDiagnosis, plant_and_inertias
from jointrig.identify.harmonics import fourier_coefficients, max_harmonic
from jointrig.identify.periods import period_spectra
from jointrig.vocab.plant import drive_of_record

from jointrig.rig.chain import ChainRig, simulate_chain
from jointrig.rig.simulate import SimulationConfig, SteadyStateNotReached

__all__ = ["ChainValidation", "validate_chain", "twist_error"]


@dataclass(frozen=True)
class ChainValidation:
    """Output error of the nominal and the extended model on held-out runs.

    Attributes:
      nominal_error, extended_error: relative RMS error of the joint twists' harmonics.
      noise_floor: the error the noise alone gives (an exact model's).
      per_run: ``(label, nominal error, extended error)`` per held-out run.
      note: what kept a model from being simulated, if anything.
    """

    nominal_error: float
    extended_error: float
    noise_floor: float
    per_run: tuple
    note: str = ""
    #: per held-out run: (measured record, nominal simulation, extended simulation), for plots
    records: tuple = field(default=(), repr=False, compare=False)

    @property
    def gain(self) -> float:
        return self.nominal_error / self.extended_error if self.extended_error > 0 else math.inf

    def as_json(self) -> dict:
        return {"nominal_error": self.nominal_error, "extended_error": self.extended_error, "gain": self.gain,
                "noise_floor": self.noise_floor, "note": self.note,
                "per_run": [{"run": lab, "nominal_error": a, "extended_error": b} for lab, a, b in self.per_run]}


def _twists(rec: ChainRecord, band: int) -> np.ndarray:
    """Harmonics 1..band of every joint's twist, ``(N - 1, band)``."""
    return np.array([fourier_coefficients(rec.angles_rad[j] - rec.angles_rad[j + 1], rec.n_periods, band)[1:]
                     for j in range(rec.n_flywheels - 1)])


def twist_error(sim: ChainRecord, meas: ChainRecord, band: int) -> tuple[float, float]:
    """(sum |sim - meas|^2, sum |meas|^2) over every joint's twist harmonics 1..band."""
    a, b = _twists(sim, band), _twists(meas, band)
    return float(np.sum(np.abs(a - b) ** 2)), float(np.sum(np.abs(b) ** 2))


def _noise(meas: ChainRecord, band: int) -> float:
    """Expected sum |noise|^2 of the averaged twist harmonics (from period-to-period spread)."""
    P = meas.n_periods
    if P < 2:
        return 0.0
    total = 0.0
    for j in range(meas.n_flywheels - 1):
        _, _, var = period_spectra(meas.angles_rad[j] - meas.angles_rad[j + 1], P)
        total += 4.0 * float(np.sum(var[1:band + 1]))  # of the coefficients C_n = 2 X_n, n = 1..band
    return total


def validate_chain(rig: ChainRig, diagnosis: ChainDiagnosis, held_out: Sequence[ChainRecord], *,
                   band: int = 10, config: SimulationConfig = SimulationConfig(samples_per_period=128, max_step_s=5e-5),
                   max_wall_s: Optional[float] = 120.0, backend: str = "auto") -> ChainValidation:
    """Replay every held-out run's drives on the nominal and the extended plant (module docstring);
    ``backend`` as :func:`rig.chain.simulate_chain`'s."""
    cfg = replace(config, absolute_angles_periodic=False, max_wall_s=max_wall_s, n_periods=1)
    models = {"nominal": plant_and_inertias(diagnosis.nominal), "extended": plant_and_inertias(diagnosis.final)}
    num = {k: 0.0 for k in models}
    den = noise = 0.0
    per_run = []
    records = []
    for meas in held_out:
        top = min(band, max_harmonic(meas.samples_per_period))
        coeffs = {i + 1: fourier_coefficients(t, meas.n_periods, max_harmonic(meas.samples_per_period))
                  for i, t in enumerate(meas.torques_Nm) if t is not None}
        drives = {i: drive_of_record(meas.omega_rad_s, c) for i, c in coeffs.items()}
        errs, sims = {}, {}
        for name, (plant, J) in models.items():
            try:
                sim, _ = simulate_chain(rig.with_plant(plant), meas.omega_rad_s, drives, cfg, inertias_kgm2=J,
                                        backend=backend)
            except SteadyStateNotReached as err:
                return ChainValidation(math.nan, math.nan, math.nan, tuple(per_run),
                                       note=f"the {name} model did not settle on {meas.source}: {err}")
            sims[name] = sim
            e, d = twist_error(sim, meas, top)
            num[name] += e
            errs[name] = math.sqrt(e / d)
        den += twist_error(meas, meas, top)[1]
        noise += _noise(meas, top)
        per_run.append((meas.source, errs["nominal"], errs["extended"]))
        records.append((meas, sims["nominal"], sims["extended"]))
    return ChainValidation(math.sqrt(num["nominal"] / den), math.sqrt(num["extended"] / den),
                           math.sqrt(max(noise, 0.0) / den), tuple(per_run), records=tuple(records))
