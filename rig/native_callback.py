"""The joint law as a native MuJoCo passive callback (C, loaded through ctypes).

MuJoCo's Python bindings accept a ctypes handle to a C function as a callback and then call
it without the GIL (mujoco/doc/python.rst, "Callbacks"). ``native/jointrig_law.c`` evaluates
the same terms, bearing drag and drive as the Python callback of :mod:`rig.simulate`, with
the same arithmetic in the same order (compiled with ``-ffp-contract=off`` so no fused
multiply-add changes a rounding). Trajectories agree to the rounding of the elementary functions
(exp, tanh, sin, cos), which the interpreter and the C library need not reach through the same
implementation on every machine: 1e-8 of each channel's peak is tested, 2e-10 was seen.

The shared library is compiled on first use with the system C compiler (``cc``, or
``$CC``) against the headers that ship with the ``mujoco`` wheel, and cached under
``$XDG_CACHE_HOME/jointrig`` (default ``~/.cache/jointrig``) by a hash of the source and the
mujoco version; it needs no linking against libmujoco: the callback only reads and writes
mjData, and ``jointrig_run`` (laws with sliders, stepped in C) gets ``mj_step`` by its address
in the libmujoco the mujoco module loaded.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path
from typing import Iterator, Optional, Union

import mujoco
import numpy as np

from jointrig.vocab.law import JointLaw, play
from jointrig.vocab.plant import PeriodicDrive, Plant

__all__ = ["BACKENDS", "NativeLaw", "NativeChain", "NativeBuildError", "choose_native", "library_path", "native_session",
           "session_active"]

SOURCE = Path(__file__).resolve().parent / "native" / "jointrig_law.c"
MAX_TERMS, MAX_KNOTS, MAX_HARM, MAX_SLIDERS = 64, 512, 256, 2048


class NativeBuildError(RuntimeError):
    """The native callback could not be compiled (no C compiler, or it failed)."""


class _Params(ctypes.Structure):
    _fields_ = [
        ("n_terms", ctypes.c_int),
        ("kind", ctypes.c_int * MAX_TERMS),
        ("ipar1", ctypes.c_int * MAX_TERMS),
        ("ipar2", ctypes.c_int * MAX_TERMS),
        ("ipar3", ctypes.c_int * MAX_TERMS),
        ("value", ctypes.c_double * MAX_TERMS),
        ("dpar", ctypes.c_double * MAX_TERMS),
        ("knots", ctypes.c_double * MAX_KNOTS),
        ("n_sliders", ctypes.c_int),
        ("slider", ctypes.c_double * MAX_SLIDERS),
        ("slider_slip", ctypes.c_double * MAX_SLIDERS),
        ("slider_k", ctypes.c_double * MAX_SLIDERS),
        ("q1", ctypes.c_int), ("q2", ctypes.c_int), ("v1", ctypes.c_int), ("v2", ctypes.c_int),
        ("act", ctypes.c_int),
        ("b1", ctypes.c_double), ("b2", ctypes.c_double), ("delay", ctypes.c_double),
        ("omega", ctypes.c_double),
        ("single", ctypes.c_int),
        ("single_a", ctypes.c_double),
        ("n_coeffs", ctypes.c_int),
        ("c_re", ctypes.c_double * MAX_HARM),
        ("c_im", ctypes.c_double * MAX_HARM),
        ("error", ctypes.c_int),
        ("cache_valid", ctypes.c_int),
        ("cache_t", ctypes.c_double),
        ("cache_u", ctypes.c_double),
        ("next", ctypes.c_void_p),
        ("input_n", ctypes.c_int),
        ("input", ctypes.c_void_p),
        ("input_rate", ctypes.c_double),
    ]


def library_path() -> Path:
    """The compiled library (built on first call)."""
    include = Path(mujoco.__file__).resolve().parent / "include"
    key = hashlib.sha256(SOURCE.read_bytes() + mujoco.__version__.encode()).hexdigest()[:16]
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "jointrig"
    try:
        cache.mkdir(parents=True, exist_ok=True)
    except OSError:  # a read-only home: build in the temporary directory instead
        cache = Path(tempfile.gettempdir()) / f"jointrig-{os.getuid()}"
        cache.mkdir(parents=True, exist_ok=True)
    lib = cache / f"jointrig_law-{key}.so"
    if lib.is_file():
        return lib
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise NativeBuildError("no C compiler found (set CC): the native callback needs one to build")
    fd, tmp = tempfile.mkstemp(prefix=".jointrig_law.", suffix=".so", dir=cache)
    os.close(fd)
    cmd = [cc, "-O2", "-ffp-contract=off", "-shared", "-fPIC", f"-I{include}", str(SOURCE), "-o", tmp, "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        os.unlink(tmp)
        raise NativeBuildError(f"compiling {SOURCE.name} failed ({' '.join(cmd)}):\n{proc.stderr}")
    os.replace(tmp, lib)
    return lib


_lib: Optional[ctypes.CDLL] = None


def _load() -> ctypes.CDLL:
    global _lib
    if _lib is None:
        lib = ctypes.CDLL(str(library_path()))
        lib.jointrig_register.argtypes = [ctypes.c_void_p, ctypes.POINTER(_Params)]
        lib.jointrig_register.restype = ctypes.c_int
        lib.jointrig_unregister.argtypes = [ctypes.c_void_p]
        lib.jointrig_unregister.restype = None
        lib.jointrig_run.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int,
                                     ctypes.POINTER(ctypes.c_int), ctypes.c_int, ctypes.POINTER(ctypes.c_double),
                                     ctypes.POINTER(ctypes.c_double)]
        lib.jointrig_run.restype = ctypes.c_int
        _lib = lib
    return _lib


_step_address: Optional[int] = None


def _mj_step_address() -> int:
    """The address of ``mj_step`` in the libmujoco that the mujoco module has loaded (the same
    file, so the same process-wide callbacks), for :func:`jointrig_run` to step in C."""
    global _step_address
    if _step_address is None:
        here = Path(mujoco.__file__).resolve().parent
        libs = sorted(here.glob("libmujoco.so*")) or sorted(here.glob("libmujoco*.dylib"))
        if not libs:
            raise NativeBuildError(f"no libmujoco shared library in {here}: cannot step stateful laws in C")
        _step_address = ctypes.cast(ctypes.CDLL(str(libs[0])).mj_step, ctypes.c_void_p).value
    return _step_address


_unavailable: Optional[str] = None
_checked = False


def unavailable() -> Optional[str]:
    """Why the native callback cannot run on this machine (no C compiler, a failed build, a
    library that does not load), or None when it can; checked once per process."""
    global _unavailable, _checked
    if not _checked:
        try:
            _load()
        except (NativeBuildError, OSError) as e:
            _unavailable = str(e).splitlines()[0]
        _checked = True
    return _unavailable


def unsupported(laws) -> Optional[str]:
    """Why the native callback cannot simulate these joint laws (or plants): the machine has
    none (:func:`unavailable`), or a law has a term without a C case or more terms, knots or
    sliders than a parameter block holds; None when it can."""
    why = unavailable()
    if why is not None:
        return why
    for law in laws:
        try:
            _pack_law(_Params(), law.law if isinstance(law, Plant) else law)
        except ValueError as e:
            return str(e)
    return None


#: How a simulation evaluates the joint law, as every simulation's ``backend`` argument and the
#: commands' ``--backend`` spell it: ``"native"`` the C callback, ``"python"`` the Python one,
#: ``"auto"`` (the default) native wherever it can run (:func:`choose_native`). The numbers agree
#: to 1e-8 of each channel's peak, far below any noise (tests/test_native_callback.py), so the
#: backend is not part of a run's :class:`rig.simulate.SimulationConfig` (nor of a sweep store's key).
BACKENDS = ("auto", "native", "python")


def choose_native(backend: str, laws, allowed: tuple[str, ...] = BACKENDS) -> bool:
    """Whether a simulation with ``backend`` runs the native callback: ``"python"`` no; any
    other name but ``"auto"`` (``"native"``, the two-flywheel rig's ``"native-stepped"``) yes;
    ``"auto"`` wherever it can simulate ``laws`` (:func:`unsupported`), else the Python callback.

    Raises:
      ValueError: ``backend`` is not one of ``allowed``.
    """
    if backend not in allowed:
        raise ValueError(f"backend must be one of {allowed}, got {backend!r}")
    if backend == "auto":
        return unsupported(laws) is None
    return backend != "python"


_registry_lock = threading.Lock()
_session_lock = threading.Lock()
_session_active = False
_session_count = 0
_session_installed = None


def session_active() -> bool:
    """True while :func:`native_session` has the native callback installed."""
    return _session_active


@contextlib.contextmanager
def native_session() -> Iterator[None]:
    """Install the native callback once for several simulations, in this thread or others.

    Each simulation registers its own parameter block under its own ``MjData`` (see
    :meth:`NativeLaw.activate`), so threads stepping different ``MjData`` share the one
    installed callback safely; MuJoCo's stepping releases the GIL, so they run in parallel.
    Sessions nest and overlap across threads (a count): the first installs the callback, the
    last to leave restores the previous one.
    """
    global _session_active, _session_count, _session_installed
    from .callback import passive_callback

    with _session_lock:
        if _session_count == 0:
            installed = passive_callback(_load().jointrig_passive)
            installed.__enter__()
            _session_installed = installed
            _session_active = True
        _session_count += 1
    try:
        yield
    finally:
        with _session_lock:
            _session_count -= 1
            if _session_count == 0:
                _session_active = False
                installed, _session_installed = _session_installed, None
                installed.__exit__(None, None, None)


class NativeLaw:
    """Parameters of one simulation for the native callback, and its function pointer.

    ``activate(d)`` registers the parameter block under that ``MjData`` (the callback looks
    its block up by ``d``), ``deactivate(d)`` withdraws it.
    """

    def __init__(self, rig, plant: Union[Plant, JointLaw], drive: PeriodicDrive):
        plant = Plant.of(plant)
        p = _Params()
        law = plant.law
        _pack_law(p, law)
        p.q1, p.q2 = rig.qpos_adr
        p.v1, p.v2 = rig.dof_adr
        p.act = rig.actuator_id
        p.b1, p.b2 = plant.bearing1_damping_Nms_per_rad, plant.bearing2_damping_Nms_per_rad
        p.delay = plant.drive_delay_s
        _pack_drive(p, drive)
        self.params = p
        self.lib = _load()
        self.function = self.lib.jointrig_passive

    def activate(self, d: mujoco.MjData) -> None:
        with _registry_lock:
            if self.lib.jointrig_register(d._address, ctypes.byref(self.params)) < 0:
                raise RuntimeError("more than 256 simulations at once share the native callback")

    def deactivate(self, d: mujoco.MjData) -> None:
        with _registry_lock:
            self.lib.jointrig_unregister(d._address)

    def commit(self, phi_rad: float) -> None:
        """Advance the sliders to the accepted angle (after a step), as the Python path."""
        p = self.params
        for j in range(p.n_sliders):
            p.slider[j] = play(phi_rad, p.slider[j], p.slider_slip[j])

    def run(self, m: mujoco.MjModel, d: mujoco.MjData, n: int, k: int, idx: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
        """``n`` samples of ``k`` steps each, stepped in C with the sliders committed after
        every step (the GIL released): the sensors ``idx`` after each sample's first step and
        the time before it, as the Python stepping loop of :mod:`rig.simulate` records them."""
        idx = np.ascontiguousarray(idx, dtype=np.intc)
        buf = np.empty((n, idx.size))
        tbuf = np.empty(n)
        dbl = ctypes.POINTER(ctypes.c_double)
        rc = self.lib.jointrig_run(_mj_step_address(), m._address, d._address, n, k,
                                   idx.ctypes.data_as(ctypes.POINTER(ctypes.c_int)), idx.size,
                                   buf.ctypes.data_as(dbl), tbuf.ctypes.data_as(dbl))
        if rc < 0:
            raise RuntimeError("jointrig_run: this MjData has no registered parameter block (activate it first)")
        return buf, tbuf

    @property
    def error(self) -> bool:
        return bool(self.params.error)


class NativeOscillator(NativeLaw):
    """The native callback of a one-degree-of-freedom oscillator (:mod:`rig.oscillator`): the
    law between the hinge and the ground and a sampled input ``u(t - delay)`` on the fine grid
    of an :class:`identify.signals.BandlimitedInput`, added to the hinge's passive force as
    ``u - tau``, operation for operation as the Python callback (the same numbers)."""

    def __init__(self, law: JointLaw, qpos_adr: int, dof_adr: int, grid: np.ndarray, grid_rate_Hz: float,
                 delay_s: float = 0.0):
        if any(t.stateful for t in law.terms):
            raise ValueError("the oscillator's native callback takes laws without sliders (Jenkins, Iwan)")
        p = _Params()
        _pack_law(p, law)
        p.q1, p.q2, p.v1, p.v2, p.act = int(qpos_adr), -1, int(dof_adr), -1, -1
        p.delay = float(delay_s)
        self._grid = np.ascontiguousarray(grid, dtype=float)  # the block points into it: kept alive here
        p.input_n = self._grid.size
        p.input = self._grid.ctypes.data
        p.input_rate = float(grid_rate_Hz)
        self.params = p
        self.lib = _load()
        self.function = self.lib.jointrig_passive


def _pack_law(p: _Params, law: JointLaw) -> None:
    """A joint law's terms, knots and sliders into a parameter block (each term says how:
    ``Term.native``)."""
    if len(law.terms) > MAX_TERMS:
        raise ValueError(f"the native callback takes at most {MAX_TERMS} terms, the law has {len(law.terms)}")
    knots: list[float] = []
    sliders = 0
    for i, (t, v) in enumerate(zip(law.terms, law.values)):
        spec = t.native()
        if spec is None:
            raise ValueError(f"the native callback has no term {type(t).__name__}")
        ints = list(spec.ints)
        if spec.knots:
            ints[1] = len(knots)
            knots.extend(spec.knots)
        if spec.sliders:
            if sliders + len(spec.sliders) > MAX_SLIDERS:
                raise ValueError(f"the native callback takes at most {MAX_SLIDERS} sliders in all")
            ints[0], ints[2] = sliders, len(spec.sliders)
            for j, (slip, k) in enumerate(spec.sliders):
                p.slider_slip[sliders + j], p.slider_k[sliders + j] = slip, k
            sliders += len(spec.sliders)
        p.kind[i], p.value[i], p.dpar[i] = spec.kind, v, spec.dpar
        p.ipar1[i], p.ipar2[i], p.ipar3[i] = ints
    p.n_sliders = sliders
    if len(knots) > MAX_KNOTS:
        raise ValueError(f"the native callback takes at most {MAX_KNOTS} knots in all, the law has {len(knots)}")
    for i, k in enumerate(knots):
        p.knots[i] = k
    p.n_terms = len(law.terms)


def _pack_drive(p: _Params, drive: PeriodicDrive) -> None:
    p.omega = drive.omega_rad_s
    if drive.single_cosine_Nm is not None:  # the same fast path as PeriodicDrive.evaluator
        p.single, p.single_a = 1, drive.single_cosine_Nm
    else:
        coeffs = list(drive.coeffs)[: max((n for n, c in enumerate(drive.coeffs) if c != 0), default=0) + 1]
        if len(coeffs) > MAX_HARM:
            raise ValueError(f"the native callback takes harmonics up to {MAX_HARM - 1}")
        p.n_coeffs = len(coeffs)
        for n, c in enumerate(coeffs):
            p.c_re[n], p.c_im[n] = c.real, c.imag


class NativeChain:
    """The native callback's parameters for a chain (rig/chain.py): one block per joint (its law
    between its two flywheels, the drag of its left flywheel, and of the last flywheel for the
    last joint; a single body's drag in a block of its own), one per body's law to ground (its
    angle alone, ``q2 = -1``), then one block per drive, linked in that order: every generalised
    force gets its terms in the order the Python chain callback adds them, so the same bits.
    Sliders (Jenkins, Iwan) at joints and to ground are committed in C after every step by
    :meth:`run`."""

    def __init__(self, rig, plant, drives: dict):
        N = rig.n_flywheels
        blocks = []
        for j, law in enumerate(plant.laws):
            p = _Params()
            _pack_law(p, law)
            p.q1, p.q2 = rig.qpos_adr[j], rig.qpos_adr[j + 1]
            p.v1, p.v2 = rig.dof_adr[j], rig.dof_adr[j + 1]
            p.act = -1
            p.b1 = plant.bearings_Nms_per_rad[j]
            p.b2 = plant.bearings_Nms_per_rad[N - 1] if j == N - 2 else 0.0
            blocks.append(p)
        if N == 1 and plant.bearings_Nms_per_rad[0]:  # a single body: no joint block carries its drag
            p = _Params()
            p.q1, p.q2, p.v1, p.v2, p.act = rig.qpos_adr[0], -1, rig.dof_adr[0], -1, -1
            p.b1 = plant.bearings_Nms_per_rad[0]
            blocks.append(p)
        for i, g in enumerate(plant.grounds):  # after every joint and drag, as the Python callback
            if g is not None:
                p = _Params()
                _pack_law(p, g)
                p.q1, p.q2, p.v1, p.v2, p.act = rig.qpos_adr[i], -1, rig.dof_adr[i], -1, -1
                blocks.append(p)
        acts = {i: a for i, a, _ in rig.drives}
        for i, drive in sorted(drives.items()):
            p = _Params()
            p.act = acts[i]
            _pack_drive(p, drive)
            blocks.append(p)
        for a, b in zip(blocks, blocks[1:]):
            a.next = ctypes.cast(ctypes.byref(b), ctypes.c_void_p).value
        self.blocks = blocks  # kept alive: the C side holds their addresses
        self.lib = _load()
        self.function = self.lib.jointrig_passive

    def activate(self, d: mujoco.MjData) -> None:
        with _registry_lock:
            if self.lib.jointrig_register(d._address, ctypes.byref(self.blocks[0])) < 0:
                raise RuntimeError("more than 256 simulations at once share the native callback")

    def deactivate(self, d: mujoco.MjData) -> None:
        with _registry_lock:
            self.lib.jointrig_unregister(d._address)

    def run(self, m: mujoco.MjModel, d: mujoco.MjData, n: int, k: int, idx: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
        """``n`` samples of ``k`` steps each, stepped in C with every block's sliders committed
        after every step (:meth:`NativeLaw.run`; the blocks are linked from the first)."""
        return NativeLaw.run(self, m, d, n, k, idx)

    @property
    def error(self) -> bool:
        return any(p.error for p in self.blocks)
