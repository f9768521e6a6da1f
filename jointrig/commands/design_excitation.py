"""D-optimal excitation: which frequencies and amplitudes to measure, for how long, on a budget.

    jointrig design [--snr-db 40] [--setup-s 1] [--budget-s B] [--verify N] [--json OUT]

Candidates: drive frequencies 1..90 rad/s (19 values) x amplitudes 400, 1000, 2000, 4000 N m,
each simulated once to steady state without noise. Under the bench's measurement model
(white Gaussian noise of fixed level on both encoders and the torque cell, --snr-db below the
default sweep's largest RMS relative angle and torque), the Fisher
information one measured period of each candidate carries comes from identify.eiv; the
designer (identify/design.py) allocates periods to candidates to minimise the determinant of
the Cramer-Rao covariance of (Je, c, k, gamma) within the test time the default sweep takes
(18 runs x 8 periods, plus --setup-s per run), unless --budget-s is given. It prints the design,
the CRLB standard deviation of every parameter for the default sweep and for the design, and
the D-efficiency ratio (det F_design / det F_default)^(1/p). --verify N runs N Monte Carlo
realisations of both and reports the observed standard deviations.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np

from jointrig.commands import add_quiet, command_parser
from jointrig.identify.design import chain_modes_rad_s, crlb_std, d_efficiency, d_optimal, design_cost_s
from jointrig.identify.eiv import fisher_per_period
from jointrig.rig import SimulationConfig, load_rig
from jointrig.rig.measurement import noise_std
from jointrig.commands.options import add_backend_option
from jointrig.rig.native_callback import choose_native
from jointrig.studies.montecarlo import monte_carlo
from jointrig.studies.sweep import DEFAULT_PLAN, SweepPlan, records_of, run_sweep
from jointrig.files import write_json_atomic
from jointrig.vocab.params import JE

log = logging.getLogger("design")

CANDIDATES = SweepPlan(omegas_rad_s=(1.0, 2.5, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 42.5, 45.0, 47.5, 50.0,
                                     55.0, 60.0, 70.0, 80.0, 90.0),
                       amplitudes_Nm=(400.0, 1000.0, 2000.0, 4000.0))
DEFAULT_PERIODS = 8


def main(argv=None) -> int:
    p = command_parser(__doc__, 'jointrig design --snr-db 40')
    p.add_argument("--snr-db", type=float, default=40.0, help="expected signal-to-noise ratio per channel, dB (default: %(default)s)")
    p.add_argument("--setup-s", type=float, default=1.0, help="test time a run costs before measuring, s (default: %(default)s)")
    p.add_argument("--budget-s", type=float, default=None, help="test-time budget (s); default: the default sweep's")
    p.add_argument("--harmonics", type=int, default=9, help="harmonics 0..H balanced in the design (default: %(default)s)")
    p.add_argument("--verify", type=int, default=0, metavar="N", help="Monte Carlo realisations of both designs")
    add_backend_option(p)
    p.add_argument("--json", type=Path, help="write the design (runs: omega_rad_s, amplitude_Nm, periods) as JSON")
    p.add_argument("--model", type=Path, default=None,
                   help="a chain model (models/pump_train.xml): design where to drive and which frequencies "
                        "(default: the two-flywheel rig)")
    add_quiet(p)
    args = p.parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    from jointrig.commands.options import progress_level

    logging.basicConfig(level=progress_level(args.quiet), format="%(message)s", stream=sys.stderr)
    if args.model is not None:
        from jointrig.rig.chain import is_chain_model

        if not is_chain_model(args.model):
            raise ValueError(f"--model {args.model}: designs for a model file are for chains (jointrig_joint<j>_* "
                             f"fields); the two-flywheel design uses the default rig")
        return chain_main(args)
    from jointrig.commands.options import check_output, check_range

    check_range(args.snr_db, "--snr-db", lo=0, hi=200, lo_open=True)
    check_range(args.setup_s, "--setup-s", lo=0)
    if args.budget_s is not None:
        check_range(args.budget_s, "--budget-s", lo=0, lo_open=True)
    check_range(args.harmonics, "--harmonics", lo=1, hi=100, integer=True)
    check_range(args.verify, "--verify", lo=0, integer=True)
    check_output(args.json, "--json")
    rig = load_rig()
    points = CANDIDATES.points()
    native = choose_native(args.backend, (rig.plant,))
    log.info("simulating the %d candidate runs to steady state (%s callback)", len(points),
             "native" if native else "Python")
    records = records_of(run_sweep(rig, CANDIDATES, SimulationConfig(),
                                   backend="native" if native else "python", workers=2 if native else 1))
    names = (JE,) + tuple(t.name for t in rig.law.terms)
    truth = {JE: rig.Je_kgm2, **rig.law.as_dict()}
    theta = [truth[n] for n in names]
    # Sensors of fixed noise, --snr-db below the default sweep's largest relative angle (both
    # encoders together) and largest torque: a per-channel SNR on every candidate would make
    # small-swing runs nearly noise-free, and one set by the absolute angles' rigid swing
    # (100 rad at 1 rad/s) would drown the joint's deflection.
    in_default = set(DEFAULT_PLAN.points())
    default_recs = [r for r, pt in zip(records, points) if pt in in_default]
    sigma = (max(noise_std(r.phi_rad, args.snr_db) for r in default_recs) / np.sqrt(2),
             max(noise_std(r.torque_Nm, args.snr_db) for r in default_recs))
    var_phi = [2 * sigma[0] ** 2] * len(records)
    var_u = [sigma[1] ** 2] * len(records)
    F = fisher_per_period(records, rig.law.terms, theta, var_phi_rad2=var_phi, var_torque_Nm2=var_u,
                          n_harmonics=args.harmonics, torque_share=rig.torque_share)
    T = [2 * np.pi / w for w, _ in points]
    default = [DEFAULT_PERIODS if pt in in_default else 0 for pt in points]
    budget = args.budget_s if args.budget_s is not None else design_cost_s(default, T, args.setup_s)
    F_default = sum(k * f for k, f in zip(default, F))
    design = d_optimal(F, T, budget, setup_s=args.setup_s)
    d_eff = d_efficiency(design.log_det_fisher, F_default)
    print(f"Budget {budget:.1f} s of test time (the default sweep: 18 runs x {DEFAULT_PERIODS} periods + "
          f"{args.setup_s:g} s setup each); sensor noise {sigma[0]:.3g} rad per encoder, {sigma[1]:.3g} N m "
          f"({args.snr_db:g} dB below the default sweep's largest relative angle and torque, RMS).")
    print("D-optimal design:")
    for (w, a), k in zip(points, design.periods):
        if k:
            print(f"  omega {w:5.1f} rad/s, M0 {a:6.0f} N m: {k:3d} periods ({k * 2 * np.pi / w:6.2f} s)")
    print(f"  uses {design.cost_s:.1f} s")
    print(f"{'parameter':20s} {'CRLB std default':>17s} {'CRLB std design':>16s} {'ratio':>7s}")
    sd_def, sd_des = crlb_std(F_default), np.sqrt(np.diag(design.covariance))
    for n, a, b in zip(names, sd_def, sd_des):
        print(f"{n:20s} {a:17.4g} {b:16.4g} {b / a:7.3f}")
    print(f"D-efficiency of the design relative to the default sweep: {d_eff:.2f} "
          f"(> 1: a smaller joint confidence region for the same test time)")
    out = {"snr_db": args.snr_db, "sigma_angle_rad": sigma[0], "sigma_torque_Nm": sigma[1], "budget_s": budget, "setup_s": args.setup_s, "d_efficiency": d_eff,
           "design": [{"omega_rad_s": w, "amplitude_Nm": a, "periods": k} for (w, a), k in zip(points, design.periods) if k],
           "crlb_std": {n: {"default": float(a), "design": float(b)} for n, a, b in zip(names, sd_def, sd_des)}}
    if args.verify:
        for label, alloc in (("default", default), ("design", design.periods)):
            sel = [i for i, k in enumerate(alloc) if k]
            log.info("Monte Carlo of the %s: %d realisations", label, args.verify)
            mc = monte_carlo([records[i] for i in sel], rig.law.terms, truth, snr_db=args.snr_db, n_runs=args.verify,
                             n_periods=[alloc[i] for i in sel], n_harmonics=args.harmonics,
                             torque_share=rig.torque_share, seed=7, sigma=sigma)
            out[f"monte_carlo_{label}"] = mc.as_json()
            print(f"Monte Carlo, {label} ({args.verify} realisations): " + ", ".join(
                f"{s.name} std {s.std:.3g} (CRLB {s.crlb_std:.3g}, coverage {s.coverage:.2f})" for s in mc.parameters))
    if args.json:
        write_json_atomic(args.json, out)
        print(f"wrote {args.json}")
    return 0


#: Chain candidates: drive frequencies relative to the chain's highest undamped mode (log-spaced
#: from 0.05 to 1.3 of it, and each mode), at every motor, at the default plan's level and twice it.
CHAIN_RELATIVE_OMEGAS = tuple(float(x) for x in np.geomspace(0.05, 1.3, 12))


def chain_candidates(rig, amplitude_Nm: float) -> list[tuple[float, float, int]]:
    """(omega rad/s, amplitude N m, driven flywheel) candidates for a chain (see CHAIN_RELATIVE_OMEGAS)."""
    modes = chain_modes_rad_s(rig.inertias_kgm2, [law.as_dict().get("k_Nm_per_rad", 0.0) for law in rig.plant.laws])
    top = modes[-1]
    omegas = sorted({round(top * r, 1) for r in CHAIN_RELATIVE_OMEGAS} | {round(m, 1) for m in modes})
    return [(w, a, i) for i in rig.driven for a in (amplitude_Nm, 2 * amplitude_Nm) for w in omegas]


def chain_main(args) -> int:
    """D-optimal excitation of a chain: where to drive, which frequencies, how many periods."""
    import dataclasses

    from jointrig.identify.chain import fisher_per_period
    from jointrig.rig.chain import load_chain
    from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN, run_chain_sweep
    from jointrig.commands.options import check_output, check_range

    check_range(args.snr_db, "--snr-db", lo=0, hi=200, lo_open=True)
    check_range(args.setup_s, "--setup-s", lo=0)
    if args.budget_s is not None:
        check_range(args.budget_s, "--budget-s", lo=0, lo_open=True)
    check_range(args.harmonics, "--harmonics", lo=1, hi=100, integer=True)
    if args.verify:
        raise ValueError("--verify (a Monte Carlo of both designs) is for the two-flywheel rig; chains report the CRLB")
    check_output(args.json, "--json")
    rig = load_chain(args.model)
    default_points = [p for p in CHAIN_PLAN if p[2] in rig.driven] if all(
        p[2] in rig.driven for p in CHAIN_PLAN) else []
    if not default_points:
        raise ValueError(f"{args.model}: the default chain plan drives flywheels "
                         f"{sorted({p[2] for p in CHAIN_PLAN})}, this chain has motors on {list(rig.driven)}")
    candidates = chain_candidates(rig, 60.0)
    points = list(dict.fromkeys(candidates + default_points))
    cfg = dataclasses.replace(CHAIN_CONFIG, settle_tol=1e-8)
    native = choose_native(args.backend, rig.plant.laws)
    done = run_chain_sweep(rig, points, cfg, backend="native" if native else "python",
                           workers=2 if native else 1)
    records = [p.record for p in done]
    spec = rig.plant.spec()
    truth = {**{f"J{i}_kgm2": J for i, J in enumerate(rig.inertias_kgm2, start=1)}, **rig.plant.parameters()}
    theta = [truth[n] for n in spec.names]
    in_default = set(default_points)
    defaults = [r for r, pt in zip(records, points) if pt in in_default]
    twist = max(float(np.std(r.angles_rad[j] - r.angles_rad[j + 1])) for r in defaults for j in range(rig.n_flywheels - 1))
    torque = max(float(np.std(t)) for r in defaults for t in r.torques_Nm if t is not None)
    sigma = (twist * 10 ** (-args.snr_db / 20) / np.sqrt(2), torque * 10 ** (-args.snr_db / 20))
    F = [fisher_per_period(r, spec, theta, sigma_angle_rad=sigma[0], sigma_torque_Nm=sigma[1],
                           n_harmonics=args.harmonics) for r in records]
    T = [2 * np.pi / w for w, _, _ in points]
    default = [DEFAULT_PERIODS if pt in in_default else 0 for pt in points]
    budget = args.budget_s if args.budget_s is not None else design_cost_s(default, T, args.setup_s)
    F_default = sum(k * f for k, f in zip(default, F))
    design = d_optimal(F, T, budget, setup_s=args.setup_s)
    d_eff = d_efficiency(design.log_det_fisher, F_default)
    print(f"Budget {budget:.2f} s of test time (the default chain plan: {len(default_points)} runs x {DEFAULT_PERIODS} "
          f"periods + {args.setup_s:g} s setup each); sensor noise {sigma[0]:.3g} rad per encoder, {sigma[1]:.3g} N m "
          f"({args.snr_db:g} dB below the default plan's largest joint twist and drive torque, RMS); "
          f"{len(points)} candidates.")
    print("D-optimal design:")
    for (w, a, i), k in zip(points, design.periods):
        if k:
            print(f"  drive flywheel {i}, omega {w:7.1f} rad/s, {a:5.0f} N m: {k:3d} periods ({k * 2 * np.pi / w:6.3f} s)")
    print(f"  uses {design.cost_s:.2f} s")
    sd_def, sd_des = crlb_std(F_default), np.sqrt(np.diag(design.covariance))
    print(f"{'parameter':26s} {'CRLB std default':>17s} {'CRLB std design':>16s} {'ratio':>7s}")
    for n, a, b in zip(spec.names, sd_def, sd_des):
        print(f"{n:26s} {a:17.4g} {b:16.4g} {b / a:7.3f}")
    print(f"D-efficiency of the design relative to the default plan: {d_eff:.2f} (> 1: a smaller joint confidence "
          f"region for the same test time)")
    if args.json:
        write_json_atomic(args.json, {
            "model": str(rig.path), "snr_db": args.snr_db, "sigma_angle_rad": sigma[0], "sigma_torque_Nm": sigma[1],
            "budget_s": budget, "setup_s": args.setup_s, "d_efficiency": d_eff,
            "design": [{"omega_rad_s": w, "amplitude_Nm": a, "driven_flywheel": i, "periods": k}
                       for (w, a, i), k in zip(points, design.periods) if k],
            "crlb_std": {n: {"default": float(a), "design": float(b)} for n, a, b in zip(spec.names, sd_def, sd_des)}})
        print(f"wrote {args.json}")
    return 0
