"""The identified joint card held against a virtual phase-resonance test (studies/card_check.py).

    jointrig card-check [CASE ...] [--snr-db 40] [--seed 1] [--periods 8] [--json OUT]

For each case (the paper's joint, a Jenkins joint in macroslip, an Iwan joint in micro-slip):
a stepped-sine test simulated in the rig and measured at the SNR is diagnosed; the identified
law's card (natural frequency, damping ratio, dissipation per cycle, with standard errors from
the fit) is compared with a phase-resonance test run in the rig at the amplitudes it reached,
and the card straight from the measured phase-resonance runs with the test itself. The table
gives each departure relative and in standard errors, and the describing function's own bias
(the true law's card against phase resonance).
"""

from __future__ import annotations

import logging
from pathlib import Path

from jointrig.commands import add_quiet, command_parser
from jointrig.rig import load_rig
from jointrig.studies.card_check import CARD_CASES, check_card, check_text, worst
from jointrig.commands.options import check_output, check_range, progress_level
from jointrig.files import write_json_atomic

log = logging.getLogger("jointrig.card-check")


def main(argv=None) -> int:
    p = command_parser(__doc__, 'jointrig card-check paper', prog="jointrig card-check")
    p.add_argument("cases", nargs="*", choices=[[], *CARD_CASES], default=[], metavar="CASE",
                   help=f"joints to check, of {', '.join(CARD_CASES)} (default: all)")
    p.add_argument("--snr-db", type=float, default=40.0, help="SNR per channel in dB (default: %(default)s)")
    p.add_argument("--seed", type=int, default=1, help="noise seed (default: %(default)s)")
    p.add_argument("--periods", type=int, default=8, help="periods per measured run (default: %(default)s)")
    p.add_argument("--json", type=Path, help="write the comparisons as JSON")
    add_quiet(p)
    args = p.parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    logging.basicConfig(level=progress_level(args.quiet), format="%(levelname)s %(name)s: %(message)s")
    check_range(args.snr_db, "--snr-db", lo=0, hi=200)
    check_range(args.periods, "--periods", lo=2, hi=1000, integer=True)
    check_output(args.json, "--json")
    rig = load_rig()
    checks = []
    for case in args.cases or list(CARD_CASES):
        checks.append(check_card(rig, case, snr_db=args.snr_db, seed=args.seed, n_periods=args.periods,
                                 progress=log.info))
        print(check_text(checks[-1]), flush=True)
    w = worst(checks)
    print(f"largest departures: identified card from the true law's {w['identified_z']:.2f} standard errors; "
          f"runs' card from phase resonance {w['runs_z']:.2f} standard errors; describing function from phase "
          f"resonance {w['describing_bias']:.1e} (relative)")
    if args.json:
        write_json_atomic(args.json, {"snr_db": args.snr_db, "seed": args.seed, "periods": args.periods,
                                      "cases": [c.as_json() for c in checks], "worst": w})
    return 0
