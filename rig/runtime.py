"""Process-wide settings a command makes once at start-up."""

from __future__ import annotations

__all__ = ["limit_threads"]

_LIMITER = None


def limit_threads(n: int = 1) -> None:
    """Limit the BLAS and OpenMP thread pools of numpy/scipy to ``n`` threads.

    The harmonic-balance systems are small (hundreds of rows, tens of columns): a BLAS thread
    pool does not pay for itself on them, and on a busy 2-core machine the default pools
    oversubscribe the cores (measured: the worn-joint diagnosis took 143 s with the default
    OpenBLAS threads and 33 s with one). Parallel work in jointrig is explicit (sweep workers,
    dask), never the BLAS's.
    """
    global _LIMITER
    from threadpoolctl import threadpool_limits

    _LIMITER = threadpool_limits(limits=n)
