"""Readers for the files test benches export, each into the same raw form: named columns with
the units the file states (if any), one table per run where the format groups by run.

Formats (by file extension):

* ``.csv`` / ``.txt`` / ``.tsv``: delimiter (``,`` ``;`` tab ``|`` or blanks), UTF-8 byte-order
  mark and decimal comma detected; ``#`` comment lines skipped; units in the header in
  brackets or parentheses (``phi1 [deg]``, ``time (ms)``) or in a second header row of units.
* ``.parquet``: columns; timestamp and duration columns become seconds from the first sample;
  units from the schema metadata ``units`` the writer puts there, if present.
* ``.mat``: MATLAB (v4-v7 through scipy.io; v7.3 is HDF5 and read as such): every top-level
  numeric vector is a column (``time``, ``torque``, ``phi1``, ...); a struct array is read as
  one run per element.
* ``.h5`` / ``.hdf5``: 1-D datasets at the root are columns; each group holding 1-D datasets is
  one run named by the group; a dataset's ``units`` (or ``unit``) attribute gives its unit.
* ``.tdms`` (NI LabVIEW, npTDMS): each group is a run, each channel a column; units from the
  channel property ``unit_string``; without a time channel, time comes from the waveform
  properties ``wf_start_offset`` and ``wf_increment``.
* ``.uff`` / ``.unv`` (universal file, dataset 58, pyuff): each function is one channel of one
  run: the channel is named by ID line 1 (``id1``), the run by the load case number
  (``load_case_id``); time from the abscissa; units from the axis labels.

Every reader raises :class:`FormatError` (a ``ValueError``) naming the file and what was
expected; nothing else escapes for a malformed file.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

__all__ = ["FormatError", "RawTable", "SUFFIXES", "read_tables"]


class FormatError(ValueError):
    """A file that cannot be read as any of the supported formats (names the file)."""


@dataclass
class RawTable:
    """Columns as read (name -> 1-D array; text stays object arrays), the units the file states
    (name -> unit text), the run this table is (for formats that group by run) and where it came from."""

    source: str
    columns: dict
    units: dict = field(default_factory=dict)
    run: Optional[str] = None
    #: the file's comment lines (``#`` lines of a CSV), which may state what the header does not
    comments: tuple = ()


_HEADER_UNIT = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*$")


def split_header(name: str) -> tuple[str, Optional[str]]:
    """``'phi1 [deg]'`` -> ``('phi1', 'deg')``; ``'time'`` -> ``('time', None)``."""
    name = name.strip().strip('"').strip()
    m = _HEADER_UNIT.match(name)
    if m and m.group(1):
        return m.group(1), (m.group(2) or None)
    return name, None


# ------------------------------------------------------------------------------------- CSV

_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d*(?:[eE][+-]?\d+)?$")


def _to_float(v: str) -> float:
    v = v.strip().strip('"')
    if v in ("", "nan", "NaN", "NAN", "NA", "#N/A"):
        return math.nan
    return float(v)


def _is_number(v: str) -> bool:
    try:
        _to_float(v)
        return True
    except ValueError:
        return False


def _read_csv(path: Path) -> list[RawTable]:
    raw = path.read_bytes()
    for enc in ("utf-8-sig", "cp1252", "latin-1"):
        try:
            text = raw.decode(enc)
            break
        except UnicodeDecodeError:
            continue
    if "\x00" in text:
        raise FormatError(f"{path}: holds NUL bytes: not a text (CSV) file")
    comments = tuple(ln.strip().lstrip("#").strip() for ln in text.splitlines() if ln.lstrip().startswith("#"))
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise FormatError(f"{path}: no header row; expected a first line naming the columns, for example "
                          f"run,time,torque,phi1,phi2")
    head = lines[0]
    delim = None
    best = 1
    for d in (",", ";", "\t", "|"):
        k = len(next(csv.reader([head], delimiter=d)))
        if k > best:
            best, delim = k, d

    def parse(block: list[str]) -> list[list[str]]:
        if delim is None:
            return [ln.split() for ln in block] if len(head.split()) > 1 else [[ln.strip()] for ln in block]
        return list(csv.reader(io.StringIO("\n".join(block)), delimiter=delim))

    header, *body = parse(lines[:2])  # the header and what may be a row of units
    names, units = [], {}
    for h in header:
        name, unit = split_header(h)
        names.append(name)
        if unit:
            units[name] = unit
    first = 1  # the body's first line
    # A second header row of units (LabVIEW, DASYLab exports): no numbers at all in it.
    # An empty cell (under ``run``, say) is no number and no unit.
    if body and len(body[0]) == len(names) and not any(v.strip() and _is_number(v) for v in body[0]) \
            and any(v.strip() for v in body[0]):
        for name, u in zip(names, body[0]):
            u = u.strip().strip("[]()")
            if u and name not in units:
                units[name] = u
        first = 2
    decimal_comma = delim in (";", "\t", "|", None) and any(
        _DECIMAL_COMMA.match(v.strip()) for row in parse(lines[first:first + 20]) for v in row)
    seen = set()
    for name in names:
        if name in seen:
            raise FormatError(f"{path}: column name {name!r} appears twice in the header; expected unique names")
        seen.add(name)
    if delim is not None and not decimal_comma and len(lines) > first:
        # Plain numbers in every field (a DAQ's usual export): parsed in numpy's C reader, ~5x
        # faster than the csv module; anything else (quotes, blanks, labels, a short row) raises
        # and takes the general path below, with its messages.
        try:
            data = np.loadtxt(lines[first:], delimiter=delim, dtype=float, comments=None, ndmin=2)
        except ValueError:
            data = None
        if data is not None and data.shape[1] == len(names):
            return [RawTable(str(path), {n: data[:, k].copy() for k, n in enumerate(names)}, units,
                             comments=comments)]
    body = parse(lines[first:])
    if not decimal_comma and delim in (";", "\t", "|", None) and any("," in ln for ln in lines[first:]):
        # The rows looked at above may all be whole numbers (a logger at rest writes "0"): a
        # decimal comma further down decides as well.
        decimal_comma = any(_DECIMAL_COMMA.match(v.strip()) for row in body for v in row)
    for i, row in enumerate(body, start=1):
        if len(row) != len(names):
            raise FormatError(f"{path}: data row {i} has {len(row)} fields, the header has {len(names)} "
                              f"({', '.join(names)})")
    columns = list(zip(*body)) if body else [()] * len(names)
    out = {}
    for name, vals in zip(names, columns):
        if decimal_comma:
            vals = [v.replace(",", ".") for v in vals]
        try:
            out[name] = np.array(vals, dtype=float)  # plain numbers: converted in numpy, ~10x faster
        except ValueError:
            try:
                out[name] = np.array([_to_float(v) for v in vals], dtype=float)  # quoted, blank, NA
            except ValueError:
                out[name] = np.array([v.strip().strip('"') for v in vals], dtype=object)
    return [RawTable(str(path), out, units, comments=comments)]


# --------------------------------------------------------------------------------- Parquet


def _seconds(col: np.ndarray) -> np.ndarray:
    if col.dtype.kind == "M":
        return (col - col[0]).astype("timedelta64[ns]").astype(np.int64) / 1e9
    if col.dtype.kind == "m":
        return col.astype("timedelta64[ns]").astype(np.int64) / 1e9
    return col


def _read_parquet(path: Path) -> list[RawTable]:
    import pyarrow.parquet as pq

    try:
        # ParquetFile reads the file as written; read_table's dataset layer refuses duplicate
        # column names with an internal message before the check below can name them.
        table = pq.ParquetFile(path).read()
    except Exception as err:  # noqa: BLE001 - pyarrow raises many types for a bad file
        raise FormatError(f"{path}: not a readable Parquet file: {err}") from None
    names = table.column_names
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise FormatError(f"{path}: column name(s) {dup} appear more than once; expected unique names")
    cols, units = {}, {}
    for name in names:
        try:
            col = table.column(name).to_numpy(zero_copy_only=False)
        except Exception as err:  # noqa: BLE001
            raise FormatError(f"{path}: column {name!r} cannot be read as an array: {err}") from None
        if col.dtype.kind in "Mm":
            col = _seconds(col)
            units[name] = "s"
        base, unit = split_header(name)
        if unit:
            units[base] = unit
            units.pop(name, None)
        cols[base] = col
    meta = table.schema.metadata or {}
    if b"units" in meta:
        import ast

        try:
            stated = ast.literal_eval(meta[b"units"].decode())
        except (ValueError, SyntaxError, UnicodeDecodeError):
            stated = {}
        if isinstance(stated, dict):
            for k, v in stated.items():
                if isinstance(k, str) and isinstance(v, str) and k in cols:
                    units.setdefault(k, v)
    return [RawTable(str(path), cols, units)]


# ------------------------------------------------------------------------------------- MAT


def _loadmat(path: Path) -> dict:
    import faulthandler

    import scipy.io

    faulthandler.disable()  # run in a child of its own: a crash there is the parent's to report, by the file's name
    return scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)


def _in_a_fork(fn, path: Path):
    """``fn(path)`` in a forked child (a :class:`jointrig.parallel.WarmProcess`) where ``fork``
    exists: a reader that crashes the process on a corrupt file (scipy's MAT v5 reader has died
    by SIGSEGV on a duplicated byte block, with no message at all) ends only the child, and the
    file is refused by name. Exceptions come back as they were raised."""
    import multiprocessing

    from jointrig.parallel import ProcessEnded, WarmProcess

    if "fork" not in multiprocessing.get_all_start_methods():
        return fn(path)
    with WarmProcess(()) as child:
        try:
            return child.call(fn, path)
        except ProcessEnded as err:
            raise FormatError(f"{path}: the reader crashed on this file (exit {err.exitcode}): it is corrupt or not "
                              f"what its extension says") from None


def _read_mat(path: Path) -> list[RawTable]:
    try:
        mat = _in_a_fork(_loadmat, path)
    except FormatError:
        raise
    except NotImplementedError:  # v7.3: HDF5
        return _read_hdf5(path)
    except Exception as err:  # noqa: BLE001 - scipy raises many types for a bad file
        raise FormatError(f"{path}: not a readable MATLAB file: {err}") from None
    from scipy.io.matlab import mat_struct

    names = [k for k in mat if not k.startswith("__")]
    structs = [k for k in names if isinstance(mat[k], (mat_struct, np.ndarray)) and _is_struct(mat[k])]
    if structs:
        tables = []
        for k in structs:
            elems = mat[k] if isinstance(mat[k], np.ndarray) else [mat[k]]
            for i, s in enumerate(np.ravel(elems)):
                cols = {f: np.ravel(np.asarray(getattr(s, f))) for f in s._fieldnames}
                cols = _scalar_omega({f: v for f, v in cols.items() if v.size > 1 or f in ("omega", "run")})
                label = str(getattr(s, "run", None) if "run" in s._fieldnames else f"{k}({i + 1})")
                tables.append(RawTable(f"{path} {k}({i + 1})", {c: v for c, v in cols.items() if c != "run"},
                                       {}, label))
        return tables
    cols = {}
    for k in names:
        v = np.asarray(mat[k])  # squeeze_me: a vector is 1-D, a scalar 0-D, whatever MATLAB's shape
        if v.dtype.kind in "iuf" and v.ndim <= 1 and (v.size > 1 or k == "omega"):
            cols[k] = np.ravel(v).astype(float)
        elif v.dtype.kind in "USbc" and v.ndim == 1:  # text, true/false, complex: named by the loader if used
            cols[k] = v.astype(object)
    cols = _scalar_omega(cols)
    if not cols:
        raise FormatError(f"{path}: no numeric vectors found; expected variables time, torque, phi1, phi2 "
                          f"(or phi) as vectors, or a struct array with those fields, one element per run")
    return [RawTable(str(path), cols, {})]


def _scalar_omega(cols: dict) -> dict:
    """A scalar ``omega`` (rad/s) holds for every sample of its record, as a column would."""
    n = max((v.size for f, v in cols.items() if f not in ("omega", "run")), default=0)
    if "omega" in cols and cols["omega"].size == 1 and n > 1:
        cols = {**cols, "omega": np.full(n, float(np.ravel(cols["omega"])[0]))}
    return cols


def _is_struct(v) -> bool:
    from scipy.io.matlab import mat_struct

    if isinstance(v, mat_struct):
        return True
    return isinstance(v, np.ndarray) and v.dtype == object and v.size > 0 and all(
        isinstance(e, mat_struct) for e in np.ravel(v))


# ------------------------------------------------------------------------------------ HDF5


def _read_hdf5(path: Path) -> list[RawTable]:
    import h5py

    try:
        fh = h5py.File(path, "r")
    except Exception as err:  # noqa: BLE001 - h5py raises OSError and others
        raise FormatError(f"{path}: not a readable HDF5 file: {err}") from None

    def columns(group, where):
        cols, units = {}, {}
        for name, obj in group.items():
            if isinstance(obj, h5py.Dataset) and obj.ndim == 1 or (
                    isinstance(obj, h5py.Dataset) and obj.ndim == 2 and 1 in obj.shape):
                try:
                    arr = np.ravel(obj[()])
                except Exception as err:  # noqa: BLE001
                    raise FormatError(f"{path}: dataset {where}{name} cannot be read: {err}") from None
                if arr.dtype.kind in "SO":
                    arr = np.array([a.decode() if isinstance(a, bytes) else str(a) for a in arr], dtype=object)
                elif arr.dtype.kind in "bc":  # true/false, complex: kept, so the loader names them if used
                    arr = arr.astype(object)
                elif arr.dtype.kind not in "iuf":
                    continue
                base, unit = split_header(name)
                cols[base] = arr
                u = obj.attrs.get("units", obj.attrs.get("unit"))
                if isinstance(u, bytes):
                    u = u.decode()
                if u is not None:
                    units[base] = str(u)
                elif unit:
                    units[base] = unit
        return cols, units

    with fh:
        tables = []
        cols, units = columns(fh, "/")
        if cols:
            tables.append(RawTable(str(path), cols, units))
        for name, obj in fh.items():
            if isinstance(obj, h5py.Group):
                c, u = columns(obj, f"/{name}/")
                if c:
                    tables.append(RawTable(f"{path} /{name}", c, u, run=name))
    if not tables:
        raise FormatError(f"{path}: no 1-D datasets at the root or in its groups; expected datasets time, torque, "
                          f"phi1, phi2 (or phi), at the root or one group per run")
    return tables


# ------------------------------------------------------------------------------------ TDMS


def _tdms_seconds(stamps: np.ndarray) -> np.ndarray:
    """Seconds since the first of TDMS time stamps (whole seconds and 2^-64 s fractions)."""
    whole = (stamps["seconds"] - stamps["seconds"][0]).astype(float)
    frac = (stamps["second_fractions"].astype(float) - float(stamps["second_fractions"][0])) / 2.0 ** 64
    return whole + frac


def _read_tdms(path: Path) -> list[RawTable]:
    from nptdms import TdmsFile

    try:
        # raw time stamps: TDMS keeps 2^-64 s, npTDMS's datetime64 would round them to 1 us
        tdms = TdmsFile.read(path, raw_timestamps=True)
    except Exception as err:  # noqa: BLE001 - npTDMS raises many types for a bad file
        raise FormatError(f"{path}: not a readable TDMS file: {err}") from None
    tables = []
    for group in tdms.groups():
        cols, units = {}, {}
        wf = None
        for ch in group.channels():
            try:
                data = np.asarray(ch[:])
            except Exception as err:  # noqa: BLE001
                raise FormatError(f"{path}: channel {group.name}/{ch.name} cannot be read: {err}") from None
            if data.ndim != 1 or data.size == 0:
                continue
            base, unit = split_header(ch.name)
            if data.dtype.names is not None and {"seconds", "second_fractions"} <= set(data.dtype.names):
                data, unit = _tdms_seconds(data), "s"
            elif data.dtype.kind == "M":
                data, unit = _seconds(data), "s"
            elif data.dtype.kind in "bc":  # true/false, complex: kept, so the loader names them if used
                data = data.astype(object)
            elif data.dtype.kind not in "iuf":
                continue
            cols[base] = data
            u = ch.properties.get("unit_string") or unit
            if u:
                units[base] = str(u)
            if wf is None and "wf_increment" in ch.properties:
                wf = (float(ch.properties.get("wf_start_offset", 0.0)), float(ch.properties["wf_increment"]),
                      data.size)
        if not cols:
            continue
        if wf is not None and not any(split_header(c)[0].lower() == "time" for c in cols):
            t0, dt, n = wf
            if not (math.isfinite(dt) and dt > 0):
                raise FormatError(f"{path}: group {group.name}: wf_increment = {dt!r}; expected a positive "
                                  f"sample step in s")
            cols["time"] = t0 + np.arange(n) * dt
            units["time"] = "s"
        tables.append(RawTable(f"{path} group {group.name}", cols, units, run=group.name))
    if not tables:
        raise FormatError(f"{path}: no TDMS groups with numeric channels; expected one group per run with channels "
                          f"torque, phi1, phi2 (or phi) and time (or waveform timing)")
    return tables


# ------------------------------------------------------------------------------------- UFF


def _uff_cut(path: Path) -> bool:
    """Whether an ASCII universal file ends inside a dataset: every dataset ends with a line
    ``    -1``, so a file cut short (a copy interrupted, a full disk) does not; pyuff then drops
    the last datasets without a word. A binary UFF 58b is not checked."""
    with open(path, "rb") as f:
        f.seek(0, os.SEEK_END)
        f.seek(max(0, f.tell() - 4096))
        tail = f.read()
    if b"\x00" in tail:
        return False
    lines = [ln.strip() for ln in tail.splitlines() if ln.strip()]
    return bool(lines) and lines[-1] != b"-1"


def _read_uff(path: Path) -> list[RawTable]:
    import pyuff

    if _uff_cut(path):
        raise FormatError(f"{path}: the file ends inside a dataset (no closing '-1' line): it was cut short, and its "
                          f"last run(s) would be lost; copy it again whole")
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as err:  # noqa: BLE001 - pyuff raises many types for a bad file
        raise FormatError(f"{path}: not a readable universal file (UFF): {err}") from None
    if isinstance(sets, dict):
        sets = [sets]
    runs: dict[str, RawTable] = {}
    for i, s in enumerate(sets):
        if not isinstance(s, dict) or s.get("type") != 58:
            continue
        if s.get("func_type") not in (1, None):
            raise FormatError(f"{path}: dataset {i + 1} is function type {s.get('func_type')}; expected 1 "
                              f"(time response)")
        name = str(s.get("id1", "")).strip()
        if not name:
            raise FormatError(f"{path}: dataset {i + 1} has no name in ID line 1; expected the channel "
                              f"(torque, phi1, phi2 or phi)")
        base, unit = split_header(name)
        run = str(s.get("load_case_id", 0))
        tab = runs.setdefault(run, RawTable(f"{path} load case {run}", {}, {}, run=run))
        if base in tab.columns:
            raise FormatError(f"{path}: load case {run} holds channel {base!r} twice; expected one function "
                              f"per channel and run")
        data = np.asarray(s.get("data"))
        if data.dtype.kind == "c":
            raise FormatError(f"{path}: dataset {i + 1} ({base}) is complex; expected a real time response")
        tab.columns[base] = data.astype(float)
        u = str(s.get("ordinate_axis_units_lab", "") or "").strip() or unit
        if u:
            tab.units[base] = u
        x = np.asarray(s.get("x"), dtype=float)
        if "time" not in tab.columns and x.size == data.size:
            tab.columns["time"] = x
            xu = str(s.get("abscissa_axis_units_lab", "") or "").strip()
            tab.units["time"] = xu or "s"
    if not runs:
        raise FormatError(f"{path}: no dataset 58 (function at nodal DOF) found; expected one time response per "
                          f"channel and run")
    return list(runs.values())


_READERS = {
    ".csv": _read_csv, ".txt": _read_csv, ".tsv": _read_csv, ".dat": _read_csv,
    ".parquet": _read_parquet, ".mat": _read_mat, ".h5": _read_hdf5, ".hdf5": _read_hdf5,
    ".tdms": _read_tdms, ".uff": _read_uff, ".unv": _read_uff,
}

#: File extensions read by :func:`read_tables`.
SUFFIXES = tuple(sorted(_READERS))


def read_tables(path: Path) -> list[RawTable]:
    """Read one file into raw tables (see the module docstring).

    Raises:
      FormatError: unknown extension, or a file that is not what its extension says.
    """
    reader = _READERS.get(path.suffix.lower())
    if reader is None:
        raise FormatError(f"{path}: unknown file type {path.suffix!r}; expected one of {', '.join(SUFFIXES)}")
    try:
        return reader(path)
    except FormatError:
        raise
    except (OSError, ValueError, TypeError, KeyError, IndexError, AttributeError, UnicodeError,
            OverflowError, MemoryError, RuntimeError) as err:  # h5py raises RuntimeError on a corrupt file
        raise FormatError(f"{path}: cannot be read as {path.suffix} ({type(err).__name__}: {err})") from None
