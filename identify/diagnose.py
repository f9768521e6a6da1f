"""What the nominal model gets wrong: rank physical causes by evidence and extend the model.

Pure functions (records in, frozen dataclasses out); the rig simulations that measure the
gain on held-out runs live in :mod:`studies.validate`.

1. **Prepare** every run (:func:`prepare_runs`): average its P periods in the frequency
   domain, estimate the noise variance of every Fourier coefficient from period-to-period
   variation (pooled over neighbouring harmonics), and keep harmonics 0..band (the band the
   harmonic balance uses). The law columns (sign, dead zone, play operator, ...) are
   evaluated on these averaged, band-limited angles, which cuts the noise entering [A]
   (errors in variables) by sqrt(P * N / (2 band + 1)); rates are exact spectral derivatives
   of the band.
2. **Weights**: each harmonic-balance row's noise variance is the period-to-period variance
   of that row's residual at the current parameters (``F_p - A_p theta`` over periods p,
   divided by P; cosine and sine rows pooled), so noise in [A] is counted too. With
   ``nu = 2 (P - 1)`` degrees of freedom per weight, a correct model has
   ``E[chi2] = dof * nu / (nu - 2)``; chi-square values are reported corrected by that factor.
3. **Nominal fit**: Je (or J1, J2) and ``c phi' + k phi + gamma phi^3`` (paper eq. 11) by
   weighted least squares.
4. **Causes** (:data:`CAUSES`): each adds columns to the nominal model (and, for backlash,
   hysteresis and drive delay, one nonlinear parameter found by a profile search). Its
   evidence is the drop in chi-square ``D``; it is *significant* when ``D`` exceeds the
   chi-square(q) quantile at ``alpha / n_causes`` (Bonferroni), and causes are ranked by
   ``score = D - q ln(n_rows)`` (BIC: twice the log Bayes factor against the nominal model),
   so an extra parameter must pay for itself.
5. **Extension**: the best significant cause is added; the rest are scored again on top of
   it; repeat until nothing significant is left. Every other significant cause of the
   round is tested against the chosen one both ways: if neither is significant given the
   other, the data cannot tell them apart, and the report says which excitation would.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from typing import Callable, Optional, Sequence

import numpy as np

from .balance import LinearSystem, assemble, spectral_rate
from jointrig.vocab.law import Coulomb, JointLaw, Power, Viscous, monotone_runs
from .harmonics import fourier_coefficients, max_harmonic, shift_periodic
from .periods import RESOLVED_SIGMA, pooled_period_spectra, raw_noise_std
from jointrig.vocab.plant import Plant, effect_parameters
from jointrig.vocab.records import RecordError, SteadyStateRecord
from .estimates import RowFit, weighted_chi2
from .solve import IllConditionedWarning, solve
from jointrig.vocab.params import J1, J2, JE, BEARING1, BEARING2
from .causes import (DEFAULT_SEPARATION, CAUSES, NOMINAL, SEPARATING_EXCITATION, TIE, Ambiguity, Cause, CauseScore,
                     Limits, ModelSpec, parsimonious, profile, evidence, forward_select, fundamental_quadrature,
                     harmonic_shares, rate_amplitudes)

__all__ = [
    "DEFAULT_FIDELITY", "kink_corrected_rate", "kink_first_pass", "KinkPass", "PreparedRun", "prepare_runs", "Fit",
    "CauseScore", "Diagnosis", "diagnose", "fit", "plant_of",
]


# --------------------------------------------------------------------------------------------
# 1. Preparation: averaging, noise, denoising


@dataclass(frozen=True)
class PreparedRun:
    """One run after averaging and denoising.

    Attributes:
      average: one period, the mean of the run's periods restricted to harmonics 0..band.
      raw_average: the period average with all harmonics.
      fine_average, fine_periods: ``average`` and each period alone (same band) on
        FINE_SAMPLES = OVERSAMPLE x 256 samples per period, whatever the record's rate (exact: they are band-limited). The law columns are
        evaluated on these, where a jump (dry friction) or a kink (free play) aliases
        16 times less than on 256 samples; ``fine_periods`` give the noise of every row.
      kept: channel ("torque", "phi1", "phi2", "phi" relative) -> the harmonics within the band
        that stand out of the noise.
      noise_std: channel -> noise standard deviation of one raw sample (same unit).
      phi_noise_var: noise variance of the period-averaged complex Fourier coefficient of the
        relative angle, per harmonic 0..N/2 (rad^2).
    """

    average: SteadyStateRecord
    raw_average: SteadyStateRecord
    fine_average: SteadyStateRecord
    fine_periods: tuple[SteadyStateRecord, ...]
    kept: dict
    noise_std: dict
    phi_noise_var: np.ndarray = field(repr=False)

    @property
    def n_periods(self) -> int:
        return len(self.fine_periods)


from .defaults import DEFAULT_FIDELITY  # noqa: E402  (model-fidelity floor; see diagnose)

#: Law columns are evaluated on 16x the samples (trigonometric interpolation of the band-limited
#: angle): a jump (dry friction) on 256 samples per period aliases at ~1/256 of its size,
#: enough to be "significant" at 40 dB; 16x brings that to ~2e-4.
OVERSAMPLE = 16

#: Samples per period of the fine grid (OVERSAMPLE times the rig's default 256).
FINE_SAMPLES = OVERSAMPLE * 256


def prepare_runs(records: Sequence[SteadyStateRecord], *, band: int = 20,
                 significance_sigma: float = RESOLVED_SIGMA) -> list[PreparedRun]:
    """Average, estimate noise and band-limit every record (see the module docstring).

    Args:
      band: harmonics 0..band are kept (the diagnosis balances the same band). Keeping only
        the harmonics that stand out of the noise would be less noisy but biased: a law column
        evaluated on a signal stripped of its weak harmonics predicts harmonics the data then
        lack (the cubic term becomes invisible, dry friction collapses onto viscous damping).
      significance_sigma: a harmonic counts as significant (listed in ``kept``, for the report)
        when its magnitude exceeds this many noise standard errors; 4 keeps a pure-noise
        harmonic out with probability about exp(-8) (complex Gaussian) each.

    Raises:
      RecordError: a record with fewer than 2 periods or too few samples for the band.
    """
    out = []
    for rec in records:
        P = rec.n_periods
        if P < 2:
            raise RecordError(f"{rec.source}: {P} period(s); the diagnosis needs at least 2 to estimate "
                              f"the noise from period-to-period variation")
        N = rec.samples_per_period
        H = N // 2
        if band > max_harmonic(N):
            raise RecordError(f"{rec.source}: {N} samples per period hold at most {max_harmonic(N)} harmonics; "
                              f"the diagnosis band is {band}")
        chans = {"torque": rec.torque_Nm, "phi1": rec.phi1_rad}
        if rec.phi2_rad is not None:
            chans["phi2"] = rec.phi2_rad
        in_band = np.arange(H + 1) <= band
        # The fine grid has the same size whatever the file's rate: the law columns alias alike.
        Nf = FINE_SAMPLES
        _, phi_mean, phi_var = pooled_period_spectra(rec.phi_rad, P)
        kept = {"phi": np.flatnonzero(in_band & (np.abs(phi_mean) > significance_sigma * np.sqrt(phi_var)))}
        noise, avg, raw, favg, fper = {}, {}, {}, {}, {}
        for name, x in chans.items():
            X, mean, var_mean = pooled_period_spectra(x, P)
            kept[name] = np.flatnonzero(in_band & (np.abs(mean) > significance_sigma * np.sqrt(var_mean)))
            noise[name] = raw_noise_std(var_mean, P, N)
            avg[name] = np.fft.irfft(np.where(in_band, mean, 0) * N, n=N)
            raw[name] = np.fft.irfft(mean * N, n=N)
            favg[name] = np.fft.irfft(np.where(in_band, mean, 0) * Nf, n=Nf)
            fper[name] = np.fft.irfft(np.where(in_band, X, 0) * Nf, n=Nf, axis=1)
        two = "phi2" in chans
        t1 = rec.time_s[:N]
        tf = rec.time_s[0] + np.arange(Nf) * (2 * math.pi / rec.omega_rad_s) / Nf

        def make(src, get, label, t=t1):
            return SteadyStateRecord(rec.omega_rad_s, t, get(src["torque"]), get(src["phi1"]),
                                     get(src["phi2"]) if two else None, n_periods=1,
                                     drive_amplitude_Nm=rec.drive_amplitude_Nm, source=f"{rec.source} {label}")

        out.append(PreparedRun(
            average=make(avg, lambda a: a, "(period average, band-limited)"),
            raw_average=make(raw, lambda a: a, "(period average)"),
            fine_average=make(favg, lambda a: a, "(period average, band-limited, oversampled)", tf),
            fine_periods=tuple(make(fper, lambda a, p=p: a[p], f"(period {p + 1}, band-limited, oversampled)", tf)
                               for p in range(P)),
            kept=kept, noise_std=noise, phi_noise_var=phi_var,
        ))
    return out


# --------------------------------------------------------------------------------------------
# 2. Models and fits


class _Columns:
    """The harmonic-balance columns of a set of band-limited one-period records (a problem's
    period averages, or one run's periods), each computed once.

    A structure (:class:`ModelSpec`) and the jump of the relative acceleration at a rate
    reversal (dry friction's kinks, :func:`kink_corrected_rate`) choose the columns; a column
    depends only on its own term and on the sensor corrections and jump it sees, so a profile
    search recomputes only the cause's columns and, with dry friction in the model, the columns
    of the terms nonlinear in the rate. In the band, a kink-corrected rate equals the
    band-limited one (the kinks add harmonics above the band only), so the inertia, torque,
    bearing and viscous columns never depend on the jump.

    The sensor corrections: the torque that acted is the recorded one delayed by the drive
    delay; flywheel 2's angle as it was is the reading divided by ``1 + angle2_gain_error`` and
    moved back by ``angle2_delay_s``; the law sees the relative angle minus ``angle_offset_rad``.
    """

    #: arrays of the records' size kept (angles and rates under a correction or a jump; a profile
    #: search asks for a few in turn, never back), oldest dropped first
    _BIG_KEPT = 16
    #: coefficient columns kept (a profile search adds tens), oldest dropped first
    _MEMO_MAX = 20000

    def __init__(self, records: Sequence[SteadyStateRecord], n_harmonics: int, form: str, torque_share: float):
        if len({r.n_samples for r in records}) != 1 or any(r.n_periods != 1 for r in records):
            raise ValueError("_Columns: the records must be single periods of one size (the fine grid)")
        self.H, self.form, self.torque_share = n_harmonics, form, torque_share
        self.omega = np.array([r.omega_rad_s for r in records])[:, None]
        self.jw = 1j * np.arange(n_harmonics + 1) * self.omega
        self.phi1 = np.stack([r.phi1_rad for r in records])
        two = all(r.phi2_rad is not None for r in records)
        self.phi2 = np.stack([r.phi2_rad for r in records]) if two else None
        self.torque = np.stack([r.torque_Nm for r in records])
        self._memo: dict = {}
        self._big: dict = {}  # arrays of the records' size, by key (a few kept)
        #: (gain, skew, jump) -> a jump whose kink-corrected rate was computed and has the signs of
        #: the one at ``jump`` in every sample (:meth:`same_system`)
        self._anchor: dict = {}

    def _fc(self, x: np.ndarray) -> np.ndarray:
        return fourier_coefficients(x, 1, self.H)

    def _get(self, key: tuple, compute, big: bool = False):
        store = self._big if big else self._memo
        hit = store.get(key)
        if hit is None:
            hit = compute()
            if len(store) >= (self._BIG_KEPT if big else self._MEMO_MAX):
                store.pop(next(iter(store)))
            store[key] = hit
        return hit

    def _phi2t(self, gain: float, skew_s: float) -> np.ndarray:
        """Flywheel 2's angle as it was."""
        def compute():
            x = self.phi2 if gain == 0 else self.phi2 * (1.0 / (1.0 + gain))
            return x if skew_s == 0 else shift_periodic(x, 1, self.omega, -skew_s)
        return self._get(("phi2", gain, skew_s), compute, big=True)

    def _phi(self, offset: float, gain: float, skew_s: float) -> np.ndarray:
        """The relative angle the law sees."""
        def compute():
            phi1 = self.phi1 - offset if offset else self.phi1
            return phi1 if self.phi2 is None else phi1 - self._phi2t(gain, skew_s)
        return self._get(("phi", offset, gain, skew_s), compute, big=True)

    def _rate2(self, gain: float, skew_s: float) -> np.ndarray:
        return self._get(("rate2", gain, skew_s), lambda: spectral_rate(self._phi2t(gain, skew_s), self.omega, 1),
                         big=True)

    def _rate(self, jump: float, gain: float, skew_s: float) -> np.ndarray:
        """The relative rate the law sees: the recorded relative rate with its kinks restored for
        ``jump`` (:func:`kink_corrected_rate`), flywheel 2's part corrected."""
        v = self._kinked(jump).rate_rad_s if jump > 0 else self._v_bl()
        if self.phi2 is None or (gain == 0 and skew_s == 0):
            return v
        return v + (self._rate2(0.0, 0.0) - self._rate2(gain, skew_s))

    def _v_bl(self) -> np.ndarray:
        return self._get(("v_bl",), lambda: spectral_rate(self._phi(0.0, 0.0, 0.0), self.omega, 1), big=True)

    def _first_pass(self) -> KinkPass:
        return self._get(("kink_first_pass",), lambda: kink_first_pass(self._phi(0.0, 0.0, 0.0), self.omega[:, 0],
                                                                       self.H, band_limited_rate=self._v_bl()))

    def _kinked(self, jump: float) -> "_Kinked":
        return self._get(("kinked", jump), lambda: _kinked(self._first_pass(), self.H, jump), big=True)

    def same_system(self, spec: ModelSpec, jump: float, other: float) -> bool:
        """True when :meth:`system` of ``spec`` at jump ``other`` equals the one at ``jump`` bit for
        bit: the only terms it holds that see the kinks are dry friction's, ``sign(rate)``, and the
        kink-corrected rate has the same signs at both jumps in every sample. Proven without the
        rate at ``other`` where it can be (:func:`_sign_proof`, the common case in a profile
        search: a trial's jump moves by 1e-6 to 1e-2 of itself), else compared."""
        seeing = [t for t in spec.terms if not (t.elastic or t.stateful or isinstance(t, Viscous))]
        if not seeing or any(type(t) is not Coulomb for t in seeing) or jump <= 0 or other <= 0:
            return False
        gain, skew = ((0.0, 0.0) if self.phi2 is None else (spec.angle2_gain_error, spec.angle2_delay_s))
        # the jump whose rate was computed, with the signs of the one at ``jump``
        anchor = self._anchor.get((gain, skew, jump), jump)
        here = self._rate(anchor, gain, skew)
        same = _sign_proof(self._first_pass(), self.H, self._kinked(anchor), anchor, other, here)
        if not same:
            there = self._rate(other, gain, skew)
            same = np.array_equal(here > 0, there > 0) and np.array_equal(here < 0, there < 0)
        if same:
            # the columns at ``other`` are those at ``jump``: the next trial, which starts at
            # ``other``, finds them without the rate there
            self._anchor[(gain, skew, other)] = anchor
            for t in seeing:
                key = ("law", t, spec.angle_offset_rad, gain, skew)
                col = self._memo.get(key + (jump,))
                if col is not None:
                    self._get(key + (other,), lambda: col)
        return same

    def law(self, term, offset: float, gain: float, skew_s: float, jump: float) -> np.ndarray:
        """Coefficients of one law term along the records, ``(n_records, H + 1)``."""
        angle_only = term.elastic or term.stateful
        if angle_only:
            key = (term, offset, gain, skew_s)
        elif isinstance(term, Viscous):  # linear in the rate: the kinks do not reach the band
            key, jump = (term, gain, skew_s), 0.0
        else:
            key = (term, offset, gain, skew_s, jump)

        def compute():
            phi = self._phi(offset, gain, skew_s)
            if term.stateful:
                # a term with sliders runs its play operator along each record, whose monotone
                # runs (the same for every trial of a profile search) are found once
                runs = self._get(("runs", offset, gain, skew_s), lambda: [monotone_runs(p) for p in phi])
                return self._fc(np.stack([term.along(p, r) for p, r in zip(phi, runs)]))
            # elementwise: all records in one call, the same numbers
            rate = np.zeros_like(phi) if angle_only else self._rate(jump, gain, skew_s)
            return self._fc(np.broadcast_to(np.asarray(term(phi, rate), dtype=float), phi.shape))
        return self._get(("law",) + key, compute)

    def system(self, spec: ModelSpec, jump: float) -> LinearSystem:
        """The rows of harmonics 1..H (not the mean: see :func:`diagnose`) of ``spec``."""
        offset, gain, skew, delay = (spec.angle_offset_rad, spec.angle2_gain_error, spec.angle2_delay_s,
                                     spec.drive_delay_s)
        if self.phi2 is None:
            gain = skew = 0.0
        law = [self.law(t, offset, gain, skew, jump) for t in spec.terms]
        jw = self.jw
        recorded = self._get(("torque", 0.0), lambda: self._fc(self.torque))
        torque = recorded if delay == 0 else self._get(("torque", delay), lambda: recorded * np.exp(-jw * delay))
        zero = np.zeros_like(torque)
        names = tuple(t.name for t in spec.terms)
        if self.form == "two_dof":
            acc1 = self._get(("acc1",), lambda: jw**2 * self._fc(self.phi1))
            acc2 = self._get(("acc2", gain, skew), lambda: jw**2 * self._fc(self._phi2t(gain, skew)))
            eq1, eq2 = [acc1, zero, *law], [zero, acc2, *(-c for c in law)]
            names = (J1, J2) + names
            if spec.bearings:
                eq1 += [self._get(("v1",), lambda: jw * self._fc(self.phi1)), zero]
                eq2 += [zero, self._get(("v2", gain, skew), lambda: jw * self._fc(self._phi2t(gain, skew)))]
                names += (BEARING1, BEARING2)
            return assemble(np.stack([np.stack(eq1), np.stack(eq2)], axis=2), np.stack([torque, zero], axis=1),
                            names, first_harmonic=1)
        if spec.bearings:
            raise ValueError("bearing drag needs both flywheel angles (form 'two_dof')")
        acc = self._get(("acc", offset, gain, skew), lambda: jw**2 * self._fc(self._phi(offset, gain, skew)))
        return assemble(np.stack([acc, *law])[:, :, None, :], (self.torque_share * torque)[:, None, :],
                        (JE,) + names, first_harmonic=1)


@dataclass(frozen=True)
class Fit(RowFit):
    """A weighted least-squares fit of one model structure.

    ``chi2`` is corrected for the estimated weights (module docstring, step 2).
    """

    spec: ModelSpec
    names: tuple[str, ...]
    values: np.ndarray
    std_errors: np.ndarray
    chi2: float
    n_rows: int
    condition_number: float
    row_chi2: np.ndarray = field(repr=False)  # corrected per-row contributions (n_rows,)
    row_harmonic: np.ndarray = field(repr=False)
    row_record: np.ndarray = field(repr=False)
    profile_std_errors: tuple = ()  # ((name, standard error), ...) of profiled nonlinear parameters
    #: covariance of ``values`` (scaled like ``std_errors``), for quantities derived from the fit
    covariance: Optional[np.ndarray] = field(default=None, repr=False)
    #: the solver's status (False when the weighted regression matrix is rank-deficient)
    success: bool = True
    message: str = "ok"

    def _profiled_std_errors(self) -> dict[str, float]:
        return dict(self.profile_std_errors)

    def parameters(self) -> dict[str, float]:
        """Every parameter by name (:meth:`effect_parameters`): what a :class:`CauseScore` shows."""
        return self.effect_parameters()

    def effect_parameters(self) -> dict[str, float]:
        """All parameters, with the nonlinear ones (free play, slip angle, delay) added
        (named by :func:`vocab.plant.effect_parameters`, the one place that names them)."""
        law_only = Plant(_law_of(self), drive_delay_s=self.spec.drive_delay_s)
        out = {**self.as_dict(), **effect_parameters(law_only)}
        if self.spec.angle_offset_rad:
            out["angle_offset_rad"] = self.spec.angle_offset_rad
        if self.spec.angle2_delay_s:
            out["angle2_delay_s"] = self.spec.angle2_delay_s
        if self.spec.angle2_gain_error:
            out["angle2_gain_error"] = self.spec.angle2_gain_error
        return out


def kink_corrected_rate(phi_rad: np.ndarray, omega_rad_s, band: int, jump_rad_s2: float,
                        iterations: int = 2, *, band_limited_rate: Optional[np.ndarray] = None,
                        first_pass: Optional["KinkPass"] = None) -> np.ndarray:
    """The relative rate of one band-limited period with its dry-friction kinks restored.

    Dry friction makes the relative acceleration jump by ``jump_rad_s2`` (2 F_c / Je) each
    time the rate crosses zero, so the rate has a kink there; its harmonics above ``band``
    are missing from a band-limited record and the band-limited rate crosses zero late (by
    ~1e-3 of a period at band 20), which shifts every harmonic of the friction torque. The
    kinks' out-of-band part is known in closed form from the crossing times t_i and jumps
    d_i: the rate's second derivative holds sum_i d_i delta(t - t_i), whose coefficients
    are (2/T) sum_i d_i exp(-i n w t_i); dividing by (i n w)^2 gives the rate's. Adding the
    harmonics above ``band`` back and locating the crossings again converges in two passes.

    Args:
      phi_rad: one period, band-limited to ``band`` harmonics, shape (M,); or several periods
        of the same size at once, ``(n, M)``, with ``omega_rad_s`` one per period ``(n,)``.
      jump_rad_s2: size of the jump of the relative acceleration (>= 0; 0 returns the
        band-limited rate).
      band_limited_rate: ``spectral_rate(phi_rad, omega_rad_s, 1)`` if the caller has it
        (it does not depend on the jump: a profile search reuses it for every trial).
      first_pass: :func:`kink_first_pass` of the same records, if the caller has it: the first
        pass locates the crossings of the band-limited rate, which do not depend on the jump,
        so its correction is the jump times a fixed one (a profile search reuses it for every
        trial; half of this function's time).

    A period whose rate does not cross zero an even, non-zero number of times keeps its
    band-limited rate.
    """
    phi = np.atleast_2d(phi_rad)
    if jump_rad_s2 <= 0 or iterations < 1:
        return _band_limited_rate(phi, _omegas(omega_rad_s, phi.shape[0]), band_limited_rate).reshape(np.shape(phi_rad))
    if first_pass is None:
        first_pass = kink_first_pass(phi, omega_rad_s, band, band_limited_rate=band_limited_rate)
    return _kinked(first_pass, band, jump_rad_s2, iterations).rate_rad_s.reshape(np.shape(phi_rad))


@dataclass(frozen=True)
class KinkPass:
    """The first pass of :func:`kink_corrected_rate` over records ``(n, M)``: their band-limited
    rate, the correction it gives for a unit jump (1 rad/s^2), and which periods crossed zero an
    even, non-zero number of times."""
    rate_rad_s: np.ndarray
    omega_rad_s: np.ndarray
    unit_correction: np.ndarray
    kept: np.ndarray


def _omegas(omega_rad_s, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(omega_rad_s, dtype=float).reshape(-1), (n,))


def _band_limited_rate(phi: np.ndarray, omega: np.ndarray, given: Optional[np.ndarray]) -> np.ndarray:
    """The records' band-limited rate ``(n, M)``: ``given`` if the caller has it, else computed."""
    return spectral_rate(phi, omega[:, None], 1) if given is None else np.atleast_2d(given)


def kink_first_pass(phi_rad: np.ndarray, omega_rad_s, band: int, *,
                    band_limited_rate: Optional[np.ndarray] = None) -> KinkPass:
    """The jump-free first pass of :func:`kink_corrected_rate` (arguments as there)."""
    phi = np.atleast_2d(phi_rad)
    omega = _omegas(omega_rad_s, phi.shape[0])
    v_bl = _band_limited_rate(phi, omega, band_limited_rate)
    correction, crossings = _kink_pass(v_bl, omega, band, np.ones(phi.shape[0], bool))
    return KinkPass(v_bl, omega, correction, crossings.kept)


@dataclass(frozen=True)
class _Crossings:
    """Where a pass of :func:`_kink_pass` found the rate crossing zero: record ``rec``, between
    samples ``idx`` and ``idx + 1`` (cyclic), at time ``t_s`` from the record's start; only the
    crossings of the periods it ``kept``."""
    rec: np.ndarray
    idx: np.ndarray
    t_s: np.ndarray
    kept: np.ndarray


def _crossing_times(v: np.ndarray, rec: np.ndarray, idx: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Times (s) of the zero crossings of ``v`` (``(n, M)``) between samples ``idx`` and
    ``idx + 1`` of records ``rec`` (linear interpolation); ``T``: the records' periods (s)."""
    M = v.shape[1]
    now, nxt = v[rec, idx], v[rec, (idx + 1) % M]
    return (idx + now / (now - nxt)) * T[rec] / M


def _kink_pass(v: np.ndarray, omega: np.ndarray, band: int, kept: np.ndarray) -> tuple[np.ndarray, _Crossings]:
    """One pass: the out-of-band correction of the rate for a unit jump at the zero crossings of
    ``v`` (``(n, M)``), and those crossings, with ``kept`` narrowed to the periods whose crossings
    are even and non-zero."""
    n_rec, M = v.shape
    # Harmonics band+1 .. M/2-1 of sum_i d_i delta(t - t_i) / (i n w)^2, scaled for irfft:
    # (2/T) (M/2) / (i n w)^2 = -(M/T) / (n w)^2, real.
    T = 2 * math.pi / omega
    n_out = np.arange(band + 1, M // 2)
    scale = -(M / T)[:, None] / (n_out * omega[:, None]) ** 2
    up = v > 0
    flips = np.empty_like(up)
    np.not_equal(up[:, :-1], up[:, 1:], out=flips[:, :-1])
    np.not_equal(up[:, -1], up[:, 0], out=flips[:, -1])  # the period wraps round
    rec, i = np.nonzero(flips)
    counts = np.bincount(rec, minlength=n_rec)
    kept = kept & (counts > 0) & (counts % 2 == 0)
    on = kept[rec]
    rec, i = rec[on], i[on]
    t = _crossing_times(v, rec, i, T)
    d = -np.sign(v[rec, (i + 1) % M] - v[rec, i])  # friction always steepens the approach
    # exp(-i n w t) for n = band+1 .. M/2-1 as exp(-i (band+1) w t) z^k, z = exp(-i w t), with
    # z^k = z^(B q) z^r (k = B q + r, B = 64): two short power tables and one product (a complex
    # exponential per term would take ten times as long; round-off ~1e-14)
    K = n_out.size
    B = 64
    z = np.exp(-1j * omega[rec] * t)
    low = np.empty((rec.size, B), complex)
    low[:, 0] = np.exp(-1j * n_out[0] * omega[rec] * t)
    low[:, 1:] = z[:, None]
    np.cumprod(low, axis=1, out=low)  # exp(-i (band+1) w t) z^r, r < B
    high = np.empty((rec.size, -(-K // B)), complex)
    high[:, 0] = 1.0
    high[:, 1:] = (low[:, -1] * z / low[:, 0])[:, None]  # z^B
    np.cumprod(high, axis=1, out=high)
    E = (high[:, :, None] * low[:, None, :]).reshape(rec.size, -1)[:, :K]
    # each period's sum over its own crossings, as a (periods x crossings) matrix of the jumps
    # times E (real, on E's real and imaginary parts side by side); zero for a period not kept
    S = np.zeros((n_rec, rec.size))
    S[rec, np.arange(rec.size)] = d
    V = np.zeros((n_rec, M // 2 + 1), complex)
    V[:, band + 1: M // 2] = scale * (S @ np.ascontiguousarray(E).view(float)).view(complex)
    return np.fft.irfft(V, n=M, axis=1), _Crossings(rec, i, t, kept)


@dataclass(frozen=True)
class _Kinked:
    """:func:`kink_corrected_rate`'s result with what its last pass saw: the rate it corrected
    (``seen``, the band-limited rate plus the previous pass's correction), that rate's crossings,
    and the largest magnitude of the last pass's unit-jump correction in every record (s)."""
    rate_rad_s: np.ndarray
    seen: np.ndarray
    crossings: _Crossings
    correction_max_s: np.ndarray


def _kinked(first_pass: KinkPass, band: int, jump_rad_s2: float, iterations: int = 2) -> _Kinked:
    """:func:`kink_corrected_rate` for ``jump_rad_s2 > 0`` and ``iterations >= 1``, from its first pass."""
    v_bl, kept = first_pass.rate_rad_s, first_pass.kept
    correction = first_pass.unit_correction
    seen, crossings = v_bl, None
    for _ in range(iterations - 1):
        seen = v_bl + jump_rad_s2 * correction
        correction, crossings = _kink_pass(seen, first_pass.omega_rad_s, band, kept)
        kept = crossings.kept
    v = np.where(kept[:, None], v_bl + jump_rad_s2 * correction, v_bl)
    return _Kinked(v, seen, crossings, np.abs(correction).max(axis=1))


def _rate_move_bound(first_pass: KinkPass, band: int, at: _Kinked, jump_at: float, jump: float
                     ) -> Optional[np.ndarray]:
    """A bound on how far every sample of the two-pass kink-corrected rate moves from jump
    ``jump_at`` (``at`` is the rate there) to ``jump`` (both > 0), per record (rad/s), found
    without the rate at ``jump``; None when the first pass crosses zero between other samples
    there (the second pass then changes in kind).

    The rate at a jump j is ``v_bl + j c(v1)``, where ``v1 = v_bl + j c0`` (the first pass) and
    the correction ``c`` is the irfft of harmonics band+1..M/2-1 of ``-(M/T) / (n w)^2 sum_i
    d_i exp(-i n w t_i)`` over v1's zero crossings t_i. When v1 at ``jump`` crosses zero between
    the same samples as at ``jump_at``, each crossing moves by ``dt_i`` and, as
    ``|exp(-i a) - exp(-i b)| <= |a - b|``, every sample of ``c`` by at most
    ``dc = (2 / (T w)) sum_n 1/n sum_i |dt_i|``; so the rate moves by at most
    ``|jump - jump_at| (max|c(at)| + dc) + jump_at dc`` (zero in a period not kept, which keeps
    its band-limited rate at every jump)."""
    if at.crossings is None or jump <= 0 or jump_at <= 0:
        return None
    v1 = first_pass.rate_rad_s + jump * first_pass.unit_correction
    if not np.array_equal(v1 > 0, at.seen > 0):
        return None
    cr = at.crossings
    omega = first_pass.omega_rad_s
    T = 2 * math.pi / omega
    M = v1.shape[1]
    moved = np.bincount(cr.rec, np.abs(_crossing_times(v1, cr.rec, cr.idx, T) - cr.t_s), minlength=omega.size)
    dc = 2.0 / (T * omega) * _out_of_band_harmonic_sum(band, M) * moved
    return np.where(cr.kept, abs(jump - jump_at) * (at.correction_max_s + dc) + jump_at * dc, 0.0)


@lru_cache(maxsize=16)
def _out_of_band_harmonic_sum(band: int, M: int) -> float:
    """``sum 1/n`` over the harmonics band+1 .. M/2-1 the kink correction adds."""
    return float(np.sum(1.0 / np.arange(band + 1, M // 2)))


def _sign_proof(first_pass: KinkPass, band: int, at: _Kinked, jump_at: float, jump: float,
                rate_at: np.ndarray) -> bool:
    """True when the two-pass kink-corrected rate at ``jump`` has the sign of ``rate_at`` in
    every sample, proven without computing it: ``at`` is the corrected rate at ``jump_at``,
    ``rate_at`` that rate with any fixed addition (flywheel 2's correction). A sample whose
    magnitude exceeds :func:`_rate_move_bound` (with a round-off margin of 1e-9 of the record's
    largest rate) keeps its sign."""
    bound = _rate_move_bound(first_pass, band, at, jump_at, jump)
    if bound is None:
        return False
    margin = 1e-9 * np.abs(first_pass.rate_rad_s).max(axis=1)
    return bool(np.all(np.abs(rate_at).min(axis=1) > bound + margin))


def _coulomb_jump(spec: "ModelSpec", names: Sequence[str], theta: Optional[np.ndarray]) -> float:
    """Jump of the relative acceleration (rad/s^2) at a rate reversal: 2 F_c / Je."""
    if theta is None or not any(isinstance(t, Coulomb) for t in spec.terms):
        return 0.0
    p = dict(zip(names, theta))
    # At a reversal the friction is the static one: the sliding torque plus a Stribeck excess.
    fc = p.get("coulomb_torque_Nm", 0.0) + p.get("stribeck_torque_Nm", 0.0)
    if J1 in p:
        inv = (1.0 / p[J1] if p[J1] > 0 else 0.0) + (1.0 / p[J2] if p[J2] > 0 else 0.0)
    else:
        inv = 1.0 / p[JE] if p.get(JE, 0) > 0 else 0.0
    return max(2.0 * fc * inv, 0.0)


@dataclass(frozen=True)
class _Problem:
    runs: tuple[PreparedRun, ...]
    form: str
    n_harmonics: int
    torque_share: float
    nu: float  # degrees of freedom of each row weight
    fidelity: float = DEFAULT_FIDELITY  # model-fidelity floor relative to each run's torque (see diagnose)

    @cached_property
    def _averages(self) -> _Columns:
        return _Columns([r.fine_average for r in self.runs], self.n_harmonics, self.form, self.torque_share)

    @cached_property
    def _periods(self) -> tuple[_Columns, ...]:
        return tuple(_Columns(r.fine_periods, self.n_harmonics, self.form, self.torque_share) for r in self.runs)

    def system(self, spec: ModelSpec, jump: float = 0.0) -> LinearSystem:
        return self._averages.system(spec, jump)

    def same_system(self, spec: ModelSpec, jump: float, other: float) -> bool:
        return self._averages.same_system(spec, jump, other)

    @property
    def columns_memo(self) -> dict:
        """The averaged records' coefficient columns computed so far, by key."""
        return self._averages._memo

    def keep_columns(self, columns: dict) -> None:
        """Add columns computed elsewhere (a forked worker) to :attr:`columns_memo`."""
        self._averages._memo.update(columns)

    def row_variance(self, spec: ModelSpec, theta: np.ndarray, like: LinearSystem) -> np.ndarray:
        """Variance of every averaged row: noise from period-to-period residual variation, plus
        ``(fidelity * size)^2`` with ``size`` the run's largest balanced term."""
        var = np.empty(like.F.size)
        jump = _coulomb_jump(spec, like.names, theta)
        for i, run in enumerate(self.runs):
            s = self._periods[i].system(spec, jump)
            res = (s.F - s.A @ theta).reshape(run.n_periods, -1)  # the rows run by period (record)
            v = res.var(axis=0, ddof=1) / len(run.fine_periods)
            rows = np.flatnonzero(like.row_record == i)
            sub_h, sub_e = like.row_harmonic[rows], like.row_equation[rows]
            # Size of the run: its largest balanced term (inertia, law terms, torque) in any row.
            size2 = float(np.max(np.abs(np.column_stack([like.A[rows] * theta, like.F[rows]])))) ** 2
            # Pooled over each (harmonic, equation): the mean of its rows (real and imaginary
            # part), summed in row order as numpy's mean sums so few (the same bits).
            _, group = np.unique(sub_h * (int(sub_e.max()) + 1) + sub_e, return_inverse=True)
            mean = np.bincount(group, weights=v) / np.bincount(group)
            var[rows] = mean[group] + self.fidelity**2 * size2
        scale = np.max(np.abs(like.F)) if like.F.size else 1.0
        return np.maximum(var, (1e-12 * scale) ** 2)


def _solve_once(problem: _Problem, spec: ModelSpec, weights: np.ndarray, jump: float):
    system = problem.system(spec, jump)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllConditionedWarning)
        res = solve(system, row_weights=weights)
    return system, res


#: The kink iteration of :func:`_solve` stops when the next jump is within this of the one the
#: fit used (relative). The whole kink correction moves a friction torque by 4e-5 (the worn
#: joint's Coulomb friction) to 1e-2 (a Stribeck law's excess) of itself, so a jump this close
#: changes no fitted value beyond ~1e-8 of it.
KINK_RTOL = 1e-6


def _solve(problem: _Problem, spec: ModelSpec, weights: np.ndarray, start_jump: float = 0.0) -> Fit:
    """Weighted fit of ``spec``; with dry friction, the rate's kinks restored at the fitted
    friction (:func:`kink_corrected_rate`) and refitted until the jump settles (to
    ``KINK_RTOL``; at most two refits: the iteration contracts by 3e-5 per pass on the worn
    joint, by 1e-4 to 6e-3 on the independent bench's Stribeck law, measured).

    ``start_jump``: the jump to fit at first (rad/s^2): 0 (no kinks), or a neighbour's settled
    jump, which a profile search passes from trial to trial (a trial next to a solved one then
    needs one fit, not three). A refit whose system would be the last one bit for bit
    (:meth:`_Problem.same_system`: only dry friction's signs see the jump, and they stay) is
    skipped: its fit is the last one, already settled."""
    jump = start_jump
    system, res = _solve_once(problem, spec, weights, jump)
    for _ in range(2):
        new = _coulomb_jump(spec, system.names, res.values)
        if new <= 0 or abs(new - jump) <= KINK_RTOL * new:
            break
        if problem.same_system(spec, jump, new):
            break  # the fit at the new jump is this one, bit for bit: it is settled
        jump = new
        system, res = _solve_once(problem, spec, weights, jump)
    row, chi2, scale = weighted_chi2(system.F - system.A @ res.values, weights, problem.nu, res.dof)
    se = res.std_errors * math.sqrt(scale)
    return Fit(spec, tuple(system.names), np.array(res.values), np.array(se), chi2, system.F.size,
               res.condition_number, row, system.row_harmonic, system.row_record,
               covariance=np.array(res.covariance) * scale, success=res.success, message=res.message)


def fit(problem: _Problem, spec: ModelSpec, weights: Optional[np.ndarray] = None, *, iterations: int = 2
        ) -> tuple[Fit, np.ndarray]:
    """Fit ``spec``; without weights, estimate them (ordinary LS, then re-weighted ``iterations`` times)."""
    if weights is not None:
        return _solve(problem, spec, weights), weights
    system = problem.system(spec)
    w = np.ones(system.F.size)
    f = _solve(problem, spec, w)
    for _ in range(iterations):
        w = 1.0 / problem.row_variance(spec, f.values, system)
        f = _solve(problem, spec, w)
    return f, w


# --------------------------------------------------------------------------------------------
# 3. Causes


def _law_of(f: Fit) -> JointLaw:
    p = f.as_dict()
    return JointLaw(f.spec.terms, tuple(p[t.name] for t in f.spec.terms))


def _dissipative_share(problem: "_Problem", base: Fit, ext: Fit) -> Optional[float]:
    """The cause's own joint torque along the measured motion, at the fundamental: 0 = in
    phase with the angle (elastic), 1 = in quadrature (dissipative); None when the cause
    acts outside the joint (drive delay, bearings)."""
    if ext.spec.terms == base.spec.terms:
        return None
    # The effect alone, at the extended fit's values: its added terms, and for free play the
    # elastic terms with the gap minus the same terms without it.
    law = _law_of(ext)
    base_names = set(base.names)
    plain = [(Power(t.power) if isinstance(t, Power) else t, v) for t, v in zip(law.terms, law.values)
             if t.name in base_names]
    without = JointLaw(tuple(t for t, _ in plain), tuple(v for _, v in plain))
    torques, motions = [], []
    for run in problem.runs:
        rec = run.fine_average
        phi = rec.phi_rad
        rate = spectral_rate(phi, rec.omega_rad_s, 1)
        torques.append(np.asarray(law.torque(phi, rate), float) - np.asarray(without.torque(phi, rate), float))
        motions.append(phi)
    return fundamental_quadrature(torques, motions)


def _signature(problem: "_Problem", base: Fit, ext: Fit) -> dict:
    """Where the cause's improvement lies: share of the chi-square drop by harmonic class
    (mean, fundamental, even, odd >= 3), and the dissipative share of its joint torque."""
    out: dict = harmonic_shares(base.row_chi2 - ext.row_chi2, base.row_harmonic)
    out["dissipative"] = _dissipative_share(problem, base, ext)
    return out


def _magnitude(cause: Cause, f: Fit) -> tuple[str, float, float]:
    name, value, se = cause.magnitude_of(f.effect_parameters(), f.std_error)
    return name, (value if math.isfinite(value) else 0.0), se


def _profile(problem, cause: Cause, base: ModelSpec, weights, start_jump: float = 0.0) -> Fit:
    """:func:`identify.causes.profile` over the cause's bounds; each trial's kink iteration starts
    from the settled jump of the nearest trial solved so far."""
    cache: dict[float, Fit] = {}

    def aside(h):
        near = cache[min(cache, key=lambda g: abs(g - h))] if cache else None
        start = _coulomb_jump(near.spec, near.names, near.values) if near is not None else start_jump
        return _solve(problem, cause.extend(base, h), weights, start)

    def solved(h):
        cache[h] = aside(h)
        return cache[h]

    lo, hi = cause.bounds(problem.runs)
    found = profile(solved, cause, lo, hi, solve_aside=aside, points=cause.grid_points(problem.runs, lo, hi))
    return replace(found.fit, profile_std_errors=((cause.profiled, found.std_error),))


def score_cause(problem: _Problem, cause: Cause, base: Fit, weights: np.ndarray, n_causes: int,
                alpha: float) -> CauseScore:
    if cause.needs_two_angles and problem.form != "two_dof":
        return CauseScore(cause.name, 0.0, cause.n_linear, -math.inf, 1.0, False, None, (cause.magnitude, math.nan,
                          math.nan), {}, note="not testable: needs both flywheel angles (phi1, phi2)")
    start = _coulomb_jump(base.spec, base.names, base.values)  # the base's settled jump: a warm start
    if cause.bounds is None:
        ext = _solve(problem, cause.extend(base.spec, 0.0), weights, start)
    else:
        ext = _profile(problem, cause, base.spec, weights, start)
    q = len(ext.names) - len(base.names) + (1 if cause.bounds is not None else 0)
    delta = base.chi2 - ext.chi2
    score, p, significant = evidence(delta, q, base.n_rows, alpha, n_causes * cause.n_trials(problem.runs))
    mag = _magnitude(cause, ext)
    note = ""
    if cause.nonnegative and mag[1] < 0:
        # A friction or damping that feeds energy in is not a physical cause; it only bends
        # the model towards another effect's signature.
        note = f"fitted with an unphysical negative {mag[0]} = {mag[1]:.4g}: rejected"
        significant = False
    elif significant:
        note = _degenerate(problem, cause, ext) or _feeds_energy(ext)
        if note:
            significant = False
    return CauseScore(cause.name, float(delta), q, float(score), p, significant, ext, mag,
                      _signature(problem, base, ext), note=note)


#: Parameters that dissipate energy when positive: an extended model with one of them
#: significantly negative (beyond 2 standard errors) would feed energy in and is never adopted.
def _dissipative_names(f: Fit) -> tuple[str, ...]:
    """The fit's parameters that dissipate when positive: its dissipative law terms' (each term
    says so: ``Term.dissipative``) and the bearings' drag."""
    law = tuple(t.name for t in f.spec.terms if t.dissipative)
    return law + (BEARING1, BEARING2)


def _feeds_energy(f: Fit) -> str:
    for name in _dissipative_names(f):
        if name in f.names:
            v, se = f.values[f.names.index(name)], f.std_errors[f.names.index(name)]
            if v < 0 and (not math.isfinite(se) or -v > 2 * se):
                return (f"the extended model would hold a negative {name} = {v:.4g} +- {se:.2g}: it would feed energy "
                        f"in: rejected")
    return ""


def angle_resolution(runs: Sequence["PreparedRun"], band: int) -> float:
    """What the relative angle the law columns see resolves (rad): 3 noise standard deviations
    of one sample of the period average band-limited to harmonics 0..band (white noise of
    sigma per raw sample leaves sigma sqrt((2 band + 1) / (N P)) there), largest over the runs."""
    out = 0.0
    for r in runs:
        sd = r.noise_std.get("phi1", 0.0)
        if "phi2" in r.noise_std:
            sd = math.hypot(sd, r.noise_std["phi2"])
        N = r.raw_average.samples_per_period
        out = max(out, 3.0 * sd * math.sqrt(min(1.0, (2 * band + 1) / N) / r.n_periods))
    return out


def _degenerate(problem: "_Problem", cause: "Cause", ext: Fit) -> str:
    """The cause's own rule (``Cause.degenerate``) on its fitted nonlinear parameter: a Jenkins
    element whose slip angle is below what the angles resolve never sticks (it is dry friction);
    a free play below it is no free play. Empty if the cause stands as fitted."""
    if cause.degenerate is None:
        return ""
    h = ext.effect_parameters().get(cause.profiled, math.nan)
    lo = cause.bounds(problem.runs)[0]
    res = max(angle_resolution(problem.runs, problem.n_harmonics), 2.0 * lo)
    return cause.degenerate(h, Limits(res, max(rate_amplitudes(problem.runs))))


@dataclass(frozen=True)
class Diagnosis:
    """The whole diagnosis.

    Attributes:
      nominal: fit of the nominal model; causes: first-round scores against it, ranked;
      steps: (cause score) added in order; extended: the final fit;
      ambiguous: pairs the data cannot tell apart; form: "two_dof" or "equivalent";
      noise_std: channel -> median noise standard deviation per raw sample over the runs;
      chi2_per_dof: nominal and extended goodness of fit (about 1 when only noise is left).
    """

    nominal: Fit
    causes: tuple[CauseScore, ...]
    steps: tuple[CauseScore, ...]
    extended: Fit
    ambiguous: tuple[Ambiguity, ...]
    form: str
    torque_share: float
    n_harmonics: int
    noise_std: dict
    notes: tuple[str, ...] = ()
    #: what in the fitted model says the data may be read wrong (an inertia that is no flywheel's):
    #: shown before the causes, since no cause can mend a file read wrong
    plausibility: tuple[str, ...] = ()

    @property
    def effects(self) -> tuple[str, ...]:
        return tuple(s.effect for s in self.steps)

    def effects_of_kind(self, kind: str) -> tuple[str, ...]:
        """Adopted causes in the plant (``"dynamic"``) or in the sensors (``"measurement"``)."""
        kinds = {c.name: c.kind for c in CAUSES}
        return tuple(e for e in self.effects if kinds.get(e, "dynamic") == kind)


from jointrig.parallel import default_workers, fork_map  # noqa: E402


def _cost_rank(problem: _Problem, cause: Cause, base: Fit) -> int:
    """0: a profile search over a law with sliders (its columns are stepped sample by sample at
    every trial value: the longest), 1: another profile search (tens of fits), 2: one fit."""
    if cause.bounds is None:
        return 2
    lo, hi = cause.bounds(problem.runs)
    return 0 if any(t.stateful for t in cause.extend(base.spec, 0.5 * (lo + hi)).terms) else 1


@dataclass(frozen=True)
class _RivalCheck:
    """Rivals of a cause just adopted: significant beside it on the previous base, are they still
    needed on the new one (``base``, with ``n`` causes left), and is the adopted cause still
    needed on each rival's model instead (the reverse)? Checked together with the next round's
    causes (:func:`_score_all`): a rival's score on the new base is that round's score of it."""
    adopted: CauseScore
    cause: Cause
    rivals: tuple[CauseScore, ...]
    base: tuple[Fit, np.ndarray]
    n: int


def _score_all(problem: _Problem, causes: Sequence[Cause], base: Fit, weights: np.ndarray, n: int, alpha: float,
               workers: int, progress: Optional[Callable[[str], None]] = None, *, rivals_by_name: Optional[dict] = None,
               check: Optional[_RivalCheck] = None) -> tuple[list[CauseScore], list[tuple[CauseScore, CauseScore]]]:
    """:func:`score_cause` for every cause, and the rival check ``check`` (on this same base,
    weights and ``n``), in ``workers`` forked processes when more than one: the causes of a round
    and the checks are independent, the scores the same numbers either way. ``rivals_by_name``:
    the catalogue's causes by name (a rival checked need not be among ``causes``).

    Returns the causes' scores and, per rival of ``check``, ``(its score on this base, the
    adopted cause's score on the rival's refitted model)``.
    ``progress`` hears of each cause as its score arrives."""
    say = progress or (lambda msg: None)
    index = {c.name: k for k, c in enumerate(causes)}
    rivals = check.rivals if check is not None else ()
    # Work items: ("score", cause) on this base; ("reverse", rival) the adopted cause on the
    # rival's refitted model. A rival among the causes is scored once, as a cause.
    items = [("score", c) for c in causes] + [("score", (rivals_by_name or {})[r.effect]) for r in rivals
                                              if r.effect not in index]
    items += [("reverse", r) for r in rivals]

    def cost(item) -> int:
        kind, what = item
        return (_cost_rank(problem, what, base) if kind == "score"
                else _cost_rank(problem, check.cause, what.fit))

    def work(item):
        kind, what = item
        if kind == "score":
            return score_cause(problem, what, base, weights, n, alpha)
        rival_fit, wr = fit(problem, what.fit.spec)
        return score_cause(problem, check.cause, rival_fit, wr, n, alpha)

    # The longest first (sliders, then other profile searches), so the processes finish together.
    order = sorted(range(len(items)), key=lambda k: cost(items[k]))
    out: dict = {}
    told = 0
    for k, (value, cols) in zip(order, fork_map(lambda k: _with_new_columns(problem, lambda: work(items[k])),
                                                order, workers)):
        problem.keep_columns(cols)
        out[k] = value
        if k < len(causes):
            told += 1
            say(f"  scored {value.effect} ({told}/{len(causes)}): evidence {value.score:.4g}"
                + (", significant" if value.significant else ""))
    scores = [out[k] for k in range(len(causes))]
    by_name = {items[k][1].name: out[k] for k in range(len(items)) if items[k][0] == "score"}
    first_reverse = len(items) - len(rivals)
    return scores, [(by_name[r.effect], out[first_reverse + i]) for i, r in enumerate(rivals)]


def _with_new_columns(problem: _Problem, work: Callable):
    """``(work(), the harmonic-balance columns it computed)``: a forked worker's columns die
    with it, so it hands them back for the next rounds' workers (:meth:`_Problem.keep_columns`).
    A profile search's grid of trial values is the same in every round, and a column of an
    angle-only term (free play, a Jenkins or Iwan element) does not depend on the base: the
    later rounds find them computed. The same numbers either way."""
    memo = problem.columns_memo
    before = set(memo)
    value = work()
    return value, {k: v for k, v in memo.items() if k not in before}


def diagnose(runs: Sequence[PreparedRun], *, form: Optional[str] = None, n_harmonics: int = 20,
             torque_share: float = 0.5, alpha: float = 1e-3, max_effects: int = 3,
             fidelity: float = DEFAULT_FIDELITY, causes: Sequence[Cause] = CAUSES,
             workers: Optional[int] = None, progress: Optional[Callable[[str], None]] = None,
             nominal_spec: ModelSpec = NOMINAL) -> Diagnosis:
    """Fit the nominal model, rank causes by evidence, extend greedily (module docstring).

    The mean (harmonic 0) is not balanced: every sensor's zero is arbitrary on a bench (an
    encoder's index, a torque amplifier's offset), and an offset of the relative angle would
    pass for a preload and an even stiffness term. A preload is therefore not sought, and an
    even term shows through the even harmonics it creates.

    Args:
      form: ``"two_dof"`` (default when every run has both angles) or ``"equivalent"``.
      n_harmonics: harmonics 0..H balanced per run (capped by the samples per period).
      torque_share: J2 / (J1 + J2), used only by the equivalent form.
      alpha: family-wise false-alarm probability over the causes of one round.
      workers: processes that score the causes of a round (default :func:`default_workers`).
      progress: optional callable ``(message) -> None``: each round and each cause scored.
      nominal_spec: the structure the user's model has (default the paper's eq. 11: c phi' + k phi
        + gamma phi^3); the causes extend it.
      fidelity: model-fidelity floor added to every row's noise, relative to the run's
        largest balanced torque: a misfit below ``fidelity`` times that is not evidence.
        Harmonic balance of a law with a jump (dry friction) from angles band-limited to
        ``n_harmonics`` is exact only up to where the jumps fall (restored by
        :func:`kink_corrected_rate` to ~4e-5 of a period) and the rig's RK4 step (~1e-4 of
        the swing). Measured on the dry-friction case: without noise the remaining misfit is
        ~2e-4 of the run's torque; at 40 dB a floor of 5e-4 still let that misfit pass as a
        small second "hysteresis" (slip 1.5e-3 rad, 9 N m, p = 2e-5) for one noise seed in
        three. 1e-3 keeps it out; causes of a few percent of the joint torque stay ~50x above
        it. The price: gamma's standard error grows from ~18 to ~27 N m/rad^3.
    """
    runs = tuple(runs)
    if not runs:
        raise ValueError("no runs to diagnose")
    two = all(r.average.phi2_rad is not None for r in runs)
    form = form or ("two_dof" if two else "equivalent")
    if form == "two_dof" and not two:
        raise ValueError("form 'two_dof' needs phi1 and phi2 in every run")
    H = min(n_harmonics, min(max_harmonic(r.average.samples_per_period) for r in runs))
    nu = 2.0 * (min(r.n_periods for r in runs) - 1)
    problem = _Problem(runs, form, H, torque_share, nu, fidelity)
    workers = default_workers() if workers is None else int(workers)
    notes = []
    if nu <= 4:
        notes.append(f"only {int(nu / 2 + 1)} periods per run: the noise estimates are rough (more periods "
                     f"sharpen the significance tests)")
    say = progress or (lambda msg: None)
    say(f"fitting the nominal model{' (paper eq. 11)' if nominal_spec == NOMINAL else ''} to {len(runs)} runs, "
        f"harmonics 1..{H}")
    nominal, w = fit(problem, nominal_spec)
    ambiguous: list[Ambiguity] = []
    kind_of = {c.name: c.kind for c in causes}
    by_name = {c.name: c for c in causes}
    adopted: list[CauseScore] = []
    pending: list[_RivalCheck] = []  # the last adopted cause's rival check, done with the next round

    def resolve(check: _RivalCheck, outcome) -> None:
        for rival, (r_given_b, b_given_r) in zip(check.rivals, outcome):
            if not r_given_b.significant and not b_given_r.significant:
                pair = frozenset({check.adopted.effect, rival.effect})
                ambiguous.append(Ambiguity((check.adopted.effect, rival.effect),
                                           SEPARATING_EXCITATION.get(pair, DEFAULT_SEPARATION)))

    def announce(check: _RivalCheck) -> None:
        say(f"  are {', '.join(r.effect for r in check.rivals)} still needed beside {check.adopted.effect}? "
            f"(and the reverse)")

    def rank(base, remaining, rnd):
        # Ranked by evidence; causes rejected as unphysical or untestable go last. Causes the data
        # cannot tell apart at all (an angle offset and an asymmetric stiffness bend the model alike)
        # score the same to round-off: ranked to 9 digits, they keep the catalogue's order.
        current, wcur = base
        check = pending.pop() if pending else None
        assert check is None or check.base is base, "a rival check runs on the base it was made for"
        say(f"round {rnd + 1}: scoring {len(remaining)} causes on "
            + (" + ".join(s.effect for s in adopted) or "the nominal model")
            + (f" ({workers} processes)" if workers > 1 else ""))
        if check is not None:
            announce(check)
        scores, outcome = _score_all(problem, remaining, current, wcur, len(remaining), alpha, workers, say,
                                     rivals_by_name=by_name, check=check)
        if check is not None:
            resolve(check, outcome)
        return parsimonious(sorted(scores, key=lambda s: (bool(s.note), -float(f"{s.score:.9g}"))), by_name,
                             current.n_rows, alpha)

    def adopt(base, scores):
        best = next((c for c in scores if c.significant), None)
        sensor = next((c for c in scores if c.significant and kind_of[c.effect] == "measurement"), None)
        if best is not None and sensor is not None and sensor.delta_chi2 >= TIE * best.delta_chi2:
            # As good as the best dynamic cause (they explain the same data): the sensors are
            # checked first, as a test engineer checks the instrumentation before the joint.
            best = sensor
        if best is None:
            return None
        adopted.append(best)
        # Re-estimate the weights with the extended structure, then refit.
        carried = base[0].profile_std_errors + best.fit.profile_std_errors
        current, wcur = fit(problem, best.fit.spec)
        return best, (replace(current, profile_std_errors=carried), wcur)

    def rivals_of(base, best, scores, remaining):
        # Rivals: significant on the previous base, close in evidence; are they still needed?
        # Each is tested both ways, with the next round's causes (one set of forked processes);
        # after the last round, on their own.
        rivals = tuple(r for r in scores if r is not best and r.significant)
        if rivals:
            pending.append(_RivalCheck(best, by_name[best.effect], rivals, base, len(remaining)))

    chosen = forward_select((nominal, w), causes, rank=rank, adopt=adopt, after=rivals_of, max_effects=max_effects)
    if pending:  # no round followed the last adoption
        check = pending.pop()
        announce(check)
        (current, wcur), n_left = check.base, check.n
        resolve(check, _score_all(problem, [], current, wcur, n_left, alpha, workers, say, rivals_by_name=by_name,
                                  check=check)[1])
    current = chosen.base[0]
    first = list(chosen.rounds[0]) if chosen.rounds else []
    steps = list(chosen.adopted)
    if len(steps) > 1:
        steps, current = _needed(problem, steps, chosen.base, by_name, alpha, say, nominal_spec)
    noise = {}
    for ch in runs[0].noise_std:
        noise[ch] = float(np.median([r.noise_std[ch] for r in runs]))
    return Diagnosis(nominal, tuple(first), tuple(steps), current, tuple(ambiguous), form, torque_share, H,
                     noise, tuple(notes), implausible_fit(nominal))


def _spec_of(steps: Sequence[CauseScore], final: Fit, by_name: dict, nominal: ModelSpec = NOMINAL) -> ModelSpec:
    """The nominal structure extended by ``steps``' causes, each nonlinear parameter at its
    value in ``final``."""
    params = final.effect_parameters()
    spec = nominal
    for step in steps:
        cause = by_name[step.effect]
        spec = cause.extend(spec, params.get(cause.profiled, 0.0) if cause.profiled else 0.0)
    return spec


def _needed(problem: _Problem, steps: list[CauseScore], base: tuple, by_name: dict, alpha: float,
            say: Callable[[str], None], nominal: ModelSpec = NOMINAL) -> tuple[list[CauseScore], Fit]:
    """Parsimony after the forward selection: a cause stays adopted only if the model without it
    fails, i.e. removing it (the others kept at their fitted nonlinear parameters, the final
    model's weights) raises chi-square significantly (:func:`identify.causes.evidence` at
    ``alpha`` for its parameters). The least needed cause goes first, then the rest are tested
    again on the refitted model. Returns the kept steps and the final fit."""
    current, weights = base
    while len(steps) > 1:
        start = _coulomb_jump(current.spec, current.names, current.values)
        tests = []
        for step in steps:
            rest = [s for s in steps if s is not step]
            without = _solve(problem, _spec_of(rest, current, by_name, nominal), weights, start)
            tests.append((evidence(without.chi2 - current.chi2, step.n_params, current.n_rows, alpha), step))
        (score, _, needed), weakest = min(tests, key=lambda t: t[0][0])
        if needed:
            break
        say(f"  {weakest.effect} is not needed beside {' + '.join(s.effect for s in steps if s is not weakest)} "
            f"(the model without it explains the data as well): dropped")
        steps = [s for s in steps if s is not weakest]
        carried = tuple(pe for s in steps for pe in s.fit.profile_std_errors)
        current, weights = fit(problem, _spec_of(steps, current, by_name, nominal))
        current = replace(current, profile_std_errors=carried)
    return steps, current


#: Flywheel inertias further apart than this ratio are not a bench's two flywheels.
INERTIA_RATIO = 1000.0


def implausible_fit(f: Fit) -> tuple[str, ...]:
    """What a fitted model says about how the data were read (pure): a negative or zero inertia,
    or one a thousand times below the other, is no flywheel's; a significantly negative damping
    feeds energy in. Their likely causes are named: a torque that is not the drive on flywheel 1
    (a shaft torque is the joint's own), swapped angle columns, signs, or other units than the
    file says."""
    p = f.as_dict()
    J = {n: p[n] for n in (J1, J2, JE) if n in p}
    bad = [n for n, v in J.items() if not v > 0]
    if not bad and J1 in J and J2 in J and max(J[J1], J[J2]) > INERTIA_RATIO * min(J[J1], J[J2]):
        bad = [J1 if J[J1] < J[J2] else J2]
    out = []
    if bad:
        values = ", ".join(f"{n.split('_')[0]} = {v:.3g} kg m^2" for n, v in J.items())
        out.append(f"the fitted inertias ({values}) are no flywheels': check that 'torque' is the drive torque on "
                   f"flywheel 1 (a torque measured in the shaft between the flywheels is the joint's own torque, not a "
                   f"drive), that phi1 is the driven flywheel's angle, and the units (torque in N m, not N mm; angles "
                   f"in rad, not deg)")
    c, se = p.get("c_Nms_per_rad"), f.std_error("c_Nms_per_rad") if "c_Nms_per_rad" in p else math.nan
    if c is not None and c < 0 and (not math.isfinite(se) or -c > 2 * se):
        out.append(f"the joint's fitted damping c = {c:.3g} N m s/rad is negative (it would feed energy in): check "
                   f"that phi1 is the driven flywheel's angle and phi2 the other's (swapped columns give this), and "
                   f"the signs of the torque and the angles (all positive in one sense of rotation)")
    return tuple(out)


def plant_of(f: Fit, torque_share: float = 0.5) -> tuple[Plant, tuple[float, float]]:
    """The identified plant and flywheel inertias (J1, J2) in kg m^2, ready for the rig.

    For the equivalent form J1 = Je / s and J2 = Je / (1 - s) with s the torque share.
    """
    p = f.as_dict()
    plant = Plant(_law_of(f), bearing1_damping_Nms_per_rad=max(p.get(BEARING1, 0.0), 0.0),
                  bearing2_damping_Nms_per_rad=max(p.get(BEARING2, 0.0), 0.0),
                  drive_delay_s=f.spec.drive_delay_s)
    if J1 in p:
        J = (p[J1], p[J2])
    else:
        J = (p[JE] / torque_share, p[JE] / (1 - torque_share))
    return plant, J
