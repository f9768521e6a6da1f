"""Main job: sweep the rig over frequency x amplitude, identify the joint, report, record.

    jointrig sweep                       # default sweep, runs/sweep.{json,rrd}
    jointrig sweep --form two_dof --spawn # J1, J2 and the law; live viewer
    jointrig sweep --workers 2            # 2 threads (native callback)
    jointrig sweep --snr-db 40            # measured at 40 dB SNR: ML, +- std errors
    jointrig sweep --excitation multisine # two odd random-phase multisines
    jointrig sweep --executor dask --scheduler tcp://head:8786  # a cluster

Frequencies are in rad/s, drive amplitudes in N m (torque on flywheel 1). Finished sweep
points are kept in ``--store`` (default: runs/store/<model>-<settings hash>) so an
interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import argparse

import dataclasses
import logging
import math
from pathlib import Path

import numpy as np

from jointrig.commands import add_quiet, command_parser, shipped
from jointrig.identify import FORMS, compare, format_table, identify
from jointrig.identify.multisine import line_levels
from jointrig.vocab.law import JointLaw
from jointrig.rig import DEFAULT_MODEL, SimulationConfig, load_rig
from jointrig.rig.measurement import add_noise, repeat_periods
from jointrig.commands.options import add_backend_option, progress_level
from jointrig.studies.sweep import (DEFAULT_MULTISINE, DEFAULT_PLAN, EXECUTORS, SweepPlan, default_store, records_of,
                                    run_multisines, run_sweep, write_json_atomic)
from jointrig.vocab.params import J1, J2, JE

log = logging.getLogger("run_sweep")


def parse_args(argv=None) -> argparse.Namespace:
    p = command_parser(__doc__, 'jointrig sweep')
    p.add_argument("--model", type=Path, default=DEFAULT_MODEL, help=f"rig MJCF (default: {shipped(DEFAULT_MODEL)})")
    p.add_argument("--omegas", type=float, nargs="+", default=None,
                   metavar="RAD_S", help=f"drive frequencies in rad/s (default: {list(DEFAULT_PLAN.omegas_rad_s)}; "
                                         f"for a chain model, studies.chain_sweep.CHAIN_PLAN)")
    p.add_argument("--amplitudes", type=float, nargs="+", default=None,
                   metavar="NM", help=f"drive torque amplitudes in N m (default: {list(DEFAULT_PLAN.amplitudes_Nm)})")
    p.add_argument("--drive-at", type=int, default=1, metavar="I",
                   help="chain models: the flywheel driven at every --omegas x --amplitudes point (default: %(default)s)")
    p.add_argument("--form", choices=FORMS, default="equivalent",
                   help="equivalent 1-DOF (Je + law) or direct 2-DOF (J1, J2 + law) (default: %(default)s)")
    p.add_argument("--harmonics", type=int, default=None,
                   help="harmonics 0..H balanced (default: 9 stepped, 3 x the top line for a multisine)")
    p.add_argument("--excitation", choices=("stepped", "multisine"), default="stepped",
                   help="stepped: one cosine per frequency x amplitude; multisine: odd random-phase multisines "
                        "(studies/sweep.py DEFAULT_MULTISINE), whose detection lines show nonlinear distortion "
                        "(default: %(default)s)")
    d = SimulationConfig()
    p.add_argument("--max-step", type=float, default=d.max_step_s, metavar="S",
                   help="largest RK4 step in s (default: %(default)s)")
    p.add_argument("--samples-per-period", type=int, default=d.samples_per_period,
                   help="samples of each logged steady-state period (the record's resolution; harmonics up to half of it are resolved) (default: %(default)s)")
    p.add_argument("--sample-rate-hz", type=float, default=None, metavar="FS",
                   help="log at a bench's fixed sampling rate instead of --samples-per-period; every frequency is "
                        "moved to the nearest one whose period holds whole samples (coherent sampling)")
    p.add_argument("--integrator", default=d.integrator, help="MuJoCo integrator (default: %(default)s)")
    p.add_argument("--settle-tol", type=float, default=d.settle_tol,
                   help="steady state: bound on the distance from the exact steady state / swing "
                        "(default: %(default)s)")
    p.add_argument("--store", type=Path, default=None,
                   help="directory of finished sweep points, for resuming (default: runs/store/<auto>)")
    p.add_argument("--no-store", action="store_true", help="keep no sweep points on disk")
    p.add_argument("--json", type=Path, default=Path("runs/sweep.json"), help="results JSON (default: %(default)s)")
    p.add_argument("--rrd", type=Path, default=Path("runs/sweep.rrd"), help="rerun recording (default: %(default)s)")
    p.add_argument("--no-rrd", action="store_true", help="write no recording file")
    viewer = p.add_mutually_exclusive_group()
    viewer.add_argument("--spawn", action="store_true", help="also stream to a newly spawned rerun viewer")
    viewer.add_argument("--connect", metavar="URL", help="also stream to a running viewer (gRPC URL)")
    add_backend_option(p)
    p.add_argument("--workers", type=int, default=1,
                   help="simulate this many sweep points at once: threads with --executor local (native backend), "
                        "worker processes of a local dask cluster (default: %(default)s)")
    p.add_argument("--executor", choices=EXECUTORS, default="local",
                   help="local: this process; dask: a dask.distributed cluster (default: %(default)s)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="dask scheduler address, e.g. tcp://head-node:8786 (default: start a local cluster "
                        "of --workers processes)")
    p.add_argument("--continuation", action="store_true",
                   help="start each frequency from the previous one's steady state (same amplitude)")
    p.add_argument("--snr-db", "--noise-db", dest="noise_db", type=float, default=None, metavar="DB",
                   help="measure every run with white Gaussian noise on both angles and the torque at this SNR "
                        "per channel (rates not recorded) and identify by errors-in-variables maximum likelihood "
                        "(identify/eiv.py) (default: no noise, least squares)")
    p.add_argument("--periods", type=int, default=8,
                   help="measured periods per run with --snr-db (the noise is estimated from their variation) "
                        "(default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="noise seed with --snr-db (default: %(default)s)")
    add_quiet(p)
    return p.parse_args(argv)


def truth_of(rig, form: str) -> dict[str, float]:
    inertia = ({JE: rig.Je_kgm2} if form == "equivalent"
               else {J1: rig.J1_kgm2, J2: rig.J2_kgm2})
    return {**inertia, **rig.law.as_dict()}


#: The lowest drive frequency a sweep takes (rad/s): a period of about a minute.
MIN_OMEGA_RAD_S = 0.1
#: The most integrator steps one period may take (a run then takes minutes, not days).
MAX_STEPS_PER_PERIOD = 2e6


def main(argv=None) -> int:
    args = parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    logging.basicConfig(level=progress_level(args.quiet),
                        format="%(levelname)s %(name)s: %(message)s")
    if args.excitation == "multisine" and (args.executor != "local" or args.continuation or args.workers > 1):
        raise ValueError("--excitation multisine simulates its runs here, one after another: drop --executor, "
                         "--workers and --continuation")
    if args.noise_db is not None and args.form != "equivalent":
        raise ValueError("--snr-db identifies the equivalent form (Je and the law): drop --form two_dof")
    if args.periods < 2:
        raise ValueError(f"--periods must be >= 2 (the noise is estimated from their variation), got {args.periods}")
    from jointrig.commands.options import check_each, check_folder, check_output, check_range

    check_output(args.json, "--json")
    if not args.no_store:
        check_folder(args.store, "--store")
    if not args.no_rrd:
        check_output(args.rrd, "--rrd")
    if args.harmonics is not None:
        check_range(args.harmonics, "--harmonics", lo=1, hi=1000, integer=True)
    check_range(args.workers, "--workers", lo=1, hi=256, integer=True)
    # Ranges a run can be simulated in: a period of at most MAX_STEPS_PER_PERIOD steps, a
    # record of at most 65536 samples per period (issue 38: 1e7 samples hung, omega 1e-6 rad/s
    # asked for 468 GiB).
    check_range(args.samples_per_period, "--samples-per-period", lo=8, hi=65536, integer=True)
    check_range(args.max_step, "--max-step", lo=1e-7, hi=0.1)
    check_range(args.settle_tol, "--settle-tol", lo=1e-14, hi=1e-2)
    check_range(args.seed, "--seed", lo=0, hi=2**32 - 1, integer=True)
    check_range(args.drive_at, "--drive-at", lo=1, hi=8, integer=True)
    if args.noise_db is not None:
        check_range(args.noise_db, "--snr-db", lo=0, hi=200, lo_open=True)
    if args.sample_rate_hz is not None:
        check_range(args.sample_rate_hz, "--sample-rate-hz", lo=0, hi=1e7, lo_open=True)
    from jointrig.rig.chain import is_chain_model

    if is_chain_model(args.model):
        return chain_main(args)
    omegas = list(DEFAULT_PLAN.omegas_rad_s) if args.omegas is None else args.omegas
    amplitudes = list(DEFAULT_PLAN.amplitudes_Nm) if args.amplitudes is None else args.amplitudes
    check_each(omegas, "--omegas", lo=MIN_OMEGA_RAD_S, hi=1e4)
    longest = 2 * math.pi / min(omegas) / args.max_step
    if longest > MAX_STEPS_PER_PERIOD:
        raise ValueError(f"--omegas {min(omegas):g} rad/s: a period of {2 * math.pi / min(omegas):.3g} s is "
                         f"{longest:.3g} steps of --max-step {args.max_step:g} s; at most {MAX_STEPS_PER_PERIOD:g} "
                         f"(raise --max-step or the frequency)")
    check_each(amplitudes, "--amplitudes", lo=0, hi=1e7, lo_open=True)
    rig = load_rig(args.model)
    plan = SweepPlan(tuple(omegas), tuple(amplitudes))
    if args.sample_rate_hz is not None:
        plan = plan.coherent(args.sample_rate_hz)
        log.info("sampling at %g Hz: frequencies moved to %s rad/s (whole samples per period)", args.sample_rate_hz,
                 ", ".join(f"{w:.4f}" for w in plan.omegas_rad_s))
    config = SimulationConfig(max_step_s=args.max_step, samples_per_period=args.samples_per_period,
                              settle_tol=args.settle_tol, integrator=args.integrator,
                              sample_rate_Hz=args.sample_rate_hz)
    store = None if args.no_store else (args.store or default_store(rig, config))
    check_folder(store, "--store")  # the default store too, before the sweep
    log.info("model %s: law %s, J1 %.6g, J2 %.6g kg m^2; %d sweep points; store %s", rig.path,
             rig.law.as_dict(), rig.J1_kgm2, rig.J2_kgm2, len(plan.points()), store)
    if args.excitation == "stepped":
        harmonics = 9 if args.harmonics is None else args.harmonics
        points = run_sweep(rig, plan, config, store=store, backend=args.backend, workers=args.workers,
                           continuation=args.continuation, executor=args.executor, scheduler=args.scheduler)
        runs_json = [{"omega_rad_s": p.record.omega_rad_s, "amplitude_Nm": p.record.drive_amplitude_Nm,
                      "periods_to_steady_state": p.settle.periods_simulated, "last_change": p.settle.last_change,
                      "error_bound": p.settle.error_bound, "timestep_s": p.settle.timestep_s} for p in points]
        records = records_of(points)
        excitations = None
    else:
        ms_plan = DEFAULT_MULTISINE
        harmonics = ms_plan.n_harmonics if args.harmonics is None else args.harmonics
        ms_config = dataclasses.replace(config, samples_per_period=max(config.samples_per_period,
                                                                       2 * harmonics + 2))
        done = run_multisines(rig, ms_plan, ms_config, backend=args.backend)
        records = [r for r, _, _ in done]
        excitations = [m for _, _, m in done]
        runs_json = [{"omega0_rad_s": ms_plan.omega0_rad_s, "rms_Nm": m.rms_Nm, "excited_harmonics": list(m.excited),
                      "detection_harmonics": list(m.detection), "periods_to_steady_state": i.periods_simulated,
                      "error_bound": i.error_bound, "timestep_s": i.timestep_s} for _, i, m in done]

    if args.noise_db is not None:
        rng = np.random.default_rng(args.seed)
        records = [add_noise(repeat_periods(r, args.periods), args.noise_db, rng) for r in records]
    if excitations is not None:
        print("\nNon-excited lines of the relative angle (mean power per line, relative to the excited lines):")
        def db(x, ref):
            return f"{10 * math.log10(x / ref):6.0f} dB" if x > 0 else "  -inf dB"

        for rec, m, rj in zip(records, excitations, runs_json):
            lv = line_levels(rec, m, harmonics)
            rj["line_levels_rad2"] = {"excited": lv.excited, "odd_detection": lv.odd_detection, "even": lv.even,
                                      "noise": lv.noise}
            print(f"  RMS {m.rms_Nm:6.0f} N m: odd detection lines {db(lv.odd_detection, lv.excited)} (odd "
                  f"distortion), even lines {db(lv.even, lv.excited)} (even distortion)"
                  + (f", noise {db(lv.noise, lv.excited)}" if lv.noise > 0 else ""))
    if args.noise_db is None:
        result = identify(records, rig.law.terms, form=args.form, n_harmonics=harmonics,
                          torque_share=rig.torque_share)
        print(f"\nHarmonic-balance identification ({args.form} form) from {len(records)} runs, "
              f"harmonics 0..{harmonics}: {result.n_rows} equations, condition number "
              f"{result.condition_number:.3g}, status: {result.message}\n")
    else:
        from jointrig.identify.eiv import ml_identify  # scipy.optimize and .stats: loaded when used

        result = ml_identify(records, rig.law.terms, n_harmonics=harmonics, torque_share=rig.torque_share)
        print(f"\nErrors-in-variables maximum-likelihood harmonic balance (equivalent form) from {len(records)} "
              f"runs x {args.periods} periods measured at SNR {args.noise_db:g} dB (seed {args.seed}), harmonics "
              f"0..{harmonics}: {result.n_rows} equations; cost {result.cost:.1f} for {result.dof} degrees of "
              f"freedom (chi-square p = {result.p_value:.2g}), status: {result.message}\n")
    rows = compare(result, truth_of(rig, args.form))
    print(format_table(rows))
    if args.noise_db is not None:  # without noise the standard errors only reflect integrator error
        for r in rows:
            print(f"  {r.name:20s} {r.identified:.6g} +- {r.std_error:.2g}"
                  + (f"  ({(r.identified - r.true) / r.std_error:+.2f} standard errors from the truth)"
                     if r.true is not None and r.std_error > 0 else ""))

    identified_law = JointLaw(rig.law.terms, tuple(result.value(t.name) for t in rig.law.terms))
    out = {
        "parameters": {r.name: r.as_json() for r in rows},
        "form": args.form,
        "condition_number": getattr(result, "condition_number", None),
        "relative_residual": getattr(result, "relative_residual", None),
        "noise_db": args.noise_db,
        "estimator": "least squares" if args.noise_db is None else "errors-in-variables maximum likelihood",
        "n_equations": result.n_rows,
        "success": result.success,
        "message": result.message,
        "max_abs_rel_error": max(abs(r.rel_error) for r in rows if r.rel_error is not None),
        "excitation": args.excitation,
        "sweep": ({"omegas_rad_s": list(plan.omegas_rad_s), "amplitudes_Nm": list(plan.amplitudes_Nm)}
                  if args.excitation == "stepped" else dataclasses.asdict(DEFAULT_MULTISINE)) | {"runs": runs_json},
        "simulation": {**dataclasses.asdict(config), "model": str(rig.path), "model_sha256": rig.digest},
        "units": "SI; parameter names carry their units",
    }
    if args.json:
        write_json_atomic(args.json, out)
        print(f"\nwrote {args.json}")

    rrd = None if args.no_rrd else args.rrd
    if rrd is not None or args.spawn or args.connect:
        from jointrig.present.recording import (log_harmonics, log_parameter_table, log_restoring_force, log_run,
                                             open_recording, sweep_blueprint)

        with open_recording(rrd, spawn=args.spawn, connect=args.connect) as rec:
            rec.send_blueprint(sweep_blueprint(records))
            for r in records:
                log_run(rec, r)
            log_harmonics(rec, records, harmonics)
            phi_all = np.concatenate([r.phi_rad for r in records])
            log_restoring_force(rec, rig.law, identified_law, (float(phi_all.min()), float(phi_all.max())))
            log_parameter_table(rec, format_table(rows, markdown=True))
        if rrd is not None:
            print(f"wrote {rrd} (open it with: .venv/bin/rerun {rrd}; without a display: .venv/bin/rerun {rrd} "
                  f"--web-viewer, then a browser on port 9090)")
    return 0 if result.success else 1


def chain_main(args: argparse.Namespace) -> int:
    """A chain model (``jointrig_joint<j>_*`` fields): sweep it, identify every inertia and every
    joint law at once (identify/chain.py), report and record."""
    from jointrig.identify.chain import identify_chain, joint_law
    from jointrig.rig.chain import load_chain
    from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN, default_chain_store, run_chain_sweep
    from jointrig.present.recording import (chain_blueprint, log_chain_laws, log_chain_run, log_parameter_table,
                                         open_recording)
    from jointrig.commands.options import check_each, check_folder

    unsupported = [flag for flag, on in (("--form two_dof", args.form != "equivalent"),
                                         ("--excitation multisine", args.excitation != "stepped"),
                                         ("--workers with --backend python",
                                          args.workers > 1 and args.backend == "python" and args.executor == "local"),
                                         ("--continuation", args.continuation),
                                         ("--sample-rate-hz", args.sample_rate_hz is not None)) if on]
    if unsupported:
        raise ValueError(f"{args.model} is a chain model: {', '.join(unsupported)} is not available for chains yet "
                         f"(they are identified from noise-free stepped sweeps, simulated here, in threads with "
                         f"--workers N)")
    rig = load_chain(args.model)
    if args.omegas is None and args.amplitudes is None:
        points = list(CHAIN_PLAN)
    else:
        omegas = args.omegas or sorted({w for w, _, _ in CHAIN_PLAN})
        amps = args.amplitudes or [60.0]
        check_each(omegas, "--omegas", lo=0, hi=1e5, lo_open=True)
        check_each(amps, "--amplitudes", lo=0, hi=1e7, lo_open=True)
        if args.drive_at not in rig.driven:
            raise ValueError(f"--drive-at {args.drive_at}: {args.model} has motors on flywheels {list(rig.driven)}")
        points = [(w, a, args.drive_at) for a in amps for w in omegas]
    d = SimulationConfig()
    config = dataclasses.replace(
        CHAIN_CONFIG, settle_tol=args.settle_tol, integrator=args.integrator,
        max_step_s=args.max_step if args.max_step != d.max_step_s else CHAIN_CONFIG.max_step_s,
        samples_per_period=(args.samples_per_period if args.samples_per_period != d.samples_per_period
                            else CHAIN_CONFIG.samples_per_period))
    harmonics = 9 if args.harmonics is None else args.harmonics
    store = None if args.no_store else (args.store or default_chain_store(rig, config))
    check_folder(store, "--store")  # the default store too, before the sweep
    log.info("chain model %s: %d flywheels, inertias %s kg m^2, %d sweep points; store %s", rig.path,
             rig.n_flywheels, rig.inertias_kgm2, len(points), store)
    done = run_chain_sweep(rig, points, config, store=store, backend=args.backend, workers=args.workers,
                           executor=args.executor, scheduler=args.scheduler)
    records = [p.record for p in done]
    spec = rig.plant.spec()
    truth = {**{f"J{i}_kgm2": J for i, J in enumerate(rig.inertias_kgm2, start=1)}, **rig.plant.parameters()}
    if args.noise_db is None:
        result = identify_chain(records, spec, n_harmonics=harmonics)
        print(f"\nHarmonic-balance identification of a {rig.n_flywheels}-flywheel chain from {len(records)} runs, "
              f"harmonics 0..{harmonics}: {result.n_rows} equations for {len(result.names)} unknowns (block-banded), "
              f"condition number {result.condition_number:.3g}, status: {result.message}\n")
    else:
        from jointrig.identify.chain import ml_identify_chain
        from jointrig.rig.measurement import measure_chain

        rng = np.random.default_rng(args.seed)
        records = [measure_chain(r, args.noise_db, rng, n_periods=args.periods) for r in records]
        result = ml_identify_chain(records, spec, n_harmonics=harmonics)
        print(f"\nErrors-in-variables maximum-likelihood harmonic balance of a {rig.n_flywheels}-flywheel chain from "
              f"{len(records)} runs x {args.periods} periods measured at SNR {args.noise_db:g} dB (seed {args.seed}), "
              f"harmonics 1..{harmonics}: {result.n_rows} equations; cost {result.cost:.1f} for {result.dof} degrees "
              f"of freedom (chi-square p = {result.p_value:.2g}), status: {result.message}\n")
    rows = compare(result, truth)
    print(format_table(rows))
    if args.noise_db is not None:
        for r in rows:
            print(f"  {r.name:26s} {r.identified:.6g} +- {r.std_error:.2g}  ({(r.identified - r.true) / r.std_error:+.2f} "
                  f"standard errors from the truth)")
    out = {
        "parameters": {r.name: r.as_json() for r in rows},
        "form": "chain",
        "n_flywheels": rig.n_flywheels,
        "condition_number": getattr(result, "condition_number", None),
        "relative_residual": getattr(result, "relative_residual", None),
        "noise_db": args.noise_db,
        "estimator": ("least squares (block-banded QR)" if args.noise_db is None
                      else "errors-in-variables maximum likelihood"),
        "n_equations": result.n_rows,
        "success": result.success,
        "message": result.message,
        "max_abs_rel_error": max(abs(r.rel_error) for r in rows if r.rel_error is not None),
        "excitation": "stepped",
        "sweep": {"points": [{"omega_rad_s": p.omega_rad_s, "amplitude_Nm": p.amplitude_Nm, "driven_flywheel": p.flywheel,
                              "periods_to_steady_state": p.settle.periods_simulated,
                              "error_bound": p.settle.error_bound, "timestep_s": p.settle.timestep_s} for p in done]},
        "simulation": {**dataclasses.asdict(config), "model": str(rig.path), "model_sha256": rig.digest},
        "units": "SI; parameter names carry their units",
    }
    if args.json:
        write_json_atomic(args.json, out)
        print(f"\nwrote {args.json}")
    rrd = None if args.no_rrd else args.rrd
    if rrd is not None or args.spawn or args.connect:
        values = result.as_dict()
        identified = [joint_law(values, spec, j) for j in range(1, rig.n_flywheels)]
        with open_recording(rrd, spawn=args.spawn, connect=args.connect) as rec:
            rec.send_blueprint(chain_blueprint(records, rig.n_flywheels - 1))
            for r in records:
                log_chain_run(rec, r)
            log_chain_laws(rec, rig.plant.laws, identified, records)
            log_parameter_table(rec, format_table(rows, markdown=True))
        if rrd is not None:
            print(f"wrote {rrd} (open it with: .venv/bin/rerun {rrd})")
    return 0 if result.success else 1
