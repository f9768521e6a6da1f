"""The result family of every identification: parameters by typed name, with standard errors and
the status of the fit that produced them.

Each fit of the project (:class:`identify.solve.IdentificationResult`, the errors-in-variables
:class:`identify.eiv.EivResult`, the diagnosis's :class:`identify.chain_diagnose.ChainFit`, the
output-error
:class:`identify.output_error.OutputErrorResult`) is a frozen dataclass that is an
:class:`Estimates`: it holds ``names`` (unit-carrying, :class:`jointrig.vocab.params.Param`),
``values``, ``std_errors``, ``condition_number`` (of the problem its solver inverted: the
column-equilibrated regression matrix or Jacobian), ``success`` and ``message``, and is asked
by name: ``fit.value(J1)``, ``fit.std_error("k_Nm_per_rad")``, ``J1 in fit``. Results that
are more than one fit (the unknown law's :class:`identify.hat.HatFit`, the Silverbox's
:class:`identify.extend.ExtensionResult`) carry one (``.result``, ``.fit``).
"""

from __future__ import annotations

import math

import numpy as np

from jointrig.vocab.params import Param

__all__ = ["Estimates", "RowFit", "weighted_chi2", "equilibrated_condition", "satterthwaite", "interval_factor"]

#: The confidence of every interval the diagnosis reports (value +- half width).
INTERVAL_LEVEL = 0.95


def satterthwaite(sizes, dofs) -> float:
    """The degrees of freedom of a sum of independent variance estimates (Welch-Satterthwaite):
    ``(sum s)^2 / sum(s^2 / nu)`` over the parts ``sizes`` of ``dofs`` degrees of freedom each
    (a scalar for all; inf: a part known exactly). inf where nothing is estimated (pure)."""
    s = np.asarray(sizes, dtype=float)
    nu = np.broadcast_to(np.asarray(dofs, dtype=float), s.shape)
    est = np.isfinite(nu) & (nu > 0) & (s > 0)
    spread = float(np.sum(s[est] ** 2 / nu[est]))
    total = float(np.sum(s[s > 0]))
    if not (total > 0 and spread > 0):
        return math.inf
    return total ** 2 / spread


def interval_factor(dof: float, level: float = INTERVAL_LEVEL) -> float:
    """What a standard error estimated with ``dof`` degrees of freedom is multiplied by for a
    two-sided ``level`` interval: Student's t quantile (1.96 at 95% for a known error, 2.57 at
    five degrees of freedom). A standard error read from a few periods' scatter is itself
    uncertain, and 1.96 of it holds the truth less often than 95%."""
    from scipy.special import ndtri, stdtrit

    q = 0.5 + 0.5 * level
    if not math.isfinite(dof) or dof > 1e7:
        return float(ndtri(q))
    return float(stdtrit(max(dof, 1.0), q))


class Estimates:
    """Parameters addressed by name (see the module docstring). Nonlinear parameters found by a
    profile search (a free play, a slip angle) are not among ``names``; a result that has them
    lists ``(name, standard error)`` in :meth:`_profiled_std_errors`."""

    # The attributes every member holds (as dataclass fields):
    names: tuple
    values: object
    std_errors: object
    condition_number: float
    success: bool
    message: str

    @property
    def params(self) -> tuple[Param, ...]:
        """The parameter names, typed (each knows its unit)."""
        return tuple(Param(n) for n in self.names)

    def __contains__(self, name: str) -> bool:
        return name in self.names

    def value(self, name: str) -> float:
        try:
            return float(self.values[self.names.index(name)])
        except ValueError:
            raise KeyError(f"no parameter '{name}'; have {list(self.names)}") from None

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.names, (float(v) for v in self.values)))

    def std_error(self, name: str) -> float:
        """Standard error of any parameter, profiled nonlinear ones included (NaN if unknown)."""
        if name in self.names:
            return float(self.std_errors[self.names.index(name)])
        return float(self._profiled_std_errors().get(name, math.nan))

    def _profiled_std_errors(self) -> dict[str, float]:
        return {}

    def std_error_dof(self, name: str) -> float:
        """The degrees of freedom of ``name``'s standard error (inf: taken as known)."""
        return float(self._std_error_dofs().get(name, math.inf))

    def interval(self, name: str, level: float = INTERVAL_LEVEL) -> float:
        """Half the width of ``name``'s two-sided ``level`` interval: its standard error times
        :func:`interval_factor` of its degrees of freedom (NaN without a standard error)."""
        return self.std_error(name) * interval_factor(self.std_error_dof(name), level)

    def _std_error_dofs(self) -> dict[str, float]:
        return {}


class RowFit(Estimates):
    """A weighted least-squares fit of ``n_rows`` harmonic-balance rows (the diagnosis's
    :class:`identify.chain_diagnose.ChainFit`), with its degrees of freedom."""

    n_rows: int

    @property
    def dof(self) -> int:
        return self.n_rows - len(self.names)


def weighted_chi2(residual: np.ndarray, weights: np.ndarray, nu: float, dof: int
                  ) -> tuple[np.ndarray, float, float, float]:
    """Chi-square of balance rows whose weights were estimated from the data (``nu`` degrees of
    freedom each: the inverse of such a variance estimate is ``nu / (nu - 2)`` times too large on
    average, so ``E[chi2] = dof nu / (nu - 2)``, and it is scaled by ``(nu - 2) / nu``), each
    row's share, and the covariance: the inverse of half the scaled chi-square's Hessian,
    ``(A'WA)^-1 nu / (nu - 2)``, times ``chi2 / dof`` when the fit is worse than the noise (model
    error). Scaled alike, a linear parameter's standard error and a profiled one's (from the
    chi-square's curvature, :func:`identify.causes.profile`) follow one convention; unscaled, the
    linear ones were ``sqrt(nu / (nu - 2))`` too small (1.12 at six periods: the linear train's
    RMS z 1.12 and 1.22 at six and four periods, ``scripts/coverage_periods.py --harmonics 1``).
    Returns ``(row chi2, chi2, factor on the solver's covariance, factor on (A'WA)^-1)``."""
    corr = (nu - 2) / nu if nu > 2 else 1.0
    row = weights * residual**2 * corr
    chi2 = float(row.sum())
    dof = max(dof, 1)
    s2_raw = float(np.sum(weights * residual**2)) / dof
    on_inverse = max(1.0, chi2 / dof) / corr
    return row, chi2, on_inverse / max(s2_raw, 1e-300), on_inverse


def equilibrated_condition(J) -> float:
    """Condition number of ``J`` with its columns scaled to unit 2-norm (what a least-squares
    solve of it loses in digits, whatever units its columns carry); inf if a column is zero."""
    J = np.asarray(J, dtype=float)
    norms = np.linalg.norm(J, axis=0)
    if J.size == 0 or np.any(norms == 0):
        return math.inf
    sv = np.linalg.svd(J / norms, compute_uv=False)
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
