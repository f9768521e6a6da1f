"""Independent pieces of work in forked processes: the one place that decides how many, and how.

A fork shares the parent's memory, so the work (closures, a diagnosis problem, a report) is not
pickled; only the results come back. Each worker runs with one BLAS/OpenMP thread: the workers
are the parallelism (forked with the parent's pools of several threads each, a diagnosis ran 3x
slower, measured). The results are the same numbers as in one process, in the items' order.
"""

from __future__ import annotations

import gc
import importlib
import multiprocessing
import os
import signal
import threading
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterator, Optional, Sequence

__all__ = ["ProcessEnded", "WarmProcess", "default_workers", "die_with_parent", "fork_map"]

#: The function and items of the running :func:`fork_map`, set just before the workers are forked.
_WORK: Optional[tuple] = None
#: The thread-pool limits of a forked worker (kept referenced for the worker's life).
_LIMITS = None


def default_workers() -> int:
    """Processes for independent work: ``JOINTRIG_WORKERS`` if set, else the cores this process
    may use (at most 4; 1 where ``fork`` is not available, or when the process runs other Python
    threads: forking then could copy a lock another thread holds)."""
    env = os.environ.get("JOINTRIG_WORKERS")
    if env:
        try:
            n = int(env)
        except ValueError:
            raise ValueError(f"JOINTRIG_WORKERS must be a whole number >= 1, got {env!r}") from None
        if n < 1:
            raise ValueError(f"JOINTRIG_WORKERS must be a whole number >= 1, got {env!r}")
        return n
    if "fork" not in multiprocessing.get_all_start_methods() or threading.active_count() > 1:
        return 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, 4))


def die_with_parent(parent_pid: int) -> None:
    """Make this forked child end when ``parent_pid``, the process that forked it, ends, however
    it ends: SIGTERM from ``timeout``, a CI runner or a scheduler, or SIGKILL, which run no
    cleanup in the parent. On Linux the kernel sends the child SIGKILL (``prctl``
    ``PR_SET_PDEATHSIG``); elsewhere a daemon thread watches the parent's pid. A parent gone
    before this call ends the child at once."""
    if os.getppid() != parent_pid:
        os._exit(1)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) == 0:  # PR_SET_PDEATHSIG = 1
            if os.getppid() != parent_pid:  # the parent ended between the check and the call
                os._exit(1)
            return
    except (OSError, AttributeError):
        pass

    def watch():
        import time

        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="jointrig-parent-watch", daemon=True).start()


def _worker_start(parent_pid: int) -> None:
    die_with_parent(parent_pid)
    _one_thread()


def _one_thread() -> None:
    """Limit the worker's BLAS/OpenMP pools to one thread, touching only pools that have more:
    setting OpenBLAS's threads in a forked child, even to the one it has, restarts its thread
    server, whose threads then spin for ~60 ms of CPU per worker (measured; every jointrig
    command has limited the parent already, so its workers skip this)."""
    from threadpoolctl import ThreadpoolController

    global _LIMITS
    controller = ThreadpoolController()
    if any(lib.num_threads > 1 for lib in controller.lib_controllers):
        _LIMITS = controller.limit(limits=1)


def _run(i: int):
    fn, items = _WORK
    return fn(items[i])


def _stop(pool: ProcessPoolExecutor) -> None:
    """Stop a pool's workers now, without waiting for the items they are computing."""
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    processes = list((getattr(pool, "_processes", None) or {}).values())  # Python < 3.14; shutdown clears it
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.kill()
        process.join()


