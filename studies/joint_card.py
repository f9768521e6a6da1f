"""The joint card of a diagnosis: the identified card of every place (every joint of a train;
a single body: what holds it to the frame) beside the card its runs show.

The identified model is the one the diagnosis stands behind: the extended model when its verdict
is "explained", otherwise the nominal one (an "unexplained" misfit leaves no better model; the
card says which it used). Its covariance (inertias and law values) is mapped onto
``(J of the place's mode, law values)`` (:func:`identify.chain_diagnose.place_covariance`);
nonlinear parameters found by a profile search (a free play, a slip angle) are held at their
values. The model's curves span the amplitudes the runs reached: a card is not an extrapolation.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from jointrig.identify.card import JointCard, MasingCheck, law_card
from jointrig.identify.verdict import Verdict
from jointrig.vocab.law import Power
from jointrig.vocab.params import HINGE, Coordinate, unit_of

__all__ = ["CardReport", "cards_of_train"]

#: amplitudes of the model's curves, spaced geometrically over the runs' range
N_CURVE_POINTS = 25


@dataclass(frozen=True)
class CardReport:
    """The model's card, the runs' card, and which model it is (its words:
    :func:`present.card.model_name`, :func:`present.card.mode_text`)."""

    model: JointCard  # the backbone: each amplitude at its natural frequency
    runs: JointCard
    model_at_runs: JointCard  # the model at each run's amplitude and drive frequency
    masing: MasingCheck  # do the runs' loops follow from one backbone (Masing's rule)?
    #: the diagnosis's verdict: the card's model is the extended one (``causes``) where it is
    #: "explained", else the nominal one (None: no verdict was given)
    verdict: Optional[Verdict] = None
    #: the adopted causes (labels) the card's model holds; empty: the nominal model
    causes: tuple = ()
    #: the place: joint ``joint`` (1-based), or 0 for a single body's law to the frame
    joint: int = 1
    #: how the bodies move (hinges: rad, N m/rad; slides: m, N/m)
    kind: Coordinate = HINGE

    @property
    def unadopted(self) -> Optional[Verdict]:
        """The verdict where the diagnosis adopted no model, so the card's (the nominal one) may
        not be the joint: the warning of the text, the JSON and the report
        (:func:`present.card.card_warning`)."""
        return self.verdict if self.verdict is not None and self.verdict.verdict == "unexplained" else None

    @property
    def place(self) -> str:
        """The place's label (``"joint 2"``, ``"body 1 to ground"``), as file names carry it."""
        return "body 1 to ground" if self.joint == 0 else f"joint {self.joint}"

    @property
    def units(self) -> tuple:
        """The amplitude's and the secant stiffness's units."""
        return self.kind.unit, unit_of(self.kind.name(Power(1).name))


def cards_of_train(report, records) -> tuple[CardReport, ...]:
    """The card of every place of a train's diagnosis (``studies.chain_validate.TrainReport``;
    ``records`` its runs, in order): every joint's, or a single body's at its guide. The model
    is the adopted one (the nominal one when nothing is adopted, with the warning); the runs'
    rows come from the equations of motion with its inertias and drags
    (:func:`identify.chain_diagnose.train_joint_runs`). The model's curves carry the standard
    errors of its law, of its mode's inertia and of the profiled parameters that shape the law (a
    slip angle, a free play: :func:`identify.chain_diagnose.place_uncertainty`)."""
    from jointrig.identify.card import MASING_HARMONICS, joint_masing_check, joint_runs_card
    from jointrig.identify.chain_diagnose import place_law, place_uncertainty, prepare_chain_runs, train_joint_runs

    d = report.diagnosis
    fit = report.adopted_fit
    band = d.n_harmonics
    places = train_joint_runs(prepare_chain_runs(records, band=band), report.run_ids, fit, band)
    # the Masing check's loops: the same coefficients up to its harmonics (each is the band's own)
    top = min(band, MASING_HARMONICS) + 1
    masing_runs = [[replace(jr, phi=jr.phi[:, :top], torque=jr.torque[:, :top]) for jr in runs] for runs in places]
    causes = tuple(s.label for s in d.steps) if report.adopted else ()
    N = d.nominal.spec.n_flywheels
    out = []
    for k, (runs, mruns) in enumerate(zip(places, masing_runs)):
        law, je = place_law(fit, k)
        card = joint_runs_card(runs, je)
        amps = [q.amplitude_rad for q in card.points]
        grid = np.geomspace(min(amps), max(amps), N_CURVE_POINTS) if max(amps) > min(amps) else np.array(amps[:1])
        cov, shapes = place_uncertainty(fit, k)
        model = law_card(law, je, grid, covariance=cov, inertia_index=0, shapes=shapes)
        at_runs = law_card(law, je, amps, covariance=cov, inertia_index=0, shapes=shapes,
                           omegas_rad_s=[q.omega_rad_s for q in card.points])
        out.append(CardReport(model, card, at_runs, joint_masing_check(mruns), report.verdict, causes,
                              0 if N == 1 else k + 1, report.kind))
    return tuple(out)
