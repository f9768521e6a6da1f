"""How the diagnosis does on every hidden-effect case of studies.hidden_effects.

    jointrig cases [--snr-db 40] [--seed N] [--json OUT]

For each case: the rig simulates 9 runs (16 periods each) with the effect hidden, measures
them at the SNR, and the diagnosis of every bench (``jointrig diagnose``: the two flywheels as
the train of two bodies; fit on 6 runs, validate on 3 held out) reports which cause it ranks
first, the effects it adds, the recovered magnitude against the truth and the gain.
"""

from __future__ import annotations

import time
from pathlib import Path

from jointrig.commands import add_quiet, command_parser
from jointrig.rig import load_rig
from jointrig.studies.hidden_effects import HIDDEN_EFFECTS, simulate_case
from jointrig.files import write_json_atomic
from jointrig.present.diagnosis_json import ambiguity_json
from jointrig.identify.chain import ChainRecord
from jointrig.rig.chain import chain_of_two_flywheels
from jointrig.studies.chain_validate import run_train_diagnosis
from jointrig.vocab.params import train_name


def main(argv=None) -> int:
    p = command_parser(__doc__, 'jointrig cases --snr-db 40 --json runs/cases.json')
    add_quiet(p)
    p.add_argument("--snr-db", type=float, default=40.0, help="SNR per channel in dB (default: %(default)s)")
    p.add_argument("--seed", type=int, default=None, help="noise seed (default: one per case, from its name)")
    p.add_argument("--json", type=Path, help="write the table as JSON")
    args = p.parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    from jointrig.commands.options import check_output

    check_output(args.json, "--json")
    rig = load_rig()
    chain = chain_of_two_flywheels(rig, [1])
    rows = []
    print(f"{'hidden':26s} {'ranked first':32s} {'found':50s} {'magnitude (true -> found)':44s} {'gain':>7s} "
          f"{'s':>5s}")
    for case, (_, truth) in HIDDEN_EFFECTS.items():
        t0 = time.perf_counter()
        records, peak = simulate_case(rig, case, snr_db=args.snr_db, seed=args.seed)
        report = run_train_diagnosis([ChainRecord.of_two_flywheels(r) for r in records], run_ids=[str(i) for i in range(len(records))],
                                     rig=chain)
        d = report.diagnosis
        params = d.final.parameters() if report.adopted else {}
        mags = {n: (v, params.get(train_name(n), float("nan"))) for n, v in truth.items()}
        first = d.first_round[0].label if d.first_round and d.first_round[0].significant else "none"
        mag_txt = "; ".join(f"{n.split('_')[0]} {v:.4g} -> {f:.4g}" for n, (v, f) in mags.items()) or "-"
        found = [s.label for s in d.steps] if report.adopted else []
        gain = report.validation.gain if report.validation is not None else float("nan")
        print(f"{case:26s} {first:32s} {'+'.join(found) or 'none':50s} {mag_txt:44s} {gain:7.3g} "
              f"{time.perf_counter() - t0:5.1f}", flush=True)
        for a in d.ambiguities:
            print(f"{'':26s} cannot tell apart: {a.effects[0]} and {a.effects[1]}", flush=True)
        rows.append({"hidden": case, "ranked_first": first, "found": found, "verdict": report.verdict.verdict,
                     "magnitudes": {n: {"true": v, "found": f, "rel_error": (f - v) / v} for n, (v, f) in mags.items()},
                     "gain": gain, "peak_joint_torque_Nm": peak,
                     "ambiguous": [ambiguity_json(a) for a in d.ambiguities]})
    if args.json:
        write_json_atomic(args.json, {"snr_db": args.snr_db, "cases": rows})
    return 0