def fork_map(fn: Callable, items: Sequence, workers: Optional[int] = None) -> Iterator:
    """``fn(item)`` for every item, yielded in order as each arrives: in ``workers`` forked
    processes (default :func:`default_workers`, at most one per item) when more than one, else
    here. ``fn`` may be any callable, a closure included; its results must pickle. An exception
    in ``fn`` is raised here when its item's turn comes.

    When the caller stops early (breaks out of the loop), the items still running are stopped,
    not waited for: a search that takes candidates in order up to the first that passes pays no
    wall time for the candidates after it."""
    items = list(items)
    workers = min(default_workers() if workers is None else int(workers), len(items))
    if workers <= 1:
        for item in items:
            yield fn(item)
        return
    global _WORK
    _WORK = (fn, items)
    # The parent's objects out of the collector's sight while the workers run: a worker's
    # collections then do not walk (and copy-on-write) the parent's heap (worn-joint diagnosis
    # 3.2 -> 3.1 s, measured with scripts/bench_diagnose.py).
    gc.freeze()
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=_worker_start, initargs=(os.getpid(),))
    finished = False
    try:
        yield from pool.map(_run, range(len(items)))
        finished = True
    finally:
        _WORK = None
        gc.unfreeze()
        if finished:
            pool.shutdown(wait=True)
        else:
            _stop(pool)


class ProcessEnded(RuntimeError):
    """A :class:`WarmProcess` ended (killed, crashed) before it answered its call; ``exitcode``
    is the process's (negative: the signal that ended it)."""

    def __init__(self, message: str, exitcode: Optional[int]):
        super().__init__(message)
        self.exitcode = exitcode


class WarmProcess:
    """A process forked now, while the command is still light, that imports ``modules`` at once
    and then runs the one call it is sent: work at the end of a command that needs a heavy stack
    of its own (the recording's rerun: 0.3 s of imports, and its interpreter teardown) has it
    imported meanwhile, on the core the command's own start leaves idle, instead of after the
    results.

    ``call(fn, *args)`` pickles ``fn`` (a module-level function) and its arguments to the
    process, runs it there and returns its result, or raises its exception here. Leaving the
    ``with`` block without a call (bad input, an error, Ctrl-C) kills the process at once,
    whatever it is importing. The process ignores SIGINT: Ctrl-C stops the command, and the
    process ends when the command does (its pipe closes), so files it is writing are either
    finished (atomically) or not there."""

    def __init__(self, modules: Sequence[str]):
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._process = ctx.Process(target=_warm_main, args=(child, self._conn, tuple(modules), os.getpid()),
                                    name="jointrig-warm")
        self._process.start()
        child.close()

    @property
    def pid(self) -> Optional[int]:
        """The process's id while it runs (None once it has answered or been stopped)."""
        return None if self._process is None else self._process.pid

    def call(self, fn: Callable, /, *args, **kwargs):
        if self._process is None:
            raise RuntimeError("WarmProcess.call: the process has run its call already")
        try:
            self._conn.send((fn, args, kwargs))
            ok, value = self._conn.recv()
        except (EOFError, BrokenPipeError, ConnectionResetError):
            self._process.join()
            code = self._process.exitcode
            self._process = None
            raise ProcessEnded(f"the process that was to run {getattr(fn, '__qualname__', fn)} ended "
                               f"(exit code {code}) without an answer", code) from None
        self._process.join()
        self._process = None
        self._conn.close()
        if ok:
            return value
        raise value

    def close(self) -> None:
        """Stop the process if it has not run its call (idempotent)."""
        if self._process is not None:
            self._process.kill()
            self._process.join()
            self._process = None
            self._conn.close()

    def __enter__(self) -> "WarmProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _warm_main(conn, parents_end, modules: tuple, parent_pid: int) -> None:
    die_with_parent(parent_pid)
    parents_end.close()  # else the pipe would never end here when the command does
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    failed = None
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception as err:  # raised where the call is made, as the call would raise it
            failed = err
            break
    try:
        fn, args, kwargs = conn.recv()
    except EOFError:  # the command ended without a call
        return
    try:
        if failed is not None:
            raise failed
        answer = (True, fn(*args, **kwargs))
    except Exception as err:
        answer = (False, err)
    try:
        conn.send(answer)
    except BrokenPipeError:  # the command is gone
        pass
    except Exception as err:  # a result or an exception that does not pickle: say what it was
        what = answer[1] if not answer[0] else f"a result of type {type(answer[1]).__name__}"
        conn.send((False, RuntimeError(f"{getattr(fn, '__qualname__', fn)} in the warm process: {what!r} "
                                       f"could not be sent back ({type(err).__name__}: {err})")))
