#!/usr/bin/env python3
"""Why a linear parameter's interval is short at a dry-friction joint: one bench's runs, many draws
of their noise.

    .venv/bin/python scripts/period_scatter.py [--seed 17] [--draws 20] [--db 40]
                                               [--channel-noise T PHI1 PHI2] [--jackknife] [--json OUT]

The two flywheels of tests/test_independent_bench.py's paper joint with 40 N m of dry friction
(``coulomb_friction/1``, scripts/coverage.py's bench): the fitted runs of one ``--seed`` (their
start phases and offsets) written ``--draws`` times, each with its own draw of the noise
(``bench_sim.measure``'s ``noise_seed``), and fitted in the bench's own structure (dry friction
at joint 1, the twist's zero held at the truth) as the diagnosis fits its final model: weighted,
compensated, each linear error floored by the periods' own scatter
(``identify.chain_diagnose._Problem.compensated``). Per parameter, over the draws:

- ``sd(error)``: the scatter of the fitted value about the truth, what a calibrated error equals;
- ``rms SE weights`` and ``rms SE floored``: the fit's reported error before and after the floor;
- at the true parameters, through the fit's linear map ``G = (A'WA)^-1 A'W``: ``sd e(average)``,
  the error the balance of the periods' average gives (the fit's own, to first order), and
  ``sd e(periods)``, the error of the mean of each period's own balance (what the floor's scatter
  estimates, ``rms floor``);
- with ``--jackknife``: each period left out of the average in turn (``rms jackknife``).

Where the columns are linear in the data the two errors are one; a dry friction's column is the
sign of a rate, which near a reversal crosses zero several times in a noisy period and once in
the average, so the two part (docs/noisy-measurements.md). It prints its table (``--json OUT``
writes it atomically); progress goes to stderr.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "scripts")]

EFFECT = "coulomb_friction/1"


def _draw(seed: int, draw: int, db: float, channels: tuple, tmp: Path):
    """The fitted runs of ``seed``'s bench with noise draw ``draw``, prepared as the diagnosis does."""
    from coverage import HOLDOUT, _flywheel_file
    from jointrig.identify.chain_diagnose import prepare_chain_runs
    from jointrig.measured.runs import read_runs

    path = _flywheel_file(db, seed, 0.0, tmp, EFFECT, channels, noise_seed=10_000 * seed + draw)
    return tuple(prepare_chain_runs([r for k, r in enumerate(read_runs(path).records) if k not in HOLDOUT]))


def one_draw(seed: int, draw: int, db: float, channels: tuple, jackknife: bool) -> dict:
    """One draw's fit and the errors at the truth through its linear map (module docstring)."""
    from coverage import _twist_zero_rad, effect_case
    from jointrig.identify import chain_diagnose as cd
    from jointrig.identify.causes import Place, by_name

    with tempfile.TemporaryDirectory() as tmp:
        runs = _draw(seed, draw, db, channels, Path(tmp))
    problem = cd._Problem(runs, 20, 2.0 * (min(r.n_periods for r in runs) - 1), 1e-6, (False, False), (False,))
    spec = cd.Candidate(cd.TWIST_ZERO, Place("joint", 1)).extend(cd.nominal_spec(2), _twist_zero_rad(seed))
    spec = cd.Candidate(by_name("coulomb_friction"), Place("joint", 1)).extend(spec, 0.0)
    fit, w = problem.fit(spec)
    floored = problem.compensated(fit, w)
    truth = dict(effect_case(EFFECT)[1], joint1_coulomb_torque_Nm=40.0)
    theta = np.array([truth[n] for n in fit.names])
    jumps = problem.jumps(spec, dict(zip(fit.names, theta)))
    banded = problem.system(spec, jumps)
    A, F = banded.system.A, banded.system.F
    G = np.linalg.solve(A.T @ (A * w[:, None]), (A * w[:, None]).T)
    e_periods, floor = np.zeros(len(theta)), np.zeros(len(theta))
    for rows, As, Fs, _, _ in problem.period_systems(spec, banded, jumps):
        u = (Fs - As @ theta) @ G[:, rows].T
        e_periods += u.mean(axis=0)
        floor += u.var(axis=0, ddof=1) / u.shape[0]
    out = {"se_weights": fit.std_errors, "se_floored": floored.std_errors, "floored_error": floored.values - theta, "e_average": G @ (F - A @ theta), "e_periods": e_periods,
           "floor": np.sqrt(floor)}
    if jackknife:
        var = np.zeros(len(theta))
        for k, run in enumerate(runs):
            P, avg, us = run.n_periods, run.average, []
            for per in run.periods:
                loo = replace(avg, angles_rad=tuple((P * a - b) / (P - 1) for a, b in zip(avg.angles_rad, per.angles_rad)),
                              torques_Nm=tuple(None if a is None else (P * a - b) / (P - 1)
                                               for a, b in zip(avg.torques_Nm, per.torques_Nm)), rates_rad_s=None)
                left = problem.runs[:k] + (replace(run, average=loo),) + problem.runs[k + 1:]
                s = cd._Problem(left, problem.n_harmonics, problem.nu, 1e-6, (False, False), (False,)).system(spec, jumps).system
                rows = np.flatnonzero(s.row_record == k)
                us.append(G[:, rows] @ (s.F[rows] - s.A[rows] @ theta))
            us = np.array(us)
            var += (P - 1) / P * np.sum((us - us.mean(axis=0)) ** 2, axis=0)
        out["jackknife"] = np.sqrt(var)
    return {k: v.tolist() for k, v in out.items()} | {"names": list(fit.names)}


