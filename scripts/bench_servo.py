#!/usr/bin/env python3
"""A position-controlled carriage, as a lab records it: is the diagnosis right on one record from rest?

    python scripts/bench_servo.py [--case incline sticky ...] [--seed S] [--band B] [--json OUT]

Why: a positioning axis is measured once, for a few periods of its reference, from rest, with the
motor force coming out of a position controller; a second record with force pulses on top
validates. Each case of ``tests/bench_servo_sim.py`` (an independent scipy simulator written from
the physics alone: a carriage with viscous drag, Coulomb friction with exact stick-slip events and
a constant offset force, a discrete PD controller at 1 kHz whose output is held over each sample,
an encoder with its own zero, quantised and noisy) is written as ``<case>_id.csv`` (3.5 periods
from rest) and ``<case>_pulses.csv``, and diagnosed as a user would:
``jointrig diagnose <case>_id.csv --validate <case>_pulses.csv --json OUT``.

One row per case: the verdict, the adopted causes, and each parameter against the truth (mass,
drag, dry friction, the constant force against the drive: the offset force F0), as a relative
error and in standard errors. Progress goes to stderr; ``--json OUT`` writes the table atomically.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

#: How the diagnosis's JSON names the truth's parameters on a slide (the start of each name).
NAMES = {"m": "m1_", "c": "guide1_damping_", "Fc": "ground1_coulomb_force_", "F0": "ground1_constant_force_"}


def diagnosed(folder: Path, case: str, seed: int, band: int) -> dict:
    """One case written and diagnosed by the command; its verdict and parameters against the truth."""
    from bench_servo_sim import write_case

    truth = write_case(folder, case, seed=seed)
    out = folder / f"{case}.json"
    cmd = [sys.executable, "-m", "jointrig", "diagnose", str(folder / f"{case}_id.csv"), "--validate",
           str(folder / f"{case}_pulses.csv"), "--band", str(band), "--json", str(out), "-q"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        return {"case": case, "error": done.stderr.strip()[-400:]}
    got = json.loads(out.read_text())
    ext = got["extended"] if got["verdict"]["verdict"] == "explained" else got["nominal"]
    values, errors = ext["parameters"], ext["std_errors"]
    axis = truth["axis"]
    rows = {}
    for key, start in NAMES.items():
        name = next((n for n in values if n.startswith(start)), None)
        if name is not None:
            v, se = values[name], errors.get(name, float("nan"))
            rows[key] = {"value": v, "std_error": se, "true": axis[key],
                         "relative": (v - axis[key]) / axis[key] if axis[key] else float("nan"),
                         "z": (v - axis[key]) / se if se else float("nan")}
    return {"case": case, "verdict": got["verdict"]["verdict"], "causes": ext.get("effects", []),
            "parameters": rows, "reason": got["verdict"]["reason"][:300]}


def main(argv=None) -> int:
    from bench_servo_sim import CASES

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", nargs="+", choices=sorted(CASES), default=list(CASES))
    p.add_argument("--seed", type=int, default=0, help="noise seed of the records (default: %(default)s)")
    p.add_argument("--band", type=int, default=20, help="jointrig diagnose --band (default: %(default)s)")
    p.add_argument("--json", type=Path, help="write the table (JSON, atomically)")
    args = p.parse_args(argv)
    rows = []
    print(f"{'case':15s} {'verdict':11s} " + " ".join(f"{k + ' rel (z)':>17s}" for k in NAMES) + "  causes")
    for k, case in enumerate(args.case, start=1):
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            r = diagnosed(Path(tmp), case, args.seed, args.band)
        rows.append(r)
        if "error" in r:
            print(f"{case:15s} error: {r['error']}")
        else:
            cells = [f"{r['parameters'][n]['relative']:+8.2%} ({r['parameters'][n]['z']:+5.1f})" if n in r["parameters"]
                     else f"{'-':>17s}" for n in NAMES]
            print(f"{case:15s} {r['verdict']:11s} " + " ".join(cells) + "  " + (", ".join(r["causes"]) or "-"),
                  flush=True)
        print(f"[{k}/{len(args.case)}] {case}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    if args.json:
        from jointrig.files import write_json_atomic

        write_json_atomic(args.json, {"seed": args.seed, "band": args.band, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
