#!/usr/bin/env python3
"""Coverage of the diagnosis's 95% intervals over seeds, on files of the independent bench.

    python scripts/coverage.py [--bench flywheels|slide] [--seeds N] [--first-seed S] [--db 20 40 70]
                               [--friction NM | --effect CASE [--given-structure [--measured-fidelity]]] [--out DIR] [--workers W]
                               [--json OUT]

Why: a standard error is only worth printing if value +- 1.96 SE holds the truth 95% of the
time. The two-flywheel paper joint with 20 N m of dry friction (tests/bench_sim.py: scipy,
event-driven stick-slip, a DAQ's CSV with sensor offsets) is measured at each noise level with
N seeds (a seed draws the white noise, the sensor offsets and the start phases), 6 runs (3
frequencies x 1500 and 3500 N m, the middle frequency held out), and diagnosed as
``jointrig diagnose`` does (``studies.chain_validate.run_train_diagnosis``). For every reported
parameter with a known truth (J1, J2 = 2 kg m^2; c = 100 N m s/rad, k = 2000 N m/rad, gamma =
200 N m/rad^3, Coulomb 20 N m; the twist's zero: the DAQ's drawn offsets phi1 - phi2), read
as the report and the JSON print it (for the zero: the mean taken out first plus the fit's), it
records whether the truth lies in the reported 95% interval (value +- t SE, t Student's quantile
at the standard error's degrees of freedom, :meth:`Estimates.interval`; 1.96 where the error is
taken as known), and prints per parameter and level the share covered with its binomial standard
error, the median z = (value - truth) / SE (median |z| is 0.674 for a calibrated Gaussian
estimate), the median t and the share within 1.96 SE. ``--friction 0`` measures the same joint without
its friction (a right model then adopts nothing), to tell what the friction's own handling (the
stick masks, the kinks restored) costs the intervals.

``--effect CASE``: the same two flywheels with one effect of tests/test_independent_bench.py's
paper joint instead of the friction (``backlash/1``, ``stribeck_friction/1``, ``micro_slip/1``,
``drive_delay/1``, ...; its magnitudes are truths too): the coverage of the causes' profiled
parameters (a free play's half gap, a Stribeck speed, an Iwan slip angle, a delay), whose
standard error comes from the profile's curvature, not from the linear fit's covariance.
``--given-structure`` fits the bench's own structure instead of diagnosing (the twist's zero and
the effect's cause at joint 1 profiled, refined, compensated and widened as the diagnosis does its
final model, :func:`given_structure`), on the fitted runs, with the balance's fidelity a fixed
floor of 1e-6: the intervals given the right structure, about 7 s a seed instead of a minute, so
that 100 seeds at three levels take minutes; ``--measured-fidelity`` then fits it again with the
fidelity measured on that fit's noise-free replay in the rig, as the diagnosis weighs its rows (a
few seconds more a seed). The structure a diagnosis adopts is measured without it.

``--bench slide``: the carriage on a guide instead (tests/bench_slide_sim.py: 12 kg, 40 N s/m,
25 N of dry friction by default, scipy with exact stick-slip events, positions in mm with the
sensor's own zero), 9 runs (3 frequencies x 80, 150, 300 N, scripts/bench_calibration.py's), the
default hold-out; the truths are the mass, the guide's drag and the friction.

A noise level L dB is white noise of standard deviation 10^(-L/20) times each channel's RMS
(tests/bench_sim.py ``noise``): 20 dB is 10%, 40 dB 1%, 70 dB 0.032%.

Resumable: ``--out DIR`` keeps one small JSON per (level, seed), written atomically, and cases
whose file exists are not run again. Cases run in ``--workers`` processes (default 2); progress
goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time

from jointrig.files import write_json_atomic
from jointrig.identify.estimates import interval_factor
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: The bench's truth (tests/bench_sim.py PAPER with Fc = 20 N m); the twist's zero is per seed.
FRICTION_Nm = 20.0
TRUTH = {"J1_kgm2": 2.0, "J2_kgm2": 2.0, "joint1_c_Nms_per_rad": 100.0, "joint1_k_Nm_per_rad": 2000.0,
         "joint1_gamma_Nm_per_rad3": 200.0, "joint1_coulomb_torque_Nm": FRICTION_Nm}
OFFSET = "joint1_angle_offset_rad"
RIGHT_STEP = "coulomb_friction at joint 1"
HOLDOUT = (2, 3)
FS_HZ = 2000.0
N_PERIODS = 6.5
Z95 = 1.96


def noise_fraction(db: float) -> float:
    """Noise standard deviation relative to each channel's RMS at an SNR of ``db`` dB."""
    return 10.0 ** (-db / 20.0)


