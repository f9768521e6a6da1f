"""The verdict of a diagnosis, the same for two flywheels and for a train of any length (pure):
"no_misfit", "explained" or "unexplained", from the adopted (or nominal) model's chi-square per
degree of freedom and its error on held-out data against what a right model misses there, and
whether the nominal model's error there is beyond it. The thresholds and why they are where they
are live here.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, replace
from typing import Sequence

__all__ = ["CHI2_PER_DOF_OK", "RIG_FIDELITY", "Grounds", "Verdict", "judge"]

#: A model explains the data to the noise when its chi-square per degree of freedom is at most
#: this (a right model reads 0.7-1.5 with the measured fidelity at 20-80 dB on the independent
#: simulators: docs/noisy-measurements.md) ...
CHI2_PER_DOF_OK = 2.0
#: ... and its error on held-out data is within what a right model misses there: the held-out
#: records' noise, its own parameters' uncertainty and the method's bias, measured for each
#: comparison (:class:`studies.chain_validate.RightModelError`), times the F bound at the
#: verdict's false-alarm rate (the diagnosis's ``alpha``). An extension is confirmed when the
#: nominal model's error is beyond what the nominal model would miss were it right: the held-out
#: runs show the misfit the extension removes.


class Grounds(enum.Enum):
    """Why a verdict is what it is: the branch of :func:`judge` (or of the caller that could not
    judge) it came from."""

    #: no_misfit: the nominal model explains the data to the noise
    NOMINAL_FITS = "nominal_fits"
    #: unexplained: no catalogued cause is significant, but the nominal model does not fit
    NOMINAL_MISFITS = "nominal_misfits"
    #: explained: the extension fits, and the nominal model's held-out error is beyond its bound
    CONFIRMED = "confirmed"
    #: explained: the extension fits, and the nominal model reaches no steady state where it does
    NOMINAL_LOST = "nominal_lost"
    #: explained: the held-out runs cannot tell the two apart but lean the extension's way
    FIT_EVIDENCE = "fit_evidence"
    #: unexplained: the extension fits, but the nominal model predicts the held-out runs as well
    NOT_CONFIRMED = "not_confirmed"
    #: unexplained: the extension fits the runs worse than the noise, or misses the held-out ones
    FAILS_VALIDATION = "fails_validation"
    #: unexplained: the judged model could not be checked on held-out runs (:attr:`Verdict.unchecked`)
    UNCHECKED = "unchecked"
    #: unexplained: no model is adopted under its own measured fidelity (:attr:`Verdict.cycle`)
    FIDELITY_CYCLE = "fidelity_cycle"


@dataclass(frozen=True)
class Verdict:
    """``verdict``: "no_misfit" (the nominal model explains the data to the noise), "explained"
    (an extension of catalogued causes does, confirmed on held-out runs) or "unexplained" (a
    significant misfit remains that no catalogued cause explains); ``grounds`` and the figures
    say why (their words: :func:`present.notes.verdict_text`)."""

    verdict: str
    grounds: Grounds
    #: the judged extension's causes (labels; empty: the nominal model is judged)
    causes: tuple = ()
    #: the judged model's chi-square per degree of freedom, against :data:`CHI2_PER_DOF_OK`
    chi2_per_dof: float = math.nan
    #: the judged model's held-out error over what a right model misses there, and its bound
    error_ratio: float = math.nan
    bound: float = math.nan
    #: the nominal model's held-out error over what it would miss were it right, and its bound
    nominal_ratio: float = math.nan
    nominal_bound: float = math.nan
    #: the nominal model's held-out error over the extended one's
    gain: float = math.nan
    #: the held-out data are each run's later periods, not whole runs
    later_periods: bool = False
    #: held-out runs (labels) where the nominal model reaches no periodic steady state
    nominal_lost: tuple = ()
    #: why the judged model could not be checked on held-out runs (with :attr:`Grounds.UNCHECKED`:
    #: the validation's failed replays, :class:`studies.notes.NoReplay`; empty: no held-out run)
    unchecked: tuple = ()
    #: with :attr:`Grounds.FIDELITY_CYCLE`: two models (their causes in words), the balance's
    #: fidelity measured on each adopting the other (:class:`studies.notes.FidelityCycle`)
    cycle: tuple = ()


def unsettled(v: Verdict, one: str, other: str) -> Verdict:
    """``v`` made unexplained where the measured fidelity cycles between the models ``one`` and
    ``other`` (pure): a verdict that holds only under another model's fidelity is not one; an
    unexplained verdict stands as it is."""
    if v.verdict == "unexplained":
        return v
    return replace(v, verdict="unexplained", grounds=Grounds.FIDELITY_CYCLE, cycle=(one, other))


#: The rig's own fidelity in a held-out comparison, relative to the RMS of the compared motion:
#: a model replayed in the rig under a measured drive (its harmonics up to the band) on
#: noise-free data of the rig itself misses by up to 4.7e-5 of the motion (the worn two-flywheel
#: joint, whose friction kinks the band cuts) and 1.5e-5 (the pump train's coupling twist).
#: Added in quadrature to the noise floor, it keeps exact data (``make-data --no-noise``) from
#: reading as a misfit of millions of noise floors (they read 1.5-4.7 floors); at 40 dB the noise
#: floor is 1.7e-4 to 6e-4 of the motion, and this moves it by at most 0.2% of itself.
RIG_FIDELITY = 1e-5


def judge(causes: Sequence[str], chi2_per_dof: float, error_ratio: float, nominal_ratio: float, bound: float, *,
          later_periods: bool = False, nominal_lost: Sequence[str] = (), nominal_bound: float = math.nan,
          gain: float = math.nan) -> Verdict:
    """The verdict of a model that reached a steady state (or followed the record) on every
    held-out run (a caller says otherwise itself, naming the runs): ``causes`` the extension's
    (none: the nominal model is judged), ``error_ratio`` the judged model's held-out error over
    what a right model misses there, ``nominal_ratio`` the nominal model's over what it would
    miss were it right (NaN if it has no steady state in the held-out runs ``nominal_lost``),
    ``bound`` and ``nominal_bound`` (default ``bound``) the most a right model's ratio reaches at
    the false-alarm rate, ``gain`` the nominal's held-out error over the extended's (where both are
    within their bounds, the extension stands on the fit's evidence if the held-out runs lean its
    way), ``later_periods`` whether the held-out data are each run's later periods."""
    nominal_bound = bound if math.isnan(nominal_bound) else nominal_bound
    fits = chi2_per_dof <= CHI2_PER_DOF_OK and error_ratio <= bound
    causes, lost = tuple(causes), tuple(nominal_lost)
    figures = dict(causes=causes, chi2_per_dof=chi2_per_dof, error_ratio=error_ratio, bound=bound,
                   nominal_ratio=nominal_ratio, nominal_bound=nominal_bound, gain=gain, later_periods=later_periods,
                   nominal_lost=lost)
    if not causes:
        if fits:
            return Verdict("no_misfit", Grounds.NOMINAL_FITS, **figures)
        return Verdict("unexplained", Grounds.NOMINAL_MISFITS, **figures)
    if fits and nominal_ratio > nominal_bound:
        return Verdict("explained", Grounds.CONFIRMED, **figures)
    if fits and lost:
        # The nominal model has no steady state where the extension predicts the runs: an
        # infinite gain, stated in words.
        return Verdict("explained", Grounds.NOMINAL_LOST, **figures)
    if fits and gain > 1:
        # the held-out runs cannot tell the two apart (the nominal model's parameters leave it as
        # uncertain there as its misfit): they do not contradict the fit's evidence, which decides
        return Verdict("explained", Grounds.FIT_EVIDENCE, **figures)
    if fits:
        return Verdict("unexplained", Grounds.NOT_CONFIRMED, **figures)
    return Verdict("unexplained", Grounds.FAILS_VALIDATION, **figures)
