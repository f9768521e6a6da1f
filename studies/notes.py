"""What the diagnosis notes about the data and how it treated them, as values (pure data): the
numbers and places each note is about, made once where the diagnosis decides; the sentences are
made from them in one place, :func:`present.notes.note_text`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional


@dataclass(frozen=True)
class BandCut:
    """The band fitted is narrower than asked: run ``run`` holds ``samples_per_period`` samples per
    period, enough for harmonics 1..``top``, not 1..``asked``."""

    top: int
    asked: int
    run: str
    samples_per_period: int


@dataclass(frozen=True)
class FixedFidelity:
    """The model fidelity stayed at the fixed ``fidelity`` (of each run's largest balanced torque).

    ``model``: the model whose replay would have measured it. Either the replay failed
    (``failure``: the rig's reason), or it was measured (``measured``: its share of the balanced
    torque) and left the best model at ``chi2_per_dof`` on records whose chi-square cannot test a
    model: ``noise_free_below`` (records noise-free below that share of every channel) or
    ``two_periods`` (a noise estimate of two periods)."""

    fidelity: float
    model: str
    failure: Optional[str] = None
    measured: float = float("nan")
    chi2_per_dof: float = float("nan")
    noise_free_below: Optional[float] = None
    two_periods: bool = False


@dataclass(frozen=True)
class BodyRests:
    """In run ``run``, body ``body`` rests ``rest`` of its period (its rate below ``rest_below`` of its
    peak): its equation is balanced only where its rate exceeds ``balanced_above`` of its peak
    (``masked`` of the period left out, in every model compared)."""

    run: str
    body: int
    rest: float
    masked: float
    rest_below: float
    balanced_above: float


@dataclass(frozen=True)
class JointSticks:
    """In run ``run``, joint ``joint`` may stick: its twist rests ``rest`` of its period (``resolved``),
    or is not resolved above the noise. Its two bodies' equations are balanced as their sum, and
    one of them on its own where the joint slides when ``left_out`` (the share of the period left
    out there) is below 1."""

    run: str
    joint: int
    rest: float
    resolved: bool
    left_out: float
    rest_below: float
    balanced_above: float


@dataclass(frozen=True)
class NoSpringToFrame:
    """Bodies (1-based) with no spring to the frame: every replay adds the constant load that leaves
    them without drift, and compares the motion about its mean."""

    bodies: tuple


@dataclass(frozen=True)
class Spanned:
    """A replay compared over the record's own periods from its measured state, not in a steady
    state: the ``model`` (nominal or extended) under the drive of ``record``, which reached no
    periodic steady state within ``max_periods`` periods (or ``max_wall_s`` s, when set)."""

    model: str
    record: str
    max_periods: int
    max_wall_s: Optional[float] = None


@dataclass(frozen=True)
class RelativeAngle:
    """The relative angle alone: one body of inertia J1 J2/(J1 + J2) driven by ``share`` of the
    torque (from the user's model when ``from_model``)."""

    share: float
    from_model: bool = False
