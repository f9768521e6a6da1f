"""What the nominal model gets wrong on periodic one-coordinate data, and the smallest physical
extension that fixes it.

* :func:`residual_analysis`: where the simulation error sits, by line group (excited, odd and
  even non-excited, DC), and the phase trend of simulated vs measured response over frequency
  (a slope is a delay).
* :func:`score_candidates`: rank candidate effects by the score (Lagrange-multiplier) test: the
  part of the output-error residual that the candidate's sensitivity explains after the present
  parameters' sensitivities are projected out; ``reduction / sigma^2`` is chi-square(1) under
  "no such effect", with sigma^2 the residual variance (conservative: it holds model error too).
* :func:`extend_model`: greedy forward selection (the loop every pipeline shares,
  :func:`identify.causes.forward_select`): fit the best-ranked candidate by output error on
  training records and keep it only if the simulation error on held-out records drops by at
  least ``min_gain``; re-rank and repeat; stop at the first rejection. Ranking by evidence,
  acceptance by validation, never by order.
"""

from __future__ import annotations

import math

import logging
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from jointrig.vocab.law import JointLaw, Term
from jointrig.vocab.params import DRIVE_DELAY
from jointrig.parallel import fork_map

from .causes import OSCILLATOR_CAUSES, Cause, CauseScore, ModelSpec, evidence, forward_select
from .output_error import OutputErrorResult, refine_output_error, simulate_periods

__all__ = ["removable", "residual_spectrum", "ResidualAnalysis", "ExtensionStep", "ExtensionResult",
           "residual_analysis", "score_candidates", "extend_model", "indistinguishable", "INDISTINGUISHABLE_SHARE"]

log = logging.getLogger(__name__)


def _added_term(cause: Cause) -> Optional[Term]:
    """The law term a catalogued cause adds (None: the cause is a late input, a delay of the
    drive, which the simulation takes as a parameter rather than a term)."""
    if cause.profiled == DRIVE_DELAY:
        return None
    terms = cause.extend(ModelSpec(()), 0.0).terms
    if len(terms) != 1:
        raise ValueError(f"cause {cause.name!r} adds {len(terms)} terms; the oscillator scores single-term "
                         f"extensions only")
    return terms[0]


@dataclass(frozen=True)
class ResidualAnalysis:
    """Simulation residual ``y_sim - y`` by line group (power summed over lines and records, V^2
    in data units), the measured output's power in the same groups, and the phase trend.

    Attributes:
      groups: names of the line groups.
      residual_power, measured_power: ``(len(groups),)``.
      phase_slope_s: slope of arg(Y_sim / Y) over the excited lines against omega (s); a pure
        delay tau of the model relative to the data gives -tau.
      dc_residual: mean residual (data units).
    """

    groups: tuple[str, ...]
    residual_power: np.ndarray
    measured_power: np.ndarray
    phase_slope_s: float
    dc_residual: float


def residual_analysis(y_sim: np.ndarray, y: np.ndarray, fs_Hz: float, excited: np.ndarray,
                      band_max_bin: int) -> ResidualAnalysis:
    """Split the residual of ``(R, N)`` periodic records into line groups within the band."""
    n = y.shape[-1]
    R = np.fft.rfft(y_sim - y, axis=-1) / n
    Y = np.fft.rfft(y, axis=-1) / n
    Ys = np.fft.rfft(y_sim, axis=-1) / n
    k = np.arange(R.shape[-1])
    exc = np.zeros(k.size, bool)
    exc[excited] = True
    inband = (k > 0) & (k <= band_max_bin)
    masks = {"excited": exc, "odd_not_excited": inband & (k % 2 == 1) & ~exc, "even": inband & (k % 2 == 0),
             "dc": k == 0, "above_band": k > band_max_bin}
    rp = np.array([np.sum(np.abs(R[:, m]) ** 2) for m in masks.values()])
    mp = np.array([np.sum(np.abs(Y[:, m]) ** 2) for m in masks.values()])
    w = 2 * np.pi * fs_Hz * k[exc] / n
    ph = np.angle(np.sum(Ys[:, exc] * np.conj(Y[:, exc]), axis=0))
    weights = np.sum(np.abs(Y[:, exc]) ** 2, axis=0)
    slope = float(np.sum(weights * w * ph) / np.sum(weights * w * w))
    return ResidualAnalysis(tuple(masks), rp, mp, slope, float(np.mean(y_sim - y)))


