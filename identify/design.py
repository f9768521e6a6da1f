"""D-optimal excitation design under a test-time budget (pure).

Given candidate runs (a drive frequency and amplitude each) with the Fisher information one
measured period carries (:func:`identify.eiv.fisher_per_period`, under the bench's noise
model), choose how many periods to measure of each so that the parameter covariance bound
``(sum_i p_i F_i)^-1`` has the smallest determinant (D-optimality: the smallest joint
confidence ellipsoid, independent of the parameters' units) within a budget of test time:
``sum_i (p_i T_i + setup_s [p_i > 0]) <= budget_s``, with T_i the period and ``setup_s`` the
time a run costs before it can be measured (reaching steady state, changing the setting).

The allocation is greedy: starting from nothing, repeatedly add the step (a first block of
``min_periods`` periods for an unused run, one more period for a used one) with the largest
gain in log det per second, until nothing more fits. Then run exchanges: drop all periods of
one run, refill greedily without it, and keep the result if log det grew; repeat until no
exchange helps. (A greedy start favours candidates informative in every direction at once;
the exchanges undo that.) log det is concave in the allocation, so every step's gain is a
true marginal gain; the result is a local optimum of the integer problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

__all__ = ["Design", "d_optimal", "design_cost_s", "log_det", "crlb_std", "d_efficiency", "chain_modes_rad_s"]


def log_det(F: np.ndarray) -> float:
    sign, val = np.linalg.slogdet(F)
    return float(val) if sign > 0 else -math.inf


def design_cost_s(periods: Sequence[int], period_s: Sequence[float], setup_s: float) -> float:
    """Test time of an allocation: measured periods plus the setup of every run used (s)."""
    return float(sum(p * t + (setup_s if p > 0 else 0.0) for p, t in zip(periods, period_s)))


@dataclass(frozen=True)
class Design:
    """An allocation of measured periods to candidate runs.

    Attributes:
      periods: periods to measure per candidate (0: not used).
      cost_s: test time it takes; budget_s: the budget.
      covariance: the CRLB ``(sum p_i F_i)^-1``; log_det_fisher: log det of the information.
    """

    periods: tuple[int, ...]
    cost_s: float
    budget_s: float
    covariance: np.ndarray
    log_det_fisher: float


def _greedy(F: np.ndarray, T: np.ndarray, budget_s: float, setup_s: float, min_periods: int, ridge: np.ndarray,
            alloc: np.ndarray, banned: frozenset = frozenset()) -> np.ndarray:
    """Fill ``alloc`` greedily (largest log-det gain per second first) until nothing fits."""
    alloc = alloc.copy()
    total = np.einsum("i,ijk->jk", alloc.astype(float), F)
    spent = design_cost_s(alloc, T, setup_s)
    idx = np.arange(len(F))
    while True:
        k = np.where(alloc == 0, min_periods, 1)
        cost = k * T + np.where(alloc == 0, setup_s, 0.0)
        ok = (spent + cost <= budget_s + 1e-9) & ~np.isin(idx, list(banned))
        if not ok.any():
            break
        sign, base = np.linalg.slogdet(total + ridge)
        sgn, val = np.linalg.slogdet(total[None] + k[:, None, None] * F + ridge[None])
        rate = np.where(ok & (sgn > 0), (val - base) / cost, -np.inf)
        i = int(np.argmax(rate))
        if not rate[i] > 0:
            break
        alloc[i] += k[i]
        total = total + k[i] * F[i]
        spent += cost[i]
    return alloc


def d_optimal(fishers: Sequence[np.ndarray], period_s: Sequence[float], budget_s: float, *,
              setup_s: float = 1.0, min_periods: int = 4) -> Design:
    """D-optimal allocation of measured periods within ``budget_s`` seconds: greedy, then
    run exchanges (drop a run's periods, refill greedily, keep if log det grows) until none helps.

    Args:
      fishers: Fisher information of one period of each candidate, ``(p, p)`` each.
      period_s: each candidate's period (s).
      setup_s: time a run costs before its first measured period (s).
      min_periods: periods measured at least in a run that is used (the noise estimate and
        the instrumental-variable start need 4).

    Raises:
      ValueError: the budget admits no nonsingular design.
    """
    F = np.array([np.asarray(f, dtype=float) for f in fishers])
    T = np.array([float(t) for t in period_s])
    if len(F) != len(T) or not len(F):
        raise ValueError("need one period per candidate Fisher matrix, and at least one candidate")
    p = F.shape[1]
    # A tiny ridge lets log det rank steps before the information is full rank; it is scaled
    # to each parameter's largest single-candidate information, so it favours no parameter.
    ridge = np.diag(np.maximum(np.max(np.diagonal(F, axis1=1, axis2=2), axis=0), 1e-300)) * 1e-9

    def score(a):
        return log_det(np.einsum("i,ijk->jk", a.astype(float), F))

    best = _greedy(F, T, budget_s, setup_s, min_periods, ridge, np.zeros(len(F), dtype=int))
    improved = True
    while improved:
        improved = False
        for i in np.flatnonzero(best):
            trial = best.copy()
            trial[i] = 0
            trial = _greedy(F, T, budget_s, setup_s, min_periods, ridge, trial, banned=frozenset({int(i)}))
            if score(trial) > score(best) + 1e-9:
                best, improved = trial, True
                break
    total = np.einsum("i,ijk->jk", best.astype(float), F)
    ld = log_det(total)
    if not math.isfinite(ld):
        raise ValueError(f"a budget of {budget_s:g} s admits no design that determines all {p} parameters")
    return Design(tuple(int(x) for x in best), design_cost_s(best, T, setup_s), float(budget_s), np.linalg.inv(total), ld)


def crlb_std(fisher: np.ndarray) -> np.ndarray:
    """Cramer-Rao bound on each parameter's standard error: sqrt(diag(F^-1)), ``(p,)``."""
    return np.sqrt(np.diag(np.linalg.inv(fisher)))


def d_efficiency(log_det_design: float, fisher_reference: np.ndarray) -> float:
    """D-efficiency of a design against a reference: (det F_design / det F_ref)^(1/p); above 1
    the design's joint confidence region is smaller for the same test time."""
    p = fisher_reference.shape[0]
    return float(np.exp((log_det_design - log_det(fisher_reference)) / p))


def chain_modes_rad_s(inertias_kgm2: Sequence[float], stiffnesses_Nm_per_rad: Sequence[float]) -> tuple[float, ...]:
    """Undamped natural frequencies (rad/s, ascending) of flywheels in a chain, joint j a spring
    of stiffness k_j between flywheels j and j+1: the square roots of the eigenvalues of J^-1 K,
    the rigid-body mode (0) left out."""
    J = np.asarray(inertias_kgm2, dtype=float)
    K = np.zeros((J.size, J.size))
    for j, k in enumerate(stiffnesses_Nm_per_rad):
        K[j:j + 2, j:j + 2] += k * np.array([[1.0, -1.0], [-1.0, 1.0]])
    modes = np.sqrt(np.clip(np.linalg.eigvals(np.linalg.solve(np.diag(J), K)).real, 0, None))
    return tuple(sorted(float(m) for m in modes if m > 1e-6))
