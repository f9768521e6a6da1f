"""The paper's example (Poterasu et al., eq. 12 and the shifted form), ours beside theirs.

    jointrig paper [--json OUT]

1. Eq. (12): phi'' + 100 phi' + 2000 phi + 200 phi^3 = 200 cos t, simulated on the rig
   (M0 = 400 N m on flywheel 1; Je = 1 kg m^2 and the torque share 1/2 make the right-hand
   side 200 cos t), identified at omega = 1 rad/s alone.
2. The shifted form alpha = phi + 1:
   alpha'' + 100 alpha' + 2600 alpha - 600 alpha^2 + 200 alpha^3 = 2200 + 200 cos t,
   identified as {S} = {m, c, k, a, b} and transformed back, next to the published numbers.
3. Why one frequency cannot fix Je: the same identification from data carrying a small
   measurement error (Gaussian noise on the torque, 60 dB SNR) at omega = 1 alone and over
   the default sweep.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np

from jointrig.commands import add_quiet, command_parser
from jointrig.identify import identify, single_dof_system, solve
from jointrig.vocab import Power, Viscous
from jointrig.vocab.records import SteadyStateRecord
from jointrig.rig import SimulationConfig, load_rig, simulate_steady_state
from jointrig.studies.sweep import DEFAULT_PLAN, records_of, run_sweep
from jointrig.files import write_json_atomic
from jointrig.vocab.params import JE

PAPER_S = {"m": 1.148887957, "c": 100.0641277, "k": 2599.80183, "a": -599.70047474, "b": 199.80868402}
PAPER_BACK = {"c/Je": 100.0641277, "k/Je": 1999.826933, "gamma/Je": 199.80868402, "M": 199.8986447}
TRUE_S = {"m": 1.0, "c": 100.0, "k": 2600.0, "a": -600.0, "b": 200.0}
TRUE_BACK = {"c/Je": 100.0, "k/Je": 2000.0, "gamma/Je": 200.0, "M": 200.0}
SHIFT_RAD = 1.0
N_HARMONICS = 9


def _row(name, ours, paper, true):
    return (f"  {name:9s} {ours:16.10f} {paper:16.10f} {true:10g}   "
            f"{(ours - true) / abs(true):+.2e}   {(paper - true) / abs(true):+.2e}")


def _table(title, ours, paper, true):
    print(title)
    print(f"  {'':9s} {'ours':>16s} {'paper':>16s} {'true':>10s}   ours err    paper err")
    for k in true:
        print(_row(k, ours[k], paper[k], true[k]))


def with_torque_noise(record: SteadyStateRecord, snr_db: float, rng: np.random.Generator) -> SteadyStateRecord:
    """The record with white Gaussian noise on the measured torque at ``snr_db`` (RMS of the
    torque over RMS of the noise). Noise on the torque enters only {F}, so least squares stays
    unbiased and the spread shows how well each parameter is determined; noise on the angles
    (errors in variables) is a separate matter."""
    sigma = np.std(record.torque_Nm) * 10 ** (-snr_db / 20)
    return dataclasses.replace(record, torque_Nm=record.torque_Nm + rng.normal(0.0, sigma, record.n_samples),
                               source=record.source + " + torque noise")


def main(argv=None) -> int:
    p = command_parser(__doc__, 'jointrig paper --json runs/paper.json')
    add_quiet(p)
    p.add_argument("--json", type=Path, default=None, help="write the figures as JSON")
    p.add_argument("--snr-db", type=float, default=60.0, help="noise level of part 3 (default: %(default)s)")
    p.add_argument("--seed", type=int, default=1, help="noise seed of part 3 (default: %(default)s)")
    args = p.parse_args(argv)
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()
    from jointrig.commands.options import check_output

    check_output(args.json, "--json")
    logging.basicConfig(level=logging.WARNING)

    rig = load_rig()
    config = SimulationConfig()
    record, info = simulate_steady_state(rig, 1.0, 400.0, config)
    terms = (Viscous(), Power(1), Power(3))
    direct = identify([record], terms, form="equivalent", n_harmonics=N_HARMONICS, torque_share=rig.torque_share)
    print(f"Eq. (12) at omega = 1 rad/s (RK4, dt = {info.timestep_s:.3g} s, {record.samples_per_period} "
          f"samples/period, harmonics 0..{N_HARMONICS}, steady after {info.periods_simulated} periods)")
    for name in direct.names:
        print(f"  {name:18s} {direct.value(name):.10g} +- {direct.std_error(name):.2e}")

    # Shifted variable alpha = phi + 1: same samples, forcing + 2200 N m (= 2200 Je).
    alpha = record.phi_rad + SHIFT_RAD
    forcing = rig.torque_share * record.torque_Nm + 2200.0 * rig.Je_kgm2
    shifted_system = single_dof_system(omega_rad_s=1.0, n_periods=record.n_periods, x=alpha,
                                       rate=record.rate_rad_s, forcing=forcing,
                                       terms=(Viscous(), Power(1), Power(2), Power(3)), n_harmonics=N_HARMONICS,
                                       inertia_name="m_kgm2")
    shifted = solve(shifted_system)
    m_, c_, k_, a_, b_ = shifted.values
    ours_s = dict(zip(["m", "c", "k", "a", "b"], shifted.values))
    # Back to phi: k_a (1+phi) + a (1+phi)^2 + b (1+phi)^3 = const + (k_a + 2a + 3b) phi + (a + 3b) phi^2 + b phi^3
    first = shifted_system.row_harmonic == 1  # cosine and sine rows of the fundamental
    lhs1 = shifted_system.A[first] @ shifted.values
    F1 = float(np.hypot(*shifted_system.F[first]))
    ours_back = {"c/Je": c_ / m_, "k/Je": (k_ + 2 * a_ + 3 * b_) / m_, "gamma/Je": b_ / m_,
                 "M": float(np.hypot(*lhs1)) / m_}
    print()
    _table("Shifted form alpha = phi + 1: {S} = {m, c, k, a, b}", ours_s, PAPER_S, TRUE_S)
    print()
    _table("Back-transformed (M: drive amplitude / Je that the identified model balances at the fundamental)",
           ours_back, PAPER_BACK, TRUE_BACK)
    print(f"  residual quadratic term (a + 3b)/Je = {(a_ + 3 * b_) / m_:+.3e} N m/rad^2 per kg m^2 (true 0); "
          f"|F_1| = {F1:.10g} N m")

    # Part 3: one frequency vs a sweep, same measurement noise.
    rng = np.random.default_rng(args.seed)
    sweep = records_of(run_sweep(rig, DEFAULT_PLAN, config))
    single_noisy = identify([with_torque_noise(record, args.snr_db, rng)], terms, form="equivalent",
                            n_harmonics=N_HARMONICS, torque_share=rig.torque_share)
    sweep_noisy = identify([with_torque_noise(r, args.snr_db, rng) for r in sweep], terms, form="equivalent",
                           n_harmonics=N_HARMONICS, torque_share=rig.torque_share)
    print(f"\nWhy one frequency cannot fix Je: {args.snr_db:g} dB SNR noise on the torque "
          f"(seed {args.seed})")
    print(f"  {'':18s} {'omega = 1 only':>24s} {'default sweep':>24s}")
    truth = {JE: rig.Je_kgm2, **rig.law.as_dict()}
    noisy_out = {}
    for name in single_noisy.names:
        t = truth[name]
        e1 = (single_noisy.value(name) - t) / t
        e2 = (sweep_noisy.value(name) - t) / t
        print(f"  {name:18s} {e1:+10.2e} (se {single_noisy.std_error(name) / t:.1e}) "
              f"{e2:+10.2e} (se {sweep_noisy.std_error(name) / t:.1e})")
        noisy_out[name] = {"single_rel_error": e1, "single_rel_std": single_noisy.std_error(name) / t,
                           "sweep_rel_error": e2, "sweep_rel_std": sweep_noisy.std_error(name) / t}
    print(f"  condition number: {single_noisy.condition_number:.3g} (omega = 1) vs "
          f"{sweep_noisy.condition_number:.3g} (sweep)")

    if args.json:
        write_json_atomic(args.json, {
            "eq12_omega1": direct.as_dict(), "eq12_omega1_std": dict(zip(direct.names, direct.std_errors.tolist())),
            "shifted_S": {k: float(v) for k, v in ours_s.items()}, "paper_S": PAPER_S,
            "back_transformed": ours_back, "paper_back_transformed": PAPER_BACK,
            "noise_snr_db": args.snr_db, "one_frequency_vs_sweep": noisy_out})
    return 0
