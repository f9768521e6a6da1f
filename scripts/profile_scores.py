#!/usr/bin/env python3
"""Does a profiled parameter's standard error miss correlations between harmonics?

    python scripts/profile_scores.py [--effect backlash/1] [--db 40] [--seeds 3 6] [--json OUT]

Why: on the independent bench's free play (tests/test_independent_bench.py's paper joint) the half
gap and the stiffness scattered 1.27-1.29 times their standard errors over 100 seeds at 40 and 70
dB alike before the profile's error carried the rows' correlations between equations (1.10-1.15
with it; docs/noisy-measurements.md). One candidate: a law whose stiffness changes along the cycle (none in
the play, k in contact) carries the twist's noise at one harmonic into its column at every
harmonic, and the profile's chi-square (rows weighted one by one) would miss those correlations.

This script measures it without the weights' assumption. For every profile of the diagnosis
(``identify.chain_diagnose._profile``, wrapped here; the library is not changed), at the value
found: the Jacobian of the balance's residual over the linear parameters and the profiled one
(``A`` and ``dA/dh theta``, central difference), and each period's own score ``J_k' W r_k`` (the
run's periods are independent draws of the noise, so their scores' spread is the score's
covariance, every correlation between rows included, across harmonics too). The sandwich
``B Q B`` (``B = (J'WJ)^-1``) gives the profiled parameter's standard error from the data alone;
for a cause at a joint, again with the joint's twist zero free beside it (the diagnosis profiles
the two in turn, each given the other). It prints, per profile: the profile's standard error, the
sandwich's, and their ratio; and, per
seed, the final value of the profiled parameter against the truth, in the profile's standard
errors. A ratio near 1 where the truth lies several standard errors off rules the candidate out.

The files are those of ``scripts/coverage.py --effect CASE`` (two flywheels, 4 fitted runs of 6.5
periods at 2 kHz, runs 2 and 3 held out), diagnosed in this process (one worker: a seed takes
about a minute).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "scripts"), str(ROOT / "tests")]
# one process: the wrapped profile records what it sees here, not in a forked worker
os.environ["JOINTRIG_WORKERS"] = "1"


def period_scores_se(problem, profiled, base, weights, fit, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """The standard errors of the profiled parameters ``profiled`` (``(candidate, value)`` each, the
    first the one profiled) from the periods' own scores, and from ``(J'WJ)^-1`` alone, at their
    values in ``base`` (the linear parameters at ``fit``'s): every one of them free together."""
    theta = np.asarray(fit.values, dtype=float)

    def at(shifts):
        spec = base
        for (cand, value), d in zip(profiled, shifts):
            spec = cand.extend(spec, value + d)
        return spec

    steps = [max(1e-3 * abs(v), 1e-6 * (hi - lo)) for _, v in profiled]
    zero = [0.0] * len(profiled)
    spec = at(zero)
    jumps = problem.jumps(spec, fit.as_dict())
    banded = problem.system(spec, jumps)
    moved = []  # (below, above, step) per profiled parameter
    for k, d in enumerate(steps):
        moved.append(tuple(at([(s if i == k else 0.0) for i in range(len(profiled))]) for s in (-d, d)) + (d,))
    cols = [(problem.system(up, jumps).system.A - problem.system(down, jumps).system.A) @ theta / (2 * d)
            for down, up, d in moved]
    J = np.column_stack([banded.system.A] + cols)
    B = np.linalg.pinv(J.T @ (J * weights[:, None]))
    Q = np.zeros_like(B)
    per = [list(problem.period_systems(spec, banded, jumps))] + [
        (list(problem.period_systems(down, banded, jumps)), list(problem.period_systems(up, banded, jumps)), d)
        for down, up, d in moved]
    for i, (rows, As, Fs, _, _) in enumerate(per[0]):
        P = As.shape[0]
        extra = [((m[1][i][1] - m[0][i][1]) @ theta / (2 * m[2]))[:, :, None] for m in per[1:]]
        Jk = np.concatenate([As] + extra, axis=2)
        g = np.einsum("kmi,m,km->ki", Jk, weights[rows], Fs - As @ theta)
        dg = g - g.mean(axis=0)
        Q += dg.T @ dg / (P * (P - 1))
    cov = B @ Q @ B
    n = len(profiled)
    return (np.sqrt(np.clip(np.diag(cov)[-n:], 0.0, None)), np.sqrt(np.clip(np.diag(B)[-n:], 0.0, None)))


def _diagnosis(db: float, seed: int, effect: str, tmp: Path, omega_given: bool):
    """``scripts/coverage.py``'s file of ``effect`` (with each run's true frequency in an ``omega``
    column where ``omega_given``) and its diagnosis."""
    import coverage
    from bench_sim import JOINTS, POINTS, measure, with_effect
    from jointrig.measured.runs import read_runs
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    points = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1]
    path = measure(with_effect(JOINTS["paper"], **coverage.effect_case(effect)[0]), points, tmp / "b.csv", seed=seed,
                   fs_Hz=coverage.FS_HZ, n_periods=coverage.N_PERIODS, noise=coverage.noise_fraction(db))
    if omega_given:
        head, *rows = path.read_text().splitlines()
        path.write_text("\n".join([head + ",omega [rad/s]"] + [f"{r},{points[int(r.split(',')[0])][0]!r}" for r in rows])
                        + "\n")
    loaded = read_runs(path)
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]),
                               holdout=coverage.HOLDOUT)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effect", default="backlash/1", help="a paper-joint case of tests/test_independent_bench.py")
    ap.add_argument("--db", type=float, default=40.0, help="noise level, dB below each channel's RMS")
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 6])
    ap.add_argument("--omega-given", action="store_true",
                    help="write each run's true drive frequency in the file (an omega column) instead of letting "
                         "the reader estimate it from the torque")
    ap.add_argument("--json", type=Path, help="write the rows here (atomically)")
    args = ap.parse_args(argv)

    import coverage
    from jointrig.files import write_json_atomic
    from jointrig.identify import chain_diagnose as cd

    try:
        truths = coverage.effect_case(args.effect)[1]
    except KeyError:
        print(f"--effect: no case {args.effect!r}; expected one of {', '.join(coverage.effect_names())}",
              file=sys.stderr)
        return 2
    rows, seen = [], []
    original = cd._profile

    def wrapped(problem, cand, base, weights):
        fit = original(problem, cand, base, weights)
        name, value, se = fit.profiled[0]
        if math.isfinite(se) and value != 0:
            _, lo, hi = cd._search_range(problem, cand)
            scores, plain = (x[0] for x in period_scores_se(problem, [(cand, value)], base, weights, fit, lo, hi))
            together = math.nan
            if cand.at_joint and cand.cause.name != cd.TWIST_ZERO.name:  # the joint's zero free beside it
                zero = cd.Candidate(cd.TWIST_ZERO, cand.where)
                both = period_scores_se(problem, [(cand, value), (zero, base.offsets_rad[cand.place - 1])],
                                        base, weights, fit, lo, hi)[0]
                together = float(both[0])
            print(f"  profile {name} = {value:.6g} +- {se:.3g}: the periods' scores give {scores:.3g}, with the "
                  f"joint's zero free {together:.3g}", file=sys.stderr)
            seen.append({"parameter": name, "value": value, "se_profile": se, "se_scores": scores,
                         "se_plain": plain, "ratio": scores / se, "se_scores_zero_free": together})
        return fit

    cd._profile = wrapped
    try:
        for seed in args.seeds:
            seen.clear()
            print(f"seed {seed}: diagnosing {args.effect} at {args.db:g} dB", file=sys.stderr)
            with tempfile.TemporaryDirectory() as tmp:
                report = _diagnosis(args.db, seed, args.effect, Path(tmp), args.omega_given)
            final = {n: (v, e) for n, v, e in report.diagnosis.final.profiled}
            for name, (value, se) in final.items():
                # the adopted cause's last profile (another cause may profile a parameter of that name:
                # a free play's with damping in contact)
                last = min((s for s in seen if s["parameter"] == name), key=lambda s: abs(s["value"] - value))
                truth = truths.get(name)
                row = {"seed": seed, "verdict": report.verdict.verdict, **last,
                       "truth": truth, "z": (value - truth) / se if truth is not None and se > 0 else None}
                rows.append(row)
                z = "" if row["z"] is None else f", truth {truth:.4g}: z {row['z']:+.2f}"
                free = last["se_scores_zero_free"]
                print(f"seed {seed}: {name} = {value:.5g} +- {se:.3g} (profile); the periods' scores give "
                      f"{last['se_scores']:.3g}, ratio {last['ratio']:.2f}"
                      + (f"; with the joint's zero free {free:.3g}, ratio {free / se:.2f}" if math.isfinite(free) else "")
                      + z)
    finally:
        cd._profile = original
    if args.json:
        write_json_atomic(args.json, {"effect": args.effect, "db": args.db, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
