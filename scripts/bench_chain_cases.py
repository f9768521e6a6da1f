#!/usr/bin/env python3
"""Every catalogued effect at every joint of a 4-inertia train (and bearing drag at every
flywheel): does the chain diagnosis name the right place and cause, and what is the gain?

    python3 scripts/bench_chain_cases.py [--snr-db 40] [--json OUT]

Data come from the tests' independent bench (tests/bench_chain_sim.py: scipy, no jointrig);
the cases and their magnitudes are tests/chain_cases.py. A benchmark, not a unit test: it
takes about 12 s per case on one core (24 cases). Prints one line per case and the summary.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from jointrig.rig.runtime import limit_threads  # noqa: E402

from chain_cases import EFFECTS, run_case  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--snr-db", type=float, default=40.0)
    p.add_argument("--json", type=Path)
    p.add_argument("--only", nargs="*", help="causes to run (default: all)")
    args = p.parse_args()
    limit_threads()
    cases = [(c, j) for c in EFFECTS for j in (1, 2, 3)] + [("bearing_friction", i) for i in (1, 2, 3, 4)]
    if args.only:
        cases = [(c, j) for c, j in cases if c in args.only]
    rows, ok = [], 0
    for cause, place in cases:
        r = run_case(cause, place, snr_db=args.snr_db)
        kind = "flywheel" if cause == "bearing_friction" else "joint"
        right = r.found == f"{cause} at {kind} {place}" and r.first == r.found
        good = right and r.gain >= 5
        ok += good
        mag = f"{r.magnitude[0]} = {r.magnitude[1]:.4g} +- {r.magnitude[2]:.2g}" if r.magnitude else "-"
        print(f"{cause:22s} at {kind} {place}: first {r.first:34s} found {r.found:34s} gain {r.gain:7.3g}  {mag}  "
              f"({r.seconds:.0f} s){'' if good else '  <-- MISSED'}", flush=True)
        rows.append({"cause": cause, "place": f"{kind} {place}", "first": r.first, "found": r.found, "gain": r.gain,
                     "magnitude": list(r.magnitude), "right": right, "seconds": r.seconds})
    print(f"\n{ok}/{len(cases)} cases: right place and cause first with gain >= 5 at {args.snr_db:g} dB")
    if args.json:
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(rows, indent=2) + "\n")
        os.replace(tmp, args.json)
    return 0 if ok == len(cases) else 1


if __name__ == "__main__":
    sys.exit(main())
