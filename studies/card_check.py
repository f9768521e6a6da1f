"""The identified joint card held against a virtual phase-resonance test (issue 16's acceptance).

A study, not a step of the diagnosis: for a joint whose law is known (``CARD_CASES``),

1. the rig simulates (native callback, the Python one's records to 1e-8 of their peak) a stepped
   sine test (3 frequencies x 3 levels around the joint's mode, ``n_periods`` each) and measures
   it at ``snr_db``;
2. the diagnosis identifies the joint from those runs alone, as the train of two bodies
   (nominal model of the paper plus whatever cause it adopts), and
   :func:`identify.chain_diagnose.place_law` gives the law it stands behind, with its covariance;
3. the rig runs the phase-resonance test (:func:`studies.phase_resonance.phase_resonance`, noise
   free, true law) at ``pr_levels_Nm``: the backbone and damping as a lab measures them;
4. the identified law's card (:func:`identify.card.law_card`) is evaluated at the amplitudes the
   phase-resonance test reached, with standard errors from the fit's covariance; the true
   law's card at the same amplitudes gives the describing function's own single-harmonic bias
   against phase resonance (it is there with a perfect identification);
5. the phase-resonance runs themselves, measured at ``snr_db``, give the card straight from the
   runs (:func:`identify.card.runs_card`, inertias from the fit), point for point.

Everything is SI: amplitudes in rad (relative angle), frequencies in rad/s, dissipation in J
per cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from jointrig.vocab.law import Iwan, Jenkins, JointLaw, Power, Viscous
from jointrig.identify.card import JointCard, law_card, runs_card

from jointrig.identify.chain_diagnose import place_law, place_uncertainty, plant_and_inertias
from jointrig.identify.chain import ChainRecord, inertia_name
from jointrig.rig.chain import chain_of_two_flywheels
from jointrig.rig.measurement import add_noise
from jointrig.rig.model import RigModel
from .chain_validate import run_train_diagnosis
from .phase_resonance import phase_resonance
from jointrig.rig.simulate import SimulationConfig, simulate_steady_state

__all__ = ["CardCase", "CARD_CASES", "CardComparison", "CardCheck", "check_card", "check_text", "worst", "QUANTITIES"]

#: the card's quantities compared with phase resonance
QUANTITIES = ("natural_frequency_rad_s", "damping_ratio", "dissipation_J_per_cycle")


@dataclass(frozen=True)
class CardCase:
    """A joint of known law and the tests run on it (levels in N m on flywheel 1)."""

    law: Optional[JointLaw]  # None: the rig model's own law (the paper's joint)
    omegas_rad_s: tuple[float, ...]  # stepped-sine frequencies of the identification runs
    levels_Nm: tuple[float, ...]  # their drive levels
    pr_levels_Nm: tuple[float, ...]  # phase-resonance levels
    pr_bracket_rad_s: tuple[float, float]
    pr_xtol_rad_s: float
    settle_tol: float = 1e-9
    description: str = ""


CARD_CASES = {
    # The paper's joint (eq. 12: c 100, k 2000, gamma 200; heavily damped, zeta ~1.1).
    "paper": CardCase(None, (25.0, 45.0, 65.0), (400.0, 2000.0, 4000.0), (400.0, 4000.0), (5.0, 200.0), 1e-5,
                      description="the paper's joint, eq. (12)"),
    # A lightly damped joint with a Jenkins element (40 N m slipping at 0.02 rad): macroslip.
    "jenkins": CardCase(JointLaw((Viscous(), Power(1), Jenkins(0.02)), (5.0, 500.0, 40.0)),
                        (18.0, 24.0, 30.0), (200.0, 400.0, 800.0), (400.0, 800.0), (15.0, 40.0), 1e-4,
                        description="c 5, k 500, Jenkins 40 N m at 0.02 rad (macroslip)"),
    # A lightly damped joint with Segalman's Iwan element (40 N m, s_max 0.05 rad): micro-slip.
    "iwan": CardCase(JointLaw((Viscous(), Power(1), Iwan(0.05)), (0.5, 500.0, 40.0)),
                     (35.0, 42.0, 50.0), (3.0, 6.0, 12.0), (3.0, 6.0, 12.0), (30.0, 55.0), 1e-3, settle_tol=1e-6,
                     description="c 0.5, k 500, Iwan 40 N m, s_max 0.05 rad, chi -0.5, beta 0.1 (micro-slip)"),
}


@dataclass(frozen=True)
class CardComparison:
    """One quantity at one phase-resonance amplitude."""

    amplitude_rad: float
    quantity: str
    phase_resonance: float
    identified: float
    identified_std: float
    true_law: float  # the describing function of the true law
    runs: float  # the card straight from the measured phase-resonance run
    runs_std: float

    @property
    def describing_bias(self) -> float:
        """The true law's describing function against phase resonance, relative."""
        return (self.true_law - self.phase_resonance) / self.phase_resonance

    @property
    def identified_z(self) -> float:
        """The identified card's departure from the true law's, in its standard errors."""
        return (self.identified - self.true_law) / self.identified_std

    @property
    def runs_z(self) -> float:
        """The runs' card against phase resonance, in its standard errors."""
        return (self.runs - self.phase_resonance) / self.runs_std


