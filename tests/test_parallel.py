"""jointrig.parallel.fork_map: results in order, errors where they belong, and nothing left
running (or waited for) when the caller stops early."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from jointrig.parallel import fork_map


def _children() -> set[int]:
    """This process's child processes, zombies included (from /proc: Linux, like CI)."""
    me, out = os.getpid(), set()
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    stat = f.read()
            except OSError:  # gone meanwhile
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == me:
                out.add(int(entry))
    return out


@pytest.fixture
def no_children_left():
    """Whatever children the test process had before (pytest-xdist's own), fork_map leaves none
    of its own behind: every worker it forked has exited and been reaped."""
    before = _children()
    yield
    assert _children() <= before


def test_results_come_in_the_items_order_whatever_order_they_finish_in(no_children_left):
    delays = [0.3, 0.0, 0.2, 0.0, 0.1]
    out = list(fork_map(lambda d: (time.sleep(d), d)[1], delays, workers=2))
    assert out == delays


def test_a_closure_runs_on_the_parents_memory_and_large_results_come_back_whole():
    table = np.arange(10.0)  # not passed: the forked child sees it
    out = list(fork_map(lambda n: np.full(n, table.sum()), [10, 3_000_000], workers=2))  # 24 MB > a pipe
    assert out[0].shape == (10,) and out[1].shape == (3_000_000,)
    assert np.all(out[1] == 45.0)


def test_an_error_in_an_item_is_raised_at_its_turn_as_itself(no_children_left):
    def f(x):
        if x == 2:
            raise ValueError("item two is bad")
        return x

    seen = []
    with pytest.raises(ValueError, match="item two is bad"):
        for r in fork_map(f, [0, 1, 2, 3], workers=2):
            seen.append(r)
    assert seen == [0, 1]


def test_a_worker_that_dies_is_reported_not_waited_for(no_children_left):
    from concurrent.futures.process import BrokenProcessPool

    def f(x):
        if x:
            os.kill(os.getpid(), 9)
        return x

    with pytest.raises(BrokenProcessPool):
        list(fork_map(f, [0, 1], workers=2))


def test_stopping_early_stops_the_speculative_items(tmp_path, no_children_left):
    # Items 1 and 2 would sleep 30 s and then leave a file. The caller stops after item 0: they
    # must be stopped (no file, no child process), not waited for (which would leave the files).
    def f(x):
        if x:
            time.sleep(30)
            (tmp_path / f"done{x}").write_text("finished")
        return x

    for r in fork_map(f, [0, 1, 2], workers=2):
        assert r == 0
        break
    assert not list(tmp_path.iterdir())


def test_one_worker_runs_here():
    pid = os.getpid()
    assert list(fork_map(lambda _: os.getpid(), [0, 1], workers=1)) == [pid, pid]
    assert set(fork_map(lambda _: os.getpid(), [0, 1], workers=2)).isdisjoint({pid})


def test_workers_run_one_blas_thread_whatever_the_parent_runs(no_children_left):
    """The workers are the parallelism: each runs its BLAS pools with one thread, whether the
    parent had limited them already (every command does; the workers then leave the pools
    alone) or runs several (a library user's session; the workers then limit them)."""
    from threadpoolctl import ThreadpoolController, threadpool_limits

    if not ThreadpoolController().lib_controllers:
        pytest.skip("no BLAS/OpenMP pool loaded that threadpoolctl can see")

    def threads(_):
        return max(lib.num_threads for lib in ThreadpoolController().lib_controllers)

    for parent in (1, 2):
        with threadpool_limits(parent):
            assert threads(0) == parent
            assert list(fork_map(threads, range(2), 2)) == [1, 1]
