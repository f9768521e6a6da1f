"""What an unexplained misfit looks like, without a catalogue (pure).

The residual torque along the measured motion (measured through the equations of motion, minus
the final model's law) of every run, at one place: two flywheels' joint, or a train's joint or
a body's law to ground. Its character (parity, dissipation, harmonics, how it scales with
frequency and drive, whether it changes with run order), its restoring-force surface, and the
measurements that would tell more. Both diagnoses describe a misfit this way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .balance import spectral_rate
from .harmonics import fourier_coefficients
from .surface import RestoringSurface, restoring_surface

__all__ = ["ResidualRun", "MisfitCharacter", "misfit_character", "next_measurements", "ResidualSamples",
           "residual_samples", "residual_surface", "distinct_settings", "same_setting", "PHASE_SPAN_RESONANT_DEG",
           "HIGH_SHARE", "REPEAT_CHANGE", "NextMeasurement"]


@dataclass(frozen=True)
class ResidualRun:
    """What a misfit's description reads of one run (SI): its setting, the place's motion on the
    harmonics the measurement resolves (an angle in rad, or a position in m), and the torque (N m,
    or force in N) there: measured through the equations of motion, and the final model's law
    along that motion."""

    run_id: str
    omega_rad_s: float
    amplitude_Nm: float
    phi_resolved_rad: np.ndarray
    joint_torque_measured_Nm: np.ndarray
    joint_torque_extended_Nm: np.ndarray


def distinct_settings(values, rel: float = 0.05) -> list[float]:
    """The distinct settings among measured values (within ``rel`` of each other they are one:
    frequencies and levels estimated from a measured torque differ in their last digits)."""
    out: list[float] = []
    for v in sorted(values):
        if not out or v > out[-1] * (1 + rel):
            out.append(v)
    return out


def same_setting(a: float, b: float, rel: float) -> bool:
    """Two measured settings (omega, drive level) are one within ``rel`` of the larger."""
    return abs(a - b) <= rel * max(abs(a), abs(b))


@dataclass(frozen=True)
class MisfitCharacter:
    """What the remaining misfit looks like, without a catalogue: the residual joint torque
    (measured through the equation of motion minus the final model's law, along the measured
    motion) of every run.

    Attributes:
      rms_Nm: per run, RMS of the residual joint torque over harmonics 1..band.
      relative: per run, that RMS over the RMS of the measured joint torque.
      even_share: power of the residual on even harmonics over all (0: odd in phi, like a
        symmetric law; 1: even, like an asymmetric one).
      dissipative_share: at the fundamental, the share of the residual in quadrature with the
        angle (1: it dissipates like damping or friction; 0: elastic).
      top_harmonics: the harmonics holding most of the residual power.
      frequency_slope, amplitude_slope: log-log slopes of the residual RMS against omega and
        against the drive amplitude (least squares over the runs).
      worst_runs: run ids with the largest relative residual.
      phase_deg: per run, the phase of the residual's fundamental against the angle's (deg; 90:
        in quadrature, dissipative).
      phase_span_deg: the largest turn of the residual's axis at the fundamental (its phase
        modulo 180 deg, so in [0, 90]: from in phase with the angle towards quadrature) between
        runs of one drive level at different frequencies, over runs whose residual is at least
        30% on the fundamental (a resonance-like phase change when large; 0 if none).
      high_share: power of the residual on harmonics 4 and up over all (a ripple, a kink).
      repeat_change: the largest change of the residual's harmonic magnitudes between two runs
        that repeat one setting (omega within 1%, drive level within 5%), relative to its size;
        NaN when no run repeats a setting (then run order or time cannot be told apart from
        frequency and level). repeat_runs: the two runs of that largest change.
    """

    rms_Nm: tuple[float, ...]
    relative: tuple[float, ...]
    even_share: float
    dissipative_share: float
    top_harmonics: tuple[int, ...]
    frequency_slope: float
    amplitude_slope: float
    worst_runs: tuple[str, ...]
    phase_deg: tuple[float, ...] = ()
    phase_span_deg: float = 0.0
    high_share: float = 0.0
    repeat_change: float = math.nan
    repeat_runs: tuple[str, ...] = ()

    def as_json(self) -> dict:
        return {"rms_Nm": list(self.rms_Nm), "relative": list(self.relative), "even_share": self.even_share,
                "dissipative_share": self.dissipative_share, "top_harmonics": list(self.top_harmonics),
                "frequency_slope": self.frequency_slope, "amplitude_slope": self.amplitude_slope,
                "worst_runs": list(self.worst_runs), "phase_deg": list(self.phase_deg),
                "phase_span_deg": self.phase_span_deg, "high_share": self.high_share,
                "repeat_change": self.repeat_change if math.isfinite(self.repeat_change) else None,
                "repeat_runs": list(self.repeat_runs)}


#: A residual whose axis at the fundamental turns by more than this across frequencies at one
#: drive level points to a stiffness and damping that depend on frequency (a dynamic element with
#: its own time constant). Measured on the open-world bench: a Maxwell element 40 deg (paper's
#: joint) and 86 deg (light joint); cogging 0-2 deg; a torque cell's cubic error 13-75 deg.
PHASE_SPAN_RESONANT_DEG = 30.0
#: A residual with more than this share of its power on harmonics 4 and up is called rippled.
HIGH_SHARE = 0.3
#: A residual whose harmonic magnitudes change by more than this share of their size between two
#: runs of one setting depends on run order or time. A judgement, not a measured bound: the
#: residual of an unexplained misfit stands well out of the noise (held-out errors 78-470 times
#: the floor on the open-world bench), so a third of its size is far beyond what noise moves.
REPEAT_CHANGE = 0.3


def _repeat_change(runs, residual_coeffs) -> tuple[float, tuple[str, ...]]:
    """Largest relative change of the residual's harmonic magnitudes between runs of one setting."""
    best, pair = math.nan, ()
    for i in range(len(runs)):
        for j in range(i + 1, len(runs)):
            a, b = runs[i], runs[j]
            if same_setting(a.omega_rad_s, b.omega_rad_s, 0.01) and same_setting(a.amplitude_Nm, b.amplitude_Nm, 0.05):
                mi, mj = np.abs(residual_coeffs[i][1:]), np.abs(residual_coeffs[j][1:])
                size = max(float(np.linalg.norm(mi)), float(np.linalg.norm(mj)), 1e-300)
                change = float(np.linalg.norm(mi - mj)) / size
                if not change <= best:  # the first, or a larger one
                    best, pair = change, (a.run_id, b.run_id)
    return best, pair


