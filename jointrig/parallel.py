"""Independent pieces of work in forked processes: the one place that decides how many, and how.

A fork shares the parent's memory, so the work (closures, a diagnosis problem, a report) is not
pickled; only the results come back. Each worker runs with one BLAS/OpenMP thread: the workers
are the parallelism (forked with the parent's pools of several threads each, a diagnosis ran 3x
slower, measured). The results are the same numbers as in one process, in the items' order.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import pickle
import select
import signal
import sys
import threading
import traceback
from typing import Callable, Iterator, Optional, Sequence

__all__ = ["default_workers", "fork_map"]

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


def _one_thread() -> None:
    from threadpoolctl import threadpool_limits

    global _LIMITS
    _LIMITS = threadpool_limits(1)


def _child(fn: Callable, item, write_fd: int) -> None:
    """In the forked child: ``fn(item)`` pickled down the pipe as ``(True, result)`` or
    ``(False, exception)``, then exit without running the parent's exit handlers."""
    try:
        _one_thread()
        try:
            payload = pickle.dumps((True, fn(item)), protocol=pickle.HIGHEST_PROTOCOL)
        except BaseException as exc:  # sent to the parent, which raises it
            try:
                payload = pickle.dumps((False, exc), protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:
                payload = pickle.dumps((False, RuntimeError("".join(traceback.format_exception(exc)))))
        with os.fdopen(write_fd, "wb") as out:
            out.write(payload)
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(0)


class _Worker:
    """One forked child computing one item; its pickled answer is read as it arrives."""

    def __init__(self, fn: Callable, item, index: int):
        self.index = index
        self.chunks: list[bytes] = []
        read_fd, write_fd = os.pipe()
        sys.stdout.flush()  # else the child inherits unwritten output and writes it again
        sys.stderr.flush()
        self.pid = os.fork()
        if self.pid == 0:
            os.close(read_fd)
            _child(fn, item, write_fd)
        os.close(write_fd)
        self.fd = read_fd

    def read(self) -> bool:
        """Read what is there; True at the end of the answer."""
        chunk = os.read(self.fd, 1 << 20)
        if chunk:
            self.chunks.append(chunk)
            return False
        os.close(self.fd)
        self.fd = -1
        _, status = os.waitpid(self.pid, 0)
        self.pid = 0
        self.status = status
        return True

    def result(self):
        if self.status != 0 or not self.chunks:
            raise RuntimeError(f"fork_map: the worker for item {self.index} died without an answer "
                               f"(exit code {os.waitstatus_to_exitcode(self.status)})")
        ok, value = pickle.loads(b"".join(self.chunks))
        if not ok:
            raise value
        return value

    def kill(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
        if self.pid:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signal.SIGKILL)
            os.waitpid(self.pid, 0)
            self.pid = 0


def fork_map(fn: Callable, items: Sequence, workers: Optional[int] = None) -> Iterator:
    """``fn(item)`` for every item, yielded in order as each arrives: in ``workers`` forked
    processes (default :func:`default_workers`, at most one per item) when more than one, else
    here. ``fn`` may be any callable, a closure included; its results must pickle. An exception
    in ``fn`` is raised here when its item's turn comes.

    Items are started ahead of the one being waited for (up to ``workers`` at a time). When the
    caller stops early (breaks out of the loop), the items still running are stopped, not
    waited for: a search that takes candidates in order up to the first that passes pays no wall
    time for the candidates after it."""
    items = list(items)
    workers = min(default_workers() if workers is None else int(workers), len(items))
    if workers <= 1:
        for item in items:
            yield fn(item)
        return
    running: dict[int, _Worker] = {}
    done: dict[int, _Worker] = {}
    started = 0
    try:
        for turn in range(len(items)):
            while turn not in done:
                while started < len(items) and len(running) < workers:
                    running[started] = _Worker(fn, items[started], started)
                    started += 1
                ready, _, _ = select.select([w.fd for w in running.values()], [], [])
                for w in [w for w in running.values() if w.fd in ready]:
                    if w.read():
                        done[w.index] = running.pop(w.index)
            yield done.pop(turn).result()
    finally:
        for w in running.values():
            w.kill()
