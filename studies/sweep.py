"""Frequency x amplitude sweeps on the rig, resumable, with results written atomically.

A sweep store is a directory: ``manifest.json`` (model digest, joint law, simulation
config, plan) and one ``.npz`` file per finished point (arrays named with their units,
metadata in a JSON string ``meta``; loaded with ``allow_pickle=False``). Every file is
written to a temporary name in the same directory and renamed into place, so an
interrupted sweep leaves only whole files, and re-running the same sweep skips the points
already done.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import math
import tempfile
import threading
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from jointrig.files import write_atomic, write_json_atomic
from jointrig.vocab.records import SteadyStateRecord

from jointrig.rig.model import RigModel, load_rig
from jointrig.rig.simulate import SIMULATOR_VERSION, SettleInfo, SimulationConfig, StartState, simulate_steady_state
from jointrig.rig.native_callback import choose_native

__all__ = ["SweepPlan", "SweepPoint", "SweepStoreMismatch", "run_sweep", "simulate_segment", "DEFAULT_PLAN",
           "EXECUTORS", "records_of", "MultisinePlan", "DEFAULT_MULTISINE",
           "run_multisines"]

log = logging.getLogger(__name__)

FORMAT_VERSION = 1


@dataclass(frozen=True)
class SweepPlan:
    """Drive settings: every ``omega_rad_s`` at every ``amplitude_Nm`` (torque on flywheel 1)."""

    omegas_rad_s: tuple[float, ...]
    amplitudes_Nm: tuple[float, ...]

    def __post_init__(self):
        om = tuple(float(w) for w in self.omegas_rad_s)
        am = tuple(float(a) for a in self.amplitudes_Nm)
        if not om or not am:
            raise ValueError("a sweep needs at least one frequency and one amplitude")
        if any(not (math.isfinite(w) and w > 0) for w in om):
            raise ValueError(f"omegas_rad_s must be finite and > 0, got {om}")
        if any(not (math.isfinite(a) and a > 0) for a in am):
            raise ValueError(f"amplitudes_Nm must be finite and > 0, got {am}")
        object.__setattr__(self, "omegas_rad_s", om)
        object.__setattr__(self, "amplitudes_Nm", am)

    def points(self) -> list[tuple[float, float]]:
        return [(w, a) for a in self.amplitudes_Nm for w in self.omegas_rad_s]

    def coherent(self, sample_rate_Hz: float) -> "SweepPlan":
        """The plan with every frequency moved to the nearest one a bench sampling at
        ``sample_rate_Hz`` holds whole periods of (rig.simulate.coherent_omega)."""
        from jointrig.rig.simulate import coherent_omega

        return SweepPlan(tuple(dict.fromkeys(coherent_omega(w, sample_rate_Hz) for w in self.omegas_rad_s)),
                         self.amplitudes_Nm)


#: Default sweep for the paper's joint (undamped natural frequency sqrt(k/Je) = 44.7 rad/s):
#: from far below (1 rad/s, the paper's case) through the natural frequency to twice it,
#: at the paper's drive (M0 = 400 N m on flywheel 1, eq. 12) and at 10x, where the cubic
#: term reaches ~7% of the linear one (at 400 N m it is ~0.1%, nearly invisible).
DEFAULT_PLAN = SweepPlan(omegas_rad_s=(1.0, 10.0, 20.0, 30.0, 40.0, 45.0, 50.0, 60.0, 90.0),
                         amplitudes_Nm=(400.0, 4000.0))


@dataclass(frozen=True)
class MultisinePlan:
    """Odd random-phase multisine runs (identify.multisine): one run per RMS level, all with
    fundamental ``omega0_rad_s``, odd lines up to ``max_harmonic_excited`` and the same phases
    and detection lines (the levels differ only in scale, so the distortion's growth with
    level is seen line for line)."""

    omega0_rad_s: float
    max_harmonic_excited: int
    rms_levels_Nm: tuple[float, ...]
    seed: int = 0

    def excitations(self):
        from jointrig.identify.multisine import odd_multisine

        return [odd_multisine(self.omega0_rad_s, self.max_harmonic_excited, rms, seed=self.seed)
                for rms in self.rms_levels_Nm]

    @property
    def n_harmonics(self) -> int:
        """Harmonics to balance: three times the top line (a cubic term's reach)."""
        return 3 * self.max_harmonic_excited


#: Default multisine test of the paper's joint: lines 2.5 .. 87.5 rad/s (the stepped sweep's
#: span, through the natural frequency 44.7 rad/s to twice it), one of every three odd lines
#: left out to detect distortion, at RMS 300 N m and 2000 N m (the stepped sweep's peak
#: amplitudes 400 and 4000 N m are RMS 283 and 2828 N m; a multisine's crest factor is ~3).
DEFAULT_MULTISINE = MultisinePlan(omega0_rad_s=2.5, max_harmonic_excited=35, rms_levels_Nm=(300.0, 2000.0))


def run_multisines(rig: RigModel, plan: MultisinePlan = DEFAULT_MULTISINE,
                   config: SimulationConfig = SimulationConfig(samples_per_period=512), *,
                   backend: str = "auto") -> list[tuple[SteadyStateRecord, SettleInfo, object]]:
    """Simulate every multisine run to steady state: ``(record, settle info, excitation)``;
    ``backend`` as :func:`rig.simulate.simulate_steady_state`'s.

    Raises:
      ValueError: too few samples per period for the harmonics to balance.
    """
    from jointrig.identify.harmonics import max_harmonic

    if max_harmonic(config.samples_per_period) < plan.n_harmonics:
        raise ValueError(f"samples_per_period={config.samples_per_period} resolves harmonics up to "
                         f"{max_harmonic(config.samples_per_period)}; the multisine needs {plan.n_harmonics} "
                         f"(at least {2 * plan.n_harmonics + 1} samples per period)")
    out = []
    for ms in plan.excitations():
        rec, info = simulate_steady_state(rig, plan.omega0_rad_s, ms.rms_Nm, config, drive=ms.drive, backend=backend)
        out.append((rec, info, ms))
        log.info("multisine RMS %.0f N m: %d lines, steady after %d periods (bound %.1e)", ms.rms_Nm,
                 len(ms.excited), info.periods_simulated, info.error_bound)
    return out


@dataclass(frozen=True)
class SweepPoint:
    record: SteadyStateRecord
    settle: SettleInfo
    from_store: bool


class SweepStoreMismatch(ValueError):
    """The store directory holds a sweep of another model, law or configuration."""


def _manifest(rig: RigModel, config: SimulationConfig) -> dict:
    return {
        "format": FORMAT_VERSION,
        "simulator": SIMULATOR_VERSION,
        "units": "SI: time_s in s, angles in rad, rates in rad/s, torque in N m",
        "model": str(rig.path),
        "model_sha256": rig.digest,
        "law": rig.law.as_dict(),
        "simulation": dataclasses.asdict(config),
    }


def _point_path(store: Path, omega: float, amplitude: float) -> Path:
    return store / f"w{omega:.9g}_M{amplitude:.9g}.npz"


def _save_point(path: Path, point: SweepPoint) -> None:
    r = point.record
    meta = {"omega_rad_s": r.omega_rad_s, "drive_amplitude_Nm": r.drive_amplitude_Nm,
            "n_periods": r.n_periods, "source": r.source, "settle": dataclasses.asdict(point.settle)}

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, time_s=r.time_s, torque_Nm=r.torque_Nm, phi1_rad=r.phi1_rad,
                     phi2_rad=r.phi2_rad, rate1_rad_s=r.rate1_rad_s, rate2_rad_s=r.rate2_rad_s,
                     meta=np.array(json.dumps(meta)))

    write_atomic(path, write)


