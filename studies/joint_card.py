"""The joint card of a diagnosis: the identified joint's card beside the card its runs show.

The identified model is the one the diagnosis stands behind: the extended model when its verdict
is "explained", otherwise the nominal one (an "unexplained" misfit leaves no better model; the
card says which it used). Its covariance (inertias and law values) is mapped onto
``(Je, law values)``; nonlinear parameters found by a profile search (a free play, a slip angle)
are held at their values. The model's curves span the amplitudes the runs reached: a card is
not an extrapolation.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from jointrig.identify.card import MASING_FIDELITY, JointCard, MasingCheck, law_card, masing_check, runs_card
from jointrig.identify.diagnose import plant_of
from jointrig.vocab.records import SteadyStateRecord

from .validate import DiagnosisReport
from jointrig.vocab import params

__all__ = ["CardReport", "card_of_diagnosis", "identified_law", "inertia_covariance", "card_json", "card_png", "masing_text",
           "runs_fit", "card_warning"]

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


def masing_text(check: MasingCheck) -> str:
    """One sentence on Masing's rule for a card's runs."""
    if not check.runs or check.discrepancy != check.discrepancy:  # NaN: nothing compared
        return "Masing check: fewer than two runs whose loops can be compared."
    how = (f"the runs' loops imply backbones {100 * check.discrepancy:.3g}% apart (of the tip torque; runs "
           f"{check.worst_pair[0]} and {check.worst_pair[1]}; noise {100 * check.noise:.2g}%, fidelity "
           f"{100 * MASING_FIDELITY:.2g}%)")
    verdict = {True: "they follow Masing's rule, as a joint of sliders (Jenkins, Iwan, dry friction) does",
               False: "they do not follow Masing's rule: the damping depends on the rate or the loops change "
                      "otherwise than their backbone says",
               None: "too noisy to tell"}[check.follows]
    skipped = f"; runs {', '.join(check.skipped)} are not simple loops" if check.skipped else ""
    return f"Masing check: {how}: {verdict}{skipped}."


def card_json(card: CardReport, *, source: str = "", input_sha256: str = "") -> dict:
    """The card as JSON: ``amplitudes`` lists every point (``source``: "runs", "model_at_runs" (the
    model at each run's amplitude and drive frequency) or "model" (its backbone, at the natural
    frequency)), each value with its ``_std``; the dissipation slopes (and, for runs at several
    frequencies, the rate exponent) of each with their standard errors."""
    points = ([{"source": "runs", **p.as_json()} for p in card.runs.points]
              + [{"source": "model_at_runs", **p.as_json(), "run": r.run}
                 for p, r in zip(card.model_at_runs.points, card.runs.points)]
              + [{"source": "model", **p.as_json()} for p in card.model.points])
    return {"source": source, "input_sha256": input_sha256, "model": card.model_name,
            "model_adopted": not card.warning, "warning": card.warning or None,
            "runs_inertias": card.runs_inertias,
            "units": "SI: rad, rad/s, N m/rad, N m s/rad, J per cycle; damping ratio dimensionless",
            "what": "amplitude-dependent joint card: secant stiffness, natural frequency and damping ratio of the "
                    "joint's mode (relative coordinate, inertia Je), dissipation per cycle; model by the "
                    "single-harmonic describing function at the natural frequency, runs from their first harmonics "
                    "and loop areas at the drive frequency",
            "amplitudes": points,
            "dissipation_slope": {"runs": card.runs.dissipation_slope, "runs_std": card.runs.dissipation_slope_std,
                                  "model_at_runs": card.model_at_runs.dissipation_slope,
                                  "model_at_runs_std": card.model_at_runs.dissipation_slope_std,
                                  "model": card.model.dissipation_slope,
                                  "model_std": card.model.dissipation_slope_std},
            "rate_exponent": {"runs": card.runs.rate_exponent, "runs_std": card.runs.rate_exponent_std,
                              "model_at_runs": card.model_at_runs.rate_exponent,
                              "model_at_runs_std": card.model_at_runs.rate_exponent_std},
            "masing": card.masing.as_json(),
            "runs_card": card.runs.as_json(), "model_card": card.model.as_json(),
            "model_at_runs_card": card.model_at_runs.as_json()}


def card_png(card: CardReport, title: str = "joint card") -> bytes:
    """Four panels over the relative amplitude: natural frequency, damping ratio, dissipation per
    cycle (log-log, with the slopes) and secant stiffness; the model's backbone as a curve with
    its +-2 standard-error band, the runs as points with +-2 standard-error bars, the model at
    each run's drive frequency as open squares (what the runs are compared with)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    m, r = card.model.points, card.runs.points
    am = np.array([p.amplitude_rad for p in m])
    ar = np.array([p.amplitude_rad for p in r])
    panels = (("natural_frequency_rad_s", "natural frequency [rad/s]"), ("damping_ratio", "damping ratio [-]"),
              ("dissipation_J_per_cycle", "dissipation per cycle [J]"),
              ("secant_stiffness_Nm_per_rad", "secant stiffness [N m/rad]"))
    for ax, (key, label) in zip(axes.flat, panels):
        y = np.array([getattr(p, key) for p in m])
        s = np.array([getattr(p, key + "_std") for p in m])
        ax.plot(am, y, color="tab:blue", label=f"model backbone ({card.model_name})")
        if np.all(np.isfinite(s)):
            ax.fill_between(am, y - 2 * s, y + 2 * s, color="tab:blue", alpha=0.2, lw=0, label="model +-2 s.e.")
        yr = np.array([getattr(p, key) for p in r])
        sr = np.array([getattr(p, key + "_std") for p in r])
        ax.errorbar(ar, yr, yerr=np.where(np.isfinite(sr), 2 * sr, 0.0), fmt="o", color="k", ms=4, capsize=3,
                    label="runs (+-2 s.e.), at their drive frequency")
        ym = np.array([getattr(p, key) for p in card.model_at_runs.points])
        ax.plot(ar, ym, "s", mfc="none", color="tab:blue", ms=7, label="model at the runs' frequencies")
        ax.set(xlabel="relative amplitude A [rad]", ylabel=label, xscale="log")
        _amplitude_ticks(ax, np.concatenate([am, ar]))
        if key == "dissipation_J_per_cycle":
            ax.set_yscale("log")
            ax.set_title(f"slope d lnE/d lnA: runs {_slope(card.runs)}, model at runs {_slope(card.model_at_runs)}, "
                         f"backbone {_slope(card.model)}", fontsize=8)
        ax.grid(alpha=0.3, which="both")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def _amplitude_ticks(ax, amplitudes: np.ndarray) -> None:
    """Log-axis ticks that never overlap: labels only at 1, 2 and 5 times a power of ten (at
    powers of ten alone beyond three decades), plain numbers, no labels on the minor ticks
    (matplotlib labels them in a range of about a decade, and they crowded into each other
    when the amplitudes spanned just over one)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    finite = amplitudes[np.isfinite(amplitudes) & (amplitudes > 0)]
    span = float(finite.max() / finite.min()) if finite.size else 1.0
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0,) if span > 1000 else (1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _slope(c: JointCard) -> str:
    if not math.isfinite(c.dissipation_slope):
        return "n/a"
    return f"{c.dissipation_slope:.3g} +- {c.dissipation_slope_std:.2g}" if math.isfinite(
        c.dissipation_slope_std) else f"{c.dissipation_slope:.3g}"