#: The carriage (tests/bench_slide_sim.py Carriage) as the diagnosis names it (the project's
#: names: the mass as J1, the guide's drag as bearing 1's, the friction to ground at body 1).
SLIDE_FRICTION_N = 25.0
SLIDE_TRUTH = {"J1_kgm2": 12.0, "bearing1_damping_Nms_per_rad": 40.0, "ground1_coulomb_torque_Nm": SLIDE_FRICTION_N}
SLIDE_STEP = "coulomb_friction to ground at body 1"
#: each channel's noise (torque, phi1, phi2) as a multiple of the level's: the level's on every one
CHANNELS = (1.0, 1.0, 1.0)


def case_path(out: Path, db: float, seed: int, friction_Nm: float = FRICTION_Nm, bench: str = "flywheels",
              effect: str | None = None, given: bool = False, channels: tuple = CHANNELS, measured: bool = False) -> Path:
    """One case's record (the friction in the name where it is not the bench's default, the
    effect where there is one, whether its structure was given and with a measured fidelity, and
    the channels' noise where it is not the level's on every channel)."""
    ch = "" if tuple(channels) == CHANNELS else "_ch" + "-".join(f"{c:g}" for c in channels)
    if effect is not None:
        mode = ("_given_measured" if measured else "_given") if given else ""
        return out / f"db{db:g}_{effect.replace('/', '-')}{mode}{ch}_seed{seed:04d}.json"
    if bench == "slide":
        fc = "" if friction_Nm == SLIDE_FRICTION_N else f"_fc{friction_Nm:g}"
        return out / f"slide_db{db:g}{fc}_seed{seed:04d}.json"
    fc = "" if friction_Nm == FRICTION_Nm else f"_fc{friction_Nm:g}"
    return out / f"db{db:g}{fc}{ch}_seed{seed:04d}.json"




def _twist_zero_rad(seed: int) -> float:
    """The twist's zero the DAQ wrote (bench_sim.measure's first draw: the offsets of torque,
    phi1, phi2): phi1's minus phi2's, the reading of the twist at zero twist."""
    import numpy as np

    offsets = np.random.default_rng(seed).uniform(-1, 1, 3) * np.array([0.5, 2e-3, 2e-3])
    return float(offsets[1] - offsets[2])


def truth_of(friction_Nm: float, bench: str = "flywheels") -> dict:
    """The parameters with a known truth for a bench with ``friction_Nm`` of dry friction."""
    base, name = (SLIDE_TRUTH, "ground1_coulomb_torque_Nm") if bench == "slide" else (TRUTH, "joint1_coulomb_torque_Nm")
    return {k: v for k, v in base.items() if k != name} | ({name: friction_Nm} if friction_Nm > 0 else {})


def effect_case(effect: str) -> tuple[dict, dict]:
    """The bench parameters of tests/test_independent_bench.py's paper-joint case ``effect`` and
    its truths as the diagnosis names them (joint 1's)."""
    sys.path[:0] = [str(ROOT / "tests")]
    from test_independent_bench import CASES
    from jointrig.vocab.params import train_name

    bench, magnitudes = CASES["paper"][effect]
    truth = {k: v for k, v in TRUTH.items() if k != "joint1_coulomb_torque_Nm"}
    if "c" in bench:  # damping only in contact: none within the gap
        truth["joint1_c_Nms_per_rad"] = bench["c"]
    return bench, truth | {train_name(k): v for k, v in magnitudes.items()}