def _load_point(path: Path) -> SweepPoint:
    with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        record = SteadyStateRecord(
            omega_rad_s=meta["omega_rad_s"], time_s=z["time_s"], torque_Nm=z["torque_Nm"],
            phi1_rad=z["phi1_rad"], phi2_rad=z["phi2_rad"], rate1_rad_s=z["rate1_rad_s"],
            rate2_rad_s=z["rate2_rad_s"], n_periods=meta["n_periods"],
            drive_amplitude_Nm=meta["drive_amplitude_Nm"], source=meta["source"])
    return SweepPoint(record, SettleInfo(**meta["settle"]), from_store=True)


def _segments(points: list[tuple[float, float]], continuation: bool, parts: int) -> list[list[int]]:
    """Index lists simulated one after another (continuation chains); independent of each other.

    Without continuation every point is its own segment. With it, a chain is one amplitude's
    frequencies in plan order (each starts from the previous one's steady state); chains are
    cut into contiguous pieces until there are at least ``parts`` segments (so every worker
    has one), each piece starting from rest.
    """
    if not continuation:
        return [[i] for i in range(len(points))]
    chains: list[list[int]] = []
    for i, (_, amp) in enumerate(points):
        if chains and points[chains[-1][-1]][1] == amp:
            chains[-1].append(i)
        else:
            chains.append([i])
    pieces = max(1, math.ceil(parts / len(chains)))
    out = []
    for chain in chains:
        size = math.ceil(len(chain) / min(pieces, len(chain)))
        out.extend(chain[j:j + size] for j in range(0, len(chain), size))
    return out


