"""The joint card: amplitude-dependent stiffness, damping and dissipation, in the field's terms.

A structural dynamicist designing with a joint asks for its backbone: the natural frequency and
damping ratio of the joint's mode against the amplitude, the energy it dissipates per cycle and
how that grows with the amplitude. Two ways to them, one pure function each:

* :func:`law_card` from an identified law, by the single-harmonic describing function (the
  first-harmonic balance of the paper's eq. 5-6): for ``phi = A cos(theta)``,
  ``phi' = -A omega sin(theta)``,

      k_eq(A, omega) = 1/(pi A)       int_0^2pi f(phi, phi') cos(theta) dtheta
      c_eq(A, omega) = 1/(pi A omega) int_0^2pi f(phi, phi') (-sin(theta)) dtheta

  the secant stiffness and equivalent viscous damping. The joint's mode is that of the
  relative coordinate, ``Je phi'' + f = share M`` with ``Je = J1 J2 / (J1 + J2)``: its
  natural frequency ``omega_n(A) = sqrt(k_eq(A, omega_n) / Je)`` (solved by fixed point, as
  k_eq may depend on the rate), its damping ratio ``zeta = c_eq / (2 Je omega_n)`` and the
  dissipation per cycle ``E = pi c_eq omega_n A^2`` (only the first harmonic of the torque
  does work on a pure cosine). Standard errors are propagated from the fit's covariance (a
  numerical Jacobian).
* :func:`runs_card` from measured runs without any law: per run the first harmonics of the
  relative angle ``Phi_1`` and of the joint torque ``F_1 = share M_1 + Je omega^2 Phi_1``
  (the equation of motion; only the inertias are taken from a fit) give the secant stiffness
  ``Re(F_1 / Phi_1)``, and the loop area ``E = pi sum_n n Im(F_n conj(Phi_n))`` (all
  harmonics: the exact work of the joint torque over a period of band-limited signals); the
  damping ratio is the loss factor's half, ``E / (2 pi k A^2)``, equal to the law's zeta at
  resonance. Standard errors from the spread over the run's periods.

The dissipation slope ``d ln E / d ln A`` is fitted by weighted least squares over the points
(with the frequency as a second regressor for runs at several frequencies: its exponent is 1
for viscous damping, 0 for friction and hysteresis).
Closed forms (tested): viscous damping 2, dry friction 1 (``E = 4 F A``), a Jenkins element
in macroslip ``E = 4 F (A - s)`` (slope ``A / (A - s)``, towards 1), an Iwan joint in
micro-slip ``3 + chi``. (This is the slope against the displacement amplitude, the card's
abscissa; against the force amplitude, the other convention of the literature, viscous and
micro-slip give 2 and 3 + chi as well but macroslip grows without bound.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from jointrig.vocab.law import JointLaw
from .harmonics import fourier_coefficients, synthesize
from jointrig.vocab.records import SteadyStateRecord

__all__ = ["CardPoint", "JointCard", "JointRun", "MasingCheck", "MasingRun", "describing_function", "law_card",
           "masing_check", "joint_masing_check", "runs_card", "joint_runs_card", "two_flywheel_run", "dissipation_slope"]

#: samples of theta over a cycle for the describing-function integrals (midpoint rule on a
#: periodic grid: exact for trigonometric polynomials below 2048 harmonics, second order at a
#: kink such as dry friction's |sin| (relative error ~1e-7 here))
N_THETA = 4096


@dataclass(frozen=True)
class CardPoint:
    """The joint at one relative amplitude (SI; each ``*_std`` is that value's standard error).

    ``omega_rad_s`` is where it was evaluated: the natural frequency for a law's backbone, the
    drive frequency for a run."""

    amplitude_rad: float
    omega_rad_s: float
    natural_frequency_rad_s: float
    damping_ratio: float
    dissipation_J_per_cycle: float
    secant_stiffness_Nm_per_rad: float
    equivalent_damping_Nms_per_rad: float
    amplitude_rad_std: float = math.nan  # 0 for a law's points: there the amplitude is chosen
    natural_frequency_rad_s_std: float = math.nan
    damping_ratio_std: float = math.nan
    dissipation_J_per_cycle_std: float = math.nan
    secant_stiffness_Nm_per_rad_std: float = math.nan
    run: str = ""

    def as_json(self) -> dict:
        return {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class JointCard:
    """Card points over amplitude and the fitted dissipation power law ``E ~ A^slope``."""

    source: str  # "law" or "runs"
    inertia_kgm2: float  # Je of the joint's mode
    points: tuple[CardPoint, ...]
    dissipation_slope: float
    dissipation_slope_std: float
    #: d lnE / d ln(omega) at equal amplitude (1: viscous, 0: friction and hysteresis); NaN when
    #: the points share one frequency (a backbone has its own: see :func:`dissipation_slope`)
    rate_exponent: float = math.nan
    rate_exponent_std: float = math.nan

    def as_json(self) -> dict:
        return {"source": self.source, "inertia_kgm2": self.inertia_kgm2,
                "amplitudes": [p.as_json() for p in self.points],
                "dissipation_slope": _finite(self.dissipation_slope),
                "dissipation_slope_std": _finite(self.dissipation_slope_std),
                "rate_exponent": _finite(self.rate_exponent), "rate_exponent_std": _finite(self.rate_exponent_std)}


def _finite(v: float) -> Optional[float]:
    return v if math.isfinite(v) else None


def describing_function(law: JointLaw, amplitude_rad: float, omega_rad_s: float) -> tuple[float, float]:
    """``(k_eq N m/rad, c_eq N m s/rad)`` of the law at relative amplitude A and frequency omega
    (module docstring). Stateful terms (Jenkins) run over the cycle twice and give their
    periodic loop."""
    if not (amplitude_rad > 0 and omega_rad_s > 0):
        raise ValueError(f"describing_function needs amplitude_rad > 0 and omega_rad_s > 0, got "
                         f"{amplitude_rad!r}, {omega_rad_s!r}")
    # Midpoints: no sample sits on the reversals (theta = 0, pi), where a sign() would see the
    # round-off of sin(pi) and break the symmetry.
    theta = 2 * math.pi * (np.arange(N_THETA) + 0.5) / N_THETA
    phi = amplitude_rad * np.cos(theta)
    rate = -amplitude_rad * omega_rad_s * np.sin(theta)
    f = np.asarray(law.torque(phi, rate), dtype=float)
    k = 2.0 * float(np.mean(f * np.cos(theta))) / amplitude_rad
    c = 2.0 * float(np.mean(f * -np.sin(theta))) / (amplitude_rad * omega_rad_s)
    # A torque's harmonic below round-off of the torque itself is none (inside a free play the
    # law is nil, and a sum of 4096 zeros and near-zeros must not read as a tiny stiffness).
    tiny = 1e-12 * float(np.max(np.abs(f))) if f.size else 0.0
    return (k if abs(k) * amplitude_rad > tiny else 0.0), (c if abs(c) * amplitude_rad * omega_rad_s > tiny else 0.0)


def _backbone(law: JointLaw, inertia: float, amplitude: float) -> tuple[float, ...]:
    """(omega_n, zeta, E, k_eq, c_eq) at one amplitude; NaN where the joint has no stiffness."""
    k, _ = describing_function(law, amplitude, 1.0)
    if not k > 0:
        return (math.nan,) * 5
    w = math.sqrt(k / inertia)
    for _ in range(50):  # k_eq depends on omega only through rate terms: converges in a few steps
        k, c = describing_function(law, amplitude, w)
        if not k > 0:
            return (math.nan,) * 5
        w_new = math.sqrt(k / inertia)
        if abs(w_new - w) <= 1e-12 * w:
            w = w_new
            break
        w = w_new
    k, c = describing_function(law, amplitude, w)
    return w, c / (2 * inertia * w), math.pi * c * w * amplitude**2, k, c


def law_card(law: JointLaw, inertia_kgm2: float, amplitudes_rad: Sequence[float], *,
             covariance: Optional[np.ndarray] = None, inertia_index: Optional[int] = None,
             omegas_rad_s: Optional[Sequence[float]] = None, shapes: Sequence[tuple] = ()) -> JointCard:
    """The card of an identified law (module docstring): on the backbone (each amplitude at its
    natural frequency) or, with ``omegas_rad_s``, at given frequencies (the runs' drive
    frequencies, to compare with :func:`runs_card` point by point). Off the backbone the damping
    ratio is the loss factor's half, ``E / (2 pi k A^2)``, as for the runs.

    Args:
      law: the joint law (its values are the parameters of the covariance, in order).
      inertia_kgm2: Je of the joint's mode.
      amplitudes_rad: relative amplitudes A > 0.
      covariance: ``(p, p)`` covariance of the law's values, or of ``(Je, values...)`` when
        ``inertia_index`` is 0 (the equivalent form's parameter order), followed by the
        ``shapes``' parameters; None: no standard errors.
      shapes: ``(terms below, terms above, step)`` per parameter that shapes the law's terms (a
        slip angle, a free play), the law's terms at that parameter ``step`` below and above its
        value (:func:`identify.chain_diagnose.place_uncertainty`): its column of the card's
        Jacobian is their central difference at the law's values.
    """
    amps = [float(a) for a in amplitudes_rad]
    if not amps or not all(a > 0 and math.isfinite(a) for a in amps):
        raise ValueError(f"law_card needs finite amplitudes > 0, got {amplitudes_rad!r}")
    if not inertia_kgm2 > 0:
        raise ValueError(f"law_card needs inertia_kgm2 > 0, got {inertia_kgm2!r}")
    base = np.array([inertia_kgm2, *law.values])

    omegas = None if omegas_rad_s is None else [float(w) for w in omegas_rad_s]
    if omegas is not None and (len(omegas) != len(amps) or not all(w > 0 for w in omegas)):
        raise ValueError(f"law_card: omegas_rad_s must give one frequency > 0 per amplitude, got {omegas_rad_s!r}")

    def point(lw: JointLaw, je: float, a: float, i: int) -> tuple[float, ...]:
        if omegas is None:
            return _backbone(lw, je, a)
        w = omegas[i]
        k, c = describing_function(lw, a, w)
        e = math.pi * c * w * a * a
        return (math.sqrt(k / je) if k > 0 else math.nan, e / (2 * math.pi * k * a * a) if k > 0 else math.nan,
                e, k, c)

    def evaluate(theta: np.ndarray, a: float, i: int, terms=law.terms) -> np.ndarray:
        return np.array(point(JointLaw(terms, tuple(theta[1:])), float(theta[0]), a, i)[:4])

    points = []
    for i, a in enumerate(amps):
        w, zeta, e, k, c = point(law, inertia_kgm2, a, i)
        std = [math.nan] * 4
        if covariance is not None:  # (a row that is not finite, say where k <= 0, keeps no error)
            cov = np.asarray(covariance, dtype=float)
            full = np.zeros((base.size + len(shapes),) * 2)
            if inertia_index == 0:
                full[:, :] = cov
            else:
                full[1:, 1:] = cov
            jac = np.empty((4, full.shape[0]))
            for j in range(base.size):
                h = 1e-6 * max(abs(base[j]), math.sqrt(max(full[j, j], 0.0)), 1e-12)
                up = base.copy()
                up[j] += h
                dn = base.copy()
                dn[j] -= h
                jac[:, j] = (evaluate(up, a, i) - evaluate(dn, a, i)) / (2 * h)
            for j, (below, above, step) in enumerate(shapes, start=base.size):
                jac[:, j] = (evaluate(base, a, i, tuple(above)) - evaluate(base, a, i, tuple(below))) / (2 * step)
            var = np.einsum("ij,jk,ik->i", jac, full, jac)
            std = list(np.sqrt(np.clip(var, 0.0, None)))
        at = w if omegas is None else omegas[i]
        points.append(CardPoint(a, at, w, zeta, e, k, c, amplitude_rad_std=0.0, natural_frequency_rad_s_std=std[0],
                                damping_ratio_std=std[1],
                                dissipation_J_per_cycle_std=std[2], secant_stiffness_Nm_per_rad_std=std[3]))
    return JointCard("law", float(inertia_kgm2), tuple(points), *dissipation_slope(points))


@dataclass(frozen=True)
class JointRun:
    """One run at one joint, as its card reads it: per period, the Fourier coefficients
    (harmonics 0..h, ``(periods, h + 1)``) of the joint's relative motion and of the torque the
    joint carries, measured through the equations of motion (two flywheels:
    :func:`two_flywheel_run`; a train's joint: ``identify.chain_diagnose.train_joint_runs``)."""

    run: str
    omega_rad_s: float
    phi: np.ndarray
    torque: np.ndarray


def two_flywheel_run(rec: SteadyStateRecord, J1: float, J2: float, h: int, run: str = "") -> JointRun:
    """A two-flywheel run's joint: the relative angle and ``share M + Je omega^2 n^2 Phi_n``."""
    je, share = J1 * J2 / (J1 + J2), J2 / (J1 + J2)
    n, w = rec.samples_per_period, rec.omega_rad_s
    harm = np.arange(h + 1)
    phi, torque = [], []
    for q in range(rec.n_periods):
        sl = slice(q * n, (q + 1) * n)
        Phi = fourier_coefficients(rec.phi_rad[sl], 1, h)
        phi.append(Phi)
        torque.append(share * fourier_coefficients(rec.torque_Nm[sl], 1, h) + je * (harm * w) ** 2 * Phi)
    return JointRun(run, w, np.array(phi), np.array(torque))


def _run_periods(rec: SteadyStateRecord, J1: float, J2: float, h: int) -> np.ndarray:
    """``(amplitude, secant stiffness, dissipation, damping ratio)`` of every period of a run."""
    return _joint_periods(two_flywheel_run(rec, J1, J2, h))


def _joint_periods(jr: JointRun) -> np.ndarray:
    """``(amplitude, secant stiffness, dissipation, damping ratio)`` of every period of a joint's run."""
    harm = np.arange(jr.phi.shape[1])
    per = []
    for Phi, F in zip(jr.phi, jr.torque):
        a = abs(Phi[1])
        k = float(np.real(F[1] / Phi[1]))
        e = math.pi * float(np.sum(harm * np.imag(F * np.conj(Phi))))
        zeta = e / (2 * math.pi * k * a * a) if k > 0 else math.nan
        per.append((a, k, e, zeta))
    return np.array(per)


def _natural_frequency(k: float, je: float) -> float:
    return math.sqrt(k / je) if k > 0 else math.nan


def joint_runs_card(runs: Sequence[JointRun], je_kgm2: float) -> JointCard:
    """The card straight from a joint's measured runs (:func:`runs_card` without the inertias'
    own uncertainty): per run the periods' mean, standard errors from their spread; ``je_kgm2``
    the inertia of the joint's mode, for its natural frequency."""
    points = []
    for jr in runs:
        per = _joint_periods(jr)
        p = per.shape[0]
        a, k, e, zeta = map(float, per.mean(axis=0))
        se = per.std(axis=0, ddof=1) / math.sqrt(p) if p > 1 else np.full(4, math.nan)
        wn = _natural_frequency(k, je_kgm2)
        points.append(CardPoint(a, jr.omega_rad_s, wn, zeta, e, k, e / (math.pi * jr.omega_rad_s * a * a),
                                amplitude_rad_std=float(se[0]), natural_frequency_rad_s_std=0.5 * wn * se[1] / k
                                if k > 0 else math.nan, damping_ratio_std=float(se[3]),
                                dissipation_J_per_cycle_std=float(se[2]), secant_stiffness_Nm_per_rad_std=float(se[1]),
                                run=jr.run))
    points.sort(key=lambda q: q.amplitude_rad)
    return JointCard("runs", je_kgm2, tuple(points), *dissipation_slope(points))


def runs_card(records: Sequence[SteadyStateRecord], J1_kgm2: float, J2_kgm2: float, *,
              n_harmonics: int = 20, run_ids: Optional[Sequence[str]] = None,
              inertia_covariance: Optional[np.ndarray] = None) -> JointCard:
    """The card straight from measured runs, without a law (module docstring). Each record
    holds whole periods of a steady state; the inertias come from a fit (they are what the
    harmonic balance determines best).

    The standard errors hold the period-to-period spread of each run and, given
    ``inertia_covariance`` (the fit's ``(2, 2)`` covariance of J1 and J2 in kg^2 m^4), the
    inertias' own uncertainty: the torque share ``J2 / (J1 + J2)`` scales the joint torque and
    so the secant stiffness and the dissipation (a 1e-3 error in the share is a 1e-3 error in
    the loop area, measured on the paper's joint at 40 dB: three times the spread's error).
    """
    if not (J1_kgm2 > 0 and J2_kgm2 > 0):
        raise ValueError(f"runs_card needs inertias > 0, got J1 {J1_kgm2!r}, J2 {J2_kgm2!r}")
    cov_J = None
    if inertia_covariance is not None:
        cov_J = np.asarray(inertia_covariance, dtype=float)
        if cov_J.shape != (2, 2) or not np.all(np.isfinite(cov_J)):
            raise ValueError(f"runs_card: inertia_covariance must be a finite 2x2 matrix, got {inertia_covariance!r}")
    je = J1_kgm2 * J2_kgm2 / (J1_kgm2 + J2_kgm2)
    ids = list(run_ids) if run_ids is not None else [str(i) for i in range(len(records))]
    points = []
    for rid, rec in zip(ids, records):
        h = min(n_harmonics, (rec.samples_per_period - 1) // 2)
        w = rec.omega_rad_s
        p = rec.n_periods
        per = _run_periods(rec, J1_kgm2, J2_kgm2, h)
        mean = per.mean(axis=0)
        se = per.std(axis=0, ddof=1) / math.sqrt(p) if p > 1 else np.full(4, math.nan)
        a, k, e, zeta = map(float, mean)
        wn = _natural_frequency(k, je)
        wn_se = 0.5 * wn * se[1] / k if k > 0 else math.nan
        if cov_J is not None:
            # (a, k, E, zeta, omega_n) against (J1, J2) by central differences (the per-period
            # values are affine in the share and Je: exact up to round-off).
            base = np.array([J1_kgm2, J2_kgm2])
            jac = np.empty((5, 2))
            for j in range(2):
                step = 1e-6 * base[j]
                vals = []
                for sgn in (1.0, -1.0):
                    Jp = base.copy()
                    Jp[j] += sgn * step
                    m = _run_periods(rec, Jp[0], Jp[1], h).mean(axis=0)
                    vals.append(np.append(m, _natural_frequency(m[1], Jp[0] * Jp[1] / (Jp[0] + Jp[1]))))
                jac[:, j] = (vals[0] - vals[1]) / (2 * step)
            var_J = np.einsum("ij,jk,ik->i", jac, cov_J, jac)
            se = np.sqrt(se**2 + var_J[:4])
            wn_se = math.sqrt(wn_se**2 + var_J[4])
        points.append(CardPoint(a, w, wn, zeta, e, k, e / (math.pi * w * a * a),
                                amplitude_rad_std=float(se[0]), natural_frequency_rad_s_std=wn_se,
                                damping_ratio_std=float(se[3]), dissipation_J_per_cycle_std=float(se[2]),
                                secant_stiffness_Nm_per_rad_std=float(se[1]), run=str(rid)))
    points.sort(key=lambda q: q.amplitude_rad)
    return JointCard("runs", je, tuple(points), *dissipation_slope(points))


def dissipation_slope(points: Sequence[CardPoint]) -> tuple[float, float, float, float]:
    """``(slope, its standard error, rate exponent, its standard error)``: weighted least squares
    of ``ln E = a + slope ln A + rate_exponent ln omega`` (weights from the points' standard
    errors where all are known, else equal; errors scaled by the residual when it exceeds them).

    Runs at several drive frequencies need the frequency term: a viscous joint dissipates
    ``pi c omega A^2``, so its slope over A alone would mix in how the frequencies were chosen.
    On a backbone (one frequency per amplitude, omega_n(A)) or at one frequency the term is left
    out (rate exponent NaN) and the slope is taken along the points: 2 for a linear joint, 3 + chi
    for micro-slip. NaN where fewer than two amplitudes dissipate."""
    nan4 = (math.nan,) * 4
    pts = [q for q in points if q.dissipation_J_per_cycle > 0 and math.isfinite(q.dissipation_J_per_cycle)]
    x = np.log([q.amplitude_rad for q in pts])
    if np.unique(np.round(x, 9)).size < 2:
        return nan4
    lw = np.log([q.omega_rad_s for q in pts])
    backbone = all(q.omega_rad_s == q.natural_frequency_rad_s for q in pts)
    with_rate = not backbone and np.unique(np.round(lw, 9)).size >= 2 and len(pts) >= 4
    X = np.column_stack([np.ones_like(x), x] + ([lw] if with_rate else []))
    y = np.log([q.dissipation_J_per_cycle for q in pts])
    rel = np.array([q.dissipation_J_per_cycle_std / q.dissipation_J_per_cycle for q in pts])
    weighted = bool(np.all(np.isfinite(rel) & (rel > 0)))
    wts = 1.0 / rel**2 if weighted else np.ones_like(x)
    XtW = X.T * wts
    try:
        cov = np.linalg.inv(XtW @ X)
    except np.linalg.LinAlgError:
        return nan4
    beta = cov @ (XtW @ y)
    r = y - X @ beta
    dof = len(x) - X.shape[1]
    if weighted:
        scale = max(1.0, float(wts @ r**2) / dof) if dof > 0 else 1.0
    else:
        scale = float(r @ r) / dof if dof > 0 else math.nan
    se = np.sqrt(np.diag(cov) * scale) if math.isfinite(scale) else np.full(X.shape[1], math.nan)
    if with_rate:
        return float(beta[1]), float(se[1]), float(beta[2]), float(se[2])
    return float(beta[1]), float(se[1]), math.nan, math.nan


#: Harmonics of the loops the Masing check compares (:func:`masing_check`'s reason)
MASING_HARMONICS = 8
#: Masing check: points of each implied backbone on [0, A], and the grid of a synthesised loop
MASING_U_POINTS, MASING_GRID = 64, 4096
#: implied backbones that differ by less than this share of the smaller run's tip torque follow
#: Masing's rule whatever the noise: the loops are band-limited (harmonics 1..8 by default), which
#: rounds a slider's corners and rings along the branches (noise-free Jenkins and Iwan joints in
#: the rig: 2.4% and 1.6% measured, tests/test_card.py)
MASING_FIDELITY = 0.04
#: above this share of the tip torque (3 standard errors) the loops are too noisy to judge
MASING_NOISE_LIMIT = 0.1


@dataclass(frozen=True)
class MasingRun:
    """One run's loop read by Masing's rule: the backbone it implies, ``g(u)`` at ``u`` in [0, A]
    (rad, N m), with the standard error of ``g`` from the spread over the run's periods."""

    run: str
    amplitude_rad: float
    tip_torque_Nm: float
    u_rad: tuple[float, ...]
    g_Nm: tuple[float, ...]
    g_Nm_std: tuple[float, ...]
    highest_harmonic: int = 0  # the loop's band: harmonics 1..highest_harmonic


@dataclass(frozen=True)
class MasingCheck:
    """Do the measured loops follow from one backbone, as a Jenkins or Iwan joint's do?

    ``discrepancy`` is the largest, over pairs of runs, RMS difference of their implied
    backbones on the smaller run's range, over that run's tip torque; ``noise`` the same
    measure of the implied backbones' standard errors. ``follows`` when the discrepancy is
    within ``max(MASING_FIDELITY, 3 noise)`` and ``3 noise <= MASING_NOISE_LIMIT``; not when it
    exceeds ``max(MASING_FIDELITY, 5 noise)``; None in between (too noisy to judge) or when no
    two runs can be compared (amplitudes too far apart for the bandwidth). ``skipped`` names runs whose loop is not a
    simple loop (the angle turns more than twice a period), where the rule says nothing."""

    runs: tuple[MasingRun, ...]
    discrepancy: float
    noise: float
    worst_pair: tuple[str, str]
    follows: Optional[bool]  # None: fewer than two usable runs
    skipped: tuple[str, ...] = ()

    def as_json(self) -> dict:
        return {"follows": self.follows, "discrepancy": _finite(self.discrepancy), "noise": _finite(self.noise),
                "fidelity": MASING_FIDELITY,
                "worst_pair": list(self.worst_pair), "skipped": list(self.skipped),
                "runs": [{"run": r.run, "amplitude_rad": r.amplitude_rad, "tip_torque_Nm": r.tip_torque_Nm,
                          "u_rad": list(r.u_rad), "g_Nm": list(r.g_Nm), "g_Nm_std": list(r.g_Nm_std),
                          "highest_harmonic": r.highest_harmonic}
                         for r in self.runs]}


def _implied_backbone(phi: np.ndarray, f: np.ndarray, u_frac: np.ndarray) -> Optional[tuple[float, float, np.ndarray]]:
    """(A, tip torque, g at u = u_frac A) of one synthesised loop by Masing's rule, or None when
    the angle is not monotone between its extremes (not a simple loop)."""
    n = phi.size
    i_max, i_min = int(np.argmax(phi)), int(np.argmin(phi))
    down = np.arange(i_max, i_max + (i_min - i_max) % n + 1) % n
    up = np.arange(i_min, i_min + (i_max - i_min) % n + 1) % n
    x0, f0 = 0.5 * (phi[i_max] + phi[i_min]), 0.5 * (f[i_max] + f[i_min])
    a, tip = 0.5 * (phi[i_max] - phi[i_min]), 0.5 * (f[i_max] - f[i_min])
    xd, fd, xu, fu = phi[down] - x0, f[down] - f0, phi[up] - x0, f[up] - f0
    # Noise or a higher harmonic can make the angle wobble near its extremes: the branches are
    # taken as their monotone envelopes, unless the wobble exceeds 1% of the amplitude.
    env_d, env_u = np.minimum.accumulate(xd), np.maximum.accumulate(xu)
    if max(float(np.max(xd - env_d)), float(np.max(env_u - xu))) > 0.01 * (phi[i_max] - phi[i_min]):
        return None
    xd, xu = env_d, env_u
    u = u_frac * a
    # Descending from the tip (A, tip): f = tip - 2 g((A - x)/2); ascending from (-A, -tip):
    # f = -tip + 2 g((x + A)/2). The two halves are averaged.
    g_down = 0.5 * (tip - np.interp(a - 2 * u, xd[::-1], fd[::-1]))
    g_up = 0.5 * (np.interp(2 * u - a, xu, fu) + tip)
    return float(a), float(tip), 0.5 * (g_down + g_up)


def masing_check(records: Sequence[SteadyStateRecord], J1_kgm2: float, J2_kgm2: float, *,
                 n_harmonics: int = MASING_HARMONICS, run_ids: Optional[Sequence[str]] = None) -> MasingCheck:
    """Masing's rule on measured runs, without a law: a joint whose memory is a set of sliders
    (Jenkins, Iwan, dry friction beside springs) unloads from a reversal point ``(A, F)`` along
    its backbone ``g`` scaled by two, ``f = F - 2 g((A - x)/2)``. Read backwards, every run's loop
    implies a backbone on [0, A]; the rule holds when the loops of all runs imply the same one.
    Rate-dependent damping (viscous, quadratic) breaks it: its loop widens with the frequency
    and the amplitude, not as the backbone says.

    The joint torque is the equation of motion's ``share M + Je omega^2 n^2 Phi_n`` per harmonic
    (as in :func:`runs_card`), synthesised with the angle over one period from harmonics
    1..``n_harmonics``; per period for the standard errors, averaged for the value. The inertia
    term amplifies the angle's noise n^2 times: with 20 harmonics a 40 dB record is too noisy to
    judge, with 8 (the default) it is judged right (tests/test_card.py); the corners that 8
    harmonics round off are left out of the comparison.
    """
    if not (J1_kgm2 > 0 and J2_kgm2 > 0):
        raise ValueError(f"masing_check needs inertias > 0, got J1 {J1_kgm2!r}, J2 {J2_kgm2!r}")
    ids = list(run_ids) if run_ids is not None else [str(i) for i in range(len(records))]
    return joint_masing_check([two_flywheel_run(rec, J1_kgm2, J2_kgm2, min(n_harmonics, (rec.samples_per_period - 1) // 2),
                                                str(rid)) for rid, rec in zip(ids, records)])


def joint_masing_check(joint_runs: Sequence[JointRun]) -> MasingCheck:
    """:func:`masing_check` on a joint's runs, each band-limited to its coefficients' harmonics."""
    u_frac = np.linspace(0.0, 1.0, MASING_U_POINTS)
    runs, skipped = [], []
    for jr in joint_runs:
        rid, h = jr.run, jr.phi.shape[1] - 1
        per = []
        for Phi, F in zip(jr.phi, jr.torque):
            Phi, F = Phi.copy(), F.copy()
            Phi[0] = F[0] = 0.0
            per.append((Phi, F))
        Phi = np.mean([a for a, _ in per], axis=0)
        F = np.mean([b for _, b in per], axis=0)
        top = h
        mean = _implied_backbone(synthesize(Phi, MASING_GRID), synthesize(F, MASING_GRID), u_frac)
        if mean is None:
            skipped.append(str(rid))
            continue
        a, tip, g = mean
        each = [_implied_backbone(synthesize(x, MASING_GRID), synthesize(y, MASING_GRID), u_frac) for x, y in per]
        gs = np.array([e[2] for e in each if e is not None])
        g_std = gs.std(axis=0, ddof=1) / math.sqrt(len(gs)) if len(gs) > 1 else np.full(u_frac.size, math.nan)
        runs.append(MasingRun(str(rid), a, tip, tuple(map(float, u_frac * a)), tuple(map(float, g)),
                              tuple(map(float, g_std)), top))
    runs.sort(key=lambda r: r.amplitude_rad)
    worst, worst_noise, pair = -math.inf, math.nan, ("", "")
    # A band-limited loop is exact away from its reversals; within a phase of 2 pi / H of a
    # reversal (H its highest harmonic) the corners are rounded, i.e. for u below
    # (1 - cos(2 pi / H)) / 2 of its amplitude.
    for i, small in enumerate(runs):
        for big in runs[i + 1:]:
            u = np.asarray(small.u_rad)
            corner = 0.5 * (1.0 - math.cos(2.0 * math.pi / max(big.highest_harmonic, 4)))
            u_ok = u >= corner * big.amplitude_rad
            if np.count_nonzero(u_ok) < MASING_U_POINTS // 4:
                continue  # amplitudes too far apart to compare at this bandwidth
            u = u[u_ok]
            diff = np.asarray(small.g_Nm)[u_ok] - np.interp(u, big.u_rad, big.g_Nm)
            var = np.asarray(small.g_Nm_std)[u_ok] ** 2 + np.interp(u, big.u_rad, np.asarray(big.g_Nm_std) ** 2)
            scale = abs(small.tip_torque_Nm)
            d = math.sqrt(float(np.mean(diff**2))) / scale
            if d > worst:
                worst, worst_noise, pair = d, math.sqrt(float(np.mean(var))) / scale, (small.run, big.run)
    if not math.isfinite(worst):
        return MasingCheck(tuple(runs), math.nan, math.nan, ("", ""), None, tuple(skipped))
    noise = worst_noise if math.isfinite(worst_noise) else 0.0
    if worst > max(MASING_FIDELITY, 5 * noise):
        follows: Optional[bool] = False  # beyond any doubt the noise leaves
    elif worst <= max(MASING_FIDELITY, 3 * noise) and 3 * noise <= MASING_NOISE_LIMIT:
        follows = True
    else:
        follows = None  # too noisy to judge (a looser threshold would let viscous damping pass)
    return MasingCheck(tuple(runs), worst, worst_noise, pair, follows, tuple(skipped))