def effect_names() -> list[str]:
    """The paper joint's cases with one effect (``--effect``)."""
    sys.path[:0] = [str(ROOT / "tests")]
    from test_independent_bench import CASES

    return [c for c in CASES["paper"] if c != "none"]


def _flywheel_file(db: float, seed: int, friction_Nm: float, tmp: Path, effect: str | None = None,
                   channels: tuple = CHANNELS, noise_seed: int | None = None) -> Path:
    """The two flywheels' runs (with ``effect``, else ``friction_Nm`` of dry friction) written as a
    DAQ does, each channel's noise the level's times its entry of ``channels`` (torque, phi1,
    phi2); ``noise_seed``: the noise drawn apart from ``seed``'s runs (``bench_sim.measure``)."""
    bench = effect_case(effect)[0] if effect is not None else {"Fc": friction_Nm}  # (puts tests/ on the path)
    from bench_sim import JOINTS, POINTS, measure, with_effect

    points = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1]
    return measure(with_effect(JOINTS["paper"], **bench), points, tmp / "b.csv", seed=seed, fs_Hz=FS_HZ,
                   n_periods=N_PERIODS, noise=tuple(noise_fraction(db) * c for c in channels), noise_seed=noise_seed)


def _flywheel_diagnosis(db: float, seed: int, friction_Nm: float, tmp: Path, effect: str | None = None,
                        channels: tuple = CHANNELS):
    """The two flywheels' runs written as a DAQ does, and their diagnosis."""
    from jointrig.measured.runs import read_runs
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    loaded = read_runs(_flywheel_file(db, seed, friction_Nm, tmp, effect, channels))
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=HOLDOUT)


def _slide_diagnosis(db: float, seed: int, friction_N: float, tmp: Path):
    """The carriage's runs written as a DAQ does, and their diagnosis."""
    from bench_calibration import SLIDE_POINTS
    from bench_slide_sim import Carriage, daq_runs
    from jointrig.measured.runs import read_runs
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_validate import run_train_diagnosis

    path = daq_runs(Carriage(Fc=friction_N), SLIDE_POINTS, tmp / "axis.csv", snr_db=db, seed=seed)
    loaded = read_runs(path)
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(1, [1], "slide"))


def given_structure(db: float, seed: int, effect: str, tmp: Path, channels: tuple = CHANNELS,
                    measured: bool = False) -> dict:
    """The two flywheels' file with ``effect`` (:func:`_flywheel_file`), its fitted runs read, and the bench's own structure fitted as the diagnosis fits its final model
    (``identify.chain_diagnose.diagnose_chain``: the twist's zero profiled on the nominal model,
    the effect's cause at joint 1 (a drive's lag at the drives) profiled beside it, both refined, the fit compensated and every
    linear error widened by the profiled ones), the fidelity a fixed floor of 1e-6 of each run's
    largest term (below the noise of every level here); ``measured``: then fitted again with the
    fidelity measured as the diagnosis measures it, the balance's misfit on that fit's noise-free
    replay in the rig (``studies.chain_validate.rig_replay``, ``balance_fidelity``; the fixed floor
    where no run replays). Returns ``{name: (value, SE)}``, the twist's zero on the DAQ's own
    sensors (no mean is taken out), ``chi2_per_dof`` and ``fidelity`` (the relative misfit, or the
    floor)."""
    from dataclasses import replace

    from jointrig.identify import chain_diagnose as cd
    from jointrig.identify.causes import Place, by_name
    from jointrig.measured.runs import read_runs

    path = _flywheel_file(db, seed, 0.0, tmp, effect, channels)
    records = [r for k, r in enumerate(read_runs(path).records) if k not in HOLDOUT]
    runs = tuple(cd.prepare_chain_runs(records))
    nu = 2.0 * (min(r.n_periods for r in runs) - 1)
    zero = cd.Candidate(cd.TWIST_ZERO, Place("joint", 1))
    law = by_name(effect.split("/")[0])
    at_drive = any(c.name == law.name for c in cd.DRIVE_CAUSES)  # a lag of the drives, not of the joint
    cause = cd.Candidate(law, Place("drive", None) if at_drive else Place("joint", 1))

    def fitted(fidelity):
        problem = cd._Problem(runs, 20, nu, fidelity, (False, False), (False,))
        nominal, w = problem.fit(cd.nominal_spec(2))
        spec, zeroed, _ = cd._twist_zeros(problem, [zero], nominal.spec, w)
        nominal, w = problem.fit(spec)
        found = cd._profile(problem, cause, nominal.spec, w) if cause.cause.bounds is not None else \
            problem.solve(cause.extend(nominal.spec, 0.0), w)
        fit, w = problem.fit(found.spec)
        fit = replace(fit, profiled=zeroed + found.profiled)
        adopted = [zero, cause] if cause.cause.bounds is not None else [zero]
        fit, w = cd._refine(problem, adopted, fit, w)
        fit, w = problem.settled(fit, w)
        return cd._widened(problem, adopted, problem.compensated(fit, w), w)

    fit, fidelity = fitted(1e-6), 1e-6
    if measured:
        from jointrig.rig.chain import rig_of_bodies
        from jointrig.studies.chain_validate import rig_replay

        got = rig_replay(rig_of_bodies(2, [1]), runs, 20)(fit)
        if not isinstance(got, tuple):  # (a tuple: why no run replayed; the floor stands)
            table = cd.balance_fidelity(got, fit, 20, (False, False), (False,))
            fit, fidelity = fitted(table), table.relative
    out = {n: (float(v), float(e)) for n, v, e in zip(fit.names, fit.values, fit.std_errors)}
    out.update({n: (float(v), float(e)) for n, v, e in fit.profiled})
    return {"values": out, "chi2_per_dof": fit.chi2 / max(fit.dof, 1),
            "dofs": {n: fit.std_error_dof(n) for n in out}, "fidelity": fidelity}


