#!/usr/bin/env python3
"""How long the diagnosis makes a test engineer wait, on the one pipeline of every bench.

    .venv/bin/python scripts/bench_diagnose.py [--repeat N] [--json OUT] [--coarse-search]

1. ``jointrig make-data`` of the worn joint (models/two_flywheels_worn.xml, 9 runs x 16
   periods at 40 dB) into a temporary folder (not timed);
2. the whole diagnosis as a user runs it: a new ``jointrig diagnose DATA --json --rrd --report``
   process (Python's start and the imports included), on the worn joint's file and on the
   README's example (examples/bench_dry_friction.csv, an independent simulator's file);
3. in this process, the diagnosis of the worn joint's fit runs alone
   (:func:`identify.chain_diagnose.diagnose_chain`) with one worker and with
   ``default_workers()`` forked ones: the scoring of the causes, every round's profile searches;
4. with ``--coarse-search``: that diagnosis again with a coarser profile search (9 grid points
   instead of 17, a 100x looser tolerance), its time and how far it moves the final model.

Best of ``--repeat`` for each. One BLAS thread (as every jointrig command sets).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from jointrig.commands import make_data as make_data_cmd
from jointrig.files import write_json_atomic
from jointrig.identify import causes
from jointrig.identify.chain_diagnose import diagnose_chain, prepare_chain_runs
from jointrig.measured.runs import read_runs
from jointrig.parallel import default_workers
from jointrig.rig import DEFAULT_MODEL
from jointrig.rig.runtime import limit_threads
from jointrig.studies.chain_validate import train_setting
from jointrig.studies.holdout import holdout_of_another_kind

WORN = DEFAULT_MODEL.parent / "two_flywheels_worn.xml"
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "bench_dry_friction.csv"


def best_of(n: int, f) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def command_time(data: Path, out: Path, repeat: int) -> tuple[float, dict]:
    """Best wall time of ``jointrig diagnose`` in a new process, and its JSON."""
    cmd = [sys.executable, "-m", "jointrig", "diagnose", str(data), "-q", "--json", str(out / "d.json"),
           "--rrd", str(out / "d.rrd"), "--report", str(out / "d.html")]
    t = best_of(repeat, lambda: subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL))
    return t, json.loads((out / "d.json").read_text())


def coarse_search(runs, repeat: int) -> dict:
    """The diagnosis with 9 grid points and a 100x looser tolerance: its time and the largest
    relative move of the final model's parameters."""
    fine = diagnose_chain(runs, workers=1).final.as_dict()
    points, tol = causes.PROFILE_GRID_POINTS, causes.PROFILE_XATOL
    causes.PROFILE_GRID_POINTS, causes.PROFILE_XATOL = 9, 100 * tol
    try:
        t = best_of(repeat, lambda: diagnose_chain(runs, workers=1))
        coarse = diagnose_chain(runs, workers=1).final.as_dict()
    finally:
        causes.PROFILE_GRID_POINTS, causes.PROFILE_XATOL = points, tol
    moves = {n: abs(coarse[n] / fine[n] - 1) for n in fine if n in coarse and fine[n]}
    worst = max(moves, key=moves.get)
    return {"scoring_one_process_s": t, "largest_relative_move": moves[worst], "of": worst}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeat", type=int, default=3, help="timings per step; the best is kept (default: %(default)s)")
    p.add_argument("--json", type=Path, help="write the timings as JSON")
    p.add_argument("--coarse-search", action="store_true",
                   help="also diagnose with a coarser profile search (9 grid points, 100x looser tolerance): its "
                        "time and how far the final model moves")
    args = p.parse_args(argv)
    limit_threads()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        data = tmp / "worn.csv"
        if make_data_cmd.main([str(data), "--model", str(WORN), "-q"]) != 0:
            return 1
        t_worn, worn = command_time(data, tmp, args.repeat)
        t_example, example = command_time(EXAMPLE, tmp, args.repeat)
        loaded = read_runs(data)
        held = set(holdout_of_another_kind([train_setting(r) for r in loaded.records]))
        runs = prepare_chain_runs([r for i, r in enumerate(loaded.records) if i not in held], band=20)
        t_one = best_of(args.repeat, lambda: diagnose_chain(runs, workers=1))
        t_all = best_of(args.repeat, lambda: diagnose_chain(runs))
        coarse = coarse_search(runs, args.repeat) if args.coarse_search else None
    report = {
        "what": "best of --repeat; one BLAS thread", "workers": default_workers(),
        "worn_joint_command_s": t_worn, "worn_verdict": worn["verdict"]["verdict"],
        "worn_effects": worn["extended"]["effects"], "worn_gain": worn["validation"]["gain"],
        "example_command_s": t_example, "example_verdict": example["verdict"]["verdict"],
        "worn_diagnosis_one_process_s": t_one, "worn_diagnosis_default_workers_s": t_all,
    }
    if coarse is not None:
        report["coarse_search"] = coarse
    print(f"best of {args.repeat}, {default_workers()} worker(s):")
    print(f"  worn joint (9 runs x 16 periods), jointrig diagnose --json --rrd --report  {t_worn:6.2f} s   verdict "
          f"{worn['verdict']['verdict']}, {' + '.join(worn['extended']['effects']) or 'nothing'}, gain "
          f"{worn['validation']['gain']:.3g}")
    print(f"  README example (examples/bench_dry_friction.csv), the same                {t_example:6.2f} s   "
          f"verdict {example['verdict']['verdict']}")
    print(f"  worn joint's diagnosis (scoring; no validation), one process               {t_one:6.2f} s")
    print(f"  the same in {default_workers()} forked workers{'':47s}{t_all:6.2f} s")
    if coarse is not None:
        print(f"  coarse profile search (9 points, 100x tolerance), one process             "
              f"{coarse['scoring_one_process_s']:6.2f} s   largest move {coarse['largest_relative_move']:.2g} "
              f"({coarse['of']})")
    if args.json:
        write_json_atomic(args.json, report)
    return 0 if np.isfinite(t_worn) else 1


if __name__ == "__main__":
    sys.exit(main())
