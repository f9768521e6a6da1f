#!/usr/bin/env python3
"""How long the diagnosis makes a test engineer wait: the worn-joint example, timed in one run.

    .venv/bin/python scripts/bench_diagnose.py [--repeat N] [--json OUT]

1. ``jointrig make-data`` of the worn joint (models/two_flywheels_worn.xml, 9 runs x 16
   periods at 40 dB) into a temporary folder (not timed);
2. the whole diagnosis, end to end: ``jointrig diagnose DATA --json --rrd --report`` in this
   process (reading, fitting, ranking, validating in the rig, writing; the modules imported
   already), and the same as a user runs it, a new ``jointrig diagnose`` process (Python's start
   and the imports of numpy and MuJoCo included; rerun is imported meanwhile by the process
   that writes the recording and the report); the in-process run's parts, from the times its
   progress lines arrive: reading the file, preparing the runs and the nominal fit, scoring the
   causes, validating in the rig (the JSON written), writing the recording and the report;
3. the nominal fit alone (period averaging and the weighted harmonic balance of the nominal
   model on the fit runs);
4. the native simulation of the same 9 runs in the rig (the C callback), the floor a diagnosis
   that validates in the rig cannot go below;
   and, in one process each, the two largest pieces of work the end-to-end time holds: the
   scoring of the causes (``identify.diagnose.diagnose`` with one worker: every round's profile
   searches and fits), the same in ``default_workers()`` processes side by side (what the
   machine's cores give this work at once: they share caches and memory) and the report's
   figures (SVG, drawn one after another);
5. with ``--coarse-search``: the scoring again with a coarser profile search (9 grid points
   instead of 17, a 100x looser tolerance), and how far that moves the final model;
6. with ``--busy``: the whole diagnosis again as a separate ``jointrig diagnose`` process while
   another process keeps one core busy (a spinning Python loop), once with the project's default
   thread settings (BLAS/OpenMP pools limited to one thread by the command, the causes scored in
   ``default_workers()`` forked processes) and once with everything on one thread
   (``JOINTRIG_WORKERS=1 OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1``), and their ratio.

Best of ``--repeat`` for each, then the ratios, and the least end to end the scoring's work
allows: all parts but the scoring, plus the one-process scoring split evenly over the
``default_workers()`` processes (no fork, no pickling, no round waiting for its slowest cause).
One BLAS thread (as every jointrig command sets).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from jointrig.commands import diagnose as diagnose_cmd
from jointrig.commands import make_data as make_data_cmd
from jointrig.identify.causes import NOMINAL
from jointrig.identify.diagnose import _Problem, diagnose, fit, prepare_runs
from jointrig.measured.runs import read_runs
from jointrig.rig import DEFAULT_MODEL, SimulationConfig, load_rig, simulate_steady_state
from jointrig.parallel import default_workers
from jointrig.rig.runtime import limit_threads
from jointrig.files import write_json_atomic
from jointrig.studies.validate import holdout_of_another_kind, run_setting

WORN = DEFAULT_MODEL.parent / "two_flywheels_worn.xml"
POINTS = [(w, a) for w in (25.0, 40.0, 55.0) for a in (1500.0, 2500.0, 3500.0)]


def best_of(n: int, f) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeat", type=int, default=3, help="timings per step; the best is kept (default: %(default)s)")
    p.add_argument("--json", type=Path, help="write the timings as JSON")
    p.add_argument("--coarse-search", action="store_true",
                   help="also score the causes with a coarser profile search (9 grid points, 100x looser "
                        "tolerance): its time and how far the final model moves")
    p.add_argument("--busy", action="store_true",
                   help="also time the diagnosis with another core kept busy, default threads against one thread")
    args = p.parse_args(argv)
    limit_threads()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        data = tmp / "worn.csv"
        if make_data_cmd.main([str(data), "--model", str(WORN)]) != 0:
            return 1
        out = [str(tmp / "worn.json"), str(tmp / "worn.rrd"), str(tmp / "worn.html")]
        argv_d = [str(data), "-q", "--json", out[0], "--rrd", out[1], "--report", out[2]]
        t_diag, parts = end_to_end(argv_d, args.repeat)
        result = json.loads(Path(out[0]).read_text())
        cmd = [sys.executable, "-m", "jointrig", "diagnose", *argv_d]
        t_cmd = best_of(args.repeat, lambda: subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL))

        loaded = read_runs(data)
        # the diagnosis's held-out runs, chosen once (not timed): the nominal fit sees the others
        hold = set(holdout_of_another_kind([run_setting(r) for r in prepare_runs(loaded.records, band=20)]))
        fit_recs = [r for i, r in enumerate(loaded.records) if i not in hold]

        def nominal():
            runs = prepare_runs(fit_recs, band=20)
            fit(_Problem(tuple(runs), "two_dof", 20, 0.5, 2.0 * (runs[0].n_periods - 1)), NOMINAL)

        t_nom = best_of(args.repeat, nominal)
        fit_runs = prepare_runs(fit_recs, band=20)
        t_score = best_of(args.repeat, lambda: diagnose(fit_runs, workers=1))
        t_pair = side_by_side(lambda: diagnose(fit_runs, workers=1), default_workers(), args.repeat)
        coarse = coarse_search(fit_runs, args.repeat) if args.coarse_search else None
        t_fig = figure_time(loaded, args.repeat)
        rig = load_rig(WORN)
        cfg = SimulationConfig(n_periods=16)
        t_sim = best_of(args.repeat, lambda: [simulate_steady_state(rig, w, a, cfg, backend="native") for w, a in POINTS])
        busy = busy_core_timings(argv_d, args.repeat) if args.busy else None
    report = {
        "what": "worn-joint example, 9 runs x 16 periods at 40 dB; best of --repeat; one BLAS thread",
        "diagnosis_end_to_end_s": t_diag, "diagnosis_as_a_command_s": t_cmd,
        "nominal_fit_s": t_nom, "native_simulation_of_the_runs_s": t_sim,
        "scoring_one_process_s": t_score, "report_figures_one_process_s": t_fig,
        "diagnosis_over_native_simulation": t_diag / t_sim, "diagnosis_over_nominal_fit": t_diag / t_nom,
        "parts_s": parts,
        "scoring_side_by_side_s": t_pair, "floor": floor_of(t_diag, parts["scoring"], t_score, t_pair, t_sim),
        "verdict": result["verdict"]["verdict"], "effects": result["extended"]["effects"],
        "gain": result["validation"]["gain"],
    }
    if busy is not None:
        report["busy_core"] = busy
    if coarse is not None:
        report["coarse_search"] = coarse
    print(f"worn joint, 9 runs x 16 periods at 40 dB (best of {args.repeat}):")
    print(f"  diagnosis end to end (--json --rrd --report)  {t_diag:7.2f} s   verdict {result['verdict']['verdict']}, "
          f"{' + '.join(result['extended']['effects']) or 'nothing'} adopted, gain {result['validation']['gain']:.3g}")
    print(f"  the same as a command (a new process)         {t_cmd:7.2f} s   imports and start-up "
          f"{t_cmd - t_diag:.2f} s")
    print(f"  nominal fit alone                             {t_nom:7.2f} s")
    print(f"  scoring of the causes, one process            {t_score:7.2f} s   "
          f"({t_score / t_sim:.2f} x the native simulation)")
    print(f"  {f'the same in {default_workers()} processes side by side, each':<46}{t_pair:7.2f} s   "
          f"({t_pair / t_score:.2f} x alone: what {default_workers()} cores give this work)")
    print(f"  the report's figures, one process             {t_fig:7.2f} s")
    print(f"  native simulation of the 9 runs in the rig    {t_sim:7.2f} s")
    print(f"  diagnosis / native simulation                 {t_diag / t_sim:7.2f} x")
    print(f"  where the end to end goes (the scoring on {default_workers()} processes):")
    for name, value in report["parts_s"].items():
        print(f"    {name.replace('_', ' '):<42}  {value:7.2f} s")
    floor = report["floor"]
    print(f"  all but the scoring                           {floor['outside_the_scoring_s']:7.2f} s   "
          f"({floor['outside_the_scoring_s'] / t_sim:.2f} x the native simulation)")
    print(f"  + the one-process scoring split evenly        {floor['least_end_to_end_s']:7.2f} s   "
          f"({floor['over_native_simulation']:.2f} x: the least this much scoring allows on "
          f"{floor['processes']} cores)")
    print(f"  + the same at the side-by-side speed          {floor['least_at_side_by_side_speed_s']:7.2f} s   "
          f"({floor['at_side_by_side_speed_over_native_simulation']:.2f} x)")
    if coarse is not None:
        worst = ", ".join(f"{k} by {v:.2g}" for k, v in coarse["largest_relative_moves"].items())
        print(f"  {'scoring with the coarse profile search':<46}{coarse['scoring_one_process_s']:7.2f} s   "
              f"({1 - coarse['scoring_one_process_s'] / t_score:.0%} less; the final model moves: {worst})")
    if busy is not None:
        print(f"  with the other core busy, a separate process:  default threads {busy['default_s']:.2f} s, "
              f"one thread {busy['one_thread_s']:.2f} s: {busy['default_over_one_thread']:.2f} x")
    if args.json:
        write_json_atomic(args.json, report)
        print(f"wrote {args.json}")
    return 0


def floor_of(t_diag: float, t_scoring: float, t_score_one: float, t_pair: float, t_sim: float) -> dict:
    """The least end-to-end time the scoring's work allows: everything but the scoring (the end
    to end less its scoring part) plus the scoring's one-process time split evenly over
    :func:`default_workers` processes, with no fork, no pickling and no round that waits for its
    slowest cause; once at the speed of one process alone, once at the speed each of them has
    when all run side by side (``t_pair``: the cores share caches and memory)."""
    n = default_workers()
    outside = t_diag - t_scoring
    least = outside + t_score_one / n
    shared = outside + t_pair / n
    return {"outside_the_scoring_s": outside, "processes": n, "least_end_to_end_s": least,
            "over_native_simulation": least / t_sim, "least_at_side_by_side_speed_s": shared,
            "at_side_by_side_speed_over_native_simulation": shared / t_sim}


def coarse_search(fit_runs, repeat: int, grid_points: int = 9, looser: float = 100.0) -> dict:
    """The scoring in one process with a coarser profile search (``grid_points`` trial values,
    a ``looser`` tolerance: ``identify.causes.PROFILE_GRID_POINTS`` and ``PROFILE_XATOL`` set
    for it, then restored), best of ``repeat``; and the largest relative moves of the final
    model's parameters (the profiled ones included) against the search as it is."""
    from jointrig.identify import causes as C

    def parameters(d):
        f = d.extended
        return {**dict(zip(f.names, map(float, f.values))), **f.effect_parameters()}

    as_is = parameters(diagnose(fit_runs, workers=1))
    saved = C.PROFILE_GRID_POINTS, C.PROFILE_XATOL
    C.PROFILE_GRID_POINTS, C.PROFILE_XATOL = grid_points, saved[1] * looser
    try:
        found = {}
        t = best_of(repeat, lambda: found.update(d=diagnose(fit_runs, workers=1)))
    finally:
        C.PROFILE_GRID_POINTS, C.PROFILE_XATOL = saved
    moved = parameters(found["d"])
    if set(moved) != set(as_is):
        raise RuntimeError(f"the coarse search adopts other causes: {sorted(moved)} against {sorted(as_is)}")
    rel = {k: abs(moved[k] - v) / abs(v) for k, v in as_is.items() if v}
    top = dict(sorted(rel.items(), key=lambda kv: -kv[1])[:3])
    return {"grid_points": grid_points, "xatol_over_range": saved[1] * looser, "scoring_one_process_s": t,
            "largest_relative_moves": top}


