"""The rig's measurement model: what a test bench's encoders and torque cell would record.

Gaussian white noise is added to the recorded torque and to both angles at a stated
signal-to-noise ratio per channel, ``SNR_dB = 20 log10(rms(x - mean x) / sigma)``; rates are
not recorded (a bench measures angles; the identifier differentiates). Optionally the angles
are then quantised by an encoder of a given resolution (rad per count): with noise larger
than a count the quantisation error is close to white, variance q^2 / 12, and the
period-to-period noise estimate includes it. Noise is drawn from a seeded generator, so a
data set is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Iterable, Optional, Union

import numpy as np

from jointrig.vocab.law import JointLaw
from jointrig.vocab.plant import Plant
from jointrig.vocab.records import SteadyStateRecord

from .model import RigModel
from .simulate import SimulationConfig, simulate_steady_state

__all__ = ["add_noise", "noise_std", "simulate_runs", "repeat_periods", "measure_chain"]


def noise_std(x: np.ndarray, snr_db: float) -> float:
    """Noise standard deviation for signal ``x`` at ``snr_db`` (same unit as x)."""
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)) * 10 ** (-snr_db / 20))


def add_noise(record: SteadyStateRecord, snr_db: Optional[float], rng: np.random.Generator, *,
              encoder_resolution_rad: Optional[float] = None,
              sigma: Optional[tuple[float, float]] = None) -> SteadyStateRecord:
    """The record as measured: noisy torque and angles, rates dropped. ``snr_db=None``: no
    noise; ``encoder_resolution_rad``: quantise both angles to multiples of it (rad per count);
    ``sigma = (angle_rad, torque_Nm)``: fixed noise standard deviations instead of ``snr_db``
    (sensors whose noise does not scale with the signal)."""
    if snr_db is not None and not math.isfinite(snr_db):
        raise ValueError(f"snr_db must be a finite number (dB) or None, got {snr_db}")
    if sigma is not None and (len(sigma) != 2 or not all(math.isfinite(x) and x >= 0 for x in sigma)):
        raise ValueError(f"sigma must be (angle_rad, torque_Nm), finite and >= 0, got {sigma}")
    q = encoder_resolution_rad
    if q is not None and not (math.isfinite(q) and q > 0):
        raise ValueError(f"encoder_resolution_rad must be a finite number > 0 (rad per count), got {q}")

    def noisy(x, fixed_sd):
        if x is None or (snr_db is None and sigma is None):
            return x
        return x + rng.normal(0.0, fixed_sd if sigma is not None else noise_std(x, snr_db), x.shape)

    def encoder(x):
        return x if x is None or q is None else np.round(x / q) * q

    sd_angle, sd_torque = sigma if sigma is not None else (None, None)
    note = (f"noise {sigma[0]:.3g} rad, {sigma[1]:.3g} N m" if sigma is not None else f"SNR {snr_db} dB") + (
        f", encoder {q:g} rad/count" if q is not None else "")
    return replace(record, torque_Nm=noisy(record.torque_Nm, sd_torque),
                   phi1_rad=encoder(noisy(record.phi1_rad, sd_angle)), phi2_rad=encoder(noisy(record.phi2_rad, sd_angle)),
                   rate1_rad_s=None, rate2_rad_s=None, source=f"{record.source} (measured, {note})")


def repeat_periods(record: SteadyStateRecord, n_periods: int) -> SteadyStateRecord:
    """A steady-state record extended to ``n_periods`` periods by repeating its mean period
    (exact for a periodic steady state: the rig would log the same samples again)."""
    if n_periods < 1:
        raise ValueError(f"n_periods must be >= 1, got {n_periods}")
    P, N = record.n_periods, record.samples_per_period
    T = 2 * math.pi / record.omega_rad_s

    def tile(x):
        return None if x is None else np.tile(x.reshape(P, N).mean(axis=0), n_periods)

    t0 = record.time_s[:N]
    return replace(record, time_s=(t0[None, :] + T * np.arange(n_periods)[:, None]).ravel(),
                   torque_Nm=tile(record.torque_Nm), phi1_rad=tile(record.phi1_rad), phi2_rad=tile(record.phi2_rad),
                   rate1_rad_s=tile(record.rate1_rad_s), rate2_rad_s=tile(record.rate2_rad_s), n_periods=n_periods)


def simulate_runs(rig: RigModel, plant: Union[Plant, JointLaw], points: Iterable[tuple[float, float]], *,
                  n_periods: int = 8, snr_db: Optional[float] = 40.0, seed: int = 0,
                  config: Optional[SimulationConfig] = None) -> list[SteadyStateRecord]:
    """Simulate one steady-state run per ``(omega_rad_s, amplitude_Nm)`` point and measure it.

    Args:
      n_periods: steady periods logged per run (the diagnosis estimates the noise from their
        period-to-period variation, so at least 2; 8 gives 7 degrees of freedom per estimate).
    """
    cfg = config or SimulationConfig(n_periods=n_periods)
    if config is not None and config.n_periods != n_periods:
        cfg = replace(config, n_periods=n_periods)
    rng = np.random.default_rng(seed)
    out = []
    for omega, amp in points:
        rec, _ = simulate_steady_state(rig, omega, amp, cfg, law=plant)
        out.append(add_noise(rec, snr_db, rng))
    return out


def measure_chain(record, snr_db: Optional[float], rng: np.random.Generator, *, n_periods: Optional[int] = None):
    """A chain record as a bench measures it: its mean period repeated to ``n_periods`` (exact
    for a steady state), white noise on every angle and every recorded drive torque at
    ``snr_db`` per channel, rates dropped (a bench measures angles). ``snr_db=None``: no noise."""
    from jointrig.identify.chain import ChainRecord

    P, N = record.n_periods, record.samples_per_period
    n_periods = P if n_periods is None else n_periods
    if n_periods < 1:
        raise ValueError(f"n_periods must be >= 1, got {n_periods}")
    T = 2 * math.pi / record.omega_rad_s

    def measured(x):
        if x is None:
            return None
        x = np.tile(x.reshape(P, N).mean(axis=0), n_periods)
        return x if snr_db is None else x + rng.normal(0.0, noise_std(x, snr_db), x.shape)

    t0 = record.time_s[:N]
    note = "noise-free" if snr_db is None else f"SNR {snr_db:g} dB"
    return ChainRecord(record.omega_rad_s, (t0[None, :] + T * np.arange(n_periods)[:, None]).ravel(),
                       [measured(x) for x in record.torques_Nm], [measured(x) for x in record.angles_rad], None,
                       n_periods, record.drive_amplitude_Nm, source=f"{record.source} (measured, {note})")
