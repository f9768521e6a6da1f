#!/usr/bin/env python3
"""How many periods the rig simulates to reach steady state, and the error that leaves.

    python3 scripts/bench_steady.py [--json OUT]

For the default sweep, on the paper's joint (c = 100 N m s/rad, damping ratio 1.1) and on a
lightly damped one (c = 5 N m s/rad, damping ratio 0.056), it runs every point four ways:

* ``plain``: from rest, period by period, adaptive steady-state detection at ``settle_tol``
  (1e-9) (``SimulationConfig(accelerate=False)``);
* ``rest``: the same with the default extrapolation jumps (``SimulationConfig.accelerate``);
* ``continuation``: each frequency starts from the previous one's steady state (with jumps);
* ``reference``: plain, from rest, 30 periods beyond where ``plain`` stopped (the transients
  here shrink by r <= 0.84 per period, so what is left of them is 0.84^30 = 5e-3 of what
  ``plain`` left; what remains is the integration floor, ~1e-11 of the swing).

It reports periods simulated, the estimated error bound of each run and the error measured
against the reference (relative angle and rates, relative to their swing), and the largest
relative difference of the harmonic-balance parameters identified from each sweep. Where the
transient bound is tiny (omega = 1 rad/s: 2e-20) the measured error (~9e-10) is the rates'
integration drift over the reference's 30 extra periods, not a transient; so the check is
that every measured error is within settle_tol, and the count within the bound is shown.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from jointrig.identify import identify
from jointrig.rig import SimulationConfig, load_rig
from jointrig.rig.simulate import relative_departure
from jointrig.studies.sweep import DEFAULT_PLAN, simulate_segment
from jointrig.files import write_json_atomic


REFERENCE_EXTRA = 30
VERBOSE = False


def _sweep(rig, config, continuation: bool):
    out = []
    for amp in DEFAULT_PLAN.amplitudes_Nm:
        tasks = [(w, amp, None) for w in DEFAULT_PLAN.omegas_rad_s]
        out.extend(simulate_segment(rig, tasks, config, backend="native", continuation=continuation))
    return out


def bench(rig, label: str) -> dict:
    cfg = SimulationConfig()
    plain = dataclasses.replace(cfg, accelerate=False)
    runs = {"plain": _sweep(rig, plain, False), "rest": _sweep(rig, cfg, False), "continuation": _sweep(rig, cfg, True)}
    # The reference: each point from rest again, plainly, REFERENCE_EXTRA periods beyond where
    # the plain run settled.
    ref = []
    for p in runs["plain"]:
        n = p.settle.periods_simulated + REFERENCE_EXTRA
        c = dataclasses.replace(plain, min_periods=n, max_periods=n + 1, settle_tol=0.5,
                                absolute_angles_periodic=False)
        ref.extend(simulate_segment(rig, [(p.record.omega_rad_s, p.record.drive_amplitude_Nm, None)], c,
                                    backend="native", continuation=False))
    runs["reference"] = ref
    params = {k: identify([p.record for p in v], rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
              for k, v in runs.items()}
    names = [t.name for t in rig.law.terms]
    out = {"model": label, "settle_tol": cfg.settle_tol}
    for k in ("plain", "rest", "continuation"):
        pts = runs[k]
        errs = [relative_departure(p.record, r.record) for p, r in zip(pts, ref)]
        if VERBOSE:
            for p, e in zip(pts, errs):
                print(f"    {k} w {p.record.omega_rad_s:5.1f} M {p.record.drive_amplitude_Nm:6.0f}: {p.settle.periods_simulated:4d} periods, "
                      f"error {e:.2e}, bound {p.settle.error_bound:.2e}, r {p.settle.decay_ratio:.3f}")
        bounds = [p.settle.error_bound for p in pts]
        out[k] = {
            "periods": int(sum(p.settle.periods_simulated for p in pts)),
            "steps": int(sum(round(p.settle.periods_simulated * 2 * np.pi / p.record.omega_rad_s / p.settle.timestep_s)
                             for p in pts)),
            "max_error": max(errs),
            "max_bound": max(bounds),
            "errors_within_settle_tol": all(e <= cfg.settle_tol for e in errs),
            "errors_within_bound": sum(e <= b for e, b in zip(errs, bounds)),
            "n_points": len(errs),
            "max_param_rel_diff": max(abs(params[k].value(n) / params["reference"].value(n) - 1) for n in names),
        }
    out["reference_periods"] = int(sum(p.settle.periods_simulated for p in ref))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", type=Path)
    p.add_argument("--points", action="store_true", help="also print every point")
    args = p.parse_args(argv)
    global VERBOSE
    VERBOSE = args.points
    rig = load_rig()
    light = rig.with_plant(rig.law.with_values(c_Nms_per_rad=5.0))
    results = [bench(rig, "paper joint, c = 100 N m s/rad"), bench(light, "light damping, c = 5 N m s/rad")]
    for r in results:
        print(f"{r['model']} (settle_tol {r['settle_tol']:g}; reference {r['reference_periods']} periods):")
        for k in ("plain", "rest", "continuation"):
            x = r[k]
            print(f"  {k:13s} {x['periods']:5d} periods {x['steps']:8d} steps  error {x['max_error']:.2e} "
                  f"(bound {x['max_bound']:.2e}; within bound at {x['errors_within_bound']}/{x['n_points']} points, all within settle_tol: {x['errors_within_settle_tol']})  parameters vs "
                  f"reference {x['max_param_rel_diff']:.1e}")
    if args.json:
        write_json_atomic(args.json, {"units": "errors relative to each channel's swing", "results": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
