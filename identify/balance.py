"""Harmonic balance: the linear system [A]{S} = {F} of paper eq. (5)-(6), generalised.

For every record and every harmonic n = 0..H the equation of motion, expanded in Fourier
series, gives one complex equation that is linear in the unknowns; its real part (cosine,
``X_n``) and imaginary part (sine, ``-X_n*``) are two real rows (n = 0 gives one).
Stacking rows over harmonics, frequencies and amplitudes gives an over-determined system
solved by (weighted) least squares in :mod:`identify.solve`.

Two forms:

* equivalent one-degree-of-freedom (paper eq. 10-11): relative angle ``phi = phi1 - phi2``,

      Je phi'' + M_v(phi, phi') = s T(t),   Je = J1 J2 / (J1 + J2),   s = J2 / (J1 + J2)

  unknowns ``{Je, theta}``; the torque share ``s`` is a known design ratio.
* direct two-degree-of-freedom: both flywheel equations,

      J1 phi1'' + M_v = T(t),     J2 phi2'' - M_v = 0

  unknowns ``{J1, J2, theta}``; needs no inertia ratio.

The inertia column is ``(i n omega) R_n`` with ``R_n`` the coefficients of the measured
rate (one exact spectral derivative) or ``(i n omega)^2 Phi_n`` if the record has no rates.
Law columns are the Fourier coefficients of the basis terms evaluated on the samples
(paper eq. 4 and 9); the rows are exact for exact samples, so the harmonic count H only
chooses how much of the data is used.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import Optional, Sequence

import numpy as np

from jointrig.vocab.law import Term
from .harmonics import fourier_coefficients, max_harmonic, synthesize
from jointrig.vocab.records import RecordError, SteadyStateRecord
from jointrig.vocab.params import J1, J2, JE, BEARING1, BEARING2

__all__ = [
    "LinearSystem",
    "assemble",
    "harmonic_rows",
    "law_rows",
    "memo_arrays",
    "equivalent_system",
    "two_dof_system",
    "single_dof_system",
    "spectral_rate",
    "upsample",
]


@dataclass(frozen=True)
class LinearSystem:
    """A real over-determined system ``A S = F``.

    Attributes:
      A: shape ``(n_rows, n_params)``.
      F: shape ``(n_rows,)``.
      names: parameter names with units, length ``n_params``.
      row_record: index of the record each row comes from, ``(n_rows,)``.
      row_harmonic: harmonic number n of each row, ``(n_rows,)``.
      row_part: 0 for the cosine (real) row, 1 for the sine (imaginary) row, ``(n_rows,)``.
      row_equation: which equation of motion the row balances (0: relative / flywheel 1,
        1: flywheel 2), ``(n_rows,)``.
    """

    A: np.ndarray
    F: np.ndarray
    names: tuple[str, ...]
    row_record: np.ndarray
    row_harmonic: np.ndarray
    row_part: np.ndarray
    row_equation: np.ndarray

    def __post_init__(self):
        if self.A.ndim != 2 or self.F.shape != (self.A.shape[0],):
            raise ValueError(f"LinearSystem: A {self.A.shape} and F {self.F.shape} do not match")
        if len(self.names) != self.A.shape[1]:
            raise ValueError(f"LinearSystem: {len(self.names)} names for {self.A.shape[1]} columns")

    @staticmethod
    def stack(systems: Sequence["LinearSystem"]) -> "LinearSystem":
        if not systems:
            raise ValueError("LinearSystem.stack: nothing to stack")
        names = systems[0].names
        for s in systems[1:]:
            if s.names != names:
                raise ValueError(f"LinearSystem.stack: parameter names differ: {names} vs {s.names}")
        cat = lambda attr: np.concatenate([getattr(s, attr) for s in systems])  # noqa: E731
        return LinearSystem(np.vstack([s.A for s in systems]), cat("F"), names, cat("row_record"),
                            cat("row_harmonic"), cat("row_part"), cat("row_equation"))


def spectral_rate(x: np.ndarray, omega_rad_s, n_periods: int) -> np.ndarray:
    """Time derivative of a periodic record by FFT (all harmonics below Nyquist), (n_samples,);
    or of several records ``(n, n_samples)`` with one ``omega_rad_s`` each, shape ``(n, 1)``."""
    n = x.shape[-1]
    per = n // n_periods
    coeffs = fourier_coefficients(x, n_periods, max_harmonic(per))
    harm = np.arange(coeffs.shape[-1])
    return synthesize(1j * harm * omega_rad_s * coeffs, n, n_periods)


def _check_harmonics(record: SteadyStateRecord, n_harmonics: int) -> None:
    top = max_harmonic(record.samples_per_period)
    if not 0 <= n_harmonics <= top:
        raise RecordError(
            f"{record.source}: n_harmonics={n_harmonics} needs more than the record's "
            f"{record.samples_per_period} samples per period (at most {top} harmonics)"
        )


def assemble(columns: np.ndarray, rhs: np.ndarray, names: Sequence[str], *,
             first_harmonic: int = 0) -> LinearSystem:
    """The real rows of the harmonic balance from complex Fourier coefficients: the one place
    that lays the rows out.

    Args:
      columns: coefficients of every column signal in every equation of every record,
        ``(n_params, n_records, n_equations, H + 1)`` (zero where a parameter does not enter).
      rhs: coefficients of the right-hand sides, ``(n_records, n_equations, H + 1)``.
      first_harmonic: 0 keeps the mean (its cosine row only); 1 balances harmonics 1..H.

    Rows run by record, then equation, then harmonic: the mean's cosine row (if kept), then a
    cosine (real part, ``part`` 0) and a sine (imaginary part, ``part`` 1) row per harmonic.
    """
    columns = np.asarray(columns, dtype=complex)
    rhs = np.asarray(rhs, dtype=complex)
    n_params, n_rec, n_eq, n_coef = columns.shape
    if rhs.shape != (n_rec, n_eq, n_coef):
        raise ValueError(f"assemble: rhs {rhs.shape} does not match columns {columns.shape}")
    if first_harmonic not in (0, 1):
        raise ValueError(f"assemble: first_harmonic must be 0 or 1, got {first_harmonic}")
    keep, row_record, row_harmonic, row_part, row_equation = _row_layout(n_rec, n_eq, n_coef - 1, first_harmonic)

    def real_rows(C):  # (..., H + 1) complex -> (..., rows) real: [Re C_1, Im C_1, Re C_2, ...]
        return np.stack([C.real, C.imag], axis=-1).reshape(C.shape[:-1] + (-1,))[..., keep]

    A = real_rows(columns).reshape(n_params, -1).T
    F = real_rows(rhs).reshape(-1)
    return LinearSystem(np.ascontiguousarray(A), F, tuple(names), row_record, row_harmonic, row_part, row_equation)


@functools.lru_cache(maxsize=64)
def _row_layout(n_rec: int, n_eq: int, H: int, first_harmonic: int) -> tuple[np.ndarray, ...]:
    """:func:`assemble`'s row layout for a shape (computed once, read-only): which of the
    interleaved real and imaginary parts of harmonics 0..H are rows, and every row's record,
    harmonic, part and equation."""
    keep = np.arange(2 * first_harmonic, 2 * (H + 1))
    if first_harmonic == 0:  # the mean has no sine row
        keep = np.delete(keep, 1)
    per = keep.size
    harm, part = keep // 2, keep % 2
    k = n_rec * n_eq
    out = (keep, np.repeat(np.arange(n_rec), n_eq * per), np.tile(harm, k), np.tile(part, k),
           np.tile(np.repeat(np.arange(n_eq), per), n_rec))
    for a in out:
        a.setflags(write=False)
    return out


def harmonic_rows(
    columns: np.ndarray,
    rhs: np.ndarray,
    n_harmonics: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Real rows of the harmonic balance of one record and one equation (:func:`assemble`).

    Args:
      columns: complex Fourier coefficients of every column signal, ``(n_params, H + 1)``.
      rhs: complex Fourier coefficients of the right-hand side, ``(H + 1,)``.

    Returns:
      ``A (n_rows, n_params)``, ``F (n_rows,)``, harmonic ``(n_rows,)`` and part ``(n_rows,)``:
      harmonic 0 gives its cosine row only; harmonics 1..H give cosine and sine rows.
    """
    columns = np.asarray(columns)[:, : n_harmonics + 1]
    s = assemble(columns[:, None, None, :], np.asarray(rhs)[None, None, : n_harmonics + 1],
                 ("",) * columns.shape[0])
    return s.A, s.F, s.row_harmonic, s.row_part


