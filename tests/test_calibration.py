"""The diagnosis's numbers mean what they say at every sensor quality (issue 48), on files of the
independent two-flywheel bench (tests/bench_sim.py: scipy, event-driven friction, a DAQ's
writer with sensor offsets on every channel).

The weights carry the harmonic balance's own misfit measured on each model's noise-free replay
in the rig, not a fixed floor, and every twist's zero is part of the nominal model: a right
model reads chi-square per degree of freedom near 1 from 2% to 0.01% noise, its standard errors
shrink with the noise, a small effect stands out at high SNR, and the limits of what the runs
rule out are the sizes at which an effect is found. The slow script
``scripts/bench_calibration.py`` runs the same on trains and a slide at four levels, and
``scripts/coverage.py`` the coverage of the intervals over seeds (docs/noisy-measurements.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench_sim import JOINTS, POINTS, measure, with_effect
from jointrig.measured.runs import read_runs
from jointrig.rig.chain import rig_of_bodies
from jointrig.studies.chain_validate import run_train_diagnosis

#: 6 runs: 3 frequencies x the lowest and highest level; the middle frequency's two held out
HOLDOUT = (2, 3)


def _diagnose(tmp_path, noise: float, seed: int = 1, **effect):
    points = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1]
    path = measure(with_effect(JOINTS["paper"], **effect), points, tmp_path / f"b{noise:g}-{seed}.csv", seed=seed,
                   fs_Hz=2000.0, n_periods=6.5, noise=noise)
    loaded = read_runs(path)
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=HOLDOUT)


@pytest.mark.slow
def test_a_right_model_reads_chi2_near_one_and_learns_from_a_better_sensor(tmp_path):
    # No effect at 2% and at 0.01% of each signal: no misfit, chi2/dof within 0.7-1.5 at both (the
    # band the issue sets: with 4 fitted runs of 6 periods the chi-square of about 300 rows
    # scatters by +-10% around 1 if only noise is left; it read 0.045 at 0.01% with the fixed
    # 1e-3 floor). A sensor 200 times better gives a stiffness 50-400 times surer (the SE scales
    # with the noise: 200; the twists' zero and the period estimates add their own share).
    from jointrig.identify.chain_diagnose import BalanceFidelity

    rough, fine = _diagnose(tmp_path, 0.02), _diagnose(tmp_path, 0.0001)
    se = []
    for r in (rough, fine):
        d = r.diagnosis
        assert r.verdict.verdict == "no_misfit", r.verdict
        assert 0.7 <= d.reduced_chi2(d.final) <= 1.5, d.reduced_chi2(d.final)
        assert isinstance(d.fidelity, BalanceFidelity), d.fidelity  # measured on the replay, not fixed
        k, s = d.final.parameters()["joint1_k_Nm_per_rad"], d.final.std_error("joint1_k_Nm_per_rad")
        assert abs(k - 2000.0) <= 3 * s, (k, s)
        se.append(s)
    assert 50 <= se[0] / se[1] <= 400, se


@pytest.mark.slow
def test_two_newton_metres_of_dry_friction_at_a_fine_sensor_are_explained(tmp_path):
    # The case: 2 N m of dry friction on the paper's joint at 0.02% noise was UNEXPLAINED
    # (friction 1.97 +- 0.79 "not significant", held-out 25.7 floors). Now: EXPLAINED, the friction
    # within 2 standard errors (measured 2.0006 +- 0.0083), a held-out gain of at least 3 (29.2),
    # chi2/dof within 0.7-1.5.
    from jointrig.identify.chain_diagnose import BalanceFidelity

    r = _diagnose(tmp_path, 0.0002, Fc=2.0)
    d = r.diagnosis
    assert r.verdict.verdict == "explained", r.verdict
    assert [s.effect for s in d.steps] == ["coulomb_friction"], [s.label for s in d.steps]
    value, se = d.final.parameters()["joint1_coulomb_torque_Nm"], d.final.std_error("joint1_coulomb_torque_Nm")
    assert abs(value - 2.0) <= 2 * se, (value, se)
    assert r.validation.gain >= 3
    assert 0.7 <= d.reduced_chi2(d.final) <= 1.5
    # the fidelity was measured on the replay of the model with the friction, and is stated
    assert isinstance(d.fidelity, BalanceFidelity) and 0 < d.fidelity.relative < 1e-2, d.fidelity


@pytest.mark.slow
def test_what_the_runs_rule_out_is_the_size_at_which_an_effect_is_found(tmp_path):
    # The limit the report gives for dry friction at 0.2% noise (measured 0.47 N m on this seed), then
    # the same bench with dry friction at 0.4 and at 2 times that limit. At the limit an effect is
    # found 95% of the time by construction (its drop in chi-square (m/SE)^2 against the evidence's
    # threshold); at 0.4 times it about 4% of the time (m/SE 2.2 against a threshold of 3.95), at 2
    # times always (m/SE 11): the small one is not adopted, the large one is.
    r = _diagnose(tmp_path, 0.002, seed=3)
    assert r.verdict.verdict == "no_misfit", r.verdict
    limits = {s.label: lim for s, lim in r.diagnosis.ruled_out()}
    limit = limits["coulomb_friction at joint 1"]
    assert 0.05 < limit < 5.0, limit
    below, above = (_diagnose(tmp_path, 0.002, seed=3, Fc=f * limit) for f in (0.4, 2.0))
    assert not any(s.effect == "coulomb_friction" for s in below.diagnosis.steps), [s.label for s in below.diagnosis.steps]
    assert [s.effect for s in above.diagnosis.steps] == ["coulomb_friction"], [s.label for s in above.diagnosis.steps]
    value = above.diagnosis.final.parameters()["joint1_coulomb_torque_Nm"]
    assert math.isclose(value, 2 * limit, rel_tol=0.5), (value, limit)


@pytest.mark.slow
def test_a_run_whose_replay_does_not_settle_borrows_the_measured_runs_misfit(tmp_path, monkeypatch):
    # A replay that reaches no steady state in one fitted run (a joint stuck most of the period
    # creeps under the rig's friction constraint: the pump train's 8 N m coupling at 1200 rad/s)
    # no longer sends every run back to the fixed floor: that run's rows take the largest misfit
    # the replayed runs show at each harmonic relative to their size (not a constant: at 80 dB the
    # fixed floor held the sticking train's chi2/dof at 0.66), and the report names the runs. Here the replays of runs 4 and 5 (the
    # two at 55 rad/s) are made to fail; the right model still reads chi2/dof within 0.7-1.5 at 2%
    # noise.
    from jointrig.identify.chain_diagnose import BalanceFidelity
    from jointrig.present.train_report import format_train_report, train_report_json
    from jointrig.rig.simulate import SimulationError
    from jointrig.studies import chain_validate

    real = chain_validate.simulate_chain

    def creeping(rig, omega, drives, cfg, **kw):
        if cfg.settle_tol == 1e-7 and abs(omega - 55.0) < 0.1:  # rig_replay's, not the validation's
            raise SimulationError("no steady state in sight (made to fail)")
        return real(rig, omega, drives, cfg, **kw)

    monkeypatch.setattr(chain_validate, "simulate_chain", creeping)
    r = _diagnose(tmp_path, 0.02)
    d = r.diagnosis
    assert isinstance(d.fidelity, BalanceFidelity) and d.fidelity.unmeasured == (2, 3), d.fidelity.unmeasured
    assert r.verdict.verdict == "no_misfit" and 0.7 <= d.reduced_chi2(d.final) <= 1.5, r.verdict
    text = format_train_report(r)
    assert "the replay of run(s) 4, 5 reached no periodic steady state" in text
    assert "their rows take the largest misfit a replayed run shows at that harmonic" in text
    assert train_report_json(r)["fidelity"]["fixed_runs"] == ["4", "5"]


def test_an_unmeasured_run_borrows_the_largest_relative_misfit_of_the_measured_ones():
    # BalanceFidelity.borrowed: the share a measured run showed at that harmonic and equation,
    # times the unmeasured run's own size squared; the fixed floor where none was measured there
    from jointrig.identify.chain_diagnose import BalanceFidelity

    fid = BalanceFidelity({(0, 1, 0): 4.0}, 1e-4, "the nominal model", unmeasured=(1,), floor=1e-3,
                          shares={(1, 0): 1e-8, (2, 0): 3e-9})
    assert fid.borrowed(1, 0, 100.0 ** 2) == pytest.approx(1e-4)
    assert fid.borrowed(2, 0, 10.0 ** 2) == pytest.approx(3e-7)
    assert fid.borrowed(3, 0, 10.0 ** 2) == pytest.approx(1e-6 * 100.0)  # (1e-3 * 10)^2
    assert fid.at(0, 1, 0) == 4.0 and fid.at(1, 1, 0) == 0.0


def test_the_noise_cross_covariance_of_the_balance_rows_is_what_noise_through_the_chain_gives():
    # identify.chain.noise_cross_covariance: one encoder's noise enters the equations of
    # both bodies beside it, so neighbouring equations' residuals are correlated (at low frequency
    # nearly opposite). Checked against 200000 draws of white noise's cosine and sine parts pushed
    # through e = Z dPhi - dT (a 3-body chain, body 1 driven, joints 1 and 2 summed as when joint 2
    # may stick): every entry within 5 of its Monte Carlo standard errors (about 0.3% of the scale).
    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain import noise_cross_covariance
    from jointrig.identify.chain_diagnose import nominal_spec

    spec: ChainSpec = nominal_spec(3)
    values = {"J1_kgm2": 1.0, "J2_kgm2": 0.5, "J3_kgm2": 0.8, "joint1_c_Nms_per_rad": 30.0,
              "joint1_k_Nm_per_rad": 1e4, "joint2_c_Nms_per_rad": 20.0, "joint2_k_Nm_per_rad": 5e3,
              "bearing2_damping_Nms_per_rad": 40.0}
    sa, st, w = np.array([1e-3, 2e-3, 1.5e-3]), np.array([3.0, 0.0, 0.0]), 40.0
    rng = np.random.default_rng(3)
    n = 200_000
    dphi = (rng.standard_normal((n, 3)) + 1j * rng.standard_normal((n, 3))) * sa
    dT = (rng.standard_normal((n, 3)) + 1j * rng.standard_normal((n, 3))) * st
    Z = np.diag(-np.array([1.0, 0.5, 0.8]) * w ** 2 + 1j * w * np.array([0.0, 40.0, 0.0]))
    for j, (k, c) in enumerate(((1e4, 30.0), (5e3, 20.0))):
        Z[j:j + 2, j:j + 2] += (k + 1j * w * c) * np.array([[1, -1], [-1, 1]])
    e = dphi @ Z.T - dT
    for merged, rows in (((), e), ((1,), np.column_stack([e[:, 0], e[:, 1] + e[:, 2]]))):
        parts = np.column_stack([rows.real, rows.imag])
        mc = parts.T @ parts / n
        C = noise_cross_covariance(spec, values, w, sa, st, merged)
        scale = np.sqrt(np.outer(np.diag(mc), np.diag(mc)))
        se = np.sqrt((scale ** 2 + mc ** 2) / n)  # of a product moment of two Gaussians
        assert C.shape == mc.shape
        assert np.all(np.abs(C - mc) <= 5 * se), np.max(np.abs(C - mc) / se)
    # a joint law without a spring (a user's model) propagates as one with k = 0
    springless = {n: v for n, v in values.items() if n != "joint2_k_Nm_per_rad"}
    np.testing.assert_array_equal(noise_cross_covariance(spec, springless, w, sa, st),
                                  noise_cross_covariance(spec, dict(values, joint2_k_Nm_per_rad=0.0), w, sa, st))
    # the first two equations' cosine rows nearly opposite: the joint's stiffness dominates both
    C = noise_cross_covariance(spec, values, 5.0, sa, st)
    assert C[0, 1] / np.sqrt(C[0, 0] * C[1, 1]) < -0.5


def test_the_covariance_of_masked_rows_is_what_noise_through_the_balance_gives():
    # identify.chain.masked_noise_covariance: a body's equation weighted in time (here a joint
    # that sticks 60% of its period: the bodies' sum, and body 2's own equation where it slides)
    # mixes the harmonics of its noise, so its rows are correlated across harmonics. Checked
    # against 3000 draws of band-limited white noise on the two encoders and the torque cell,
    # balanced by chain_system itself at the model's values (a linear law, so the propagation is
    # exact): every entry within 5 of its Monte Carlo standard errors. Unmasked, it is the
    # per-harmonic noise_cross_covariance (to rounding) with nothing across harmonics.
    from dataclasses import replace as _replace

    from jointrig.identify.chain import ChainRecord, chain_system, masked_noise_covariance, noise_cross_covariance
    from jointrig.identify.chain_diagnose import nominal_spec
    from jointrig.vocab.law import Power

    spec = nominal_spec(2)
    spec = _replace(spec, joints=(tuple(t for t in spec.joints[0] if not (isinstance(t, Power) and t.power > 1)),))
    values = {"J1_kgm2": 2.0, "J2_kgm2": 1.5, "joint1_c_Nms_per_rad": 100.0, "joint1_k_Nm_per_rad": 2000.0}
    theta = np.array([values[n] for n in spec.names])
    w, band, n, H = 30.0, 6, 128, 6
    sa, st, per = np.array([1e-3, 2e-3]), np.array([0.5, 0.0]), 0.01
    theta_t = 2 * np.pi * np.arange(n) / n
    mask = (np.sin(theta_t) > 0.6).astype(float)  # slides 40% of the period
    mask.setflags(write=False)
    basis = np.vstack([np.ones(n)] + [f(h * theta_t) for h in range(1, band + 1) for f in (np.cos, np.sin)])
    scale = np.sqrt(np.r_[0.5, np.ones(2 * band)] * per)
    rng = np.random.default_rng(11)
    t = np.arange(n) * (2 * np.pi / w) / n

    def rows(noise, merged, slipping):
        a1, a2, T = ((rng.standard_normal(2 * band + 1) * scale * sd) @ basis for sd in noise)
        rec = ChainRecord(w, t, (T, None), (a1, a2), None, 1, 1.0, source="noise")
        b = chain_system([rec], spec, n_harmonics=H, first_harmonic=1, merged=merged, slipping=slipping)
        return b, b.system.F - b.system.A @ theta

    for merged, slipping in (([(0,)], [(mask,)]), (None, None)):
        b, _ = rows((sa[0], sa[1], st[0]), merged, slipping)
        s = b.system
        C = masked_noise_covariance(s.row_harmonic, s.row_part, s.row_equation,
                                    {e: b.bodies[(0, e)] for e in set(s.row_equation.tolist())}, spec, values, w,
                                    band, n, sa, st, per)
        draws = np.array([rows((sa[0], sa[1], st[0]), merged, slipping)[1] for _ in range(3000)])
        mc = draws.T @ draws / len(draws)
        sd = np.sqrt(np.outer(np.diag(mc), np.diag(mc)))
        se = np.sqrt((sd ** 2 + mc ** 2) / len(draws))
        assert np.all(np.abs(C - mc) <= 5 * se), np.max(np.abs(C - mc) / se)
        if merged is None:
            for h in range(1, H + 1):
                r = np.flatnonzero(s.row_harmonic == h)
                ref = per * noise_cross_covariance(spec, values, h * w, sa, st)
                pos = s.row_part[r] * 2 + s.row_equation[r]
                np.testing.assert_allclose(C[np.ix_(r, r)], ref[np.ix_(pos, pos)], rtol=1e-10, atol=1e-12 * ref.max())
                assert np.max(np.abs(C[np.ix_(r, np.flatnonzero(s.row_harmonic != h))])) < 1e-12 * np.max(C)
        else:  # the slides' rows are correlated across harmonics
            own = np.flatnonzero(s.row_equation == 3)
            corr = C[np.ix_(own, own)] / np.sqrt(np.outer(np.diag(C)[own], np.diag(C)[own]))
            assert np.max(np.abs(corr - np.eye(own.size))) > 0.3


def test_a_fits_covariance_is_the_sandwich_over_its_rows_cross_covariances(tmp_path):
    # _Problem.cross_covariance feeds the fit's covariance: B (A'WA + A'WCWA) B max(1, chi2/dof)
    # nu / (nu - 2) (the weights' own estimate, identify.estimates.weighted_chi2),
    # built here densely from identify.chain.row_covariance (the ML fit's row mapping, not the
    # diagnosis's), C the off-diagonal part of each run's and harmonic's block, each correlation
    # held within the rows' own variances. The two flywheels of the independent bench at 1%
    # noise; agreement to 1e-6 (round-off of two orders of summation and an inverse).
    from jointrig.identify.chain import row_covariance
    from jointrig.identify.chain_diagnose import _Problem, nominal_spec, prepare_chain_runs

    pts = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1][:3]
    path = measure(JOINTS["paper"], pts, tmp_path / "b.csv", seed=2, fs_Hz=2000.0, n_periods=6.5, noise=1e-2)
    runs = prepare_chain_runs(read_runs(path).records, band=21)
    H = 20
    prob = _Problem(tuple(runs), H, 2.0 * (min(r.n_periods for r in runs) - 1), 1e-9, (False, False), ())
    spec = nominal_spec(2)
    fit, w = prob.fit(spec)
    s = prob.system(spec).system
    A = s.A
    D = 1.0 / np.linalg.norm(A * np.sqrt(w)[:, None], axis=0)
    B = D[:, None] * np.linalg.inv((A * D).T @ ((A * D) * w[:, None])) * D[None, :]
    Q = np.zeros_like(B)
    for k, run in enumerate(runs):
        rec = run.average
        sa = [run.noise_std["phi1"], run.noise_std["phi2"]]
        _, C = row_covariance(rec, spec, fit.values, sigma_angle_rad=sa, sigma_torque_Nm=run.noise_std["torque1"],
                              n_harmonics=H)
        C = C * rec.n_samples / (run.samples_per_period * run.n_periods)  # per raw sample over P periods
        rows = np.flatnonzero(s.row_record == k)
        d, v = np.sqrt(np.diag(C)), 1.0 / np.sqrt(w[rows])
        off = C / np.outer(d, d) * np.minimum(np.outer(d, d), np.outer(v, v))
        np.fill_diagonal(off, 0.0)
        Aw = A[rows] * w[rows, None]
        Q += Aw.T @ off @ Aw
    factor = max(1.0, fit.chi2 / fit.dof) * prob.nu / (prob.nu - 2)
    want = (B + B @ Q @ B) * factor
    np.testing.assert_allclose(fit.std_errors, np.sqrt(np.diag(want)), rtol=1e-6)
    assert np.max(np.abs(np.sqrt(np.diag(want)) / np.sqrt(np.diag(B * factor)) - 1)) > 0.02  # it does move them


def test_the_weighted_chi_square_and_its_covariance_factor_on_exact_rows():
    # Ten rows of residual 1 and weight 2: raw chi-square 20. With weights estimated from nu
    # degrees of freedom it is scaled by (nu - 2) / nu and the covariance by nu / (nu - 2)
    # (times chi2 / dof where that is above 1); at nu <= 2 (two periods) no scale is defined and
    # none is applied. Exact arithmetic on small numbers: to round-off.
    from jointrig.identify.estimates import weighted_chi2

    r, w = np.ones(10), np.full(10, 2.0)
    row, chi2, on_solver, on_inverse = weighted_chi2(r, w, 4.0, 5)
    assert chi2 == pytest.approx(10.0) and row == pytest.approx(np.ones(10))
    assert on_inverse == pytest.approx(2.0 * 2.0)  # chi2 / dof = 2, times nu / (nu - 2) = 2
    assert on_solver == pytest.approx(on_inverse / 4.0)  # the raw chi2 / dof, 20 / 5
    assert weighted_chi2(r, w, 3.0, 100)[1:] == pytest.approx((20.0 / 3.0, 3.0 / 0.2, 3.0))
    for nu in (2.0, 1.0):
        assert weighted_chi2(r, w, nu, 100)[1:] == pytest.approx((20.0, 1.0 / 0.2, 1.0))
    # no degrees of freedom left: taken as one
    assert weighted_chi2(r, w, 4.0, 0)[1:] == pytest.approx((10.0, 20.0 / 20.0, 20.0))


def test_the_measured_fidelity_is_the_balances_misfit_not_the_rigs(tmp_path, monkeypatch):
    # What the fidelity stands for is what the balance misses on records of the fitted model. On
    # noise-free records of the independent bench (the paper's joint with 20 N m of dry friction,
    # event-driven stick-slip) that is measured directly: the records themselves balanced at the
    # fit. The rig's replay of the same fit, balanced alike, must read about as much, not its own
    # error at the kinks: at the validation's step (FIDELITY_STEP_SHARE 1) it read 7.2 times the
    # records' misfit overall (4-30 times run by run); at the fidelity's step it must stay within
    # 3 times (measured 2.5; deterministic: no noise, a fixed seed). A misfit 3 times too large is
    # a variance 9 times too large: standard errors up to 3 times too wide where it outweighs
    # the noise (80 dB).
    from jointrig.identify import defaults
    from jointrig.identify.chain_diagnose import balance_fidelity, diagnose_chain, prepare_chain_runs
    from jointrig.identify.zeros import rezeroed, sensor_zeros
    from jointrig.studies import chain_validate

    points = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1][:4]
    path = measure(with_effect(JOINTS["paper"], Fc=20.0), points, tmp_path / "exact.csv", seed=1, fs_Hz=2000.0,
                   n_periods=6.5, noise=0.0)
    records = read_runs(path).records
    zeros = sensor_zeros(records)
    runs = prepare_chain_runs([rezeroed(r, zeros) for r in records], band=20)
    d = diagnose_chain(runs, n_harmonics=20, fidelity=1e-3)
    assert [s.effect for s in d.steps] == ["coulomb_friction"], [s.label for s in d.steps]
    on_records = balance_fidelity(list(runs), d.final, d.n_harmonics, d.masked, d.merging).relative
    rig = rig_of_bodies(2, [1])

    def on_replay() -> float:
        got = chain_validate.rig_replay(rig, runs, 20)(d.final)
        assert not isinstance(got, str) and all(g is not None for g in got), got
        return balance_fidelity(got, d.final, d.n_harmonics, d.masked, d.merging).relative

    fine = on_replay()
    monkeypatch.setattr(chain_validate, "FIDELITY_STEP_SHARE", 1.0)
    coarse = on_replay()
    assert 0 < on_records and fine < 3 * on_records < coarse, (on_records, fine, coarse)
    assert defaults.FIDELITY_STEP_SHARE < 1


def test_the_fidelitys_replay_step_is_a_share_of_the_replay_step_unless_a_period_is_long():
    # A quarter of 5e-5 s where the period is short (40 rad/s: 0.157 s, 12,600 steps); where a
    # quarter would take more than MAX_REPLAY_STEPS_PER_PERIOD (2e5) steps a period, as fine as
    # those allow (2 rad/s: 3.14 s / 2e5 = 1.57e-5 s); never coarser than the replay step (0.5
    # rad/s: 12.6 s / 2e5 = 6.3e-5 s would be coarser: 5e-5 s). Exact: one division and a choice.
    from jointrig.identify.defaults import FIDELITY_STEP_SHARE, MAX_REPLAY_STEPS_PER_PERIOD, REPLAY_MAX_STEP_S
    from jointrig.studies.chain_validate import fidelity_step_s

    assert fidelity_step_s(40.0) == FIDELITY_STEP_SHARE * REPLAY_MAX_STEP_S
    assert fidelity_step_s(2.0) == pytest.approx(math.pi / MAX_REPLAY_STEPS_PER_PERIOD, rel=1e-12)
    assert fidelity_step_s(0.5) == REPLAY_MAX_STEP_S


def test_a_condition_number_does_not_depend_on_the_columns_units():
    # identify.estimates.equilibrated_condition: each column scaled to unit norm, then the ratio of
    # the largest to the smallest singular value (numpy's own 2-norm condition as reference); a
    # column in kg m^2 beside one in N m/rad is no ill-conditioning. A zero column, or none, is
    # inf. Round-off of one SVD: 1e-12.
    from jointrig.identify.estimates import equilibrated_condition

    B = np.array([[1.0, 0.5, 0.2], [0.0, 1.0, 0.4], [0.3, 0.0, 1.0], [0.1, 0.2, 0.3]])
    want = np.linalg.cond(B / np.linalg.norm(B, axis=0))
    assert 1.5 < want < 10.0
    assert equilibrated_condition(B) == pytest.approx(want, rel=1e-12)
    assert equilibrated_condition(B * [1e-3, 1.0, 2e4]) == pytest.approx(want, rel=1e-12)
    assert equilibrated_condition(np.diag([1e-3, 1.0, 2e4])) == pytest.approx(1.0, rel=1e-12)
    assert equilibrated_condition(np.column_stack([B[:, :2], np.zeros(4)])) == math.inf
    assert equilibrated_condition(np.zeros((0, 3))) == math.inf
