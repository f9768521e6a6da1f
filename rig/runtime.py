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


def quiet_mujoco() -> None:
    """Keep MuJoCo's own warning text ("Nan, Inf or huge value in QACC", printed to stderr) out of
    a command's results: the rig reads every warning from ``MjData.warning`` and says in words
    what it means (a candidate model that diverges is rejected with that reason). Called by the
    commands that simulate, after their arguments are parsed (``--help`` loads no MuJoCo)."""
    import mujoco

    mujoco.set_mju_user_warning(lambda text: None)
