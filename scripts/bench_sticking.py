#!/usr/bin/env python3
"""A joint that sticks most of its cycle: is the diagnosis right, and do its standard errors cover?

    python scripts/bench_sticking.py [--seeds 0-9] [--friction 650] [--noise 0.002] [--json OUT]

Why: while a joint sticks its torque is a reaction, not its law's. The diagnosis balances its two
flywheels' equations as their sum there and the undriven one's own equation only where the joint
slides (``identify.chain.chain_system``'s ``slipping``). The data come from the independent bench
(``tests/bench_sim.py``: scipy, event-driven stick-slip, written as a DAQ writes them, each channel
with its own offset): the paper's joint (J 2 + 2 kg m^2, c 100, k 2000, gamma 200) with dry friction
of ``--friction`` N m, which at 650 N m sticks 57-61% of the cycle at the lower drive level and
10-19% at the higher; the runs of ``tests/test_independent_bench.py`` (25, 40, 55 rad/s at 1500 and
3500 N m; the 40 rad/s runs held out). One row per seed: the verdict, the causes adopted,
chi2/dof, and each parameter's error in its own standard errors (z); then the share of seeds whose
every |z| <= 3 and each parameter's RMS z (1 where the errors are calibrated). Progress goes to
stderr; ``--json OUT`` writes the rows atomically.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from jointrig.files import write_json_atomic

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

#: The bench's law, by the diagnosis's names (the friction added from ``--friction``).
TRUTH = {"J1_kgm2": 2.0, "J2_kgm2": 2.0, "joint1_c_Nms_per_rad": 100.0, "joint1_k_Nm_per_rad": 2000.0,
         "joint1_gamma_Nm_per_rad3": 200.0}


def diagnosed(seed: int, friction_Nm: float, noise: float) -> dict:
    """One file of the bench written and diagnosed; its verdict and every parameter's z."""
    from bench_sim import JOINTS, measure, with_effect
    from test_independent_bench import HOLDOUT, _points

    from jointrig.measured.runs import read_runs
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    truth = dict(TRUTH, joint1_coulomb_torque_Nm=friction_Nm)
    with tempfile.TemporaryDirectory() as tmp:
        path = measure(with_effect(JOINTS["paper"], Fc=friction_Nm), _points("paper"), Path(tmp) / "bench.csv",
                       seed=seed, fs_Hz=2000.0, n_periods=6.5, noise=noise)
        loaded = read_runs(path)
    t0 = time.perf_counter()
    r = run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=HOLDOUT,
                            form="train")
    d = r.diagnosis
    fit = d.final if d.steps else d.nominal
    values = fit.parameters()
    z = {n: (values[n] - t) / fit.std_error(n) if n in values else math.nan for n, t in truth.items()}
    return {"seed": seed, "verdict": r.verdict.verdict, "causes": [s.label for s in d.steps],
            "chi2_per_dof": d.reduced_chi2(fit), "z": z, "seconds": time.perf_counter() - t0,
            "stuck_share": [round(left, 3) for *_, left in d.stuck_joints]}


def seeds_of(text: str) -> list[int]:
    """``0-9`` or ``1,4,7``: the seeds."""
    try:
        if "-" in text:
            a, b = (int(x) for x in text.split("-"))
            return list(range(a, b + 1))
        return [int(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a range like 0-9 or a list like 1,4,7, got {text!r}") from None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument("--seeds", type=seeds_of, default="0-9", help="seeds of the bench's noise and phases (default 0-9)")
    ap.add_argument("--friction", type=float, default=650.0, help="the joint's dry friction (N m; default 650)")
    ap.add_argument("--noise", type=float, default=0.002, help="each channel's noise over its RMS (default 0.002)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path, help="write the rows here (atomically)")
    args = ap.parse_args(argv)
    if not (args.friction > 0 and args.noise >= 0 and args.workers >= 1):
        print("bench_sticking: --friction must be > 0, --noise >= 0, --workers >= 1", file=sys.stderr)
        return 2
    seeds = args.seeds
    from jointrig.rig.runtime import limit_threads

    limit_threads()
    rows = []
    names = list(TRUTH) + ["joint1_coulomb_torque_Nm"]
    short = [n.split("_")[1] if n.startswith("joint1_") else n.split("_")[0] for n in names]
    print(f"{'seed':>5s} {'verdict':12s} {'chi2/dof':>8s} " + " ".join(f"{s:>8s}" for s in short) + "  causes")
    with ProcessPoolExecutor(args.workers) as pool:
        for k, row in enumerate(pool.map(diagnosed, seeds, [args.friction] * len(seeds), [args.noise] * len(seeds)),
                                start=1):
            rows.append(row)
            print(f"{row['seed']:5d} {row['verdict']:12s} {row['chi2_per_dof']:8.3f} "
                  + " ".join(f"{row['z'][n]:8.2f}" for n in names) + "  " + " + ".join(row["causes"]), flush=True)
            print(f"  {k}/{len(seeds)} seeds ({row['seconds']:.0f} s)", file=sys.stderr, flush=True)
    within = sum(all(abs(row["z"][n]) <= 3 for n in names) for row in rows)
    print(f"every |z| <= 3 in {within} of {len(rows)} seeds; explained in "
          f"{sum(r['verdict'] == 'explained' for r in rows)}")
    print("RMS z: " + ", ".join(f"{s} {math.sqrt(sum(r['z'][n] ** 2 for r in rows) / len(rows)):.2f}"
                                for s, n in zip(short, names)))
    if args.json:
        write_json_atomic(args.json, rows)  # strict JSON: a z that is not a number is null
    return 0


if __name__ == "__main__":
    sys.exit(main())