def run_case(db: float, seed: int, out: str, friction_Nm: float = FRICTION_Nm, bench: str = "flywheels",
             effect: str | None = None, given: bool = False, channels: tuple = CHANNELS, measured: bool = False) -> dict:
    """One diagnosis (in a worker process); its record is written to ``out`` and returned."""
    os.environ["JOINTRIG_WORKERS"] = "1"  # one process per case: no forked scoring inside
    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "scripts")]
    from jointrig.present.train_report import reported_values
    from jointrig.rig.runtime import limit_threads

    limit_threads()
    t0 = time.perf_counter()
    rec = {"bench": bench, "db": db, "seed": seed, "noise_fraction": noise_fraction(db), "friction_Nm": friction_Nm,
           "channel_noise": list(channels)}
    if effect is not None:
        rec.update(effect=effect, friction_Nm=0.0)
        truth = dict(effect_case(effect)[1], **{OFFSET: _twist_zero_rad(seed)})
    elif bench == "slide":
        truth = truth_of(friction_Nm, bench)
    else:
        truth = dict(truth_of(friction_Nm), **{OFFSET: _twist_zero_rad(seed)})
    rec["truth"] = truth
    try:
        if given:
            with tempfile.TemporaryDirectory() as tmp:
                g = given_structure(db, seed, effect, Path(tmp), channels, measured)
            values, dofs = g["values"], g["dofs"]
            rec.update(verdict="given", steps=[f"{effect.split('/')[0]} at joint 1"], effects=[effect.split("/")[0]],
                       chi2_per_dof=g["chi2_per_dof"], fidelity=g["fidelity"], given_structure=True,
                       measured_fidelity=measured)
        else:
            with tempfile.TemporaryDirectory() as tmp:
                r = (_slide_diagnosis(db, seed, friction_Nm, Path(tmp)) if bench == "slide" else
                     _flywheel_diagnosis(db, seed, friction_Nm, Path(tmp), effect, channels))
            d = r.diagnosis
            values = reported_values(d.final, r)  # as the JSON prints them: a twist's zero on the user's sensors
            dofs = {n: d.final.std_error_dof(n) for n in values}
            rec.update(verdict=r.verdict.verdict, steps=[s.label for s in d.steps], effects=[s.effect for s in d.steps],
                       chi2_per_dof=float(d.reduced_chi2(d.final)), fidelity=getattr(d.fidelity, "relative", None))
        rec.update(parameters={k: float(v) for k, (v, _) in values.items()},
                   std_errors={k: float(e) for k, (_, e) in values.items()},
                   std_error_dofs={k: (float(d) if math.isfinite(d) else None) for k, d in dofs.items()})
    except Exception as err:  # a failed case is recorded, counted and reported, not retried
        rec["error"] = f"{type(err).__name__}: {err}"
    rec["wall_s"] = time.perf_counter() - t0
    write_json_atomic(case_path(Path(out), db, seed, friction_Nm, bench, effect, given, channels, measured), rec)
    return rec


