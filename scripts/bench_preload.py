#!/usr/bin/env python3
"""Does a preload's standard error cover the truth? The pump train under a mean load, many seeds.

    python scripts/bench_preload.py [--seeds N] [--first S] [--preload NM] [--json OUT]

Why: the diagnosis reads the mean torque a joint carries (its preload) from the joint's law at the
measured mean twist, with a standard error from the fit's covariance and the twist zero's profile
(identify.chain_diagnose.mean_joint_torque). A standard error means what it says when the 95%
interval holds the truth in about 95% of seeds.

Each seed: the independent chain bench (tests/bench_chain_sim.py: scipy, nothing of jointrig)
writes the pump train of tests/test_preload.py (the motor's mean torque carried through every
coupling to the pump's unmeasured load, each encoder on its own zero uniform in +-pi, a torque
cell offset up to 2% of the drive, 40 dB, 20 kHz) with a new noise and zero draw; the diagnosis
reads it (``studies.chain_validate.run_train_diagnosis``). One row per seed: the verdict, the
preload read at the coupling and its standard error, the coupling's k, and whether each 95%
interval holds the truth. Progress goes to stderr; ``--json OUT`` writes the rows atomically.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))


def _row(seed: int, preload: float) -> dict:
    import test_preload
    from test_preload import _diagnosed

    test_preload.PRELOAD_NM = preload
    with tempfile.TemporaryDirectory() as tmp:
        rep = _diagnosed(Path(tmp), seed=seed)
    loads = {j: (q, se) for j, q, se, _ in rep.preloads}
    q, se = loads.get(2, (math.nan, math.nan))
    fit = rep.adopted_fit
    k, k_se = fit.as_dict()["joint2_k_Nm_per_rad"], fit.std_error("joint2_k_Nm_per_rad")
    return {"seed": seed, "verdict": rep.verdict.verdict, "preload_Nm": q, "preload_se_Nm": se,
            "preload_covered": bool(abs(q - preload) <= 1.96 * se), "k_Nm_per_rad": k, "k_se": k_se,
            "k_covered": bool(abs(k - 25000.0) <= 1.96 * k_se)}


def _timed(seed: int, k: int, n: int, preload: float) -> dict:
    """One seed's row, printed, and its time on stderr (seed k of n)."""
    t0 = time.perf_counter()
    r = _row(seed, preload)
    print(f"{seed:5d} {r['verdict']:12s} {r['preload_Nm']:10.2f} ± {r['preload_se_Nm']:5.2f} "
          f"{str(r['preload_covered']):>6s} {r['k_Nm_per_rad']:9.0f} ± {r['k_se']:4.0f} {str(r['k_covered']):>6s}",
          flush=True)
    print(f"[{k}/{n}] seed {seed}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return r


def main(argv=None) -> int:
    from jointrig.commands.options import BadArgument, check_output, refused
    from jointrig.files import write_json_atomic

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=20, help="seeds run (default: %(default)s)")
    p.add_argument("--first", type=int, default=100, help="the first seed (default: %(default)s)")
    p.add_argument("--preload", type=float, default=200.0, help="the motor's mean torque, N m (default: %(default)s)")
    p.add_argument("--json", type=Path, help="write the rows (JSON, atomically)")
    args = p.parse_args(argv)
    def some_seeds():
        if args.seeds < 1:
            raise BadArgument(f"--seeds must be at least 1, got {args.seeds}")

    refused(p, some_seeds, lambda: check_output(args.json, "--json"))
    print(f"{'seed':>5s} {'verdict':12s} {'preload N m':>18s} {'in 95%':>6s} {'k N m/rad':>16s} {'in 95%':>6s}")
    seeds = range(args.first, args.first + args.seeds)
    rows = [_timed(s, k, len(seeds), args.preload) for k, s in enumerate(seeds, start=1)]
    if args.json:
        write_json_atomic(args.json, {"preload_Nm": args.preload, "rows": rows})
    count = {key: sum(bool(r[key]) for r in rows) for key in ("preload_covered", "k_covered")}
    n_right = sum(r["verdict"] == "no_misfit" for r in rows)
    print(f"\nno_misfit: {n_right} of {len(rows)}; preload within its 95% interval: {count['preload_covered']} of "
          f"{len(rows)}; k within its 95% interval: {count['k_covered']} of {len(rows)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
