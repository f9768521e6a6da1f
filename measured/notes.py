"""What the reader notes about a file and how it read it, as values (pure data): the numbers,
runs and columns each note is about, made once where the file is read; the sentences are made
from them in one place, :func:`present.notes.note_text`."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class NoUnits:
    """No unit was stated in the file or the options: SI is assumed."""


@dataclass(frozen=True)
class NamesFrom:
    """The column names and units came from the side file ``side``."""

    side: str


@dataclass(frozen=True)
class IgnoredColumns:
    """Columns ``columns`` of table ``where`` are not read (the diagnosis reads at most
    ``max_bodies`` positions and drives)."""

    where: str
    columns: tuple
    max_bodies: int


@dataclass(frozen=True)
class EpochTime:
    """Run ``run``'s time stamps count from ``t0_s`` (an epoch time): its time starts at its first stamp."""

    run: str
    t0_s: float


@dataclass(frozen=True)
class ClockJitter:
    """Run ``run``'s time stamps deviate up to ``max_deviation`` steps from a uniform clock of
    ``dt_s``, which is used."""

    run: str
    max_deviation: float
    dt_s: float


@dataclass(frozen=True)
class LaterFundamental:
    """Run ``run``'s fundamental over the whole record (``whole``, ``whole_se`` rad/s) differs from
    that after its first period (``later``, ``later_se``): a transient at its start; the later is used."""

    run: str
    whole: float
    whole_se: float
    later: float
    later_se: float


@dataclass(frozen=True)
class OmegaDisagrees:
    """Run ``run``'s 'omega' column (``omega`` rad/s) and the record's own period of ``samples``
    samples (``record_omega``) differ; the record's value is used."""

    run: str
    omega: float
    samples: int
    record_omega: float


@dataclass(frozen=True)
class OmegaFromPeriod:
    """Run ``run`` has no 'omega' column and repeats every ``samples`` samples: omega
    ``omega`` rad/s (its ``drive`` channel's line alone gives ``line_omega`` +- ``line_se``)."""

    run: str
    samples: int
    omega: float
    drive: str
    line_omega: float
    line_se: float


@dataclass(frozen=True)
class IncompletePeriod:
    """Run ``run``'s ``samples`` samples hold ``periods`` whole periods of ``per_period``
    samples; the rest, at the start (an incomplete period), is not used."""

    run: str
    samples: int
    per_period: int
    periods: int


@dataclass(frozen=True)
class Resampled:
    """Run ``run`` resampled from ``from_samples`` to ``to_samples`` samples per period
    (harmonics 0..``harmonics``)."""

    run: str
    from_samples: int
    to_samples: int
    harmonics: int


@dataclass(frozen=True)
class LeastSquaresPeriods:
    """Run ``run`` holds ``per_period`` samples per period at ``omega`` rad/s (from ``source``: the
    'omega' column, or the ``drive`` channel's line +- ``source_se``), not a whole number:
    harmonics 0..``harmonics`` of each of its ``periods`` whole periods estimated by least
    squares and synthesised at ``samples`` per period; ``shares`` ``(channel, residual RMS over
    the channel's RMS)``; ``unused`` samples at the start (an incomplete period) not used."""

    run: str
    per_period: float
    omega: float
    drive: str
    source_se: float
    harmonics: int
    periods: int
    samples: int
    shares: tuple
    unused: int
    omega_column: bool = False


@dataclass(frozen=True)
class TransientCut:
    """Run ``run``'s first ``cut`` periods are a transient (beyond ``factor`` times its last two
    periods' own difference): left out, ``kept`` steady periods kept."""

    run: str
    cut: int
    kept: int
    factor: float


@dataclass(frozen=True)
class CommonMotion:
    """Run ``run``'s bodies move together steadily at ``slope`` (``unit``/s) on top of the
    vibration, which is removed: two flywheels' common rotation (``line`` empty), or a whole
    train's (``line``: what the bodies form, "train", "carriage line")."""

    run: str
    slope: float
    unit: str = "rad"
    line: str = ""


@dataclass(frozen=True)
class ZeroPerRun:
    """``--zero-per-run``: each run's positions taken about their own mean (``single``: one body's
    position; else the angles, the joint's zero each run's mean twist)."""

    single: bool


@dataclass(frozen=True)
class PreloadChanges:
    """Joint ``joint``'s mean twist (0: the relative angle's mean) differs between runs by
    ``spread_rad`` as the drives' mean does (by ``drive_spread``): a preload that changes between
    runs, held by each run's replay."""

    joint: int
    spread_rad: float
    drive_spread: float


@dataclass(frozen=True)
class FromValidate:
    """A note of the separate validation record ``path`` (``--validate``)."""

    path: str
    note: object
