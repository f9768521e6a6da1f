"""Process-wide settings a command makes once at start-up."""

from __future__ import annotations

__all__ = ["limit_threads"]

_LIMITER = None
_USER_SIZED = None  # the pool kinds the user's environment sized (frozenset), once known

#: The environment variables that size each kind of thread pool when its library loads.
THREAD_VARIABLES = {"blas": ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"), "openmp": ("OMP_NUM_THREADS",)}


def limit_threads(n: int = 1) -> None:
    """Limit the BLAS and OpenMP thread pools to ``n`` threads, in this process and its children,
    wherever the user has not sized them (a pool kind whose variable in
    :data:`THREAD_VARIABLES` is set is left as the user asked). ``jointrig.cli`` calls it before
    it imports a command, so every command runs so; a script or test session that imports numpy
    first calls it too (threadpoolctl then limits the loaded pools).

    Both ways at once: the environment variables, which a library reads when it loads (numpy's
    and scipy's OpenBLAS load after this in a command; a child process inherits them), and
    threadpoolctl for the pools loaded already (a test session, a script that imported numpy;
    only numpy and scipy load them here, so without either nothing is loaded and threadpoolctl,
    20 ms of imports, is not needed).

    The harmonic-balance systems are small (hundreds of rows, tens of columns): a BLAS thread
    pool does not pay for itself on them, and on a busy 2-core machine the default pools
    oversubscribe the cores (measured: the worn-joint diagnosis took 143 s with the default
    OpenBLAS threads and 33 s with one; ``scripts/silverbox.py`` 14.9 s and 24.8 s of CPU with
    the default pools, 14.0 s and 21.3 s with one). Parallel work in jointrig is explicit (forked
    workers, sweep threads, dask), never the BLAS's.
    """
    global _LIMITER, _USER_SIZED
    import os
    import sys

    if _USER_SIZED is None:  # what the environment sized before any call here
        _USER_SIZED = frozenset(api for api, names in THREAD_VARIABLES.items() if any(v in os.environ for v in names))
    limits = {api: n for api in THREAD_VARIABLES if api not in _USER_SIZED}
    for api in limits:
        for v in THREAD_VARIABLES[api]:
            os.environ[v] = str(n)
    if limits and any(m in sys.modules for m in ("numpy", "scipy")):  # a pool may be loaded already
        from threadpoolctl import threadpool_limits

        _LIMITER = threadpool_limits(limits=limits)


class BadArgument(ValueError):
    """A command-line argument that cannot be used (names the option and what was expected)."""


def _probe_writable(option: str, p, what: str) -> None:
    """Refuse ``p`` (an output file's folder or an output folder) unless a file can be created in
    it, or in the nearest existing folder above it (probed by creating and removing one)."""
    import os
    import tempfile

    place = p
    while not place.exists():
        place = place.parent
    if not place.is_dir():
        raise BadArgument(f"{option} {what}: {place} is a file, not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".jointrig-probe.", dir=place)
        os.close(fd)
        os.unlink(tmp)
    except OSError as err:
        raise BadArgument(f"{option} {what}: cannot create a file in {place} ({err.strerror})") from None


def check_output(path, option: str) -> None:
    """Refuse an output path before any work: a directory, or a place where no file can be
    created (probed in the nearest existing folder)."""
    import os
    from pathlib import Path

    if path is None:
        return
    p = Path(path)
    if p.exists() and p.is_dir():
        raise BadArgument(f"{option} {p}: is a folder; expected a file path")
    if p.exists() and not os.access(p, os.W_OK):
        raise BadArgument(f"{option} {p}: exists and is not writable")
    _probe_writable(option, p.parent, str(p))


def check_folder(path, option: str) -> None:
    """Refuse an output folder before any work: a file in its place, or a place where the folder
    cannot be made or written (probed in it, or in the nearest existing folder above it)."""
    from pathlib import Path

    if path is None:
        return
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise BadArgument(f"{option} {p}: is a file; expected a folder")
    _probe_writable(option, p, str(p))


def check_range(value, option: str, *, lo=None, hi=None, lo_open=False, hi_open=False, integer=False) -> None:
    """Refuse a numeric option outside [lo, hi] (open ends where asked), or not finite."""
    import math

    ok = isinstance(value, (int, float)) and math.isfinite(value)
    if integer:
        ok = ok and float(value).is_integer()
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value < hi if hi_open else value <= hi
    if not ok:
        def num(x):
            return str(x) if integer else f"{x:g}"

        lo_s = "" if lo is None else ("(" if lo_open else "[") + num(lo)
        hi_s = "" if hi is None else num(hi) + (")" if hi_open else "]")
        kind = "an integer" if integer else "a number"
        rng = f" in {lo_s or '(-inf'}, {hi_s or 'inf)'}"
        raise BadArgument(f"{option} {value!r}: expected {kind}{rng}")


def check_each(values, option: str, **bounds) -> None:
    """:func:`check_range` on every value of a list option (``--omegas 10 45 90``)."""
    for v in values:
        check_range(v, option, **bounds)


def run_cli(main, name: str, argv=None) -> int:
    """Run a command's ``main``: bad input (a ``ValueError``: the message names the file,
    option or field) exits 2 with the message; a failed simulation (``RuntimeError``) exits 1;
    neither prints a traceback."""
    import sys

    try:
        return main(argv)
    except BrokenPipeError:
        # The reader went away (``jointrig diagnose DATA | head``): not an error of the command.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except ValueError as err:
        print(f"{name}: error: {err}", file=sys.stderr)
        return 2
    except RuntimeError as err:
        print(f"{name}: failed: {err}", file=sys.stderr)
        return 1


def progress_level(quiet: bool) -> int:
    """Logging level of a command's progress lines (on stderr): INFO on a terminal, WARNING under
    ``--quiet`` or when stderr is not a terminal (a log file or a CI job gets the results, not
    the progress), unless ``JOINTRIG_PROGRESS=1`` asks for them."""
    import logging
    import os
    import sys

    if quiet:
        return logging.WARNING
    if os.environ.get("JOINTRIG_PROGRESS") == "1" or sys.stderr.isatty():
        return logging.INFO
    return logging.WARNING


def add_backend_option(parser) -> None:
    """``--backend {auto,native,python}`` (:data:`rig.native_callback.BACKENDS`; default auto:
    the native C callback wherever it can run, bit-identical to the Python one), passed on as
    the simulations' ``backend``, and ``--native``, kept as its old spelling."""
    from .native_callback import BACKENDS

    g = parser.add_mutually_exclusive_group()
    g.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="the joint law's callback: native (C, compiled on first use; the same numbers, 3-5x "
                        "faster), python, or auto: native wherever a C compiler builds it and it knows every "
                        "term, else python (default: %(default)s)")
    g.add_argument("--native", dest="backend", action="store_const", const="native",
                   help="same as --backend native")


def quiet_mujoco() -> None:
    """Keep MuJoCo's own warning text ("Nan, Inf or huge value in QACC", printed to stderr) out of
    a command's results: the rig reads every warning from ``MjData.warning`` and says in words
    what it means (a candidate model that diverges is rejected with that reason). Called by the
    commands that simulate, after their arguments are parsed (``--help`` loads no MuJoCo)."""
    import mujoco

    mujoco.set_mju_user_warning(lambda text: None)
