"""Simulate measured runs in the rig and write them in the measured-runs format.

    jointrig make-data runs/worn.csv --model models/two_flywheels_worn.xml
    jointrig diagnose runs/worn.csv --report runs/worn.html

Every (omega, amplitude) point is one run: the rig is driven to steady state and PERIODS
whole periods are logged, then measured with Gaussian noise on torque and both angles at
SNR_DB per channel (rates are not written: a bench measures angles). The effects the rig
carries come from the model's ``jointrig_*`` fields (see models/two_flywheels_worn.xml).

A drive train's model (``jointrig_joint<j>_*`` fields, models/pump_train_worn.xml) writes
``phi1..phiN`` and a ``torque<i>`` per driven body; without --omegas and --amplitudes its runs
are the pump train's sweep and two runs at other levels (OMEGA,AMPLITUDE,BODY of
studies.chain_sweep.CHAIN_PLAN and HELD_OUT), else every point drives the model's first drive:

    jointrig make-data runs/train.csv --model models/pump_train_worn.xml
    jointrig diagnose runs/train.csv --model models/pump_train.xml
"""

from __future__ import annotations

import argparse

import logging
import sys
from pathlib import Path

from jointrig.commands import add_quiet, command_parser, shipped
from jointrig.measured.runs import write_runs
from jointrig.rig import DEFAULT_MODEL, RigModelError, SimulationError, load_rig
from jointrig.rig.measurement import simulate_runs

log = logging.getLogger("make_data")

#: The two-flywheel runs' default drive frequencies (rad/s) and amplitudes (N m).
OMEGAS = (25.0, 40.0, 55.0)
AMPLITUDES = (1500.0, 2500.0, 3500.0)


def parse_args(argv=None) -> argparse.Namespace:
    p = command_parser(__doc__, 'jointrig make-data runs/worn.csv --model models/two_flywheels_worn.xml')
    p.add_argument("out", type=Path, help="output file (.csv or .parquet)")
    p.add_argument("--model", type=Path, default=DEFAULT_MODEL, help=f"rig MJCF (default: {shipped(DEFAULT_MODEL)})")
    p.add_argument("--omegas", type=float, nargs="+", metavar="RAD_S",
                   help=f"drive frequencies in rad/s (default: {' '.join(map(str, OMEGAS))}; a train: its sweep)")
    p.add_argument("--amplitudes", type=float, nargs="+", metavar="NM",
                   help=f"drive amplitudes in N m (default: {' '.join(map(str, AMPLITUDES))}; a train: its sweep)")
    p.add_argument("--periods", type=int, default=16, help="periods logged per run (default: %(default)s)")
    p.add_argument("--snr-db", type=float, default=40.0, help="signal-to-noise ratio per channel in dB "
                   "(default: %(default)s); --no-noise for exact data")
    p.add_argument("--no-noise", action="store_true", help="write the exact simulated signals (no measurement noise)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default: %(default)s)")
    add_quiet(p)
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    from jointrig.commands.options import BadArgument, check_each, check_output, check_range, progress_level

    try:
        if args.out.suffix.lower() not in (".csv", ".parquet"):
            raise BadArgument(f"{args.out}: expected a .csv or .parquet output file")
        check_output(args.out, "out")
        check_range(args.periods, "--periods", lo=2, hi=10000, integer=True)
        check_range(args.snr_db, "--snr-db", lo=0, hi=200, lo_open=True)
        check_range(args.seed, "--seed", lo=0, hi=2**32 - 1, integer=True)
        check_each(args.omegas or (), "--omegas", lo=0, hi=1e4, lo_open=True)
        check_each(args.amplitudes or (), "--amplitudes", lo=0, hi=1e7, lo_open=True)
    except BadArgument as err:
        print(f"jointrig make-data: error: {err}", file=sys.stderr)
        return 2
    logging.basicConfig(level=progress_level(args.quiet), format="%(message)s", stream=sys.stderr)
    from jointrig.rig.model import is_chain_model

    if is_chain_model(args.model):
        return _train(args)
    omegas, amps = args.omegas or OMEGAS, args.amplitudes or AMPLITUDES
    points = [(w, a) for w in omegas for a in amps]
    try:
        rig = load_rig(args.model)
        log.info("simulating %d runs of %s (%s)", len(points), args.model.name, rig.plant.parameters())
        records = simulate_runs(rig, rig.plant, points, n_periods=args.periods,
                                snr_db=None if args.no_noise else args.snr_db, seed=args.seed)
        comment = (f"simulated by jointrig from {args.model.name}: {rig.plant.parameters()}; "
                   f"SNR {'none' if args.no_noise else args.snr_db} dB, seed {args.seed}")
        write_runs(args.out, records, run_ids=list(range(len(records))), comment=comment)
    except (RigModelError, SimulationError, ValueError) as err:
        print(f"jointrig make-data: error: {err}", file=sys.stderr)
        return 2
    log.info("wrote %s", args.out)
    return 0


def _train(args: argparse.Namespace) -> int:
    """A drive train's runs: simulated in the chain rig, measured, written with phi1..phiN, torque<i>."""
    import numpy as np

    from jointrig.rig.chain import load_chain
    from jointrig.rig.measurement import measure_chain
    from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN, HELD_OUT, run_chain_sweep

    try:
        rig = load_chain(args.model)
        if args.omegas or args.amplitudes:
            points = [(w, a, rig.driven[0]) for w in (args.omegas or (CHAIN_PLAN[0][0],))
                      for a in (args.amplitudes or (CHAIN_PLAN[0][1],))]
        else:
            points = list(CHAIN_PLAN) + list(HELD_OUT)
        log.info("simulating %d runs of the %d-body train %s", len(points), rig.n_flywheels, args.model.name)
        swept = run_chain_sweep(rig, points, CHAIN_CONFIG)
        rng = np.random.default_rng(args.seed)
        records = [measure_chain(p.record, None if args.no_noise else args.snr_db, rng, n_periods=args.periods)
                   for p in swept]
        comment = (f"simulated by jointrig from {args.model.name} (a {rig.n_flywheels}-body train); points "
                   f"(omega rad/s, amplitude N m, driven body) {points}; SNR "
                   f"{'none' if args.no_noise else args.snr_db} dB, seed {args.seed}")
        write_runs(args.out, records, run_ids=list(range(len(records))), comment=comment)
    except (RigModelError, SimulationError, ValueError) as err:
        print(f"jointrig make-data: error: {err}", file=sys.stderr)
        return 2
    log.info("wrote %s", args.out)
    return 0
