#!/usr/bin/env python3
"""Is the diagnosis the same whatever zero each sensor had? Every case of the independent bench.

    python scripts/bench_zeros.py [--suite] [--joint paper light] [--case none coulomb_friction/1 ...]
                                  [--seed S] [--json OUT]
    python scripts/bench_zeros.py --chains [--case none backlash/2 ...]   # trains and the carriage
    python scripts/bench_zeros.py --means [--seed S]     # the cell's offset alone, every case, no diagnosis

Why: encoders mounted by hand each have their own zero, a torque cell reads an offset. The
diagnosis takes every angle channel about its mean over the fitted runs (identify/zeros.py) and
leaves every mean out of the balance and the replay, so the verdict, the causes and every
parameter must be those of zeroed sensors, and the zero it reads must be the one the bench added.

Each case of tests/test_independent_bench.py (the paper's and the light joint, no effect and
every catalogued effect at two sizes; scipy, event-driven friction, nothing of jointrig) is
written twice with the same noise: as the bench writes it, and with each encoder's zero drawn
uniform in +-pi and the torque cell's offset uniform in +-2% of the largest drive amplitude.
Both are diagnosed in-process (``studies.chain_validate.run_train_diagnosis``, runs 2 and 3 held
out, as the test does). ``--suite``: only the 11 cases the test suite runs (no effect on both
joints, every effect at its smaller size on one).

``--chains``: the chain benches instead (:func:`_chain_benches`: a 3-body train, the 4-body test
train, the pump train, the carriage on a slide in 9 runs), each encoder's zero uniform in +-pi
(the carriage's position zero too) and every torque or force cell's offset uniform in +-2%. Every
other run of a train (both files) carries a mean drive torque of :data:`MEAN_LOAD_SHARE` of its
amplitude, held by an unmeasured load of the opposite sense at the train's far end (a pump's): it
preloads every joint between them (:func:`_mean_loads`). The carriage has none: a free axis
cannot hold a mean force without a spring to ground.

One row per case: whether the verdicts and the adopted causes agree, the largest
|unzeroed - zeroed| / SE over the parameters (the twist's zero left out), and the twist's zero
read against what the bench added, (read - true) / SE. Where the diagnosis adopts an even
stiffness at the joint, its zero is not read: ``a`` and the zero are one balance under the
cubic, and the report says the two cannot be told apart (the zero only a zeroed file, or
``--zeroed``, gives); the summary counts those cases apart. Progress goes to stderr; ``--json
OUT`` writes the table atomically.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from jointrig.files import write_json_atomic

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

ZERO = "joint1_angle_offset_rad"


def _draws(joint: str, case: str, seed: int) -> tuple:
    """A case's bench, its file's seed, the encoders' zeros (rad) and the cell's offset (N m)."""
    from bench_sim import JOINTS, with_effect
    from test_independent_bench import CASES, _points

    params, _ = CASES[joint][case]
    file_seed = sum(map(ord, joint + case))
    rng = np.random.default_rng([seed, file_seed])
    zeros = rng.uniform(-math.pi, math.pi, 2)
    offset = rng.uniform(-0.02, 0.02) * max(m for _, m in _points(joint))
    return with_effect(JOINTS[joint], **params), file_seed, zeros, offset


def _cell_truth(file_seed: int, offset: float) -> float:
    """The cell's offset in the lab file: the drawn one plus the bench's own (bench_sim.measure's
    first draw: torque, phi1, phi2)."""
    return offset + float(np.random.default_rng(file_seed).uniform(-1, 1, 3)[0] * 0.5)


def _means_case(tmp: Path, joint: str, case: str, seed: int) -> dict:
    """The lab file's drive mean over the fitted runs against the cell's offset (no diagnosis:
    :func:`identify.zeros.sensor_zeros` on the runs the diagnosis fits)."""
    from bench_sim import measure
    from test_independent_bench import HOLDOUT, _points

    from jointrig.identify.zeros import sensor_zeros
    from jointrig.measured.runs import read_runs

    bench, file_seed, zeros, offset = _draws(joint, case, seed)
    path = measure(bench, _points(joint), tmp / "lab.csv", seed=file_seed, fs_Hz=2000.0, n_periods=6.5,
                   transform=lambda t, T, p1, p2: (t, T + offset, p1 + zeros[0], p2 + zeros[1]))
    fitted = [r for i, r in enumerate(read_runs(path).records) if i not in HOLDOUT]
    zs = sensor_zeros(fitted)
    return {"joint": joint, "case": case, "torque_offset_true_Nm": _cell_truth(file_seed, offset),
            "torque_mean_Nm": zs.torques[0], "torque_se_Nm": zs.torque_se[0]}


def _case(tmp: Path, joint: str, case: str, seed: int) -> dict:
    from bench_sim import JOINTS, measure, with_effect
    from test_independent_bench import CASES, HOLDOUT, _points

    from jointrig.measured.runs import read_runs
    from jointrig.present.train_report import reported_values
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    bench, file_seed, zeros, offset = _draws(joint, case, seed)

    def diagnosed(name, transform=None):
        path = measure(bench, _points(joint), tmp / name, seed=file_seed, fs_Hz=2000.0, n_periods=6.5,
                       transform=transform)
        loaded = read_runs(path)
        return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=HOLDOUT)

    zeroed = diagnosed("zeroed.csv")
    lab = diagnosed("lab.csv", lambda t, T, p1, p2: (t, T + offset, p1 + zeros[0], p2 + zeros[1]))
    want, got = reported_values(zeroed.diagnosis.final, zeroed), reported_values(lab.diagnosis.final, lab)
    worst = max((abs(v - want[n][0]) / want[n][1] for n, (v, _) in got.items()
                 if n != ZERO and n in want and math.isfinite(want[n][1]) and want[n][1] > 0), default=math.nan)
    bench_offsets = np.random.default_rng(file_seed).uniform(-1, 1, 3) * np.array([0.5, 2e-3, 2e-3])
    z_read, z_se = got.get(ZERO, (lab.zeros.twists[0], lab.zeros.twist_se[0]))
    z_true = zeros[0] - zeros[1] + bench_offsets[1] - bench_offsets[2]
    t_mean, t_se = lab.zeros.torques[0], lab.zeros.torque_se[0]
    # an even stiffness adopted at the joint and its zero are one balance under the cubic (the
    # report says the two cannot be told apart): the mean twist then reads no sensor's zero
    told = not _zero_told_apart_from(lab, 1)
    return {"joint": joint, "case": case, "verdict": lab.verdict.verdict, "zeroed_verdict": zeroed.verdict.verdict,
            "causes": [s.label for s in lab.diagnosis.steps],
            "zeroed_causes": [s.label for s in zeroed.diagnosis.steps],
            "worst_parameter_z": worst, "zero_true_rad": z_true, "zero_read_rad": z_read, "zero_se_rad": z_se,
            "zero_z": (z_read - z_true) / z_se if z_se > 0 and not told else math.nan, "zero_told_apart": not told,
            "torque_offset_true_Nm": _cell_truth(file_seed, offset), "torque_mean_Nm": t_mean, "torque_se_Nm": t_se}


#: The chain benches (tests/bench_chain_sim.py, tests/bench_slide_sim.py): name -> (bench, points,
#: held-out run indices). A 3-body train (the test train's first three bodies: modes 81 and 196
#: rad/s), the 4-body test train of tests/chain_cases.py, the pump train (motor side, no pump
#: cell), and the 12 kg carriage in 9 runs. Points are (omega rad/s, amplitude N m, driven body).
TRAIN3_POINTS = ((45.0, 100.0, 1), (80.0, 100.0, 1), (130.0, 100.0, 1), (196.0, 100.0, 1), (80.0, 100.0, 3),
                 (196.0, 100.0, 3), (100.0, 150.0, 1), (160.0, 150.0, 3))


def _chain_benches():
    from bench_chain_sim import PUMP_POINTS, PUMP_TRAIN, TRAIN, Train, with_effect
    from bench_slide_sim import Carriage
    from chain_cases import ESTIMATION, HELD_OUT

    train3 = Train(J=TRAIN.J[:3], joints=TRAIN.joints[:2], b=(0.0, 0.0, 0.0))
    t3 = (TRAIN3_POINTS, (6, 7))
    t4 = (ESTIMATION + HELD_OUT, (len(ESTIMATION), len(ESTIMATION) + 1))
    pump = ([p for p in PUMP_POINTS if p[2] == 1], None)
    slide = ([(w, F) for w in (6.283, 12.566, 25.13) for F in (80.0, 150.0, 300.0)], None)
    return {
        "train3 none": (train3, *t3),
        "train3 coulomb_friction/1": (with_effect(train3, 1, Fc=4.0), *t3),
        "train4 none": (TRAIN, *t4),
        "train4 backlash/2": (with_effect(TRAIN, 2, gap=0.003), *t4),
        "train4 coulomb_friction/3": (with_effect(TRAIN, 3, Fc=4.0), *t4),
        "pump none": (PUMP_TRAIN, *pump),
        "pump backlash/2": (with_effect(PUMP_TRAIN, 2, gap=1e-3), *pump),
        "slide none": (Carriage(Fc=0.0), *slide),
        "slide coulomb_friction": (Carriage(), *slide),
    }


#: A train run's mean drive torque, as a share of its amplitude (every other run).
MEAN_LOAD_SHARE = 0.15


def _mean_loads(points, N: int) -> list:
    """Per run, each body's constant torque (N m): in every other run a mean drive torque on the
    driven body and the opposite load at the far end of the train (they sum to 0: a train free
    to turn), none in the others."""
    out = []
    for r, (_, M0, i) in enumerate(points):
        loads = [0.0] * N
        if r % 2:
            loads[i - 1], loads[(N if i == 1 else 1) - 1] = MEAN_LOAD_SHARE * M0, -MEAN_LOAD_SHARE * M0
        out.append(tuple(loads))
    return out


def _chain_case(tmp: Path, name: str, seed: int) -> dict:
    """One chain bench written zeroed and as a lab has it (every encoder's zero uniform in +-pi,
    every torque or force cell's offset uniform in +-2% of the largest amplitude; a train's runs with
    :func:`_mean_loads` in both), both diagnosed."""
    from bench_chain_sim import daq_file
    from bench_slide_sim import daq_runs

    from jointrig.measured.runs import read_runs
    from jointrig.present.train_report import reported_values
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    bench, points, holdout = _chain_benches()[name]
    slide = name.startswith("slide")
    rng = np.random.default_rng([seed, sum(map(ord, name))])
    n = 1 if slide else bench.N
    zeros = rng.uniform(-math.pi, math.pi, n)
    offset = rng.uniform(-0.02, 0.02) * max(p[1] for p in points)
    loads = None if slide else _mean_loads(points, n)

    def diagnosed(file, lab: bool):
        if slide:
            path = daq_runs(bench, points, tmp / file, seed=seed, at_rest_m=float(zeros[0]) if lab else 0.0,
                            force_offset_N=offset if lab else 0.0)
            loaded, rig = read_runs(path), rig_of_bodies(1, [1], "slide")
        else:
            path = daq_file(bench, points, tmp / file, seed=seed, offsets_rad=tuple(zeros) if lab else (0.0,) * n,
                            cell_offset_Nm=offset if lab else 0.0, loads_by_run=loads)
            loaded = read_runs(path, columns={"time": "t"})
            rig = rig_of_bodies(n, sorted({p[2] for p in points}))
        return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig, holdout=holdout)

    zeroed, lab = diagnosed("zeroed.csv", False), diagnosed("lab.csv", True)
    want, got = reported_values(zeroed.diagnosis.final, zeroed), reported_values(lab.diagnosis.final, lab)
    worst = max((abs(v - want[k][0]) / want[k][1] for k, (v, _) in got.items()
                 if not k.endswith("angle_offset_rad") and k in want and math.isfinite(want[k][1])
                 and want[k][1] > 0), default=math.nan)
    # each profiled twist's zero against the encoders' (their difference), the cells' means against the offset
    zero_z, untold = [], 0
    for k, (v, se) in got.items():
        if k.startswith("joint") and k.endswith("angle_offset_rad") and se > 0:
            j = int(k[len("joint"):k.index("_")])  # joint j between encoders j and j + 1
            if _zero_told_apart_from(lab, j):
                zero_z.append((v - (zeros[j - 1] - zeros[j])) / se)
            else:
                untold += 1
    # a driven cell's mean over the fitted runs: its offset plus the mean drive torque those runs held
    fitted = [r for r in range(len(points)) if r not in lab.held_out]
    held = [float(np.mean([loads[r][b] for r in fitted])) if loads else 0.0 for b in range(n)]
    cells = [(m - offset - held[b]) / se for b, (m, se) in enumerate(zip(lab.zeros.torques, lab.zeros.torque_se))
             if math.isfinite(m) and se > 0]
    return {"joint": name.split()[0], "case": name.split()[1], "verdict": lab.verdict.verdict,
            "zeroed_verdict": zeroed.verdict.verdict, "causes": [s.label for s in lab.diagnosis.steps],
            "zeroed_causes": [s.label for s in zeroed.diagnosis.steps], "worst_parameter_z": worst,
            "zero_z": max(zero_z, key=abs) if zero_z else math.nan, "zeros_not_told_apart": untold,
            "torque_z": max(cells, key=abs) if cells else math.nan, "encoder_zeros_rad": zeros.tolist(),
            "cell_offset": offset}


def _zero_told_apart_from(report, joint: int) -> bool:
    """Whether the diagnosis tells joint ``joint``'s zero apart from its law: not where it adopted
    an even stiffness there (a cause that reads as an offset, ``Cause.reads_as_offset``), whose
    ``a`` and the zero are one balance under the cubic."""
    from jointrig.identify.causes import by_name

    return not any(by_name(s.effect).reads_as_offset and s.where is not None and s.where.at_joint
                   and s.where.number == joint for s in report.diagnosis.steps)


def _print_means(rows: list, json_path, seed: int) -> int:
    """The cell's offset read against the truth, case by case, and how often within 1.96 and 3 SE."""
    zs = []
    for r in rows:
        z = (r["torque_mean_Nm"] - r["torque_offset_true_Nm"]) / r["torque_se_Nm"]
        zs.append(z)
        print(f"{r['joint']:6s} {r['case']:26s} read {r['torque_mean_Nm']:+10.4f} +- {r['torque_se_Nm']:.3g} N m, "
              f"true {r['torque_offset_true_Nm']:+10.4f}: z {z:+6.2f}")
    a = np.abs(zs)
    print(f"\nthe cell's offset within 1.96 SE in {np.sum(a <= 1.96)} of {a.size}, within 3 in {np.sum(a <= 3)}; "
          f"median |z| {np.median(a):.2f} (0.67 calibrated)")
    if json_path:
        write_json_atomic(json_path, {"seed": seed, "rows": rows})
    return 0


