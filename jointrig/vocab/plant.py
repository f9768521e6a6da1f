"""The plant around the joint: the law plus effects that are not in the joint, and the drive.

:class:`Plant` is what the rig simulates and what the diagnosis fits:

* ``law``: the joint law (:class:`vocab.law.JointLaw`, any terms, including backlash
  in ``Power.gap_rad``, dry friction and hysteresis);
* ``bearing1_damping_Nms_per_rad`` / ``bearing2_damping_Nms_per_rad``: viscous drag of
  flywheel 1 / 2 to ground (bearing friction: it acts on the absolute rate, not through the
  joint);
* ``drive_delay_s``: the torque reaches flywheel 1 this long after it is recorded.

:class:`PeriodicDrive` is a periodic drive torque given by its Fourier coefficients (the
convention of :mod:`identify.harmonics`), evaluated at continuous time in the rig's callback.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from .law import JointLaw, Power, law_parameters
from .params import BEARING1, BEARING2, DRIVE_DELAY

__all__ = ["Plant", "PeriodicDrive", "effect_parameters", "drive_of_record"]


@dataclass(frozen=True)
class PeriodicDrive:
    """``T(t) = sum_n Re(coeffs[n] exp(i n omega t))`` in N m, n = 1..len(coeffs) - 1.

    ``coeffs[0]`` (a constant torque) must be 0: it would spin the free rig up without bound.
    """

    omega_rad_s: float
    coeffs: tuple[complex, ...]

    def __post_init__(self):
        if not (math.isfinite(self.omega_rad_s) and self.omega_rad_s > 0):
            raise ValueError(f"PeriodicDrive.omega_rad_s must be a finite number > 0, got {self.omega_rad_s}")
        c = tuple(complex(v) for v in self.coeffs)
        if len(c) < 2:
            raise ValueError("PeriodicDrive needs coefficients for harmonics 0 and 1 at least")
        if not all(cmath.isfinite(v) for v in c):
            raise ValueError(f"PeriodicDrive.coeffs must be finite, got {c}")
        if c[0] != 0:
            raise ValueError(f"PeriodicDrive.coeffs[0] (constant torque) must be 0, got {c[0]}: a constant "
                             f"drive torque spins the free rig up without bound")
        object.__setattr__(self, "coeffs", c)
        object.__setattr__(self, "omega_rad_s", float(self.omega_rad_s))

    @staticmethod
    def cosine(omega_rad_s: float, amplitude_Nm: float) -> "PeriodicDrive":
        return PeriodicDrive(omega_rad_s, (0.0, complex(amplitude_Nm)))

    @property
    def single_cosine_Nm(self) -> Optional[float]:
        """``a`` if the drive is exactly ``a cos(omega t)`` (the fast path of the callbacks), else None."""
        nz = [(n, v) for n, v in enumerate(self.coeffs) if n and v != 0]
        if len(nz) == 1 and nz[0][0] == 1 and nz[0][1].imag == 0.0:
            return nz[0][1].real
        return None

    @property
    def amplitude_Nm(self) -> float:
        """Amplitude of the fundamental (N m)."""
        return abs(self.coeffs[1])

    def evaluator(self, delay_s: float = 0.0):
        """A fast scalar function ``t -> T(t - delay_s)`` for the MuJoCo callback."""
        w = self.omega_rad_s
        cos = math.cos
        a = self.single_cosine_Nm
        if a is not None:
            return lambda t: a * cos(w * (t - delay_s))
        coeffs = list(self.coeffs)
        top = max((n for n, v in enumerate(coeffs) if v != 0), default=0)  # 0: no drive at all
        coeffs = coeffs[: top + 1]
        rot = cmath.exp

        def at(t):  # Horner in exp(i w t): one complex exponential per call
            e = rot(1j * w * (t - delay_s))
            acc = 0j
            for c in reversed(coeffs):
                acc = acc * e + c
            return acc.real

        return at

    def delayed(self, delay_s: float) -> "PeriodicDrive":
        """The drive ``T(t - delay_s)`` as a drive of its own: every harmonic n turned by
        ``-n omega delay_s`` (for a simulator that evaluates drives without a delay of its own)."""
        w = self.omega_rad_s
        return PeriodicDrive(w, tuple(c * cmath.exp(-1j * n * w * delay_s) for n, c in enumerate(self.coeffs)))

    def mean_free_impulse(self, t_s: float, delay_s: float = 0.0) -> float:
        """The zero-mean antiderivative of ``T(t - delay_s)`` at ``t_s`` (N m s).

        A free rigid body started at ``t_s`` with velocity ``mean_free_impulse / J`` rotates
        periodically under this drive (no drift); from rest it would drift unless it is 0.
        """
        w = self.omega_rad_s
        return float(sum((v * cmath.exp(1j * n * w * (t_s - delay_s)) / (1j * n * w)).real
                         for n, v in enumerate(self.coeffs) if n))

    def __call__(self, t_s) -> np.ndarray:
        t = np.asarray(t_s, dtype=float)
        n = np.arange(len(self.coeffs))
        return np.real(np.exp(1j * np.multiply.outer(t, n * self.omega_rad_s)) @ np.asarray(self.coeffs))


@dataclass(frozen=True)
class Plant:
    """The joint law and the effects outside the joint (SI, names carry the units)."""

    law: JointLaw
    bearing1_damping_Nms_per_rad: float = 0.0
    bearing2_damping_Nms_per_rad: float = 0.0
    drive_delay_s: float = 0.0

    def __post_init__(self):
        if not isinstance(self.law, JointLaw):
            raise TypeError(f"Plant.law must be a JointLaw, got {type(self.law).__name__}")
        for name in (BEARING1, BEARING2, DRIVE_DELAY):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"Plant.{name} must be a finite number >= 0, got {getattr(self, name)!r}")
            object.__setattr__(self, name, v)

    @staticmethod
    def of(law_or_plant) -> "Plant":
        return law_or_plant if isinstance(law_or_plant, Plant) else Plant(law_or_plant)

    def parameters(self) -> dict[str, float]:
        """Every parameter by name: the law's values and the effects' (nonzero ones)."""
        return {**self.law.as_dict(), **effect_parameters(self)}


def effect_parameters(plant: Plant) -> dict[str, float]:
    """Effect parameters that are not law values: free play, slip angle, bearings, delay."""
    out: dict[str, float] = {}
    # Terms without free play may sit beside those with it (an even term added later).
    gaps = {t.gap_rad for t in plant.law.terms if isinstance(t, Power) and t.gap_rad > 0}
    if gaps:
        if len(gaps) > 1:
            raise ValueError(f"the elastic terms have different free plays {sorted(gaps)}")
        out["backlash_half_gap_rad"] = gaps.pop()
    out.update(law_parameters(plant.law.terms, plant.law.values))
    for name in (BEARING1, BEARING2, DRIVE_DELAY):
        if getattr(plant, name):
            out[name] = getattr(plant, name)
    return out


def drive_of_record(omega_rad_s: float, torque_coeffs: Sequence[complex]) -> PeriodicDrive:
    """The drive that replays a record's torque harmonics (its constant part dropped)."""
    c = list(torque_coeffs)
    c[0] = 0.0
    return PeriodicDrive(omega_rad_s, tuple(c))