def _phase_span(omegas, amplitudes, phases_deg, on_fundamental) -> float:
    """Largest turn (deg, in [0, 90]) of the residual's axis at the fundamental between runs of one
    drive level (within 5%) at different frequencies, over runs with ``on_fundamental``."""
    span = 0.0
    for i in range(len(omegas)):
        for j in range(len(omegas)):
            if (on_fundamental[i] and on_fundamental[j] and same_setting(amplitudes[i], amplitudes[j], 0.05)
                    and not same_setting(omegas[i], omegas[j], 1e-6)):
                d = abs(phases_deg[i] - phases_deg[j]) % 180.0
                span = max(span, min(d, 180.0 - d))
    return span


#: Measurements that would tell more about a misfit (:attr:`NextMeasurement.kind`): a stepped
#: sine over more frequencies; a quasi-static ramp of the motion; a static calibration of the
#: sensors; runs with a preload and a check of the zero; runs at more drive levels; a setting
#: repeated with the temperature logged; one run repeated at the start and the end.
(MORE_FREQUENCIES, QUASI_STATIC_RAMP, SENSOR_CALIBRATION, PRELOAD_AND_ZERO, MORE_LEVELS, REPEAT_WITH_TEMPERATURE,
 REPEAT_START_END) = ("more_frequencies", "quasi_static_ramp", "sensor_calibration", "preload_and_zero", "more_levels",
                      "repeat_with_temperature", "repeat_start_end")


@dataclass(frozen=True)
class NextMeasurement:
    """A measurement that would tell more about a misfit: ``kind`` (:data:`MORE_FREQUENCIES`, ...),
    ``count`` the frequencies or drive levels the runs hold (more frequencies, more levels), and
    ``runs`` the two runs of one setting whose misfit changed (a setting repeated)."""

    kind: str
    count: int = 0
    runs: tuple = ()


def next_measurements(character: "MisfitCharacter", surface: RestoringSurface,
                      runs: Sequence["ResidualRun"]) -> tuple[NextMeasurement, ...]:
    """Which measurements would tell more about an unexplained misfit (pure; from its character
    and the runs' plan, naming no cause)."""
    out = []
    levels = len(distinct_settings([r.amplitude_Nm for r in runs]))
    freqs = len(distinct_settings([r.omega_rad_s for r in runs]))
    if ((0.3 <= surface.elastic_share <= 0.7 and abs(character.frequency_slope) > 0.5)
            or character.phase_span_deg > PHASE_SPAN_RESONANT_DEG):
        out.append(NextMeasurement(MORE_FREQUENCIES, count=freqs))
    if character.high_share > HIGH_SHARE and surface.elastic_share > 0.7:
        out.append(NextMeasurement(QUASI_STATIC_RAMP))
    if character.amplitude_slope > 1.5 and character.even_share < 0.4:
        out.append(NextMeasurement(SENSOR_CALIBRATION))
    if character.even_share > 0.6 or surface.symmetric_share < 0.3:
        out.append(NextMeasurement(PRELOAD_AND_ZERO))
    if levels < 3:
        out.append(NextMeasurement(MORE_LEVELS, count=levels))
    if math.isfinite(character.repeat_change) and character.repeat_change > REPEAT_CHANGE:
        out.append(NextMeasurement(REPEAT_WITH_TEMPERATURE, runs=tuple(character.repeat_runs)))
    elif not math.isfinite(character.repeat_change):
        out.append(NextMeasurement(REPEAT_START_END))
    return tuple(out)