def upsample(x: np.ndarray, factor: int) -> np.ndarray:
    """Trigonometric interpolation of a periodic record onto ``factor`` times as many samples
    (exact for a record band-limited below its Nyquist harmonic, which is dropped)."""
    if factor == 1:
        return x
    n = x.shape[-1]
    X = np.fft.rfft(x)
    if n % 2 == 0:
        X[-1] = 0.0
    return np.fft.irfft(X, n=n * factor) * factor


def _term_coeffs(terms: Sequence[Term], phi: np.ndarray, rate: np.ndarray, n_periods: int,
                 n_harmonics: int, oversample: int) -> np.ndarray:
    """Fourier coefficients of every term along the record. ``oversample > 1`` evaluates the
    terms on a finer grid (trigonometric interpolation of phi and rate) first: a term with a
    jump or a kink (dry friction, free play, hysteresis) aliases with error O(1/N) on N
    samples per period; evaluating on ``oversample * N`` cuts that error by the factor."""
    phi, rate = upsample(phi, oversample), upsample(rate, oversample)
    signals = np.vstack([np.broadcast_to(np.asarray(t(phi, rate), dtype=float), phi.shape)
                         for t in terms])
    return fourier_coefficients(signals, n_periods, n_harmonics)


#: Columns already computed, by record identity: records are immutable (read-only arrays), so a
#: record's law column for a term, and its acceleration and torque coefficients, never change.
#: The diagnosis's profile searches rebuild the system for every trial value of one cause's
#: parameter while the other columns stay; this turns those rebuilds into lookups. Each entry
#: holds its record (so its id is not reused while cached); the memo is emptied when full.
_MEMO: dict = {}
_MEMO_MAX = 1024  # at most ~150 records held (about 35 MB at 4096 samples per period)