def simulate_segment(rig: RigModel, tasks: Sequence[tuple[float, float, Optional[SweepPoint]]],
                     config: SimulationConfig, backend: str, continuation: bool,
                     on_point: Optional[Callable[[int, SweepPoint], None]] = None) -> list[SweepPoint]:
    """Simulate a segment's points in order; ``tasks`` are ``(omega, amplitude, stored)``;
    ``backend`` as :func:`rig.simulate.simulate_steady_state`'s.

    A stored point is reused as is (and, with continuation, starts the next point).
    """
    out: list[SweepPoint] = []
    prev: Optional[SteadyStateRecord] = None
    for j, (omega, amp, stored) in enumerate(tasks):
        if stored is not None:
            point = stored
        else:
            start = StartState.of_record(prev) if continuation and prev is not None else None
            record, info = simulate_steady_state(rig, omega, amp, config, backend=backend, start=start)
            point = SweepPoint(record, info, from_store=False)
        prev = point.record
        out.append(point)
        if on_point is not None:
            on_point(j, point)
    return out


def default_store(rig: RigModel, config: SimulationConfig, root: Path = Path("runs/store")) -> Path:
    """Where a sweep of ``rig`` under ``config`` keeps its finished points by default: a folder
    named by the model and a digest of the model file and the simulation settings, so a sweep
    with other settings never resumes from these."""
    key = json.dumps([rig.digest, dataclasses.asdict(config)], sort_keys=True)
    return root / f"{rig.path.stem}-{hashlib.sha256(key.encode()).hexdigest()[:12]}"


