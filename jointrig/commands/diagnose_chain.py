"""Which joint of a drive train is worn, and how: diagnose a chain against its nominal model.

    jointrig diagnose-chain --truth models/pump_train_worn.xml            # the README's example
    jointrig diagnose-chain --truth MY_WORN.xml --model MY_TRAIN.xml --snr-db 30 --json OUT

The rig simulates the "measured" train (``--truth``, the effect hidden in its file) at the
sweep points of studies.chain_sweep.CHAIN_PLAN for estimation and at held-out points of another
level (``--held-out``), measures every angle and drive torque with white noise at
``--snr-db``, and hands the records to the diagnosis (identify/chain_diagnose.py), which
knows only the nominal model's structure: it scores every catalogued cause at every joint
and bearing drag at every flywheel, names the place and the cause, extends the model there,
and the rig measures the extended model's gain on the held-out runs (studies/chain_validate.py),
replaying their recorded drives on the nominal (``--model``) chain's bodies.
Frequencies in rad/s, torques in N m.
"""

from __future__ import annotations

import argparse

import logging
import math
from pathlib import Path

import numpy as np

from jointrig.commands import add_quiet, command_parser, shipped
from jointrig.identify.chain_diagnose import diagnose_chain, prepare_chain_runs
from jointrig.rig.chain import load_chain
from jointrig.rig.model import DEFAULT_MODEL
from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN, HELD_OUT, run_chain_sweep
from jointrig.studies.chain_validate import validate_chain
from jointrig.rig.measurement import measure_chain
from jointrig.rig.runtime import add_backend_option, check_output, check_range, progress_level
from jointrig.files import write_json_atomic

log = logging.getLogger("diagnose_chain")

MODELS = DEFAULT_MODEL.parent  # package data: found beside the installed rig, editable or not



def _point(text: str) -> tuple[float, float, int]:
    try:
        w, a, i = text.split(",")
        return float(w), float(a), int(i)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected OMEGA_RAD_S,AMPLITUDE_NM,FLYWHEEL (e.g. 300,90,1), got {text!r}")