def memo_arrays(arrays: tuple, key: tuple, compute):
    """The memoised ``compute()``, keyed by the identity of the objects it is computed from (held
    in the entry, so no id is reused while cached): records that share their angles (a record
    whose rate alone was replaced, as the dry-friction kink correction does) share angle-only
    columns."""
    k = tuple(id(a) for a in arrays) + key
    hit = _MEMO.get(k)
    if hit is not None and all(x is y for x, y in zip(hit[0], arrays)):
        return hit[1]
    value = compute()
    if len(_MEMO) >= _MEMO_MAX:
        _MEMO.clear()
    _MEMO[k] = (arrays, value)
    return value


def _memo(rec: SteadyStateRecord, key: tuple, compute):
    """:func:`memo_arrays` keyed by the record itself."""
    return memo_arrays((rec,), key, compute)


def law_rows(terms: Sequence[Term], angles: tuple, rates: tuple, fine_phi, fine_rate, n_periods: int,
             n_harmonics: int, oversample: int, tag: tuple = (), weight: Optional[np.ndarray] = None) -> np.ndarray:
    """Fourier coefficients (harmonics 0..n_harmonics) of each term's torque along one relative
    motion, one memoised row per term: the rows of every builder (two flywheels, chains).

    The motion is that of ``angles`` (the two absolute angles, first minus second) and
    ``rates`` (their rates, entries may be None): ``fine_phi()`` and ``fine_rate()`` give the
    relative angle and rate oversampled ``oversample`` times; each is computed once per set of
    arrays (and ``tag``: what else ``fine_phi`` depends on, a zero offset). A term of the angle alone (elastic, or with memory of the angle: Jenkins, Iwan) is
    keyed by the angles only, any other also by the rates, so a profile search that varies one
    term's parameter, or a kink correction that replaces the rate, re-evaluates only what changed.
    ``weight``: samples (at ``oversample`` 1) that multiply every term's torque before its Fourier
    coefficients are taken (an equation balanced only where it holds: a body's stick phases
    masked out, :func:`identify.chain.chain_system`).
    """
    if weight is not None and oversample != 1:
        raise ValueError("law_rows: a weight needs oversample 1")
    angles = angles + ((weight,) if weight is not None else ())
    motion = angles + rates

    def row(term):
        angle_only = term.elastic or term.stateful

        def compute():
            phi = memo_arrays(angles, ("fine_phi", oversample) + tag, fine_phi)
            rate = np.zeros_like(phi) if angle_only else memo_arrays(motion, ("fine_rate", oversample), fine_rate)
            sig = np.broadcast_to(np.asarray(term(phi, rate), dtype=float), phi.shape)
            return fourier_coefficients(sig if weight is None else sig * weight, n_periods, n_harmonics)
        return memo_arrays(angles if angle_only else motion, ("term", term, n_periods, n_harmonics, oversample) + tag,
                           compute)

    return np.vstack([row(t) for t in terms])


