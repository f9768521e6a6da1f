"""Measured runs of a joint test: the files the diagnosis reads, from any bench, and the format
the rig writes.

**Columns** (any order; names matched without regard to case; others are ignored with a note):

    run     label of the run (one steady-state record at one drive setting); optional: without
            it a file (or a TDMS/HDF5 group, a UFF load case) is one run
    time    s      sample times (a bench's clock: uniform, from any phase of the drive)
    torque  N m    drive torque on flywheel 1 as recorded (on flywheel 2: ``torque_on``)
    phi1    rad    flywheel 1 angle     } or ``phi`` (rad, the relative angle phi1 - phi2)
    phi2    rad    flywheel 2 angle     }
    omega   rad/s  optional: the drive's fundamental (checked against the data)

**Names and units** come from, in this order: the ``columns`` / ``units`` arguments (CLI
``--columns torque=M_soll --units phi1=deg``), a sidecar file (``DATA.meta.json`` beside the
file, or ``jointrig.json`` in a folder of runs: ``{"columns": {...}, "units": {...}}``), and
the file itself (``phi1 [deg]`` headers, a units row, TDMS ``unit_string``, HDF5 ``units``
attributes, UFF axis labels, the rig writer's Parquet metadata). Accepted units: see
:data:`UNITS`. Values are converted to SI on reading.

**Periods.** Each run must be a steady-state record of at least 2 whole periods. The loader
finds the fundamental in the data (:mod:`identify.periods`): the time stamps define a uniform
clock (their deviation measured; a gap refused); the frequency is estimated from the torque,
sharpened by the twist's own (:func:`identify.periods.with_second_channel`);
an ``omega`` column, and the candidate period of a whole number N of samples, are accepted
only if the data repeat at that period (the residual of a periodic model there is not
significantly above its minimum; otherwise the record is refused with the mismatch shown).
A record is cut to its latest whole periods (an incomplete period dropped from its start, where
a record from rest settles); at a bench's fixed rate (not a whole number of samples per period)
each period's harmonics are estimated by least squares and synthesised on a uniform grid. An angle that drifts (a slipping encoder, an unsettled transient) is refused; a
rotation common to both flywheels is removed. Every change is said in
:attr:`LoadedRuns.notes`.

**One shape of record.** Every bench reads as a line of bodies
(:class:`identify.chain.ChainRecord`): a drive train's phi1..phiN; two flywheels as the line of
their two bodies, the torque on body 1 (or 2, ``torque_on``); the relative angle alone as one
body, the joint's twist, tied to the frame by the joint's law and driven by the share of the
torque that twists it (``torque_share``).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from jointrig.identify.periods import (MAX_CLOCK_DEVIATION, TRANSIENT_FACTOR, estimate_fundamental, fit_at,
                                      linear_drift, ls_harmonics, periods_by_least_squares, repeat_statistic,
                                      transient_periods, uniform_clock, with_second_channel)
from jointrig.identify.chain import ChainRecord
from jointrig.vocab.params import HINGE, SLIDE, Coordinate
from jointrig.vocab.records import MAX_SI_VALUE, RecordError

from .formats import SUFFIXES, FormatError, RawTable, read_tables
from .notes import (ClockJitter, CommonMotion, EpochTime, IgnoredColumns, IncompletePeriod, LaterFundamental,
                    LeastSquaresPeriods, NamesFrom, NoUnits, OmegaDisagrees, OmegaFromPeriod, PreloadChanges, Resampled,
                    TransientCut, ZeroPerRun)

__all__ = ["RunsFileError", "LoadedRuns", "read_runs", "write_runs", "estimate_omega", "COLUMNS", "UNITS",
           "parse_mapping", "REPEAT_THRESHOLD", "TORQUE_ON"]

#: Canonical columns and their SI units.
#: Most bodies of a drive train (``phi1..phi8``, ``torque1..torque8``).
MAX_BODIES = 8

COLUMNS = {"run": "-", "time": "s", "torque": "N m", "phi1": "rad", "phi2": "rad", "phi": "rad",
           "omega": "rad/s"} | {f"phi{i}": "rad" for i in range(3, MAX_BODIES + 1)} \
          | {f"torque{i}": "N m" for i in range(1, MAX_BODIES + 1)} \
          | {"x": "m", "force": "N"} | {f"x{i}": "m" for i in range(1, MAX_BODIES + 1)} \
          | {f"force{i}": "N" for i in range(1, MAX_BODIES + 1)}

#: Columns only a drive train's file has (more than two angles, a numbered drive, or bodies on
#: slides: positions ``x``, ``x1..`` in m and forces ``force``, ``force1..`` in N).
TRAIN_COLUMNS = frozenset(c for c in COLUMNS if (c[-1].isdigit() and c not in ("phi1", "phi2"))
                          or c.startswith(("x", "force")))

_QUANTITY = {c: {"s": "time", "N m": "torque", "rad": "angle", "rad/s": "frequency", "m": "length",
                 "N": "force"}.get(u) for c, u in COLUMNS.items()}

#: Accepted units per quantity -> factor to SI (unit text compared without case, blanks, '*', '.', '·').
UNITS = {
    "time": {"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0},
    "angle": {"rad": 1.0, "mrad": 1e-3, "urad": 1e-6, "µrad": 1e-6, "deg": math.pi / 180, "°": math.pi / 180,
              "degree": math.pi / 180, "degrees": math.pi / 180, "rev": 2 * math.pi, "turn": 2 * math.pi},
    "torque": {"N m": 1.0, "N mm": 1e-3, "N cm": 1e-2, "kN m": 1e3, "mN m": 1e-3},
    "frequency": {"rad/s": 1.0, "hz": 2 * math.pi, "rpm": 2 * math.pi / 60, "1/min": 2 * math.pi / 60,
                  "deg/s": math.pi / 180},
    "length": {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "µm": 1e-6},
    "force": {"N": 1.0, "kN": 1e3, "mN": 1e-3},
}

#: A stated period (an ``omega`` column, or a whole number of samples) is refused when the
#: periodic model there fits worse than at the best frequency by more than this many noise
#: variances, summed over the torque and the relative angle (chi-square(2): p ~ 3e-7).
REPEAT_THRESHOLD = 30.0

#: A stated omega this close (relative) to a record's own whole-sample period is taken as that
#: period written with a logger's rounding (5 significant digits): the record's value is used.
STATED_ROUNDING = 1e-4

#: Harmonics of the periodic model used to find and check the fundamental.
CHECK_HARMONICS = 10

#: A linear drift of a channel is refused when it exceeds this many standard errors and this
#: share of the channel's peak-to-peak swing over the record.
DRIFT_T_STAT = 10.0
DRIFT_SHARE = 1e-3

#: Largest magnitude accepted in SI units (:data:`vocab.records.MAX_SI_VALUE`).
MAX_ABS_VALUE = MAX_SI_VALUE


class RunsFileError(ValueError):
    """A measured-runs file that cannot be used (names the file, run, column and what was expected)."""


@dataclass(frozen=True)
class LoadedRuns:
    """Records read from a file or folder, one per run, in file order, and what was done to them.

    ``sha256``: of the input file (of the files' digests, in order, for a folder)."""

    path: Path
    run_ids: tuple[str, ...]
    records: tuple[ChainRecord, ...]
    #: what the reader noted about the file and how it read it (:mod:`measured.notes`; in words:
    #: :func:`present.notes.note_text`)
    notes: tuple
    sha256: str = ""
    #: how the bodies move: "hinge" (rad, N m, kg m^2) or "slide" (m, N, kg; held in the records'
    #: angle and torque fields, which are the project's generic coordinate and drive)
    kind: Coordinate = HINGE
    #: the relative angle alone as one body (module docstring): the share ``s`` of the drive that
    #: twists the joint (J of the undriven flywheel over J1 + J2), None for any other runs
    torque_share: Optional[float] = None


def _norm_unit(u: str) -> str:
    u = u.strip().lower().replace("µ", "u").replace("μ", "u")
    u = re.sub(r"[\s*·.]", "", u)
    return {"n-m": "nm", "n-mm": "nmm"}.get(u, u)


def _unit_factor(where: str, column: str, unit: str) -> float:
    q = _QUANTITY[column]
    table = {_norm_unit(k): v for k, v in UNITS[q].items()}
    u = _norm_unit(unit)
    if u in table:
        return table[u]
    raise RunsFileError(f"{where}: column '{column}' has unit {unit!r}, which is not a {q} unit this tool knows; "
                        f"expected one of {', '.join(UNITS[q])}")


def parse_mapping(text: Optional[Union[str, Mapping[str, str]]], what: str) -> dict[str, str]:
    """``"torque=M, phi1=enc1"`` (or a mapping, or a list of ``NAME=VALUE`` strings) ->
    ``{"torque": "M", "phi1": "enc1"}``; keys must be canonical column names."""
    if text is None:
        return {}
    if isinstance(text, (list, tuple)) and all(isinstance(t, str) for t in text):
        text = ",".join(text)
    if isinstance(text, Mapping):
        items = list(text.items())
    elif not isinstance(text, str):
        raise RunsFileError(f"{what}: expected NAME=VALUE pairs as a string ('torque=M_drive,phi1=enc1'), a list of "
                            f"them or a mapping, got {type(text).__name__} {text!r}")
    else:
        items = []
        # Commas (or semicolons) separate the pairs; blanks may sit inside a unit ("N m").
        for part in (p.strip() for p in re.split(r"[,;]", str(text))):
            if not part:
                continue
            if "=" not in part:
                raise RunsFileError(f"{what}: {part!r} is not NAME=VALUE; expected for example "
                                    f"'torque=M_drive,phi1=enc1'")
            k, v = part.split("=", 1)
            items.append((k.strip(), v.strip()))
    out = {}
    for k, v in items:
        if k not in COLUMNS:
            raise RunsFileError(f"{what}: {k!r} is not a column of this format; expected one of {', '.join(COLUMNS)}")
        if not isinstance(v, str) or not v:
            raise RunsFileError(f"{what}: {k!r} needs a non-empty value")
        out[k] = v
    return out


def _sidecar(path: Path) -> tuple[Optional[Path], dict, dict]:
    side = path / "jointrig.json" if path.is_dir() else path.with_name(path.name + ".meta.json")
    if not side.is_file():
        return None, {}, {}
    try:
        meta = json.loads(side.read_text())
    except (OSError, ValueError) as err:
        raise RunsFileError(f"{side}: not readable JSON ({err}); expected {{\"columns\": {{...}}, "
                            f"\"units\": {{...}}}}") from None
    if not isinstance(meta, dict) or set(meta) - {"columns", "units", "comment"}:
        raise RunsFileError(f"{side}: expected an object with keys 'columns', 'units' (and 'comment'), got "
                            f"{sorted(meta) if isinstance(meta, dict) else type(meta).__name__}")
    return side, parse_mapping(meta.get("columns"), str(side)), parse_mapping(meta.get("units"), str(side))


def _resolve(table: RawTable, columns: dict, units: dict, notes: list) -> tuple[dict, dict]:
    """Canonical columns (SI arrays; 'run' as labels) of one raw table."""
    where = table.source
    lower: dict[str, str] = {}
    for name in table.columns:
        key = name.strip().lower()
        if key in lower:
            raise RunsFileError(f"{where}: columns {lower[key]!r} and {name!r} differ only in case; expected "
                                f"unique names")
        lower[key] = name
    found: dict[str, str] = {}
    for canon in COLUMNS:
        if canon in columns:
            src = columns[canon]
            if src not in table.columns and src.lower() not in lower:
                raise RunsFileError(f"{where}: column {src!r} (mapped to '{canon}') is not in the file; its "
                                    f"columns are {sorted(table.columns)}")
            found[canon] = src if src in table.columns else lower[src.lower()]
        elif canon in lower and lower[canon] not in columns.values():
            found[canon] = lower[canon]
    used = set(found.values())
    extra = [c for c in table.columns if c not in used]
    if extra:
        notes.append(IgnoredColumns(str(where), tuple(extra), MAX_BODIES))
    out, stated = {}, {}
    for canon, src in found.items():
        col = np.asarray(table.columns[src])
        if canon == "run":
            if col.dtype.kind in "iuf":  # numbers: each distinct value labelled once
                distinct, where_in = np.unique(col, return_inverse=True)
                out[canon] = np.array([_label(v) for v in distinct], dtype=object)[where_in.reshape(-1)]
            else:
                out[canon] = np.array([_label(v) for v in col], dtype=object)
            continue
        if canon == "time" and col.dtype.kind not in "iufbc":
            col = _iso_seconds(where, src, col)
        if col.dtype.kind not in "iuf":
            bad = next((i for i, v in enumerate(col)
                        if isinstance(v, (bool, np.bool_, complex, np.complexfloating)) or not _is_float(v)), 0)
            what = ("true/false values" if isinstance(col[bad], (bool, np.bool_)) else
                    "complex numbers" if isinstance(col[bad], (complex, np.complexfloating)) else "a non-number")
            raise RunsFileError(f"{where}: column '{src}' holds {what} ({col[bad]!r} in data row {bad + 1}); "
                                f"expected real numbers in {COLUMNS[canon]}")
        col = col.astype(float)
        given, in_file = units.get(canon), table.units.get(src)
        if given is not None and in_file is not None and \
                _unit_factor(where, canon, given) != _unit_factor(where, canon, in_file):
            raise RunsFileError(f"{where}: column '{src}' is in {in_file!r} by the file's header, but {given!r} by "
                                f"--units or the sidecar: units given twice must agree; drop one")
        unit = given or in_file
        if unit is not None:
            f = _unit_factor(where, canon, unit)
            if f != 1.0:
                col = col * f
            stated[canon] = unit
        out[canon] = col
    return out, stated


#: Unit words that, next to a column's name in a comment line, read as that column's unit.
_COMMENT_UNIT = r"(deg|degrees?|mrad|urad|rev|ms|us|ns|min|mm|cm|n ?mm|n ?cm|kn ?m|rpm|hz)"


def _units_in_comments(table: RawTable, columns: dict, stated: dict) -> None:
    """Refuse a file whose comment lines state a unit for a column the header leaves in SI
    (``# phi1 in deg``): units are read from the header, ``--units`` or a sidecar only, and
    reading such a column as SI is silently wrong."""
    for canon in ("time", "torque", "phi1", "phi2", "phi", "omega"):
        if canon in stated:
            continue
        name = columns.get(canon, canon)
        pattern = re.compile(rf"\b{re.escape(name)}\b[^,;]{{0,20}}?\b{_COMMENT_UNIT}\b", re.IGNORECASE)
        for line in table.comments:
            m = pattern.search(line)
            if m:
                raise RunsFileError(f"{table.source}: a comment line says {line!r}, which reads as column '{name}' in "
                                    f"{m.group(1)!r}, but units are read only from the header ('{name} "
                                    f"[{m.group(1)}]'), --units {canon}={m.group(1).replace(' ', '')} or a sidecar "
                                    f"DATA.meta.json; state it there (or reword the comment)")


def _iso_seconds(where: str, src: str, col: np.ndarray) -> np.ndarray:
    """ISO 8601 time stamps (``2026-11-26T14:31:02.125000+00:00``) as seconds after the first;
    the column as it is when its first value is not such a stamp."""
    import datetime

    def parse(v):
        return datetime.datetime.fromisoformat(str(v).strip().strip('"').replace("Z", "+00:00"))

    try:
        t0 = parse(col[0])
    except ValueError:
        return col
    out = np.empty(col.size)
    for i, v in enumerate(col):
        try:
            out[i] = (parse(v) - t0).total_seconds()
        except (ValueError, TypeError):
            raise RunsFileError(f"{where}: column '{src}' mixes ISO 8601 time stamps with {v!r} (data row {i + 1}); "
                                f"expected one kind of time stamp") from None
    return out


def _is_float(v) -> bool:
    try:
        float(v)
        return True
    except (TypeError, ValueError):
        return False


def _label(v) -> str:
    if isinstance(v, (float, np.floating)) and math.isfinite(v) and float(v).is_integer():
        return str(int(v))
    if isinstance(v, bytes):
        return v.decode(errors="replace")
    return str(v).strip()


def estimate_omega(time_s: np.ndarray, torque_Nm: np.ndarray) -> float:
    """The drive fundamental (rad/s) from a torque record (multi-harmonic least squares,
    :func:`identify.periods.estimate_fundamental`).

    Raises RunsFileError if the torque has no periodic component.
    """
    try:
        return estimate_fundamental(np.asarray(time_s, float), np.asarray(torque_Nm, float)).omega_rad_s
    except ValueError as err:
        raise RunsFileError(f"torque: {err}") from None


#: Smallest spread (in the column's SI unit) a channel must show to carry a signal: below it the
#: squares the noise estimates form underflow (1e-300 rad squared is 0.0) or no motion was
#: recorded. A real encoder resolves far more than 1e-100 rad; this only refuses a dead channel.
MIN_SPREAD = 1e-100


#: The fewest samples a run can hold: 2 whole periods of at least 8 samples.
MIN_RUN_SAMPLES = 16


def _check_length(where: str, run: str, n: int) -> None:
    """Refuse a run too short to hold two periods, before its channels are judged (a one-row
    run does not vary either, but its fault is its length)."""
    if n < MIN_RUN_SAMPLES:
        raise RunsFileError(f"{where}: run {run}: {n} samples is too short; expected at least {MIN_RUN_SAMPLES} "
                            f"(2 whole periods of at least 8 samples)")


def _check_varies(where: str, run: str, name: str, x: np.ndarray) -> None:
    """Refuse an angle channel that does not vary (a disconnected sensor, a wrong column)."""
    spread = float(np.max(x) - np.min(x))
    if not spread > MIN_SPREAD:
        raise RunsFileError(f"{where}: run {run}: column '{name}' does not vary (spread {spread:.3g} rad); expected "
                            f"the measured angle of the flywheels' motion: is the sensor connected and the column "
                            f"mapped right (--columns)?")


#: Time stamps beyond this (s) are absolute (an epoch time): float64 then resolves them only to
#: about 2e-7 s, so the run's time is taken from its first stamp.
MAX_TIME_ORIGIN_S = 1e6


#: Two estimates of a record's fundamental, over the whole record and after its first period,
#: that differ by more than this many combined standard errors: the first period is a transient.
STEADY_FUNDAMENTAL_SE = 5.0


def _steady_fundamental(tu: np.ndarray, drive: np.ndarray, best, run: str, notes: list):
    """The fundamental of a record's steady part: a record from rest holds a transient in its first
    period, which the whole record's least squares fits as if periodic. A servo carriage's force
    from rest (3.5 periods of 3.5 s) read 1.78812 +- 0.00023 rad/s against the reference's
    1.79520, its periods then misaligned by 14 samples. With 3 periods or more at the first
    estimate, the fundamental is estimated again after the first period; where the two differ
    by more than :data:`STEADY_FUNDAMENTAL_SE` combined standard errors, the later one is taken,
    with a note."""
    per = 2 * math.pi / (best.omega_rad_s * (tu[1] - tu[0]))
    if tu.size < 3 * per:
        return best
    k = int(math.ceil(per))
    try:
        later = estimate_fundamental(tu[k:], drive[k:], harmonics=CHECK_HARMONICS)
    except ValueError:
        return best
    se = math.hypot(best.std_error_rad_s, later.std_error_rad_s)
    if not abs(later.omega_rad_s - best.omega_rad_s) > STEADY_FUNDAMENTAL_SE * se:
        return best
    notes.append(LaterFundamental(run, best.omega_rad_s, best.std_error_rad_s, later.omega_rad_s,
                                  later.std_error_rad_s))
    return later


def _whole_periods(where: str, run: str, t: np.ndarray, chans: dict, drive: str, rel: np.ndarray,
                   omega: Optional[float], samples_per_period: Optional[int], notes: list) -> tuple:
    """Whole periods of one run's channels on a uniform grid (module docstring, **Periods**):
    ``(omega_rad_s, time_s, n_periods, channel -> samples)``. The fundamental is estimated from
    the drive channel ``drive`` and checked on it and on the relative angle ``rel``."""
    n = t.size
    # Epoch stamps (1.7e9 s) keep their spacing's precision only as differences (a period's
    # samples would otherwise round to 2e-7 s): such a run's time counts from its first stamp.
    if n and abs(t[0]) > MAX_TIME_ORIGIN_S:
        notes.append(EpochTime(run, float(t[0])))
        t = t - t[0]
    try:
        clock = uniform_clock(t)
    except ValueError as err:
        raise RunsFileError(f"{where}: run {run}: column 'time': {err}") from None
    if clock.max_deviation > MAX_CLOCK_DEVIATION:
        i = clock.worst_index
        raise RunsFileError(
            f"{where}: run {run}: column 'time' is not uniformly sampled: sample {i} at {t[i]:.9g} s is "
            f"{clock.max_deviation:.3g} steps off the uniform clock t0 + k * {clock.dt_s:.6g} s (a gap, a missing "
            f"sample or a restart?); expected a uniform clock (deviations below {MAX_CLOCK_DEVIATION} steps)")
    if clock.max_deviation > 1e-6:
        notes.append(ClockJitter(run, clock.max_deviation, clock.dt_s))
    dt = clock.dt_s
    tu = clock.times(n)
    torque, phi = chans[drive], rel
    try:
        best = estimate_fundamental(tu, torque, harmonics=CHECK_HARMONICS)
    except ValueError:
        raise RunsFileError(f"{where}: run {run}: column '{drive}' does not vary: no drive to identify from; "
                            f"expected a periodic drive torque") from None
    first, best = best, _steady_fundamental(tu, torque, best, run, notes)
    # the motion's own period sharpens the drive's (over the steady part the drive's was read on)
    skip = 0 if best is first else int(math.ceil(2 * math.pi / (first.omega_rad_s * (tu[1] - tu[0]))))
    best = with_second_channel(tu[skip:], torque[skip:], phi[skip:], best)
    refs = [(torque, best), (phi, fit_at(tu, phi, best))]

    def stat(w: float) -> float:
        return sum(repeat_statistic(tu, x, w, ref) for x, ref in refs)

    per_hat = 2 * math.pi / (best.omega_rad_s * dt)
    N = int(round(per_hat))
    commensurate = N >= 8 and stat(2 * math.pi / (N * dt)) <= REPEAT_THRESHOLD
    near_own = commensurate and omega is not None and abs(omega * N * dt / (2 * math.pi) - 1) < STATED_ROUNDING
    if omega is not None and not near_own:
        s = stat(omega)
        if s > REPEAT_THRESHOLD:
            raise RunsFileError(
                f"{where}: run {run}: column 'omega' gives {omega:.9g} rad/s, but the record does not repeat at that "
                f"period: it repeats at {best.omega_rad_s:.9g} +- {best.std_error_rad_s:.2g} rad/s "
                f"({per_hat:.6g} samples per period), {abs(omega / best.omega_rad_s - 1):.3g} relative off; at the "
                f"stated omega the periodic model's residual exceeds its minimum by {s:.3g} noise variances "
                f"(at most {REPEAT_THRESHOLD:g} expected); check the column's value and unit (rad/s)")
    cols = list(chans.values())
    if commensurate:
        w_rec = 2 * math.pi / (N * dt)
        if omega is not None and abs(omega / w_rec - 1) < 1e-9:
            w_rec = omega  # the stated value and the record's own period agree to round-off
        elif omega is not None:
            notes.append(OmegaDisagrees(run, omega, N, w_rec))
        elif samples_per_period is None:
            notes.append(OmegaFromPeriod(run, N, w_rec, drive, best.omega_rad_s, best.std_error_rad_s))
        P = n // N
        if P < 2:
            raise RunsFileError(f"{where}: run {run}: holds {n / N:.3g} periods of omega = {w_rec:.6g} rad/s; "
                                f"expected at least 2 whole periods (the noise is estimated from period-to-period "
                                f"variation)")
        if P * N != n:
            notes.append(IncompletePeriod(run, n, N, P))
        per_out = N
        # the latest whole periods: a record's leftover samples go from its start, where a
        # record from rest holds its transient, not from its settled end
        start = n - P * N
        data = [c[start:] for c in cols]
        t_rec = clock.t0_s + start * dt + np.arange(P * N) * (2 * math.pi / (w_rec * N))
        if samples_per_period is not None and samples_per_period != N:
            fit = periods_by_least_squares(t_rec, np.array(data), w_rec, samples_per_period=samples_per_period)
            data, per_out = list(fit.samples), samples_per_period
            t_rec = clock.t0_s + np.arange(P * per_out) * (2 * math.pi / (w_rec * per_out))
            notes.append(Resampled(run, N, per_out, fit.harmonics))
    else:
        w_rec = omega if omega is not None else best.omega_rad_s
        per = 2 * math.pi / (w_rec * dt)
        H = ls_harmonics(per)
        per_out = samples_per_period or max(16, 2 * (H + 1))
        # the latest whole periods (as above): the leftover samples from the start
        start = max(0, n - int(math.ceil(math.floor(n / per + 1e-9) * per - 1e-9)))
        try:
            fit = periods_by_least_squares(tu[start:], np.array([c[start:] for c in cols]), w_rec,
                                           samples_per_period=per_out, harmonics=H)
        except ValueError as err:
            raise RunsFileError(f"{where}: run {run}: {err}") from None
        P = fit.n_periods
        if P < 2:
            raise RunsFileError(f"{where}: run {run}: holds {n / per:.3g} periods of omega = {w_rec:.6g} rad/s; "
                                f"expected at least 2 whole periods (the noise is estimated from period-to-period "
                                f"variation)")
        data = list(fit.samples)
        t_rec = clock.t0_s + start * dt + np.arange(P * per_out) * (2 * math.pi / (w_rec * per_out))
        used = int(round(P * per))
        rms = [float(np.std(c)) or 1.0 for c in cols]
        shares = tuple((name, float(r / s)) for name, r, s in zip(chans, fit.residual_rms, rms))
        notes.append(LeastSquaresPeriods(run, per, w_rec, drive, best.std_error_rad_s, fit.harmonics, P, per_out,
                                         shares, n - used, omega_column=omega is not None))
    angles = [np.asarray(d) for name, d in zip(chans, data) if name.startswith(("phi", "x"))]
    # every joint's twist (a free train may turn as a whole, its angles ramping); one body's own angle
    twists = [a - b for a, b in zip(angles, angles[1:])]
    cut = transient_periods(twists or angles, P, () if twists else (True,) * len(angles))
    if cut:  # a record from rest: its transient is not a steady state
        n_cut = cut * (len(t_rec) // P)
        data, t_rec = [np.asarray(d)[n_cut:] for d in data], t_rec[n_cut:]
        notes.append(TransientCut(run, cut, P - cut, TRANSIENT_FACTOR))
        P -= cut
    return w_rec, t_rec, P, dict(zip(chans, data))


def _to_record(where: str, run: str, t: np.ndarray, chans: dict, omega: Optional[float],
               samples_per_period: Optional[int], notes: list, driven: int, share: Optional[float]) -> ChainRecord:
    """One run of a two-flywheel bench (``torque``, ``phi1`` and ``phi2``, or ``phi``) as a line of
    bodies: both angles, two bodies with the torque on body ``driven``; the relative angle alone,
    one body driven by ``share`` times the torque (signed: negative on flywheel 2)."""
    _check_length(where, run, t.size)
    phi = chans["phi1"] - chans["phi2"] if "phi2" in chans else chans["phi1"]
    for name in ("phi1", "phi2"):
        if name in chans:
            _check_varies(where, run, name if "phi2" in chans else "phi", chans[name])
    _check_varies(where, run, "phi1 - phi2" if "phi2" in chans else "phi", phi)
    w_rec, t_rec, P, data = _whole_periods(where, run, t, chans, "torque", phi, omega, samples_per_period, notes)
    _check_drift(where, run, t_rec, data, w_rec, notes)
    T = data["torque"]
    if share is not None:
        torques, angles = (share * T,), (data["phi1"],)
    else:
        torques, angles = ((T, None) if driven == 1 else (None, T)), (data["phi1"], data["phi2"])
    try:
        return ChainRecord(float(w_rec), t_rec, torques, angles, None, P, source=f"{where} run {run}")
    except RecordError as err:
        raise RunsFileError(f"{where}: run {run}: {err}") from None


def _drifts(x: np.ndarray, d) -> bool:
    """Whether a channel's linear drift ``d`` (:func:`identify.periods.linear_drift`) is one
    (:data:`DRIFT_T_STAT` standard errors and :data:`DRIFT_SHARE` of its swing)."""
    return abs(d.t_stat) > DRIFT_T_STAT and abs(d.over_record) > DRIFT_SHARE * max(float(np.ptp(x)), 1e-300)


def _refuse_twist_drift(where: str, run: str, what: str, x: np.ndarray, d, unit: str) -> None:
    """Refuse a joint's twist that drifts (``d`` its linear drift): a steady state repeats."""
    if _drifts(x, d):
        raise RunsFileError(
            f"{where}: run {run}: {what} drifts by {d.over_record:.3g} {unit} over the record ({d.slope:.3g} "
            f"{unit}/s, {abs(d.t_stat):.3g} standard errors): a steady-state record repeats every period (a slipping "
            f"encoder, or a transient that has not settled: from rest, record until at least 2 steady periods follow "
            f"the transient)")


def _check_drift(where: str, run: str, t: np.ndarray, data: dict, omega: float, notes: list) -> None:
    """Refuse a channel that drifts; remove a rotation common to both flywheels (in place)."""
    def drift(x):
        return linear_drift(t, x, omega, harmonics=CHECK_HARMONICS)


    if "phi2" in data:
        rel = data["phi1"] - data["phi2"]
        _refuse_twist_drift(where, run, "the relative angle phi1 - phi2", rel, drift(rel), "rad")
        d1, d2 = drift(data["phi1"]), drift(data["phi2"])
        if _drifts(data["phi1"], d1) or _drifts(data["phi2"], d2):
            slope = 0.5 * (d1.slope + d2.slope)
            tc = t - t[0]
            data["phi1"] = data["phi1"] - slope * tc
            data["phi2"] = data["phi2"] - slope * tc
            notes.append(CommonMotion(run, float(slope)))
    # With two angles, phi1 is checked after any common rotation is removed; phi2 then follows
    # from the relative angle, already checked. With one, phi1 holds the relative angle.
    for name in ("torque", "phi1"):
        x = data[name]
        d = drift(x)
        if _drifts(x, d):
            label = "phi" if name == "phi1" and "phi2" not in data else name
            unit = "N m" if name == "torque" else "rad"
            raise RunsFileError(
                f"{where}: run {run}: column '{label}' drifts by {d.over_record:.3g} {unit} over the record "
                f"({d.slope:.3g} {unit}/s, {abs(d.t_stat):.3g} standard errors): a steady-state record repeats "
                f"every period (a slipping encoder, a drifting amplifier or an unsettled transient?)")


def _to_train_record(where: str, run: str, t: np.ndarray, torques: dict, angles: list, omega: Optional[float],
                     samples_per_period: Optional[int], notes: list, layout: "_Train") -> ChainRecord:
    """One run of a drive train: the drives on the driven bodies, the positions of bodies 1..N
    (N >= 1; a slide's in m and N, held as the record's angles and torques)."""
    kind = layout.kind
    pos, drv, unit, drive_unit = kind.position, kind.drive, kind.unit, kind.drive_unit
    _check_length(where, run, t.size)
    for i, a in enumerate(angles, start=1):
        _check_varies(where, run, layout.positions[i - 1], a)
    for j in range(1, len(angles)):
        _check_varies(where, run, f"{pos}{j} - {pos}{j + 1}", angles[j - 1] - angles[j])
    drive = max(torques, key=lambda i: float(np.std(torques[i])))
    # channels by the bench's own names (force1, x1 on a slide), as the notes name them
    chans = {f"{drv}{i}": x for i, x in torques.items()} | {f"{pos}{i}": a for i, a in enumerate(angles, start=1)}
    ref = angles[0] - angles[1] if len(angles) > 1 else angles[0]
    w_rec, t_rec, P, data = _whole_periods(where, run, t, chans, f"{drv}{drive}", ref, omega, samples_per_period,
                                           notes)
    N = len(angles)

    def drift(x):
        return linear_drift(t_rec, x, w_rec, harmonics=CHECK_HARMONICS)


    for j in range(1, N):
        rel = data[f"{pos}{j}"] - data[f"{pos}{j + 1}"]
        _refuse_twist_drift(where, run, f"the twist {pos}{j} - {pos}{j + 1} of joint {j}", rel, drift(rel), unit)
    ds = [drift(data[f"{pos}{i}"]) for i in range(1, N + 1)]
    if any(_drifts(data[f"{pos}{i}"], d) for i, d in enumerate(ds, start=1)):
        slope = float(np.mean([d.slope for d in ds]))
        for i in range(1, N + 1):
            data[f"{pos}{i}"] = data[f"{pos}{i}"] - slope * (t_rec - t_rec[0])
        notes.append(CommonMotion(run, slope, unit, kind.line))
    for i in torques:
        d = drift(data[f"{drv}{i}"])
        if _drifts(data[f"{drv}{i}"], d):
            col = dict(layout.drives)[i]
            raise RunsFileError(f"{where}: run {run}: column '{col}' drifts by {d.over_record:.3g} {drive_unit} over "
                                f"the record ({abs(d.t_stat):.3g} standard errors): a steady-state record repeats "
                                f"every period")
    try:
        return ChainRecord(w_rec, t_rec, tuple(data.get(f"{drv}{i}") for i in range(1, N + 1)),
                           tuple(data[f"{pos}{i}"] for i in range(1, N + 1)), None, P,
                           max(float(np.ptp(x)) / 2 for x in torques.values()), source=f"{where} run {run}")
    except RecordError as err:
        raise RunsFileError(f"{where}: run {run}: {err}") from None


def _files(path: Path) -> list[Path]:
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in SUFFIXES
                       and not p.name.endswith(".meta.json") and not p.name.startswith("."))
        if not files:
            raise RunsFileError(f"{path}: a folder without run files; expected files ending in {', '.join(SUFFIXES)}")
        return files
    if not path.exists():
        raise RunsFileError(f"{path}: no such file or folder")
    if not path.is_file():
        raise RunsFileError(f"{path}: not a regular file")
    return [path]


def _digest(files: Sequence[Path]) -> str:
    if len(files) == 1:
        return hashlib.sha256(files[0].read_bytes()).hexdigest()
    h = hashlib.sha256()
    for f in files:
        h.update(hashlib.sha256(f.read_bytes()).hexdigest().encode())
    return h.hexdigest()


#: A relative angle whose amplitude exceeds this (rad) is no twist of a joint: with no angle unit
#: stated, the file is refused as probably in degrees (a joint twisting 0.5 rad reads 28.6 "rad").
MAX_TWIST_RAD = math.pi
#: Runs whose relative-angle means differ by more than this share of the largest amplitude were
#: zeroed separately (encoders zeroed at the start of each recording: the zero then falls
#: anywhere within the swing). An asymmetric joint's mean shifts with the level by far less
#: (the independent bench's largest even term: 7% of the amplitude).
ZERO_SPREAD = 0.2


def _twists(r, relative: bool = False) -> list[np.ndarray]:
    """Each joint's twist over a record (N - 1 of N bodies; the relative angle alone: its one
    body's angle, which is the joint's twist)."""
    if relative:
        return [r.angles_rad[0]]
    return [r.angles_rad[j] - r.angles_rad[j + 1] for j in range(r.n_flywheels - 1)]


def _centred(r):
    return replace(r, angles_rad=tuple(a - a.mean() for a in r.angles_rad))


def _drive_means(r) -> list[float]:
    """Each drive channel's mean over a record (N m; N on a slide; NaN where the run has none)."""
    return [float(np.mean(t)) if t is not None else math.nan for t in r.torques_Nm]


def _drive_swing(r) -> float:
    """The largest drive channel's half peak-to-peak over a record."""
    return max((float(np.ptp(t)) / 2 for t in r.torques_Nm if t is not None), default=0.0)


#: The drives' mean differs between runs by more than this share of their largest swing: the runs
#: hold different mean loads, and a joint's mean twist may differ between them as its preload
#: does (a pump's load that grows with its speed), not because its encoders were re-zeroed.
LOAD_SPREAD = 0.1


def _in_degrees(path: Path, records: Sequence, unstated: set, what: str, zero_per_run: bool = False) -> None:
    """Where some angles' units are stated and others' not, and reading the unstated ones in
    degrees makes every joint's twist swing plausibly (below :data:`MAX_TWIST_RAD`), refuse naming
    the unit forgotten: the fix that applies, not a re-zeroing alone. Where the runs' mean twists
    differ in degrees too (by more than :data:`ZERO_SPREAD` of the swing) and each run does not
    already take its own zero (``zero_per_run``), the refusal names ``--zero-per-run`` as well."""
    bodies = sorted(unstated, key=lambda c: (len(c), c))
    index = {c: (int(c.lstrip("phix")) - 1 if c.lstrip("phix") else 0) for c in bodies}
    alt = []
    for r in records:
        a = [x * (math.pi / 180.0) if i in index.values() else x for i, x in enumerate(r.angles_rad)]
        if len(a) < 2:
            return
        alt.append([a[j] - a[j + 1] for j in range(len(a) - 1)])
    amps = [max(float(np.ptp(x)) / 2 for x in tw) for tw in alt]
    if max(amps) > MAX_TWIST_RAD:
        return
    spread = max(max(m) - min(m) for m in ([float(np.mean(tw[j])) for tw in alt] for j in range(len(alt[0]))))
    one_zero = not zero_per_run and (len(alt) < 2 or spread <= ZERO_SPREAD * max(amps))
    raise RunsFileError(
        f"{path}: {what}; {', '.join(bodies)} {'has' if len(bodies) == 1 else 'have'} no unit stated (read as rad) while "
        f"the other angles' are stated, and read in degrees every joint's twist is plausible ("
        f"{'one zero for all runs' if one_zero else 'each run on its own zero'}, a swing of "
        f"+-{max(amps):.3g} rad): state the unit in the header ('{bodies[0]} [deg]') or with --units "
        + ",".join(f"{c}=deg" for c in bodies)
        + ("" if one_zero or zero_per_run else ", and pass --zero-per-run: in degrees too the runs' mean twists differ, "
                                               "as from sensors zeroed at the start of each recording"))


def _plausible_angles(path: Path, run_ids: Sequence[str], records: Sequence,
                      angles_stated: bool, zero_per_run: bool, notes: list, unstated: set = frozenset(),
                      relative: bool = False) -> list:
    """Refuse angles that are probably not in rad (no unit stated, a twist of several rad; or one
    angle's unit forgotten beside the others'), and runs whose angle sensors were zeroed one by
    one, or centre each run's angles when asked. ``unstated``: the angle columns read as rad for
    want of a unit while others' are stated; ``relative``: the records are the relative angle
    alone (one body whose angle is the joint's twist)."""
    twists = [_twists(r, relative) for r in records]
    if not twists[0]:  # a single body: its position's zero is its own affair
        if zero_per_run:
            notes.append(ZeroPerRun(single=True))
            return [_centred(r) for r in records]
        return list(records)
    joint = "the relative angle" if len(twists[0]) == 1 else "a joint's twist"
    amps = [max(float(np.ptp(x)) / 2 for x in tw) for tw in twists]
    worst = int(np.argmax(amps))
    if amps[worst] > MAX_TWIST_RAD and unstated:
        swing = f"run {run_ids[worst]}: {joint} swings by +-{amps[worst]:.3g} rad, more than any joint twists"
        _in_degrees(path, records, unstated, swing, zero_per_run)
        names = sorted(unstated, key=lambda c: (len(c), c))
        raise RunsFileError(f"{path}: {swing}, and {', '.join(names)} without a unit (read as rad): state every "
                            f"angle's unit in the header ('{names[0]} [deg]') or with --units")
    if amps[worst] > MAX_TWIST_RAD and not angles_stated:
        raise RunsFileError(
            f"{path}: run {run_ids[worst]}: {joint} swings by +-{amps[worst]:.3g} rad, more than any joint "
            f"twists (+-{MAX_TWIST_RAD:.3g} rad), and no angle unit is stated: are the angles in degrees "
            f"(+-{math.radians(amps[worst]):.3g} rad)? State the unit in the header ('phi1 [deg]') or with "
            f"--units phi1=deg,phi2=deg")
    if zero_per_run:
        notes.append(ZeroPerRun(single=False))
        return [_centred(r) for r in records]
    drive = np.array([_drive_means(r) for r in records])
    spread = [float(np.ptp(c[np.isfinite(c)])) for c in drive.T if np.isfinite(c).any()]
    loads = bool(spread) and max(spread) > LOAD_SPREAD * max(_drive_swing(r) for r in records)
    for j in range(len(twists[0])):
        means = [float(np.mean(tw[j])) for tw in twists]
        if len(records) >= 2 and max(means) - min(means) > ZERO_SPREAD * max(amps) and loads:
            notes.append(PreloadChanges(0 if len(twists[0]) == 1 else j + 1, float(max(means) - min(means)),
                                        float(max(spread))))
            continue
        if len(records) >= 2 and max(means) - min(means) > ZERO_SPREAD * max(amps):
            lo, hi = int(np.argmin(means)), int(np.argmax(means))
            what = "the relative angle's mean" if len(twists[0]) == 1 else f"joint {j + 1}'s mean twist"
            if unstated:
                _in_degrees(path, records, unstated, f"{what} differs between runs by {max(means) - min(means):.3g} rad")
            raise RunsFileError(
                f"{path}: {what} differs between runs by {max(means) - min(means):.3g} rad (run "
                f"{run_ids[lo]}: {means[lo]:.3g} rad, run {run_ids[hi]}: {means[hi]:.3g} rad), "
                f"{(max(means) - min(means)) / max(amps):.2g} of the largest amplitude: the angle sensors look zeroed "
                f"at the start of each recording, and a joint's law needs one zero for all runs. Zero the encoders "
                f"once for the whole test, or pass --zero-per-run to take each run's mean as its zero (right for a "
                f"symmetric joint; a preload that differs between runs also shifts the mean)")
    return list(records)


#: Where a file's drive torque acts (``jointrig diagnose --torque-on``).
TORQUE_ON = ("flywheel1", "flywheel2", "shaft")


def _where_driven(path: Path, torque_on: str) -> int:
    """The body a two-flywheel file's torque drives (1 or 2), refusing a torque measured in the
    shaft: it is the joint's own torque, not a drive."""
    if torque_on not in TORQUE_ON:
        raise RunsFileError(f"--torque-on {torque_on!r}: expected one of {', '.join(TORQUE_ON)}")
    if torque_on == "shaft":
        raise RunsFileError(
            f"{path}: --torque-on shaft: a torque measured in the shaft between the flywheels is the joint's "
            f"own torque, not a drive; the diagnosis identifies the joint from the drive torque on a flywheel and "
            f"replays the runs in the rig under it. Record the motor's torque on the driven flywheel (a torque cell "
            f"between motor and flywheel) and give that column as 'torque'")
    return 2 if torque_on == "flywheel2" else 1


@dataclass(frozen=True)
class _Train:
    """A drive train's layout: the position column of each body, ``drives`` as (body number,
    column), ``kind`` how the bodies move (hinges: phi, torque in rad, N m; slides: x, force in m, N)."""

    positions: tuple
    drives: tuple
    kind: Coordinate

    @property
    def n_bodies(self) -> int:
        return len(self.positions)


def _train_layout(where: str, cols: dict) -> Optional[_Train]:
    """The drive-train layout of a table's columns, or None for a two-flywheel file; refuses a
    train whose positions are not ``phi1..phiN`` (``x1..xN``) without a gap, whose drives are not
    among them, or that mixes hinges and slides."""
    found = TRAIN_COLUMNS & set(cols)
    if not any(c.startswith("x") for c in cols):  # forces without positions: no slide's file
        found = {c for c in found if not c.startswith("force")}
    if not found:
        return None
    slide = [c for c in cols if c.startswith(("x", "force"))]
    hinge = [c for c in cols if c.startswith(("phi", "torque"))]
    if slide and hinge:
        raise RunsFileError(f"{where}: columns {sorted(hinge)} (bodies on hinges: rad, N m) and {sorted(slide)} "
                            f"(bodies on slides: m, N) in one file; expected the bodies of one line, all on hinges or "
                            f"all on slides")
    kind = SLIDE if slide else HINGE
    pos, drv = kind.position, kind.drive
    numbered = sorted(int(c[len(pos):]) for c in cols if re.fullmatch(rf"{pos}\d", c))
    if pos in cols and kind.bare_position_is_one_body:
        if numbered:
            raise RunsFileError(f"{where}: both 'x' and numbered positions {[f'x{i}' for i in numbered]}; 'x' is "
                                f"the position of a single body: give one of them")
        numbered, single = [1], True
    else:
        single = False
    N = max(numbered, default=0)
    gaps = [f"{pos}{i}" for i in range(1, N + 1) if i not in numbered]
    drives = tuple(sorted((int(c[len(drv):]), c) for c in cols if re.fullmatch(rf"{drv}\d", c)))
    if drv in cols:
        if any(i == 1 for i, _ in drives):
            raise RunsFileError(f"{where}: both '{drv}' and '{drv}1' are given; '{drv}' is the drive on body 1: "
                                f"give one of them")
        drives = ((1, drv),) + drives
    if gaps or N < 1:
        raise RunsFileError(f"{where}: a drive train's positions are columns {pos}1..{pos}N, one per body; "
                            + (f"missing {', '.join(gaps)}" if gaps else "found none") + f" (columns {sorted(cols)}). "
                            f"Every joint's law is a function of its two bodies' positions")
    beyond = [c for i, c in drives if i > N]
    if beyond:
        raise RunsFileError(f"{where}: drive column(s) {beyond} act on bodies with no position column (the train has "
                            f"{pos}1..{pos}{N}); expected {drv}<i> with i from 1 to {N}")
    if not drives:
        raise RunsFileError(f"{where}: no drive: expected a column {drv}<i> ({kind.drive_unit}) for each driven body (or "
                            f"'{drv}', the drive on body 1); without a known drive nothing fixes the scale")
    positions = (pos,) if single else tuple(f"{pos}{i}" for i in range(1, N + 1))
    return _Train(positions, drives, kind)


def read_runs(path: Union[str, os.PathLike], *, samples_per_period: Optional[int] = None,
              columns: Optional[Union[str, Mapping[str, str]]] = None,
              units: Optional[Union[str, Mapping[str, str]]] = None, zero_per_run: bool = False,
              torque_on: str = "flywheel1", torque_share: float = 0.5) -> LoadedRuns:
    """Read measured runs from a file or a folder of files into whole-period records of a line of
    bodies (module docstring).

    Args:
      samples_per_period: resample every run to this many samples per period (default: keep
        a whole number of samples per period as it is; a fixed-rate record gets 2 (H + 1)
        for the H harmonics estimated, :func:`identify.periods.ls_harmonics`).
      columns: canonical name -> the file's column name (``"torque=M,phi1=enc1"`` or a dict).
      units: canonical name -> unit of the file's column (``"phi1=deg,time=ms"``); see :data:`UNITS`.
      zero_per_run: take each run's mean angles as their zero (encoders zeroed at the start of
        each recording); without it such a file is refused (:data:`ZERO_SPREAD`).
      torque_on: where a two-flywheel file's ``torque`` acts: ``flywheel1`` or ``flywheel2`` (the
        bodies keep the file's numbering); ``shaft`` is refused with the reason. A drive train's
        file names its driven bodies by its ``torque<i>`` columns.
      torque_share: the relative angle alone (``phi``): the share of the torque that twists the
        joint, the undriven flywheel's inertia over both (``J1 J2/(J1 + J2) phi'' + M(phi, phi') =
        s T``, ``-s T`` on flywheel 2; exact without bearing drag).

    Raises:
      RunsFileError: any file that cannot be used, naming the file, run, column and row and
        what was expected.
    """
    path = Path(path)
    driven = _where_driven(path, torque_on)
    if samples_per_period is not None and (not isinstance(samples_per_period, (int, np.integer))
                                           or samples_per_period < 16):
        raise RunsFileError(f"samples_per_period must be an integer >= 16, got {samples_per_period!r}")
    columns = parse_mapping(columns, "columns")
    units = parse_mapping(units, "units")
    for k, v in units.items():
        if k != "run":
            _unit_factor("units", k, v)
    files = _files(path)
    side, side_cols, side_units = _sidecar(path)
    notes: list = []
    if side is not None:
        notes.append(NamesFrom(str(side)))
    columns = {**side_cols, **columns}
    units = {**side_units, **units}
    tables: list[tuple[Path, RawTable]] = []
    for f in files:
        try:
            tables.extend((f, t) for t in read_tables(f))
        except FormatError as err:
            raise RunsFileError(str(err)) from None
    multi = len(files) > 1
    # A folder's files are runs named by their stems, however many it holds (one included).
    named_by_file = multi or Path(path).is_dir()
    run_ids, records, seen, any_units, angles_stated, layouts, relatives = [], [], set(), False, False, [], []
    unstated: set = set()  # angle columns read as rad for want of a unit
    for f, table in tables:
        cols, stated = _resolve(table, columns, units, notes)
        _units_in_comments(table, columns, stated)
        any_units = any_units or bool(stated)
        angles_stated = angles_stated or any(c.startswith(("phi", "x")) for c in stated)
        unstated |= {c for c in cols if c.startswith(("phi", "x")) and c not in stated}
        where = table.source
        train = _train_layout(where, cols)
        if layouts and (train is None) != (layouts[-1] is None):
            mine, theirs = ("phi1..phiN, torque<i>", "torque, phi1, phi2") if train else \
                ("torque, phi1, phi2", "phi1..phiN, torque<i>")
            raise RunsFileError(f"{where}: this file has the columns {mine}, the files before it {theirs}; expected "
                                f"one bench per file or folder")
        if train and layouts and (train.kind, train.n_bodies) != (layouts[-1].kind, layouts[-1].n_bodies):
            raise RunsFileError(f"{where}: {train.n_bodies} bodies on {train.kind}s, the files before it "
                                f"{layouts[-1].n_bodies} on {layouts[-1].kind}s; expected one bench per file or folder")
        layouts.append(train)
        if "phi" in cols and ("phi1" in cols or "phi2" in cols):
            raise RunsFileError(f"{where}: give either 'phi' or 'phi1' and 'phi2', not both")
        if train and torque_on != "flywheel1":
            raise RunsFileError(f"--torque-on {torque_on}: {where} is a drive train's file, which names the driven "
                                f"bodies by its torque<i> columns; leave it out")
        if not train and "phi" in cols and not 0 < torque_share < 1:
            raise RunsFileError(f"--torque-share {torque_share}: expected J2/(J1 + J2), strictly between 0 and 1")
        rel = not train and "phi" in cols
        if relatives and rel != relatives[-1]:
            raise RunsFileError(f"{where}: this file has the column {'phi' if rel else 'phi1, phi2'}, the files before "
                                f"it {'phi1, phi2' if rel else 'phi'}; expected one bench per file or folder")
        relatives.append(rel)
        missing = sorted({"time"} - set(cols)) + ([] if train else sorted({"torque"} - set(cols)))
        if train:
            pass
        elif "phi" not in cols and not {"phi1", "phi2"} <= set(cols):
            missing += sorted({"phi1", "phi2"} - set(cols)) if {"phi1", "phi2"} & set(cols) else ["phi1, phi2 (or phi)"]
        if missing and train:
            raise RunsFileError(f"{where}: missing column(s) {', '.join(missing)}; a drive train's file has time, "
                                f"phi1..phiN and torque<i> (the drive on body i), optionally run and omega; its "
                                f"columns are {sorted(table.columns)} (map other names with --columns time=NAME)")
        if missing:  # every missing column at once
            raise RunsFileError(f"{where}: missing column(s) {', '.join(missing)}; expected time, torque (the drive "
                                f"torque on flywheel 1), phi1 and phi2 (or phi, the relative angle), optionally run "
                                f"and omega; its columns are {sorted(table.columns)} (map other names with --columns "
                                f"torque=NAME,phi1=NAME)")
        n = cols["time"].size
        for name, col in cols.items():
            if col.size != n:
                raise RunsFileError(f"{where}: column '{name}' has {col.size} values, 'time' has {n}")
            if name == "run":
                continue
            bad = ~np.isfinite(col) | (np.abs(col) > MAX_ABS_VALUE)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                run_i = f"run {cols['run'][i]}, " if "run" in cols else ""
                raise RunsFileError(f"{where}: column '{name}' holds {int(bad.sum())} missing, non-finite or "
                                    f"implausibly large value(s) (first {float(col[i])!r} in {run_i}data row "
                                    f"{i + 1}); expected finite numbers in {COLUMNS[name]} below {MAX_ABS_VALUE:g}")
        if n == 0:
            raise RunsFileError(f"{where}: no data rows")
        if "run" in cols:
            labels = cols["run"]
        else:
            labels = np.full(n, table.run if table.run is not None else (f.stem if named_by_file else "0"), dtype=object)
        prefix = f"{f.stem}/" if multi and ("run" in cols or table.run is not None) else ""
        for run in dict.fromkeys(labels.tolist()):
            sel = labels == run
            rid = prefix + str(run)
            if rid in seen:
                raise RunsFileError(f"{where}: run {rid!r} appears twice; expected one block of rows per run")
            seen.add(rid)
            omega = None
            if "omega" in cols:
                w = cols["omega"][sel]
                if np.ptp(w) > 1e-9 * abs(w[0]) or not w[0] > 0:
                    raise RunsFileError(f"{where}: run {run}: column 'omega' must be one positive value per run, "
                                        f"got {w.min():g}..{w.max():g} rad/s")
                omega = float(w[0])
            if train:
                drives = {i: cols[c][sel] for i, c in train.drives if np.any(cols[c][sel] != 0)}  # idle: 0
                if not drives:
                    raise RunsFileError(f"{where}: run {run}: every drive column ({', '.join(c for _, c in train.drives)}) "
                                        f"is zero; expected the drive torque of at least one body")
                records.append(_to_train_record(
                    where, rid, cols["time"][sel], drives, [cols[c][sel] for c in train.positions], omega,
                    samples_per_period, notes, train))
                run_ids.append(rid)
                continue
            chans = {"torque": cols["torque"][sel]}
            if "phi" in cols:
                chans["phi1"] = cols["phi"][sel]
            else:
                chans["phi1"], chans["phi2"] = cols["phi1"][sel], cols["phi2"][sel]
            share = None if "phi2" in chans else (torque_share if driven == 1 else -torque_share)
            records.append(_to_record(where, rid, cols["time"][sel], chans, omega, samples_per_period, notes, driven,
                                      share))
            run_ids.append(rid)
    if not any_units:
        notes.insert(0, NoUnits())
    relative = relatives[0]
    records = _plausible_angles(path, run_ids, records, angles_stated, zero_per_run, notes,
                                unstated if angles_stated else set(), relative)
    kind = layouts[0].kind if layouts and layouts[0] else HINGE
    return LoadedRuns(path, tuple(run_ids), tuple(records), tuple(notes), _digest(files), kind,
                      torque_share if relative else None)


def _column_order(name: str) -> tuple:
    """torque, torque1..8, then phi, phi1..8: the measured-runs format's column order."""
    return (not name.startswith("torque"), len(name), name)


def _channels(r) -> dict:
    """A record's columns in the measured-runs format (two flywheels, or a train's)."""
    if isinstance(r, ChainRecord):
        return ({f"torque{i}": t for i, t in enumerate(r.torques_Nm, start=1) if t is not None}
                | {f"phi{i}": a for i, a in enumerate(r.angles_rad, start=1) if a is not None})
    if r.phi2_rad is not None:
        return {"torque": r.torque_Nm, "phi1": r.phi1_rad, "phi2": r.phi2_rad}
    return {"torque": r.torque_Nm, "phi": r.phi_rad}


def write_runs(path: Union[str, os.PathLike], records: Sequence, *,
               run_ids: Optional[Sequence] = None, with_omega: bool = True, comment: str = "") -> Path:
    """Write records (two flywheels' or a drive train's) in the measured-runs format (CSV with
    units in the header, or Parquet with units in the schema metadata), atomically (temp file +
    rename)."""
    from jointrig.files import write_atomic

    path = Path(path)
    run_ids = list(range(len(records))) if run_ids is None else list(run_ids)
    if len(run_ids) != len(records):
        raise ValueError(f"{len(run_ids)} run ids for {len(records)} records")
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise ValueError(f"{path}: unknown file type {path.suffix!r}; expected .csv or .parquet")
    chans = [_channels(r) for r in records]
    # A train's body driven in some runs only: its drive column reads 0 in the others (an idle
    # motor's torque), which the reader takes as no drive in that run.
    idle = sorted({k for c in chans for k in c if k.startswith("torque")} - set.intersection(*(set(c) for c in chans)))
    cols: dict[str, list] = {"run": [], "time": []}
    for rid, r, ch in zip(run_ids, records, chans):
        ch = {k: ch.get(k, np.zeros(r.n_samples)) for k in sorted(set(ch) | set(idle), key=_column_order)}
        for k, v in ({"run": np.full(r.n_samples, rid), "time": r.time_s} | ch
                     | ({"omega": np.full(r.n_samples, r.omega_rad_s)} if with_omega else {})).items():
            cols.setdefault(k, []).append(v)
    if len({len(v) for v in cols.values()}) != 1:
        raise ValueError(f"{path}: the records hold different channels; expected runs of one bench")
    data = {k: np.concatenate(v) for k, v in cols.items()}

    def write(tmp: Path) -> None:
        if suffix == ".parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            units = {k: COLUMNS[k] for k in data}
            table = pa.table(data).replace_schema_metadata({"units": repr(units), "comment": comment})
            pq.write_table(table, tmp)
        else:
            with open(tmp, "w", newline="") as fh:
                fh.write("# jointrig measured runs\n")
                if comment:
                    fh.write(f"# {comment}\n")
                w = csv.writer(fh)
                w.writerow([k if k == "run" else f"{k} [{COLUMNS[k]}]" for k in data])
                for row in zip(*(data[k] for k in data)):
                    w.writerow([row[0]] + [repr(float(v)) for v in row[1:]])

    write_atomic(path, write)
    return path
