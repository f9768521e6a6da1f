"""The gain of a chain's extended model on held-out runs, measured in the rig.

Each held-out run's recorded drive torques (their harmonics) are replayed in the chain rig on
the nominal fit's plant and on the extended fit's (identified inertias and laws); the
simulated joint twists are compared with the measured ones, harmonics 1..band of the period
average. The error of a model is ``sqrt(sum |sim - meas|^2 / sum |meas|^2)`` over every joint,
harmonic and held-out run; the gain is nominal error / extended error. The measured twists
carry noise: the error an exact model would have (the noise of the averaged harmonics) is
reported beside it as the floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, is_dataclass, replace
from typing import Optional, Sequence

import numpy as np

from jointrig.identify.chain import (REST_RATE_FRACTION, STICK_RATE_FRACTION, ChainRecord, channel_corrected, constant_loads,
                                    inertia_name)
from jointrig.identify.chain_diagnose import ChainDiagnosis, plant_and_inertias
from jointrig.identify.harmonics import fourier_coefficients, max_harmonic, synthesize
from jointrig.identify.zeros import SensorZeros, rezeroed, sensor_zeros
from jointrig.identify.estimates import satterthwaite
from jointrig.identify.periods import RESOLVED_SIGMA, period_spectra, pooled_period_spectra
from jointrig.vocab.law import Constant
from jointrig.vocab.params import HINGE, Coordinate
from jointrig.vocab.plant import drive_of_record

from jointrig.rig.chain import ChainRig, simulate_chain
from jointrig.rig.native_callback import MAX_HARM
from jointrig.parallel import fork_map

from jointrig.identify.defaults import (DEFAULT_ALPHA, DEFAULT_FIDELITY, DEFAULT_MAX_CAUSES, FIDELITY_STEP_SHARE,
                                       MAX_REPLAY_STEPS_PER_PERIOD, REPLAY_MAX_STEP_S)
from jointrig.identify.verdict import CHI2_PER_DOF_OK, RIG_FIDELITY, Grounds, Verdict, judge, unsettled

from .notes import (DIVERGED, NO_INERTIA, NO_STEADY_STATE, NOR_SPANNED, NOT_FOLLOWED, BandCut, BiasUnmeasured, BodyRests,
                    FidelityCycle, FixedFidelity, JointSticks, NoReplay, NoSpringToFrame, Spanned)
from .holdout import (MIN_PERIODS_TO_SPLIT, MIN_RUNS_TO_HOLD_OUT, Generalisation, generalisation_kind,
                      holdout_of_another_kind)
from jointrig.vocab.records import RecordError
from jointrig.rig.simulate import Diverged, SimulationConfig, SimulationError, SteadyStateNotReached

__all__ = ["ChainValidation", "RightModelError", "validate_chain", "twist_error", "found_motion", "departure", "TrainReport", "train_verdict", "run_train_diagnosis",
           "written_of", "held_means"]


@dataclass(frozen=True)
class ChainValidation:
    """Output error of the nominal and the extended model on held-out runs.

    Attributes:
      nominal_error, extended_error: relative RMS error of the joint twists' harmonics (NaN: the
        model reaches no steady state under a held-out run's drive; the nominal's is infinite
        where the extended model's is not).
      noise_floor: the error an exact model would have: the noise's, and the rig's own fidelity
        (:data:`identify.verdict.RIG_FIDELITY`) in quadrature.
      per_run: ``(label, nominal error, extended error, noise floor, a right model's error)`` per
        held-out run (the last :attr:`RightModelError.relative` of that run alone; NaN unmeasured).
      failures: what kept a model from being simulated (:class:`studies.notes.NoReplay`), if anything.
      right: what a right model would miss here (:class:`RightModelError`): the noise, its own
        parameters' uncertainty and the method's bias; None where the judged model was not
        simulated (the verdict is then "unexplained" for that reason).
    """

    nominal_error: float
    extended_error: float
    noise_floor: float
    per_run: tuple
    failures: tuple = ()
    right: Optional["RightModelError"] = None
    #: what the nominal model would miss here were it right (where a cause was adopted): the
    #: yardstick of the test that the held-out runs show the nominal model wrong
    nominal_right: Optional["RightModelError"] = None
    #: the harmonics compared: 1..band
    band: int = 10
    #: per held-out run: (measured record, nominal simulation, extended simulation), for plots
    records: tuple = field(default=(), repr=False, compare=False)
    #: the replays compared over the record's own span from its measured state, no steady state
    #: reached in the rig (:class:`studies.notes.Spanned`: which model, which run, why)
    spanned: tuple = ()
    #: the method's bias on the judged model's parameters: ``(name, refitted - fitted, standard
    #: error)`` for each, its structure refitted on its own noise-free replay of the fitted runs
    #: (empty where none was made)
    method_bias: tuple = ()

    @property
    def gain(self) -> float:
        """nominal / extended error; NaN where a model was not simulated (``failures`` say why), infinite
        where only the nominal model reaches no steady state."""
        if not math.isfinite(self.extended_error) or math.isnan(self.nominal_error):
            return math.nan
        return self.nominal_error / self.extended_error if self.extended_error > 0 else math.inf

    @property
    def expected_error(self) -> float:
        """The relative error a right model has in this comparison (:attr:`RightModelError.relative`;
        NaN where the judged model was not simulated)."""
        return self.right.relative if self.right is not None else math.nan

    @property
    def bound(self) -> float:
        """The most a right model's error exceeds :attr:`expected_error` (a ratio) at the verdict's
        false-alarm rate (:attr:`RightModelError.bound`; NaN where not measured)."""
        return self.right.bound if self.right is not None else math.nan


@dataclass(frozen=True)
class RightModelError:
    """What a right model misses on the held-out twists (sums of ``|.|^2`` over every compared
    joint, harmonic and run, relative to the measured twists' ``sum |meas|^2``) (pure data).

    A model whose form is right still misses the held-out motion by (a) the held-out records'
    own noise; (b) what its inputs' uncertainty carries into the replay, propagated through the
    rig to first order: its parameters' (the fit's covariance as a right model has it, not
    inflated by a misfit; one replay per direction) and the noise of the measured drive it is
    replayed under (a few draws); (c) the method's bias: the
    model refitted on its own noise-free replay of the fitted runs, where the truth is known,
    predicts the held-out runs this differently (the harmonic balance's misfit at kinks, the
    band, the rig's integrator); (d) the rig's own fidelity (:data:`identify.verdict.RIG_FIDELITY`).
    Under a right model the squared error is about a chi-square of ``dof`` components (the
    Welch-Satterthwaite count of the parts' sizes) times ``total / dof``; ``total`` is itself
    estimated (the noise from the records' period-to-period spread, the drive's part from a few
    draws), with ``estimate_dof`` degrees of freedom (the same count over the estimates), so
    the squared ratio is about Fisher's F(dof, estimate_dof), and the error over :attr:`relative`
    stays below :attr:`bound` but with probability ``alpha``.

    Attributes:
      noise, propagated, method, rig: the parts (a), (b), (c), (d).
      dof: the effective number of independent components.
      estimate_dof: the effective degrees of freedom of ``total``'s estimate (inf: known).
      alpha: the false-alarm rate of :attr:`bound`.
      draws: how many draws of the drive's noise (b) was estimated from.
      directions: how many directions of the parameters' covariance were replayed for (b).
      unmeasured: why (c) is 0 (:class:`studies.notes.BiasUnmeasured`; None where it was measured).
    """

    noise: float
    propagated: float
    method: float
    rig: float
    dof: float
    alpha: float
    draws: int
    unmeasured: Optional[BiasUnmeasured] = None
    estimate_dof: float = math.inf
    directions: int = 0

    @property
    def total(self) -> float:
        return self.noise + self.propagated + self.method + self.rig

    @property
    def relative(self) -> float:
        """A right model's RMS error relative to the measured twists."""
        return math.sqrt(max(self.total, 0.0))

    @property
    def bound(self) -> float:
        """``sqrt(F.ppf(1 - alpha, dof, estimate_dof))`` (with a known total, ``sqrt(chi2.ppf(1 -
        alpha, dof) / dof)``): the error over :attr:`relative` that a right model exceeds with
        probability ``alpha``."""
        from scipy.special import chdtri, fdtri  # the quantiles, without scipy.stats's 0.9 s import

        k = max(self.dof, 1.0)
        if math.isfinite(self.estimate_dof):
            return math.sqrt(float(fdtri(k, max(self.estimate_dof, 1.0), 1.0 - self.alpha)))
        return math.sqrt(float(chdtri(k, self.alpha)) / k)


def found_motion(rec: ChainRecord, step) -> tuple[str, np.ndarray]:
    """What to show of a record for a found cause (``step``: a chain candidate's score): the twist
    of its joint, or of a body's nearest joint for a drag; a single body's position, or the body's
    own for a law to ground; for the drives' lag, joint 1's twist (body 1's position). Returns
    (label, samples)."""
    N = rec.n_flywheels
    if N == 1 or step.ground:
        i = step.place or 1
        return f"body {i} position", rec.angles_rad[i - 1]
    j = step.place if step.at_joint else min(step.place or 1, N - 1)
    return f"joint {j} twist", rec.angles_rad[j - 1] - rec.angles_rad[j]


def departure(meas: ChainRecord, sim: ChainRecord, step, band: int) -> np.ndarray:
    """Where a simulated record departs from the measured one in what ``step``'s cause acts on
    (:func:`found_motion`): model minus measurement over one period on the measured record's
    samples, harmonics 1..``band`` (those the validation compares; the mean left out, a sensor's
    zero being arbitrary) (pure)."""
    N = meas.samples_per_period
    out = []
    for rec in (sim, meas):
        x = found_motion(rec, step)[1]
        top = min(band, rec.samples_per_period // 2 - 1, N // 2 - 1)
        out.append(synthesize(fourier_coefficients(x, rec.n_periods, top) * (np.arange(top + 1) > 0), N))
    return out[0] - out[1]


def _motions(rec: ChainRecord) -> list[np.ndarray]:
    """What the laws see, compared between model and measurement: every joint's twist; a single
    body's own position (its laws are to ground)."""
    if rec.n_flywheels == 1:
        return [rec.angles_rad[0]]
    return [rec.angles_rad[j] - rec.angles_rad[j + 1] for j in range(rec.n_flywheels - 1)]


def _twists(rec: ChainRecord, band: int) -> np.ndarray:
    """Harmonics 1..band of every joint's twist (a single body: its position), ``(N - 1, band)``."""
    return np.array([fourier_coefficients(x, rec.n_periods, band)[1:] for x in _motions(rec)])


def twist_error(sim: ChainRecord, meas: ChainRecord, band: int) -> tuple[float, float]:
    """(sum |sim - meas|^2, sum |meas|^2) over every joint's twist harmonics 1..band."""
    a, b = _twists(sim, band), _twists(meas, band)
    return float(np.sum(np.abs(a - b) ** 2)), float(np.sum(np.abs(b) ** 2))


def _noise_parts(meas: ChainRecord, band: int, noise_std: Optional[dict] = None) -> np.ndarray:
    """The expected ``|noise|^2`` of each real component (cosine and sine of every joint's twist
    harmonics 1..band, period-averaged): from the period-to-period spread, or for a record of one
    period from ``noise_std`` (channel "phi<i>" -> noise per sample, the fit's: each coefficient
    C_n = 2 X_n of white noise sigma over N samples has E|C_n|^2 = 4 sigma^2 / N, half in each
    real part); empty without either."""
    P = meas.n_periods
    if P < 2:
        if not noise_std:
            return np.zeros(0)
        N, N_bodies = meas.samples_per_period, meas.n_flywheels
        sig = [noise_std.get(f"phi{i}", 0.0) for i in range(1, N_bodies + 1)]
        per = [sig[0] ** 2] if N_bodies == 1 else [sig[j] ** 2 + sig[j + 1] ** 2 for j in range(N_bodies - 1)]
        return np.repeat(2.0 * np.array(per) / N, 2 * band)
    parts = []
    for x in _motions(meas):
        _, _, var = period_spectra(x, P)
        parts.append(np.repeat(2.0 * var[1:band + 1], 2))  # of C_n = 2 X_n: 4 var, half in each part
    return np.concatenate(parts)


def _floor(noise: float, den: float) -> float:
    """The error an exact model has: the noise's, relative to the measured twists' size, and the
    rig's own fidelity in quadrature."""
    return math.sqrt(max(noise, 0.0) / den + RIG_FIDELITY ** 2)


def start_of(rec: ChainRecord, band: int, offsets_rad: Sequence[float] = ()) -> Optional[tuple]:
    """Each body's angle and rate at the record's t = 0 from harmonics 0..``band`` of its periods
    (the noise above them left out), for a replay that begins on the measured motion
    (:func:`rig.chain.simulate_chain`'s ``start``); None where a body's angle is not measured.
    ``offsets_rad``: each joint's fitted twist zero (``ChainSpec.offsets_rad``): the rig's twist
    is the measured one minus it, so each body after a joint starts that much further on."""
    if any(a is None for a in rec.angles_rad):
        return None
    top = min(band, max_harmonic(rec.samples_per_period))
    n = np.arange(top + 1)
    c = [fourier_coefficients(a, rec.n_periods, top) for a in rec.angles_rad]
    shift = np.concatenate([[0.0], np.cumsum(np.asarray(offsets_rad, float))])[:len(c)] if len(offsets_rad) else \
        np.zeros(len(c))
    return (tuple(float(np.sum(x.real)) + float(d) for x, d in zip(c, shift)),
            tuple(float(-np.sum(n * rec.omega_rad_s * x.imag)) for x in c))


def held_means(fit, rec: ChainRecord) -> tuple[float, ...]:
    """The constant torque (N m; N on a slide) on each body that holds ``rec``'s mean twists under
    the fitted model ``fit`` (a :class:`identify.chain_diagnose.ChainFit`) (pure): each joint whose
    zero the data determine (:func:`identify.chain_diagnose.zero_resolved`) carries its elastic terms' mean along the
    record's twist (:func:`identify.chain_diagnose.mean_joint_torque`), pushed on its two bodies
    in opposite senses. A mean load (a pump's) preloads the joints between it and the drive; a
    replay without it swings about the laws' zero instead of the measured mean twist, where an
    even stiffness or a progressive coupling is another spring. The measured drive's mean cannot
    stand in: a torque cell reads its own offset, and a load may act where no cell is. Elsewhere
    the laws do not show where their zero is, and no constant is needed: a linear law's swing is
    the same about any twist. A body whose constant the fit read (:class:`vocab.law.Constant`,
    where it may stick) carries its drive's measured mean less that constant: the net constant
    force that moves it, the cell's offset taken out."""
    from jointrig.identify.chain_diagnose import mean_joint_torque, zero_resolved

    # a body's fitted constant (its cell's offset plus a constant load): the replay's drive drops
    # the measured mean, so the body carries that mean less the constant
    loads = [(float(np.mean(rec.torques_Nm[i])) if rec.torques_Nm[i] is not None else 0.0) - k if k else 0.0
             for i, k in enumerate(constant_loads(fit.as_dict(), fit.spec))]
    for j in range(1, fit.spec.n_flywheels):
        if zero_resolved(fit, j):
            q = mean_joint_torque(fit, [rec], j, with_error=False)[0]
            if math.isfinite(q):
                loads[j - 1] += q
                loads[j] -= q
    return tuple(loads)


#: A free body's drift per period that :func:`without_drift` leaves in a replay, relative to its
#: swing (RMS of its position): a sawtooth of that size in a record is far below any noise floor.
DRIFT_TOL = 1e-7
#: Secant steps :func:`without_drift` takes at most.
DRIFT_STEPS = 8


def drifting_bodies(fit) -> tuple[int, ...]:
    """The bodies (0-based) whose replay under a measured drive would drift: those with a fitted
    constant (:class:`vocab.law.Constant`: where they may stick, balanced while they slide) in a
    train with no elastic law to ground. Nothing holds their mean position but what held it on
    the bench, a position controller (or an operator): a replay under the measured force alone
    walks off by whatever mean force the fit misses, a fraction of a newton per period."""
    spec = fit.spec
    if any(t.elastic for g in spec.grounds for t in g):
        return ()
    return tuple(i for i, g in enumerate(spec.grounds) if any(isinstance(t, Constant) for t in g))


def without_drift(simulate, loads: tuple, bodies: Sequence[int], scale: Sequence[float]):
    """``simulate(loads)`` (a settled replay) with each of ``bodies`` given the constant load that
    leaves its mean rate 0, as the bench's position controller held it: secant steps on each
    body's load (from ``scale``, N m or N, a first probe of 1e-3 of it) until its drift per
    period is below :data:`DRIFT_TOL` of its swing. Returns (the replay, the loads used)."""
    loads = list(loads)
    sim = simulate(tuple(loads))
    if not bodies:
        return sim, tuple(loads)
    T = 2 * math.pi / sim.omega_rad_s
    swing = np.array([max(float(np.std(sim.angles_rad[i] - np.mean(sim.rate(i)) * sim.time_s)), 1e-300)
                      for i in bodies])

    def drift(rec) -> np.ndarray:  # per period, relative to the first replay's swing about its trend
        return np.array([float(np.mean(rec.rate(i))) * T for i in bodies]) / swing

    d_prev, l_prev = drift(sim), np.array([loads[i] for i in bodies])
    step = np.array([1e-3 * max(abs(x), 1e-12) for x in scale]) * -np.sign(d_prev)
    for _ in range(DRIFT_STEPS):
        if np.all(np.abs(d_prev) < DRIFT_TOL):
            break
        now = l_prev + step
        for i, v in zip(bodies, now):
            loads[i] = float(v)
        sim = simulate(tuple(loads))
        d = drift(sim)
        slope = (d - d_prev) / np.where(step != 0, step, 1.0)
        step = np.where(slope != 0, -d / np.where(slope != 0, slope, 1.0), step)
        d_prev, l_prev = d, now
    return sim, tuple(loads)


class _NoReplay(Exception):
    """A model that could not be simulated under a held-out run's drive (why: ``failure``)."""

    def __init__(self, failure: NoReplay):
        super().__init__(failure)
        self.failure = failure


#: The most replay steps a cycle of a held-out drive's highest harmonic may span less than
#: (:func:`held_drive_lines`): 8 keep the integrator's stages from folding it onto a lower one.
STEPS_PER_DRIVE_CYCLE = 8


def held_drive_lines(meas: ChainRecord, n_harmonics: int, step_s: float = REPLAY_MAX_STEP_S) -> int:
    """The harmonics 0..H of a held-out run's drives its replay carries: the diagnosis's band, and
    above it up to the highest harmonic where a drive's period average stands out of its noise
    (:data:`identify.periods.RESOLVED_SIGMA`, pooled), within what the record resolves, the rig's
    drive takes (:data:`rig.native_callback.MAX_HARM`) and the replay's step ``step_s`` follows
    (:data:`STEPS_PER_DRIVE_CYCLE`). A controller's kinks or force pulses put drive far above the
    band; replayed without it a position-controlled carriage (pulses of 0.04 s in a 3 s period)
    moved 3.2 times what a right model misses at harmonics 0..40, 1.75 times with them."""
    top = max_harmonic(meas.samples_per_period)
    lines = min(n_harmonics, top)
    if meas.n_periods < 2:
        return lines  # no noise estimate: no line is known to stand out of it
    cap = min(top, MAX_HARM - 1, int(2 * math.pi / (meas.omega_rad_s * step_s * STEPS_PER_DRIVE_CYCLE) + 1e-9))
    for t in meas.torques_Nm:
        if t is None:
            continue
        _, mean, var = pooled_period_spectra(t, meas.n_periods)
        above = np.flatnonzero(np.abs(mean[lines + 1:cap + 1]) > RESOLVED_SIGMA * np.sqrt(var[lines + 1:cap + 1]))
        if above.size:
            lines = lines + 1 + int(above[-1])
    return lines


def _held_coefficients(meas: ChainRecord, n_harmonics: int, step_s: float = REPLAY_MAX_STEP_S) -> dict:
    """A held-out run's drive torques' harmonics 0..:func:`held_drive_lines`, by body (1-based)."""
    lines = held_drive_lines(meas, n_harmonics, step_s)
    return {i + 1: fourier_coefficients(t, meas.n_periods, lines) for i, t in enumerate(meas.torques_Nm)
            if t is not None}


def _drive_noise(meas: ChainRecord, coeffs: dict, noise_std: Optional[dict] = None) -> dict:
    """E|noise|^2 of each drive coefficient C_n = 2 X_n of :func:`_held_coefficients` (its
    constant part 0: the replay drops it), by body: from the period-to-period spread, or over one
    period from ``noise_std`` ("torque<i>": the fit's noise per sample)."""
    out = {}
    for i, c in coeffs.items():
        x = meas.torques_Nm[i - 1]
        if meas.n_periods >= 2:
            var = 4.0 * period_spectra(x, meas.n_periods)[2][:len(c)]
        else:
            sig = (noise_std or {}).get(f"torque{i}", 0.0)
            var = np.full(len(c), 4.0 * sig ** 2 / meas.samples_per_period)
        var = np.array(var, dtype=float)
        var[0] = 0.0
        out[i] = var
    return out


def _drive_scale(rec: ChainRecord) -> tuple:
    """Per body, the size of its measured drive (RMS about its mean; 1 where it has none): the
    scale of :func:`without_drift`'s first probe."""
    return tuple(float(np.std(t)) if t is not None else 1.0 for t in rec.torques_Nm)


def _drives(meas: ChainRecord, coeffs: dict) -> dict:
    return {i: drive_of_record(meas.omega_rad_s, c) for i, c in coeffs.items()}


def _drawn_drives(meas: ChainRecord, coeffs: dict, noise: dict, rng: np.random.Generator) -> dict:
    """The drives at :data:`DRAW_STEP` of a draw of the measured torques' noise (:func:`_drive_noise`)."""
    out = {}
    for i, c in coeffs.items():
        sd = DRAW_STEP * np.sqrt(noise[i] / 2.0)
        out[i] = np.asarray(c) + sd * (rng.standard_normal(len(c)) + 1j * rng.standard_normal(len(c)))
    return _drives(meas, out)


def _replayed(rig: ChainRig, fit, read, meas: ChainRecord, drives: dict, cfg: SimulationConfig, top: int,
              backend: str, name: str, span: Optional[bool] = None) -> tuple[ChainRecord, bool]:
    """``fit``'s model under a held-out run's drives from the run's measured state and mean twists,
    read through ``read``'s channels: its periodic steady state, or where it reaches none in the
    rig, its course over the record's own periods (a right model may settle slowly, or never, and
    still follow the record: "no steady state" is never the reason a model is refused). ``span``:
    True or False forces one of the two. Returns (simulated record, whether spanned); raises
    :class:`_NoReplay` with the reason."""
    plant, J = plant_and_inertias(fit)
    bad = tuple((i, float(v)) for i, v in enumerate(J, start=1) if not (math.isfinite(v) and v > 0))
    if bad:  # no body's (a file read wrong): nothing to simulate
        raise _NoReplay(NoReplay(name, meas.source, NO_INERTIA, inertias=bad))
    start, loads = start_of(meas, top, read.offsets_rad), held_means(fit, meas)
    spanned_cfg = replace(cfg, settle=False, n_periods=meas.n_periods)

    def diverged(err: Diverged) -> _NoReplay:  # a fitted value makes the model unstable: a reason, not a crash
        return _NoReplay(NoReplay(name, meas.source, DIVERGED, err.warnings))

    def run(c):
        def once(held):
            return simulate_chain(rig.with_plant(plant), meas.omega_rad_s, drives, c, inertias_kgm2=J,
                                  backend=backend, start=start, loads_Nm=held)[0]
        sim, _ = without_drift(once, loads, drifting_bodies(fit) if c.settle else (), _drive_scale(meas))
        return channel_corrected(sim, read, read=True)

    if span:
        try:
            return run(spanned_cfg), True
        except Diverged as err:
            raise diverged(err) from err
        except SimulationError as err:
            raise _NoReplay(NoReplay(name, meas.source, NOT_FOLLOWED, str(err))) from err
    try:
        return run(cfg), False
    except Diverged as err:
        raise diverged(err) from err
    except SteadyStateNotReached:
        if span is False:
            raise _NoReplay(NoReplay(name, meas.source, NO_STEADY_STATE)) from None
        try:
            return run(spanned_cfg), True
        except Diverged as again:
            raise diverged(again) from again
        except SimulationError as again:
            raise _NoReplay(NoReplay(name, meas.source, NOR_SPANNED, str(again), periods=meas.n_periods)) from again
    except SimulationError as err:  # a divergence: a reason, not a crash
        raise _NoReplay(NoReplay(name, meas.source, NO_STEADY_STATE, str(err))) from err


#: Draws of the held-out drive's noise whose replays estimate what it costs a held-out prediction
#: (part of :class:`RightModelError`'s ``propagated``; the parameters' part is exact, one replay
#: per direction of their covariance): each draw's squared departure is at least a chi-square of
#: one degree of freedom times its share, so the mean of 2 is an estimate of 2 degrees of freedom
#: or more, and the bound says so (a part that small beside the noise moves it little). Drawn with
#: a fixed seed, so that a file's verdict does not change between runs.
DRIVE_DRAWS = 2
DRAW_SEED = 0


def right_covariance(fit) -> Optional[np.ndarray]:
    """The covariance of ``fit``'s linear parameters that a right model has: the solver's, without
    the factor a misfit puts on it (:func:`identify.estimates.weighted_chi2`: chi2/dof where above
    1) (pure)."""
    if fit.covariance is None:
        return None
    return np.asarray(fit.covariance) / max(1.0, fit.chi2 / max(fit.dof, 1))


#: A replay moves the parameters (or the drive) this fraction of a standard deviation along a
#: direction of their covariance, and its squared departure is divided by its square: the
#: first-order propagation of the covariance, as a standard error is. A whole standard deviation
#: can cross a resonance or a free play's edge that the fitted model is far from.
DRAW_STEP = 0.1
#: Directions of a covariance whose variance (of the correlation matrix, whose eigenvalues sum to
#: the number of parameters) is below this share of the largest carry nothing worth a replay.
DIRECTION_FLOOR = 1e-9


def _directions(fit, cov: np.ndarray) -> list:
    """``fit`` moved :data:`DRAW_STEP` of a standard deviation along each principal direction of
    ``cov`` (pure): the sum of the squared departures these cause, over ``DRAW_STEP^2``, is the
    covariance propagated to first order, ``trace(G cov G')``. The directions are the correlation
    matrix's, scaled by each standard error: the parameters' scales span 15 orders of magnitude
    (an inertia's 1e-4 kg m^2 beside a cubic's 5e6 N m/rad^3), and the covariance's own
    eigenvectors would lose the small ones to round-off (draws moved an inertia 50 of its standard
    errors)."""
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    scale = np.where(sd > 0, sd, 1.0)
    corr = cov / np.outer(scale, scale)
    w, V = np.linalg.eigh((corr + corr.T) / 2)
    keep = w > DIRECTION_FLOOR * max(float(w.max()), 0.0)
    values = np.asarray(fit.values)
    return [replace(fit, values=values + DRAW_STEP * sd * V[:, i] * math.sqrt(w[i])) for i in np.flatnonzero(keep)]


def _with_value(obj, value: float, to: float):
    """``obj`` (a spec, its terms, tuples of them) with every float field equal to ``value`` set to
    ``to`` (pure): where a profiled parameter (a free play, a cogging's order, a lag, a twist's
    zero) lives in a structure, whatever its type."""
    if isinstance(obj, float):
        return to if value != 0 and abs(obj - value) <= 1e-12 * abs(value) else obj
    if isinstance(obj, tuple):
        return tuple(_with_value(x, value, to) for x in obj)
    if is_dataclass(obj) and not isinstance(obj, type):
        changes = {f.name: _with_value(getattr(obj, f.name), value, to) for f in fields(obj)}
        return replace(obj, **{k: v for k, v in changes.items() if v is not getattr(obj, k)})
    return obj


def _profiled_moves(fit) -> list:
    """``fit`` with each profiled parameter moved :data:`DRAW_STEP` of its standard error (pure):
    its part of the first-order propagation (the linear parameters' covariance carries it as well,
    widened, so it is counted twice: a bound on the safe side)."""
    out = []
    for _, value, se in fit.profiled:
        if math.isfinite(se) and se > 0 and math.isfinite(value) and value != 0:
            spec = _with_value(fit.spec, float(value), float(value) + DRAW_STEP * float(se))
            if spec != fit.spec:
                out.append(replace(fit, spec=spec))
    return out


def validate_chain(rig: ChainRig, diagnosis: ChainDiagnosis, held_out: Sequence[ChainRecord], *,
                   band: int = 10, config: SimulationConfig = SimulationConfig(samples_per_period=128,
                                                                               max_step_s=REPLAY_MAX_STEP_S),
                   max_wall_s: Optional[float] = 120.0, backend: str = "auto",
                   noise_std: Optional[dict] = None, refit=None, alpha: float = DEFAULT_ALPHA,
                   draws: int = DRIVE_DRAWS) -> ChainValidation:
    """Replay every held-out run's drives on the nominal and the extended plant (module docstring);
    ``backend`` as :func:`rig.chain.simulate_chain`'s; ``noise_std``: the fit's noise per sample
    by channel, the noise floor of a held-out record of one period (:func:`_noise_parts`).

    What a right model misses here is measured for the model the verdict judges (the extended
    one, or the nominal without a cause): :class:`RightModelError` at false-alarm rate ``alpha``,
    from one replay per direction of its parameters' covariance, ``draws`` of the drive's noise, and ``refit(fit)`` (the fit's structure refitted on its own
    noise-free replay of the fitted runs, or why not, :class:`studies.notes.BiasUnmeasured`; None:
    no method bias measured)."""
    cfg = replace(config, absolute_angles_periodic=False, max_wall_s=max_wall_s, n_periods=1)
    # a sensor's skew or scale is not simulated: the simulated angles are read as its channel reads
    fits = {"nominal": diagnosis.nominal}
    if diagnosis.steps:  # without a cause the extended model is the nominal one
        fits["extended"] = diagnosis.final
    judged = "extended" if diagnosis.steps else "nominal"
    num = {k: 0.0 for k in fits}
    failed: dict = {}
    spanned: list = []
    den = noise = 0.0
    per_run = []
    records = []
    # what a right model misses, for the judged model and (to test it) the nominal one: each one's
    # parameters' directions, its drive's draws, and the judged one's refit on its own replay
    rated = {"extended", "nominal"} if diagnosis.steps else {"nominal"}
    rng = np.random.default_rng(DRAW_SEED)
    moved = {}
    for name in rated:
        cov = right_covariance(fits[name])
        moved[name] = (_directions(fits[name], cov) if cov is not None else []) + _profiled_moves(fits[name])
    got = refit(fits[judged]) if refit is not None else BiasUnmeasured()
    refitted, why_not = (got, None) if not isinstance(got, BiasUnmeasured) else (None, got)
    bias = () if refitted is None else tuple(
        (n, float(a - b), float(e)) for n, a, b, e in zip(fits[judged].names, refitted.values, fits[judged].values,
                                                          fits[judged].std_errors))
    tally = {name: {"propagated": 0.0, "method": 0.0, "components": [], "estimates": []} for name in rated}
    for meas in held_out:
        top = min(band, max_harmonic(meas.samples_per_period))
        coeffs = _held_coefficients(meas, diagnosis.n_harmonics, cfg.max_step_s)
        drives = _drives(meas, coeffs)
        errs, sims, spans = {}, {}, {}
        for name, fit in fits.items():
            if name in failed:
                continue
            try:
                sim, spans[name] = _replayed(rig, fit, fit.spec, meas, drives, cfg, top, backend, name)
            except _NoReplay as err:
                failed[name] = err.failure
                continue
            if spans[name]:
                spanned.append(Spanned(name, meas.source, cfg.max_periods, cfg.max_wall_s or None))
            sims[name] = sim
            e, d = twist_error(sim, meas, top)
            num[name] += e
            errs[name] = math.sqrt(e / d)
        sims.setdefault("extended", sims.get("nominal"))
        errs.setdefault("extended", errs.get("nominal", math.nan))
        d_run, noise_run = twist_error(meas, meas, top)[1], _noise_parts(meas, top, noise_std)
        n_run = float(np.sum(noise_run))
        den += d_run
        noise += n_run
        right_run = math.nan
        noise_in = _drive_noise(meas, coeffs, noise_std)
        for name in sorted(rated):
            if name not in spans:  # not simulated here
                continue
            p_run, d_part, m_run, by_direction = _departures(
                rig, fits[name], sims[name], meas, drives, [_drawn_drives(meas, coeffs, noise_in, rng)
                                                             for _ in range(draws)],
                moved[name], refitted if name == judged else None, cfg, top, backend, name, spans[name])
            t = tally[name]
            t["propagated"] += p_run + d_part
            t["method"] += m_run
            t["components"] += list(noise_run) + [float(x) for x in by_direction if x > 0] + [d_part, m_run]
            # each harmonic's noise estimated from the period spread (2 (P - 1) degrees of freedom;
            # one period: the fit's noise per sample, of many); the drive's part from its draws
            if meas.n_periods >= 2:
                t["estimates"] += [(float(a + b), 2.0 * (meas.n_periods - 1))
                                   for a, b in zip(noise_run[::2], noise_run[1::2])]
            t["estimates"].append((d_part, float(max(draws, 1))))
            if name == judged:
                right_run = math.sqrt((n_run + p_run + d_part + m_run) / d_run + RIG_FIDELITY ** 2)
        per_run.append((meas.source, errs.get("nominal", math.nan), errs["extended"], _floor(n_run, d_run), right_run))
        if sims.get("nominal") is not None and sims["extended"] is not None:
            records.append((meas, sims["nominal"], sims["extended"]))
    num.setdefault("extended", num["nominal"])
    error = {k: (math.nan if k in failed else math.sqrt(num[k] / den)) for k in num}
    if "nominal" in failed and diagnosis.steps and "extended" not in failed:
        error["nominal"] = math.inf  # the extension predicts the runs the nominal model cannot reach
    if not diagnosis.steps and "nominal" in failed:
        error["extended"] = math.nan
    right = {}
    for name in rated:
        if name in failed or den <= 0:
            continue
        t = tally[name]
        lam = np.asarray([c for c in t["components"] if c > 0] + [RIG_FIDELITY ** 2 * den])
        dof = float(np.sum(lam) ** 2 / np.sum(lam ** 2)) if lam.size else 1.0
        # the estimate's degrees of freedom: its estimated parts beside what is known (the
        # parameters' directions, the method's bias, the rig's fidelity)
        est = [(size, m) for size, m in t["estimates"] if size > 0]
        known = float(np.sum(lam)) - sum(size for size, _ in est)
        m_eff = satterthwaite([size for size, _ in est] + [known], [m for _, m in est] + [math.inf])
        right[name] = RightModelError(noise / den, t["propagated"] / den, t["method"] / den, RIG_FIDELITY ** 2, dof,
                                      alpha, draws, why_not if name == judged else BiasUnmeasured(smooth=True),
                                      m_eff, len(moved[name]))
    return ChainValidation(error["nominal"], error["extended"], _floor(noise, den), tuple(per_run),
                           failures=tuple(failed.values()), band=band, records=tuple(records), spanned=tuple(spanned),
                           right=right.get(judged), nominal_right=right.get("nominal") if diagnosis.steps else None,
                           method_bias=bias)


def _departures(rig, fit, sim, meas, drives, drawn_drives, moved, refitted, cfg, top, backend, name, span):
    """How far ``fit``'s replay of a held-out run moves (sums of ``|.|^2`` over the compared twist
    harmonics) along each of its parameters' directions (``moved``, over ``DRAW_STEP^2``: the
    covariance's first-order part), under each of ``drawn_drives`` (their mean: the drive's noise)
    and, given ``refitted``, under its refit on its own replay (the method's bias). Returns
    (parameters' part, drive's part, method's part, each direction's)."""
    ref = _twists(sim, top)
    replays = [(f, drives) for f in moved] + [(fit, d) for d in drawn_drives] + (
        [(refitted, drives)] if refitted is not None else [])

    def departure(item) -> float:
        other, with_drives = item
        try:
            alt, _ = _replayed(rig, other, fit.spec, meas, with_drives, cfg, top, backend, name, span=span)
        except _NoReplay:
            return math.nan
        return float(np.sum(np.abs(_twists(alt, top) - ref) ** 2))

    parts = list(fork_map(departure, replays))  # independent replays, one per core (2x on the worn example)
    by_direction = np.array(parts[:len(moved)]) / DRAW_STEP ** 2
    by_draw = np.array(parts[len(moved):len(moved) + len(drawn_drives)]) / DRAW_STEP ** 2
    p_run = float(np.nansum(by_direction)) if by_direction.size else 0.0
    d_part = float(np.nanmean(by_draw)) if by_draw.size and not np.all(np.isnan(by_draw)) else 0.0
    m_run = parts[-1] if refitted is not None and math.isfinite(parts[-1]) else 0.0
    return p_run, d_part, m_run, by_direction


def fidelity_step_s(omega_rad_s: float) -> float:
    """The rig's largest step (s) when it replays a run of ``omega_rad_s`` to measure the fidelity
    (pure): :data:`identify.defaults.FIDELITY_STEP_SHARE` of the replay step, or as fine as
    :data:`identify.defaults.MAX_REPLAY_STEPS_PER_PERIOD` steps a period allow, never coarser
    than the replay step (a slow axis's period of seconds keeps it)."""
    period_s = 2 * math.pi / omega_rad_s
    return max(FIDELITY_STEP_SHARE * REPLAY_MAX_STEP_S, min(REPLAY_MAX_STEP_S, period_s / MAX_REPLAY_STEPS_PER_PERIOD))


def rig_replay(rig: ChainRig, runs: Sequence, band: int, *, backend: str = "auto", max_wall_s: float = 20.0):
    """``replay(fit)``: the fitted model's noise-free records in ``rig`` under each prepared run's
    measured drive (harmonics 1..band of its period average), at the run's own samples per
    period, read through the model's channels and prepared as the runs were
    (:func:`identify.chain_diagnose.prepare_chain_runs`); or why it could not be replayed (the
    fixed floor then stands in). The diagnosis measures the balance's fidelity on them
    (:class:`identify.chain_diagnose.BalanceFidelity`). A replay that has not settled in
    ``max_wall_s`` seconds of a run is given up: a fidelity is not worth a long wait (that run's
    replay is None, its rows borrow the replayed runs' misfit, :meth:`BalanceFidelity.borrowed`;
    every run's: why, :class:`studies.notes.NoReplay` per run). Settled to 1e-7 of
    each channel's swing: a variance estimate, at most 80 dB below the signal, needs no more. The
    rig steps at :func:`fidelity_step_s`: at the replay step its own error at a stick-slip kink
    outweighs the balance's misfit."""
    from jointrig.identify.chain_diagnose import prepare_chain_runs

    def replay(fit):
        plant, J = plant_and_inertias(fit)
        bad = tuple((i, float(v)) for i, v in enumerate(J, start=1) if not (math.isfinite(v) and v > 0))
        if bad:
            return (NoReplay("", "", NO_INERTIA, inertias=bad),)
        constants = constant_loads(fit.as_dict(), fit.spec)
        out, why = [], []
        for run in runs:
            rec = run.average
            drives = {i + 1: drive_of_record(rec.omega_rad_s, fourier_coefficients(t, 1, band))
                      for i, t in enumerate(rec.torques_Nm) if t is not None}
            cfg = SimulationConfig(samples_per_period=int(min(max(run.samples_per_period, 8 * band), 2048)),
                                   max_step_s=fidelity_step_s(rec.omega_rad_s), n_periods=2,
                                   absolute_angles_periodic=False,
                                   max_wall_s=max_wall_s,
                                   settle_tol=1e-7)
            def once(held, rec=rec, drives=drives, cfg=cfg):
                return simulate_chain(rig.with_plant(plant), rec.omega_rad_s, drives, cfg, inertias_kgm2=J,
                                      backend=backend, start=start_of(rec, band, fit.spec.offsets_rad),
                                      loads_Nm=held)[0]
            try:
                sim, used = without_drift(once, held_means(fit, rec), drifting_bodies(fit), _drive_scale(rec))
            except SimulationError as err:
                out.append(None)
                why.append(NoReplay("", rec.source, DIVERGED, err.warnings) if isinstance(err, Diverged)
                           else NoReplay("", rec.source, NO_STEADY_STATE, str(err)))
                continue
            if any(constants):  # the cell's mean, which the drive dropped: the load held plus the constant
                sim = replace(sim, torques_Nm=tuple(t + u + k if t is not None and k else t
                                                    for t, u, k in zip(sim.torques_Nm, used, constants)))
            out.append(prepare_chain_runs([channel_corrected(sim, fit.spec, read=True)], band=band)[0])
        if all(r is None for r in out):
            return tuple(why)
        return out

    return replay


#: Diagnoses with a measured fidelity after the first (with the fixed floor): each measures the
#: fidelity on the replay of the model the one before adopted, until the adopted kind of model
#: repeats (two sufficed on every bench: the floor's model, then its own fidelity's).
FIDELITY_PASSES = 2

#: Why a chi-square cannot test a model (:func:`measured_diagnosis`'s ``exact``): records without
#: noise (the rig's own), or a noise estimate of two periods.
NOISE_FREE, TWO_PERIODS = "noise-free", "two periods"


def noise_free(runs: Sequence) -> bool:
    """Whether every channel of every run has a noise per sample below :data:`RIG_FIDELITY` of its
    swing (RMS about its mean) (pure): records a simulator wrote without noise."""
    for run in runs:
        a = run.average
        channels = {f"phi{i}": x for i, x in enumerate(a.angles_rad, start=1) if x is not None}
        channels.update({f"torque{i}": x for i, x in enumerate(a.torques_Nm, start=1) if x is not None})
        for ch, x in channels.items():
            rms = float(np.std(x))
            if rms > 0 and run.noise_std.get(ch, 0.0) > RIG_FIDELITY * rms:
                return False
    return True


def measured_diagnosis(diagnosed, replay, say=lambda msg: None, exact: Optional[str] = None) -> tuple:
    """The diagnosis whose fidelity is its own model's: first with the fixed floor
    (:data:`identify.defaults.DEFAULT_FIDELITY`), then again with the balance's misfit measured on
    the noise-free replay of the model it adopted (:func:`identify.chain_diagnose.balance_fidelity`;
    one table for every model compared, so their chi-squares stay comparable), until the kind of
    model adopted repeats (at most :data:`FIDELITY_PASSES` more). Where the measured fidelity leaves
    even the best model above the verdict's chi2/dof bound, the records hold a misfit that neither
    the noise nor the method explains: that diagnosis stands, and its verdict says so (the fixed
    floor would hide the misfit and inflate every standard error), unless the records are
    noise-free (``exact`` :data:`NOISE_FREE`, :func:`noise_free`: the rig's own, where the misfit is
    the integrators' difference) or their chi-square cannot test a model (``exact``
    :data:`TWO_PERIODS`: a noise estimate of two periods); the fixed floor's diagnosis stands then.
    Where the passes return to a kind of model whose own fidelity led elsewhere (one model's
    fidelity adopts another, whose fidelity adopts the first), no model is adopted under its own
    fidelity: the last diagnosis stands with a :class:`studies.notes.FidelityCycle` note, which
    makes the verdict unexplained. ``diagnosed(fidelity)`` runs one
    diagnosis; ``replay(fit)`` is :func:`rig_replay`'s. Returns the diagnosis and notes (why the
    fidelity stayed fixed, if it did: :class:`studies.notes.FixedFidelity`; a cycle)."""
    from jointrig.identify.chain_diagnose import balance_fidelity, model_kind

    d = diagnosed(DEFAULT_FIDELITY)
    led = {}  # a kind of model whose own fidelity was measured -> its causes in words
    for _ in range(FIDELITY_PASSES):
        label = " + ".join(s.label for s in d.steps) or "the nominal model"
        say(f"measuring the balance's fidelity on the noise-free replay of {label}")
        got = replay(d.final)
        if isinstance(got, tuple):  # why no run could be replayed
            return d, (FixedFidelity(DEFAULT_FIDELITY, label, failure=got),)
        fid = balance_fidelity(got, d.final, d.n_harmonics, d.masked, d.merging, label)
        again = diagnosed(fid)
        if exact and again.reduced_chi2(again.final) > CHI2_PER_DOF_OK:
            # records without noise (the rig's own, written at another step): the measured fidelity
            # reads the two integrators' difference as a misfit of every model; or a noise estimate
            # of two periods (one degree of freedom per line and part), whose weights give a
            # chi-square without a finite expectation: it cannot test a model
            return d, (FixedFidelity(DEFAULT_FIDELITY, label, measured=fid.relative,
                                     chi2_per_dof=again.reduced_chi2(again.final),
                                     noise_free_below=RIG_FIDELITY if exact == NOISE_FREE else None,
                                     two_periods=exact == TWO_PERIODS),)
        kind, now = model_kind(d.final.spec), model_kind(again.final.spec)
        led[kind] = label
        d = again
        if now == kind:
            break
        if now in led:  # back to a model whose own fidelity adopted another
            return d, (FidelityCycle(led[now], label),)
    return d, ()


# --------------------------------------------------------------------------------------------
# A measured drive train, diagnosed and validated (``jointrig diagnose TRAIN_FILE``)


def train_verdict(diagnosis: ChainDiagnosis, validation: Optional[ChainValidation], *,
                  held_out_periods: bool = False) -> Verdict:
    """The verdict of a train's diagnosis (:func:`identify.verdict.judge`, the two flywheels' too),
    errors against what a right model misses on the held-out twists (pure); ``held_out_periods``: the held
    out data are each run's later periods."""
    d, v = diagnosis, validation
    f = d.final if d.steps else d.nominal
    causes = tuple(s.label for s in d.steps)
    if v is None or not math.isfinite(v.extended_error):
        return Verdict("unexplained", Grounds.UNCHECKED, causes, later_periods=held_out_periods,
                       unchecked=v.failures if v is not None else ())
    c2 = f.chi2 / max(f.dof, 1)
    err = v.extended_error if d.steps else v.nominal_error
    right = v.expected_error
    ratio = err / right if right > 0 else math.inf
    lost = ()
    if math.isinf(v.nominal_error):  # the nominal model failed where the extension did not
        lost = tuple(lab for lab, nom, *_ in v.per_run if not math.isfinite(nom))
    own = v.nominal_right if d.steps and v.nominal_right is not None else v.right
    nominal = (v.nominal_error / own.relative if own is not None and own.relative > 0 and math.isfinite(v.nominal_error)
               else math.nan)
    return judge(causes, c2, ratio, nominal, v.bound, later_periods=held_out_periods, nominal_lost=lost,
                 nominal_bound=own.bound if own is not None else v.bound, gain=v.gain)


#: The forms a bench's runs come in (:attr:`TrainReport.form`).
FORMS = ("train", "relative")


@dataclass(frozen=True)
class TrainReport:
    """A measured train's diagnosis: the fit runs' diagnosis, the held-out runs' validation in
    the rig, the verdict, and the user's model as written (``(name, value)`` pairs; empty
    without ``--model``)."""

    run_ids: tuple
    held_out: tuple
    diagnosis: ChainDiagnosis
    validation: Optional[ChainValidation]
    verdict: Verdict
    #: what the held-out data ask of the model (:class:`studies.holdout.Generalisation`)
    generalisation: Generalisation
    written: tuple = ()
    model_path: Optional[str] = None
    #: what the diagnosis notes about the data and how it treated them (:mod:`studies.notes`; in
    #: words: :func:`present.notes.note_text`)
    notes: tuple = ()
    #: the held-out data are each run's later periods (fewer than 4 runs), not whole runs
    held_out_periods: bool = False
    #: how the bodies move: on hinges (rad, N m, kg m^2) or slides (m, N, kg)
    kind: Coordinate = HINGE
    #: per run, its setting (:func:`train_setting`: omega rad/s, the largest drive's amplitude)
    settings: tuple = ()
    #: where an unexplained misfit is and what it looks like, the nominal model's
    #: (:class:`identify.chain_diagnose.TrainMisfit`; None unless unexplained)
    misfit: Optional[object] = None
    #: :data:`FORMS`: "train" (every body's position measured) or "relative" (the relative angle
    #: alone: the joint's twist as one body tied to the frame by the joint's law)
    form: str = "train"
    #: each channel's mean over the fitted runs, the angles' taken out before the diagnosis
    #: (:class:`identify.zeros.SensorZeros`; None where not read)
    zeros: Optional[SensorZeros] = None
    #: ``(joint, mean torque N m (N on a slide), standard error, per fitted run)`` per joint whose
    #: twist's zero the data determine (:func:`identify.chain_diagnose.mean_joint_torque` over the
    #: fitted runs, the adopted model's): what a mean load passes through it, which the replays hold
    preloads: tuple = ()

    @property
    def adopted(self) -> bool:
        return self.verdict.verdict == "explained"

    @property
    def adopted_fit(self):
        """The extended fit if adopted, else the nominal one."""
        return self.diagnosis.final if self.adopted else self.diagnosis.nominal


def written_of(rig: ChainRig) -> tuple:
    """A chain model's parameters as its file writes them, ``(name, value)``: the inertias, then
    every joint's law and the bearings (the names of the diagnosis's fits)."""
    return (tuple((inertia_name(i), J) for i, J in enumerate(rig.inertias_kgm2, start=1))
            + tuple(rig.plant.parameters().items()))


def periods_of(rec: ChainRecord, lo: int, hi: int, label: str = "") -> ChainRecord:
    """Whole periods ``lo..hi - 1`` (0-based) of a run, its source labelled (pure)."""
    n = rec.samples_per_period
    cut = slice(lo * n, hi * n)
    pick = (lambda xs: None if xs is None else tuple(None if x is None else x[cut] for x in xs))
    return replace(rec, time_s=rec.time_s[cut], torques_Nm=pick(rec.torques_Nm), angles_rad=pick(rec.angles_rad),
                   rates_rad_s=pick(rec.rates_rad_s), n_periods=hi - lo,
                   source=f"{rec.source} ({label})" if label else rec.source)


def split_chain_periods(rec: ChainRecord) -> tuple[ChainRecord, ChainRecord]:
    """A train's run as its earlier and its later whole periods (half each, the fit at least two;
    the later half gets the odd one), to fit on one and validate on the other when there are too
    few runs to hold one out (pure)."""
    P, k = rec.n_periods, max(2, rec.n_periods // 2)
    return periods_of(rec, 0, k, f"periods 1-{k}"), periods_of(rec, k, P, f"periods {k + 1}-{P}")


#: The band in which a drive's lines are counted for its kind (a sine, or several lines).
SETTING_BAND = 20


def train_setting(rec: ChainRecord) -> tuple[float, float, int]:
    """A train run's setting for :func:`holdout_of_another_kind`: (omega rad/s, the largest drive's
    fundamental amplitude N m, its lines 2..:data:`SETTING_BAND` that stand out of the noise:
    0 for a sine, more for a multisine). With one period, no noise is estimated and no line
    counted."""
    drives = [t for t in rec.torques_Nm if t is not None]
    amp = [float(abs(fourier_coefficients(t, rec.n_periods, 1)[1])) for t in drives]
    k = int(np.argmax(amp))
    lines = 0
    if rec.n_periods >= 2:
        _, mean, var = pooled_period_spectra(drives[k], rec.n_periods)
        top = min(SETTING_BAND, mean.size - 1)
        lines = int(np.count_nonzero(np.abs(mean[2:top + 1]) > RESOLVED_SIGMA * np.sqrt(var[2:top + 1])))
    return rec.omega_rad_s, amp[k], lines


def _refitted(replay, fit, d: ChainDiagnosis):
    """``fit``'s structure refitted on its own noise-free replay of the fitted runs
    (:func:`identify.chain_diagnose.refit_on_replay`), or why not (:class:`studies.notes.BiasUnmeasured`)."""
    from jointrig.identify.chain_diagnose import refit_on_replay

    got = replay(fit)
    if isinstance(got, tuple):
        return BiasUnmeasured(failures=got)
    return refit_on_replay(got, fit, d.n_harmonics, d.masked, d.merging)


def run_train_diagnosis(records: Sequence[ChainRecord], *, run_ids: Sequence[str], rig: ChainRig,
                        holdout: Optional[Sequence[int]] = None, written: Sequence[tuple] = (),
                        band: int = 20, alpha: float = DEFAULT_ALPHA, fidelity: Optional[float] = None,
                        progress=None, backend: str = "auto", form: str = "train",
                        max_causes: int = DEFAULT_MAX_CAUSES, zeroed: bool = False) -> TrainReport:
    """Diagnose a measured train on the runs not held out, and replay the held-out runs' drives on
    the nominal and the extended model in ``rig`` (its bodies and drives; the user's model, or
    one written for the file's bodies and drives). ``holdout``: run indices (default: runs of
    another kind, :func:`holdout_of_another_kind`). ``form``: the runs' form (:data:`FORMS`):
    without a written model, a "relative" one is fitted with the joint's law to the frame
    (:func:`identify.chain_diagnose.nominal_spec` with ``twist``), and the report says "joint".
    ``fidelity``: None measures the balance's fidelity on the adopted model's replay in ``rig``
    (:func:`measured_diagnosis`); a number fixes it relative to each run's largest balanced torque.
    ``max_causes``: the most causes adopted (the evidence decides below it). ``zeroed``: the
    encoders were zeroed together, so their zeros are kept; otherwise every angle channel is taken
    about its mean over the fitted runs first (:mod:`identify.zeros`), and the report says what
    each twist reads at rest."""
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}, got {form!r}")
    from jointrig.identify.chain_diagnose import (diagnose_chain, mean_joint_torque, nominal_spec, prepare_chain_runs,
                                                  train_misfit, zero_resolved)
    from jointrig.identify.defaults import DEFAULT_FIDELITY

    records = list(records)
    notes = []
    settings = [train_setting(r) for r in records]
    split = holdout is None and len(records) < MIN_RUNS_TO_HOLD_OUT + 1
    if split:  # one long run (or a few): each one's later periods are held out
        short = [f"{rid} ({r.n_periods})" for rid, r in zip(run_ids, records) if r.n_periods < MIN_PERIODS_TO_SPLIT]
        if short:
            raise RecordError(f"run(s) {', '.join(short)} hold fewer than {MIN_PERIODS_TO_SPLIT} steady whole periods: "
                              f"with fewer than {MIN_RUNS_TO_HOLD_OUT + 1} runs the diagnosis fits each run's earlier "
                              f"periods and holds out the later ones. Record at least {MIN_PERIODS_TO_SPLIT} periods "
                              f"after the transient, or give a separate validation record (--validate OTHER)")
        halves = [split_chain_periods(r) for r in records]
        fit_recs, held_recs = [a for a, _ in halves], [b for _, b in halves]
        held = ()
    else:
        held = tuple(sorted(holdout)) if holdout is not None else holdout_of_another_kind(settings)
        fit_recs = [r for i, r in enumerate(records) if i not in held]
        held_recs = [r for i, r in enumerate(records) if i in held]
    zeros = sensor_zeros(fit_recs, keep=zeroed)
    fit_recs, held_recs = [rezeroed(r, zeros) for r in fit_recs], [rezeroed(r, zeros) for r in held_recs]
    records = [rezeroed(r, zeros) for r in records]
    say = progress or (lambda msg: None)
    say(f"diagnosing {len(fit_recs)} runs of a {rig.n_flywheels}-body train; {len(held_recs)} held out for validation")
    top = min(max_harmonic(r.samples_per_period) for r in records)
    if top < band:
        worst = min(range(len(records)), key=lambda i: records[i].samples_per_period)
        notes.append(BandCut(top, band, run_ids[worst], records[worst].samples_per_period))
        band = top
    runs = prepare_chain_runs(fit_recs, band=band)
    nominal = rig.plant.spec() if written else (nominal_spec(1, twist=True) if form == "relative" else None)
    def diagnosed(fid):
        return diagnose_chain(runs, n_harmonics=band, alpha=alpha, nominal=nominal, max_effects=max_causes,
                              fidelity=fid, progress=lambda k, n, label: say(f"scored {k}/{n} candidates ({label})")
                              if k == n else None)

    replay = rig_replay(rig, runs, band, backend=backend)
    if fidelity is not None:
        d = diagnosed(fidelity)
    else:
        few = min(r.n_periods for r in runs) <= 2
        d, why = measured_diagnosis(diagnosed, replay, say, exact=NOISE_FREE if noise_free(runs) else
                                    TWO_PERIODS if few else None)
        notes += list(why)
    fit_ids = run_ids if split else [run_ids[i] for i in range(len(records)) if i not in held]
    for k, body, rest, masked in d.rests:
        notes.append(BodyRests(fit_ids[k], body, rest, masked, REST_RATE_FRACTION, STICK_RATE_FRACTION))
    for k, joint, rest, resolved, left_out in d.stuck_joints:
        notes.append(JointSticks(fit_ids[k], joint, rest, resolved, left_out, REST_RATE_FRACTION, STICK_RATE_FRACTION))
    say("replaying the held-out runs' drives on the nominal and the extended model in the rig")
    v = validate_chain(rig, d, held_recs, backend=backend, noise_std=d.noise_std, alpha=alpha,
                       refit=lambda fit: _refitted(replay, fit, d))
    if split:
        general = Generalisation(later_periods=tuple(r.n_periods for r in held_recs), runs=len(records))
    else:
        general = generalisation_kind([settings[i] for i in range(len(records)) if i not in held],
                                      [settings[i] for i in held])
    verdict = train_verdict(d, v, held_out_periods=split)
    for cycle in (n for n in notes if isinstance(n, FidelityCycle)):
        verdict = unsettled(verdict, cycle.one, cycle.other)
    free = drifting_bodies(d.final if d.steps else d.nominal)
    if free:
        notes.append(NoSpringToFrame(tuple(i + 1 for i in free)))
    notes += list(v.spanned)
    misfit = None
    if verdict.verdict == "unexplained":
        say("describing the misfit: the residual torque at every joint along every run's measured motion")
        # of the model the verdict keeps (the nominal one): the whole misfit, none of it taken up by
        # a rejected cause
        misfit = train_misfit(prepare_chain_runs(records, band=band), run_ids, [s[1] for s in settings],
                              d.nominal, band, rig.kind)
    kept = d.final if verdict.verdict == "explained" else d.nominal
    preloads = tuple((j, *mean_joint_torque(kept, [r.average for r in runs], j),
                      tuple(mean_joint_torque(kept, [r.average], j)[0] for r in runs))
                     for j in range(1, kept.spec.n_flywheels) if form != "relative" and zero_resolved(kept, j))
    return TrainReport(tuple(run_ids), held, d, v, verdict, general, tuple(written),
                       str(rig.path) if written else None, tuple(notes), split, rig.kind, tuple(settings), misfit,
                       form, zeros, preloads)