def _record_term_coeffs(rec: SteadyStateRecord, terms: Sequence[Term], n_harmonics: int,
                        oversample: int) -> np.ndarray:
    """:func:`law_rows` along the relative motion of ``rec``."""
    return law_rows(terms, (rec.phi1_rad, rec.phi2_rad), (rec.rate1_rad_s, rec.rate2_rad_s),
                    lambda: upsample(rec.phi_rad, oversample),
                    lambda: upsample(_rate_or_spectral(rec.rate_rad_s, rec.phi_rad, rec), oversample),
                    rec.n_periods, n_harmonics, oversample)


def _rate_or_spectral(rate: Optional[np.ndarray], x: np.ndarray, rec: SteadyStateRecord) -> np.ndarray:
    return rate if rate is not None else spectral_rate(x, rec.omega_rad_s, rec.n_periods)


def _acceleration_coeffs(x: np.ndarray, rate: Optional[np.ndarray], rec: SteadyStateRecord,
                         n_harmonics: int) -> np.ndarray:
    jw = 1j * np.arange(n_harmonics + 1) * rec.omega_rad_s
    if rate is not None:
        return jw * fourier_coefficients(rate, rec.n_periods, n_harmonics)
    return jw**2 * fourier_coefficients(x, rec.n_periods, n_harmonics)


def single_dof_system(
    *,
    omega_rad_s: float,
    n_periods: int,
    x: np.ndarray,
    rate: Optional[np.ndarray],
    forcing: np.ndarray,
    terms: Sequence[Term],
    n_harmonics: int,
    inertia_name: Optional[str] = JE,
    record_index: int = 0,
) -> LinearSystem:
    """Rows of ``J x'' + sum_j theta_j b_j(x, x') = forcing`` for one periodic record.

    Use this for a transformed problem (e.g. the paper's shifted variable alpha = phi + 1);
    :func:`equivalent_system` builds it from rig records. ``inertia_name=None`` leaves the
    inertia out of the unknowns (then ``forcing`` must already hold ``-J x''``).
    """
    rec = SteadyStateRecord(omega_rad_s, np.arange(x.size) * 2 * np.pi * n_periods / (omega_rad_s * x.size),
                            forcing, x, None, rate, None, n_periods, source="single_dof_system")
    return _single(rec, rec.phi1_rad, rec.rate1_rad_s, rec.torque_Nm, terms, n_harmonics,
                   inertia_name, record_index, equation=0, law_sign=1.0)


def _single(rec, x, rate, forcing, terms, n_harmonics, inertia_name, record_index, equation,
            law_sign, oversample=1) -> LinearSystem:
    _check_harmonics(rec, n_harmonics)
    r = _rate_or_spectral(rate, x, rec)
    cols = [law_sign * _term_coeffs(terms, x, r, rec.n_periods, n_harmonics, oversample)]
    names = [t.name for t in terms]
    if inertia_name is not None:
        cols.insert(0, _acceleration_coeffs(x, rate, rec, n_harmonics)[None, :])
        names.insert(0, inertia_name)
    rhs = fourier_coefficients(forcing, rec.n_periods, n_harmonics)
    s = assemble(np.vstack(cols)[:, None, None, :], rhs[None, None, :], names)
    return replace(s, row_record=np.full(s.F.size, record_index), row_equation=np.full(s.F.size, equation))


