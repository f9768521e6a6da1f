#!/usr/bin/env python3
"""Do the tests fail when the answer is wrong? Each deliberate fault of issue 18 is put into the
code, the tests that guard that part are run, and the code is restored.

    .venv/bin/python scripts/deliberate_faults.py [--json OUT]

Faults (each a one-line change of the source, applied in place and always undone, also on
Ctrl-C; the script refuses to start on a working tree with changes to those files):

- the errors-in-variables estimator's standard errors x3 and x0.75 (identify/eiv.py);
- the Cramer-Rao bound x2 (identify/eiv.py);
- flywheel 2's angle negated when a measured-runs file is read (measured/runs.py);
- a Jenkins element's slip torque 4% high in the rig's callback (rig/native/jointrig_law.c, the C
  callback the rig steps), and the same in the Python step (jointrig/vocab/law.py, the fallback
  where no C compiler is found, and the C callback's reference); the identifier's array path is
  left right in both.

A fault is caught when at least one of its tests fails. Exit status 1 if any fault is not.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: (name, file, exact text, faulty text, test files)
FAULTS = (
    ("errors-in-variables standard errors x3", "identify/eiv.py",
     "np.sqrt(np.diag(cov)), cov, start", "3 * np.sqrt(np.diag(cov)), cov, start", ("tests/test_eiv.py",)),
    ("errors-in-variables standard errors x0.75", "identify/eiv.py",
     "np.sqrt(np.diag(cov)), cov, start", "0.75 * np.sqrt(np.diag(cov)), cov, start", ("tests/test_eiv.py",)),
    ("Cramer-Rao bound x2", "identify/eiv.py",
     "    return np.linalg.inv(sum(p * f for p, f in zip(periods, F)))",
     "    return 2 * np.linalg.inv(sum(p * f for p, f in zip(periods, F)))", ("tests/test_eiv.py",)),
    ("phi2 negated on read", "measured/runs.py",
     'chans["phi1"], chans["phi2"] = cols["phi1"][sel], cols["phi2"][sel]',
     'chans["phi1"], chans["phi2"] = cols["phi1"][sel], -cols["phi2"][sel]', ("tests/test_runs_file.py",)),
    # The rig steps the C callback (rig/native/jointrig_law.c); the Python step is its fallback
    # and its reference, held to it bit for bit by tests/test_native_callback.py.
    ("Jenkins slip torque 4% high in the rig", "rig/native/jointrig_law.c",
     "tau += P->value[t] * ((phi - play(phi, P->slider[P->ipar1[t]], s)) / s);",
     "tau += 1.04 * P->value[t] * ((phi - play(phi, P->slider[P->ipar1[t]], s)) / s);",
     ("tests/test_effects_rig.py", "tests/test_native_callback.py")),
    ("Jenkins slip torque 4% high in the Python step", "jointrig/vocab/law.py",
     "return (phi - play(phi, state[at], self.slip_rad)) / self.slip_rad",
     "return 1.04 * (phi - play(phi, state[at], self.slip_rad)) / self.slip_rad",
     ("tests/test_effects_rig.py", "tests/test_native_callback.py")),
)


def run_fault(name: str, rel: str, good: str, bad: str, tests: tuple[str, ...]) -> dict:
    path = ROOT / rel
    original = path.read_text(encoding="utf-8")
    if original.count(good) != 1:
        raise SystemExit(f"deliberate_faults: {rel}: expected the text of fault {name!r} exactly once, found "
                         f"{original.count(good)} times; update FAULTS")
    t0 = time.perf_counter()
    try:
        path.write_text(original.replace(good, bad), encoding="utf-8")
        out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "2", "-p", "no:cacheprovider", *tests],
                             cwd=ROOT, capture_output=True, text=True)
    finally:
        path.write_text(original, encoding="utf-8")
    failed = [ln.split(" - ")[0].removeprefix("FAILED ") for ln in out.stdout.splitlines() if ln.startswith("FAILED ")]
    return {"fault": name, "file": rel, "tests": list(tests), "caught": out.returncode != 0 and bool(failed),
            "failed": failed, "seconds": round(time.perf_counter() - t0, 1)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", type=Path, help="write the outcome per fault as JSON")
    args = p.parse_args(argv)
    files = sorted({f[1] for f in FAULTS})
    dirty = subprocess.run(["git", "status", "--porcelain", "--", *files], cwd=ROOT, capture_output=True,
                           text=True).stdout.strip()
    if dirty:
        print(f"deliberate_faults: error: uncommitted changes in {dirty.split()}; commit or stash them first "
              f"(the faults are applied to these files and undone)", file=sys.stderr)
        return 2
    results = []
    for fault in FAULTS:
        r = run_fault(*fault)
        results.append(r)
        caught = f"caught by {len(r['failed'])} test(s): {', '.join(r['failed'][:3])}" if r["caught"] else "NOT CAUGHT"
        print(f"{r['fault']:42s} {caught} ({r['seconds']:.0f} s)", flush=True)
    if args.json:
        from jointrig.files import write_json_atomic

        write_json_atomic(args.json, {"faults": results})
    return 0 if all(r["caught"] for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