def run_sweep(
    rig: RigModel,
    plan: SweepPlan = DEFAULT_PLAN,
    config: SimulationConfig = SimulationConfig(),
    *,
    store: Optional[Path] = None,
    progress: Optional[Callable[[int, int, SweepPoint], None]] = None,
    backend: str = "auto",
    workers: int = 1,
    continuation: bool = False,
    executor: str = "local",
    scheduler: Optional[str] = None,
) -> list[SweepPoint]:
    """Simulate every point of ``plan`` (amplitude-major order), reusing finished points.

    Args:
      store: directory to keep finished points in (created if missing); None keeps nothing.
        Points are saved as they finish, by the calling process, also with a cluster.
      progress: called as ``progress(i, n, point)`` after each point (in completion order
        when ``workers > 1``).
      backend: ``"native"``: the native C callback (the same numbers, faster); ``"python"``: the
        Python callback; ``"auto"`` (the default): native wherever it can run
        (:func:`rig.native_callback.choose_native`).
      workers: simulate this many points at once: threads for the ``local`` executor (needs
        the native callback: MuJoCo's stepping releases the GIL, a Python callback would take it back at
        every force evaluation), processes for a local ``dask`` cluster. Results are
        identical to a serial sweep: the segments are independent.
      continuation: start each point from the previous frequency's steady state at the same
        amplitude instead of from rest (fewer periods to settle; see
        ``scripts/bench_steady.py``). The steady state reached is the same to ``settle_tol``;
        the records are not bit-identical to a sweep from rest.
      executor: ``local`` (this process) or ``dask`` (a dask.distributed cluster: each segment
        is a task; the model file's text travels with it, so workers need no shared disk).
      scheduler: the dask scheduler address (``tcp://host:8786``); None starts a local
        cluster of ``workers`` processes for the duration of the sweep.

    Raises:
      SweepStoreMismatch: ``store`` holds points of another model, law or configuration.
    """
    manifest = _manifest(rig, config)
    if store is not None:
        store = Path(store)
        mpath = store / "manifest.json"
        if mpath.exists():
            try:
                old = json.loads(mpath.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as err:
                raise SweepStoreMismatch(f"{mpath}: not readable JSON ({err}): the store's manifest is cut or corrupt; "
                                         f"delete the folder {store} to start the sweep afresh") from None
            if old != manifest:
                diff = sorted(k for k in set(old) | set(manifest) if old.get(k) != manifest.get(k))
                raise SweepStoreMismatch(
                    f"{store}: holds a sweep with different {diff}; use another store directory "
                    f"(or delete this one) to start afresh")
        else:
            write_json_atomic(mpath, manifest)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {executor!r}")
    backend = "native" if choose_native(backend, (rig.plant,)) else "python"
    if executor == "local" and workers > 1 and backend != "native":
        raise ValueError("workers > 1 needs the native callback (backend 'native', or 'auto' where a C compiler "
                         "builds it): the Python passive callback is one global that holds the GIL, so threads "
                         "would neither share it safely nor run in parallel")
    if scheduler is not None and executor != "dask":
        raise ValueError("scheduler is an address of a dask cluster: use executor='dask'")
    points = plan.points()
    segments = _segments(points, continuation, workers)
    t0 = time.perf_counter()
    results: dict[int, SweepPoint] = {}
    done_lock = threading.Lock()

    def stored(i: int) -> Optional[SweepPoint]:
        if store is None:
            return None
        path = _point_path(store, *points[i])
        if not path.exists():
            return None
        try:
            point = _load_point(path)
            omega, amplitude = points[i]
            r = point.record
            if not (math.isclose(r.omega_rad_s, omega, rel_tol=1e-12)
                    and math.isclose(r.drive_amplitude_Nm, amplitude, rel_tol=1e-12)):
                raise ValueError(f"it holds the point omega = {r.omega_rad_s:g} rad/s, M0 = {r.drive_amplitude_Nm:g} "
                                 f"N m, not this one (omega = {omega:g} rad/s, M0 = {amplitude:g} N m)")
            return point
        except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as err:
            # A point file that cannot be read (a sweep killed mid-write before atomic writes,
            # a full disk, bit rot) is simulated again, not a reason to stop resuming.
            log.warning("sweep store %s: cannot read it (%s: %s); simulating that point again", path,
                        type(err).__name__, err)
            return None

    def finished(i: int, point: SweepPoint) -> None:
        omega, amp = points[i]
        if store is not None and not point.from_store:
            _save_point(_point_path(store, omega, amp), point)
        with done_lock:
            results[i] = point
            count = len(results)
        log.info("point %d/%d (%d done): omega %6.2f rad/s, M0 %7.1f N m: %s, %d periods, change %.1e, "
                 "bound %.1e (%.1f s elapsed)", i + 1, len(points), count, omega, amp,
                 "from store" if point.from_store else f"simulated in {point.settle.wall_time_s:.2f} s",
                 point.settle.periods_simulated, point.settle.last_change, point.settle.error_bound,
                 time.perf_counter() - t0)
        if progress is not None:
            progress(i, len(points), point)

    def tasks_of(seg: list[int]) -> list[tuple[float, float, Optional[SweepPoint]]]:
        return [(points[i][0], points[i][1], stored(i)) for i in seg]

    def local(seg: list[int]) -> None:
        simulate_segment(rig, tasks_of(seg), config, backend, continuation,
                         on_point=lambda j, point: finished(seg[j], point))

    if executor == "dask":
        _run_dask(rig, segments, points, tasks_of, config, backend, continuation, workers, scheduler, finished)
    elif workers == 1:
        for seg in segments:
            local(seg)
    else:
        from concurrent.futures import ThreadPoolExecutor

        from jointrig.rig.native_callback import native_session

        with native_session(), ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(local, _longest_first(segments, points, config)))
    return [results[i] for i in range(len(points))]


