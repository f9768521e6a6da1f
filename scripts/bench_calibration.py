#!/usr/bin/env python3
"""Is a right model's chi-square per degree of freedom about 1 at every noise level, on files of
the independent simulators?

    python scripts/bench_calibration.py [--quick] [--db 20 40 60 80] [--bench flywheels train slide]
                                        [--seed S] [--train-friction-Nm F] [--flywheel-friction-Nm F]
                                        [--encoder-zeros] [--json OUT]

Why: the diagnosis weighs the harmonic balance's rows by the noise plus a *measured* model
fidelity (the balance's misfit on the fitted model's noise-free replay in the rig). If that is
right, a right model reads chi2/dof near 1 (0.7-1.5 here) whatever the sensor, and the fitted
size of an effect lies within a few standard errors of the truth. This runs the scipy benches
of tests/ (nothing of jointrig simulates the data) and diagnoses their DAQ-style files:

- ``flywheels``: two flywheels with the paper's joint (tests/bench_sim.py), 6 runs (3
  frequencies x 1500 and 3500 N m, the middle frequency held out), without an effect and with
  dry friction (``--flywheel-friction-Nm``, default 20 N m); diagnosed in-process
  (``studies.chain_validate.run_train_diagnosis``). ``--encoder-zeros``: each encoder on its own
  zero, uniform in +-pi (drawn from the seed), as two encoders mounted by hand read.
- ``train``: the 4-body pump train (tests/bench_chain_sim.py, its 12 PUMP_POINTS, 20 kHz, time
  in ms, encoders not zeroed), without an effect and with dry friction at joint 2
  (``--train-friction-Nm``, default 8 N m: it sticks in most runs); ``jointrig diagnose FILE
  --columns time=t --json OUT -q``.
- ``slide``: the carriage on a guide (tests/bench_slide_sim.py, 12 kg, 40 N s/m), 9 runs (3
  frequencies x 80, 150, 300 N), without dry friction (Fc = 0) and with its 25 N;
  ``jointrig diagnose FILE --json OUT -q``.

A noise level L dB is white noise of standard deviation 10^(-L/20) times each channel's RMS
(the ``snr_db`` of the chain and slide benches; bench_sim's ``noise`` is that fraction): 20 dB
is 10%, 40 dB 1%, 60 dB 0.1%, 80 dB 0.01%. ``--quick`` runs 40 and 80 dB only.

One row per case: bench, effect, level, verdict, the causes the extension adopted, the final
(extended) model's chi2/dof, and the effect's size: fitted, and (fitted - true) / SE, and the held-out gain. "worst"
is the largest |z| over the other parameters with a known truth (inertias or mass, damping,
stiffness). Progress goes to stderr; ``--json OUT`` writes the table atomically.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from jointrig.files import write_json_atomic
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

BENCHES = ("flywheels", "train", "slide")
FLYWHEEL_FRICTION_Nm = 20.0
SLIDE_FRICTION_N = 25.0
SLIDE_POINTS = [(w, F) for w in (6.283, 12.566, 25.13) for F in (80.0, 150.0, 300.0)]

#: the truths of the nominal parameters, as the diagnosis names them
FLYWHEEL_TRUTH = {"J1_kgm2": 2.0, "J2_kgm2": 2.0, "joint1_c_Nms_per_rad": 100.0, "joint1_k_Nm_per_rad": 2000.0,
                  "joint1_gamma_Nm_per_rad3": 200.0}
SLIDE_TRUTH = {"m1_kg": 12.0, "guide1_damping_Ns_per_m": 40.0}


def noise_fraction(db: float) -> float:
    """Noise standard deviation relative to each channel's RMS at an SNR of ``db`` dB."""
    return 10.0 ** (-db / 20.0)