def residual_spectrum(y_sim: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Mean magnitude over records of each line of the simulation residual ``y_sim - y`` of
    ``(R, N)`` periodic records, ``(N // 2 + 1,)`` in data units per line (``|X_k| / N``)."""
    return np.abs(np.fft.rfft(y_sim - y, axis=-1)).mean(axis=0) / y.shape[-1]


#: Two candidates whose removable residual is within this share of each other explain nearly
#: the same part of it: the data cannot tell them apart.
INDISTINGUISHABLE_SHARE = 0.9


def removable(score: CauseScore) -> float:
    """What a scored cause can remove of the residual sum of squares (data units^2)."""
    return score.signature["removable_rss"]


def indistinguishable(scores: Sequence[CauseScore]) -> Optional[tuple[str, str, float]]:
    """``(best, runner-up, relative difference of their removable residual)`` when the two
    best-scored candidates explain nearly the same part of the residual (the runner-up removes
    more than :data:`INDISTINGUISHABLE_SHARE` of what the best removes), else None."""
    if len(scores) > 1 and removable(scores[1]) > INDISTINGUISHABLE_SHARE * removable(scores[0]):
        return scores[0].effect, scores[1].effect, 1 - removable(scores[1]) / removable(scores[0])
    return None


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def score_candidates(u: np.ndarray, y: np.ndarray, fs_Hz: float, *, inertia: float, law: JointLaw,
                     delay_s: float = 0.0, candidates: Sequence[Cause] = OSCILLATOR_CAUSES
                     ) -> tuple[CauseScore, ...]:
    """Score test of each catalogued cause at the present fit, best first (largest reduction):
    the one score type of every diagnosis (:class:`identify.causes.CauseScore`), with
    ``delta_chi2`` the test's chi-square, no fit (the test fits nothing), the magnitude's start
    value (one Gauss-Newton step) and in ``signature`` the residual sum of squares it can remove
    (``removable_rss``, data units^2) and the RMS residual left after (``predicted_rms``)."""
    y0, Y0 = simulate_periods(inertia, law, u, fs_Hz, delay_s=delay_s)
    r = (y0 - y).ravel()
    n_per = y.shape[-1]
    x0 = y0.ravel()
    v0 = np.fft.irfft(Y0 * 1j * 2 * np.pi * fs_Hz / n_per * np.arange(Y0.shape[-1]), n=n_per, axis=-1).ravel()
    torque_rms = _rms(law.torque(x0, v0))
    n = r.size

    def sens(J, lw, tau, step):
        ys, _ = simulate_periods(J, lw, u, fs_Hz, delay_s=tau, initial=Y0)
        return ((ys - y0) / step).ravel()

    cols = []
    h = 1e-6 * abs(inertia)
    cols.append(sens(inertia + h, law, delay_s, h))
    for i, v in enumerate(law.values):
        hv = 1e-6 * abs(v) if v != 0 else 1e-6
        vals = list(law.values)
        vals[i] += hv
        cols.append(sens(inertia, JointLaw(law.terms, tuple(vals)), delay_s, hv))
    S = np.column_stack(cols)
    Q, _ = np.linalg.qr(S / np.linalg.norm(S, axis=0))
    rss = float(r @ r)
    sigma2 = rss / (n - S.shape[1])
    scores = []
    for cand in candidates:
        term = _added_term(cand)
        if term is not None and term.name in law.names:
            continue
        if term is None:
            hd = 1e-3 / fs_Hz
            s = sens(inertia, law, delay_s + hd, hd)
        else:
            # sensitivity to a small coefficient of the new term: its torque is 1e-6 of the law's
            hc = 1e-6 * torque_rms / max(_rms(term(x0, v0)), 1e-300)
            probe = JointLaw(law.terms + (term,), law.values + (hc,))
            s = sens(inertia, probe, delay_s, hc)
        s_perp = s - Q @ (Q.T @ s)
        ss = float(s_perp @ s_perp)
        if ss <= 0:
            continue
        proj = float(s_perp @ r)
        red = proj * proj / ss
        stat = red / sigma2
        bic, p, significant = evidence(stat, 1, n)  # ranked by it; kept only if held-out runs improve
        scores.append(CauseScore(cand.name, stat, 1, bic, p, significant, None, (cand.magnitude, -proj / ss, math.nan),
                                 {"removable_rss": red, "predicted_rms": float(np.sqrt(max(rss - red, 0) / n))}))
    return tuple(sorted(scores, key=lambda c: -removable(c)))


@dataclass(frozen=True)
class ExtensionStep:
    """One candidate tried: simulation RMS on the held-out realisations before/after, and on
    the other excitation (NaN when there is none)."""

    effect: str
    accepted: bool
    validation_rms_before: float
    validation_rms_after: float
    other_rms_before: float = math.nan
    other_rms_after: float = math.nan


@dataclass(frozen=True)
class ExtensionResult:
    """Selected effects, the steps tried, and the final fit on all records."""

    effects: tuple[str, ...]
    steps: tuple[ExtensionStep, ...]
    fit: OutputErrorResult
    scores: tuple[CauseScore, ...]


def _fit(u, y, fs, inertia, law, delay, estimate_delay):
    return refine_output_error(u, y, fs, inertia=inertia, law=law, estimate_delay=estimate_delay, delay_s=delay)


def _val_rms(fit: OutputErrorResult, u, y, fs):
    ys, _ = simulate_periods(fit.inertia, fit.law, u, fs, delay_s=fit.delay_s)
    return float(np.sqrt(np.mean((ys - y) ** 2)))


def extend_model(u: np.ndarray, y: np.ndarray, fs_Hz: float, *, inertia: float, law: JointLaw,
                 train: np.ndarray, validate: np.ndarray, candidates: Sequence[Cause] = OSCILLATOR_CAUSES,
                 min_gain: float = 0.02, max_effects: int = 3,
                 other: Optional[tuple[np.ndarray, np.ndarray]] = None) -> ExtensionResult:
    """Greedy forward selection of candidate effects (see the module docstring).

    Args:
      u, y: periodic records ``(R, N)``; train, validate: record indices.
      inertia, law: the nominal model (a starting point; refitted here).
      min_gain: relative drop of the held-out simulation RMS required to keep an effect.
      other: periodic records ``(u, y)``, each ``(R2, N2)``, of another excitation of the same
        system: an effect is kept only if it also lowers the simulation error there (held-out
        realisations of the fit's own excitation cannot see a model that fits the excitation
        rather than the system). Candidates are then tried in order of evidence until one
        passes both, not only the best-evidenced one.
    """
    by_name = {c.name: c for c in candidates}
    ut, yt, uv, yv = u[train], y[train], u[validate], y[validate]
    fit0 = _fit(ut, yt, fs_Hz, inertia, law, 0.0, False)
    val0 = _val_rms(fit0, uv, yv, fs_Hz)
    oth0 = _val_rms(fit0, other[0], other[1], fs_Hz) if other is not None else math.nan
    steps: list[ExtensionStep] = []

    # The base is (fit, held-out RMS, other excitation's RMS, delay estimated).
    def rank(base, remaining, rnd):
        fit = base[0]
        return score_candidates(ut, yt, fs_Hz, inertia=fit.inertia, law=fit.law, delay_s=fit.delay_s,
                                candidates=remaining)

    def adopt(base, scores):
        fit, val, oth, delay_on = base
        # Without another excitation only the best-evidenced candidate is tried per round: if
        # it does not generalise, weaker evidence will not either (each trial is a full
        # output-error fit). With one, a candidate that fails there may be an artefact of the
        # fit's excitation while the next one is not: they are tried in order.
        tried = scores if other is not None else scores[:1]

        def trial_of(best):
            term = _added_term(by_name[best.effect])
            if term is None:
                trial = _fit(ut, yt, fs_Hz, fit.inertia, fit.law, fit.delay_s, True)
            else:
                trial_law = JointLaw(fit.law.terms + (term,), fit.law.values + (best.magnitude[1],))
                trial = _fit(ut, yt, fs_Hz, fit.inertia, trial_law, fit.delay_s, delay_on)
            new_oth = _val_rms(trial, other[0], other[1], fs_Hz) if other is not None else math.nan
            return term, trial, _val_rms(trial, uv, yv, fs_Hz), new_oth

        # The trials are independent: all of the round's are fitted at once in forked processes
        # (jointrig.parallel), then taken in order up to the first that passes, as one by one.
        for best, (term, trial, new_val, new_oth) in zip(tried, fork_map(trial_of, tried)):
            ok = new_val < (1 - min_gain) * val and (other is None or new_oth < oth)
            steps.append(ExtensionStep(best.effect, ok, val, new_val, oth, new_oth))
            log.info("candidate %s: held-out RMS %.4g -> %.4g, other excitation %.4g -> %.4g (%s)", best.effect, val,
                     new_val, oth, new_oth, "kept" if ok else "rejected")
            if ok:
                return best, (trial, new_val, new_oth, delay_on or term is None)
        return None

    chosen = forward_select((fit0, val0, oth0, False), candidates, rank=rank, adopt=adopt, max_effects=max_effects)
    fit, _, _, delay_on = chosen.base
    effects = [s.effect for s in chosen.adopted]
    first_scores = chosen.rounds[0] if chosen.rounds else None
    final = _fit(u, y, fs_Hz, fit.inertia, fit.law, fit.delay_s, delay_on)
    return ExtensionResult(tuple(effects), tuple(steps), final, first_scores or ())