def main(argv=None) -> int:
    from test_independent_bench import CASES, SUITE

    from jointrig.rig.runtime import limit_threads

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--chains", action="store_true",
                   help="the chain benches instead (3- and 4-body trains, the pump train, the carriage)")
    p.add_argument("--joint", nargs="+", choices=sorted(CASES), default=sorted(CASES))
    p.add_argument("--case", nargs="+", help="cases of tests/test_independent_bench.py (default: all)")
    p.add_argument("--suite", action="store_true", help="only the cases the test suite runs")
    p.add_argument("--means", action="store_true",
                   help="the torque cell's offset alone, read from the fitted runs' means (no diagnosis: seconds a case)")
    p.add_argument("--seed", type=int, default=49, help="seed of the zeros and offsets (default: %(default)s)")
    p.add_argument("--json", type=Path, help="write the table (JSON, atomically)")
    args = p.parse_args(argv)
    limit_threads()
    rows = []
    if args.chains:
        todo = [tuple(name.split()) for name in _chain_benches() if not args.case or name.split()[1] in args.case]
    else:
        todo = [(j, c) for j in args.joint for c in (args.case or CASES[j]) if c in CASES[j]
                and (not args.suite or (j, c) in SUITE)]
    if not todo:
        print("bench_zeros: no such case (see tests/test_independent_bench.py CASES)", file=sys.stderr)
        return 2
    if args.means and not args.chains:
        for j, c in todo:
            with tempfile.TemporaryDirectory() as tmp:
                rows.append(_means_case(Path(tmp), j, c, args.seed))
        return _print_means(rows, args.json, args.seed)
    print(f"{'joint':6s} {'case':26s} {'verdict':11s} {'same':5s} {'worst z':>8s} {'zero z':>7s} "
          f"{'torque z':>8s}  causes")
    for k, (joint, case) in enumerate(todo, start=1):
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            r = _chain_case(Path(tmp), f"{joint} {case}", args.seed) if args.chains else \
                _case(Path(tmp), joint, case, args.seed)
        rows.append(r)
        same = r["verdict"] == r["zeroed_verdict"] and r["causes"] == r["zeroed_causes"]
        tz = r["torque_z"] if args.chains else (r["torque_mean_Nm"] - r["torque_offset_true_Nm"]) / r["torque_se_Nm"]
        print(f"{joint:6s} {case:26s} {r['verdict']:11s} {str(same):5s} {r['worst_parameter_z']:8.2g} "
              f"{r['zero_z']:7.2g} {tz:8.2g}  {', '.join(r['causes']) or '-'}", flush=True)
        print(f"[{k}/{len(todo)}] {joint} {case}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    same = sum(r["verdict"] == r["zeroed_verdict"] and r["causes"] == r["zeroed_causes"] for r in rows)
    untold = sum((not r["zero_told_apart"]) if "zero_told_apart" in r else r["zeros_not_told_apart"] for r in rows)
    print(f"\nsame verdict and causes: {same} of {len(rows)}; parameters within 3 SE of the zeroed: "
          f"{sum(r['worst_parameter_z'] <= 3 for r in rows)} of {len(rows)}; zero within 3 SE: "
          f"{sum(abs(r['zero_z']) <= 3 for r in rows)} of {sum(math.isfinite(r['zero_z']) for r in rows)} read"
          + (f" ({untold} not told apart from an even stiffness, as the report says)" if untold else ""))
    if args.json:
        write_json_atomic(args.json, {"seed": args.seed, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