EXECUTORS = ("local", "dask")


def _longest_first(segments: list[list[int]], points, config: SimulationConfig) -> list[list[int]]:
    """Segments in order of decreasing integrator steps per period (low frequencies first), so
    that parallel workers finish together instead of one waiting for the last long point."""
    def cost(seg):
        return sum(config.samples_for(points[i][0]) * config.steps_per_sample(points[i][0]) for i in seg)

    return sorted(segments, key=cost, reverse=True)

_worker_models: dict = {}
_worker_lock = threading.Lock()


#: How long a dask scheduler named by ``--scheduler`` may take to answer (s).
SCHEDULER_TIMEOUT_S = 10


def connect_scheduler(address: str):
    """A dask client of the scheduler at ``address``; a scheduler that does not answer is a
    clear error naming the option (it was a traceback after dask's 30 s)."""
    from dask.distributed import Client

    try:
        return Client(address, timeout=SCHEDULER_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as err:
        raise ValueError(f"--scheduler {address}: no dask scheduler answered there within {SCHEDULER_TIMEOUT_S} s "
                         f"({type(err).__name__}: {err}); start one with 'dask scheduler' and its workers with "
                         f"'dask worker {address}', or drop --scheduler for a local cluster") from None


def worker_model(model_name: str, model_text: bytes, digest: str, load: Callable[[Path], object]):
    """The model a dask worker process simulates: rebuilt from the client's model text by ``load``
    (``load_rig`` or ``load_chain``), checked against the client's digest, and cached per worker
    process by digest (both kinds of sweep share the cache: a digest names one file's text)."""
    with _worker_lock:
        rig = _worker_models.get(digest)
        if rig is None:
            with tempfile.TemporaryDirectory(prefix="jointrig-worker-") as tmp:
                path = Path(tmp) / model_name
                path.write_bytes(model_text)
                rig = load(path)
            if rig.digest != digest:
                raise RuntimeError(f"{model_name}: the worker's model digest {rig.digest} differs from "
                                   f"the client's {digest}")
            _worker_models[digest] = rig
    return rig


_python_callback_lock = threading.Lock()


def _remote_segment(model_name: str, model_text: bytes, digest: str, plant, tasks, config: SimulationConfig,
                    backend: str, continuation: bool) -> list[SweepPoint]:
    """A dask task: rebuild the rig from the model text (cached per worker process by digest),
    check it is the same model, give it the client's plant (which may differ from the file's),
    simulate the segment. Python-callback simulations in one worker process run one at a time
    (the callback is process-global)."""
    rig = worker_model(model_name, model_text, digest, load_rig)
    rig = rig.with_plant(plant)
    if backend == "native":
        from jointrig.rig.native_callback import native_session

        with native_session():
            return simulate_segment(rig, tasks, config, backend, continuation)
    with _python_callback_lock:
        return simulate_segment(rig, tasks, config, backend, continuation)


def _run_dask(rig: RigModel, segments, points_of, tasks_of, config, backend, continuation, workers, scheduler,
              finished) -> None:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as err:  # pragma: no cover - dask is a declared dependency
        raise RuntimeError("executor 'dask' needs dask.distributed (pip install 'dask[distributed]')") from err
    text = Path(rig.path).read_bytes()
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            cluster = stack.enter_context(LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                       dashboard_address=":0"))  # any free port: 8787 may be taken
            client = stack.enter_context(Client(cluster))
        else:
            client = stack.enter_context(connect_scheduler(scheduler))
        log.info("dask cluster %s: %d segment(s)", client.scheduler.address, len(segments))
        futures = {}
        for seg in _longest_first(segments, points_of, config):
            fut = client.submit(_remote_segment, Path(rig.path).name, text, rig.digest, rig.plant, tasks_of(seg),
                                config, backend, continuation, pure=False)
            futures[fut] = seg
        for fut in as_completed(futures):
            for i, point in zip(futures[fut], fut.result()):
                finished(i, point)


def records_of(points: Sequence[SweepPoint]) -> list[SteadyStateRecord]:
    return [p.record for p in points]