def parse_args(argv=None) -> argparse.Namespace:
    p = command_parser(__doc__)
    p.add_argument("--truth", type=Path, default=MODELS / "pump_train_worn.xml",
                   help=f"chain model that plays the measured train (default: {shipped(MODELS / 'pump_train_worn.xml')})")
    p.add_argument("--model", type=Path, default=MODELS / "pump_train.xml",
                   help=f"the nominal chain model: its bodies and drives replay the held-out runs (default: "
                        f"{shipped(MODELS / 'pump_train.xml')})")
    p.add_argument("--snr-db", type=float, default=40.0, help="SNR per channel in dB (default: %(default)s)")
    p.add_argument("--periods", type=int, default=8, help="measured periods per run (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default: %(default)s)")
    p.add_argument("--held-out", type=_point, nargs="+", default=list(HELD_OUT), metavar="W,A,I",
                   help="held-out runs as omega rad/s,amplitude N m,driven flywheel (default: %(default)s)")
    p.add_argument("--json", type=Path, default=Path("runs/chain_diagnosis.json"), help="results (default: %(default)s)")
    p.add_argument("--rrd", type=Path, default=Path("runs/chain_diagnosis.rrd"), help="recording (default: %(default)s)")
    p.add_argument("--no-rrd", action="store_true", help="write no recording")
    p.add_argument("--store", type=Path, default=None, help="keep simulated runs here to resume (default: none)")
    add_backend_option(p)
    add_quiet(p)
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    logging.basicConfig(level=progress_level(args.quiet), format="%(levelname)s %(name)s: %(message)s")
    check_range(args.snr_db, "--snr-db", lo=0, hi=200)
    check_range(args.periods, "--periods", lo=2, hi=1000, integer=True)
    check_output(args.json, "--json")
    if not args.no_rrd:
        check_output(args.rrd, "--rrd")
    truth, nominal = load_chain(args.truth), load_chain(args.model)
    if truth.n_flywheels != nominal.n_flywheels:
        raise ValueError(f"--truth has {truth.n_flywheels} flywheels, --model {nominal.n_flywheels}")
    store = args.store
    log.info("simulating the measured train %s: %d estimation and %d held-out runs", truth.path.name,
             len(CHAIN_PLAN), len(args.held_out))
    est = run_chain_sweep(truth, CHAIN_PLAN, CHAIN_CONFIG, store=store / "estimation" if store else None,
                          backend=args.backend)
    held = run_chain_sweep(truth, args.held_out, CHAIN_CONFIG, store=store / "held_out" if store else None,
                           backend=args.backend)
    rng = np.random.default_rng(args.seed)
    est_recs = [measure_chain(p.record, args.snr_db, rng, n_periods=args.periods) for p in est]
    held_recs = [measure_chain(p.record, args.snr_db, rng, n_periods=args.periods) for p in held]
    runs = prepare_chain_runs(est_recs)

    def progress(k, n, label):
        if k == n or k % 5 == 0:
            log.info("scored %d/%d candidates (%s)", k, n, label)

    d = diagnose_chain(runs, progress=progress)
    log.info("replaying the held-out runs on the nominal and the extended model")
    v = validate_chain(nominal, d, held_recs, backend=args.backend) if d.steps else None
    N = nominal.n_flywheels
    print(f"\nDiagnosis of a {N}-flywheel chain from {len(runs)} runs x {args.periods} periods at SNR "
          f"{args.snr_db:g} dB (truth {truth.path.name}; the diagnosis knows only the nominal structure):")
    print(f"  nominal model: chi2/dof = {d.nominal.chi2 / d.nominal.dof:.3g} (1 = explained to the noise)")
    print(f"  candidates ({len(d.first_round)}: {len(d.first_round) - N} causes at {N - 1} joints, bearing drag at "
          f"{N} flywheels), best first:")
    for s in d.first_round[:6]:
        print(f"    {s.label:34s} score {s.score:10.1f}  p = {s.p_value:.2g}  {s.magnitude[0]} = "
              f"{s.magnitude[1]:.4g} +- {s.magnitude[2]:.2g}" + (f"  [{s.note}]" if s.note else ""))
    if not d.steps:
        print("  nothing significant: the nominal model explains the data to the noise")
    for s in d.steps:
        print(f"  FOUND: {s.label}: {s.magnitude[0]} = {s.magnitude[1]:.4g} +- {s.magnitude[2]:.2g}")
    print(f"  extended model: chi2/dof = {d.final.chi2 / d.final.dof:.3g}")
    for a in d.ambiguities:
        print(f"  AMBIGUOUS: {a.candidates[0]} or {a.candidates[1]}: {a.explanation}")
    if v is not None:
        print(f"  held-out runs ({len(held_recs)}, another level): twist error nominal {v.nominal_error:.3g}, extended "
              f"{v.extended_error:.3g} (noise floor {v.noise_floor:.2g}): gain {v.gain:.3g}" + (
                  f" [{v.note}]" if v.note else ""))
    out = {"truth_model": str(truth.path), "model": str(nominal.path), "snr_db": args.snr_db, "seed": args.seed,
           "periods": args.periods, "estimation_points": [list(p) for p in CHAIN_PLAN],
           "held_out_points": [list(p) for p in args.held_out], **d.as_json(),
           "validation": v.as_json() if v is not None else None,
           "truth_parameters": {**{f"J{i}_kgm2": J for i, J in enumerate(truth.inertias_kgm2, start=1)},
                                **truth.plant.parameters()},
           "units": "SI; parameter names carry their units"}
    write_json_atomic(args.json, out)
    print(f"\nwrote {args.json}")
    if not args.no_rrd:
        from jointrig.present.recording import log_chain_diagnosis, open_recording

        with open_recording(args.rrd) as rec:
            log_chain_diagnosis(rec, d, v, N)
        print(f"wrote {args.rrd} (open it with: .venv/bin/rerun {args.rrd})")
    return 0 if (not d.steps or (v is not None and math.isfinite(v.gain))) else 1
