#!/usr/bin/env python3
"""Coverage of the joint card's 95% intervals over seeds (``jointrig card-check`` repeated).

    python scripts/coverage_card.py [CASE ...] [--seeds N] [--first-seed S] [--db 40] [--out DIR]
                                    [--workers W] [--json OUT]

Why: the card's rows carry standard errors, and a user reads them as intervals. For each joint of
``studies.card_check.CARD_CASES`` (the paper's, a Jenkins joint in macroslip, an Iwan joint in
micro-slip) and each seed, ``studies.card_check.check_card`` measures a stepped-sine test at the
level (a seed draws the noise), diagnoses it, and compares at the amplitudes a noise-free
phase-resonance test reached:

- the model's rows (the identified law's card: natural frequency, damping ratio, dissipation per
  cycle, standard errors from the fit's covariance) with the true law's card at the same
  amplitudes (what a perfect identification gives: the describing function of the true law);
- the runs' rows (the card straight from the phase-resonance runs measured at the level, the
  inertias from the fit) with the noise-free phase-resonance test.

Per joint, row kind, quantity and phase-resonance amplitude (A1 the lowest level's; the
noise-free test reaches the same amplitudes in every seed) it prints the share of seeds where
|z| <= 1.96 with its binomial standard error, the median |z| (0.674 for a calibrated Gaussian
estimate) and the RMS z (1); then every row of a kind pooled ("(all rows)": the rows of one seed
are not independent, so its binomial error is too small). The
runs are the rig's (the card's truth is the rig's own law, which only the rig simulates exactly).

Resumable: ``--out DIR`` keeps one JSON per (case, level, seed), written atomically; cases whose
file exists are not run again. Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
Z95 = 1.96


def case_path(out: Path, case: str, db: float, seed: int) -> Path:
    return out / f"card_{case}_db{db:g}_seed{seed:04d}.json"


def run_case(case: str, db: float, seed: int, out: str) -> dict:
    """One card check (in a worker process); its record is written to ``out`` and returned."""
    os.environ["JOINTRIG_WORKERS"] = "1"
    from jointrig.files import write_json_atomic
    from jointrig.rig import load_rig
    from jointrig.rig.runtime import limit_threads, quiet_mujoco
    from jointrig.studies.card_check import check_card

    limit_threads()
    quiet_mujoco()
    t0 = time.perf_counter()
    rec = {"case": case, "db": db, "seed": seed}
    try:
        rec.update(check_card(load_rig(), case, snr_db=db, seed=seed).as_json())
    except Exception as err:  # a failed case is recorded, counted and reported, not retried
        rec["error"] = f"{type(err).__name__}: {err}"
    rec["wall_s"] = time.perf_counter() - t0
    write_json_atomic(case_path(Path(out), case, db, seed), rec)
    return rec


def summarise(records: list[dict]) -> dict:
    """Per (case, level), row kind (``identified``: the model's rows against the true law's card;
    ``runs``: the runs' rows against phase resonance) and quantity: n, share covered, its binomial
    SE, median z and |z| (pure)."""
    table: dict = {}
    for r in records:
        if "error" in r:
            table.setdefault(f"{r['case']} {r['db']:g} dB", {}).setdefault("failed", []).append(r["seed"])
            continue
        level = table.setdefault(f"{r['case']} {r['db']:g} dB", {})
        level.setdefault("verdicts", []).append(r["verdict"])
        seen: dict = {}
        for c in r["comparisons"]:  # the k-th phase-resonance amplitude (noise free: the same in every seed)
            k = seen[c["quantity"]] = seen.get(c["quantity"], 0) + 1
            for kind in ("identified", "runs"):
                z = c[f"{kind}_z"]
                if z is not None and math.isfinite(z):
                    level.setdefault(kind, {}).setdefault(f"{c['quantity']} at A{k}", []).append(z)
    out = {}
    for key, level in table.items():
        row = {"failed": level.get("failed", []),
               "verdicts": {v: level.get("verdicts", []).count(v) for v in sorted(set(level.get("verdicts", [])))}}
        for kind in ("identified", "runs"):
            by_row = dict(level.get(kind, {}))
            if by_row:  # every row of the kind pooled (rows of one seed are not independent)
                by_row["(all rows)"] = [z for zs in by_row.values() for z in zs]
            for q, zs in by_row.items():
                p = sum(abs(z) <= Z95 for z in zs) / len(zs)
                row[f"{kind} {q}"] = {"n": len(zs), "covered": p, "binomial_se": math.sqrt(p * (1 - p) / len(zs)),
                                      "median_z": statistics.median(zs),
                                      "median_abs_z": statistics.median(abs(z) for z in zs),
                                      "rms_z": math.sqrt(statistics.fmean(z * z for z in zs))}
        out[key] = row
    return out


def print_table(table: dict) -> None:
    for key, row in table.items():
        print(f"\n{key}: verdicts {row['verdicts']}; failed seeds {row['failed'] or 'none'}")
        print(f"  {'rows':45s} {'n':>4s} {'covered':>8s} {'+-':>6s} {'median z':>9s} {'median |z|':>10s} {'RMS z':>6s}")
        for name, s in row.items():
            if name in ("failed", "verdicts"):
                continue
            flag = "" if 0.90 <= s["covered"] <= 0.98 else "  <- outside 90-98%"
            print(f"  {name:45s} {s['n']:4d} {s['covered']:8.1%} {s['binomial_se']:6.1%} {s['median_z']:9.2f} "
                  f"{s['median_abs_z']:10.2f} {s['rms_z']:6.2f}{flag}")


def parse(argv) -> argparse.Namespace:
    from jointrig.studies.card_check import CARD_CASES

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("cases", nargs="*", metavar="CASE", help=f"joints, of {', '.join(CARD_CASES)} (default: all)")
    p.add_argument("--seeds", type=int, default=30, help="seeds per joint and level (default 30)")
    p.add_argument("--first-seed", type=int, default=0, help="the first seed (default 0)")
    p.add_argument("--db", type=float, nargs="+", default=[40.0], help="SNR per channel in dB (default 40)")
    p.add_argument("--out", type=Path, default=ROOT / "runs" / "coverage_card",
                   help="folder of the per-case JSON files (default runs/coverage_card)")
    p.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    p.add_argument("--json", type=Path, help="write the summary table here (atomically)")
    args = p.parse_args(argv)
    bad = [c for c in args.cases if c not in CARD_CASES]
    if bad:
        p.exit(2, f"{p.prog}: error: CASE {bad[0]!r} is none of {', '.join(CARD_CASES)}\n")
    args.cases = args.cases or list(CARD_CASES)
    if args.seeds < 1 or args.first_seed < 0 or args.workers < 1:
        p.exit(2, f"{p.prog}: error: --seeds and --workers must be at least 1 and --first-seed at least 0\n")
    from jointrig.commands.options import study_outputs

    study_outputs(p, args.out, args.db, args.json)
    return args


def main(argv=None) -> int:
    args = parse(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    records, todo = [], []
    for seed in seeds:
        for case in args.cases:
            for db in dict.fromkeys(args.db):
                path = case_path(args.out, case, db, seed)
                if path.exists():
                    records.append(json.loads(path.read_text()))
                else:
                    todo.append((case, db, seed))
    print(f"coverage_card: {len(records)} case(s) already in {args.out}, {len(todo)} to run in {args.workers} "
          "process(es)", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    if todo:
        with ProcessPoolExecutor(args.workers) as pool:
            futures = {pool.submit(run_case, case, db, seed, str(args.out)): (case, db, seed) for case, db, seed in todo}
            for k, fut in enumerate(as_completed(futures), 1):
                case, db, seed = futures[fut]
                r = fut.result()
                records.append(r)
                eta = (time.perf_counter() - t0) / k * (len(todo) - k)
                print(f"[{k}/{len(todo)}] {case} {db:g} dB seed {seed}: {r.get('error') or r['verdict']} "
                      f"({r['wall_s']:.1f} s; about {eta / 60:.0f} min left)", file=sys.stderr, flush=True)
    table = summarise(records)
    print(f"Coverage of the joint card's rows, value +- {Z95} SE, over seeds {seeds.start}-{seeds.stop - 1}")
    print_table(table)
    if args.json is not None:
        from jointrig.files import write_json_atomic

        write_json_atomic(args.json, {"seeds": [seeds.start, seeds.stop - 1], "levels_db": args.db, "table": table})
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