def misfit_character(runs: Sequence[ResidualRun], band: int) -> MisfitCharacter:
    """The character of the residual joint torque of the final model over all runs (pure)."""
    rms, rel, even, total, diss_num, diss_den, phase, first, coeffs = [], [], 0.0, 0.0, 0.0, 0.0, [], [], []
    power = np.zeros(band + 1)
    for r in runs:
        res = r.joint_torque_measured_Nm - r.joint_torque_extended_Nm
        R = fourier_coefficients(res, 1, band)
        coeffs.append(R)
        M = fourier_coefficients(r.joint_torque_measured_Nm, 1, band)
        P = fourier_coefficients(r.phi_resolved_rad, 1, band)
        p = np.abs(R[1:]) ** 2 / 2
        power[1:] += p / max(float(np.sum(np.abs(M[1:]) ** 2 / 2)), 1e-300)
        rms.append(float(np.sqrt(p.sum())))
        rel.append(rms[-1] / max(float(np.sqrt(np.sum(np.abs(M[1:]) ** 2 / 2))), 1e-300))
        even += float(p[1::2].sum())  # harmonics 2, 4, ...
        total += float(p.sum())
        diss_num += abs((R[1] * np.conj(P[1])).imag)
        diss_den += abs(R[1]) * abs(P[1])
        phase.append(float(np.degrees(np.angle(R[1] * np.conj(P[1])))))
        first.append(float(p[0] / p.sum()) if p.sum() > 0 else 0.0)
    top = tuple(int(h) for h in np.argsort(power)[::-1][:3] if power[h] > 0)
    w = np.log([r.omega_rad_s for r in runs])
    a = np.log([max(r.amplitude_Nm, 1e-300) for r in runs])
    y = np.log(np.maximum(rms, 1e-300))
    X = np.column_stack([np.ones_like(w), w - w.mean(), a - a.mean()])
    coef = np.linalg.lstsq(X, y, rcond=None)[0] if len(runs) >= 3 else np.zeros(3)
    order = np.argsort(rel)[::-1][:2]
    return MisfitCharacter(tuple(rms), tuple(rel), even / total if total > 0 else 0.0,
                           float(diss_num / diss_den) if diss_den > 0 else 0.0, top, float(coef[1]), float(coef[2]),
                           tuple(runs[i].run_id for i in order), tuple(phase),
                           _phase_span([r.omega_rad_s for r in runs], [r.amplitude_Nm for r in runs], phase,
                                       [f >= 0.3 for f in first]),
                           float(np.sum(power[4:]) / np.sum(power)) if np.sum(power) > 0 else 0.0,
                           *_repeat_change(runs, coeffs))


@dataclass(frozen=True)
class ResidualSamples:
    """The final model's residual joint torque at every sample of every run's measured period,
    with where it was: the relative angle about the runs' common centre and its rate. One list
    entry per run (SI units)."""

    phi_rad: tuple[np.ndarray, ...]
    rate_rad_s: tuple[np.ndarray, ...]
    residual_Nm: tuple[np.ndarray, ...]


def residual_samples(runs: Sequence[ResidualRun]) -> ResidualSamples:
    """The residual along each run's measured (resolved) motion (pure)."""
    centre = float(np.mean([np.mean(r.phi_resolved_rad) for r in runs]))
    return ResidualSamples(tuple(r.phi_resolved_rad - centre for r in runs),
                           tuple(spectral_rate(r.phi_resolved_rad, r.omega_rad_s, 1) for r in runs),
                           tuple(r.joint_torque_measured_Nm - r.joint_torque_extended_Nm for r in runs))


def residual_surface(runs: Sequence[ResidualRun]) -> RestoringSurface:
    """The final model's residual joint torque over (phi, phi') along every run's measured motion
    (:func:`identify.surface.restoring_surface` on :func:`residual_samples`)."""
    s = residual_samples(runs)
    return restoring_surface(s.phi_rad, s.rate_rad_s, s.residual_Nm)