def side_by_side(fn, n: int, repeat: int) -> float:
    """``fn()`` in ``n`` forked processes started together: the mean of their times, best of
    ``repeat``. Against ``fn`` alone, what the machine's cores give work like this at once."""
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    best = float("inf")
    for _ in range(repeat):
        gate, times = ctx.Barrier(n), ctx.SimpleQueue()

        def one():
            gate.wait()
            t0 = time.perf_counter()
            fn()
            times.put(time.perf_counter() - t0)

        procs = [ctx.Process(target=one) for _ in range(n)]
        for proc in procs:
            proc.start()
        for proc in procs:
            proc.join()
        if any(proc.exitcode != 0 for proc in procs):
            raise RuntimeError(f"a side-by-side process failed (exit codes {[proc.exitcode for proc in procs]})")
        best = min(best, sum(times.get() for _ in range(n)) / n)
    return best


#: The end to end's parts, each from the progress line that starts it (the first of its kind)
#: to the next part's; the reading from the command's start.
PARTS = (("reading", None), ("preparing_and_the_nominal_fit", "preparing "), ("scoring", "round 1:"),
         ("validating_in_the_rig", "simulating the "), ("writing_the_recording_and_report", "writing "))


def end_to_end(argv_d: list[str], repeat: int) -> tuple[float, dict]:
    """The diagnosis command in this process (its progress lines heard, not printed; the report's
    text to /dev/null), best of ``repeat``: its time and that run's parts (:data:`PARTS`), from
    the times its progress lines arrive. The JSON is written in the validation's part."""
    root = logging.getLogger()
    saved = root.level, root.handlers[:]
    best = None
    for _ in range(repeat):
        seen: dict[str, float] = {}

        class Hear(logging.Handler):
            def emit(self, record: logging.LogRecord) -> None:
                msg = record.getMessage()
                for name, prefix in PARTS[1:]:
                    if msg.startswith(prefix) and name not in seen:
                        seen[name] = time.perf_counter()

        root.handlers[:] = [Hear()]  # the command's own logging setup then leaves them alone
        root.setLevel(logging.INFO)
        try:
            with open(os.devnull, "w") as null, contextlib.redirect_stdout(null):
                t0 = time.perf_counter()
                if diagnose_cmd.main([a for a in argv_d if a != "-q"]) != 0:
                    raise RuntimeError(f"jointrig diagnose {' '.join(argv_d)} failed")
                end = time.perf_counter()
        finally:
            root.setLevel(saved[0])
            root.handlers[:] = saved[1]
        missing = [prefix for name, prefix in PARTS[1:] if name not in seen]
        if missing:
            raise RuntimeError(f"no progress line starting with {missing}: the diagnosis's messages changed")
        starts = [t0] + [seen[name] for name, _ in PARTS[1:]] + [end]
        if best is None or end - t0 < best[0]:
            best = end - t0, {name: starts[k + 1] - starts[k] for k, (name, _) in enumerate(PARTS)}
    return best


