"""Which joint of a drive train is worn, and how: the diagnosis of a chain.

The one diagnosis of every bench: two flywheels (the train of two bodies), a train of up to
eight, a single axis, and the relative angle alone (its twist as one body tied to the frame). It
asks which cause explains a misfit, and *where*. Every catalogued joint cause
(:func:`identify.causes.at`) is scored at every joint (and at a body tied to the frame by an
elastic law), bearing drag at every flywheel:

1. **Prepare** (:func:`prepare_chain_runs`): average each run's P periods in the frequency
   domain, keep harmonics 0..band of every channel and resynthesise the mean period and each
   period on :data:`identify.kink.FINE_SAMPLES` samples (the law columns of a jump or a
   kink alias 16 times less there); rates are exact spectral derivatives of the band.
2. **Weights**: every harmonic-balance row's noise variance is the period-to-period variance
   of its residual at the current parameters, over P (cosine and sine rows of one harmonic of
   one flywheel's equation pooled), plus the model-fidelity floor ``(fidelity * size)^2`` with
   ``size`` the run's largest balanced term; chi-square is corrected for the estimated weights
   as in the two-flywheel case (``E[chi2] = dof nu / (nu - 2)``, ``nu = 2 (P - 1)``). The
   standard errors also carry the covariances between neighbouring equations' rows that the
   diagonal weights leave out (:meth:`_Problem.cross_covariance`).
3. **Nominal fit**: all inertias and every joint's ``c phi' + k phi + gamma phi^3`` (paper eq.
   11) by weighted least squares on the banded system (:func:`identify.chain.solve_banded`);
   the mean (harmonic 0) is not balanced (a sensor's zero is arbitrary).
4. **Candidates**: (cause, joint) and (bearing drag, flywheel). Evidence is the chi-square
   drop D; a candidate is significant when D exceeds the chi-square(q) quantile at
   ``alpha / n_candidates`` (Bonferroni over every cause at every place) and its BIC score
   ``D - q ln(n_rows)`` is positive; causes with one nonlinear parameter are profiled. A
   friction or damping fitted negative, a slip angle or free play below the angle resolution
   (then it is dry friction, or nothing; a free play the whole fit resolves stands) and a
   Stribeck rate above every run's rate are rejected with the reason.
5. **Extension**: the best significant candidate is adopted, the weights re-estimated, and
   the rest scored again on top of it, until nothing significant is left. A rival at another
   place that neither needs the other nor is needed by it (both ways not significant) makes
   the two *places* ambiguous: :func:`separating_drive` then says, from the Fisher
   information of each drive location, which drive would tell them apart.

Dry friction balanced over a whole period is wrong where it sticks, and its kinks lie above the
band where it slides through rest. A body that may stick to ground has its equation masked where
it rests (:func:`identify.chain.stick_mask`); the joint that may stick
(:func:`_joints_that_may_stick`) has its two bodies' equations summed in the runs where it may be
stuck (its torque cancels there), and one of them balanced on its own where the joint slides (a
joint that sticks most of the cycle is fitted there); elsewhere a friction's kinks are restored at the fitted size
(:meth:`_Problem.solve`). Which rows are masked or summed is fixed for the whole diagnosis, so
every chi-square compared is of the same rows.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from types import SimpleNamespace
from typing import Optional, Sequence

import numpy as np

from jointrig.vocab.law import Constant, JointLaw, Power, Viscous, law_parameters
from jointrig.vocab.params import ANGLE2_DELAY, ANGLE2_GAIN, DRIVE_DELAY, HINGE, Coordinate, channel_name
from .chain import (ChainIdentifiabilityError, ChainPlant, ChainRecord, ChainSpec, bearing_name, chain_system, channel_corrected,
                    masked_noise_covariance, noise_cross_covariance,
                    ground_laws, ground_prefix, identifiability, inertia_name, joint_prefix, solve_banded, rest_share,
                    rests, stick_mask, sticks_to_ground, jumps_at_rest)
from .causes import (CATALOGUE, Ambiguity, Cause, CauseScore, FeedsEnergy, Limits, ModelSpec, Place, Rejection,
                     Unphysical, at, by_name, effective_dof,
                     detection_limit, evidence, forward_select,
                     fundamental_quadrature, harmonic_shares, joint_minimum, on_search_bound, parsimonious, profile,
                     resolved, widened)
from .defaults import DEFAULT_ALPHA, DEFAULT_FIDELITY
from .kink import FINE_SAMPLES, KINK_RTOL, kink_corrected_rate, kink_first_pass, switch_shifts
from .balance import harmonic_rows
from .harmonics import max_harmonic
from .periods import period_spectra, raw_noise_std
from jointrig.vocab.records import RecordError, SteadyStateRecord
from .estimates import RowFit, satterthwaite, weighted_chi2
from .solve import IllConditionedWarning

__all__ = ["ChainRun", "prepare_chain_runs", "ChainFit", "ProfiledSpread", "Candidate", "CauseScore", "ChainDiagnosis",
           "diagnose_chain", "JOINT_CAUSES", "nominal_spec", "plant_and_inertias", "separating_drive",
           "drive_information", "zero_resolved", "mean_joint_torque"]

#: The catalogue's causes that live in a joint (scored at every joint); bearing drag is scored
#: at every flywheel; an angle's zero at a joint is its twist's offset; the drives' lag is scored
#: once (:data:`DRIVE_CAUSES`), each angle channel's skew and scale at bodies 2..N
#: (:data:`CHANNEL_CAUSES`).
JOINT_CAUSES: tuple[Cause, ...] = at("joint")
_BEARING = by_name("bearing_friction")

#: The causes scored in a single body's law to ground: a guide's friction, a motor's cogging.
GROUND_CAUSES: tuple[Cause, ...] = at("ground")
#: The causes of the drives' channels, scored once: their lag behind the record.
DRIVE_CAUSES: tuple[Cause, ...] = at("drive")
#: The causes of body 2..N's angle channel (against the drive's and body 1's): its skew and scale.
CHANNEL_CAUSES: tuple[Cause, ...] = at("channel")
#: On a train of two or more bodies no friction to ground is scored yet (viscous bearing drag
#: is). The independent bench's Stribeck joint 3 (its law shaped unlike the project's) drew a
#: second cause at the next body: Stribeck friction to ground (p < 1e-3 after Bonferroni over 40
#: candidates; that model found no steady state in the rig), or with dry friction to ground
#: alone, that (gain 10.9 against 12.5 without it). A wrong name beside the right one.
TRAIN_GROUND_CAUSES: tuple[str, ...] = ()


#: The paper's joint law (eq. 11), ``c phi' + k phi + gamma phi^3``: every joint's nominal one.
PAPER_LAW = (Viscous(), Power(1), Power(3))


def nominal_spec(n_flywheels: int, twist: bool = False) -> ChainSpec:
    """Every joint the paper's law (:data:`PAPER_LAW`), no bearings; a single body (N = 1) its
    mass and a viscous drag to ground (the one law it surely has), or with ``twist`` (the
    relative-angle form: the joint's twist as one body) the paper's law to the frame."""
    if n_flywheels == 1:
        return ChainSpec((), grounds=(PAPER_LAW,)) if twist else ChainSpec((), bearings=(1,))
    if twist:
        raise ValueError("nominal_spec: the relative-angle form is one body")
    return ChainSpec((PAPER_LAW,) * (n_flywheels - 1))


# --------------------------------------------------------------------------------------------
# 1. Preparation


@dataclass(frozen=True)
class ChainRun:
    """One run after averaging and band-limiting (see the module docstring).

    Attributes:
      average: the mean period, harmonics 0..band, on FINE_SAMPLES samples.
      periods: each period alike (their spread gives every row's noise).
      noise_std: channel ("phi<i>", "torque<i>") -> noise standard deviation of one raw sample.
      samples_per_period: of the raw record.
    """

    average: ChainRecord
    periods: tuple
    noise_std: dict
    samples_per_period: int
    #: harmonics 0..band kept (the band-limiting a kink correction restores above)
    band: int = 20

    @property
    def n_periods(self) -> int:
        return len(self.periods)


def prepare_chain_runs(records: Sequence[ChainRecord], *, band: int = 20) -> list[ChainRun]:
    """Average, estimate the noise and band-limit every record.

    Raises:
      RecordError: fewer than 2 periods, or too few samples per period for the band.
      ChainIdentifiabilityError: an angle a joint needs is not measured, or no drive torque.
    """
    out = []
    for rec in records:
        P, N = rec.n_periods, rec.samples_per_period
        if P < 2:
            raise RecordError(f"{rec.source}: {P} period(s); the diagnosis needs at least 2 to estimate the noise "
                              f"from period-to-period variation")
        if band > max_harmonic(N):
            raise RecordError(f"{rec.source}: {N} samples per period hold at most {max_harmonic(N)} harmonics; the "
                              f"diagnosis band is {band}")
        why = identifiability(rec.n_flywheels, rec.measured, rec.driven)
        if why:
            raise ChainIdentifiabilityError(f"{rec.source}: " + "; ".join(why))
        Nf = FINE_SAMPLES
        keep = np.arange(N // 2 + 1) <= band
        noise = {}

        def split(x, name):
            X, mean, var = period_spectra(x, P)
            noise[name] = raw_noise_std(var, P, N)
            return (np.fft.irfft(np.where(keep, mean, 0) * Nf, n=Nf),
                    np.fft.irfft(np.where(keep, X, 0) * Nf, n=Nf, axis=1))

        angles = [split(a, f"phi{i}") for i, a in enumerate(rec.angles_rad, start=1)]
        torques = [split(t, f"torque{i}") if t is not None else None for i, t in enumerate(rec.torques_Nm, start=1)]
        tf = rec.time_s[0] + np.arange(Nf) * (2 * math.pi / rec.omega_rad_s) / Nf

        def make(pick, label):
            return ChainRecord(rec.omega_rad_s, tf, [pick(t) if t is not None else None for t in torques],
                               [pick(a) for a in angles], None, 1, rec.drive_amplitude_Nm,
                               source=f"{rec.source} {label}")

        out.append(ChainRun(make(lambda c: c[0], "(period average, band-limited)"),
                            tuple(make(lambda c, p=p: c[1][p], f"(period {p + 1}, band-limited)") for p in range(P)),
                            noise, N, band))
    return out


# --------------------------------------------------------------------------------------------
# 2. Fits


@dataclass(frozen=True)
class ProfiledSpread:
    """The profiled parameters' uncertainty beside the linear values' (:func:`_widened`), for a
    quantity that depends on both (a joint card's model rows: :func:`place_uncertainty`).
    ``below`` and ``above`` are the fit's structure (:class:`ChainSpec`) with each parameter
    ``steps`` below and above its value; ``cross`` ``(values, m)`` is the values' covariance with
    the parameters, ``G S`` (``G`` the fit's slopes along them, :attr:`identify.causes.Profiled.slope`),
    ``covariance`` ``(m, m)`` theirs, ``S``."""

    names: tuple
    steps: tuple
    below: tuple
    above: tuple
    cross: np.ndarray = field(repr=False)
    covariance: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class ChainFit(RowFit):
    """A weighted least-squares fit of one chain structure (chi-square corrected for the weights).

    ``profiled`` holds ``(name, value, standard error)`` of nonlinear parameters found by a
    profile search (a free play, a slip angle, a Stribeck rate), by their chain names.
    """

    spec: ChainSpec
    names: tuple
    values: np.ndarray
    std_errors: np.ndarray
    chi2: float
    n_rows: int
    row_chi2: np.ndarray = field(repr=False)
    profiled: tuple = ()
    #: of the banded solve's equilibrated, weighted regression matrix, and the solver's status
    condition_number: float = math.nan
    success: bool = True
    message: str = "ok"
    #: each row's harmonic (where a cause's improvement lies: :func:`identify.causes.harmonic_shares`)
    row_harmonic: Optional[np.ndarray] = field(default=None, repr=False, compare=False)
    #: covariance of ``values`` (scaled like ``std_errors``), for quantities derived from the fit
    #: (a joint card's model curves, :func:`place_covariance`)
    covariance: Optional[np.ndarray] = field(default=None, repr=False, compare=False)
    #: each row's group of rows that share one variance estimate (a run's harmonic of one
    #: equation: :meth:`_Problem.row_variance`), for a drop's degrees of freedom
    row_group: Optional[np.ndarray] = field(default=None, repr=False, compare=False)
    #: each row's residual ``F - A theta`` at the least-squares values
    residual: Optional[np.ndarray] = field(default=None, repr=False, compare=False)
    #: ``(name, name, correlation)`` of each pair of ``profiled`` parameters whose chi-square
    #: couples them (:func:`_jointly`); a pair not listed is taken as uncorrelated
    profiled_correlation: tuple = ()
    #: each linear parameter's standard error's degrees of freedom (:meth:`_Problem.compensated`;
    #: None: taken as known), for its interval (:meth:`Estimates.interval`)
    std_error_dofs: Optional[np.ndarray] = field(default=None, repr=False, compare=False)
    #: the profiled parameters' covariance with the values (:func:`_widened`), for a joint card
    #: (:func:`place_uncertainty`); None where nothing profiled widened the fit
    profiled_spread: Optional[ProfiledSpread] = field(default=None, repr=False, compare=False)

    def _profiled_std_errors(self) -> dict[str, float]:
        return {n: se for n, _, se in self.profiled}

    def _std_error_dofs(self) -> dict[str, float]:
        if self.std_error_dofs is None:
            return {}
        return dict(zip(self.names, (float(d) for d in self.std_error_dofs)))

    def parameters(self) -> dict[str, float]:
        """Every parameter by its chain name: the linear ones, then what each joint's terms imply
        (free play, slip angles, Stribeck rate: ``Term.derived_parameters``)."""
        out = self.as_dict()
        laws = [(ground_prefix(i), terms) for i, terms in enumerate(self.spec.grounds, start=1)]
        laws += [(joint_prefix(j), terms) for j, terms in enumerate(self.spec.joints, start=1)]
        for pre, terms in laws:
            out.update({pre + k: v for k, v in law_parameters(terms, [out[pre + t.name] for t in terms]).items()})
        for j, terms in enumerate(self.spec.joints, start=1):
            for t in terms:
                if isinstance(t, Power) and t.gap_rad > 0:
                    out[joint_prefix(j) + "backlash_half_gap_rad"] = t.gap_rad
        for j, o in enumerate(self.spec.offsets_rad, start=1):
            if o:
                out[joint_prefix(j) + "angle_offset_rad"] = o
        if self.spec.drive_delay_s:
            out[DRIVE_DELAY] = self.spec.drive_delay_s
        for i, (d, g) in enumerate(zip(self.spec.channel_delays_s, self.spec.channel_gains), start=1):
            if d:
                out[channel_name(i, ANGLE2_DELAY)] = d
            if g:
                out[channel_name(i, ANGLE2_GAIN)] = g
        for name, value, _ in self.profiled:  # a profile's value where the structure holds none (a lag of 0)
            out.setdefault(name, value)
        return out


#: A joint's twist in a run is resolved when the RMS of its band-limited period average exceeds
#: this many times the RMS its noise leaves there. The pump train's coupling held by 8 N m of dry
#: friction the whole period (independent DAQ bench): 0.9-1.3; every twist that moves, stuck part
#: of the period or not, at any joint: 20 or more.
RESOLVED_SNR = 5.0

#: A chosen model's refit under the weights at its own values is kept where the weights at the
#: refit's values read its chi-square within this share (:meth:`_Problem.settled`): a right model
#: settles to 0.3% in one reweighting (the pump train at 10% noise, the independent chain bench);
#: one that misses a sticking joint's friction moves by times (190 to 630 over ten reweightings).
SETTLED_RTOL = 0.05


def twist_resolved(run: ChainRun, j: int) -> bool:
    """Whether joint j's (0-based) twist in ``run`` stands above its noise (:data:`RESOLVED_SNR`):
    the per-sample noise of its two angles, averaged over the run's periods and samples, in the
    band's ``2 band`` real coefficients."""
    a = run.average
    twist = a.angles_rad[j] - a.angles_rad[j + 1]
    noise = math.hypot(run.noise_std[f"phi{j + 1}"], run.noise_std[f"phi{j + 2}"])
    in_band = noise * math.sqrt(2 * run.band / (run.samples_per_period * run.n_periods))
    return bool(np.std(twist) > RESOLVED_SNR * in_band)


@dataclass(frozen=True)
class Jumps:
    """Where dry friction makes an acceleration jump at a reversal (:meth:`_Problem.jumps`):
    ``sizes`` per body (its rate's reversal, to ground: rad/s^2 or m/s^2) then per joint (its
    twist rate's reversal); ``shares`` per joint: body j's part of its joint's jump,
    ``(1/J_j) / (1/J_j + 1/J_j+1)`` (body j+1 takes the rest, with the opposite sign)."""

    sizes: tuple = ()
    shares: tuple = ()

    def __bool__(self) -> bool:
        return any(s > 0 for s in self.sizes)

    def settled(self, other: Optional["Jumps"]) -> bool:
        """Whether every jump is within ``KINK_RTOL`` of ``other``'s."""
        return other is not None and all(abs(a - b) <= KINK_RTOL * a for a, b in zip(self.sizes, other.sizes))


#: The least misfit a measured fidelity allows a row, relative to its run's largest balanced
#: term: the rig's own integration error (RK4 at its replay step; records the rig wrote at another
#: step differ from its replay by about this), below the noise of a harmonic averaged over the
#: periods even at 80 dB (3e-6). Without it, noise-free records of the rig itself (make-data
#: --no-noise) read every model as a misfit of the integrators' difference.
RIG_BALANCE_FLOOR = 1e-6


@dataclass(frozen=True)
class BalanceFidelity:
    """What the harmonic balance misses on noise-free data of a model: the model's own records,
    replayed in the rig under each fitted run's measured drive and balanced exactly as the
    measured runs are, at the model's own parameters (pure data).

    The balance is exact for a smooth law on band-limited motion; a jump or a kink (dry
    friction, free play, sliders) leaves a misfit above the band that the kink correction only
    partly restores, and the rig's integrator adds its own. A row's variance adds this misfit's
    mean square (its harmonic's cosine and sine rows of one equation pooled), so that a right
    model reads chi-square per degree of freedom near 1 whatever the noise.

    Attributes:
      variance: ``(run, harmonic, equation) -> mean square misfit`` (N^2 m^2, N^2 on a slide).
      relative: RMS misfit over RMS balanced torque, every row.
      model: the replayed model's causes in words ("the nominal model" without any).
      unmeasured: the runs (indices among the fitted ones) whose replay reached no steady state
        (a joint stuck at a high frequency creeps under the rig's friction constraint; a damping
        that jumps at contact may keep the rig's fixed step from settling): their
        rows take the measured runs' misfit relative to their size (:meth:`borrowed`), or where
        no measured run has that row, the fixed floor ``floor`` (relative to each run's largest
        balanced term).
      shares: ``(harmonic, equation) -> the largest mean square misfit of a measured run over
        its largest balanced term squared``: what :meth:`borrowed` lends an unmeasured run.
    """

    variance: dict = field(repr=False)
    relative: float
    model: str
    unmeasured: tuple = ()
    floor: float = DEFAULT_FIDELITY
    shares: dict = field(default_factory=dict, repr=False)

    def at(self, run: int, harmonic: int, equation: int) -> float:
        return self.variance.get((run, harmonic, equation), 0.0)

    def borrowed(self, harmonic: int, equation: int, size2: float) -> float:
        """An unmeasured run's misfit at a row: the largest a measured run shows there relative to
        its size, times this run's size squared ``size2``; the fixed floor where none was measured
        there (the same model's balance, measured where it settled, rather than a constant)."""
        share = self.shares.get((harmonic, equation))
        return (share if share is not None else self.floor ** 2) * size2


def model_kind(spec: ChainSpec) -> tuple:
    """What kind of model ``spec`` is, its numbers left out: the kinds of term at every joint and
    to ground (with or without free play), the bearings with a drag, whether the drives lag and
    which channels are read late or scaled."""
    def kinds(terms):
        return tuple((type(t).__name__, getattr(t, "power", None), bool(getattr(t, "gap_rad", 0.0))) for t in terms)

    return (tuple(kinds(t) for t in spec.joints), tuple(kinds(g) for g in spec.grounds), tuple(spec.bearings),
            bool(spec.drive_delay_s), tuple(bool(d) for d in spec.channel_delays_s),
            tuple(bool(g) for g in spec.channel_gains))


#: The fewest degrees of freedom of a row's variance (2 (P - 1)) at which the reported values are
#: compensated for the regressors' noise (:meth:`_Problem.compensated`): four periods.
MIN_COMPENSATED_NU = 6.0


@dataclass(frozen=True)
class _Problem:
    runs: tuple
    n_harmonics: int
    nu: float
    #: the balance's own misfit every row's variance adds: measured (:class:`BalanceFidelity`, one
    #: table for every model the diagnosis compares, so that their chi-squares stay comparable),
    #: or a fixed floor relative to each run's largest balanced term (``--fidelity``)
    fidelity: "float | BalanceFidelity"

    #: per body: True where some model of the diagnosis lets it stick to ground (its nominal law
    #: or a candidate's has dry friction there): that body's equation is balanced with its stick
    #: phases masked out in *every* fit, so the nominal and extended fits' chi-squares are of
    #: the same rows and their difference is evidence (:func:`identify.chain.stick_mask`)
    masked: tuple = ()
    #: per joint: True where it may stick (:func:`_joints_that_may_stick`): in every run where
    #: it may be stuck, its two bodies' equations are balanced as their sum (and one of them where
    #: it slides: :meth:`slipping`), in every fit,
    #: so that chi-squares stay of the same rows (:meth:`merged`;
    #: :func:`identify.chain.chain_system`'s ``merged``)
    merging: tuple = ()
    _masks: dict = field(default_factory=dict, compare=False, repr=False)
    _merged: list = field(default_factory=list, compare=False, repr=False)
    _slips: dict = field(default_factory=dict, compare=False, repr=False)
    #: (run, body i or N + joint j, periods) -> its angles or twist (the average's, or each
    #: period's) and the kink correction's first pass over them
    _first_pass: dict = field(default_factory=dict, compare=False, repr=False)
    def masks(self) -> Optional[list]:
        """Per run, per body: the stick mask of a masked body where it rests in that run (of its
        period-average rate), else None; None when no body rests. The same mask weighs every
        period of a run."""
        if not any(self.masked):
            return None
        if not self._masks:
            self._masks.update({k: tuple(stick_mask(run.average.rate(i)) if on else None
                                         for i, on in enumerate(self.masked)) for k, run in enumerate(self.runs)})
        out = [self._masks[k] for k in range(len(self.runs))]
        return out if any(m is not None for ms in out for m in ms) else None

    def merged(self) -> Optional[list]:
        """Per run, the joints (0-based) that may stick and may be stuck in it: their twist rests
        (of its period-average twist rate, :func:`identify.chain.rests`) or is not resolved above
        its noise (:func:`twist_resolved`: stuck the whole period); None when there is none."""
        if not any(self.merging):
            return None
        if not self._merged:
            out = [tuple(j for j, on in enumerate(self.merging)
                         if on and (rests(run.average.rate(j) - run.average.rate(j + 1)) or not twist_resolved(run, j)))
                   for run in self.runs]
            # a joint stuck the whole period in every run leaves its law nothing to be fitted on
            # (no run where it slides: :meth:`slipping`): balanced as it is
            everywhere = {j for j in set.intersection(*(set(m) for m in out))
                          if not any(twist_resolved(run, j) for run in self.runs)}
            self._merged.append([tuple(j for j in m if j not in everywhere) for m in out])
        out = self._merged[0]
        return out if any(out) else None

    def slipping(self) -> Optional[list]:
        """Per run, per joint: where a merged joint (:meth:`merged`) slides, the stick mask of
        its period-average twist rate (:func:`identify.chain.stick_mask`; one of its bodies' own
        equations is balanced there too, so that a joint that sticks most of the cycle is fitted
        on the rest: :func:`identify.chain.chain_system`'s ``slipping``); None for a joint not
        merged in that run, or stuck the whole period."""
        merged = self.merged()
        if merged is None:
            return None
        if not self._slips:
            for k, (run, js) in enumerate(zip(self.runs, merged)):
                self._slips[k] = tuple(stick_mask(run.average.rate(j) - run.average.rate(j + 1))
                                       if j in js and twist_resolved(run, j) else None
                                       for j in range(len(self.merging)))
        return [self._slips[k] for k in range(len(self.runs))]

    def balanced_runs(self, cand: "Candidate") -> list:
        """The runs that balance the candidate's place on its own: for a joint, those where its
        bodies' equations are not summed (:meth:`merged`); all runs elsewhere."""
        merged = self.merged()
        if merged is None or not cand.at_joint:
            return list(self.runs)
        return [r for r, m in zip(self.runs, merged) if cand.place - 1 not in m] or list(self.runs)

    def jumps(self, spec: ChainSpec, values: Optional[dict]) -> "Jumps":
        """Where dry friction makes an acceleration jump at a reversal, per body then per joint
        (N + N - 1 sizes; 0 where nothing jumps, and everywhere without ``values``).

        A body's (to ground): ``2 F_s / m`` where its rate reverses (F_s the static friction of
        its law to ground at ``values``). A joint j's: ``2 F_s (1/J_j + 1/J_j+1)`` where its twist
        rate reverses, the jump of the twist's acceleration, shared by its bodies as ``1/J``."""
        N = spec.n_flywheels
        if values is None:
            return Jumps((0.0,) * (2 * N - 1))

        def static(terms, prefix) -> float:
            return sum(t.dry_friction(values[prefix + t.name])[0] for t in terms if jumps_at_rest((t,)))

        inverse = [1.0 / m if (m := values.get(inertia_name(i + 1), 0.0)) > 0 else 0.0 for i in range(N)]
        out = [max(2.0 * static(terms, ground_prefix(i + 1)) * inverse[i], 0.0) if sticks_to_ground(spec, i) else 0.0
               for i, terms in enumerate(spec.grounds)]
        out += [max(2.0 * static(terms, joint_prefix(j + 1)) * (inverse[j] + inverse[j + 1]), 0.0)
                for j, terms in enumerate(spec.joints)]
        shares = tuple(inverse[j] / (inverse[j] + inverse[j + 1]) if inverse[j] + inverse[j + 1] > 0 else 0.5
                       for j in range(N - 1))
        return Jumps(tuple(out), shares)

    def _kinked(self, k: int, i: int, jump: float, periods: bool) -> tuple[np.ndarray, np.ndarray]:
        """Run k's rate of body i (``i < N``) or twist rate of joint ``i - N`` (0-based), of its
        average ``(1, M)`` or of each period ``(P, M)``, with the kinks of a jump ``jump`` at its
        reversals restored, and the band-limited rate it corrects
        (:func:`identify.kink.kink_corrected_rate`; its first pass, which does not depend on
        the jump, is kept)."""
        run = self.runs[k]
        key = (k, i, periods)
        if key not in self._first_pass:
            N = run.average.n_flywheels

            def angle(r):
                return r.angles_rad[i] if i < N else r.angles_rad[i - N] - r.angles_rad[i - N + 1]

            x = np.vstack([angle(p) for p in run.periods] if periods else [angle(run.average)])
            self._first_pass[key] = (x, kink_first_pass(x, run.average.omega_rad_s, run.band))
        x, first = self._first_pass[key]
        return kink_corrected_rate(x, run.average.omega_rad_s, run.band, jump, first_pass=first), first.rate_rad_s

    def records(self, jumps: Optional["Jumps"], periods: bool) -> list[list]:
        """Per run: its average (``periods`` False, a list of one) or each of its periods, with the
        kinks of every reversal with a jump (:meth:`jumps`) restored in its rates: a body's that
        slides through rest (unmasked in that run), and a joint's that slides through rest (its
        bodies' equations not summed in that run) in both its bodies' rates, shared as the jump
        is; the prepared records elsewhere, and all of them without ``jumps``."""
        masks, merged = self.masks(), self.merged()
        out = []
        for k, run in enumerate(self.runs):
            recs = list(run.periods) if periods else [run.average]
            N = recs[0].n_flywheels
            rates = {}  # body -> its rates, periods stacked, where a kink is restored

            def add(b, correction, recs=recs):
                rates[b] = (rates[b] if b in rates else np.vstack([r.rate(b) for r in recs])) + correction

            for i, jump in enumerate(jumps.sizes if jumps else ()):
                skip = (masks is not None and masks[k][i] is not None) if i < N else \
                    (merged is not None and i - N in merged[k])
                if jump <= 0 or skip:
                    continue
                kinked, plain = self._kinked(k, i, jump, periods)
                if i < N:
                    add(i, kinked - plain)
                else:  # joint j between bodies j and j+1: each body's rate takes its share
                    j, share = i - N, jumps.shares[i - N]
                    add(j, (kinked - plain) * share)
                    add(j + 1, -(kinked - plain) * (1.0 - share))
            out.append([replace(r, rates_rad_s=tuple(rates[b][n] if b in rates else r.rates_rad_s[b] for b in range(N)))
                        for n, r in enumerate(recs)] if rates else recs)
        return out

    def system(self, spec: ChainSpec, jumps: Optional[Jumps] = None):
        return chain_system([r[0] for r in self.records(jumps, periods=False)], spec, n_harmonics=self.n_harmonics,
                            first_harmonic=1, masks=self.masks(), merged=self.merged(), slipping=self.slipping())

    def period_systems(self, spec: ChainSpec, like, jumps: Optional[Jumps] = None):
        """Per run: ``(rows, A, F, h, e)``, each period's balance of that run in the stacked
        system's row order (``rows``, its rows in ``like.system``): ``A (P, m, p)``, ``F (P, m)``,
        each row's harmonic ``h`` and equation ``e``."""
        sysl = like.system
        masks, merged, slips = self.masks(), self.merged(), self.slipping()
        recs = self.records(jumps, periods=True)
        for i in range(len(self.runs)):
            As, Fs = [], []
            for per in recs[i]:
                s = chain_system([per], spec, n_harmonics=self.n_harmonics, first_harmonic=1,
                                 masks=None if masks is None else [masks[i]],
                                 merged=None if merged is None else [merged[i]],
                                 slipping=None if slips is None else [slips[i]]).system
                As.append(s.A)
                Fs.append(s.F)
            rows = np.flatnonzero(sysl.row_record == i)
            # The single-run system lists the rows of each equation in the same order as the
            # stacked one lists this run's rows of that equation.
            order = np.empty(rows.size, dtype=int)
            for eq in np.unique(s.row_equation):
                order[np.flatnonzero(s.row_equation == eq)] = rows[sysl.row_equation[rows] == eq]
            yield order, np.array(As), np.array(Fs), s.row_harmonic, s.row_equation

    def switched(self, spec: ChainSpec, like, jumps: Optional[Jumps], periods: list) -> list:
        """``periods`` (:meth:`period_systems`) with every column that jumps at zero rate (dry
        friction's, a Stribeck law's) taken as the average's, its switches moved by each period's
        first-order shift (:func:`identify.kink.switch_shifts`): what that column's noise does to
        the average's balance, which each period's own ``sign(rate)``, crossing zero several times
        near a reversal, does not show. In each equation the shift is weighted as its bodies are
        (a summed joint's cancels, a stick mask is read at the switch)."""
        names = list(like.system.names)
        places = [(j, names.index(joint_prefix(j + 1) + t.name), {j: 1.0, j + 1: -1.0}, t)
                  for j, terms in enumerate(spec.joints) for t in terms if jumps_at_rest((t,))]
        places += [(i, names.index(ground_prefix(i + 1) + t.name), {i: 1.0}, t)
                   for i, terms in enumerate(spec.grounds) for t in terms if jumps_at_rest((t,))]
        if not places:
            return periods
        averages, each = self.records(jumps, periods=False), self.records(jumps, periods=True)
        zero = np.zeros(1)
        jumps_of = [float(t(zero, zero + 1e-12)[0] - t(zero, zero - 1e-12)[0]) for *_, t in places]
        cols = sorted({c for _, c, _, _ in places})
        H = self.n_harmonics
        out = []
        for k, (rows, As, Fs, h, e) in enumerate(periods):
            if As.shape[0] < 2:
                out.append((rows, As, Fs, h, e))
                continue
            avg = channel_corrected(averages[k][0], spec)
            pers = [channel_corrected(r, spec) for r in each[k]]
            A = As.copy()
            A[:, :, cols] = like.system.A[rows][:, cols]
            for (at, c, signs, _), jump in zip(places, jumps_of):
                rate = (lambda r: r.relative(at)[1]) if len(signs) == 2 else (lambda r: r.rate(at))
                shifts = switch_shifts(rate(avg), np.array([rate(r) for r in pers]), 2.0 * math.pi / avg.omega_rad_s)
                for eq in np.unique(e):
                    coef = sum(signs[b] * shifts.coefficients(H, jump, m) for b, m in like.bodies[(k, int(eq))]
                               if b in signs)
                    if not np.any(coef):
                        continue
                    # each period's change as a column of its own: (rows, P)
                    dA, _, harm, _ = harmonic_rows(coef, np.zeros(H + 1, dtype=complex), H)
                    A[:, np.flatnonzero(e == eq), c] += dA[harm >= 1].T
            out.append((rows, A, Fs, h, e))
        return out

    def row_variance(self, spec: ChainSpec, theta: np.ndarray, like, jumps: Optional[Jumps] = None,
                     ) -> np.ndarray:
        """Every row's variance: its residual's period-to-period variance over P (a harmonic's
        cosine and sine rows of one equation pooled), plus the balance's own misfit
        (:attr:`fidelity`): a measured table's entry for that run, harmonic and equation, or a
        fixed floor ``(f * size)^2`` (``size`` the run's largest balanced term)."""
        sysl = like.system
        var = np.empty(sysl.F.size)
        for i, (rows, As, Fs, h, e) in enumerate(self.period_systems(spec, like, jumps)):
            v = (Fs - As @ theta).var(axis=0, ddof=1) / self.runs[i].n_periods
            size2 = float(np.max(np.abs(np.column_stack([sysl.A[rows] * theta, sysl.F[rows]])))) ** 2
            pooled = v.copy()
            for key in set(zip(h.tolist(), e.tolist())):
                sel = (h == key[0]) & (e == key[1])
                if isinstance(self.fidelity, BalanceFidelity) and i in self.fidelity.unmeasured:
                    floor = max(self.fidelity.borrowed(key[0], key[1], size2), (RIG_BALANCE_FLOOR**2) * size2)
                elif isinstance(self.fidelity, BalanceFidelity):
                    floor = max(self.fidelity.at(i, key[0], key[1]), (RIG_BALANCE_FLOOR**2) * size2)
                else:
                    floor = self.fidelity ** 2 * size2
                pooled[sel] = v[sel].mean() + floor
            var[rows] = pooled
        scale = np.max(np.abs(sysl.F)) if sysl.F.size else 1.0
        return np.maximum(var, (1e-12 * scale) ** 2)

    def compensated(self, fit: ChainFit, weights: np.ndarray) -> ChainFit:
        """``fit`` with the bias its regressors' own noise gives it taken out (compensated least
        squares), and each linear parameter's standard error at least what the periods' own
        scatter gives it (:meth:`_period_scatter`, on the same periods).

        The balance's matrix holds measured angles: in ``A'WA`` each row adds its
        noise's covariance ``C``, and where a harmonic carries noise alone that pulls every
        parameter towards zero (the linear train at four periods: -0.42 standard errors at
        bodies 3-4, ``scripts/coverage_periods.py``). ``C`` (and the covariance with the torque
        ``c``) is estimated from the spread of each period's own balance (its dry-friction columns
        the average's with their switches moved to first order, :meth:`switched`), times ``nu / (nu - 2)``:
        the weights come from that spread too, and where a row's residual is its regressors'
        noise the two move together: ``E[w C_est]`` is about ``w C``, while the mean's noise,
        independent of the spread, adds ``E[w] C = nu / (nu - 2) w C`` to ``A'WA`` (without the
        factor a third of the bias stayed at four periods). The values solve
        ``(A'WA - C) theta = A'WF - c``, and the covariance is carried through that map. The
        chi-square stays the least-squares fit's (the test of the model). The values are left
        as they are when the noise holds half the information of some direction or more (the
        correction is then no small one), and the fit as it is when it is not finite, and below
        four periods (nu < 6: the weights' estimate then has no finite variance, and the factor
        of 2 at three periods moved a servo carriage's mass 1.1 standard errors away from a
        value 0.1 from the truth, ``tests/test_validate_record.py``)."""
        spec, theta = fit.spec, np.asarray(fit.values, dtype=float)
        if fit.covariance is None or not np.all(np.isfinite(theta)) or self.nu < MIN_COMPENSATED_NU:
            return fit
        jumps = self.jumps(spec, fit.as_dict())
        banded = self.system(spec, jumps)
        A = banded.system.A
        p = A.shape[1]
        periods = self.switched(spec, banded, jumps, list(self.period_systems(spec, banded, jumps)))
        C, c = np.zeros((p, p)), np.zeros(p)
        for rows, As, Fs, _, _ in periods:
            P = As.shape[0]
            dA, dF = As - As.mean(axis=0), Fs - Fs.mean(axis=0)
            wr = weights[rows] / (P * (P - 1)) * self.nu / (self.nu - 2)
            C += np.einsum("kmi,m,kmj->ij", dA, wr, dA)
            c += np.einsum("kmi,m,km->i", dA, wr, dF)
        n = np.sqrt(np.einsum("mi,m,mi->i", A, weights, A))
        if np.any(n == 0):
            return fit
        G = (A / n).T @ ((A / n) * weights[:, None])
        Cn, cn = C / np.outer(n, n), c / n
        values, cov, M = theta, np.asarray(fit.covariance), G
        try:
            share = np.linalg.eigvals(np.linalg.solve(G, Cn)).real.max()
            if share < 0.5:
                T = np.linalg.solve(G - Cn, G)  # theta_c (scaled) = T theta (scaled) - (G - C)^-1 c
                values = (T @ (theta * n) - np.linalg.solve(G - Cn, cn)) / n
                Tu = T * n[None, :] / n[:, None]  # in the parameters' own units
                cov, M = Tu @ cov @ Tu.T, G - Cn
        except np.linalg.LinAlgError:
            return fit
        cov, dofs = self._period_scatter(cov, values, M, A / n, n, weights, periods, fit.chi2 / max(fit.dof, 1),
                                         fit.row_group, self.nu)
        return replace(fit, values=values, std_errors=np.sqrt(np.clip(np.diag(cov), 0.0, None)), covariance=cov,
                       std_error_dofs=dofs)

    @staticmethod
    def _period_scatter(cov: np.ndarray, theta: np.ndarray, M: np.ndarray, An: np.ndarray, n: np.ndarray,
                        weights: np.ndarray, periods: list, chi2_per_dof: float, row_group=None,
                        nu: float = math.inf) -> tuple[np.ndarray, Optional[np.ndarray]]:
        """``cov`` with each parameter's variance raised to what the periods' own scatter gives
        it where that is larger, its correlations kept, and each variance's degrees of freedom
        (pure): each period's residual ``r_p``
        through the estimate's map, ``u_p = M^-1 A' W r_p`` (``M`` the normal matrix of the
        columns ``An``, scaled by ``n`` to unit weighted norm), their sample covariance over each
        run's periods over ``P``, summed over the runs, times chi2/dof where above 1 (a misfit
        the same in every period is not in their scatter). It holds what the noise model leaves
        out, every correlation between rows across harmonics and the noise of every column: dry
        friction's switch at a reversal moves with the rate's noise, and that error is one pulse
        across every harmonic, at a twist's extreme, so in the stiffness columns: on a 3-body
        train with dry friction at joint 1 its k and gamma scattered 1.43 and 1.46 times their
        errors over 34 seeds, with this floor 1.15 and 1.04 (21 seeds). The larger of the two, as
        a channel's mean (:func:`identify.zeros.channel_mean`): the scatter of P periods alone has
        P - 1 degrees of freedom a run.

        The degrees of freedom (Welch-Satterthwaite, :func:`identify.estimates.satterthwaite`):
        where the scatter stands, of its runs' parts, ``P - 1`` each; elsewhere of the weights'
        groups of rows (``row_group``, ``nu`` each: :func:`identify.causes.effective_dof`), each
        group's part of the variance ``(M^-1 A_i')^2 w_i`` summed over its rows. None where
        they cannot be read (no groups, a singular ``M``)."""
        try:
            Minv = np.linalg.inv(M)
        except np.linalg.LinAlgError:
            return cov, None
        S = np.zeros_like(cov)
        parts, part_dofs = [], []
        for rows, As, Fs, _, _ in periods:
            P = As.shape[0]
            if P < 2:
                continue
            u = ((Fs - As @ theta) * weights[rows]) @ An[rows] @ Minv.T / n
            u = u - u.mean(axis=0)
            S_run = u.T @ u / (P * (P - 1))
            S += S_run
            parts.append(np.diag(S_run))
            part_dofs.append(P - 1.0)
        S *= max(1.0, chi2_per_dof)
        var = np.diag(cov)
        if not (np.all(np.isfinite(S)) and np.all(var > 0)):
            return cov, None
        k = np.sqrt(np.maximum(np.diag(S) / var, 1.0))
        dofs = None
        if row_group is not None and np.shape(row_group) == np.shape(weights):
            _, group = np.unique(row_group, return_inverse=True)
            lever = (An @ Minv.T) ** 2 * weights[:, None]  # each row's part of each variance
            dofs = np.array([effective_dof(np.bincount(group, weights=lever[:, j]), nu) for j in range(len(var))])
            if parts:
                scatter = np.array([satterthwaite([d[j] for d in parts], part_dofs) for j in range(len(var))])
                dofs = np.where(k > 1.0, scatter, dofs)
        return cov * np.outer(k, k), dofs

    def solve(self, spec: ChainSpec, weights: np.ndarray, covariance: bool = True) -> ChainFit:
        """Weighted fit of ``spec``; with dry friction to ground on a body, or in a joint, that
        slides through rest, its rate's (twist rate's) kinks restored at the fitted friction and
        refitted until the jumps settle (to ``KINK_RTOL``, at most two refits; :mod:`identify.kink`).
        ``covariance`` False leaves the rows' cross-covariances out of the fit's covariance
        (:meth:`cross_covariance`): a profile's trial or a reweighting pass reads only chi-square
        and the values, and the sandwich was a fifth of a diagnosis's time."""
        jumps = None
        banded, res = self._solve_once(spec, weights, jumps)
        for _ in range(2):
            new = self.jumps(spec, dict(zip(res.names, res.values)))
            if not new or new.settled(jumps):
                break
            jumps = new
            banded, res = self._solve_once(spec, weights, jumps)
        return self._fit_of(spec, weights, banded, res, jumps, covariance)

    def _solve_once(self, spec: ChainSpec, weights: np.ndarray, jumps: Optional[Jumps]):
        banded = self.system(spec, jumps)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IllConditionedWarning)
            return banded, solve_banded(banded, row_weights=weights)

    def _fit_of(self, spec: ChainSpec, weights: np.ndarray, banded, res, jumps, covariance: bool = True) -> ChainFit:
        s = banded.system
        residual = s.F - s.A @ res.values
        row, chi2, scale, factor = weighted_chi2(residual, weights, self.nu, res.dof)
        cov = np.array(res.covariance) * scale
        extra = self.cross_covariance(banded, spec, dict(zip(res.names, res.values)), weights) if covariance else None
        if extra is not None and np.all(np.isfinite(cov)):
            cov = cov + cov @ extra @ cov / factor  # cov = B factor: the sandwich (B + B Q B) factor
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        group = (s.row_record * (s.row_harmonic.max(initial=0) + 1) + s.row_harmonic) * (s.row_equation.max(initial=0) + 1) \
            + s.row_equation
        return ChainFit(spec, res.names, np.array(res.values), std, chi2,
                        s.F.size, row, condition_number=res.condition_number, success=res.success,
                        message=res.message, row_harmonic=s.row_harmonic, covariance=cov, row_group=group,
                        residual=residual)

    def cross_covariance(self, banded, spec: ChainSpec, values: dict, weights: np.ndarray,
                         columns: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
        """``A' W C W A`` for the covariances between rows that the weights leave out (or None
        where there are none): the noise of one encoder enters the equations of both bodies beside
        it, so at one harmonic of one run the residuals of neighbouring equations are correlated
        (at low frequency a joint's stiffness term makes them nearly opposite), and a diagonal
        weighting counts their evidence twice. ``C`` holds only the off-diagonal covariances of
        each run's and harmonic's rows (:func:`identify.chain.noise_cross_covariance`: each channel's measured
        noise propagated through the model's linear part), each correlation held within the rows'
        own variances (``1 / weights``); the fit's covariance is then the sandwich
        ``B (A'WA + A'WCWA) B`` with ``B = (A'WA)^-1`` (:meth:`_fit_of`). In a run with an
        equation weighted in time (a body masked where it rests, a body's own equation where a
        joint slides) the mask mixes the harmonics: ``C`` is then the whole run's, across
        harmonics (:func:`identify.chain.masked_noise_covariance`). ``columns``: the Jacobian
        whose ``J' W C W J`` is wanted, in place of the balance's matrix (a profiled parameter's
        column beside it: :func:`_correlated_rows`)."""
        s = banded.system
        A = s.A if columns is None else columns
        N = spec.n_flywheels
        if s.F.size == 0:
            return None
        masks, merged, slips = self.masks(), self.merged(), self.slipping()
        H = self.n_harmonics
        Q = np.zeros((A.shape[1],) * 2)
        any_block = False
        for k, run in enumerate(self.runs):
            sa = np.array([run.noise_std[f"phi{i}"] for i in range(1, N + 1)])
            st = np.array([run.noise_std.get(f"torque{i}", 0.0) for i in range(1, N + 1)])
            per = 2.0 / (run.samples_per_period * run.n_periods)
            if (masks is not None and any(m is not None for m in masks[k])) or \
                    (slips is not None and any(m is not None for m in slips[k])):
                rows = np.flatnonzero(s.row_record == k)
                labels = {int(e) for e in s.row_equation[rows]}
                C = masked_noise_covariance(s.row_harmonic[rows], s.row_part[rows], s.row_equation[rows],
                                            {e: banded.bodies[(k, e)] for e in labels}, spec, values,
                                            run.average.omega_rad_s, run.band, run.average.samples_per_period,
                                            sa, st, per)
                off = _off_diagonal_within(C, 1.0 / np.sqrt(weights[rows]))
                if np.any(off):
                    Aw = A[rows] * weights[rows][:, None]
                    Q += Aw.T @ off @ Aw
                    any_block = True
                continue
            if N < 2:
                continue
            joined = merged[k] if merged is not None else ()
            kept = sorted(set(range(N)) - {j + 1 for j in joined})
            rows = np.flatnonzero((s.row_record == k) & (s.row_harmonic >= 1) & (s.row_harmonic <= H))
            if rows.size != H * 2 * len(kept):  # not every equation at every harmonic: left as it is
                continue
            # the run's rows as (harmonic, place in [Re e_1..e_K, Im e_1..e_K])
            pos = s.row_part[rows] * len(kept) + np.searchsorted(kept, s.row_equation[rows])
            idx = np.empty((H, 2 * len(kept)), dtype=int)
            idx[s.row_harmonic[rows] - 1, pos] = rows
            w = np.arange(1, H + 1) * run.average.omega_rad_s
            C = noise_cross_covariance(spec, values, w, sa, st, joined) * per
            off = _off_diagonal_within(C, 1.0 / np.sqrt(weights[idx]))
            if not np.any(off):
                continue
            Aw = A[idx] * weights[idx][:, :, None]
            Q += np.einsum("hip,hij,hjq->pq", Aw, off, Aw)
            any_block = True
        return Q if any_block else None

    def fit(self, spec: ChainSpec, iterations: int = 2) -> tuple[ChainFit, np.ndarray]:
        banded = self.system(spec)
        w = np.ones(banded.system.F.size)
        f = self.solve(spec, w, covariance=iterations == 0)
        for k in range(iterations):
            w = self._weights_at(f, banded)
            f = self.solve(spec, w, covariance=k == iterations - 1)
        return f, w

    def _weights_at(self, fit: ChainFit, banded) -> np.ndarray:
        """Every row's weight at ``fit``'s values (``banded``: its structure's system)."""
        return 1.0 / self.row_variance(fit.spec, fit.values, banded, self.jumps(fit.spec, fit.as_dict()))

    def settled(self, fit: ChainFit, weights: np.ndarray) -> tuple[ChainFit, np.ndarray]:
        """``fit`` (a model the search has chosen) refitted once under the weights at its own values,
        kept where that settles: where the weights at the refit's values read its chi-square within
        :data:`SETTLED_RTOL`. A fit's weights are the previous fit's (:meth:`fit`); where the noise
        moves the values between those fits, the chi-square is read under weights the values no
        longer have (the pump train at 10% noise: 1.95 per degree of freedom for a right model,
        1.03 under its own values' weights). Only a chosen model: reweighting until settled inside the
        search let a model without a sticking joint's friction drift (weights at other values are
        another objective, and values that inflate the rows' variance lower it), and such a model
        does not settle; it is kept as fitted. Its profiled parameters are held."""
        if not np.all(np.isfinite(fit.values)):
            return fit, weights
        banded = self.system(fit.spec)
        w = self._weights_at(fit, banded)
        again = self.solve(fit.spec, w)
        if not (np.all(np.isfinite(again.values)) and np.isfinite(again.chi2) and again.chi2 > 0):
            return fit, weights
        chi2_next = weighted_chi2(again.residual, self._weights_at(again, banded), self.nu, again.dof)[1]
        if abs(chi2_next - again.chi2) > SETTLED_RTOL * again.chi2:
            return fit, weights
        return replace(again, profiled=fit.profiled, profiled_correlation=fit.profiled_correlation), w


def _off_diagonal_within(C: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """The off-diagonal covariances of ``C (..., n, n)``, each correlation held within the rows'
    own standard deviations ``sd (..., n)`` (the weights'), the diagonal 0: what the sandwich adds
    to a diagonal weighting (:meth:`_Problem.cross_covariance`)."""
    d = np.sqrt(np.clip(np.einsum("...ii->...i", C), 0.0, None))
    dd, vv = d[..., :, None] * d[..., None, :], sd[..., :, None] * sd[..., None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where(dd > 0, C / dd, 0.0) * np.minimum(dd, vv)
    n = off.shape[-1]
    off[..., np.arange(n), np.arange(n)] = 0.0
    return off


def balance_fidelity(replays: Sequence[Optional[ChainRun]], fit: ChainFit, n_harmonics: int, masked: tuple = (),
                     merging: tuple = (), model: str = "the fitted model") -> BalanceFidelity:
    """The balance's misfit on ``replays`` (the noise-free records of ``fit``'s model, one per fitted
    run, prepared as the runs were; None where a run's replay reached no steady state) at
    ``fit``'s own parameters (pure): the rows of every run, harmonic and equation as the diagnosis
    balances them (the same bodies masked, the same joints' equations summed where they may
    stick), each harmonic's cosine and sine rows pooled; a run without a replay is
    :attr:`BalanceFidelity.unmeasured`. The replays are the rig's true twists: the fit's angle
    offsets are not applied to them."""
    kept = [i for i, r in enumerate(replays) if r is not None]
    if not kept:
        raise ValueError("balance_fidelity: no run was replayed")
    spec = replace(fit.spec, offsets_rad=(0.0,) * len(fit.spec.offsets_rad))
    problem = _Problem(tuple(replays[i] for i in kept), n_harmonics, 2.0, 0.0, masked, merging)
    values = fit.as_dict()
    banded = problem.system(spec, problem.jumps(spec, values))
    s = banded.system
    theta = np.array([values[n] for n in s.names])
    r = s.F - s.A @ theta
    # each replay's size as row_variance measures a run's: its largest balanced term
    size2 = {k: float(np.max(np.abs(np.column_stack([s.A[s.row_record == k] * theta, s.F[s.row_record == k]])))) ** 2
             for k in range(len(kept))}
    out, shares = {}, {}
    for key in set(zip(s.row_record.tolist(), s.row_harmonic.tolist(), s.row_equation.tolist())):
        sel = (s.row_record == key[0]) & (s.row_harmonic == key[1]) & (s.row_equation == key[2])
        out[(kept[key[0]],) + key[1:]] = float(np.mean(r[sel] ** 2))
        if size2[key[0]] > 0:
            shares[key[1:]] = max(shares.get(key[1:], 0.0), out[(kept[key[0]],) + key[1:]] / size2[key[0]])
    size = float(np.sqrt(np.mean(s.F ** 2))) if s.F.size else 1.0
    return BalanceFidelity(out, float(np.sqrt(np.mean(r ** 2))) / size if size > 0 else 0.0, model,
                           tuple(i for i in range(len(replays)) if replays[i] is None), shares=shares)


def refit_on_replay(replays: Sequence[Optional[ChainRun]], fit: ChainFit, n_harmonics: int, masked: tuple = (),
                    merging: tuple = ()) -> ChainFit:
    """``fit``'s structure fitted again on its own noise-free replay (``replays`` as
    :func:`balance_fidelity`'s: one per fitted run, None where none settled), the same bodies
    masked and joints' equations summed, its profiled parameters (a free play, a Stribeck rate)
    held (pure). Where the truth is known, what this fit departs from ``fit`` is the method's
    bias: the balance's misfit at kinks and above the band, the rig's integrator. Rows are weighed
    by each run's size (a fixed floor relative to its largest balanced term): the replay holds no
    noise to weigh them by. Returns ``fit`` with the refitted linear values (its own spec and
    standard errors)."""
    kept = [r for r in replays if r is not None]
    if not kept:
        raise ValueError("refit_on_replay: no run was replayed")
    spec = replace(fit.spec, offsets_rad=(0.0,) * len(fit.spec.offsets_rad))
    problem = _Problem(tuple(kept), n_harmonics, 2.0, DEFAULT_FIDELITY, masked, merging)
    again, _ = problem.fit(with_constants(spec, problem.masks()))
    by_name = again.as_dict()
    return replace(fit, values=np.array([by_name.get(n, v) for n, v in zip(fit.names, fit.values)]))


# --------------------------------------------------------------------------------------------
# 3. Candidates: a cause at a place


class _AtPlace:
    """What a cause does at one kind of place (:class:`identify.causes.Place`): how it extends
    the chain, how its parameters are named, which motion its law sees and which angle channels
    that motion is read from. One subclass per kind of place, one instance of each in
    :data:`AT_PLACE`: a cause at a new kind of place is a subclass there and the catalogue's
    entry, no branch elsewhere."""

    def extend(self, cause: Cause, spec: ChainSpec, number: int, h: float) -> ChainSpec:
        raise NotImplementedError

    def prefix(self, number: Optional[int]) -> str:
        return ""

    def magnitude_name(self, cause: Cause, number: Optional[int]) -> str:
        return self.prefix(number) + cause.magnitude

    def profiled_name(self, cause: Cause, number: Optional[int]) -> str:
        return self.prefix(number) + cause.profiled

    def motion(self, rec: ChainRecord, number: int) -> tuple[np.ndarray, np.ndarray]:
        """A body's own angle and rate (its law to ground, its angle channel)."""
        return rec.angles_rad[number - 1], rec.rate(number - 1)

    def channels(self, number: int) -> tuple[str, ...]:
        return (f"phi{number}",)


class _AtJoint(_AtPlace):
    """Joint j's law, between bodies j and j+1: it extends that joint as a cause extends the
    two-flywheel joint (its terms and its twist's zero offset, :class:`identify.causes.ModelSpec`)."""

    def extend(self, cause, spec, number, h):
        joints, offsets = list(spec.joints), list(spec.offsets_rad)
        ext = cause.extend(ModelSpec(joints[number - 1], angle_offset_rad=offsets[number - 1]), h)
        joints[number - 1], offsets[number - 1] = ext.terms, ext.angle_offset_rad
        return replace(spec, joints=tuple(joints), offsets_rad=tuple(offsets))

    def prefix(self, number):
        return joint_prefix(number)

    def motion(self, rec, number):
        """The joint's twist and twist rate."""
        return rec.relative(number - 1)

    def channels(self, number):
        return (f"phi{number}", f"phi{number + 1}")


class _AtBearing(_AtPlace):
    """A flywheel's viscous drag to ground (its bearing): a bearing added to the chain, its
    parameter the bearing's drag, the motion it sees the body's own."""

    def extend(self, cause, spec, number, h):
        return replace(spec, bearings=spec.bearings + (number,))

    def magnitude_name(self, cause, number):
        return bearing_name(number)


class _AtGround(_AtPlace):
    """Body i's own law to the frame (a guide's or a seal's friction, a motor's cogging)."""

    def extend(self, cause, spec, number, h):
        grounds = list(spec.grounds)
        grounds[number - 1] = cause.extend(ModelSpec(grounds[number - 1]), h).terms
        return replace(spec, grounds=tuple(grounds))

    def prefix(self, number):
        return ground_prefix(number)


class _AtChannel(_AtPlace):
    """Body i's angle channel: its skew and scale against the drive's and body 1's, as flywheel
    2's of two flywheels."""

    def extend(self, cause, spec, number, h):
        delays, gains = list(spec.channel_delays_s), list(spec.channel_gains)
        ext = cause.extend(ModelSpec((), angle2_delay_s=delays[number - 1], angle2_gain_error=gains[number - 1]), h)
        delays[number - 1], gains[number - 1] = ext.angle2_delay_s, ext.angle2_gain_error
        return replace(spec, channel_delays_s=tuple(delays), channel_gains=tuple(gains))

    def magnitude_name(self, cause, number):
        return channel_name(number, cause.magnitude)

    def profiled_name(self, cause, number):
        return channel_name(number, cause.profiled)


class _AtDrive(_AtPlace):
    """The drives' channels (their lag behind the record), not a place on the line."""

    def extend(self, cause, spec, number, h):
        return replace(spec, drive_delay_s=cause.extend(ModelSpec((), drive_delay_s=spec.drive_delay_s),
                                                        h).drive_delay_s)

    def motion(self, rec, number):
        raise ValueError("a cause at the drives acts on no body's motion")

    def channels(self, number):
        return ()


#: What a cause does at each kind of place (:attr:`identify.causes.Place.kind`).
AT_PLACE = {"joint": _AtJoint(), "flywheel": _AtBearing(), "ground": _AtGround(), "channel": _AtChannel(),
            "drive": _AtDrive()}


@dataclass(frozen=True)
class Candidate:
    """A catalogued cause at one place (:class:`identify.causes.Place`): a joint (1..N-1), a
    flywheel's viscous drag to ground (1..N, bearing drag), a body's law to ground (1..N: a
    guide's or a seal's friction, a motor's cogging), a body's angle channel or the drives; what
    it does there is its place's (:data:`AT_PLACE`)."""

    cause: Cause
    where: Place

    @property
    def _at(self) -> _AtPlace:
        return AT_PLACE[self.where.kind]

    @property
    def place(self) -> int:
        return self.where.number

    @property
    def at_joint(self) -> bool:
        return self.where.at_joint

    @property
    def ground(self) -> bool:
        return self.where.to_ground

    @property
    def at_drive(self) -> bool:
        """The drives' channels (their lag behind the record), not a place on the line."""
        return self.where.at_drive

    @property
    def at_channel(self) -> bool:
        """A body's angle channel (its skew and scale against the drive's and body 1's)."""
        return self.where.at_channel

    @property
    def label(self) -> str:
        return f"{self.cause.name} {self.where.describe()}"

    @property
    def name(self) -> str:
        """The label (:func:`identify.causes.forward_select` drops an adopted candidate by name:
        every cause at most once per place, the same cause may still be found elsewhere)."""
        return self.label

    @property
    def first_only(self) -> bool:
        return self.cause.first_only

    def extend(self, spec: ChainSpec, h: float) -> ChainSpec:
        """The chain with this cause at its place."""
        return self._at.extend(self.cause, spec, self.place, h)

    @property
    def prefix(self) -> str:
        return self._at.prefix(self.place)

    def magnitude_name(self) -> str:
        return self._at.magnitude_name(self.cause, self.place)

    def profiled_name(self) -> Optional[str]:
        return None if self.cause.profiled is None else self._at.profiled_name(self.cause, self.place)

    def motion(self, rec: ChainRecord) -> tuple[np.ndarray, np.ndarray]:
        """The motion this candidate's law sees in a record: its joint's twist and twist rate, or
        its body's own angle and rate (ground, an angle channel)."""
        return self._at.motion(rec, self.place)

    def channels(self) -> tuple[str, ...]:
        """The angle channels this candidate's motion is read from."""
        return self._at.channels(self.place)


#: The smallest swing a cause's search bounds read (``Cause.bounds_read_smallest``), as a share
#: of the largest: a joint of a chain may barely twist in runs far from its modes, and a bound
#: read from such a run (a periodic torque's highest order, phase over the smallest swing) would
#: search orders no other run resolves. Two flywheels' runs at three frequencies and two levels
#: span 4.6 in twist.
BOUNDS_SPAN = 8.0


def _twist_runs(problem: _Problem, cand: Candidate) -> list:
    """The runs whose motion (the candidate's joint's twist, or its body's angle) a cause's
    search bounds read (as the two-flywheel causes' bounds read runs, ``average.phi_rad``): the
    run where it swings most, among the runs that balance the place on its own
    (:meth:`_Problem.balanced_runs`), and for a cause whose bounds read the smallest swing too
    (``Cause.bounds_read_smallest``) the one where it swings least but at least
    1/:data:`BOUNDS_SPAN` of that. In a chain a joint may barely twist in runs far from its modes;
    the bounds of a free play or a slip angle must reach the largest twist, and those of a rate
    (a Stribeck rate, ``profiled`` in rad/s) the largest twist rate: swings are of the rate there."""
    if cand.at_drive or cand.at_channel:  # a lag or a skew is bounded by the runs' periods, a scale not
        return list(problem.runs)
    by_rate = cand.cause.profiled is not None and cand.cause.profiled.endswith("_rad_s")
    swings = []
    for r in problem.balanced_runs(cand):
        a = r.average
        twist, rate = cand.motion(a)
        swings.append((float(np.ptp(rate if by_rate else twist)), a, twist))
    most = max(swings, key=lambda x: x[0])
    least = min((x for x in swings if x[0] >= most[0] / BOUNDS_SPAN), key=lambda x: x[0])
    read = (most, least) if cand.cause.bounds_read_smallest and least is not most else (most,)
    return [SimpleNamespace(average=SteadyStateRecord(a.omega_rad_s, a.time_s, np.zeros_like(twist), twist, None,
                                                      source=a.source)) for _, a, twist in read]


def _rate_amplitude(problem: _Problem, cand: Candidate) -> float:
    return max(float(np.max(np.abs(cand.motion(r.average)[1]))) for r in problem.balanced_runs(cand))


def angle_resolution(problem: _Problem, cand: Candidate) -> float:
    """What the candidate's motion resolves (rad): 3 noise standard deviations of one sample of
    the band-limited period average."""
    out = 0.0
    for r in problem.runs:
        sd = math.sqrt(sum(r.noise_std[ch] ** 2 for ch in cand.channels()))
        out = max(out, 3.0 * sd * math.sqrt(min(1.0, (2 * problem.n_harmonics + 1) / r.samples_per_period)
                                             / r.n_periods))
    return out


def _preload_twist(problem: _Problem, base: ChainSpec, j: int, weights) -> float:
    """The twist (rad) a mean torque through joint ``j`` would hold it at under its linear
    stiffness, at most: the largest run's mean drive torque on the bodies before the joint (a
    train free to turn passes it to a load beyond; a cell's offset makes it an upper bound),
    over the joint's ``k`` in ``base``'s fit (0 without a linear stiffness, or for a mean below
    :data:`PRELOAD_SHARE` of the drive: a cell's offset)."""
    k_name = joint_prefix(j) + Power(1).name
    if k_name not in base.names:
        return 0.0
    means = [abs(sum(float(np.mean(t)) for t in r.average.torques_Nm[:j] if t is not None)) for r in problem.runs]
    swing = max((float(np.ptp(t)) / 2 for r in problem.runs for t in r.average.torques_Nm if t is not None), default=0.0)
    if not means or max(means) <= PRELOAD_SHARE * swing:
        return 0.0
    k = problem.solve(base, weights).as_dict().get(k_name, math.nan)
    return PRELOAD_MARGIN * max(means) / abs(k) if math.isfinite(k) and k != 0 else 0.0


#: A drive's mean below this share of the largest drive amplitude is taken for its cell's offset
#: (a torque cell's zero error is a percent or two of its range), not a mean load: the zero search
#: is not widened for it. Widened for a 2% offset, the paper joint's even stiffness (a = 400 N
#: m/rad^2, its zero and a the same balance under the cubic) moved 34 standard errors from the
#: zeroed file's (scripts/bench_zeros.py).
PRELOAD_SHARE = 0.1

#: The preload's twist is searched this many times as far as the mean torque over the fitted
#: ``k``: fitted about the mean twist, ``k`` is the local stiffness there, above the law's ``k``
#: under a progressive law (the elastomer coupling at 200 N m: 10% above, and its zero 5% past
#: the bound without a margin).
PRELOAD_MARGIN = 2.0


def _search_range(problem: _Problem, cand: Candidate) -> tuple[list, float, float]:
    """The runs the candidate's bounds read at its place (:func:`_twist_runs`) and its profile
    search range there (a twist's zero is widened further in :func:`_profile`)."""
    here = _twist_runs(problem, cand)
    return (here, *cand.cause.bounds(here))


def _profile_range(problem: _Problem, cand: Candidate, base: ChainSpec, weights) -> tuple[list, float, float]:
    """:func:`_search_range`, a twist's zero widened where the joint's law or a mean load may
    rest its twist's mean off it."""
    here, lo, hi = _search_range(problem, cand)
    if cand.cause.name == TWIST_ZERO.name and cand.at_joint:
        # a free play's rest is anywhere in its play: the twist's mean (what identify.zeros takes
        # out) may sit off it by up to the half gap, beyond a sensor's zero error
        gap = max((t.gap_rad for t in base.joints[cand.place - 1] if isinstance(t, Power)), default=0.0)
        # a joint under a preload rests its twist's mean off the law's zero by the preload's twist
        gap = max(gap, _preload_twist(problem, base, cand.place, weights))
        lo, hi = min(lo, -gap), max(hi, gap)
    return here, lo, hi


def _profile(problem: _Problem, cand: Candidate, base: ChainSpec, weights) -> ChainFit:
    """:func:`identify.causes.profile` over the candidate's bounds at its place."""
    here, lo, hi = _profile_range(problem, cand, base, weights)
    mag = cand.magnitude_name()

    def penalised(f: ChainFit) -> float:
        # A friction or damping that feeds energy in is never adopted, so the search stays in the
        # physical region: a negative magnitude scores worse than any physical value.
        v = f.as_dict().get(mag, 0.0)
        return f.chi2 if not (cand.cause.nonnegative and v < 0) else f.chi2 + 1e6 * (1.0 + abs(f.chi2))

    found = profile(lambda h: problem.solve(cand.extend(base, h), weights, covariance=False), cand.cause, lo, hi,
                    objective=penalised, points=cand.cause.grid_points(here, lo, hi))
    fit = problem.solve(cand.extend(base, found.value), weights)  # the trials' fits carry no sandwich
    return replace(fit, profiled=((cand.profiled_name(), found.value, found.std_error),))


#: Passes of the joint refinement of adopted causes' nonlinear parameters (:func:`_refine`).
REFINE_PASSES = 2


def _refine(problem: _Problem, adopted: Sequence[Candidate], fit: ChainFit, weights) -> tuple[ChainFit, np.ndarray]:
    """Each adopted cause's nonlinear parameter profiled again given the others' (coordinate
    descent, :data:`REFINE_PASSES` passes), the weights re-estimated after. A cause found first
    is profiled without the later ones: free play found before its encoders' zero offset came out
    8% short (0.92 of 1.0 mrad, 6 standard errors) until it was profiled again beside it."""
    for _ in range(REFINE_PASSES):
        for cand in adopted:
            if cand.cause.bounds is None:
                continue
            again = _profile(problem, cand, fit.spec, weights)
            name, value, se = again.profiled[0]
            fit = replace(again, profiled=tuple((n, v, e) if n != name else (name, value, se)
                                                for n, v, e in fit.profiled))
    spec, profiled, correlation = _jointly(problem, adopted, fit.spec, fit.profiled, weights)
    refit, weights = problem.fit(spec)
    return replace(refit, profiled=profiled, profiled_correlation=correlation), weights


def _jointly(problem: _Problem, cands: Sequence[Candidate], spec: ChainSpec, profiled: tuple, weights
             ) -> tuple[ChainSpec, tuple, tuple]:
    """The profiled parameters of ``cands``, each profiled one at a time, moved together to
    chi-square's joint minimum with marginal standard errors (:func:`identify.causes.joint_minimum`,
    the weights held). Returns the structure, ``profiled`` with the new values and errors, and
    their pairs' correlations (:attr:`ChainFit.profiled_correlation`). A parameter within one
    error of its search range's end, or without a finite error, is held; with fewer than two
    left, nothing changes."""
    found = {n: (v, e) for n, v, e in profiled}
    free = []
    for cand in cands:
        name = cand.profiled_name()
        if cand.cause.bounds is None or name not in found or not (math.isfinite(found[name][1]) and found[name][1] > 0):
            continue
        _, lo, hi = _profile_range(problem, cand, spec, weights)
        h, e = found[name]
        if lo <= h - e and h + e <= hi:
            free.append((cand, name, lo, hi))
    if len(free) < 2:
        return spec, profiled, ()

    def at(x) -> ChainSpec:
        out = spec
        for (cand, *_), v in zip(free, x):
            out = cand.extend(out, float(v))
        return out

    got = joint_minimum(lambda x: problem.solve(at(x), weights, covariance=False).chi2,
                        [found[n][0] for _, n, _, _ in free], [found[n][1] for _, n, _, _ in free],
                        [f[2] for f in free], [f[3] for f in free])
    moved = {n: (float(v), found[n][1] * float(k)) for (_, n, _, _), v, k in zip(free, got.values, got.widen)}
    pairs = tuple((free[i][1], free[j][1], float(got.correlation[i, j]))
                  for i in range(len(free)) for j in range(i + 1, len(free)))
    return at(got.values), tuple((n, *moved[n]) if n in moved else (n, v, e) for n, v, e in profiled), pairs


#: A twist's zero as part of the nominal model: the angle-offset cause over its own range, a
#: sensor's zero error (:data:`identify.causes.ANGLE_ZERO_TOLERANCE_RAD`). Searched over a full
#: turn, it took the even stiffness of the independent bench's joint (a = 150 N m/rad^2 under
#: gamma = 200: the same balance as a zero 0.25 rad off) for a zero, which the held-out runs then
#: refused (22.8 noise floors): the two differ only in the mean twist, which the balance leaves
#: out. A larger apparent zero stays a cause's (an even stiffness, read back as a zero).
TWIST_ZERO = by_name("angle_offset")


def _widened(problem: _Problem, cands: Sequence[Candidate], fit: ChainFit, weights) -> ChainFit:
    """``fit`` with every linear parameter's standard error (and covariance) carrying the profiled
    parameters' own uncertainty (:func:`identify.causes.widened`): the fit's slope along each by a
    central difference at its value, each one's error times :func:`_correlated_rows` (written
    into ``profiled``), their correlations :attr:`ChainFit.profiled_correlation`."""
    found = {n: (v, e) for n, v, e in fit.profiled}
    names, slopes, errors, steps, specs = [], [], [], [], []
    for cand in cands:
        if cand.cause.bounds is None or cand.profiled_name() not in found:
            continue
        h, se = found[cand.profiled_name()]
        lo, hi = cand.cause.bounds(_twist_runs(problem, cand))
        step = max(1e-3 * abs(h), 1e-6 * (hi - lo))
        at = [cand.extend(fit.spec, x) for x in (h - step, h + step)]
        below, above = (problem.solve(s, weights, covariance=False) for s in at)
        if np.shape(below.values) != np.shape(fit.values):
            continue
        names.append(cand.profiled_name())
        errors.append(se * _correlated_rows(problem, cand, fit, h, step, weights))
        slopes.append((np.asarray(above.values) - np.asarray(below.values)) / (2 * step))
        steps.append(step)
        specs.append(at)
    if not names:
        return fit
    rho = {frozenset((a, b)): r for a, b, r in fit.profiled_correlation}
    R = np.array([[1.0 if a == b else rho.get(frozenset((a, b)), 0.0) for b in names] for a in names])
    now = dict(zip(names, errors))
    out = replace(widened(fit, slopes, errors, R), profiled=tuple((n, v, now.get(n, e)) for n, v, e in fit.profiled))
    ok = [k for k, e in enumerate(errors) if math.isfinite(e)]  # as widened() keeps them
    if out.covariance is None or not ok:
        return out
    E = np.array([errors[k] for k in ok])
    S = R[np.ix_(ok, ok)] * np.outer(E, E)
    return replace(out, profiled_spread=ProfiledSpread(
        tuple(names[k] for k in ok), tuple(steps[k] for k in ok), tuple(specs[k][0] for k in ok),
        tuple(specs[k][1] for k in ok), np.column_stack([slopes[k] for k in ok]) @ S, S))


def _correlated_rows(problem: _Problem, cand: Candidate, fit: ChainFit, h: float, step: float, weights) -> float:
    """What a profiled parameter's standard error (chi-square's curvature, every row weighted on
    its own) is multiplied by for the correlations between rows that the weights leave out, as a
    linear parameter's is (:meth:`_Problem.cross_covariance`, the sandwich of :meth:`_Problem._fit_of`):
    ``sqrt(1 + (B Q B)_hh / B_hh)`` with the balance's Jacobian extended by the parameter's own
    column (a central difference over ``step`` at its value ``h``). A free play's half gap moves
    with the joint's stiffness, whose noise enters both bodies' equations: on the independent
    bench its profile alone left the gap and k 1.2-1.3 times their errors over 100 seeds. 1 where
    no row is correlated or the sandwich is not finite."""
    spec, theta = fit.spec, np.asarray(fit.values, dtype=float)
    jumps = problem.jumps(spec, fit.as_dict())
    banded = problem.system(spec, jumps)
    # (the same columns at h +- step: _widened has checked that the fits there have them)
    below, above = (problem.system(cand.extend(spec, x), jumps).system.A for x in (h - step, h + step))
    J = np.column_stack([banded.system.A, (above - below) @ theta / (2 * step)])
    Q = problem.cross_covariance(banded, spec, fit.as_dict(), weights, columns=J)
    if Q is None:
        return 1.0
    # in columns of unit weighted norm (the ratio does not depend on their scales, and a gap's
    # column and an inertia's differ by orders of magnitude)
    n = np.sqrt(np.einsum("mi,m,mi->i", J, weights, J))
    if not np.all(n > 0):
        return 1.0
    B = np.linalg.pinv((J / n).T @ ((J / n) * weights[:, None]))
    share = float((B @ (Q / np.outer(n, n)) @ B)[-1, -1] / B[-1, -1]) if B[-1, -1] > 0 else math.nan
    return math.sqrt(1.0 + share) if math.isfinite(share) and share > -1.0 else 1.0


def zeroed_joints(spec: ChainSpec, slipping: Optional[Sequence] = None) -> list[int]:
    """The joints (1-based) whose twist's zero the data determine: those whose law has a
    nonlinear elastic term (a power above 1, or free play), and those with an elastic law whose
    body's equation is balanced only where the joint slides (``slipping``, per run and joint a
    mask or None: :meth:`_Problem.slipping`): the mask turns the spring's constant part into
    every even harmonic. Elsewhere a linear law only shifts the mean twist, which the balance
    leaves out."""
    def nonlinear(t) -> bool:
        return t.elastic and not (isinstance(t, Power) and t.power <= 1 and not t.gap_rad)

    masked = {j + 1 for run in (slipping or ()) for j, m in enumerate(run) if m is not None}
    return [j for j, terms in enumerate(spec.joints, start=1)
            if any(nonlinear(t) for t in terms) or (j in masked and any(t.elastic for t in terms))]


def _twist_zeros(problem: _Problem, zeros: Sequence[Candidate], spec: ChainSpec, weights
                 ) -> tuple[ChainSpec, tuple, tuple]:
    """Each joint's twist zero profiled in turn on the nominal structure (a pass per joint, then
    once more beside the others', then together: :func:`_jointly`); returns the structure with
    them, their profiles and their correlations."""
    profiled = {}
    for _ in range(2 if len(zeros) > 1 else 1):
        for cand in zeros:
            f = _profile(problem, cand, spec, weights)
            spec = f.spec
            profiled.update({n: (n, v, e) for n, v, e in f.profiled})
    return _jointly(problem, zeros, spec, tuple(profiled.values()), weights)


def _dissipative(fit: ChainFit) -> list[str]:
    names = [joint_prefix(j) + t.name for j, terms in enumerate(fit.spec.joints, start=1) for t in terms
             if t.dissipative]
    names += [ground_prefix(i) + t.name for i, terms in enumerate(fit.spec.grounds, start=1) for t in terms
              if t.dissipative]
    return names + [bearing_name(i) for i in fit.spec.bearings]


def _rejection(problem: _Problem, cand: Candidate, ext: ChainFit, mag: tuple, base: Optional[ChainSpec] = None,
               weights: Optional[np.ndarray] = None) -> Optional[Rejection]:
    """Why a candidate the evidence calls significant is rejected all the same (its score's
    ``note``), or None where nothing rejects it; ``ext`` extends ``base`` at ``weights`` (without
    them a size below the resolution is not tested against its zero)."""
    if cand.cause.nonnegative and mag[1] < 0:
        return Unphysical(mag[0], mag[1])
    for name in _dissipative(ext):
        v, se = ext.as_dict()[name], ext.std_error(name)
        if v < 0 and (not math.isfinite(se) or -v > 2 * se):
            return FeedsEnergy(name, v, se)
    if cand.cause.degenerate is not None:
        h = ext.parameters().get(cand.profiled_name(), math.nan)
        resolution, rise = angle_resolution(problem, cand), math.nan
        if h < resolution and cand.cause.bounds is not None and base is not None:
            # chi-square at the lower end of the search: the size's zero (no play, dry friction)
            rise = problem.solve(cand.extend(base, _search_range(problem, cand)[1]), weights,
                                 covariance=False).chi2 - ext.chi2
        at_place = f"joint {cand.place}" if cand.at_joint else f"body {cand.place}"
        return cand.cause.degenerate(h, Limits(resolution, _rate_amplitude(problem, cand),
                                               f"coulomb_friction at {at_place}", rise))
    return None


def score(problem: _Problem, cand: Candidate, base: ChainFit, weights: np.ndarray, n_tests: int,
          alpha: float) -> CauseScore:
    """The evidence for one candidate on top of ``base`` (module docstring, step 4)."""
    ext = (problem.solve(cand.extend(base.spec, 0.0), weights) if cand.cause.bounds is None
           else _profile(problem, cand, base.spec, weights))
    q = len(ext.names) - len(base.names) + (1 if cand.cause.bounds is not None else 0)
    delta = base.chi2 - ext.chi2
    # The one evidence measure (identify.causes.evidence): BIC score, chi-square(q) p-value,
    # Bonferroni over the round; a candidate that adds no parameter (q = 0: dry friction where a
    # Stribeck law already holds it) is never significant.
    # (a cause without trials has no search bounds at a body's drag: no runs to ask of it)
    trials = cand.cause.n_trials(_twist_runs(problem, cand)) if cand.cause.trials is not None else 1.0
    nu_eff = _drop_dof(problem, base, ext, weights)
    nu = problem.nu if math.isfinite(nu_eff) else math.inf
    bic, p, significant = evidence(delta, q, base.n_rows, alpha, n_tests * trials, nu, nu_eff)
    name = cand.magnitude_name()
    if cand.at_joint or cand.ground:
        mag = cand.cause.magnitude_of(ext.parameters(), ext.std_error, cand.prefix)
    else:
        mag = (name, ext.parameters().get(name, math.nan), ext.std_error(name))
    rejected = (_rejection(problem, cand, ext, mag, base.spec, weights)
                if significant or (cand.cause.nonnegative and mag[1] < 0) else None)
    if rejected is not None:
        significant = False
    return CauseScore(cand.cause.name, float(delta), q, float(bic), p, significant, ext, mag,
                      _signature(problem, cand, base, ext), note=rejected, where=cand.where, nu=nu, nu_eff=nu_eff)


def _drop_dof(problem: _Problem, base: ChainFit, ext: ChainFit, weights: np.ndarray) -> float:
    """The effective degrees of freedom of the weights under the drop from ``base`` to ``ext``
    (the same rows, weighted alike): what the cause changes in each row's fitted value, its
    weighted square summed per group of rows that share a variance estimate of ``problem.nu``
    degrees of freedom (:func:`identify.causes.effective_dof`); inf where the rows differ."""
    if base.residual is None or ext.residual is None or base.row_group is None or \
            np.shape(base.residual) != np.shape(ext.residual) or np.shape(weights) != np.shape(base.residual):
        return math.inf
    _, inverse = np.unique(base.row_group, return_inverse=True)
    energy = np.bincount(inverse, weights=weights * (base.residual - ext.residual) ** 2)
    return effective_dof(energy, problem.nu)


def _signature(problem: _Problem, cand: Candidate, base: ChainFit, ext: ChainFit) -> dict:
    """Where a candidate's improvement lies (the two flywheels' signature): the share of its
    chi-square drop by harmonic class, and how dissipative its own torque is along its place's
    measured motion at the fundamental (None for a drag to ground: viscous by construction)."""
    out: dict = harmonic_shares(base.row_chi2 - ext.row_chi2, ext.row_harmonic)
    out["dissipative"] = None
    if cand.at_joint or cand.ground:
        k = cand.place - 1
        terms = ext.spec.grounds[k] if cand.ground else ext.spec.joints[k]
        held = {t.name for t in (base.spec.grounds[k] if cand.ground else base.spec.joints[k])}
        vals = ext.parameters()
        law = JointLaw(terms, tuple(vals[cand.prefix + t.name] for t in terms))
        # the base's terms at the extended values, free play's gap taken out: what is left is the cause's
        plain = [(Power(t.power) if isinstance(t, Power) else t, v) for t, v in zip(law.terms, law.values)
                 if t.name in held]
        without = JointLaw(tuple(t for t, _ in plain), tuple(v for _, v in plain)) if plain else None
        motions = [cand.motion(r.average) for r in problem.runs]
        offset = ext.spec.offsets_rad[k] if cand.at_joint else 0.0

        def own(x, v):
            base_part = np.asarray(without.torque(x, v), float) if without is not None else 0.0
            return np.asarray(law.torque(x, v), float) - base_part

        out["dissipative"] = fundamental_quadrature([own(x - offset, v) for x, v in motions], [x for x, _ in motions])
    return out


# --------------------------------------------------------------------------------------------
# 4. The diagnosis


@dataclass(frozen=True)
class ChainDiagnosis:
    """The whole diagnosis of a chain.

    Attributes:
      nominal: the nominal fit; first_round: every candidate scored on it, best first.
      steps: the candidates adopted, in order; final: the extended fit.
      ambiguities: places the data cannot tell apart (with the drive that would).
      n_candidates: candidates per round (the Bonferroni divisor); expected_chi2: the nominal's
        ``dof nu/(nu-2)``.
    """

    nominal: ChainFit
    first_round: tuple
    steps: tuple
    final: ChainFit
    ambiguities: tuple
    n_harmonics: int
    noise_std: dict
    nu: float
    #: what in the nominal fit says the file may be read wrong (:func:`implausible_train_fit`:
    #: :class:`ReadWrong`, :class:`UndeterminedInertia`; in words: :func:`present.notes.plausibility_text`)
    plausibility: tuple = ()
    #: ``(run index among the fitted runs, body number, share of the period it rests, share
    #: masked out of its equation)`` for every run where a body that may stick rests
    #: (:func:`identify.chain.stick_mask`)
    rests: tuple = ()
    #: ``(run index among the fitted runs, joint number, share of the period its twist rests,
    #: whether its twist is resolved above the noise, share of the period a body's own equation
    #: leaves out as stuck)`` for every run where a joint that may stick may be stuck: its two
    #: bodies' equations are balanced as their sum there, and one of them on its own where the
    #: joint slides (:meth:`_Problem.slipping`; 1.0: stuck the whole period, the sum alone)
    stuck_joints: tuple = ()
    #: the balance's own misfit every model's row variances carried: measured on a model's replay
    #: (:class:`BalanceFidelity`) or a fixed floor (relative to each run's largest balanced term)
    fidelity: "BalanceFidelity | float" = DEFAULT_FIDELITY
    #: per body, whether its equation is masked where it rests; per joint, whether its bodies'
    #: equations are summed where it may stick (the rows every fit balanced)
    masked: tuple = ()
    merging: tuple = ()
    #: the most causes the forward selection could adopt (``--max-causes``)
    max_effects: int = 2
    #: every cause not adopted, scored on the final model (the round that adopted nothing; empty
    #: where the selection stopped at ``max_effects``): what the data rule out is read from it
    last_round: tuple = ()
    #: the false-alarm probability of every round (``--alpha``)
    alpha: float = DEFAULT_ALPHA
    #: ``(parameter, "lower" or "upper", the bound)`` for every adopted cause's profiled parameter
    #: whose best value lies on an end of its search (:func:`identify.causes.on_search_bound`)
    on_bounds: tuple = ()

    def ruled_out(self) -> tuple:
        """``(score, limit)`` for every catalogued cause not adopted, on the final model: the
        smallest size these runs would have found (:func:`identify.causes.detection_limit`), in
        the order they were ranked; causes without a finite limit left out."""
        scored = self.last_round or (self.first_round if not self.steps else ())
        n = max(len(scored), 1)
        out = [(s, detection_limit(s, self.final.n_rows, self.alpha, n)) for s in scored if not s.significant]
        return tuple((s, lim) for s, lim in out if math.isfinite(lim))

    @property
    def found(self) -> Optional[CauseScore]:
        return self.steps[0] if self.steps else None

    def reduced_chi2(self, f: ChainFit) -> float:
        """chi2 / dof of a fit, relative to what noise alone gives (1 for a model the noise explains)."""
        return f.chi2 / max(f.dof, 1)



def candidates(n_flywheels: int, causes: Sequence[Cause] = JOINT_CAUSES, bearings: bool = True,
               ground: Sequence[Cause] = GROUND_CAUSES, drives: Sequence[Cause] = DRIVE_CAUSES,
               channels: Sequence[Cause] = CHANNEL_CAUSES, elastic_grounds: Sequence[int] = ()) -> list[Candidate]:
    """Every cause at every joint, bearing drag at every body, the ground causes at every body,
    the drives' causes (their lag) once and the channel causes at bodies 2..N. A body tied to the
    frame by an elastic law (``elastic_grounds``, 1-based: a spring to ground, the relative-angle
    form's joint) is a joint to the frame: the joint's dynamic causes are sought there too (a
    zero offset is not: a body's own angle has no offset cause)."""
    out = [Candidate(c, Place("joint", j)) for j in range(1, n_flywheels) for c in causes]
    if bearings:
        out += [Candidate(_BEARING, Place("flywheel", i)) for i in range(1, n_flywheels + 1)]
    if n_flywheels > 1:  # see TRAIN_GROUND_CAUSES
        ground = [c for c in ground if c.name in TRAIN_GROUND_CAUSES]
    for i in range(1, n_flywheels + 1):
        here = set(ground) | ({c for c in causes if c.kind == "dynamic"} if i in elastic_grounds else set())
        out += [Candidate(c, Place("ground", i)) for c in CATALOGUE if c in here]
    out += [Candidate(c, Place("drive", None)) for c in drives]
    out += [Candidate(c, Place("channel", i)) for i in range(2, n_flywheels + 1) for c in channels]
    return out


def _joints_that_may_stick(problem: _Problem, structure: ChainSpec, pool: Sequence[Candidate], alpha: float
                           ) -> tuple:
    """Per joint: whether it may stick, so that its bodies' equations are summed where its twist
    rests (:meth:`_Problem.merged`): its nominal law has dry friction, or it is the joint where
    the simplest dry friction among the candidates (one without a profiled parameter) takes up
    most of the nominal fit's misfit, with every equation balanced, and is significant there
    with a positive size.

    Only that one joint: a joint's twist far from a sinusoid rests by the rule's measure too
    (the pump train's stiff shafts: 4-11% of some periods), and summing its equations there
    only loses what they say. A misfit elsewhere makes a small friction significant at other
    joints (0.2 N m at both other joints of the independent bench's train with an Iwan element in
    its first joint); summed there, the Iwan element's profile moved to another minimum, four times
    its size."""
    N = structure.n_flywheels
    out = [jumps_at_rest(structure.joints[j]) for j in range(N - 1)]
    dry = [c for c in pool if c.at_joint and c.cause.bounds is None and not out[c.place - 1]
           and jumps_at_rest(c.extend(structure, 1e-3).joints[c.place - 1])]
    if dry:
        base, w = problem.fit(structure)
        scored = [(score(problem, c, base, w, len(pool), alpha), c) for c in dry]
        best, c = max(scored, key=lambda sc: sc[0].delta_chi2)
        out[c.place - 1] = best.significant and best.magnitude[1] > 0
    return tuple(out)


def diagnose_chain(runs: Sequence[ChainRun], *, n_harmonics: int = 20, alpha: float = DEFAULT_ALPHA, max_effects: int = 2,
                   fidelity: float = DEFAULT_FIDELITY, causes: Sequence[Cause] = JOINT_CAUSES,
                   nominal: Optional[ChainSpec] = None, progress=None, workers: Optional[int] = None
                   ) -> ChainDiagnosis:
    """Fit the nominal chain, score every cause at every place, extend greedily (module docstring).

    Args:
      nominal: the nominal structure (the user's model's, ``jointrig diagnose --model``);
        default :func:`nominal_spec` (paper eq. 11 at every joint).
      progress: optional callable ``(done, total, label)`` called after every candidate scored.
      workers: processes that score a round's candidates (default :func:`jointrig.parallel.default_workers`).
      fidelity: the balance's own misfit each row's variance adds, the same for every model
        compared: a fixed floor relative to each run's largest balanced term, or measured on a
        model's noise-free replay (:class:`BalanceFidelity`, :func:`balance_fidelity`).
    """
    from jointrig.parallel import fork_map

    runs = tuple(runs)
    if not runs:
        raise ValueError("no runs to diagnose")
    N = runs[0].average.n_flywheels
    H = min(n_harmonics, min(max_harmonic(r.samples_per_period) for r in runs))
    nu = 2.0 * (min(r.n_periods for r in runs) - 1)
    if nominal is not None and nominal.n_flywheels != N:
        raise ValueError(f"the nominal model has {nominal.n_flywheels} flywheels, the runs {N}")
    structure = nominal if nominal is not None else nominal_spec(N)
    # A lag is told from a law by its phase growing with the frequency: at one frequency it only
    # turns every harmonic by a fixed angle, and on a single run of the carriage it reached the
    # top of its range (a tenth of the period) and was second in evidence. Scored from two
    # frequencies on.
    omegas = sorted(r.average.omega_rad_s for r in runs)
    several = any(b > a * (1 + 1e-3) for a, b in zip(omegas, omegas[1:]))
    # a cause the nominal model already holds at a place is no candidate there (a single body's
    # drag to ground, a user's model with a guide's friction)
    elastic = [i for i, g in enumerate(structure.grounds, start=1) if any(t.elastic for t in g)]
    # (nor a drag at a body whose law to ground has one: the relative-angle form's joint)
    pool = [c for c in candidates(N, causes, drives=DRIVE_CAUSES if several else (), elastic_grounds=elastic)
            if (c.extend(structure, 1e-3) != structure or c.cause.bounds is not None)
            and not (c.where.at_bearing and any(isinstance(t, Viscous) for t in structure.grounds[c.place - 1]))]
    masked = tuple(sticks_to_ground(structure, i) or any(c.ground and c.place == i + 1
                                                         and sticks_to_ground(c.extend(structure, 1e-3), i)
                                                         for c in pool) for i in range(N))
    merging = _joints_that_may_stick(_Problem(runs, H, nu, fidelity, masked), structure, pool, alpha)
    problem = _Problem(runs, H, nu, fidelity, masked, merging)
    structure = with_constants(structure, problem.masks())
    nominal, w = problem.fit(structure)
    # Every twist's zero is unknown (each encoder has its own): under a nonlinear elastic law it
    # is part of the nominal model, profiled at every such joint, not a cause to be found.
    zeros = [Candidate(TWIST_ZERO, Place("joint", j)) for j in zeroed_joints(structure, problem.slipping())
             if any(p.cause.name == TWIST_ZERO.name and p.where == Place("joint", j) for p in pool)]
    if zeros:
        structure, profiled, correlation = _twist_zeros(problem, zeros, structure, w)
        nominal, w = problem.fit(structure)
        nominal = replace(nominal, profiled=profiled, profiled_correlation=correlation)
        pool = [c for c in pool if not any(c.cause.name == z.cause.name and c.where == z.where for z in zeros)]
    ambiguous: list[Ambiguity] = []
    by_label = {c.label: c for c in pool}
    causes_by_name = {c.cause.name: c.cause for c in pool}

    def rank(base, pool, rnd):
        current, wcur = base
        n = len(pool)
        scored = []
        # the candidates in forked workers (jointrig.parallel; the same numbers, in order), as the
        # two flywheels' causes are scored
        for k, (cand, s) in enumerate(zip(pool, fork_map(lambda c: score(problem, c, current, wcur, n, alpha), pool,
                                                         workers)), start=1):
            scored.append(s)
            if progress is not None:
                progress(k, n, cand.label)
        return parsimonious(sorted(scored, key=lambda s: (bool(s.note), -s.score)), causes_by_name, current.n_rows,
                            alpha, place_of=lambda s: s.where)

    adopted: list[Candidate] = []

    def adopt(base, scored):
        best = next((s for s in scored if s.significant), None)
        if best is None:
            return None
        adopted.append(by_label[best.label])
        profiled = base[0].profiled + best.fit.profiled
        current, wcur = problem.fit(best.fit.spec)
        current = replace(current, profiled=profiled, profiled_correlation=base[0].profiled_correlation)
        # (a twist's zero beside a joint balanced where it slides is profiled again too: there it
        # weighs the spring's whole torque, which the nominal fit had wrong without the friction)
        if sum(c.cause.bounds is not None for c in zeros + adopted) > 1 or (zeros and problem.slipping()):
            current, wcur = _refine(problem, zeros + adopted, current, wcur)
        return best, (current, wcur)

    def rivals_of(base, best, scored, pool):
        current, wcur = base
        for rival in scored:
            if rival is best or not rival.significant or rival.score < 0.5 * best.score:
                continue
            a, b = by_label[best.label], by_label[rival.label]
            if a.cause.reduces_to == b.cause.name or b.cause.reduces_to == a.cause.name:
                continue  # nested at one place: parsimony (_reduced) decides between them
            r_given_b = score(problem, b, current, wcur, len(pool), alpha)
            rival_fit, wr = problem.fit(rival.fit.spec)
            b_given_r = score(problem, a, rival_fit, wr, len(pool), alpha)
            if not r_given_b.significant and not b_given_r.significant:
                ambiguous.append(separating_drive(problem, a, b, best, rival))

    chosen = forward_select((nominal, w), pool, rank=rank, adopt=adopt, after=rivals_of,
                            max_effects=max_effects, name_of=lambda s: s.label)
    steps, (current, wfinal) = _reduced(problem, structure, adopted, list(chosen.adopted), chosen.rounds, chosen.base,
                                        alpha, by_label, zeros)
    nominal, w = problem.settled(nominal, w)
    nominal = _widened(problem, zeros, problem.compensated(nominal, w), w)
    if steps:
        current, wfinal = problem.settled(current, wfinal)
    current = _widened(problem, zeros + adopted, problem.compensated(current, wfinal), wfinal) if steps else nominal
    first = chosen.rounds[0] if chosen.rounds else ()
    channels = sorted({ch for r in runs for ch in r.noise_std})
    noise = {ch: float(np.median([r.noise_std[ch] for r in runs if ch in r.noise_std])) for ch in channels}
    masks = problem.masks() or ()
    rests = tuple((k, i + 1, rest_share(runs[k].average.rate(i)), 1.0 - float(np.mean(m)))
                  for k, ms in enumerate(masks) for i, m in enumerate(ms) if m is not None)
    slips = problem.slipping()
    stuck = tuple((k, j + 1, rest_share(runs[k].average.rate(j) - runs[k].average.rate(j + 1)),
                   twist_resolved(runs[k], j), 1.0 - float(np.mean(slips[k][j])) if slips[k][j] is not None else 1.0)
                  for k, js in enumerate(problem.merged() or ()) for j in js)
    return ChainDiagnosis(nominal, first, tuple(steps), current, tuple(ambiguous), H, noise, nu,
                          implausible_train_fit(nominal, current), rests, stuck, fidelity, masked, merging, max_effects,
                          chosen.rounds[-1] if len(chosen.rounds) > len(chosen.adopted) else (), alpha,
                          _on_bounds(problem, adopted, current) if steps else ())


def _on_bounds(problem: _Problem, adopted: Sequence[Candidate], fit: ChainFit) -> tuple:
    """:attr:`ChainDiagnosis.on_bounds` of the adopted causes' profiled parameters in ``fit``,
    each against the search range :func:`_profile` gave it (:func:`_search_range`; the twists'
    zeros are no adopted cause)."""
    values = {n: v for n, v, _ in fit.profiled}
    out = []
    for cand in adopted:
        name = cand.profiled_name()
        if cand.cause.bounds is None or name not in values:
            continue
        _, lo, hi = _search_range(problem, cand)
        side = on_search_bound(values[name], lo, hi, cand.cause.log_scale)
        if side:
            out.append((name, side, lo if side == "lower" else hi))
    return tuple(out)


def _reduced(problem: _Problem, structure: ChainSpec, adopted: list, steps: list, rounds: Sequence, base: tuple,
             alpha: float, by_label: dict, zeros: Sequence[Candidate] = ()) -> tuple[list, tuple]:
    """Parsimony in the final model: an adopted cause that reduces to a simpler one at its place
    (``Cause.reduces_to``: a Stribeck friction to dry friction) gives way to it where its extra
    parameters no longer lower chi-square significantly beside the other causes (the nested test
    of :func:`identify.causes.parsimonious`, on the final model, with the weights' degrees of
    freedom as every cause's test has them), or where its own size is not told from zero
    (:func:`identify.causes.resolved`). A Stribeck peak adopted first may only stand for free
    play found after it: on the worn two flywheels (60 N m of dry friction, +-0.03 rad of free
    play) its excess fell from 129 +- 77 to 1.8 +- 8.4 N m once the free play was in. From six
    periods of the same joint the extra parameters lower chi-square by 20.9 (p 6e-4 with the
    weights' 10 degrees of freedom) with an excess of 25.5 +- 13.0 N m beside a sliding friction
    of 34.8 +- 12.9: a broad fall-off (7.9 rad/s) the runs do not tell from level friction, so
    dry friction is named. ``zeros``: the twists' zeros profiled beside the causes, kept at their
    final values in every model compared and profiled again with the causes after a change.
    Returns the steps and the final fit with its weights."""
    current, weights = base

    def refit(spec, profiled):
        fit, w = problem.fit(spec)
        fit = replace(fit, profiled=profiled)
        if any(c.cause.bounds is not None for c in list(zeros) + adopted):  # profiled beside the cause gone: again
            fit, w = _refine(problem, list(zeros) + adopted, fit, w)
        return fit, w

    for k, (cand, step) in enumerate(zip(list(adopted), list(steps))):
        simpler = next((s for s in rounds[k] if s.effect == cand.cause.reduces_to and s.where == step.where), None)
        if simpler is None:
            continue
        values = {n: v for n, v, _ in current.profiled}
        keep = [c if c is not cand else by_label[simpler.label] for c in adopted]
        spec = _with_causes(structure, list(zeros) + keep, values)
        alt = problem.solve(spec, weights)
        # the drop tested as every cause's is (:func:`score`): with weights estimated from the
        # periods' spread it is heavier-tailed than chi-square
        nu_eff = _drop_dof(problem, current, alt, weights)
        nu = problem.nu if math.isfinite(nu_eff) else math.inf
        # ... and the richer cause stays only where its own size (a Stribeck peak's excess over
        # the sliding friction) is told from zero by its standard error at the same level
        _, size, se = cand.cause.magnitude_of(current.parameters(), current.std_error, cand.prefix)
        if evidence(alt.chi2 - current.chi2, step.n_params - simpler.n_params, current.n_rows, alpha, 1, nu,
                    nu_eff)[2] and resolved(size, se, alpha):
            continue
        adopted[:] = keep
        steps[k] = simpler
        current, weights = refit(spec, tuple(p for p in current.profiled if p[0] != cand.profiled_name()))
    tests = [max(len(r), 1) for r in rounds[:len(adopted)]]  # each adoption's candidates
    while len(adopted) > 1:
        weakest = _weakest(problem, structure, zeros, adopted, steps, tests, current, weights, alpha)
        if weakest is None:
            break
        k, spec = weakest
        profiled = tuple(p for p in current.profiled if p[0] != adopted[k].profiled_name())
        del adopted[k], steps[k], tests[k]
        current, weights = refit(spec, profiled)
    return steps, (current, weights)


def _with_causes(structure: ChainSpec, cands: Sequence[Candidate], values: dict) -> ChainSpec:
    """``structure`` extended by ``cands``, each profiled parameter at its value in ``values``
    (pure)."""
    spec = structure
    for c in cands:
        spec = c.extend(spec, values.get(c.profiled_name(), 0.0) if c.profiled_name() else 0.0)
    return spec


def _weakest(problem: _Problem, structure: ChainSpec, zeros: Sequence, adopted: Sequence, steps: Sequence, tests: Sequence,
             current: ChainFit, weights: np.ndarray, alpha: float) -> Optional[tuple]:
    """The adopted cause the final model can do without (``(index, the spec without it)``), or
    None: each one's removal is tested as its adoption was (:func:`score`: the drop its refit
    loses, at ``alpha`` over its round's candidates and its search's trials), and the one with the
    largest p that is no longer significant goes, until every one left is (a cause left alone
    stays: its first round tested it against the nominal model already). A cause
    adopted early may only stand for one found after it: a drag to ground taken before a
    carriage's dry friction lowers chi-square by 6.8e4 against the nominal model, and nothing
    beside it (``tests/test_chain_diagnose.py``)."""
    values = {n: v for n, v, _ in current.profiled}
    worst = None
    for k, (cand, step) in enumerate(zip(adopted, steps)):
        spec = _with_causes(structure, list(zeros) + [c for c in adopted if c is not cand], values)
        alt = problem.solve(spec, weights)
        nu_eff = _drop_dof(problem, alt, current, weights)
        nu = problem.nu if math.isfinite(nu_eff) else math.inf
        trials = cand.cause.n_trials(_twist_runs(problem, cand)) if cand.cause.trials is not None else 1.0
        _, p, significant = evidence(alt.chi2 - current.chi2, step.n_params, current.n_rows, alpha, tests[k] * trials,
                                     nu, nu_eff)
        if not significant and (worst is None or p > worst[0]):
            worst = (p, k, spec)
    return None if worst is None else worst[1:]


#: A fitted value this many standard errors on the wrong side of zero is no body's or joint's.
IMPLAUSIBLE_SE = 2.0


@dataclass(frozen=True)
class ReadWrong:
    """A train's fit that says its file was read wrong: inertias that are no body's and joints whose
    stiffness or damping is significantly negative (they would feed energy in). Likely causes:
    position columns out of the bodies' order (two swapped give both), a drive column on another
    body than its number says, or other units than the file says."""

    #: ``(body, inertia, standard error)`` of each inertia that is no body's (1-based bodies)
    bodies: tuple = ()
    #: the joints (1-based) with a negative stiffness or damping
    joints: tuple = ()


@dataclass(frozen=True)
class UndeterminedInertia:
    """Inertias within two standard errors of zero, with nothing else read wrong: the runs do not
    determine them (at too few drive frequencies an inertia and a stiffness act alike on a sine)."""

    #: ``(body, inertia, standard error)`` (1-based bodies)
    bodies: tuple


def implausible_train_fit(f: ChainFit, kept: Optional[ChainFit] = None) -> tuple:
    """What a train's fitted model says about how the data were read (pure): a :class:`ReadWrong`
    where an inertia is significantly below zero (no body's) or a joint's stiffness or damping is
    (it would feed energy in), and an :class:`UndeterminedInertia` where an inertia is within its
    errors of zero with nothing else read wrong; () where the fit is plausible. ``kept`` (default
    ``f``): the model whose inertias that is judged on (the extended one: a dry friction the
    nominal model lacks can hide a carriage's mass, 25 kg read as -2 +- 15)."""
    p = f.as_dict()
    N = f.spec.n_flywheels

    def listed(fit, bodies):
        return tuple((i, fit.as_dict()[inertia_name(i)], fit.std_error(inertia_name(i))) for i in bodies)

    lows = [i for i in range(1, N + 1) if not p[inertia_name(i)] > IMPLAUSIBLE_SE * f.std_error(inertia_name(i))]
    negative = [i for i in lows if p[inertia_name(i)] < -IMPLAUSIBLE_SE * f.std_error(inertia_name(i))]
    joints = []
    for j in range(1, N):
        for name in ("k_Nm_per_rad", "c_Nms_per_rad"):
            key = joint_prefix(j) + name
            if key in p and p[key] < -IMPLAUSIBLE_SE * f.std_error(key):
                joints.append(j)
                break
    # beside something read wrong, an undetermined inertia is part of it (swapped columns give both)
    if kept is not None and not (negative or joints):
        f, p = kept, kept.as_dict()
        lows = [i for i in range(1, N + 1) if not p[inertia_name(i)] > IMPLAUSIBLE_SE * f.std_error(inertia_name(i))]
    bodies, unknown = (lows, []) if negative or joints else ([], lows)
    out: list = []
    if bodies or joints:
        out.append(ReadWrong(listed(f, bodies), tuple(joints)))
    if unknown:
        out.append(UndeterminedInertia(listed(f, unknown)))
    return tuple(out)


def drive_information(J_kgm2, c_Nms_per_rad, k_Nm_per_rad, omegas_rad_s, torque_Nm: float, sigma_Nm: float,
                      first: tuple, second: tuple, *, n_harmonics: int = 5) -> dict[int, float]:
    """How well a drive at each flywheel tells two effects at different places apart (pure).

    The linear chain (inertias ``J``, each joint's ``c`` and ``k``) driven by ``torque_Nm cos(w t)``
    at flywheel d moves as ``X = Z(w)^-1 e_d torque``. Each effect's own torque along that motion
    enters the balance rows of harmonics 1..n_harmonics: a joint effect ``("joint", j, law)``
    (``law``: a :class:`vocab.law.JointLaw` of the effect's own torque) with + on flywheel j
    and - on j+1, a drag ``("flywheel", i, b_Nms_per_rad)`` on flywheel i. The information that
    separates them at one frequency is the squared norm of the part of either effect's rows that
    the other cannot take up (the smaller of the two), over the rows' noise ``sigma_Nm^2``; it
    is summed over the frequencies. (The nominal law's own columns, which could absorb part of
    an effect, are left out: the figure ranks drive locations, it is not a significance.)

    Returns: flywheel (1-based) -> information.
    """
    J = np.asarray(J_kgm2, dtype=float)
    c, k = np.asarray(c_Nms_per_rad, dtype=float), np.asarray(k_Nm_per_rad, dtype=float)
    N = J.size
    M = 256
    t = np.arange(M) / M * 2 * math.pi
    H = n_harmonics

    def rows(effect, X, w):
        kind, place, what = effect
        vec = np.zeros((N, 2 * H))
        if kind == "joint":
            z = X[place - 1] - X[place]
            extra = np.asarray(what.torque(np.real(z * np.exp(1j * t)), np.real(1j * w * z * np.exp(1j * t))),
                               dtype=float)
            C = np.fft.rfft(np.broadcast_to(extra, t.shape))[1:H + 1] / M * 2
            row = np.concatenate([C.real, C.imag])
            vec[place - 1] += row
            vec[place] -= row
        else:
            C = 1j * w * X[place - 1] * what
            vec[place - 1, 0], vec[place - 1, H] = C.real, C.imag
        return vec.ravel()

    out = {}
    for drive in range(1, N + 1):
        info = 0.0
        for w in omegas_rad_s:
            Z = -w**2 * np.diag(J).astype(complex)
            for j in range(N - 1):
                Z[j:j + 2, j:j + 2] += (k[j] + 1j * w * c[j]) * np.array([[1, -1], [-1, 1]])
            X = np.linalg.solve(Z, np.eye(N)[drive - 1] * torque_Nm)
            u, v = rows(first, X, w), rows(second, X, w)
            uu, vv = float(u @ u), float(v @ v)
            if uu > 0 and vv > 0:
                ru = v - (u @ v) / uu * u  # the part of v that u cannot take up
                rv = u - (u @ v) / vv * v
                info += min(float(ru @ ru), float(rv @ rv)) / sigma_Nm**2
        out[drive] = info
    return out


def separating_drive(problem: _Problem, a: Candidate, b: Candidate, sa: CauseScore, sb: CauseScore) -> Ambiguity:
    """Which flywheel to drive so that two candidates at different places tell apart:
    :func:`drive_information` with the nominal fit's linear chain, the measured runs'
    frequencies and median drive torque, the torque noise, and each candidate's fitted effect.
    Two causes at one place move alike under every drive: their ambiguity names the runs that
    tell them apart instead (:func:`identify.causes.separating_excitation`). Returns their
    :class:`identify.causes.Ambiguity`."""
    from .causes import AT_CHANNEL, SAME_PLACE, TO_GROUND, separating_excitation

    effects = (sa.label, sb.label)
    if sa.where == sb.where:
        return Ambiguity(effects, unplaced=SAME_PLACE, excitation=separating_excitation(a.cause.name, b.cause.name))
    N = problem.runs[0].average.n_flywheels
    if a.ground or b.ground:
        return Ambiguity(effects, unplaced=TO_GROUND)
    if a.at_drive or b.at_drive or a.at_channel or b.at_channel:
        return Ambiguity(effects, unplaced=AT_CHANNEL)
    base = problem.fit(nominal_spec(N))[0].as_dict()
    J = [base[inertia_name(i)] for i in range(1, N + 1)]
    c = [base[joint_prefix(j) + "c_Nms_per_rad"] for j in range(1, N)]
    k = [base[joint_prefix(j) + "k_Nm_per_rad"] for j in range(1, N)]
    runs = problem.runs
    torque = float(np.median([max(float(np.ptp(t)) / 2 for t in r.average.torques_Nm if t is not None) for r in runs]))
    sigma = float(np.median([max(v for kk, v in r.noise_std.items() if kk.startswith("torque")) for r in runs])) or 1.0

    def effect(cand, sc):
        if cand.at_joint:
            return ("joint", cand.place, _effect_law(cand, sc))
        return ("flywheel", cand.place, sc.magnitude[1])

    infos = drive_information(J, c, k, [r.average.omega_rad_s for r in runs], torque, sigma, effect(a, sa),
                              effect(b, sb))
    best = max(infos, key=infos.get)
    return Ambiguity(effects, best, tuple(sorted(infos.items(), key=lambda x: -x[1])))


@dataclass(frozen=True)
class _OwnTorque:
    """A candidate's own joint torque: the extended joint law minus the nominal terms it holds, at
    the extended values (free play's own torque is the elastic torque with the gap minus the one
    without; an added term's, that term's)."""

    law: JointLaw
    without: JointLaw

    def torque(self, phi, rate):
        return self.law.torque(phi, rate) - self.without.torque(phi, rate)


def _effect_law(cand: Candidate, sc: CauseScore) -> _OwnTorque:
    """A candidate's own joint torque at its fitted size (:class:`_OwnTorque`)."""
    joint = sc.fit.spec.joints[cand.place - 1]
    vals = sc.fit.as_dict()
    pre = joint_prefix(cand.place)
    law = JointLaw(joint, tuple(vals[pre + t.name] for t in joint))
    nominal = tuple(t for t in nominal_spec(2).joints[0] if pre + t.name in vals)
    return _OwnTorque(law, JointLaw(nominal, tuple(vals[pre + t.name] for t in nominal)))


def with_constants(spec: ChainSpec, masks: Optional[Sequence]) -> ChainSpec:
    """``spec`` with a constant torque (force) to ground (:class:`vocab.law.Constant`) on every
    body whose equation is masked where it rests in some run (pure): its drive cell's offset and
    a constant load (gravity on an axis, a cable's drag) then enter every harmonic of the mask.
    Left out, on a servo-driven carriage that stands still 4% of its period with 16 N of gravity
    and 30 N of friction, they bent the mass to 25.8 and the drag to 120 instead of 25 and 150
    (the exact states, balanced by hand); with it, 25.04 and 150.6. A body masked in no run loses
    its constant (a replay that never rests: its column would be all zero)."""
    grounds = []
    for i, g in enumerate(spec.grounds):
        rest = tuple(t for t in g if not isinstance(t, Constant))
        grounds.append(rest + (Constant(),) if masks is not None and any(ms[i] is not None for ms in masks) else rest)
    return replace(spec, grounds=tuple(grounds))


def plant_and_inertias(f: ChainFit) -> tuple[ChainPlant, tuple[float, ...]]:
    """The identified plant (laws, bearings clipped at 0) and inertias, ready for the rig."""
    vals = f.as_dict()
    laws = tuple(JointLaw(terms, tuple(vals[joint_prefix(j) + t.name] for t in terms))
                 for j, terms in enumerate(f.spec.joints, start=1))
    N = len(laws) + 1
    bearings = tuple(max(0.0, vals.get(bearing_name(i), 0.0)) for i in range(1, N + 1))
    return (ChainPlant(laws, bearings, ground_laws(vals, f.spec), f.spec.drive_delay_s),
            tuple(vals[inertia_name(i)] for i in range(1, N + 1)))


# --------------------------------------------------------------------------------------------
# 5. An unexplained misfit: where in the train, and what it looks like

def _resolved(run: ChainRun, pick) -> np.ndarray:
    """A channel's period average on the harmonics that stand out of its period-to-period spread
    (:data:`identify.periods.RESOLVED_SIGMA`): a residual's torque is read from these alone, as
    the unresolved ones' noise would be raised (n omega)^2 times by the inertia term."""
    from .periods import RESOLVED_SIGMA, pooled_period_spectra

    P = len(run.periods)
    if P > 1:
        _, mean, var = pooled_period_spectra(np.concatenate([pick(p) for p in run.periods]), P)
    else:
        mean, var = np.fft.rfft(pick(run.average)) / FINE_SAMPLES, np.zeros(FINE_SAMPLES // 2 + 1)
    keep = np.abs(mean) > RESOLVED_SIGMA * np.sqrt(var)
    keep[0] = True  # the mean position: a law to ground or a free play reads it
    return np.fft.irfft(np.where(keep, mean, 0) * FINE_SAMPLES, n=FINE_SAMPLES)


def carried_torques(xs: Sequence[np.ndarray], drives: Sequence, omega_rad_s: float, plant: ChainPlant,
                    inertias_kgm2: Sequence[float], band: int) -> list:
    """Per place, harmonics 0..``band`` of the torque it carries over one period, from the
    equations of motion of the bodies before it (pure): at joint j, ``sum_(i <= j) (T_i + J_i (n
    w)^2 X_i - i n w b_i X_i - G_i)``; a single body's place (what holds it to the frame): ``T + m
    (n w)^2 X``, its drag and law to ground being the place's law. ``xs``: one period of every
    body's position; ``drives``: its drive over that period, or None."""
    from .balance import spectral_rate
    from .harmonics import fourier_coefficients

    N = len(inertias_kgm2)
    nw = np.arange(band + 1) * omega_rad_s
    out, net = [], np.zeros(band + 1, complex)
    for i in range(N):
        X = fourier_coefficients(xs[i], 1, band)
        if drives[i] is not None:
            net = net + fourier_coefficients(drives[i], 1, band)
        net = net + inertias_kgm2[i] * nw**2 * X
        if N == 1:
            return [net]
        net = net - 1j * nw * plant.bearings_Nms_per_rad[i] * X
        g = plant.grounds[i]
        if g is not None:
            net = net - fourier_coefficients(np.asarray(g.torque(xs[i], spectral_rate(xs[i], omega_rad_s, 1)), float),
                                             1, band)
        if i < N - 1:
            out.append(net.copy())
    return out


def _same_mean(model: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """The model's torque with the measured one's mean: the balance fits harmonics 1 and up, so a
    constant torque (a law read at encoders' arbitrary zero) is no misfit."""
    return model - float(np.mean(model)) + float(np.mean(measured))


def _overall(c) -> float:
    """A place's residual RMS over its measured torque's, over all runs together (the runs where
    the place carries most weigh most: a run whose torque there is nearly nil says little)."""
    measured = [r / q for r, q in zip(c.rms_Nm, c.relative) if q > 0]
    return math.sqrt(sum(r * r for r in c.rms_Nm) / max(sum(m * m for m in measured), 1e-300))


@dataclass(frozen=True)
class TrainMisfit:
    """Where a train's unexplained misfit is and what it looks like.

    Attributes:
      where: the place it is largest at: ``"joint j"``, or ``"body 1 to ground"`` for a single body.
      by_place: per place, the residual's RMS over the measured torque's, over all runs together.
      character, surface, next_measurements: at ``where`` (:mod:`identify.misfit`).
      kind, single: how the bodies move (a :class:`vocab.params.Coordinate`) and whether the place
        is a single body's law to the frame: the words of its quantities
        (:func:`present.misfit_words.words_of`).
    """

    where: str
    by_place: tuple
    character: object
    surface: object
    next_measurements: tuple
    kind: Coordinate = HINGE
    single: bool = False
    #: the residual at every sample of every run there (:class:`identify.misfit.ResidualSamples`)
    samples: object = field(default=None, repr=False)


def train_misfit(runs: Sequence[ChainRun], run_ids: Sequence[str], amplitudes: Sequence[float],
                 fit: ChainFit, band: int, kind: str = HINGE) -> TrainMisfit:
    """``fit``'s residual torque at every joint (a single body: at its law to ground) along each
    run's measured motion, its resolved harmonics (pure): the torque a joint carries
    (:func:`carried_torques`, with the fit's values) minus the joint's law at the measured twist; then the place where it is largest,
    described by :func:`identify.misfit.misfit_character` (harmonics 1..``band``) and its
    restoring-force surface; ``kind``: how the bodies move (a :class:`vocab.params.Coordinate`), for the words and units."""
    from .balance import spectral_rate
    from .harmonics import synthesize
    from .misfit import ResidualRun, misfit_character, next_measurements, residual_samples, residual_surface

    plant, J = plant_and_inertias(fit)
    N = len(J)
    per_place: list[list[ResidualRun]] = [[] for _ in range(max(N - 1, 1))]
    for run, rid, amp in zip(runs, run_ids, amplitudes):
        w = run.average.omega_rad_s
        x = [_resolved(run, lambda r, i=i: r.angles_rad[i]) for i in range(N)]
        drives = [_resolved(run, lambda r, i=i: r.torques_Nm[i]) if run.average.torques_Nm[i] is not None else None
                  for i in range(N)]
        v = [spectral_rate(xi, w, 1) for xi in x]
        carried = [synthesize(c, FINE_SAMPLES) for c in carried_torques(x, drives, w, plant, J, band)]
        for k, measured in enumerate(carried):
            if N == 1:  # a single body: what holds it to the frame (drag and law to ground) is the place
                motion, model = x[0], plant.bearings_Nms_per_rad[0] * v[0]
                if plant.grounds[0] is not None:
                    model = model + np.asarray(plant.grounds[0].torque(x[0], v[0]), float)
            else:
                motion = x[k] - x[k + 1] - fit.spec.offsets_rad[k]
                model = np.asarray(plant.laws[k].torque(motion, v[k] - v[k + 1]), float)
            per_place[k].append(ResidualRun(rid, w, amp, motion, measured, _same_mean(model, measured)))
    names = ["body 1 to ground"] if N == 1 else [f"joint {j}" for j in range(1, N)]
    chars = [misfit_character(rs, band) for rs in per_place]
    by_place = tuple((n, _overall(c)) for n, c in zip(names, chars))
    k = int(np.argmax([r for _, r in by_place]))
    surface = residual_surface(per_place[k])
    return TrainMisfit(names[k], by_place, chars[k], surface, next_measurements(chars[k], surface, per_place[k]),
                       Coordinate(kind), N == 1, residual_samples(per_place[k]))


# --------------------------------------------------------------------------------------------
# 6. The joint card of every place


def place_law(fit: ChainFit, place: int) -> tuple[JointLaw, float]:
    """``(law, inertia of its mode)`` at a place (0-based): joint j's law and ``J_j J_j+1 / (J_j +
    J_j+1)``, the mode of its two bodies alone; a single body's drag and law to ground and its mass."""
    plant, J = plant_and_inertias(fit)
    if len(J) == 1:
        (g,), (drag,) = plant.grounds, plant.bearings_Nms_per_rad
        terms, values = list(g.terms if g is not None else ()), list(g.values if g is not None else ())
        viscous = _viscous_at(terms)
        if viscous is None:
            terms, values = terms + [Viscous()], values + [drag]
        else:  # the law's own damping (the relative-angle form's joint) holds the drag too
            values[viscous] += drag
        return JointLaw(tuple(terms), tuple(values)), J[0]
    return plant.laws[place], J[place] * J[place + 1] / (J[place] + J[place + 1])


def _viscous_at(terms) -> Optional[int]:
    """The index of a law's viscous term, None without one."""
    return next((k for k, t in enumerate(terms) if isinstance(t, Viscous)), None)


#: A joint's twist zero is read from the data where a nonlinear elastic term of its law stands
#: this many standard errors clear of 0 (a free play always): a spurious cubic of 2 standard
#: errors on a linear shaft read a 200 N m preload as -36 +- 26 N m.
ZERO_RESOLVED_SE = 3.0


def zero_resolved(fit, j: int) -> bool:
    """Whether the data determine joint ``j``'s twist zero in ``fit`` (:data:`ZERO_RESOLVED_SE`)."""
    vals = fit.as_dict()
    for t in fit.spec.joints[j - 1]:
        if isinstance(t, Power) and t.gap_rad > 0:
            return True
        if t.elastic and isinstance(t, Power) and t.power > 1:
            name = joint_prefix(j) + t.name
            se = fit.std_error(name)
            if math.isfinite(se) and abs(vals[name]) > ZERO_RESOLVED_SE * se:
                return True
    return False


def mean_joint_torque(fit: ChainFit, records: Sequence[ChainRecord], j: int, *,
                      with_error: bool = True) -> tuple[float, float]:
    """The mean torque (N m; N on a slide) joint ``j`` (1-based) carries in its elastic terms over
    ``records``, by the fitted law along their twists less the fitted zero, and its standard
    error: from the linear parameters' covariance and the zero's own (its profile's). A preload:
    what a mean load passes through the joint (pure). The dissipative terms are left out: a
    damping's mean is 0, and a dry friction's, read from sign(rate) while the joint rests, would
    be the noise's. Meaningful where the data determine the twist's zero (:func:`zero_resolved`);
    elsewhere a linear law reads 0 whatever the load. ``with_error=False``: the standard error is
    NaN, not computed (a replay's constant needs the value alone)."""
    from .chain import _law_coeffs

    terms, names = fit.spec.joints[j - 1], list(fit.names)
    vals = fit.as_dict()

    def columns(offset: float) -> np.ndarray:
        col = np.zeros(len(names))
        for rec in records:
            for t, c in zip(terms, _law_coeffs(channel_corrected(rec, fit.spec), j - 1, terms, 0, 1, offset)):
                if t.elastic:
                    col[names.index(joint_prefix(j) + t.name)] += float(c[0].real) / len(records)
        return col

    theta = np.array([vals[n] for n in names])
    delta = fit.spec.offsets_rad[j - 1]
    col = columns(delta)
    q = float(col @ theta)
    if not with_error:
        return q, math.nan
    var = float(col @ fit.covariance @ col) if fit.covariance is not None else float(
        np.sum((col * np.asarray(fit.std_errors)) ** 2))
    se_zero = {n: e for n, _, e in fit.profiled}.get(joint_prefix(j) + TWIST_ZERO.profiled, 0.0)
    if se_zero and math.isfinite(se_zero):
        step = max(1e-3 * se_zero, 1e-9)
        slope = float((columns(delta + step) - columns(delta - step)) @ theta) / (2 * step)
        var += (slope * se_zero) ** 2
    return q, math.sqrt(max(var, 0.0)) if math.isfinite(var) else math.nan


def place_covariance(fit: ChainFit, place: int) -> Optional[np.ndarray]:
    """The covariance of ``(inertia of the mode, law values)`` of :func:`place_law` at a place
    (0-based), from the fit's (the mode's inertia to first order in the two bodies'), or None
    when the fit has none. A drag clipped at 0 has no row."""
    if fit.covariance is None:
        return None
    T = _place_map(fit, place)
    return T @ fit.covariance @ T.T


def _place_map(fit: ChainFit, place: int) -> np.ndarray:
    """The first-order map from the fit's values to ``(inertia of the mode, law values)`` at a
    place (:func:`place_covariance`)."""
    law, _ = place_law(fit, place)
    idx = {n: i for i, n in enumerate(fit.names)}
    vals = fit.as_dict()
    if fit.spec.n_flywheels == 1:  # per law value, the fit's parameters it sums (see place_law)
        names = [[ground_prefix(1) + t.name] for t in fit.spec.grounds[0]]
        viscous = _viscous_at(fit.spec.grounds[0])
        if viscous is None:
            names.append([bearing_name(1)])
        else:
            names[viscous].append(bearing_name(1))
        inertia = {inertia_name(1): 1.0}
    else:
        Ja, Jb = vals[inertia_name(place + 1)], vals[inertia_name(place + 2)]
        names = [[joint_prefix(place + 1) + t.name] for t in fit.spec.joints[place]]
        inertia = {inertia_name(place + 1): (Jb / (Ja + Jb)) ** 2, inertia_name(place + 2): (Ja / (Ja + Jb)) ** 2}
    T = np.zeros((1 + len(law.values), len(fit.names)))
    for n, g in inertia.items():
        T[0, idx[n]] = g
    for r, ns in enumerate(names):
        for n in ns:
            if n in idx and (len(ns) > 1 or vals[n] == law.values[r]):  # a drag clipped at 0 is not the fit's value
                T[1 + r, idx[n]] = 1.0
    return T


def place_uncertainty(fit: ChainFit, place: int) -> tuple[Optional[np.ndarray], tuple]:
    """``(covariance, shapes)`` for a quantity of a place's law that depends on its profiled
    parameters too (a joint card's model rows: :func:`identify.card.law_card`'s ``shapes``).

    ``shapes`` holds ``(terms below, terms above, step)`` of each profiled parameter that shapes
    the place's law (a slip angle, a free play, a Stribeck speed; not a twist's zero), its law's
    terms at the value minus and plus ``step``; ``covariance`` is over ``(inertia of the mode, law
    values, those parameters)``: :func:`place_covariance`'s, the values' covariance with them
    (:attr:`ProfiledSpread.cross`) and theirs. With the widened values' covariance alone and the
    law held at its profiled shape, a card row that the fit pins along the profile (the values
    move to keep it) had its uncertainty counted where it cancels, and one that the shape sets
    directly lost it. Without a spread (nothing profiled) it is :func:`place_covariance`'s."""
    cov = place_covariance(fit, place)
    spread = fit.profiled_spread
    if cov is None or spread is None:
        return cov, ()
    law, _ = place_law(fit, place)
    keep, shapes = [], []
    for k, (below, above, step) in enumerate(zip(spread.below, spread.above, spread.steps)):
        lb, la = (place_law(replace(fit, spec=s), place)[0] for s in (below, above))
        if (lb.terms == law.terms and la.terms == law.terms) or not (len(lb.values) == len(la.values) == len(law.values)):
            continue
        keep.append(k)
        shapes.append((lb.terms, la.terms, float(step)))
    if not keep:
        return cov, ()
    cross = _place_map(fit, place) @ spread.cross[:, keep]
    return np.block([[cov, cross], [cross.T, spread.covariance[np.ix_(keep, keep)]]]), tuple(shapes)


def train_joint_runs(runs: Sequence[ChainRun], run_ids: Sequence[str], fit: ChainFit, band: int) -> list:
    """Per place (every joint; a single body: what holds it to the frame), each run as its card
    reads it (:class:`identify.card.JointRun`): per period, the twist's harmonics 0..``band`` (a
    single body: its position's) and the torque the place carries (:func:`carried_torques`, with
    the fit's values) (pure)."""
    from .card import JointRun
    from .harmonics import fourier_coefficients

    plant, J = plant_and_inertias(fit)
    N = len(J)
    places: list[list] = [[] for _ in range(max(N - 1, 1))]
    for run, rid in zip(runs, run_ids):
        w = run.average.omega_rad_s
        phi: list[list] = [[] for _ in places]
        torque: list[list] = [[] for _ in places]
        for period in run.periods:
            period = channel_corrected(period, fit.spec)  # as the bodies moved
            X = [fourier_coefficients(period.angles_rad[i], 1, band) for i in range(N)]
            for k, c in enumerate(carried_torques(period.angles_rad, period.torques_Nm, w, plant, J, band)):
                phi[k].append(X[0] if N == 1 else X[k] - X[k + 1])
                torque[k].append(c)
        for k in range(len(places)):
            places[k].append(JointRun(str(rid), w, np.array(phi[k]), np.array(torque[k])))
    return places
