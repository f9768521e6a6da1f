"""Least squares and weighted least squares for [A]{S} = {F} (paper eq. 7 and its weighted form).

The columns of [A] carry very different units (kg m^2 next to N m/rad^3), so the solve
works on the column-equilibrated matrix ``A D`` (``D`` = 1 / column 2-norms, after row
weighting) with an SVD; the reported condition number is that of ``W^1/2 A D``, the one
that governs the accuracy of the solve.

Standard errors follow the usual linear-regression estimate: residual variance
``s^2 = r' W r / (m - p)`` and ``cov(S) = s^2 (A' W A)^-1``. They reflect everything the
model does not explain (integrator error for simulated data, noise for measured data);
issue-level noise models supply proper weights on top of this.
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from typing import Sequence

from .estimates import Estimates
from .balance import LinearSystem, equivalent_system, two_dof_system
from jointrig.vocab.law import Term, duplicate_names
from jointrig.vocab.records import SteadyStateRecord

__all__ = ["IdentificationResult", "solve", "identify", "IllConditionedWarning", "FORMS"]

FORMS = ("equivalent", "two_dof")

log = logging.getLogger(__name__)

#: Above this condition number of the equilibrated matrix the solve loses about half of
#: double precision's 16 digits; we warn (and still solve).
COND_WARN = 1e8


class IllConditionedWarning(UserWarning):
    """The regression matrix is nearly rank-deficient: some parameters are not identifiable."""


@dataclass(frozen=True)
class IdentificationResult(Estimates):
    """Outcome of a harmonic-balance regression.

    Attributes:
      names: parameter names with units, ``(p,)``.
      values: identified parameters, ``(p,)``.
      std_errors: standard errors, ``(p,)``.
      covariance: ``(p, p)``.
      condition_number: of the row-weighted, column-equilibrated [A].
      residual_rms: RMS of the weighted residual ``W^1/2 (A S - F)``.
      relative_residual: ``||W^1/2 (A S - F)|| / ||W^1/2 F||``.
      n_rows, dof: equations used and degrees of freedom ``n_rows - p``.
      success, message: status (False when rank-deficient).
    """

    names: tuple[str, ...]
    values: np.ndarray
    std_errors: np.ndarray
    covariance: np.ndarray
    condition_number: float
    residual_rms: float
    relative_residual: float
    n_rows: int
    dof: int
    success: bool
    message: str



def solve(system: LinearSystem, *, row_weights: Optional[np.ndarray] = None) -> IdentificationResult:
    """Weighted least-squares solution of ``A S = F``.

    Args:
      system: the stacked harmonic-balance rows.
      row_weights: positive weights ``w_i`` (the diagonal of [W]), shape ``(n_rows,)``;
        None for ordinary least squares (paper eq. 7).
    """
    A, F = system.A, system.F
    m, p = A.shape
    if m < p:
        raise ValueError(f"{m} equations for {p} unknowns {list(system.names)}: add harmonics or runs")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(F))):
        raise ValueError("the regression matrix or right-hand side holds non-finite values")
    if row_weights is None:
        sw = np.ones(m)
    else:
        w = np.asarray(row_weights, dtype=float)
        if w.shape != (m,):
            raise ValueError(f"row_weights has shape {w.shape}, expected ({m},)")
        if np.any(~np.isfinite(w)) or np.any(w <= 0):
            raise ValueError("row_weights must be finite and > 0")
        sw = np.sqrt(w)
    Aw = A * sw[:, None]
    Fw = F * sw
    norms = np.linalg.norm(Aw, axis=0)
    zero = norms == 0
    if zero.any():
        bad = [system.names[i] for i in np.flatnonzero(zero)]
        raise ValueError(f"parameters {bad} have an all-zero column: the data do not excite them")
    D = 1.0 / norms
    U, sv, Vt = np.linalg.svd(Aw * D, full_matrices=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    rank_tol = sv[0] * max(m, p) * np.finfo(float).eps
    rank = int(np.sum(sv > rank_tol))
    success = rank == p
    inv_sv = np.where(sv > rank_tol, 1.0 / np.where(sv > 0, sv, 1.0), 0.0)
    y = Vt.T @ (inv_sv * (U.T @ Fw))
    S = D * y
    r = Aw @ S - Fw
    dof = m - p
    s2 = float(r @ r) / dof if dof > 0 else math.nan
    cov_scaled = (Vt.T * inv_sv**2) @ Vt
    cov = s2 * (D[:, None] * cov_scaled * D[None, :])
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    if not success:
        message = f"rank-deficient: rank {rank} < {p} unknowns (condition number {cond:.3g})"
    elif cond > COND_WARN:
        message = (f"ill-conditioned: condition number {cond:.3g} > {COND_WARN:.0e} "
                   f"(about half of double precision lost); check the standard errors")
        warnings.warn(message, IllConditionedWarning, stacklevel=2)
    else:
        message = "ok"
    normF = float(np.linalg.norm(Fw))
    result = IdentificationResult(
        names=tuple(system.names), values=S, std_errors=std, covariance=cov,
        condition_number=cond, residual_rms=float(np.sqrt(np.mean(r**2))),
        relative_residual=float(np.linalg.norm(r) / normF) if normF > 0 else math.inf,
        n_rows=m, dof=dof, success=success, message=message,
    )
    for arr in (result.values, result.std_errors, result.covariance):
        arr.setflags(write=False)
    log.debug("solved %d rows x %d unknowns: cond %.3g, relative residual %.3g",
              m, p, cond, result.relative_residual)
    return result


def identify(
    records: Sequence[SteadyStateRecord],
    terms: Sequence[Term],
    *,
    form: str = "equivalent",
    n_harmonics: int = 9,
    torque_share: Optional[float] = None,
    row_weights: Optional[np.ndarray] = None,
) -> IdentificationResult:
    """Harmonic-balance identification from steady-state records (build rows, then solve).

    Args:
      form: ``"equivalent"`` (unknowns Je and the law; needs ``torque_share`` = J2/(J1+J2))
        or ``"two_dof"`` (unknowns J1, J2 and the law).
      n_harmonics: harmonics 0..H balanced per record.

    Raises:
      ValueError: a term given twice (two columns of one parameter: the system is singular and
        its estimates would be split between them), or an unknown form.
    """
    dup = duplicate_names(terms)
    if dup:
        raise ValueError(f"identify: the terms {dup} are given more than once; expected each term once")
    if form == "equivalent":
        if torque_share is None:
            raise ValueError("form 'equivalent' needs torque_share = J2 / (J1 + J2)")
        system = equivalent_system(records, terms, n_harmonics=n_harmonics, torque_share=torque_share)
    elif form == "two_dof":
        system = two_dof_system(records, terms, n_harmonics=n_harmonics)
    else:
        raise ValueError(f"unknown form {form!r}; expected one of {FORMS}")
    return solve(system, row_weights=row_weights)
