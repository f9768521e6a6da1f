"""Reader for the Silverbox benchmark (Wigren and Schoukens, ECC 2013), SNLS80mV.csv.

Layout (0-based samples; ``SOURCE.md`` beside the data), checked against the data here:

* ``[0, 40575)``: the "arrow", the TEST part (never used for estimation). Scored ranges:
  "full" ``[100, 40575)`` and "without extrapolation" ``[100, 32100)``; the first 50 samples of
  each initialise the simulation and are not scored.
* 10 odd random-phase multisine realisations (period N = 8192, odd bins 1..2683 excited), each a
  ~100-sample zero-input gap, a 400-sample transient and one steady period. The ESTIMATION part.
  Block starts are located from the data: the end of each zero-input gap, refined to the sample
  where the 400 transient samples best repeat 8192 samples later (the multisine is periodic).
* Offsets: the leading zero-input samples (before the arrow starts) give the DC offsets of both
  channels (input ~6.2 mV, output ~1.0 mV), which are subtracted; the output offset is the
  output at zero input, so any DC the circuit itself creates under excitation stays in the data.

Units: volts; ``fs = 1e7 / 2**14`` Hz.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Union

import numpy as np

__all__ = ["SilverboxData", "SilverboxError", "load_silverbox", "SchroederData", "load_schroeder", "DEFAULT_DIR", "FS_HZ", "PERIOD", "TRANSIENT"]

FS_HZ = 1e7 / 2**14
PERIOD = 8192
TRANSIENT = 400
N_REALISATIONS = 10
EXCITED_MAX_BIN = 2683
ARROW_FULL = (100, 40575)
ARROW_NO_EXTRAPOLATION = (100, 32100)
SCORE_SKIP = 50
#: Where the data set is looked for: $JOINTRIG_SILVERBOX, else ``../shared/data/silverbox``
#: beside the source tree (an installed copy has no such neighbour: pass ``--data DIR``).
DEFAULT_DIR = Path(os.environ.get("JOINTRIG_SILVERBOX")
                   or Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "silverbox")


class SilverboxError(ValueError):
    """The file is missing or does not have the documented layout (names the file and the item)."""


@dataclass(frozen=True)
class SilverboxData:
    """The Silverbox record, offsets removed.

    Attributes:
      path: the CSV file.
      u_V, y_V: input and output (V), ``(131072,)``.
      u_offset_V, y_offset_V: DC offsets removed (from the leading zero-input samples).
      block_starts: first sample of each multisine block (its transient), ``(10,)``.
      fs_Hz: sampling rate.
    """

    path: Path
    u_V: np.ndarray
    y_V: np.ndarray
    u_offset_V: float
    y_offset_V: float
    block_starts: tuple[int, ...]
    fs_Hz: float = FS_HZ

    def estimation_periods(self) -> tuple[np.ndarray, np.ndarray]:
        """The steady multisine periods: ``(u, y)``, each ``(10, 8192)``."""
        idx = np.array(self.block_starts)[:, None] + TRANSIENT + np.arange(PERIOD)
        return self.u_V[idx], self.y_V[idx]

    def arrow(self, which: str = "full") -> tuple[np.ndarray, np.ndarray, slice]:
        """Arrow input and output from sample 0 to the end of the range, and the scored slice.

        ``which``: ``"full"`` or ``"no_extrapolation"``. The simulation starts at sample 0 (zero
        input, system at rest); scoring starts 50 samples into the range.
        """
        ranges = {"full": ARROW_FULL, "no_extrapolation": ARROW_NO_EXTRAPOLATION}
        if which not in ranges:
            raise ValueError(f"unknown arrow range {which!r}; expected one of {sorted(ranges)}")
        start, stop = ranges[which]
        return self.u_V[:stop], self.y_V[:stop], slice(start + SCORE_SKIP, stop)

    @property
    def excited_bins(self) -> np.ndarray:
        return np.arange(1, EXCITED_MAX_BIN + 1, 2)


def _quiet_runs(u: np.ndarray, level: float, min_len: int) -> list[tuple[int, int]]:
    quiet = np.abs(u) < level
    edges = np.flatnonzero(np.diff(np.r_[0, quiet.astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2]) if b - a >= min_len]


def _data_file(directory, name: str, what: str) -> tuple[Path, list[str]]:
    """The path of one of the data set's CSV files and its header (column names, quotes removed)."""
    path = Path(directory or os.environ.get("JOINTRIG_SILVERBOX") or DEFAULT_DIR) / name
    if not path.is_file():
        raise SilverboxError(f"{path}: no such file ({what})")
    with open(path) as f:
        header = [h.strip().strip('"') for h in f.readline().strip().split(",") if h.strip()]
    return path, header