@dataclass(frozen=True)
class CardCheck:
    case: str
    verdict: str
    adopted: tuple[str, ...]
    model_name: str
    identified: JointCard
    phase_resonance: JointCard
    runs: JointCard
    comparisons: tuple[CardComparison, ...]

    def as_json(self) -> dict:
        return {"case": self.case, "verdict": self.verdict, "adopted": list(self.adopted), "model": self.model_name,
                "dissipation_slope": {"phase_resonance": self.phase_resonance.dissipation_slope,
                                      "identified": self.identified.dissipation_slope,
                                      "identified_std": self.identified.dissipation_slope_std,
                                      "runs": self.runs.dissipation_slope, "runs_std": self.runs.dissipation_slope_std},
                "comparisons": [{**c.__dict__, "describing_bias": c.describing_bias,
                                 "identified_z": c.identified_z, "runs_z": c.runs_z} for c in self.comparisons]}


def check_card(rig: RigModel, case: str, *, snr_db: float = 40.0, seed: int = 1, n_periods: int = 8,
               progress: Optional[Callable[[str], None]] = None) -> CardCheck:
    """Run the study of the module docstring for ``CARD_CASES[case]``."""
    if case not in CARD_CASES:
        raise ValueError(f"check_card: unknown case {case!r}; expected one of {', '.join(CARD_CASES)}")
    c = CARD_CASES[case]
    law = rig.law if c.law is None else c.law
    say = progress or (lambda msg: None)
    rng = np.random.default_rng(seed)
    config = SimulationConfig(n_periods=n_periods, settle_tol=c.settle_tol)
    say(f"{case}: simulating {len(c.omegas_rad_s) * len(c.levels_Nm)} stepped-sine runs")
    records = [add_noise(simulate_steady_state(rig, w, m, config, law=law)[0], snr_db, rng)
               for w in c.omegas_rad_s for m in c.levels_Nm]
    def step(msg: str) -> None:  # the diagnosis's and the phase resonance's own progress, under this case
        say(f"{case}:   {msg.strip()}")

    say(f"{case}: diagnosing")
    report = run_train_diagnosis([ChainRecord.of_two_flywheels(r) for r in records], run_ids=[str(i) for i in range(len(records))],
                                 rig=chain_of_two_flywheels(rig, (1,)), progress=step)
    fit = report.adopted_fit
    id_law, je = place_law(fit, 0)
    cov, shapes = place_uncertainty(fit, 0)
    adopted = tuple(s.effect for s in report.diagnosis.steps) if report.adopted else ()
    name = (f"extended: {' + '.join(adopted)}" if adopted
            else f"nominal (paper eq. 11; verdict {report.verdict.verdict})")
    J1, J2 = plant_and_inertias(fit)[1]
    both = [fit.names.index(inertia_name(i)) for i in (1, 2)]
    J_cov = None if fit.covariance is None else fit.covariance[np.ix_(both, both)]
    say(f"{case}: phase resonance at {', '.join(f'{m:g}' for m in c.pr_levels_Nm)} N m")
    pr = phase_resonance(rig, c.pr_levels_Nm, law=law, omega_bracket_rad_s=c.pr_bracket_rad_s,
                         xtol_rad_s=c.pr_xtol_rad_s, config=SimulationConfig(n_periods=2, settle_tol=c.settle_tol),
                         progress=step)
    say(f"{case}: measuring the {len(pr.points)} resonance points as a lab would ({n_periods} periods, "
        f"{snr_db:g} dB)")
    amps = [p.amplitude_rad for p in pr.points]
    card = law_card(id_law, je, amps, covariance=cov, inertia_index=0, shapes=shapes)
    true = law_card(law, rig.Je_kgm2, amps)
    # The lab's own runs: each phase-resonance point simulated again over n_periods and measured.
    levels = [float(p.run.split()[0]) for p in pr.points]
    measured = [add_noise(simulate_steady_state(rig, p.omega_rad_s, m, config, law=law)[0], snr_db, rng)
                for p, m in zip(pr.points, levels)]
    runs = runs_card(measured, J1, J2, run_ids=[p.run for p in pr.points],
                     inertia_covariance=J_cov)
    comps = tuple(CardComparison(p.amplitude_rad, q, getattr(p, q), getattr(i, q), getattr(i, q + "_std"),
                                 getattr(t, q), getattr(r, q), getattr(r, q + "_std"))
                  for p, i, t, r in zip(pr.points, card.points, true.points, runs.points) for q in QUANTITIES)
    return CardCheck(case, report.verdict.verdict, adopted, name, card, pr, runs, comps)