def _train_truth() -> dict:
    from bench_chain_sim import PUMP_TRAIN

    out = {f"J{i + 1}_kgm2": j for i, j in enumerate(PUMP_TRAIN.J)}
    for i, jt in enumerate(PUMP_TRAIN.joints, 1):
        out[f"joint{i}_c_Nms_per_rad"] = jt.c
        out[f"joint{i}_k_Nm_per_rad"] = jt.k
        if jt.gamma:
            out[f"joint{i}_gamma_Nm_per_rad3"] = jt.gamma
    return out




def _diagnose_cli(path: Path, out: Path, *extra: str) -> dict:
    """``jointrig diagnose`` on a file, its JSON document as: verdict, steps, chi2/dof, parameters."""
    exe = ROOT / ".venv" / "bin" / "jointrig"
    cmd = [str(exe), "diagnose", str(path), *extra, "--json", str(out), "-q"]
    env = dict(os.environ, JOINTRIG_WORKERS=os.environ.get("JOINTRIG_WORKERS", "1"))
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if p.returncode != 0 or not out.exists():
        raise RuntimeError(f"jointrig diagnose exited {p.returncode}: {(p.stderr or p.stdout).strip()[-400:]}")
    j = json.loads(out.read_text())
    ext = j["extended"]
    fid = j.get("fidelity") or {}
    return {"verdict": j["verdict"]["verdict"], "steps": [s["label"] for s in ext.get("steps", [])],
            "chi2_per_dof": ext["chi2_per_dof"], "nominal_chi2_per_dof": j["nominal"]["chi2_per_dof"],
            "parameters": ext["parameters"], "std_errors": ext["std_errors"],
            "gain": (j.get("validation") or {}).get("gain"), "fidelity": fid.get("relative_misfit"), "fidelity_how": fid.get("how"),
            "fidelity_statement": fid.get("statement"),
            "fidelity_notes": [n for n in j.get("notes", []) if "fidelity" in n]}


def _flywheels(db: float, friction_Nm: float, seed: int, tmp: Path, encoder_zeros: bool = False) -> dict:
    from bench_sim import JOINTS, POINTS, measure, with_effect
    from jointrig.measured.runs import read_runs
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    points = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1]
    joint = with_effect(JOINTS["paper"], Fc=friction_Nm)
    zero1, zero2 = np.random.default_rng([seed, 2]).uniform(-math.pi, math.pi, 2) if encoder_zeros else (0.0, 0.0)
    path = measure(joint, points, tmp / "b.csv", seed=seed, fs_Hz=2000.0, n_periods=6.5, noise=noise_fraction(db),
                   transform=lambda t, T, p1, p2: (t, T, p1 + zero1, p2 + zero2))
    loaded = read_runs(path)
    r = run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=(2, 3))
    d = r.diagnosis
    params = d.final.parameters()
    return {"verdict": r.verdict.verdict, "steps": [s.label for s in d.steps],
            "chi2_per_dof": float(d.reduced_chi2(d.final)), "nominal_chi2_per_dof": float(d.reduced_chi2(d.nominal)),
            "parameters": {k: float(v) for k, v in params.items()},
            "std_errors": {k: float(d.final.std_error(k)) for k in params},
            "gain": r.validation.gain if r.validation is not None else None,
            "fidelity": getattr(d.fidelity, "relative", None),
            "fidelity_how": "measured" if hasattr(d.fidelity, "relative") else "fixed"}


def _train(db: float, friction_Nm: float, seed: int, tmp: Path) -> dict:
    from bench_chain_sim import PUMP_POINTS, PUMP_TRAIN, daq_file, with_effect

    train = with_effect(PUMP_TRAIN, 2, Fc=friction_Nm) if friction_Nm else PUMP_TRAIN
    path = daq_file(train, PUMP_POINTS, tmp / "train.csv", snr_db=db, seed=seed)
    return _diagnose_cli(path, tmp / "d.json", "--columns", "time=t")


def _slide(db: float, friction: bool, seed: int, tmp: Path) -> dict:
    from bench_slide_sim import Carriage, daq_runs

    car = Carriage(Fc=SLIDE_FRICTION_N if friction else 0.0)
    path = daq_runs(car, SLIDE_POINTS, tmp / "axis.csv", snr_db=db, seed=seed)
    return _diagnose_cli(path, tmp / "d.json")