def right_structure(r: dict) -> bool:
    """The final model is the bench's: dry friction at the joint (the carriage's guide) adopted
    where it has one, the effect alone where the bench has one (``--effect``), nothing else."""
    if r.get("effect") is not None:
        return r.get("effects") == [r["effect"].split("/")[0]]
    step = SLIDE_STEP if r.get("bench") == "slide" else RIGHT_STEP
    return r.get("steps") == ([step] if r.get("friction_Nm", FRICTION_Nm) > 0 else [])


def summarise(records: list[dict], levels: list[float], right_only: bool = False) -> dict:
    """Per level and parameter: n, share covered, its binomial SE, median z and |z|; with
    ``right_only`` over the seeds whose final model has the bench's structure only."""
    table = {}
    for db in levels:
        recs = [r for r in records if r["db"] == db and (not right_only or right_structure(r))]
        ok = [r for r in recs if "error" not in r]
        level = {"n_cases": len(recs), "n_failed": len(recs) - len(ok),
                 "n_friction_adopted": sum(any(n.endswith("coulomb_torque_Nm") for n in r["parameters"]) for r in ok),
                 "n_right_structure": sum(right_structure(r) for r in ok),
                 "verdicts": {v: sum(r["verdict"] == v for r in ok) for v in sorted({r["verdict"] for r in ok})},
                 "median_chi2_per_dof": statistics.median(r["chi2_per_dof"] for r in ok) if ok else math.nan,
                 "parameters": {}}
        for name in dict.fromkeys(n for r in recs for n in r["truth"]):
            zs, factors, no_se = [], [], 0
            for r in ok:
                if name not in r["parameters"] or name not in r["truth"]:  # (a friction adopted where none is)
                    continue
                se = r["std_errors"].get(name)
                if se is None or not math.isfinite(se) or se <= 0:  # no interval stated: counted apart
                    no_se += 1
                    continue
                zs.append((r["parameters"][name] - r["truth"][name]) / se)
                dof = r.get("std_error_dofs", {}).get(name)
                factors.append(interval_factor(math.inf if dof is None else dof))
            n = len(zs)
            if not n:
                level["parameters"][name] = {"n": 0, "n_without_std_error": no_se}
                continue
            p = sum(abs(z) <= f for z, f in zip(zs, factors)) / n
            p_normal = sum(abs(z) <= Z95 for z in zs) / n
            level["parameters"][name] = {"n": n, "n_without_std_error": no_se, "covered": p, "binomial_se": math.sqrt(p * (1 - p) / n),
                                         "covered_at_1.96": p_normal, "median_factor": statistics.median(factors),
                                         "median_z": statistics.median(zs),
                                         "median_abs_z": statistics.median(abs(z) for z in zs)}
        table[f"{db:g}"] = level
    return table


