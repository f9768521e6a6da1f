"""The verdict of a diagnosis, the same for two flywheels and for a train of any length (pure):
"no_misfit", "explained" or "unexplained", from the adopted (or nominal) model's chi-square per
degree of freedom and its error on held-out data against what a right model misses there, and
whether the nominal model's error there is beyond it. The thresholds and why they are where they
are live here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

__all__ = ["CHI2_PER_DOF_OK", "RIG_FIDELITY", "Verdict", "judge"]

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


@dataclass(frozen=True)
class Verdict:
    """``verdict``: "no_misfit" (the nominal model explains the data to the noise), "explained"
    (an extension of catalogued causes does, confirmed on held-out runs) or "unexplained" (a
    significant misfit remains that no catalogued cause explains); ``reason`` says why."""

    verdict: str
    reason: str


#: The rig's own fidelity in a held-out comparison, relative to the RMS of the compared motion:
#: a model replayed in the rig under a measured drive (its harmonics up to the band) on
#: noise-free data of the rig itself misses by up to 4.7e-5 of the motion (the worn two-flywheel
#: joint, whose friction kinks the band cuts) and 1.5e-5 (the pump train's coupling twist).
#: Added in quadrature to the noise floor, it keeps exact data (``make-data --no-noise``) from
#: reading as a misfit of millions of noise floors (they read 1.5-4.7 floors); at 40 dB the noise
#: floor is 1.7e-4 to 6e-4 of the motion, and this moves it by at most 0.2% of itself.
RIG_FIDELITY = 1e-5


def judge(causes: Sequence[str], chi2_per_dof: float, error_ratio: float, nominal_ratio: float, bound: float, *,
          held: str = "held-out error", nominal_lost: str = "", nominal_bound: float = math.nan,
          gain: float = math.nan) -> Verdict:
    """The verdict of a model that reached a steady state (or followed the record) on every
    held-out run (a caller says otherwise itself, naming the runs): ``causes`` the extension's
    (none: the nominal model is judged), ``error_ratio`` the judged model's held-out error over
    what a right model misses there, ``nominal_ratio`` the nominal model's over what it would
    miss were it right (NaN if it has no steady state in held-out run(s) ``nominal_lost``),
    ``bound`` and ``nominal_bound`` (default ``bound``) the most a right model's ratio reaches at
    the false-alarm rate, ``gain`` the nominal's held-out error over the extended's (where both are
    within their bounds, the extension stands on the fit's evidence if the held-out runs lean its
    way), ``held`` what the held-out data are, in words."""
    nominal_bound = bound if math.isnan(nominal_bound) else nominal_bound
    fits = chi2_per_dof <= CHI2_PER_DOF_OK and error_ratio <= bound
    figures = (f"chi2/dof {chi2_per_dof:.3g} (at most {CHI2_PER_DOF_OK:g}), {held} {error_ratio:.3g} times what a "
               f"right model misses (at most {bound:.3g})")
    if not causes:
        if fits:
            return Verdict("no_misfit", f"the nominal model explains the data to the noise: {figures}")
        return Verdict("unexplained", f"no catalogued cause is significant, but the nominal model does not explain "
                                      f"the data: {figures}")
    names = " + ".join(causes)
    verb = "explains" if len(causes) == 1 else "explain"
    if fits and nominal_ratio > nominal_bound:
        return Verdict("explained", f"{names} {verb} the data: {figures}; the nominal model's {held} is "
                                    f"{nominal_ratio:.3g} times what it would miss were it right (at most "
                                    f"{nominal_bound:.3g}): the held-out runs confirm the extension")
    if fits and nominal_lost:
        # The nominal model has no steady state where the extension predicts the runs: an
        # infinite gain, stated in words.
        return Verdict("explained", f"{names} {verb} the data: {figures}; the nominal model reaches no periodic steady "
                                    f"state in held-out run(s) {nominal_lost}, the extended model does")
    if fits and gain > 1:
        # the held-out runs cannot tell the two apart (the nominal model's parameters leave it as
        # uncertain there as its misfit): they do not contradict the fit's evidence, which decides
        return Verdict("explained", f"{names} {verb} the data: {figures}; the held-out runs do not resolve it (the "
                                    f"nominal model's {held} is {nominal_ratio:.3g} times what it would miss were it "
                                    f"right, at most {nominal_bound:.3g}; gain {gain:.3g}): adopted on the fit's "
                                    f"evidence")
    if fits:
        return Verdict("unexplained", f"the best extension ({names}) is not confirmed: {figures}, but the nominal "
                                      f"model predicts the held-out runs as well ({held} {nominal_ratio:.3g} times "
                                      f"what it would miss were it right, at most {nominal_bound:.3g}; gain "
                                      f"{gain:.3g}); nothing is adopted")
    return Verdict("unexplained", f"the best extension ({names}) fails validation: {figures}; nothing is adopted")
