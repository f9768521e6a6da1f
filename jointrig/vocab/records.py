"""Steady-state records: the data the identifier consumes, checked on entry."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Optional

import numpy as np

__all__ = ["SteadyStateRecord", "RecordError", "MAX_SI_VALUE"]

#: Largest magnitude of a quantity in SI units the tool accepts, measured or stated in a model
#: file: anything bigger is a corrupt value or a unit slip, not a bench's.
MAX_SI_VALUE = 1e12


class RecordError(ValueError):
    """A record that cannot be identified from (names the field and what was expected)."""


def _as_1d(name: str, x, source: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim != 1:
        raise RecordError(f"{source}: '{name}' must be 1-D, got shape {a.shape}")
    if a.size == 0:
        raise RecordError(f"{source}: '{name}' is empty")
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise RecordError(
            f"{source}: '{name}' holds {int(bad.sum())} non-finite value(s) (first at sample {i}: "
            f"{a[i]}); expected finite numbers"
        )
    a.setflags(write=False)
    return a


class WholePeriods:
    """Samples of a record that holds ``n_periods`` whole periods on the clock ``time_s`` (shared
    by :class:`SteadyStateRecord` and ``identify.chain.ChainRecord``)."""

    def __reduce__(self):
        """Pickled as its constructor's arguments: a record that comes back from a forked worker
        (:func:`jointrig.parallel.fork_map`) is checked again and its arrays are read-only again
        (pickle alone restores numpy arrays writeable)."""
        return type(self), tuple(getattr(self, f.name) for f in fields(self))

    @property
    def n_samples(self) -> int:
        return int(self.time_s.size)

    @property
    def samples_per_period(self) -> int:
        return self.n_samples // self.n_periods


@dataclass(frozen=True)
class SteadyStateRecord(WholePeriods):
    """Whole periods of one steady-state run at one drive setting, sampled uniformly.

    All arrays have shape ``(n_samples,)`` with ``n_samples = n_periods * samples_per_period``
    and ``time_s[k] = time_s[0] + k * 2 pi / (omega_rad_s * samples_per_period)``.

    Attributes:
      omega_rad_s: drive fundamental (rad/s).
      time_s: sample times (s).
      torque_Nm: drive torque applied to flywheel 1 (N m).
      phi1_rad, phi2_rad: flywheel angles (rad). For a record with only the relative angle,
        pass ``phi1_rad = phi`` and ``phi2_rad = None``.
      rate1_rad_s, rate2_rad_s: flywheel rates (rad/s); optional (spectral derivative if None).
      n_periods: number of whole periods held.
      drive_amplitude_Nm: nominal drive amplitude M0 (N m), for labels; NaN if unknown.
      source: where the record came from (used in error messages).
    """

    omega_rad_s: float
    time_s: np.ndarray
    torque_Nm: np.ndarray
    phi1_rad: np.ndarray
    phi2_rad: Optional[np.ndarray]
    rate1_rad_s: Optional[np.ndarray] = None
    rate2_rad_s: Optional[np.ndarray] = None
    n_periods: int = 1
    drive_amplitude_Nm: float = float("nan")
    source: str = field(default="record", compare=False)

    def __post_init__(self):
        src = self.source
        if not (isinstance(self.omega_rad_s, (int, float)) and math.isfinite(self.omega_rad_s)
                and self.omega_rad_s > 0):
            raise RecordError(f"{src}: omega_rad_s must be a finite number > 0, got {self.omega_rad_s!r}")
        if not isinstance(self.n_periods, (int, np.integer)) or self.n_periods < 1:
            raise RecordError(f"{src}: n_periods must be an int >= 1, got {self.n_periods!r}")
        arrays = {"time_s": self.time_s, "torque_Nm": self.torque_Nm, "phi1_rad": self.phi1_rad,
                  "phi2_rad": self.phi2_rad, "rate1_rad_s": self.rate1_rad_s,
                  "rate2_rad_s": self.rate2_rad_s}
        n = None
        for name, value in arrays.items():
            if value is None:
                continue
            a = _as_1d(name, value, src)
            if n is None:
                n = a.size
            elif a.size != n:
                raise RecordError(f"{src}: '{name}' has {a.size} samples, expected {n} like 'time_s'")
            object.__setattr__(self, name, a)
        if self.phi2_rad is None:
            if self.rate2_rad_s is not None:
                raise RecordError(f"{src}: 'rate2_rad_s' given without 'phi2_rad'")
        elif (self.rate1_rad_s is None) != (self.rate2_rad_s is None):
            raise RecordError(f"{src}: give both 'rate1_rad_s' and 'rate2_rad_s' or neither")
        object.__setattr__(self, "omega_rad_s", float(self.omega_rad_s))
        object.__setattr__(self, "n_periods", int(self.n_periods))
        if n % self.n_periods:
            raise RecordError(f"{src}: {n} samples do not split into {self.n_periods} whole periods")
        per = n // self.n_periods
        if per < 8:
            raise RecordError(f"{src}: {per} samples per period is too short; expected at least 8")
        t = self.time_s
        dt = 2.0 * math.pi / (self.omega_rad_s * per)
        steps = np.diff(t)
        if np.any(steps <= 0):
            raise RecordError(f"{src}: 'time_s' must be strictly increasing")
        # 1e-6 relative: sample clocks are integer multiples of the integrator step; a looser
        # mismatch means the record does not hold whole periods and the DFT would leak.
        if np.max(np.abs(steps - dt)) > 1e-6 * dt:
            raise RecordError(
                f"{src}: 'time_s' is not uniform with step 2*pi/(omega*samples_per_period) = {dt:.9g} s "
                f"(observed steps {steps.min():.9g}..{steps.max():.9g} s): the record must hold exactly "
                f"{self.n_periods} period(s) of omega = {self.omega_rad_s:.9g} rad/s; trim it to whole periods"
            )

    @property
    def phi_rad(self) -> np.ndarray:
        """Relative angle ``phi1 - phi2`` (rad)."""
        return self.phi1_rad if self.phi2_rad is None else self.phi1_rad - self.phi2_rad

    @property
    def rate_rad_s(self) -> Optional[np.ndarray]:
        """Relative rate (rad/s), or None if the record carries no rates."""
        if self.rate1_rad_s is None:
            return None
        return self.rate1_rad_s if self.rate2_rad_s is None else self.rate1_rad_s - self.rate2_rad_s
