"""jointrig.parallel: fork_map's results in order, errors where they belong, and nothing left
running (or waited for) when the caller stops early; WarmProcess's one call, its errors, and
its end when no call comes."""

from __future__ import annotations

import os
import signal
from pathlib import Path
import pickle
import time

import numpy as np
import pytest

from jointrig.parallel import WarmProcess, fork_map


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


# --------------------------------------------------------------------------------------------
# WarmProcess: a process that imports a heavy stack while the command works, then runs one call


def _where(name):
    import sys

    return os.getpid(), name in sys.modules


def _fail(message):
    raise ValueError(message)


def _unpicklable():
    return lambda: None


def test_a_warm_process_imports_its_modules_there_and_answers_its_call(no_children_left):
    import sys

    module = "tabnanny"  # a standard module nothing here imports
    assert module not in sys.modules
    with WarmProcess([module]) as warm:
        pid, imported = warm.call(_where, module)
    assert pid != os.getpid() and imported
    assert module not in sys.modules


def test_an_error_in_the_call_is_raised_here_as_itself(no_children_left):
    with WarmProcess([]) as warm:
        with pytest.raises(ValueError, match="the disk is full"):
            warm.call(_fail, "the disk is full")
    with WarmProcess(["jointrig.no_such_module"]) as warm:
        with pytest.raises(ModuleNotFoundError, match="no_such_module"):
            warm.call(_where, "x")
    with WarmProcess([]) as warm:
        with pytest.raises(RuntimeError, match="_unpicklable.*could not be sent back"):
            warm.call(_unpicklable)


def test_leaving_without_a_call_stops_the_process_at_once(tmp_path, monkeypatch, no_children_left):
    # A command that stops on bad input must not wait for the writer's imports: the module
    # below would import for 30 s and then leave a file. Killed, it leaves neither.
    (tmp_path / "slow_to_import.py").write_text(
        "import time, pathlib\ntime.sleep(30)\n"
        f"pathlib.Path({str(tmp_path / 'imported')!r}).write_text('done')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with WarmProcess(["slow_to_import"]):
        time.sleep(0.2)
    assert not (tmp_path / "imported").exists()


def test_the_process_ends_when_the_command_dies_without_closing_it():
    # A command killed (or ending by os._exit) never calls close: the process must see its pipe
    # end and exit, not wait for a call for ever.
    import subprocess
    import sys

    code = ("import os\nfrom jointrig.parallel import WarmProcess\nw = WarmProcess([])\n"
            "print(w.pid, flush=True)\nos._exit(0)\n")
    # Only the first line is read: the warm process shares the pipe, so waiting for its end
    # would wait for the process this test is about.
    command = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    pid = int(command.stdout.readline())
    command.wait()
    command.stdout.close()

    def running():
        try:
            with open(f"/proc/{pid}/stat") as f:
                return f.read().rsplit(")", 1)[1].split()[0] != "Z"  # a zombie has ended
        except OSError:
            return False

    deadline = time.monotonic() + 20  # generous: it ends within milliseconds when it works
    while running() and time.monotonic() < deadline:
        time.sleep(0.05)
    left = running()
    if left:
        os.kill(pid, 9)
    assert not left, f"the warm process {pid} outlived its command"


def _record(k: int):
    from jointrig.vocab.records import SteadyStateRecord

    t = np.arange(32) * 2 * np.pi / (16 * 3.0)  # two periods of 16 samples
    return SteadyStateRecord(3.0, t, np.sin(3 * t) * k, np.cos(3 * t), np.sin(3 * t), n_periods=2, source=f"run {k}")


def test_records_from_forked_workers_keep_read_only_arrays(no_children_left):
    # The diagnosis's validation runs come back from forked workers: pickle alone would hand
    # their arrays back writeable, and a record's arrays are read-only (the harmonic-balance
    # columns are cached per record). A chain record likewise.
    from jointrig.identify.chain import ChainRecord

    got = list(fork_map(_record, [1, 2], workers=2))
    here = [_record(1), _record(2)]
    assert [g.source for g in got] == ["run 1", "run 2"]
    for g, h in zip(got, here):
        assert all(np.array_equal(getattr(g, f), getattr(h, f)) for f in ("time_s", "torque_Nm", "phi1_rad", "phi2_rad"))
    for r in got:
        assert not any(a.flags.writeable for a in (r.time_s, r.torque_Nm, r.phi1_rad, r.phi2_rad))
    t = here[0].time_s
    chain = ChainRecord(3.0, t, (np.sin(3 * t), None), (np.cos(3 * t), np.sin(3 * t)), n_periods=2)
    back = pickle.loads(pickle.dumps(chain))
    assert np.array_equal(back.angles_rad[1], chain.angles_rad[1]) and back.torques_Nm[1] is None
    assert not back.time_s.flags.writeable and not back.angles_rad[1].flags.writeable


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_diagnosis_killed_while_it_works_leaves_no_process_behind(tmp_path, sig):
    # issue 38: SIGTERM (what timeout, CI runners and schedulers send) or SIGKILL of a running
    # `jointrig diagnose` left its writer process and fork_map workers alive, blocked on pipes.
    # Each child now ends with its parent (jointrig.parallel.die_with_parent).
    import subprocess
    import sys

    data = Path(__file__).resolve().parent.parent / "examples" / "bench_dry_friction.csv"
    env = {**os.environ, "JOINTRIG_WORKERS": "2"}  # the suite's conftest sets 1: fork the workers here
    command = subprocess.Popen([sys.executable, "-m", "jointrig", "diagnose", str(data), "-q", "--report",
                                str(tmp_path / "r.html")], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)

    def children(pid):
        out = set()
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    with open(f"/proc/{entry}/stat") as f:
                        fields = f.read().rsplit(")", 1)[1].split()
                except OSError:
                    continue
                if int(fields[1]) == pid and fields[0] != "Z":
                    out.add(int(entry))
        return out

    seen = set()
    deadline = time.monotonic() + 60
    while command.poll() is None and len(seen) < 3 and time.monotonic() < deadline:
        seen |= children(command.pid)  # the writer, then two workers scoring the causes
        time.sleep(0.005)
    assert command.poll() is None and len(seen) >= 3, f"no workers seen while the diagnosis ran: {seen}"
    command.send_signal(sig)
    command.wait(timeout=30)

    def alive(pid):
        try:
            with open(f"/proc/{pid}/stat") as f:
                return f.read().rsplit(")", 1)[1].split()[0] != "Z"
        except OSError:
            return False

    deadline = time.monotonic() + 10  # generous: they end within milliseconds
    while any(alive(p) for p in seen) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = [p for p in seen if alive(p)]
    for p in left:
        os.kill(p, signal.SIGKILL)
    assert not left, f"processes {left} outlived the killed diagnosis"