def summarise(draws: list[dict]) -> dict:
    """Per parameter, the scatters and the root-mean-square errors over the draws."""
    names = draws[0]["names"]
    a = {k: np.array([d[k] for d in draws]) for k in draws[0] if k != "names"}
    rms = lambda x: np.sqrt(np.mean(x ** 2, axis=0))  # noqa: E731
    table = {}
    for i, n in enumerate(names):
        row = {"sd_error": float(np.std(a["floored_error"][:, i], ddof=1)),
               "mean_error": float(np.mean(a["floored_error"][:, i])),
               "rms_se_weights": float(rms(a["se_weights"][:, i])), "rms_se_floored": float(rms(a["se_floored"][:, i])),
               "sd_e_average": float(np.std(a["e_average"][:, i], ddof=1)),
               "sd_e_periods": float(np.std(a["e_periods"][:, i], ddof=1)), "rms_floor": float(rms(a["floor"][:, i]))}
        if "jackknife" in a:
            row["rms_jackknife"] = float(rms(a["jackknife"][:, i]))
        table[n] = row
    return table


def main(argv=None) -> int:
    from jointrig.commands.options import check_levels_db, check_output, refused

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=17, help="the bench's runs: start phases and offsets (default 17)")
    p.add_argument("--draws", type=int, default=20, help="draws of the noise (default 20)")
    p.add_argument("--db", type=float, default=40.0, help="noise level, SNR in dB per channel (default 40)")
    p.add_argument("--channel-noise", type=float, nargs=3, default=[1.0, 1.0, 1.0], metavar=("TORQUE", "PHI1", "PHI2"),
                   help="each channel's noise as a multiple of the level's (default 1 1 1)")
    p.add_argument("--jackknife", action="store_true", help="also each period left out of the average in turn")
    p.add_argument("--json", type=Path, help="write the table here (atomically)")
    args = p.parse_args(argv)
    if args.seed < 0 or args.draws < 2:
        p.exit(2, f"{p.prog}: error: --seed must be >= 0 and --draws at least 2, got {args.seed} and {args.draws}\n")
    if not all(math.isfinite(c) and c >= 0 for c in args.channel_noise) or not any(args.channel_noise):
        p.exit(2, f"{p.prog}: error: --channel-noise takes three multiples >= 0, not all 0\n")
    refused(p, lambda: check_levels_db([args.db]), lambda: check_output(args.json, "--json"))
    from jointrig.files import write_json_atomic

    draws, t0 = [], time.perf_counter()
    for k in range(args.draws):
        draws.append(one_draw(args.seed, k, args.db, tuple(args.channel_noise), args.jackknife))
        print(f"[{k + 1}/{args.draws}] {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    table = summarise(draws)
    cols = ["sd_error", "mean_error", "rms_se_weights", "rms_se_floored", "sd_e_average", "sd_e_periods",
            "rms_floor"] + (["rms_jackknife"] if args.jackknife else [])
    print(f"seed {args.seed}, {args.draws} draws of the noise at {args.db:g} dB (channels x "
          f"{' '.join(f'{c:g}' for c in args.channel_noise)}), the structure given, the twist's zero at the truth")
    print(f"  {'parameter':26s}" + "".join(f"{c:>16s}" for c in cols))
    for n, row in table.items():
        print(f"  {n:26s}" + "".join(f"{row[c]:16.4g}" for c in cols))
    if args.json is not None:
        write_json_atomic(args.json, {"seed": args.seed, "draws": args.draws, "db": args.db,
                                      "channel_noise": list(args.channel_noise), "table": table})
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