def check_text(check: CardCheck) -> str:
    """The comparison as a table (relative departures, and in standard errors)."""
    lines = [f"{check.case}: verdict {check.verdict}; the card's model: {check.model_name}",
             f"  {'A [rad]':>9s} {'quantity':24s} {'phase res.':>11s} {'identified':>11s} {'+-':>9s} "
             f"{'(id-true)/se':>12s} {'DF bias':>9s} {'runs':>11s} {'+-':>9s} {'(runs-PR)/se':>12s}"]
    for c in check.comparisons:
        lines.append(f"  {c.amplitude_rad:9.4g} {c.quantity:24s} {c.phase_resonance:11.6g} {c.identified:11.6g} "
                     f"{c.identified_std:9.2g} {c.identified_z:+12.2f} {c.describing_bias:+9.1e} {c.runs:11.6g} "
                     f"{c.runs_std:9.2g} {c.runs_z:+12.2f}")
    s = check.identified
    lines.append(f"  dissipation slope: phase resonance {_f(check.phase_resonance.dissipation_slope)}, identified "
                 f"{_f(s.dissipation_slope)} +- {_f(s.dissipation_slope_std)}, runs {_f(check.runs.dissipation_slope)}"
                 f" +- {_f(check.runs.dissipation_slope_std)}")
    return "\n".join(lines)


def _f(v: float) -> str:
    return f"{v:.4g}" if math.isfinite(v) else "-"


def worst(checks: Sequence[CardCheck]) -> dict:
    """The largest departures over all checks (for a summary line)."""
    comps = [c for k in checks for c in k.comparisons]
    return {"identified_z": max(abs(c.identified_z) for c in comps),
            "runs_z": max(abs(c.runs_z) for c in comps),
            "describing_bias": max(abs(c.describing_bias) for c in comps)}