def figure_time(loaded, repeat: int) -> float:
    """The report's figures (:func:`present.diagnosis_report.figures`, SVG) drawn in this process
    from the worn joint's report (the diagnosis itself not timed)."""
    from jointrig.present.diagnosis_report import figures
    from jointrig.studies.validate import run_diagnosis

    report = run_diagnosis(loaded.records, run_ids=loaded.run_ids)
    return best_of(repeat, lambda: figures(report))


def busy_core_timings(argv_d: list[str], repeat: int) -> dict:
    """The diagnosis command in a child process while a spinning process keeps one core busy: with
    the environment as it is (the project's own thread settings) and with one thread everywhere."""
    one = {"JOINTRIG_WORKERS": "1", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    base = {k: v for k, v in os.environ.items() if k not in one}
    cmd = [sys.executable, "-m", "jointrig", "diagnose", *argv_d]
    spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.5)
        out = {}
        for label, env in (("default_s", base), ("one_thread_s", {**base, **one})):
            out[label] = best_of(repeat, lambda env=env: subprocess.run(cmd, env=env, check=True,
                                                                        stdout=subprocess.DEVNULL))
    finally:
        spinner.kill()
        spinner.wait()
    out["default_over_one_thread"] = out["default_s"] / out["one_thread_s"]
    return out


if __name__ == "__main__":
    sys.exit(main())
