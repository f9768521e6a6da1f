"""Which joint of a drive train is worn, and how: diagnose a chain against its nominal model.

    jointrig diagnose-chain --truth models/pump_train_worn.xml            # the README's example
    jointrig diagnose-chain --truth MY_WORN.xml --model MY_TRAIN.xml --snr-db 30 --json OUT

A demo of the path a measured train takes (``jointrig make-data OUT --model MY_WORN.xml`` then
``jointrig diagnose OUT --model MY_TRAIN.xml`` does the same through a file): the rig simulates
the "measured" train (``--truth``, the effect hidden in its file) at the sweep points of
studies.chain_sweep.CHAIN_PLAN for estimation and at held-out points of another level
(``--holdout``), measures every angle and drive torque with white noise at ``--snr-db``, and
hands the records to studies.chain_validate.run_train_diagnosis with the nominal model
(``--model``) as the user's: every catalogued cause scored at every joint and bearing drag at
every flywheel, the place and cause named, the model extended there, the held-out runs' drives
replayed on the nominal and the extended model in the rig, the verdict. Frequencies in rad/s,
torques in N m.
"""

from __future__ import annotations

import argparse

import logging
from pathlib import Path

import numpy as np

from jointrig.commands import add_quiet, command_parser, shipped
from jointrig.present.train_report import format_train_report, train_report_json
from jointrig.rig.chain import load_chain
from jointrig.rig.model import DEFAULT_MODEL
from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN, HELD_OUT, run_chain_sweep
from jointrig.studies.chain_validate import run_train_diagnosis, written_of
from jointrig.rig.measurement import measure_chain
from jointrig.commands.options import add_backend_option, check_folder, check_output, check_range, progress_level
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
    p = command_parser(__doc__, 'jointrig diagnose-chain --truth models/pump_train_worn.xml')
    p.add_argument("--truth", type=Path, default=MODELS / "pump_train_worn.xml",
                   help=f"chain model that plays the measured train (default: {shipped(MODELS / 'pump_train_worn.xml')})")
    p.add_argument("--model", type=Path, default=MODELS / "pump_train.xml",
                   help=f"the nominal chain model: its bodies and drives replay the held-out runs (default: "
                        f"{shipped(MODELS / 'pump_train.xml')})")
    p.add_argument("--snr-db", type=float, default=40.0, help="SNR per channel in dB (default: %(default)s)")
    p.add_argument("--periods", type=int, default=8, help="measured periods per run (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default: %(default)s)")
    p.add_argument("--holdout", type=_point, nargs="+", default=list(HELD_OUT), metavar="W,A,I",
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
    if args.store is not None:  # the store and the two folders the runs are kept in
        for folder in (args.store, args.store / "estimation", args.store / "held_out"):
            check_folder(folder, "--store")
    truth, nominal = load_chain(args.truth), load_chain(args.model)
    if truth.n_flywheels != nominal.n_flywheels:
        raise ValueError(f"--truth has {truth.n_flywheels} flywheels, --model {nominal.n_flywheels}")
    store = args.store
    log.info("simulating the measured train %s: %d estimation and %d held-out runs", truth.path.name,
             len(CHAIN_PLAN), len(args.holdout))
    est = run_chain_sweep(truth, CHAIN_PLAN, CHAIN_CONFIG, store=store / "estimation" if store else None,
                          backend=args.backend)
    held = run_chain_sweep(truth, args.holdout, CHAIN_CONFIG, store=store / "held_out" if store else None,
                           backend=args.backend)
    rng = np.random.default_rng(args.seed)
    est_recs = [measure_chain(p.record, args.snr_db, rng, n_periods=args.periods) for p in est]
    held_recs = [measure_chain(p.record, args.snr_db, rng, n_periods=args.periods) for p in held]
    # From here the path of a measured train's file (jointrig diagnose TRAIN.csv --model MODEL):
    # the same diagnosis, validation, verdict and text.
    report = run_train_diagnosis(est_recs + held_recs, run_ids=[str(k) for k in range(len(est) + len(held))],
                                 rig=nominal, holdout=range(len(est), len(est) + len(held)), written=written_of(nominal),
                                 progress=lambda msg: log.info("%s", msg), backend=args.backend)
    N = nominal.n_flywheels
    print(f"\nDiagnosis of a {N}-flywheel chain simulated from {truth.path.name} (the diagnosis knows only the "
          f"nominal structure), {args.periods} periods per run at SNR {args.snr_db:g} dB:\n")
    print(format_train_report(report, source=f"{truth.path.name} in the rig"))
    out = {**train_report_json(report, source=f"{truth.path.name} in the rig"),
           "demo": {"truth_model": str(truth.path), "model": str(nominal.path), "snr_db": args.snr_db,
                    "seed": args.seed, "periods": args.periods, "estimation_points": [list(p) for p in CHAIN_PLAN],
                    "held_out_points": [list(p) for p in args.holdout],
                    "truth_parameters": {**{f"J{i}_kgm2": J for i, J in enumerate(truth.inertias_kgm2, start=1)},
                                         **truth.plant.parameters()}}}
    write_json_atomic(args.json, out)
    print(f"\nwrote {args.json}")
    if not args.no_rrd:
        from jointrig.present.recording import log_chain_diagnosis, open_recording

        with open_recording(args.rrd) as rec:
            log_chain_diagnosis(rec, report.diagnosis, report.validation, N)
        print(f"wrote {args.rrd} (open it with: .venv/bin/rerun {args.rrd})")
    return 0
