#!/usr/bin/env python3
"""Rig speed on this machine: microseconds per MuJoCo step, bare vs Python vs native callback,
the default sweep's wall time serial (Python, native) vs native in threads, and the joint
identified from the default sweep's records by harmonic balance, by ``mujoco.sysid`` and by
pysindy (time and parameter errors side by side).

    python3 scripts/bench_rig.py [--steps N] [--repeats R] [--sweep-repeats S] [--json OUT] [--no-peers]

Every variant steps the default two-flywheel model with RK4 at 0.5 ms from the same state;
the bare step has no passive callback (the physical limit of a MuJoCo-backed rig); the
others apply the paper's joint law and the drive through the Python callback of
rig.simulate or the C callback of rig.native_callback. The best of R repeats is reported (2R rounds alternating bare and native)
(the least disturbed by other load).

Identification (simulation excluded, same records for all): harmonic balance (equivalent
form, harmonics 0..9, Je and the law unknown) timed as the best of R repeats; mujoco.sysid
(studies/peers.py: native polynomial stiffness, both inertias given, started 30% / 30% / 100%
away from the truth in k / c / gamma) and pysindy timed once each. Errors are the largest
relative error over k, c and gamma.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from jointrig.identify import identify
from jointrig.vocab.plant import PeriodicDrive
from jointrig.rig import SimulationConfig, load_rig, make_callback, passive_callback
from jointrig.rig.native_callback import NativeLaw
from jointrig.studies.sweep import DEFAULT_PLAN, records_of, run_sweep
from jointrig.files import write_json_atomic


def _time_steps(m, d, n: int, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        mujoco.mj_resetData(m, d)
        t0 = time.perf_counter()
        mujoco.mj_step(m, d, nstep=n)
        best = min(best, time.perf_counter() - t0)
    return best / n * 1e6


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=20000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--sweep-repeats", type=int, default=3, help="best of this many runs of each sweep")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 2, help="threads for the parallel sweep")
    p.add_argument("--json", type=Path)
    p.add_argument("--no-peers", action="store_true", help="skip the mujoco.sysid / pysindy comparison")
    args = p.parse_args(argv)
    rig = load_rig()
    m = rig.model
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = 5e-4
    d = mujoco.MjData(m)
    drive = PeriodicDrive.cosine(40.0, 2500.0)
    # Bare and native alternate, R rounds each, so both see the same machine; best of each.
    native = NativeLaw(rig, rig.law, drive)
    bare_best = native_best = float("inf")
    for _ in range(2 * args.repeats):
        bare_best = min(bare_best, _time_steps(m, d, args.steps, 1))
        native.activate(d)
        try:
            with passive_callback(native.function):
                native_best = min(native_best, _time_steps(m, d, args.steps, 1))
        finally:
            native.deactivate(d)
    out = {"bare_us_per_step": bare_best, "native_us_per_step": native_best}
    errors: list = []
    with passive_callback(make_callback(rig, rig.law, drive, errors)):
        out["python_us_per_step"] = _time_steps(m, d, args.steps, args.repeats)
    out["native_over_bare_step"] = out["native_us_per_step"] / out["bare_us_per_step"]
    out["python_over_bare_step"] = out["python_us_per_step"] / out["bare_us_per_step"]
    # The default sweep, three ways (fresh model: the timing above changed the step).
    sweep_rig = load_rig()
    runs = {}
    for label, kw in (("python_serial", {"backend": "python"}), ("native_serial", {"backend": "native"}),
                      ("native_threads", {"backend": "native", "workers": args.workers})):
        best = float("inf")
        for _ in range(args.sweep_repeats):
            t0 = time.perf_counter()
            runs[label] = records_of(run_sweep(sweep_rig, DEFAULT_PLAN, SimulationConfig(), **kw))
            best = min(best, time.perf_counter() - t0)
        out[f"sweep_{label}_s"] = best
    out["sweep_identical"] = all(np.array_equal(a.phi_rad, b.phi_rad) and np.array_equal(a.phi_rad, c.phi_rad)
                                 for a, b, c in zip(*runs.values()))
    out["sweep_speedup"] = out["sweep_python_serial_s"] / out["sweep_native_threads_s"]
    ident = {label: identify(recs, sweep_rig.law.terms, n_harmonics=9, torque_share=sweep_rig.torque_share)
             for label, recs in runs.items()}
    out["sweep_params_max_rel_diff"] = max(
        abs(ident[label].value(n) / ident["python_serial"].value(n) - 1)
        for label in ident for n in ident[label].names)
    # The same identification three ways, on the same records.
    points = run_sweep(sweep_rig, DEFAULT_PLAN, SimulationConfig(), backend="native", workers=args.workers)
    records = records_of(points)
    truth = sweep_rig.law.as_dict()

    def max_rel(values: dict) -> float:
        return max(abs(values[n] / truth[n] - 1) for n in truth)

    best = float("inf")
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        hb = identify(records, sweep_rig.law.terms, n_harmonics=9, torque_share=sweep_rig.torque_share)
        best = min(best, time.perf_counter() - t0)
    out["hb_identify_s"] = best
    out["hb_max_rel_error"] = max_rel({n: hb.value(n) for n in truth})
    details = {"hb_parameters": {n: hb.value(n) for n in truth}}
    if not args.no_peers:
        from jointrig.studies.peers import sindy_identify, sysid_identify

        start = {"k_Nm_per_rad": 1.3 * truth["k_Nm_per_rad"], "c_Nms_per_rad": 0.7 * truth["c_Nms_per_rad"],
                 "gamma_Nm_per_rad3": 2.0 * truth["gamma_Nm_per_rad3"]}
        sy = sysid_identify(records, sweep_rig.J1_kgm2, sweep_rig.J2_kgm2, start,
                            [p.settle.timestep_s for p in points])
        out["sysid_identify_s"] = sy.wall_time_s
        out["sysid_max_rel_error"] = max_rel(sy.parameters)
        details["sysid_parameters"] = sy.parameters
        out["hb_over_sysid_speedup"] = sy.wall_time_s / out["hb_identify_s"]
        si = sindy_identify(records, sweep_rig.J1_kgm2, sweep_rig.J2_kgm2)
        out["sindy_identify_s"] = si.wall_time_s
        out["sindy_max_rel_error"] = max_rel(si.parameters)
        details["sindy_parameters"] = si.parameters
        out["hb_over_sindy_speedup"] = si.wall_time_s / out["hb_identify_s"]
    for k, v in out.items():
        print(f"{k:24s} {v}" if isinstance(v, bool) else f"{k:24s} {v:.3g}" if abs(v) < 1e-2 else f"{k:24s} {v:8.3f}")
    if args.json:
        write_json_atomic(args.json, {**out, **details, "truth": truth, "units": "us per step, s, relative errors"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
