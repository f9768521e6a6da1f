"""Sweeping a chain: one cosine drive per point, finished points kept on disk (resumable).

A point is ``(omega rad/s, amplitude N m, driven flywheel)``. Each finished point is written
atomically as ``.npz`` into the store directory, whose manifest ties it to the model file's
digest, the simulation settings and the simulator's version (:data:`rig.simulate.SIMULATOR_VERSION`);
a sweep started again loads the points it finds and simulates the rest.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from jointrig.identify.chain import ChainRecord
from jointrig.vocab.plant import PeriodicDrive

from jointrig.rig.chain import ChainRig, simulate_chain
from jointrig.rig.simulate import SIMULATOR_VERSION, SettleInfo, SimulationConfig
from jointrig.rig.native_callback import choose_native
from jointrig.files import write_atomic, write_json_atomic

from .sweep import SweepStoreMismatch, connect_scheduler, worker_model

__all__ = ["ChainPoint", "CHAIN_PLAN", "HELD_OUT", "CHAIN_CONFIG", "run_chain_sweep"]

log = logging.getLogger(__name__)

#: The pump train's default sweep, (omega rad/s, amplitude N m, driven flywheel): around and
#: between its modes (47, 195, 448 Hz = 295, 1224, 2817 rad/s), motor-side ripple of 60 N m and
#: one run at 120 N m near the coupling mode, where the coupling twists by ~10 mrad and its
#: cubic stiffening (5% of the linear torque there) is seen; two runs driven from the pump
#: side so that the pump's own equation is excited directly.
CHAIN_PLAN: tuple = ((150.0, 60.0, 1), (250.0, 60.0, 1), (300.0, 60.0, 1), (330.0, 120.0, 1), (600.0, 60.0, 1),
                     (1200.0, 60.0, 1), (2000.0, 60.0, 1), (3000.0, 60.0, 1), (400.0, 30.0, 4), (1500.0, 30.0, 4))

#: Held-out runs of the pump train: another level and other frequencies than :data:`CHAIN_PLAN`,
#: driven from both ends.
HELD_OUT: tuple = ((300.0, 90.0, 1), (800.0, 45.0, 4))

#: 128 samples per period and steps of at most 50 us (the highest mode, 2817 rad/s, then has
#: w dt <= 0.14 under RK4): noise-free identification to ~1e-7 (README, tests/test_chain.py).
CHAIN_CONFIG = SimulationConfig(samples_per_period=128, max_step_s=5e-5)


@dataclass(frozen=True)
class ChainPoint:
    omega_rad_s: float
    amplitude_Nm: float
    flywheel: int
    record: ChainRecord
    settle: SettleInfo


def _manifest(rig: ChainRig, config: SimulationConfig) -> dict:
    return {"format": 1, "kind": "chain", "simulator": SIMULATOR_VERSION, "model_sha256": rig.digest,
            "config": dataclasses.asdict(config)}


def _path(store: Path, w: float, a: float, i: int) -> Path:
    return store / f"w{w!r}_a{a!r}_f{i}.npz"


def _save(path: Path, pt: ChainPoint) -> None:
    rec = pt.record
    N = rec.n_flywheels

    def stack(rows):
        return np.array([r if r is not None else np.full(rec.n_samples, np.nan) for r in rows])

    def write(tmp: Path):
        with open(tmp, "wb") as fh:
            np.savez(fh, time_s=rec.time_s, angles_rad=stack(rec.angles_rad), rates_rad_s=stack(rec.rates_rad_s),
                     torques_Nm=stack(rec.torques_Nm), n_periods=rec.n_periods, omega_rad_s=rec.omega_rad_s,
                     amplitude_Nm=pt.amplitude_Nm, flywheel=pt.flywheel, n_flywheels=N,
                     settle=np.array([pt.settle.periods_simulated, pt.settle.last_change, pt.settle.timestep_s,
                                      pt.settle.wall_time_s, pt.settle.error_bound, pt.settle.decay_ratio]))
    write_atomic(path, write)


def _load(path: Path, source: str) -> ChainPoint:
    with np.load(path) as z:
        def rows(a):
            return tuple(None if np.all(np.isnan(r)) else r for r in a)
        rec = ChainRecord(float(z["omega_rad_s"]), z["time_s"], rows(z["torques_Nm"]), rows(z["angles_rad"]),
                          rows(z["rates_rad_s"]), int(z["n_periods"]), float(z["amplitude_Nm"]), source=source)
        s = z["settle"]
        settle = SettleInfo(int(s[0]), float(s[1]), float(s[2]), float(s[3]), float(s[4]), float(s[5]))
        return ChainPoint(rec.omega_rad_s, float(z["amplitude_Nm"]), int(z["flywheel"]), rec, settle)


_python_callback_lock = threading.Lock()


def _remote_point(model_name: str, model_text: bytes, digest: str, plant, point: tuple, config: SimulationConfig,
                  backend: str) -> ChainPoint:
    """A dask task: rebuild the chain from the model text (cached per worker process by digest),
    check it is the same model, give it the client's plant, simulate one point."""
    from jointrig.rig.chain import load_chain

    rig = worker_model(model_name, model_text, digest, load_chain)
    rig = rig.with_plant(plant)
    w, a, i = point
    if backend == "native":
        from jointrig.rig.native_callback import native_session

        with native_session():
            rec, info = simulate_chain(rig, w, {i: PeriodicDrive.cosine(w, a)}, config, amplitude_Nm=a, backend=backend)
    else:
        with _python_callback_lock:  # the Python callback is process-global: one at a time
            rec, info = simulate_chain(rig, w, {i: PeriodicDrive.cosine(w, a)}, config, amplitude_Nm=a, backend=backend)
    return ChainPoint(w, a, i, rec, info)


