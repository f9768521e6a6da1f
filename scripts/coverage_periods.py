#!/usr/bin/env python3
"""Do the standard errors cover at few periods? A linear train's 95% intervals against the periods.

    python scripts/coverage_periods.py [--periods 4 6 16] [--seeds 400] [--oracle] [--json OUT]

Why: every row of the harmonic balance is weighted by its own variance, estimated from the
spread of its residual over the record's P periods (a harmonic's cosine and sine rows pooled:
2 (P - 1) degrees of freedom; ``identify.chain_diagnose._Problem.row_variance``). The chi-square
and the covariance are corrected for that estimate (``identify.estimates.weighted_chi2``:
``nu / (nu - 2)``, nu those degrees of freedom). This measures what is left: the linear 4-body train of the tests (J 0.45, 0.06, 0.12,
0.35 kg m^2; c 15, 20, 10 N m s/rad; k 4e5, 2.5e4, 1.2e5 N m/rad; body 1 driven at 60 N m, five
frequencies 150-2000 rad/s; exact steady states, ``tests/test_chain.py``) with white noise of
1e-3 of each channel's RMS on every channel (torque and angles), P periods per run, fitted as the
diagnosis fits its nominal model (``_Problem.fit``, the fixed fidelity floor set to 1e-9 so that
only the noise weighs). For every parameter: the share of seeds whose |value - truth| <= 1.96 SE
(95% for calibrated errors), the RMS of z = (value - truth) / SE (1) and its mean (0: no bias).

``--oracle`` also fits each seed with the weights of an independent 64-period record of the same
noise (the variances nearly known): what is left there is not the weights' estimate.

No jointrig simulation is involved (the records are the linear chain's exact response), so a
seed takes about 0.2 s (1 s with ``--oracle``). Progress goes to stderr; ``--json OUT`` writes
the table atomically.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from jointrig.files import write_json_atomic

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

ORACLE_PERIODS = 64


def problem(seed: int, periods: int, harmonics: int):
    """The diagnosis's problem on the linear train (``tests/test_chain_diagnose._linear_problem``:
    its steady states repeated ``periods`` times, 1e-3 of each channel's RMS as noise), balanced at
    harmonics 1..``harmonics`` with the fidelity floor at 1e-9."""
    from jointrig.identify.chain_diagnose import _Problem
    from test_chain_diagnose import _linear_problem

    p, _ = _linear_problem(seed, fidelity=1e-9, periods=periods)
    return _Problem(p.runs, harmonics, p.nu, 1e-9)


def summary(z: dict) -> dict:
    """Per parameter: coverage of the 95% interval, RMS z and mean z over the seeds."""
    out = {}
    for name, values in z.items():
        a = np.asarray(values)
        out[name] = {"covered": float(np.mean(np.abs(a) <= 1.96)), "rms_z": float(np.sqrt(np.mean(a ** 2))),
                     "mean_z": float(np.mean(a)), "n": int(a.size)}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument("--periods", type=int, nargs="+", default=[4, 6, 16], help="periods per run (each >= 3)")
    ap.add_argument("--seeds", type=int, default=400, help="noise draws per case (default 400)")
    ap.add_argument("--oracle", action="store_true", help="also fit with a 64-period record's weights")
    ap.add_argument("--harmonics", type=int, default=20,
                    help="harmonics balanced, 1..20 (default 20; the response is at the first alone)")
    ap.add_argument("--json", type=Path, help="write the table here (atomically)")
    args = ap.parse_args(argv)
    if any(p < 3 for p in args.periods) or args.seeds < 2 or not 1 <= args.harmonics <= 20:
        ap.error("--periods must each be >= 3, --seeds >= 2 and --harmonics 1..20")

    from jointrig.identify.chain import ChainSpec
    from jointrig.vocab.law import Power, Viscous
    from test_chain_diagnose import LINEAR_K, LINEAR_TRUTH as true

    spec = ChainSpec(tuple((Viscous(), Power(1)) for _ in LINEAR_K))
    table = {}
    for P in args.periods:
        kinds = ["least squares", "compensated (reported)"] + (["oracle weights"] if args.oracle else [])
        z = {kind: {n: [] for n in true} for kind in kinds}
        t0 = time.perf_counter()
        for seed in range(args.seeds):
            pr = problem(seed, P, args.harmonics)
            f0, w0 = pr.fit(spec)
            fits = {"least squares": f0, "compensated (reported)": pr.compensated(f0, w0)}
            if args.oracle:
                _, w = problem(1_000_000 + seed, ORACLE_PERIODS, args.harmonics).fit(spec)
                fits["oracle weights"] = pr.solve(spec, w)
            for kind, f in fits.items():
                values = f.parameters()
                for n, v in true.items():
                    z[kind][n].append((values[n] - v) / f.std_error(n))
            if (seed + 1) % 50 == 0:
                print(f"  P={P}: {seed + 1}/{args.seeds} seeds ({time.perf_counter() - t0:.0f} s)", file=sys.stderr,
                      flush=True)
        table[str(P)] = {kind: summary(zk) for kind, zk in z.items()}
        for kind, rows in table[str(P)].items():
            print(f"P = {P} periods ({2 * (P - 1)} degrees of freedom per row variance), harmonics 1..{args.harmonics}, "
                  f"{kind}, {args.seeds} seeds:")
            for name, s in rows.items():
                print(f"  {name:24s} covered {s['covered']:6.1%}  RMS z {s['rms_z']:5.2f}  mean z {s['mean_z']:+.2f}")
    if args.json:
        write_json_atomic(args.json, table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
