"""The joint card of a diagnosis: the identified joint's card beside the card its runs show.

The identified model is the one the diagnosis stands behind: the extended model when its verdict
is "explained", otherwise the nominal one (an "unexplained" misfit leaves no better model; the
card says which it used). Its covariance (inertias and law values) is mapped onto
``(Je, law values)``; nonlinear parameters found by a profile search (a free play, a slip angle)
are held at their values. The model's curves span the amplitudes the runs reached: a card is
not an extrapolation.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from jointrig.identify.card import JointCard, MasingCheck, law_card, masing_check, runs_card
from jointrig.identify.diagnose import plant_of
from jointrig.vocab.records import SteadyStateRecord

from .validate import DiagnosisReport
from jointrig.vocab import params

__all__ = ["CardReport", "card_of_diagnosis", "cards_of_train", "identified_law", "inertia_covariance", "runs_fit", "card_warning"]

#: amplitudes of the model's curves, spaced geometrically over the runs' range
N_CURVE_POINTS = 25


@dataclass(frozen=True)
class CardReport:
    """The model's card, the runs' card, and which model it is."""

    model: JointCard  # the backbone: each amplitude at its natural frequency
    runs: JointCard
    model_name: str
    model_at_runs: JointCard  # the model at each run's amplitude and drive frequency  # e.g. "extended: coulomb_friction + backlash" or "nominal (paper eq. 11)"
    masing: MasingCheck  # do the runs' loops follow from one backbone (Masing's rule)?
    #: why the card's model may not be the joint ("" when the diagnosis adopted it): shown in the
    #: text, the JSON and the report
    warning: str = ""
    #: which fit's inertias the runs' rows use (the best-supported one: :func:`runs_fit`)
    runs_inertias: str = ""
    #: where in a train (``"joint 2"``, ``"body 1 to ground"``); empty for two flywheels' one joint
    place: str = ""
    #: what the mode's inertia is, in words
    mode: str = "mode of the relative angle"
    #: units of the amplitude and the secant stiffness: a hinge's, or a slide's ("m", "N/m")
    units: tuple = ("rad", "N m/rad")


def runs_fit(report: DiagnosisReport):
    """``(fit, name)``: the fit whose inertias the runs' rows use: the adopted model's, or, when
    the verdict adopts nothing, whichever of the nominal and the tried extended model fits the
    data better (smaller chi-square per degree of freedom). The runs' joint torque is measured
    through J1 phi1'' (or Je phi''); a nominal fit that misses a friction biases its inertias
    (Je 0.945 for 1.0 on a 20 N m dry-friction joint) and with them every row from the runs."""
    d = report.diagnosis
    if report.verdict.verdict == "explained" and d.extended is not d.nominal:
        return d.extended, "the extended model's (adopted)"
    if report.verdict.verdict == "no_misfit" or d.extended is d.nominal:
        return d.nominal, "the nominal model's"
    better = d.extended.chi2 / max(d.extended.dof, 1) < d.nominal.chi2 / max(d.nominal.dof, 1)
    return ((d.extended, f"the tried extension's ({' + '.join(d.effects)}; it fits the runs better than the nominal "
                         f"model, though not adopted)") if better else (d.nominal, "the nominal model's"))


def card_warning(report: DiagnosisReport) -> str:
    """Why the card's model may describe the wrong joint: empty when the diagnosis adopted it."""
    v = report.verdict
    if v.verdict != "unexplained":
        return ""
    return (f"this card describes the nominal model, which the diagnosis did NOT adopt: the verdict is unexplained "
            f"({v.reason}). The data show a misfit this model does not hold; its stiffness, damping ratio and "
            f"dissipation may be those of another joint. Compare the rows from the runs with the model's before using "
            f"it.")


def identified_law(report: DiagnosisReport, torque_share: float = 0.5):
    """``(law, Je, covariance of (Je, law values) or None, model name, (J1, J2))`` of the model
    the diagnosis stands behind (module docstring)."""
    d = report.diagnosis
    use_extended = report.verdict.verdict == "explained" and d.extended is not d.nominal
    f = d.extended if use_extended else d.nominal
    name = (f"extended: {' + '.join(d.effects)}" if use_extended
            else f"nominal (paper eq. 11; verdict {report.verdict.verdict})")
    plant, (J1, J2) = plant_of(f, torque_share)
    law = plant.law
    je = J1 * J2 / (J1 + J2)
    cov = None
    if f.covariance is not None:
        idx = {n: i for i, n in enumerate(f.names)}
        T = np.zeros((1 + len(law.names), len(f.names)))
        if params.JE in idx:
            T[0, idx[params.JE]] = 1.0
        else:
            T[0, idx[params.J1]] = (J2 / (J1 + J2)) ** 2
            T[0, idx[params.J2]] = (J1 / (J1 + J2)) ** 2
        for r, n in enumerate(law.names):
            if n in idx:
                T[1 + r, idx[n]] = 1.0
        cov = T @ f.covariance @ T.T
    return law, je, cov, name, (J1, J2)


