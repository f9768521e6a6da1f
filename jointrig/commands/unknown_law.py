"""A joint law of unknown form, recovered on hat functions (eq. 8) from noisy runs.

    jointrig unknown-law [--model models/two_flywheels_kink.xml] [--knots 41]
                                   [--snr-db 40] [--periods 8] [--lam L] [--rrd OUT] [--png OUT]

The model's joint (default: 2000 N m/rad stiffening abruptly to 16000 N m/rad at +-0.2 rad)
is swept over the default plan, every run measured over ``--periods`` periods at ``--snr-db``
per channel, and g(phi) identified on ``--knots`` hat functions over the measured range,
with Je and viscous damping, by the errors-in-variables ML harmonic balance with a
smoothness penalty chosen by generalised cross-validation (identify/hat.py). It prints the
knot values +- standard error, the RMS error against the true law, that of the best
polynomial of degree <= 5 fitted to the true law itself, and the share of the range where the
95% band holds the true law; the rerun recording (and a PNG) shows the curve, its band, the
true law and the best quintic.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from jointrig.commands import add_quiet, command_parser, shipped
from jointrig.identify.hat import fit_hat_law
from jointrig.rig import DEFAULT_MODEL, SimulationConfig, load_rig
from jointrig.rig.measurement import add_noise, repeat_periods
from jointrig.present.recording import log_parameter_table, log_restoring_band, open_recording, unknown_law_blueprint
from jointrig.studies.sweep import DEFAULT_PLAN, records_of, run_sweep
from jointrig.files import write_atomic

MODEL = DEFAULT_MODEL.parent / "two_flywheels_kink.xml"
log = logging.getLogger("jointrig.unknown-law")


def main(argv=None) -> int:
    p = command_parser(__doc__, 'jointrig unknown-law --model models/two_flywheels_kink.xml --png runs/kink.png')
    p.add_argument("--model", type=Path, default=MODEL, help=f"rig MJCF whose joint is to be recovered (default: {shipped(MODEL)})")
    p.add_argument("--knots", type=int, default=41, help="hat functions over the measured range (default: %(default)s)")
    p.add_argument("--snr-db", "--noise-db", dest="noise_db", type=float, default=40.0,
                   help="SNR per channel, dB (default: %(default)s)")
    p.add_argument("--periods", type=int, default=8, help="measured periods per run (default: %(default)s)")
    p.add_argument("--harmonics", type=int, default=9, help="harmonics 0..H balanced (default: %(default)s)")
    p.add_argument("--lam", type=float, default=None, help="penalty weight (default: chosen by GCV; 0: none)")
    p.add_argument("--rate-knots", type=int, default=None, metavar="N",
                   help="also identify the damping torque f(phi') on N (odd) hat functions of the rate (eq. 9) "
                        "instead of viscous damping")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default: %(default)s)")
    p.add_argument("--rrd", type=Path, default=Path("runs/unknown_law.rrd"), help="rerun recording (default: %(default)s)")
    p.add_argument("--png", type=Path, default=Path("runs/unknown_law.png"), help="static figure (default: %(default)s)")
    add_quiet(p)
    args = p.parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    from jointrig.commands.options import check_output, check_range, progress_level

    logging.basicConfig(level=progress_level(args.quiet), format="%(levelname)s %(name)s: %(message)s")

    if not args.model.is_file():
        raise ValueError(f"--model {args.model}: no such file")
    check_range(args.knots, "--knots", lo=3, hi=1000, integer=True)
    check_range(args.noise_db, "--snr-db", lo=0, hi=200, lo_open=True)
    check_range(args.periods, "--periods", lo=2, hi=10000, integer=True)
    check_range(args.harmonics, "--harmonics", lo=1, hi=100, integer=True)
    if args.lam is not None:
        check_range(args.lam, "--lam", lo=0)
    if args.rate_knots is not None:
        check_range(args.rate_knots, "--rate-knots", lo=3, hi=1000, integer=True)
    check_output(args.rrd, "--rrd")
    check_output(args.png, "--png")
    rig = load_rig(args.model)
    log.info("simulating the default sweep of %s (%d points)", rig.path.name, len(DEFAULT_PLAN.points()))
    records = records_of(run_sweep(rig, DEFAULT_PLAN, SimulationConfig()))  # the sweep says each point
    rng = np.random.default_rng(args.seed)
    noisy = [add_noise(repeat_periods(r, args.periods), args.noise_db, rng) for r in records]
    log.info("fitting g(phi) on %d hat functions%s by errors-in-variables ML (%s)", args.knots,
             f" and f(phi') on {args.rate_knots}" if args.rate_knots else "",
             "the penalty by generalised cross-validation" if args.lam is None else f"penalty {args.lam:g}")
    fit = fit_hat_law(noisy, n_knots=args.knots, n_harmonics=args.harmonics, torque_share=rig.torque_share,
                      lam=args.lam, n_rate_knots=args.rate_knots, progress=lambda msg: log.info("  %s", msg))
    phi = np.linspace(fit.knots_rad[0], fit.knots_rad[-1], 801)
    g, lo, hi = fit.band(phi)
    true = np.asarray(rig.law.elastic_torque(phi), dtype=float)
    rms = float(np.sqrt(np.mean((g - true) ** 2)))
    quintic = np.polyval(np.polyfit(phi, true, 5), phi)
    rms5 = float(np.sqrt(np.mean((quintic - true) ** 2)))
    covered = float(np.mean((true >= lo) & (true <= hi)))
    se = np.sqrt(np.diag(fit.covariance_Nm2))
    print(f"{rig.path.name}: {len(noisy)} runs x {args.periods} periods at {args.noise_db:g} dB; {args.knots} knots on "
          f"[{fit.knots_rad[0]:.3f}, {fit.knots_rad[-1]:.3f}] rad; penalty lambda = {fit.lam:.2g}"
          + (" (GCV)" if fit.gcv else ""))
    print(f"Je = {fit.result.value('Je_kgm2'):.5g} +- {fit.result.std_error('Je_kgm2'):.2g} kg m^2"
          + (f", c = {fit.result.value('c_Nms_per_rad'):.5g} +- {fit.result.std_error('c_Nms_per_rad'):.2g} N m s/rad"
             if "c_Nms_per_rad" in fit.result.names else ""))
    if fit.f_Nm.size:
        rate = np.linspace(fit.rate_knots_rad_s[0], fit.rate_knots_rad_s[-1], 801)
        f, flo, fhi = fit.band_f(rate)
        true_f = np.asarray(rig.law.torque(np.zeros_like(rate), rate), dtype=float) - np.asarray(
            rig.law.elastic_torque(np.zeros_like(rate)), dtype=float)
        print(f"damping torque f(phi') on {args.rate_knots} knots over +-{fit.rate_knots_rad_s[-1]:.2f} rad/s: RMS error "
              f"{np.sqrt(np.mean((f - true_f) ** 2)):.1f} N m of {np.max(np.abs(true_f)):.0f}; the band holds the true "
              f"f over {np.mean((true_f >= flo) & (true_f <= fhi)):.1%} of the range")
    print(f"{'phi_rad':>9s} {'g_Nm':>10s} {'+- std err':>10s} {'true_Nm':>10s}")
    for k, v, e in zip(fit.knots_rad, fit.g_Nm, se):
        print(f"{k:9.4f} {v:10.1f} {e:10.1f} {float(rig.law.elastic_torque(np.array([k]))[0]):10.1f}")
    print(f"RMS error of g over the range: {rms:.1f} N m ({rms / np.max(np.abs(true)):.2%} of the largest torque); "
          f"best polynomial of degree 5 fitted to the true law itself: {rms5:.1f} N m")
    print(f"the 95% band holds the true law over {covered:.1%} of the range")
    if args.rrd:
        with open_recording(args.rrd) as rec:
            rec.send_blueprint(unknown_law_blueprint(bool(fit.f_Nm.size)))
            log_restoring_band(rec, phi, g, lo, hi, rig.law, {"best_quintic_Nm": quintic})
            if fit.f_Nm.size:
                log_restoring_band(rec, rate, f, flo, fhi, None, {"true_Nm": true_f}, entity="damping_force",
                                   index="rate_urad_s")
            log_parameter_table(rec, f"hat fit: {args.knots} knots, lambda {fit.lam:.2g}, RMS error {rms:.1f} N m, "
                                     f"best quintic {rms5:.1f} N m, band holds the truth over {covered:.1%}")
        print(f"wrote {args.rrd}")
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.5))
        ax.fill_between(phi, lo, hi, color="tab:blue", alpha=0.25, label="95% band")
        ax.plot(phi, g, color="tab:blue", label=f"hat fit ({args.knots} knots)")
        ax.plot(phi, true, "k--", label="true law")
        ax.plot(phi, quintic, color="tab:red", lw=0.8, label="best quintic (fitted to the truth)")
        ax.set_xlabel("phi (rad)")
        ax.set_ylabel("restoring torque g (N m)")
        ax.legend()
        ax.grid(alpha=0.3)
        write_atomic(args.png, lambda tmp: fig.savefig(tmp, format="png", dpi=120))
        print(f"wrote {args.png}")
    return 0