def cases(benches, levels, train_friction_Nm: float, flywheel_friction_Nm: float = FLYWHEEL_FRICTION_Nm,
          encoder_zeros: bool = False):
    """(bench, effect label, level dB, effect parameter, its truth, other truths, runner)."""
    for bench in benches:
        for db in levels:
            if bench == "flywheels":
                for f in (0.0, flywheel_friction_Nm):
                    yield (bench, f"Fc {f:g} N m" if f else "none", db, "joint1_coulomb_torque_Nm", f, FLYWHEEL_TRUTH,
                           lambda s, t, db=db, f=f: _flywheels(db, f, s, t, encoder_zeros))
            elif bench == "train":
                for f in (0.0, train_friction_Nm):
                    yield (bench, f"Fc {f:g} N m at joint 2" if f else "none", db, "joint2_coulomb_torque_Nm", f,
                           _train_truth(), lambda s, t, db=db, f=f: _train(db, f, s, t))
            else:
                for fr in (False, True):
                    yield (bench, f"Fc {SLIDE_FRICTION_N:g} N" if fr else "none", db, "ground1_coulomb_force_N",
                           SLIDE_FRICTION_N if fr else 0.0, SLIDE_TRUTH,
                           lambda s, t, db=db, fr=fr: _slide(db, fr, s, t))


def row_of(bench, effect, db, name, truth, others, res) -> dict:
    row = {"bench": bench, "effect": effect, "db": db, "noise_fraction": noise_fraction(db), **res}
    if "error" in res:
        return row
    v, se = res["parameters"].get(name), res["std_errors"].get(name)
    row["effect_parameter"] = name
    row["effect_true"] = truth
    row["effect_fitted"] = v
    row["effect_std_error"] = se
    row["effect_z"] = (v - truth) / se if v is not None and se else None
    zs = {k: (res["parameters"][k] - t) / res["std_errors"][k] for k, t in others.items()
          if k in res["parameters"] and res["std_errors"].get(k)}
    worst = max(zs, key=lambda k: abs(zs[k])) if zs else None
    row["z"] = zs
    row["worst"] = {"name": worst, "z": zs[worst]} if worst else None
    return row


def print_row(r: dict) -> None:
    head = f"{r['bench']:9s} {r['effect']:20s} {r['db']:4g}"
    if "error" in r:
        print(f"{head}  FAILED: {r['error']}")
        return
    chi = r["chi2_per_dof"]
    flag = "" if chi is not None and 0.7 <= chi <= 1.5 else " !"
    if r["effect_fitted"] is None:
        size = "not adopted"
    else:
        size = f"{r['effect_fitted']:.4g} +- {r['effect_std_error']:.2g} (z {r['effect_z']:+.1f})"
    worst = f"{r['worst']['name']} {r['worst']['z']:+.1f}" if r["worst"] else "-"
    causes = "; ".join(r["steps"]) or "-"
    gain = f"{r['gain']:.3g}" if r.get("gain") is not None and math.isfinite(r["gain"]) else "-"
    print(f"{head}  {r['verdict']:11s} {causes:42s} {chi:7.3f}{flag:2s} {size:34s} {gain:>6s}  {worst}")


