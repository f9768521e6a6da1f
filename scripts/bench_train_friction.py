#!/usr/bin/env python3
"""Dry friction at each joint of a measured 4-body train in turn: explained, every parameter within 3 SE?

    python scripts/bench_train_friction.py [--case 1:8 2:8 3:4 3:12] [--seed S] [--json OUT]

Why: a joint with dry friction sticks in some runs and slides in others; while it sticks its
torque is a reaction, not its law's. The independent chain bench (``tests/bench_chain_sim.py``:
scipy, event-driven stick-slip, nothing of jointrig) writes the pump train (motor, coupling hub,
gearbox, pump; shafts of 4e5 and 1.2e5 N m/rad beside a progressive coupling of 2.5e4) as a lab's
DAQ does (20 kHz, time in ms, angles in mrad, each encoder on its own zero anywhere in a turn, 40 dB,
its 12 runs),
with ``F`` N m of dry friction at joint ``J`` for each ``--case J:F``. Each file is diagnosed as a
user would: ``jointrig diagnose FILE --columns time=t --json OUT``.

One row per case: the verdict, the causes adopted, the share of the fitted runs in which the joint
may stick (from the notes), and the friction's and every joint stiffness's and inertia's error in
its own standard errors (z). Progress goes to stderr; ``--json OUT`` writes the rows atomically.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from jointrig.files import write_json_atomic

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))


def case_of(text: str) -> tuple[int, float]:
    """``J:F``: dry friction of ``F`` N m at joint ``J`` (1-3)."""
    try:
        j, f = text.split(":")
        joint, friction = int(j), float(f)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected JOINT:FRICTION_Nm like 2:8, got {text!r}") from None
    if joint not in (1, 2, 3) or not friction > 0:
        raise argparse.ArgumentTypeError(f"the joint must be 1, 2 or 3 and the friction > 0 N m, got {text!r}")
    return joint, friction


def diagnosed(folder: Path, joint: int, friction_Nm: float, seed: int) -> dict:
    """One case written by the bench and diagnosed by the command; its verdict and z per parameter."""
    import numpy as np
    from bench_chain_sim import ENCODERS_AT_REST_RAD, PUMP_POINTS, PUMP_TRAIN, daq_file, with_effect

    zeros = np.random.default_rng(seed).uniform(-np.pi, np.pi, 4)  # each encoder's own zero, anywhere in a turn
    try:
        data = daq_file(with_effect(PUMP_TRAIN, joint, Fc=friction_Nm), PUMP_POINTS,
                        folder / f"joint{joint}_{friction_Nm:g}.csv", seed=seed,
                        offsets_rad=tuple(a + z for a, z in zip(ENCODERS_AT_REST_RAD, zeros)))
    except RuntimeError as e:  # the bench's own stick-slip that never settles: no file to diagnose
        return {"joint": joint, "friction_Nm": friction_Nm, "error": f"the bench wrote no file: {e}"}
    out = folder / f"joint{joint}_{friction_Nm:g}.json"
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "jointrig", "diagnose", str(data), "--columns", "time=t", "--json",
                           str(out), "-q"], capture_output=True, text=True)
    if done.returncode != 0:
        return {"joint": joint, "friction_Nm": friction_Nm, "error": "the command failed: " + done.stderr.strip()[-400:]}
    got = json.loads(out.read_text())
    explained = got["verdict"]["verdict"] == "explained"
    fit = got["extended"] if explained else got["nominal"]
    values, errors = fit["parameters"], fit["std_errors"]
    truth = {f"joint{joint}_coulomb_torque_Nm": friction_Nm}
    truth.update({f"joint{j}_k_Nm_per_rad": law.k for j, law in enumerate(PUMP_TRAIN.joints, start=1)})
    truth.update({f"J{i}_kgm2": J for i, J in enumerate(PUMP_TRAIN.J, start=1)})
    z = {n: ((values[n] - t) / errors[n] if n in values and errors.get(n) else float("nan")) for n, t in truth.items()}
    stuck = [n for n in got["notes"] if f"joint {joint} may stick" in n]
    return {"joint": joint, "friction_Nm": friction_Nm, "verdict": got["verdict"]["verdict"],
            "causes": [s["label"] for s in got["extended"]["steps"]] if explained else [],
            "runs_may_stick": len(stuck), "whole_period": sum("not resolved" in n for n in stuck),
            "z": z, "seconds": time.perf_counter() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument("--case", type=case_of, nargs="+", default=[(1, 8.0), (2, 8.0), (3, 4.0), (3, 12.0)],
                    help="JOINT:FRICTION_Nm, one or more (default 1:8 2:8 3:4 3:12)")
    ap.add_argument("--seed", type=int, default=0, help="the bench's noise and phases (default 0)")
    ap.add_argument("--json", type=Path, help="write the rows here (atomically)")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (joint, friction) in enumerate(args.case, start=1):
            print(f"case {k}/{len(args.case)}: {friction:g} N m at joint {joint}", file=sys.stderr, flush=True)
            row = diagnosed(Path(tmp), joint, friction, args.seed)
            rows.append(row)
            if "error" in row:
                print(f"joint {joint} {friction:g} N m: {row['error']}")
                continue
            zs = " ".join(f"{n.split('_')[0]}{'' if n.startswith('J') else ' ' + n.split('_')[1]} {v:+.2f}"
                          for n, v in row["z"].items())
            print(f"joint {joint} {friction:5g} N m: {row['verdict']:12s} {' + '.join(row['causes']) or '-':40s} "
                  f"may stick in {row['runs_may_stick']} runs ({row['whole_period']} the whole period); z: {zs}",
                  flush=True)
    if args.json:
        write_json_atomic(args.json, rows)  # strict JSON: a z that is not a number is null
    return 0


if __name__ == "__main__":
    sys.exit(main())
