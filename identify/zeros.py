"""The sensors' zeros: what a bench's encoders and torque cells read when nothing moves.

On a bench every encoder has its own absolute zero (two shafts, two encoders, mounted by hand)
and a torque cell reads an offset. The harmonic balance leaves the mean out (harmonics 1..H), and
so does the held-out comparison, so a constant on a channel matters only where a law is not
linear in the motion: a cubic spring, a free play, a slip angle read the twist from its zero.

So every angle channel is taken about its mean over the fitted runs before the diagnosis (a
constant re-zeroing, which no physics can see), each joint's remaining zero is then fitted where
its law needs it (:data:`identify.chain_diagnose.TWIST_ZERO`), and the two together are what the
twist reads at rest. The diagnosis is then the same whatever zero each encoder had.

The drive torque's mean is reported, not fitted: a train free to turn carries no mean torque in a
periodic steady state, so on such a train it is the cell's offset or a constant load where the
drive acts (gravity on an axis, a cable's drag), which the data cannot tell apart; to ground (a
body tied to the frame by a spring) it may be any load. The balance and the replay leave it out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Optional, Sequence

import numpy as np

from .chain import ChainRecord


@dataclass(frozen=True)
class SensorZeros:
    """Each channel's mean over the fitted runs, and how well the runs agree on it.

    Attributes:
      angles: per body, the constant taken out of its angle channel (rad, or m on a slide); 0.0
        where the channel is not measured or the user's zeros were kept (``kept``).
      angle_se: per body, the standard error of that mean (:func:`channel_mean`: the runs'
        spread or the noise's, the larger; NaN with one run of one period).
      twists: per joint, the mean twist over the runs (``angles[j] - angles[j + 1]``), read
        from the data even where ``kept``.
      twist_se: per joint, its standard error (as ``angle_se``).
      torques: per body, the drive torque's (force's) mean over the runs (N m, or N); NaN where
        no drive acts.
      torque_se: per body, its standard error (as ``angle_se``; NaN where no drive acts).
      kept: the user said the encoders were zeroed together (``--zeroed``): nothing taken out.
    """

    angles: tuple
    angle_se: tuple
    twists: tuple
    twist_se: tuple
    torques: tuple
    torque_se: tuple
    kept: bool = False


def _mean_se(values: Sequence[float]) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    se = float(np.std(v, ddof=1) / math.sqrt(v.size)) if v.size > 1 else math.nan
    return float(np.mean(v)), se


def channel_mean(signals: Sequence[np.ndarray], periods: Sequence[int]) -> tuple[float, float]:
    """A channel's mean over runs (every run weighs alike; ``signals[r]`` holds ``periods[r]``
    whole periods) and its standard error (pure): the larger of what the runs' spread gives
    (R - 1 degrees of freedom) and what the noise gives (each period's mean about its run's,
    pooled over the runs: sum(P_r - 1) degrees of freedom). With equal runs this is the noise's
    error scaled by the Birge ratio where it exceeds 1: runs that disagree beyond their noise (a
    load that differs between runs) keep their spread, and runs that agree by chance do not
    shrink it to a few runs' estimate (4 runs: a 3-degree-of-freedom error, which put a torque
    cell's offset 3.3 and 3.5 of them off in 2 of 38 cases; a t with 3 degrees of freedom passes
    3 in 5.8%). One run of several periods has the noise's alone; NaN with nothing to go on."""
    means, scatter, dof = [], 0.0, 0
    for x, P in zip(signals, periods):
        per_period = np.mean(np.asarray(x, dtype=float).reshape(max(int(P), 1), -1), axis=1)
        means.append(float(np.mean(per_period)))
        scatter += float(np.sum((per_period - per_period.mean()) ** 2))
        dof += per_period.size - 1
    m, spread = _mean_se(means)
    noise = math.nan
    if dof > 0:
        var = scatter / dof  # of one period's mean
        noise = math.sqrt(sum(var / max(int(P), 1) for P in periods)) / len(means)
    ses = [e for e in (spread, noise) if math.isfinite(e)]
    return m, max(ses) if ses else math.nan


def sensor_zeros(records: Sequence[ChainRecord], *, keep: bool = False) -> SensorZeros:
    """The channels' means over ``records`` (whole periods each; every run weighs alike) (pure).
    ``keep``: the user's zeros stay (the twists' means are still read, to check them)."""
    if not records:
        raise ValueError("sensor_zeros: no records")
    N = records[0].n_flywheels

    def over_runs(pick, empty: float) -> tuple[float, float]:
        picked = [(x, r.n_periods) for x, r in ((pick(r), r) for r in records) if x is not None]
        return channel_mean(*zip(*picked)) if picked else (empty, math.nan)

    angles, angle_se = [], []
    for i in range(N):
        m, se = over_runs(lambda r, i=i: r.angles_rad[i], 0.0)
        angles.append(0.0 if keep else m)
        angle_se.append(se)
    twists, twist_se = [], []
    for j in range(N - 1):
        m, se = over_runs(lambda r, j=j: None if r.angles_rad[j] is None or r.angles_rad[j + 1] is None
                          else r.angles_rad[j] - r.angles_rad[j + 1], math.nan)
        twists.append(m)
        twist_se.append(se)
    torques, torque_se = [], []
    for i in range(N):
        m, se = over_runs(lambda r, i=i: r.torques_Nm[i], math.nan)
        torques.append(m)
        torque_se.append(se)
    return SensorZeros(tuple(angles), tuple(angle_se), tuple(twists), tuple(twist_se), tuple(torques),
                       tuple(torque_se), keep)


def rezeroed(record: ChainRecord, zeros: Optional[SensorZeros]) -> ChainRecord:
    """``record`` with each angle channel's zero (``zeros.angles``) taken out (pure); the record
    itself where nothing is taken out. Rates and torques are unchanged."""
    if zeros is None or not any(zeros.angles):
        return record
    return replace(record, angles_rad=tuple(None if a is None else a - z
                                            for a, z in zip(record.angles_rad, zeros.angles)))
