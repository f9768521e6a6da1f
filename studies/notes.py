"""What the diagnosis notes about the data and how it treated them, as values (pure data): the
numbers and places each note is about, made once where the diagnosis decides; the sentences are
made from them in one place, :func:`present.notes.note_text`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional


#: Why a model could not be replayed (:attr:`NoReplay.why`): a model with no body's inertia; a replay
#: over the record's own span that does not follow it; no periodic steady state (the rig's
#: ``detail``); neither a steady state nor the record's span followed; the model diverged in the
#: rig (MuJoCo warned: ``detail`` names the warnings).
NO_INERTIA, NOT_FOLLOWED, NO_STEADY_STATE, NOR_SPANNED = "no_inertia", "not_followed", "no_steady_state", "nor_spanned"
DIVERGED = "diverged"


@dataclass(frozen=True)
class NoReplay:
    """A model that could not be simulated under the measured drive of run ``run``: ``model`` is
    "nominal" or "extended" (empty: the model whose replay measures the fidelity, named by its
    :class:`FixedFidelity`), ``why`` one of :data:`NO_INERTIA`, :data:`NOT_FOLLOWED`,
    :data:`NO_STEADY_STATE`, :data:`NOR_SPANNED`, :data:`DIVERGED`, ``detail`` the rig's own message
    ("" where none; MuJoCo's warnings where it diverged), ``inertias`` ``(body, value)`` of each inertia that is no body's, ``periods`` the
    record's periods (what a replay over its span had to follow)."""

    model: str
    run: str
    why: str
    detail: str = ""
    inertias: tuple = ()
    periods: int = 0


@dataclass(frozen=True)
class BiasUnmeasured:
    """Why the method's bias on a model was not measured: the nominal law is smooth (``smooth``:
    the balance has no kink to miss), its replays of the fitted runs failed (``failures``,
    :class:`NoReplay`), or no replay of them was made (neither)."""

    smooth: bool = False
    failures: tuple = ()


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
    (``failure``: why, per run, :class:`NoReplay`), or it was measured (``measured``: its share of the balanced
    torque) and left the best model at ``chi2_per_dof`` on records whose chi-square cannot test a
    model: ``noise_free_below`` (records noise-free below that share of every channel) or
    ``two_periods`` (a noise estimate of two periods)."""

    fidelity: float
    model: str
    failure: Optional[tuple] = None
    measured: float = float("nan")
    chi2_per_dof: float = float("nan")
    noise_free_below: Optional[float] = None
    two_periods: bool = False


@dataclass(frozen=True)
class FidelityCycle:
    """The measured fidelity does not settle on one model: the balance's misfit measured on the
    replay of ``one`` (its causes in words) leads the diagnosis to adopt ``other``, and measured on
    ``other``'s replay, back to ``one``. Neither model is adopted under its own fidelity, so
    neither is: the verdict is unexplained (:class:`identify.verdict.Grounds.FIDELITY_CYCLE`)."""

    one: str
    other: str


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