def load_silverbox(directory: Optional[Union[str, os.PathLike]] = None) -> SilverboxData:
    """Read ``SNLS80mV.csv`` from ``directory`` (default ``../shared/data/silverbox`` beside the
    project, or ``$JOINTRIG_SILVERBOX``) and locate its parts. Nothing is downloaded.

    Raises:
      SilverboxError: missing file, unexpected columns, non-finite values, or a layout that
        does not match the documented one.
    """
    path, header = _data_file(directory, "SNLS80mV.csv",
                              "give the Silverbox directory, e.g. ../shared/data/silverbox")
    if header[:2] != ["V1", "V2"]:
        raise SilverboxError(f"{path}: columns {header}, expected 'V1' (input) and 'V2' (output) first")
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1))
    if data.ndim != 2 or data.shape[0] < ARROW_FULL[1] + N_REALISATIONS * (PERIOD + TRANSIENT):
        raise SilverboxError(f"{path}: {data.shape[0] if data.ndim == 2 else 0} rows, too short for the "
                             f"documented layout")
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise SilverboxError(f"{path}: non-finite value in column {header[col]} at row {row + 2}")
    u_raw, y_raw = data[:, 0], data[:, 1]
    # Leading zero-input samples: the input stays within its noise around the offset.
    lead = _quiet_runs(u_raw - np.median(u_raw[:50]), 0.002, 50)
    if not lead or lead[0][0] != 0:
        raise SilverboxError(f"{path}: no zero-input segment at the start (expected ~86 samples)")
    lead_end = min(lead[0][1], 90)
    u_off, y_off = float(u_raw[:lead_end].mean()), float(y_raw[:lead_end].mean())
    u, y = u_raw - u_off, y_raw - y_off
    gaps = [r for r in _quiet_runs(u, 0.002, 30) if ARROW_FULL[1] - 200 < r[1] < len(u) - PERIOD]
    starts = []
    for _, gap_end in gaps:
        if len(starts) == N_REALISATIONS:
            break
        cands = range(gap_end - 20, gap_end + 20)
        mism = [np.sqrt(np.mean((u[b:b + TRANSIENT] - u[b + PERIOD:b + PERIOD + TRANSIENT]) ** 2)) for b in cands]
        best = int(cands[int(np.argmin(mism))])
        if starts and best - starts[-1] < PERIOD + TRANSIENT:
            continue
        # periodicity check: the transient's input repeats one period later (to within the noise)
        if min(mism) > 0.1 * np.std(u[best:best + PERIOD]):
            raise SilverboxError(f"{path}: multisine block after sample {gap_end} does not repeat with period "
                                 f"{PERIOD} (mismatch {min(mism):.3g} V)")
        starts.append(best)
    if len(starts) != N_REALISATIONS:
        raise SilverboxError(f"{path}: found {len(starts)} multisine blocks, expected {N_REALISATIONS}")
    for s in starts:
        spec = np.abs(np.fft.rfft(u[s + TRANSIENT:s + TRANSIENT + PERIOD]))
        odd = spec[1:EXCITED_MAX_BIN + 1:2]
        even = spec[2:EXCITED_MAX_BIN + 1:2]
        if np.mean(odd**2) < 100 * np.mean(even**2):
            raise SilverboxError(f"{path}: block at sample {s} is not an odd multisine up to bin {EXCITED_MAX_BIN}")
    return SilverboxData(path=path, u_V=u, y_V=y, u_offset_V=u_off, y_offset_V=y_off, block_starts=tuple(starts))


#: The Schroeder-phase multisine of ``Schroeder80mV.csv``: 1024 samples per period from sample
#: 10584 (0-based; README.txt's 1-based 10585); measured to repeat for 11 periods there. The
#: first two hold the transient (period 0 differs from period 1 by 1.2 mV RMS in the input,
#: later ones by 0.4 mV, the noise) and are skipped.
SCHROEDER_START = 10584
SCHROEDER_PERIOD = 1024
SCHROEDER_PERIODS = 11
SCHROEDER_SKIP = 2


@dataclass(frozen=True)
class SchroederData:
    """Steady periods of the Schroeder multisine (another excitation of the same circuit), offsets
    removed as README.txt says (the mean of each channel over the file). ``u_V``, ``y_V``:
    ``(periods, 1024)``."""

    path: Path
    u_V: np.ndarray
    y_V: np.ndarray
    fs_Hz: float = FS_HZ


def load_schroeder(directory: Optional[Union[str, os.PathLike]] = None) -> SchroederData:
    """Read the Schroeder multisine periods of ``Schroeder80mV.csv`` (columns Ovld2, Ovld1, V1,
    V2). Never used for estimation: the Silverbox path uses it only to check that an extension
    chosen on the estimation multisines generalises to another excitation.

    Raises:
      SilverboxError: missing file, unexpected columns, or a section that does not repeat.
    """
    path, header = _data_file(directory, "Schroeder80mV.csv", "the Schroeder multisine of the Silverbox data set")
    if header[2:4] != ["V1", "V2"]:
        raise SilverboxError(f"{path}: columns {header}, expected 'V1' and 'V2' third and fourth")
    data = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=(2, 3))
    end = SCHROEDER_START + SCHROEDER_PERIODS * SCHROEDER_PERIOD
    if data.ndim != 2 or data.shape[0] < end or not np.all(np.isfinite(data[:end])):
        raise SilverboxError(f"{path}: expected finite V1, V2 up to sample {end}")
    u = data[:, 0] - data[:, 0].mean()
    y = data[:, 1] - data[:, 1].mean()
    idx = (SCHROEDER_START + np.arange(SCHROEDER_SKIP, SCHROEDER_PERIODS)[:, None] * SCHROEDER_PERIOD
           + np.arange(SCHROEDER_PERIOD))
    uu, yy = u[idx], y[idx]
    spread = float(np.sqrt(np.mean((uu - uu.mean(axis=0)) ** 2)))
    if spread > 0.1 * float(np.std(uu)):
        raise SilverboxError(f"{path}: the input from sample {SCHROEDER_START} does not repeat every "
                             f"{SCHROEDER_PERIOD} samples (period-to-period spread {spread:.3g} V)")
    return SchroederData(path, uu, yy)