def print_table(table: dict) -> None:
    for db, level in table.items():
        print(f"\n{db} dB (noise {noise_fraction(float(db)):.3%} of each channel's RMS): {level['n_cases']} seeds, "
              f"{level['n_failed']} failed; verdicts {level['verdicts']}; coulomb_friction adopted in "
              f"{level['n_friction_adopted']}; the bench's structure in {level.get('n_right_structure', '-')}; "
              f"median chi2/dof {level['median_chi2_per_dof']:.3f}")
        print(f"  {'parameter':28s} {'n':>4s} {'covered':>8s} {'+-':>6s} {'median z':>9s} {'median |z|':>10s} "
              f"{'t (median)':>10s} {'at 1.96':>8s}")
        for name, s in level["parameters"].items():
            apart = f"  ({s['n_without_std_error']} without a standard error)" if s["n_without_std_error"] else ""
            if not s["n"]:
                print(f"  {name:28s} {0:4d}        -{apart}")
                continue
            flag = ("" if 0.90 <= s["covered"] <= 0.98 else "  <- outside 90-98%") + apart
            print(f"  {name:28s} {s['n']:4d} {s['covered']:8.1%} {s['binomial_se']:6.1%} {s['median_z']:9.2f} "
                  f"{s['median_abs_z']:10.2f} {s.get('median_factor', Z95):10.2f} {s.get('covered_at_1.96', math.nan):8.1%}{flag}")


def parse(argv) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, default=100, help="seeds per level (default 100)")
    p.add_argument("--first-seed", type=int, default=0, help="the first seed (default 0)")
    p.add_argument("--db", type=float, nargs="+", default=[20.0, 40.0, 70.0],
                   help="noise levels, SNR in dB per channel (default 20 40 70)")
    p.add_argument("--bench", choices=("flywheels", "slide"), default="flywheels",
                   help="two flywheels (default) or the carriage on a guide")
    p.add_argument("--friction", type=float, default=None, metavar="NM",
                   help=f"the dry friction in N m, N on the guide (default {FRICTION_Nm:g}, the guide's "
                        f"{SLIDE_FRICTION_N:g}; 0: none)")
    p.add_argument("--effect", metavar="CASE",
                   help="two flywheels with this effect of tests/test_independent_bench.py's paper joint instead of "
                        "the friction (backlash/1, stribeck_friction/1, micro_slip/1, drive_delay/1, ...)")
    p.add_argument("--given-structure", action="store_true",
                   help="with --effect: fit the bench's own structure as the diagnosis fits its final model instead of "
                        "diagnosing (the intervals given the right structure; about 7 s a seed)")
    p.add_argument("--measured-fidelity", action="store_true",
                   help="with --given-structure: fit it again with the balance's fidelity measured on the fit's "
                        "noise-free replay in the rig, as the diagnosis does (default: a fixed floor of 1e-6)")
    p.add_argument("--channel-noise", type=float, nargs=3, default=list(CHANNELS), metavar=("TORQUE", "PHI1", "PHI2"),
                   help="two flywheels: each channel's noise as a multiple of the level's (default 1 1 1; "
                        "0.01 1 1: the angles' noise alone, to tell which channel's noise moves an interval)")
    p.add_argument("--out", type=Path, default=ROOT / "runs" / "coverage",
                   help="folder of the per-case JSON files (default runs/coverage)")
    p.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    p.add_argument("--json", type=Path, help="write the summary table here (atomically)")
    args = p.parse_args(argv)
    if args.seeds < 1:
        p.exit(2, f"{p.prog}: error: --seeds must be at least 1, got {args.seeds}\n")
    if args.first_seed < 0:
        p.exit(2, f"{p.prog}: error: --first-seed must be >= 0, got {args.first_seed}\n")
    if args.workers < 1:
        p.exit(2, f"{p.prog}: error: --workers must be at least 1, got {args.workers}\n")
    if args.effect is not None:
        if args.bench != "flywheels" or args.friction is not None:
            p.exit(2, f"{p.prog}: error: --effect is a case of the two flywheels' bench, without --friction "
                      f"(a Stribeck case holds its own)\n")
        if args.effect not in effect_names():
            p.exit(2, f"{p.prog}: error: --effect {args.effect!r} is none of the paper joint's cases: "
                      f"{', '.join(effect_names())}\n")
        args.friction = 0.0
    if args.given_structure and args.effect is None:
        p.exit(2, f"{p.prog}: error: --given-structure needs --effect (the structure given is the effect's cause "
                  f"at joint 1 with the twist's zero)\n")
    if args.measured_fidelity and not args.given_structure:
        p.exit(2, f"{p.prog}: error: --measured-fidelity is for --given-structure (a diagnosis always measures it)\n")
    if not all(math.isfinite(c) and c >= 0 for c in args.channel_noise) or not any(args.channel_noise):
        p.exit(2, f"{p.prog}: error: --channel-noise takes three multiples >= 0, not all 0, got "
                  f"{' '.join(f'{c:g}' for c in args.channel_noise)}\n")
    if args.bench == "slide" and tuple(args.channel_noise) != CHANNELS:
        p.exit(2, f"{p.prog}: error: --channel-noise is for the two flywheels' bench\n")
    args.channel_noise = tuple(args.channel_noise)
    if args.friction is None:
        args.friction = SLIDE_FRICTION_N if args.bench == "slide" else FRICTION_Nm
    if not (math.isfinite(args.friction) and args.friction >= 0):
        p.exit(2, f"{p.prog}: error: --friction must be a number >= 0 (N m), got {args.friction}\n")
    from jointrig.commands.options import study_outputs

    study_outputs(p, args.out, args.db, args.json)
    return args