def inertia_covariance(report: DiagnosisReport, torque_share: float = 0.5):
    """The ``(2, 2)`` covariance of the flywheel inertias (J1, J2) in kg^2 m^4 of the fit the
    runs' rows use (:func:`runs_fit`), or None when the fit has none (for the equivalent form,
    J1 = Je / s and J2 = Je / (1 - s) with s the torque share)."""
    f = runs_fit(report)[0]
    if f.covariance is None:
        return None
    idx = {n: i for i, n in enumerate(f.names)}
    if params.J1 in idx:
        i = [idx[params.J1], idx[params.J2]]
        return f.covariance[np.ix_(i, i)]
    g = np.array([1.0 / torque_share, 1.0 / (1.0 - torque_share)])
    return np.outer(g, g) * f.covariance[idx[params.JE], idx[params.JE]]


def card_of_diagnosis(report: DiagnosisReport, records: Sequence[SteadyStateRecord], *,
                      run_ids: Sequence[str] | None = None, torque_share: float = 0.5) -> CardReport:
    law, je, cov, name, _ = identified_law(report, torque_share)
    fit_for_runs, runs_inertias = runs_fit(report)
    _, (J1, J2) = plant_of(fit_for_runs, torque_share)
    runs = runs_card(records, J1, J2, run_ids=run_ids, n_harmonics=report.band,
                     inertia_covariance=inertia_covariance(report, torque_share))
    amps = [p.amplitude_rad for p in runs.points]
    grid = np.geomspace(min(amps), max(amps), N_CURVE_POINTS) if max(amps) > min(amps) else np.array(amps[:1])
    model = law_card(law, je, grid, covariance=cov, inertia_index=0)
    at_runs = law_card(law, je, amps, covariance=cov, inertia_index=0,
                       omegas_rad_s=[p.omega_rad_s for p in runs.points])
    masing = masing_check(records, J1, J2, run_ids=run_ids)
    return CardReport(model, runs, name, at_runs, masing, card_warning(report), runs_inertias)


def cards_of_train(report, records) -> tuple[CardReport, ...]:
    """The card of every place of a train's diagnosis (``studies.chain_validate.TrainReport``;
    ``records`` its runs, in order): every joint's, or a single body's at its guide. The model
    is the adopted one (the nominal one when nothing is adopted, with the warning); the runs'
    rows come from the equations of motion with its inertias and drags
    (:func:`identify.chain_diagnose.train_joint_runs`). The model's curves carry the standard
    errors of its law and of its mode's inertia (:func:`identify.chain_diagnose.place_covariance`)."""
    from jointrig.identify.card import MASING_HARMONICS, joint_masing_check, joint_runs_card
    from jointrig.identify.chain_diagnose import place_covariance, place_law, prepare_chain_runs, train_joint_runs

    d = report.diagnosis
    fit = report.adopted_fit
    band = d.n_harmonics
    places = train_joint_runs(prepare_chain_runs(records, band=band), report.run_ids, fit, band)
    # the Masing check's loops: the same coefficients up to its harmonics (each is the band's own)
    top = min(band, MASING_HARMONICS) + 1
    masing_runs = [[replace(jr, phi=jr.phi[:, :top], torque=jr.torque[:, :top]) for jr in runs] for runs in places]
    name = (f"extended: {' + '.join(s.label for s in d.steps)}" if report.adopted and d.steps
            else f"nominal (verdict {report.verdict.verdict})")
    warning = "" if report.verdict.verdict != "unexplained" else (
        f"this card describes the nominal model, which the diagnosis did NOT adopt: the verdict is unexplained "
        f"({report.verdict.reason}). Compare the rows from the runs with the model's before using it.")
    N = d.nominal.spec.n_flywheels
    out = []
    for k, (runs, mruns) in enumerate(zip(places, masing_runs)):
        law, je = place_law(fit, k)
        card = joint_runs_card(runs, je)
        amps = [q.amplitude_rad for q in card.points]
        grid = np.geomspace(min(amps), max(amps), N_CURVE_POINTS) if max(amps) > min(amps) else np.array(amps[:1])
        cov = place_covariance(fit, k)
        model = law_card(law, je, grid, covariance=cov, inertia_index=0)
        at_runs = law_card(law, je, amps, covariance=cov, inertia_index=0,
                           omegas_rad_s=[q.omega_rad_s for q in card.points])
        place = "body 1 to ground" if N == 1 else f"joint {k + 1}"
        one = "its mass" if report.kind == "slide" else "its inertia"
        mode = (f"mode of the body on what holds it to the frame, {one}" if N == 1 else
                f"mode of bodies {k + 1} and {k + 2} on joint {k + 1} alone, J{k + 1} J{k + 2} / (J{k + 1} + J{k + 2})")
        units = ("m", "N/m") if report.kind == "slide" else ("rad", "N m/rad")
        out.append(CardReport(model, card, name, at_runs, joint_masing_check(mruns), warning,
                              "the adopted model's", place, mode, units))
    return tuple(out)
