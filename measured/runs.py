"""Measured runs of a joint test: the file format the diagnosis reads and the rig writes.

One row per sample, CSV or Parquet (chosen by the file extension ``.csv`` / ``.parquet``):

    run     integer or text label of the run (one steady-state record at one drive setting)
    time    s
    torque  N m, drive torque on flywheel 1 as recorded
    phi1    rad, flywheel 1 angle       } or ``phi`` (rad, relative angle phi1 - phi2)
    phi2    rad, flywheel 2 angle       }
    omega   rad/s, optional: the drive's fundamental (constant within a run)

CSV files may start with ``#`` comment lines (the writer puts the units there). Any other
column is refused. A run that does not hold a whole number of periods is trimmed to whole
periods (the fundamental estimated from the torque when there is no ``omega``) and, when the
samples per period are not an integer, resampled onto a uniform grid of whole periods by a
cubic spline; each such change is reported in :attr:`LoadedRuns.notes`.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence, Union

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar

from identify.records import SteadyStateRecord

__all__ = ["RunsFileError", "LoadedRuns", "read_runs", "write_runs", "estimate_omega", "COLUMNS"]

COLUMNS = {"run": "-", "time": "s", "torque": "N m", "phi1": "rad", "phi2": "rad", "phi": "rad",
           "omega": "rad/s"}


class RunsFileError(ValueError):
    """A measured-runs file that cannot be used (names the file, run, column and what was expected)."""


@dataclass(frozen=True)
class LoadedRuns:
    """Records read from a file, one per run, in file order, and what was done to them."""

    path: Path
    run_ids: tuple[str, ...]
    records: tuple[SteadyStateRecord, ...]
    notes: tuple[str, ...]

    @property
    def has_both_angles(self) -> bool:
        return all(r.phi2_rad is not None for r in self.records)


def _read_table(path: Path) -> dict[str, np.ndarray]:
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(path)
        except Exception as err:  # noqa: BLE001 - pyarrow raises many types for a bad file
            raise RunsFileError(f"{path}: not a readable Parquet file: {err}") from None
        return {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
    if suffix != ".csv":
        raise RunsFileError(f"{path}: unknown file type {suffix!r}; expected .csv or .parquet")
    with open(path, newline="") as fh:
        lines = [ln for ln in fh if not ln.lstrip().startswith("#") and ln.strip()]
    rows = list(csv.reader(lines))
    if not rows:
        raise RunsFileError(f"{path}: no header row; expected columns run,time,torque,phi1,phi2")
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    cols: dict[str, list] = {h: [] for h in header}
    for i, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise RunsFileError(f"{path}: data row {i - 1} has {len(row)} fields, the header has {len(header)}")
        for h, v in zip(header, row):
            cols[h].append(v.strip())
    out = {}
    for h, vals in cols.items():
        if h == "run":
            out[h] = np.array(vals, dtype=object)
            continue
        try:
            out[h] = np.array([float(v) if v not in ("", "nan", "NaN") else math.nan for v in vals])
        except ValueError as err:
            raise RunsFileError(f"{path}: column '{h}' holds a non-number ({err})") from None
    return out


def estimate_omega(time_s: np.ndarray, torque_Nm: np.ndarray) -> float:
    """The drive fundamental (rad/s) from a torque record: the periodogram peak, refined.

    Raises RunsFileError if the torque has no clear periodic component.
    """
    t = time_s - time_s[0]
    x = torque_Nm - torque_Nm.mean()
    n = x.size
    dt = float(np.median(np.diff(t)))
    spec = np.abs(np.fft.rfft(x, 8 * n)) ** 2
    k = int(np.argmax(spec[1:])) + 1
    w0 = 2 * math.pi * k / (8 * n * dt)
    dw = 2 * math.pi / (8 * n * dt)

    def neg_power(w):
        # Least-squares sine fit (cos, sin, mean) at w: unlike the periodogram it is not biased
        # by the negative-frequency image when the record holds a non-integer number of periods.
        basis = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
        coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
        return -float(np.sum((basis @ coef) ** 2))

    res = minimize_scalar(neg_power, bounds=(w0 - 2 * dw, w0 + 2 * dw), method="bounded",
                          options={"xatol": 1e-10 * w0})
    return float(res.x)


def _to_record(path, run, t, torque, phi1, phi2, omega, samples_per_period, notes) -> SteadyStateRecord:
    where = f"{path}: run {run}"
    n = t.size
    if n < 16:
        raise RunsFileError(f"{where}: {n} samples is too short; expected at least 16")
    dt_all = np.diff(t)
    if np.any(dt_all <= 0):
        raise RunsFileError(f"{where}: column 'time' must be strictly increasing within a run")
    dt = float(np.median(dt_all))
    if np.max(np.abs(dt_all - dt)) > 1e-3 * dt:
        raise RunsFileError(f"{where}: column 'time' is not uniformly sampled (steps {dt_all.min():.6g}.."
                            f"{dt_all.max():.6g} s)")
    if omega is None:
        omega = estimate_omega(t, torque)
        notes.append(f"run {run}: no 'omega' column; the fundamental estimated from the torque is "
                     f"{omega:.9g} rad/s")
    period = 2 * math.pi / omega
    per_float = period / dt
    P = int(math.floor(n / per_float + 1e-6))
    if P < 2:
        raise RunsFileError(f"{where}: holds {n / per_float:.3g} periods of omega = {omega:.6g} rad/s; expected "
                            f"at least 2 whole periods (the noise is estimated from period-to-period variation)")
    per = int(round(per_float))
    integer = abs(per_float - per) < 1e-6 * per_float
    cols = [torque, phi1] + ([phi2] if phi2 is not None else [])
    if integer and samples_per_period in (None, per):
        if P * per != n:
            notes.append(f"run {run}: {n} samples hold {n / per:.4g} periods; trimmed to {P} whole periods "
                         f"({P * per} samples)")
        sel = slice(0, P * per)
        t_new = t[sel]
        out = [c[sel] for c in cols]
        per_new = per
    else:
        per_new = samples_per_period or per
        t_new = t[0] + np.arange(P * per_new) * period / per_new
        if t_new[-1] > t[-1]:
            P -= 1
            if P < 2:
                raise RunsFileError(f"{where}: fewer than 2 whole periods after trimming")
            t_new = t_new[: P * per_new]
        out = [CubicSpline(t, c)(t_new) for c in cols]
        notes.append(f"run {run}: {per_float:.6g} samples per period is not an integer; trimmed to {P} whole "
                     f"periods and resampled to {per_new} samples per period (cubic spline)")
    return SteadyStateRecord(
        omega_rad_s=float(omega), time_s=t_new, torque_Nm=out[0], phi1_rad=out[1],
        phi2_rad=out[2] if phi2 is not None else None, n_periods=P, source=f"{path} run {run}",
    )


def read_runs(path: Union[str, os.PathLike], *, samples_per_period: Optional[int] = None) -> LoadedRuns:
    """Read a measured-runs file into whole-period records (see the module docstring).

    Args:
      samples_per_period: resample every run to this many samples per period (default: keep
        the file's sampling when it divides the period, else round it).

    Raises:
      RunsFileError: missing file, unknown or missing columns, non-numbers or NaNs (with the
        run, column and row), non-uniform time, fewer than 2 whole periods in a run.
    """
    path = Path(path)
    if not path.is_file():
        raise RunsFileError(f"{path}: no such file")
    table = _read_table(path)
    names = set(table)
    unknown = sorted(names - set(COLUMNS))
    if unknown:
        raise RunsFileError(f"{path}: unknown column(s) {unknown}; expected run, time, torque, phi1, phi2 "
                            f"(or phi instead of phi1, phi2) and optionally omega")
    missing = sorted({"run", "time", "torque"} - names)
    if missing:
        raise RunsFileError(f"{path}: missing column(s) {missing}")
    if "phi" in names and names & {"phi1", "phi2"}:
        raise RunsFileError(f"{path}: give either 'phi' or 'phi1' and 'phi2', not both")
    if "phi" not in names and not {"phi1", "phi2"} <= names:
        raise RunsFileError(f"{path}: missing angle column(s): expected 'phi1' and 'phi2', or 'phi'")
    run_col = np.array([str(v) for v in table["run"]], dtype=object)
    for name, col in table.items():
        if name == "run":
            continue
        col = np.asarray(col, dtype=float)
        bad = ~np.isfinite(col)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise RunsFileError(f"{path}: column '{name}' holds {int(bad.sum())} missing or non-finite value(s) "
                                f"(first in run {run_col[i]}, data row {i + 1}); expected finite numbers in "
                                f"{COLUMNS[name]}")
        table[name] = col
    order = list(dict.fromkeys(run_col.tolist()))
    records, notes = [], []
    for run in order:
        sel = run_col == run
        omega = None
        if "omega" in table:
            w = table["omega"][sel]
            if np.ptp(w) > 1e-9 * abs(w[0]) or not w[0] > 0:
                raise RunsFileError(f"{path}: run {run}: column 'omega' must be one positive value per run, "
                                    f"got {w.min():g}..{w.max():g} rad/s")
            omega = float(w[0])
        phi1 = table["phi"][sel] if "phi" in table else table["phi1"][sel]
        phi2 = None if "phi" in table else table["phi2"][sel]
        records.append(_to_record(path, run, table["time"][sel], table["torque"][sel], phi1, phi2, omega,
                                  samples_per_period, notes))
    return LoadedRuns(path, tuple(order), tuple(records), tuple(notes))


def write_runs(path: Union[str, os.PathLike], records: Sequence[SteadyStateRecord], *,
               run_ids: Optional[Sequence] = None, with_omega: bool = True, comment: str = "") -> Path:
    """Write records in the measured-runs format, atomically (temp file + rename)."""
    path = Path(path)
    run_ids = list(range(len(records))) if run_ids is None else list(run_ids)
    if len(run_ids) != len(records):
        raise ValueError(f"{len(run_ids)} run ids for {len(records)} records")
    two = all(r.phi2_rad is not None for r in records)
    cols: dict[str, list] = {"run": [], "time": [], "torque": []}
    if two:
        cols.update(phi1=[], phi2=[])
    else:
        cols["phi"] = []
    if with_omega:
        cols["omega"] = []
    for rid, r in zip(run_ids, records):
        n = r.n_samples
        cols["run"].append(np.full(n, rid))
        cols["time"].append(r.time_s)
        cols["torque"].append(r.torque_Nm)
        if two:
            cols["phi1"].append(r.phi1_rad)
            cols["phi2"].append(r.phi2_rad)
        else:
            cols["phi"].append(r.phi_rad)
        if with_omega:
            cols["omega"].append(np.full(n, r.omega_rad_s))
    data = {k: np.concatenate(v) for k, v in cols.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        if path.suffix.lower() == ".parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            units = {k: COLUMNS[k] for k in data}
            table = pa.table(data).replace_schema_metadata({"units": repr(units), "comment": comment})
            pq.write_table(table, tmp)
        elif path.suffix.lower() == ".csv":
            with open(tmp, "w", newline="") as fh:
                fh.write("# jointrig measured runs; units: "
                         + ", ".join(f"{k} [{COLUMNS[k]}]" for k in data) + "\n")
                if comment:
                    fh.write(f"# {comment}\n")
                w = csv.writer(fh)
                w.writerow(list(data))
                for row in zip(*(data[k] for k in data)):
                    w.writerow([row[0]] + [repr(float(v)) for v in row[1:]])
        else:
            raise ValueError(f"{path}: unknown file type {path.suffix!r}; expected .csv or .parquet")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