def main(argv=None) -> int:
    args = parse(argv)
    levels = list(dict.fromkeys(args.db))
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    records, todo = [], []
    for seed in seeds:  # seed by seed across the levels: a run stopped early leaves every level alike
        for db in levels:
            path = case_path(args.out, db, seed, args.friction, args.bench, args.effect, args.given_structure,
                             args.channel_noise, args.measured_fidelity)
            if path.exists():
                records.append(json.loads(path.read_text()))
            else:
                todo.append((db, seed))
    print(f"coverage: {len(records)} case(s) already in {args.out}, {len(todo)} to run in {args.workers} "
          "process(es)", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    if todo:
        with ProcessPoolExecutor(args.workers) as pool:
            futures = {pool.submit(run_case, db, seed, str(args.out), args.friction, args.bench, args.effect,
                                   args.given_structure, args.channel_noise, args.measured_fidelity): (db, seed)
                       for db, seed in todo}
            for k, fut in enumerate(as_completed(futures), 1):
                db, seed = futures[fut]
                r = fut.result()
                records.append(r)
                what = r.get("error") or (f"{r['verdict']}, chi2/dof {r['chi2_per_dof']:.3f}, "
                                          f"{', '.join(r['steps']) or 'no cause adopted'}")
                eta = (time.perf_counter() - t0) / k * (len(todo) - k)
                print(f"[{k}/{len(todo)}] {db:g} dB seed {seed}: {what} ({r['wall_s']:.1f} s; about "
                      f"{eta / 60:.0f} min left)", file=sys.stderr, flush=True)
    table = summarise(records, levels)
    right = summarise(records, levels, right_only=True)
    what = (f"the carriage on a guide, 12 kg, 40 N s/m, {args.friction:g} N dry friction (tests/bench_slide_sim.py), "
            f"9 runs, the default hold-out" if args.bench == "slide" else
            f"two flywheels, paper joint with {args.effect} (tests/test_independent_bench.py), 6 runs, runs {HOLDOUT} "
            f"held out" + (", the structure given" if args.given_structure else "")
            + (", the fidelity measured" if args.measured_fidelity else "") if args.effect is not None else
            f"two flywheels, paper joint, {args.friction:g} N m dry friction (tests/bench_sim.py), 6 runs, runs "
            f"{HOLDOUT} held out")
    print(f"Coverage of the 95% intervals (value +- t SE) over seeds {seeds.start}-{seeds.stop - 1}: {what}")
    print_table(table)
    step = (f"{args.effect.split('/')[0]} at joint 1" if args.effect is not None else
            SLIDE_STEP if args.bench == "slide" else RIGHT_STEP if args.friction > 0 else "no cause")
    print(f"\nOnly the seeds whose final model has the bench's structure ({step} adopted, nothing else):")
    print_table(right)
    if args.json is not None:
        write_json_atomic(args.json, {"seeds": [seeds.start, seeds.stop - 1], "levels_db": levels,
                                      "bench": args.bench, "effect": args.effect,
                                      "truth": (effect_case(args.effect)[1] if args.effect is not None else
                                                truth_of(args.friction, args.bench)), "table": table,
                                      "right_structure_only": right})
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