def equivalent_system(
    records: Sequence[SteadyStateRecord],
    terms: Sequence[Term],
    *,
    n_harmonics: int,
    torque_share: float,
    oversample: int = 1,
) -> LinearSystem:
    """Equivalent one-degree-of-freedom form: unknowns ``(Je_kgm2, theta...)``.

    ``torque_share`` is ``J2 / (J1 + J2)``: the part of the drive torque that strains the
    joint (1 for a record whose torque already acts on the relative coordinate).
    """
    if not 0 < torque_share <= 1:
        raise ValueError(f"torque_share must be in (0, 1], got {torque_share}")
    _check_records(records)
    systems = [
        _single(rec, rec.phi_rad, rec.rate_rad_s, torque_share * rec.torque_Nm, terms, n_harmonics,
                JE, i, equation=0, law_sign=1.0, oversample=oversample)
        for i, rec in enumerate(records)
    ]
    return LinearSystem.stack(systems)


def two_dof_system(
    records: Sequence[SteadyStateRecord],
    terms: Sequence[Term],
    *,
    n_harmonics: int,
    bearings: bool = False,
    oversample: int = 1,
) -> LinearSystem:
    """Direct two-degree-of-freedom form: unknowns ``(J1_kgm2, J2_kgm2, theta...)``.

    ``bearings=True`` adds viscous drag of each flywheel to ground (bearing friction), unknowns
    ``bearing1_damping_Nms_per_rad`` and ``bearing2_damping_Nms_per_rad`` at the end:
    ``J1 phi1'' + M_v + b1 phi1' = T``, ``J2 phi2'' - M_v + b2 phi2' = 0``.
    """
    _check_records(records)
    columns = []
    for rec in records:
        if rec.phi2_rad is None:
            raise RecordError(f"{rec.source}: the two-degree-of-freedom form needs 'phi2_rad'")
        _check_harmonics(rec, n_harmonics)
        law = _record_term_coeffs(rec, terms, n_harmonics, oversample)
        acc1, acc2, torque = _memo(rec, ("acc_torque", n_harmonics), lambda: (
            _acceleration_coeffs(rec.phi1_rad, rec.rate1_rad_s, rec, n_harmonics),
            _acceleration_coeffs(rec.phi2_rad, rec.rate2_rad_s, rec, n_harmonics),
            fourier_coefficients(rec.torque_Nm, rec.n_periods, n_harmonics)))
        zero = np.zeros_like(acc1)
        eq1, eq2 = [acc1, zero, *law], [zero, acc2, *(-law)]
        if bearings:
            jw = 1j * np.arange(n_harmonics + 1) * rec.omega_rad_s
            eq1 += [jw * fourier_coefficients(rec.phi1_rad, rec.n_periods, n_harmonics), zero]
            eq2 += [zero, jw * fourier_coefficients(rec.phi2_rad, rec.n_periods, n_harmonics)]
        columns.append((np.array(eq1), np.array(eq2), torque))
    names = (J1, J2) + tuple(t.name for t in terms) + ((BEARING1, BEARING2) if bearings else ())
    cols = np.stack([np.stack([a, b], axis=1) for a, b, _ in columns], axis=1)  # (params, records, 2, H+1)
    rhs = np.stack([np.stack([t, np.zeros_like(t)]) for _, _, t in columns])
    return assemble(cols, rhs, names)


def _check_records(records: Sequence[SteadyStateRecord]) -> None:
    if len(records) == 0:
        raise ValueError("no records to identify from")
    for r in records:
        if not isinstance(r, SteadyStateRecord):
            raise TypeError(f"expected SteadyStateRecord, got {type(r).__name__}")
