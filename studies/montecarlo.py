"""Monte Carlo of the noisy-data identifiers against the Cramer-Rao lower bound.

Noise-free steady-state runs (from the rig) are measured many times over with the rig's
measurement model (:func:`rig.measurement.add_noise`: white Gaussian noise on both angles and
the torque at a stated SNR per channel, rates not recorded), each time over ``n_periods``
periods, and identified by the errors-in-variables maximum-likelihood harmonic balance
(:func:`identify.eiv.ml_identify`). Per parameter: bias over the observed standard deviation,
efficiency (CRLB variance / observed variance), coverage of the 95% intervals (estimate
+- 1.96 standard errors), the CRLB standard deviation and the observed one. Plain least
squares on the same records (:func:`identify.identify`, the noise-free tool: biased by the
noise in [A]) is reported beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from jointrig.identify import identify
from jointrig.vocab.law import Term
from jointrig.identify.eiv import crlb, ml_identify
from jointrig.vocab.records import SteadyStateRecord

from jointrig.rig.measurement import add_noise, noise_std, repeat_periods
from jointrig.vocab.params import JE

__all__ = ["ParameterStats", "MonteCarloResult", "monte_carlo"]

#: Two-sided 95% normal quantile.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class ParameterStats:
    """One parameter over the Monte Carlo (units of the parameter)."""

    name: str
    true: float
    mean: float
    std: float
    crlb_std: float
    coverage: float
    mean_std_error: float
    ls_mean: float
    ls_std: float

    @property
    def bias_over_std(self) -> float:
        return (self.mean - self.true) / self.std

    @property
    def efficiency(self) -> float:
        return self.crlb_std**2 / self.std**2

    @property
    def ls_bias_over_std(self) -> float:
        return (self.ls_mean - self.true) / self.ls_std

    def as_json(self) -> dict:
        return {"bias_over_std": self.bias_over_std, "efficiency": self.efficiency, "coverage": self.coverage,
                "crlb_std": self.crlb_std, "std": self.std, "true": self.true, "mean": self.mean,
                "mean_std_error": self.mean_std_error, "ls_bias_over_std": self.ls_bias_over_std,
                "ls_efficiency": self.crlb_std**2 / self.ls_std**2}


@dataclass(frozen=True)
class MonteCarloResult:
    snr_db: float
    n_runs: int
    n_periods: object  # int, or a tuple per run
    parameters: tuple[ParameterStats, ...]
    failures: int
    #: the ML cost over its degrees of freedom in each realisation (about 1 for a right model)
    cost_over_dof: tuple[float, ...] = ()

    def as_json(self) -> dict:
        return {"snr_db": self.snr_db, "n_runs": self.n_runs, "n_periods": self.n_periods,
                "failures": self.failures, "parameters": {p.name: p.as_json() for p in self.parameters}}


def monte_carlo(noiseless: Sequence[SteadyStateRecord], terms: Sequence[Term], truth: dict[str, float], *,
                snr_db: float, n_runs: int, n_periods, n_harmonics: int, torque_share: float,
                seed: int = 0, encoder_resolution_rad: Optional[float] = None,
                sigma: Optional[tuple[float, float]] = None,
                progress: Optional[Callable[[int, int], None]] = None) -> MonteCarloResult:
    """Identify ``n_runs`` noisy measurements of the same runs; compare with the CRLB.

    Args:
      noiseless: steady-state runs without noise (one period or more each).
      truth: true ``Je_kgm2`` and law parameters by name.
      n_periods: measured periods, one number for all runs or one per run.
      sigma: fixed noise standard deviations (angle rad, torque N m) instead of ``snr_db``.
      encoder_resolution_rad: quantise the angles (the CRLB counts q^2 / 12 per encoder as
        white noise, which holds while the noise spans several counts).
    """
    if n_runs < 2:
        raise ValueError(f"n_runs must be >= 2, got {n_runs}")
    periods = [n_periods] * len(noiseless) if np.isscalar(n_periods) else [int(x) for x in n_periods]
    if len(periods) != len(noiseless):
        raise ValueError(f"n_periods: {len(periods)} values for {len(noiseless)} runs")
    base = [repeat_periods(r, P) for r, P in zip(noiseless, periods)]
    names = (JE,) + tuple(t.name for t in terms)
    theta0 = np.array([truth[n] for n in names])
    # Noise per channel as add_noise draws it: fixed (sigma) or from the channel's own RMS; the
    # encoder adds q^2 / 12 per angle.
    quant = 0.0 if encoder_resolution_rad is None else encoder_resolution_rad**2 / 12

    def var(x, fixed):
        return fixed**2 if sigma is not None else noise_std(x, snr_db) ** 2

    var_phi = [sum(var(x, sigma and sigma[0]) + quant for x in (r.phi1_rad, r.phi2_rad) if x is not None) for r in base]
    var_u = [var(r.torque_Nm, sigma and sigma[1]) for r in base]
    bound = crlb(base, terms, theta0, var_phi_rad2=var_phi, var_torque_Nm2=var_u, n_periods=periods,
                 n_harmonics=n_harmonics, torque_share=torque_share)
    rng = np.random.default_rng(seed)
    est, se, start, cost = [], [], [], []
    failures = 0
    for k in range(n_runs):
        noisy = [add_noise(r, snr_db, rng, encoder_resolution_rad=encoder_resolution_rad, sigma=sigma) for r in base]
        res = ml_identify(noisy, terms, n_harmonics=n_harmonics, torque_share=torque_share)
        if not res.success:
            failures += 1
        est.append(res.values)
        se.append(res.std_errors)
        cost.append(res.cost / max(res.dof, 1))
        start.append(identify(noisy, terms, form="equivalent", n_harmonics=n_harmonics,
                              torque_share=torque_share).values)
        if progress is not None:
            progress(k + 1, n_runs)
    est, se, start = np.array(est), np.array(se), np.array(start)
    stats = []
    for i, name in enumerate(names):
        stats.append(ParameterStats(
            name=name, true=float(theta0[i]), mean=float(est[:, i].mean()), std=float(est[:, i].std(ddof=1)),
            crlb_std=float(math.sqrt(bound[i, i])),
            coverage=float(np.mean(np.abs(est[:, i] - theta0[i]) <= Z95 * se[:, i])),
            mean_std_error=float(se[:, i].mean()), ls_mean=float(start[:, i].mean()),
            ls_std=float(start[:, i].std(ddof=1))))
    return MonteCarloResult(float(snr_db), n_runs, n_periods if np.isscalar(n_periods) else tuple(periods),
                            tuple(stats), failures, tuple(float(c) for c in cost))