def parse(argv) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="40 and 80 dB only")
    p.add_argument("--db", type=float, nargs="+", help="noise levels, SNR in dB per channel (default 20 40 60 80)")
    p.add_argument("--bench", nargs="+", default=list(BENCHES), help=f"which benches (default all: {' '.join(BENCHES)})")
    p.add_argument("--seed", type=int, default=1, help="the benches' seed (noise, offsets, start phases; default 1)")
    p.add_argument("--train-friction-Nm", type=float, default=8.0,
                   help="dry friction at the pump train's joint 2 (N m, default 8)")
    p.add_argument("--flywheel-friction-Nm", type=float, default=FLYWHEEL_FRICTION_Nm,
                   help=f"dry friction at the two flywheels' joint (N m, default {FLYWHEEL_FRICTION_Nm:g})")
    p.add_argument("--encoder-zeros", action="store_true",
                   help="each flywheel's encoder on its own zero (uniform in +-pi), not zeroed together")
    p.add_argument("--json", type=Path, help="write the table here (atomically)")
    args = p.parse_args(argv)
    if args.quick and args.db:
        p.exit(2, f"{p.prog}: error: --quick and --db exclude each other\n")
    args.levels = [40.0, 80.0] if args.quick else (args.db or [20.0, 40.0, 60.0, 80.0])
    unknown = [b for b in args.bench if b not in BENCHES]
    if unknown:
        p.exit(2, f"{p.prog}: error: unknown bench(es) {unknown}: choose from {', '.join(BENCHES)}\n")
    if not (math.isfinite(args.flywheel_friction_Nm) and args.flywheel_friction_Nm > 0):
        p.exit(2, f"{p.prog}: error: --flywheel-friction-Nm must be > 0, got {args.flywheel_friction_Nm}\n")
    if not (math.isfinite(args.train_friction_Nm) and args.train_friction_Nm > 0):
        p.exit(2, f"{p.prog}: error: --train-friction-Nm must be > 0, got {args.train_friction_Nm}\n")
    if args.seed < 0:
        p.exit(2, f"{p.prog}: error: --seed must be >= 0, got {args.seed}\n")
    from jointrig.commands.options import check_levels_db, check_output, refused

    refused(p, lambda: check_levels_db(args.levels), lambda: check_output(args.json, "--json"))
    return args


def main(argv=None) -> int:
    args = parse(argv)
    os.environ.setdefault("JOINTRIG_WORKERS", "1")
    from jointrig.rig.runtime import limit_threads

    limit_threads()
    todo = list(cases(list(dict.fromkeys(args.bench)), list(dict.fromkeys(args.levels)), args.train_friction_Nm,
                      args.flywheel_friction_Nm, args.encoder_zeros))
    print(f"Right models at every noise level (seed {args.seed}); level L dB = noise 10^(-L/20) of each "
          "channel's RMS; '!' marks chi2/dof outside 0.7-1.5")
    print(f"{'bench':9s} {'effect':20s} {'dB':>4s}  {'verdict':11s} {'adopted causes':42s} {'chi2/dof':>7s}   "
          f"{'effect fitted +- SE (z = (fit - true)/SE)':34s} {'gain':>6s}  worst other z")
    rows = []
    t_all = time.perf_counter()
    for k, (bench, effect, db, name, truth, others, run) in enumerate(todo, 1):
        print(f"[{k}/{len(todo)}] {bench}, {effect}, {db:g} dB ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            try:
                res = run(args.seed, Path(tmp))
            except Exception as err:  # one case failing is a row of the table, not the end of it
                res = {"error": f"{type(err).__name__}: {err}"}
        res["wall_s"] = time.perf_counter() - t0
        row = row_of(bench, effect, db, name, truth, others, res)
        rows.append(row)
        print_row(row)
        sys.stdout.flush()
        print(f"[{k}/{len(todo)}] done in {res['wall_s']:.0f} s", file=sys.stderr, flush=True)
        if args.json is not None:  # rewritten after every case: a stopped run keeps what finished
            write_json_atomic(args.json, {"seed": args.seed, "levels_db": args.levels,
                                          "train_friction_Nm": args.train_friction_Nm,
                                          "flywheel_friction_Nm": args.flywheel_friction_Nm,
                                          "encoder_zeros": args.encoder_zeros, "rows": rows})
    bad = [r for r in rows if "error" in r or not (0.7 <= r["chi2_per_dof"] <= 1.5)]
    print(f"{len(rows) - len(bad)} of {len(rows)} cases read chi2/dof within 0.7-1.5 "
          f"({time.perf_counter() - t_all:.0f} s)")
    if args.json is not None:
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
