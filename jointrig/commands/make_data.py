"""Simulate measured runs in the rig and write them in the measured-runs format.

    jointrig make-data runs/worn.csv --model models/two_flywheels_worn.xml
    jointrig diagnose runs/worn.csv --report runs/worn.html

Every (omega, amplitude) point is one run: the rig is driven to steady state and PERIODS
whole periods are logged, then measured with Gaussian noise on torque and both angles at
SNR_DB per channel (rates are not written: a bench measures angles). The effects the rig
carries come from the model's ``jointrig_*`` fields (see models/two_flywheels_worn.xml).
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


def parse_args(argv=None) -> argparse.Namespace:
    p = command_parser(__doc__)
    p.add_argument("out", type=Path, help="output file (.csv or .parquet)")
    p.add_argument("--model", type=Path, default=DEFAULT_MODEL, help=f"rig MJCF (default: {shipped(DEFAULT_MODEL)})")
    p.add_argument("--omegas", type=float, nargs="+", default=[25.0, 40.0, 55.0], metavar="RAD_S",
                   help="drive frequencies in rad/s (default: %(default)s)")
    p.add_argument("--amplitudes", type=float, nargs="+", default=[1500.0, 2500.0, 3500.0], metavar="NM",
                   help="drive amplitudes in N m (default: %(default)s)")
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
    from jointrig.rig.runtime import BadArgument, check_each, check_output, check_range, progress_level

    try:
        if args.out.suffix.lower() not in (".csv", ".parquet"):
            raise BadArgument(f"{args.out}: expected a .csv or .parquet output file")
        check_output(args.out, "out")
        check_range(args.periods, "--periods", lo=2, hi=10000, integer=True)
        check_range(args.snr_db, "--snr-db", lo=0, hi=200, lo_open=True)
        check_range(args.seed, "--seed", lo=0, hi=2**32 - 1, integer=True)
        check_each(args.omegas, "--omegas", lo=0, hi=1e4, lo_open=True)
        check_each(args.amplitudes, "--amplitudes", lo=0, hi=1e7, lo_open=True)
    except BadArgument as err:
        print(f"jointrig make-data: error: {err}", file=sys.stderr)
        return 2
    logging.basicConfig(level=progress_level(args.quiet), format="%(message)s", stream=sys.stderr)
    points = [(w, a) for w in args.omegas for a in args.amplitudes]
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
