#!/usr/bin/env python3
"""Chain rig speed: microseconds per MuJoCo step of the pump train (4 flywheels, 3 joints, 2
drives), bare vs the Python chain callback vs the native one, and the default chain sweep's
wall time (Python, native) with its identification.

    python3 scripts/bench_chain.py [--steps N] [--repeats R] [--json OUT]

Every variant steps models/pump_train.xml with RK4 at 50 us from the same state; the bare step
has no passive callback (the limit of a MuJoCo-backed rig); the others apply the three joint
laws and both drives through rig.chain.chain_callback or rig.native_callback.NativeChain. The
best of R repeats (alternating bare and native) is reported.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import mujoco

from jointrig.identify.chain import identify_chain
from jointrig.vocab.plant import PeriodicDrive
from jointrig.rig.chain import chain_callback, load_chain, simulate_chain
from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN
from jointrig.rig.native_callback import NativeChain
from jointrig.rig.runtime import limit_threads
from jointrig.rig.simulate import _activated, passive_callback


def _time_steps(m, d, n: int) -> float:
    mujoco.mj_resetData(m, d)
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, nstep=n)
    return (time.perf_counter() - t0) / n * 1e6


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=40000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--json", type=Path)
    args = p.parse_args(argv)
    limit_threads()
    rig = load_chain(Path(__file__).resolve().parent.parent / "models" / "pump_train.xml")
    m = rig.model
    m.opt.timestep = 5e-5
    d = mujoco.MjData(m)
    w = 300.0
    drives = {1: PeriodicDrive.cosine(w, 60.0), 4: PeriodicDrive.cosine(w, 20.0)}
    bare, native = float("inf"), float("inf")
    nat = NativeChain(rig, rig.plant, drives)
    for _ in range(args.repeats):
        bare = min(bare, _time_steps(m, d, args.steps))
        with passive_callback(nat.function), _activated(nat, d):
            native = min(native, _time_steps(m, d, args.steps))
    with passive_callback(chain_callback(rig, rig.plant, drives, [], [[], [], []])):
        python = min(_time_steps(m, d, args.steps // 4) for _ in range(args.repeats))
    print(f"pump train, RK4 at 50 us: bare step {bare:.2f} us, native chain callback {native:.2f} us "
          f"({native / bare:.3f}x bare), Python chain callback {python:.2f} us ({python / bare:.1f}x bare)")
    sweeps = {}
    for name in ("python", "native"):
        t0 = time.perf_counter()
        recs = [simulate_chain(rig, w_, {i: PeriodicDrive.cosine(w_, a)}, CHAIN_CONFIG, amplitude_Nm=a, backend=name)[0]
                for w_, a, i in CHAIN_PLAN]
        sweeps[name] = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = identify_chain(recs, rig.plant.spec(), n_harmonics=9)
    ident = time.perf_counter() - t0
    print(f"default chain sweep ({len(CHAIN_PLAN)} runs): {sweeps['python']:.1f} s with the Python callback, "
          f"{sweeps['native']:.1f} s native; identification of {len(res.names)} unknowns from {res.n_rows} "
          f"equations: {ident * 1e3:.0f} ms")
    if args.json:
        args.json.write_text(json.dumps({"bare_us": bare, "native_us": native, "python_us": python,
                                         "native_over_bare": native / bare, "sweep_s": sweeps,
                                         "identification_s": ident,
                                         "config": dataclasses.asdict(CHAIN_CONFIG)}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