def default_chain_store(rig: ChainRig, config: SimulationConfig, root: Path = Path("runs/store")) -> Path:
    """Where a chain sweep keeps its finished points by default (as :func:`studies.sweep.default_store`)."""
    key = json.dumps(["chain", SIMULATOR_VERSION, rig.digest, dataclasses.asdict(config)], sort_keys=True)
    return root / f"{rig.path.stem}-{hashlib.sha256(key.encode()).hexdigest()[:12]}"


def run_chain_sweep(rig: ChainRig, points: Sequence[tuple], config: SimulationConfig = CHAIN_CONFIG, *,
                    store: Optional[Path] = None, backend: str = "auto",
                    workers: int = 1, executor: str = "local",
                    scheduler: Optional[str] = None) -> list[ChainPoint]:
    """Simulate every ``(omega, amplitude, flywheel)`` point (loading those already in ``store``;
    ``backend``: ``"native"``, ``"python"`` or ``"auto"``, as :func:`rig.chain.simulate_chain`'s;
    the records agree to 1e-8 of their peak either way, so stored points serve any backend).

    ``workers > 1`` simulates that many points at once in threads sharing one installed native
    callback (:func:`rig.native_callback.native_session`; needs the native backend: a Python callback
    holds the GIL). ``executor="dask"`` sends each point to a dask.distributed cluster instead
    (``scheduler``: its address; default a local cluster of ``workers`` processes) with the
    model text and the plant. The points come back in the order given, bit-identical to a
    serial sweep.

    Raises:
      ValueError: a point whose flywheel has no motor, or a non-positive frequency or amplitude
        (checked for all points before any simulation); ``workers > 1`` without the native backend.
      SweepStoreMismatch: ``store`` holds points of another model, other settings or another
        simulator version.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if executor not in ("local", "dask"):
        raise ValueError(f"unknown executor {executor!r}; expected 'local' or 'dask'")
    backend = "native" if choose_native(backend, rig.plant.laws) else "python"
    if workers > 1 and backend != "native" and executor == "local":
        raise ValueError("chain sweeps in threads need the native callback (backend 'native', or 'auto' where a C "
                         "compiler builds it): a Python callback "
                         "holds the GIL and MuJoCo's passive callback is global")
    for w, a, i in points:
        if not (math.isfinite(w) and w > 0 and math.isfinite(a) and a > 0):
            raise ValueError(f"sweep point ({w}, {a}, {i}): frequency and amplitude must be finite numbers > 0")
        if i not in rig.driven:
            raise ValueError(f"sweep point ({w:g} rad/s, {a:g} N m) drives flywheel {i}, which has no motor in "
                             f"{rig.path.name} (motors on {list(rig.driven)})")
        config.samples_for(w)
    if store is not None:
        store = Path(store)
        store.mkdir(parents=True, exist_ok=True)
        man = store / "manifest.json"
        want = _manifest(rig, config)
        if man.exists():
            have = json.loads(man.read_text())
            if have != want:
                what = ("another version of the simulator (its manifest.json: "
                        f"{have.get('simulator')}, this one: {want['simulator']})"
                        if have.get("simulator") != want["simulator"] else "another model or other settings")
                raise SweepStoreMismatch(f"{store}: holds points of {what}; use another --store or delete it")
        else:
            write_json_atomic(man, want)
    total = len(points)

    def one(k: int, point: tuple) -> ChainPoint:
        w, a, i = point
        where = f"{rig.path.name} at omega = {w:g} rad/s, M0 = {a:g} N m on flywheel {i}"
        path = _path(store, w, a, i) if store is not None else None
        if path is not None and path.exists():
            pt = _load(path, where)
            log.info("[%d/%d] %s: loaded from the store", k, total, where)
            return pt
        rec, info = simulate_chain(rig, w, {i: PeriodicDrive.cosine(w, a)}, config, amplitude_Nm=a, backend=backend)
        pt = ChainPoint(w, a, i, rec, info)
        if path is not None:
            _save(path, pt)
        log.info("[%d/%d] %s: steady after %d periods (%.1f s)", k, total, where, info.periods_simulated,
                 info.wall_time_s)
        return pt

    if executor == "dask":
        return _run_dask(rig, points, config, backend, workers, scheduler, store, total)
    if workers == 1:
        return [one(k, p) for k, p in enumerate(points, start=1)]
    from concurrent.futures import ThreadPoolExecutor

    from jointrig.rig.native_callback import native_session

    with native_session(), ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(one, range(1, total + 1), points))


def _run_dask(rig: ChainRig, points, config, backend, workers, scheduler, store, total) -> list[ChainPoint]:
    from dask.distributed import Client, LocalCluster, as_completed

    out: list = [None] * len(points)
    todo = []
    for k, (w, a, i) in enumerate(points):
        path = _path(store, w, a, i) if store is not None else None
        if path is not None and path.exists():
            out[k] = _load(path, f"{rig.path.name} at omega = {w:g} rad/s, M0 = {a:g} N m on flywheel {i}")
        else:
            todo.append(k)
    text = Path(rig.path).read_bytes()
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            cluster = stack.enter_context(LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                       dashboard_address=":0"))
            client = stack.enter_context(Client(cluster))
        else:
            client = stack.enter_context(connect_scheduler(scheduler))
        log.info("dask cluster %s: %d chain point(s)", client.scheduler.address, len(todo))
        futures = {client.submit(_remote_point, Path(rig.path).name, text, rig.digest, rig.plant, points[k], config,
                                 backend, pure=False): k for k in todo}
        for n, fut in enumerate(as_completed(futures), start=1):
            k = futures[fut]
            pt = fut.result()
            if store is not None:
                _save(_path(store, pt.omega_rad_s, pt.amplitude_Nm, pt.flywheel), pt)
            log.info("[%d/%d] point %d done on the cluster", n, len(todo), k + 1)
            out[k] = pt
    return out
