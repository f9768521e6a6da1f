"""Layer 1-2: identification from analytic steady states (no simulation), and record checks."""

import math

import numpy as np
import pytest

from jointrig.identify import equivalent_system, identify, solve, spectral_rate
from jointrig.vocab import Power, RecordError, SteadyStateRecord, Viscous

J1, J2, C, K = 2.0, 3.0, 40.0, 1500.0
JE = J1 * J2 / (J1 + J2)
N = 128


def linear_record(omega, M0, n_periods=1, with_rates=True):
    """Exact steady state of two flywheels and a linear joint under M0 cos(omega t) on flywheel 1.

    Relative coordinate: Je phi'' + c phi' + k phi = s M0 cos wt (FRF H = 1/(k - Je w^2 + i c w));
    rigid mode: (J1 + J2) theta'' = M0 cos wt, theta = -M0 cos wt / (w^2 (J1 + J2)).
    """
    t = np.arange(N * n_periods) * 2 * np.pi / (omega * N)
    s = J2 / (J1 + J2)
    H = 1.0 / (K - JE * omega**2 + 1j * C * omega)
    z = s * M0 * H * np.exp(1j * omega * t)
    phi, rate = z.real, (1j * omega * z).real
    theta = -M0 * np.cos(omega * t) / (omega**2 * (J1 + J2))
    theta_rate = M0 * np.sin(omega * t) / (omega * (J1 + J2))
    phi1, phi2 = theta + J2 / (J1 + J2) * phi, theta - J1 / (J1 + J2) * phi
    r1, r2 = theta_rate + J2 / (J1 + J2) * rate, theta_rate - J1 / (J1 + J2) * rate
    return SteadyStateRecord(omega, t, M0 * np.cos(omega * t), phi1, phi2,
                             r1 if with_rates else None, r2 if with_rates else None, n_periods, M0)


OMEGAS = (5.0, 20.0, 27.0, 40.0)


@pytest.mark.parametrize("with_rates", [True, False])
def test_linear_joint_recovered_exactly_from_frf_equivalent_form(with_rates):
    recs = [linear_record(w, 100.0, with_rates=with_rates) for w in OMEGAS]
    res = identify(recs, (Viscous(), Power(1)), form="equivalent", n_harmonics=3, torque_share=J2 / (J1 + J2))
    # rtol 1e-10: exact data, only floating-point round-off (cond ~ 10) separates us from the truth.
    np.testing.assert_allclose(res.values, [JE, C, K], rtol=1e-10)
    assert res.success and res.message == "ok"


def test_linear_joint_recovered_exactly_two_dof_form():
    recs = [linear_record(w, 100.0, n_periods=2) for w in OMEGAS]
    res = identify(recs, (Viscous(), Power(1)), form="two_dof", n_harmonics=3)
    np.testing.assert_allclose(res.values, [J1, J2, C, K], rtol=1e-10)  # as above: exact data


def test_single_frequency_linear_is_rank_deficient():
    # One frequency, linear joint: only k - Je w^2 is determined, Je and k are not separable.
    res = identify([linear_record(20.0, 100.0)], (Viscous(), Power(1)), form="equivalent", n_harmonics=3,
                   torque_share=J2 / (J1 + J2))
    assert not res.success
    assert "rank-deficient" in res.message


def test_spectral_rate_of_analytic_signal():
    rec = linear_record(20.0, 100.0)
    # rtol 1e-12: band-limited signal, the FFT derivative is exact up to round-off.
    np.testing.assert_allclose(spectral_rate(rec.phi_rad, 20.0, 1), rec.rate_rad_s,
                               rtol=0, atol=1e-12 * np.abs(rec.rate_rad_s).max())


def test_weighted_least_squares_uses_weights():
    recs = [linear_record(w, 100.0) for w in OMEGAS]
    system = equivalent_system(recs, (Viscous(), Power(1)), n_harmonics=2, torque_share=J2 / (J1 + J2))
    F = system.F.copy()
    F[system.row_record == 0] *= 1.01  # corrupt one record's forcing by 1%
    corrupted = type(system)(system.A, F, system.names, system.row_record, system.row_harmonic,
                             system.row_part, system.row_equation)
    w = np.where(system.row_record == 0, 1e-12, 1.0)
    plain = solve(corrupted)
    weighted = solve(corrupted, row_weights=w)
    assert np.max(np.abs(plain.values / [JE, C, K] - 1)) > 1e-3
    # rtol 1e-6: the corrupted record keeps a weight of 1e-12, i.e. ~1e-6 influence on the solution.
    np.testing.assert_allclose(weighted.values, [JE, C, K], rtol=1e-6)


def test_standard_errors_match_monte_carlo_spread():
    # Noise on the torque only (enters F): OLS standard errors are the true spread.
    rng = np.random.default_rng(7)
    clean = [linear_record(w, 100.0) for w in OMEGAS]
    estimates, ses = [], []
    for _ in range(200):
        recs = [SteadyStateRecord(r.omega_rad_s, r.time_s, r.torque_Nm + rng.normal(0, 0.5, N), r.phi1_rad,
                                  r.phi2_rad, r.rate1_rad_s, r.rate2_rad_s, 1, 100.0) for r in clean]
        res = identify(recs, (Viscous(), Power(1)), form="equivalent", n_harmonics=5,
                       torque_share=J2 / (J1 + J2))
        estimates.append(res.values)
        ses.append(res.std_errors)
    spread = np.std(estimates, axis=0)
    # 200 runs: the sample std has ~5% relative uncertainty (1/sqrt(2*200)); 25% leaves room for that.
    np.testing.assert_allclose(np.mean(ses, axis=0), spread, rtol=0.25)


@pytest.mark.parametrize("change, match", [
    (dict(torque_Nm=np.full(N, np.nan)), "'torque_Nm' holds 128 non-finite"),
    (dict(phi1_rad=np.zeros(N - 1)), "'phi1_rad' has 127 samples, expected 128"),
    (dict(time_s=np.arange(N) * 0.01), "not uniform"),
    (dict(n_periods=3), "whole periods"),
    (dict(omega_rad_s=-1.0), "omega_rad_s"),
    (dict(rate2_rad_s=None), "both 'rate1_rad_s' and 'rate2_rad_s'"),
])
def test_bad_records_raise_clear_errors(change, match):
    r = linear_record(20.0, 100.0)
    fields = dict(omega_rad_s=r.omega_rad_s, time_s=r.time_s, torque_Nm=r.torque_Nm, phi1_rad=r.phi1_rad,
                  phi2_rad=r.phi2_rad, rate1_rad_s=r.rate1_rad_s, rate2_rad_s=r.rate2_rad_s, n_periods=1,
                  source="bench.csv")
    fields.update(change)
    with pytest.raises(RecordError, match=match) as err:
        SteadyStateRecord(**fields)
    assert "bench.csv" in str(err.value)


def test_too_short_record_raises():
    t = np.arange(4) * 2 * np.pi / 4
    with pytest.raises(RecordError, match="too short"):
        SteadyStateRecord(1.0, t, np.cos(t), np.cos(t), None)


def test_identify_rejects_unknown_form_and_keywords():
    rec = linear_record(20.0, 100.0)
    with pytest.raises(ValueError, match="unknown form"):
        identify([rec], (Viscous(),), form="three_dof")
    with pytest.raises(TypeError):
        identify([rec], (Viscous(),), form="equivalent", torque_share=0.6, harmonics=3)
    with pytest.raises(ValueError, match="torque_share"):
        identify([rec], (Viscous(),), form="equivalent")


# --- edges of the balance and the solver, pinned by hand-computed values (mutation testing
# found them unpinned: scripts/mutation_test.py) -----------------------------------------------

def _system(A, F):
    from jointrig.identify.balance import LinearSystem

    A = np.asarray(A, float)
    m, p = A.shape
    z = np.zeros(m, int)
    return LinearSystem(A, np.asarray(F, float), tuple(f"x{i}" for i in range(p)), z, z, z, z)


def test_solver_statistics_by_hand():
    # Two unknowns, three rows: columns orthogonal with norms 1 and 2 after the solver's column
    # scaling the scaled matrix is orthonormal (condition number exactly 1); the residual of
    # F = (1, 2, 3) is (0, 0, 3): s2 = 9 / (3 - 2), dof 1, relative residual 3 / |F|.
    res = solve(_system([[1, 0], [0, 2], [0, 0]], [1, 2, 3]))
    np.testing.assert_allclose(res.values, [1.0, 1.0], rtol=1e-14)
    assert res.dof == 1 and res.condition_number == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(res.std_errors, [3.0, 1.5], rtol=1e-14)  # sqrt(s2 diag((A'A)^-1))
    assert res.relative_residual == pytest.approx(3 / np.sqrt(14), rel=1e-14)
    assert not res.values.flags.writeable and not res.covariance.flags.writeable
    # The relative residual is scale-free: F a tenth of that (|F| = 0.37, below 1) gives the same.
    small = solve(_system([[1, 0], [0, 2], [0, 0]], [0.1, 0.2, 0.3]))
    assert small.relative_residual == pytest.approx(3 / np.sqrt(14), rel=1e-14)
    # A square system: an exact solve, no degree of freedom left for the noise scale.
    sq = solve(_system([[2, 0], [0, 4]], [2, 4]))
    np.testing.assert_allclose(sq.values, [1.0, 1.0], rtol=1e-14)
    assert sq.dof == 0 and np.all(np.isnan(sq.std_errors))


def test_solver_condition_number_and_rank():
    # Columns (1, 1) and (1, 1 + e) after unit scaling: singular values of [[1, 1], [1, 1+e]]/norms.
    e = 1e-3
    A = np.array([[1.0, 1.0], [1.0, 1.0 + e], [0.0, 0.0]])
    An = A / np.linalg.norm(A, axis=0)
    res = solve(_system(A, [1.0, 2.0, 0.0]))
    assert res.condition_number == pytest.approx(np.linalg.cond(An), rel=1e-9)
    assert res.success
    # Two equal columns: rank 1, reported as such (no exception, success False).
    dup = solve(_system([[1.0, 1.0], [2.0, 2.0], [0.5, 0.5]], [1.0, 2.0, 0.5]))
    assert not dup.success and "rank-deficient: rank 1 < 2" in dup.message
    # Two equal columns that are zero but in one row: the scaled matrix's second singular value is
    # exactly 0 (not round-off), and it is dropped without dividing by it (no warning): the
    # minimum-norm solution of x0 + x1 = 2, (1, 1), to round-off.
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exact = solve(_system([[1.0, 1.0], [0.0, 0.0], [0.0, 0.0]], [2.0, 1.0, 1.0]))
    assert not exact.success and "rank-deficient: rank 1 < 2" in exact.message
    np.testing.assert_allclose(exact.values, [1.0, 1.0], rtol=1e-14)
    # The warning threshold (1e8): a condition number of 2e7 is quiet, 2e9 warns.
    from jointrig.identify.solve import IllConditionedWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        quiet = solve(_system([[1.0, 1.0], [1.0, 1.0 + 1e-7], [0.0, 0.0]], [1.0, 2.0, 0.0]))
    assert 1e7 < quiet.condition_number < 1e8
    with pytest.warns(IllConditionedWarning):
        loud = solve(_system([[1.0, 1.0], [1.0, 1.0 + 1e-9], [0.0, 0.0]], [1.0, 2.0, 0.0]))
    assert loud.condition_number > 1e8


def test_solver_refuses_bad_systems():
    with pytest.raises(ValueError, match="2 equations for 3 unknowns"):
        solve(_system([[1, 0, 0], [0, 1, 0]], [1, 1]))
    with pytest.raises(ValueError, match="non-finite"):
        solve(_system([[np.nan, 0], [0, 1], [1, 1]], [1, 1, 1]))
    with pytest.raises(ValueError, match="non-finite"):
        solve(_system([[1, 0], [0, 1], [1, 1]], [1, np.inf, 1]))
    for w in ([1, 1, -1], [1, np.nan, 1], [1, 0, 1]):
        with pytest.raises(ValueError, match="finite and > 0"):
            solve(_system([[1, 0], [0, 1], [1, 1]], [1, 1, 1]), row_weights=np.array(w, float))
    with pytest.raises(ValueError, match="all-zero column"):
        solve(_system([[1, 0], [2, 0], [1, 0]], [1, 1, 1]))


def test_weighted_solution_by_hand():
    # One unknown, rows x = 1 and x = 4 with weights 3 and 1: x = (3*1 + 1*4) / 4.
    res = solve(_system([[1.0], [1.0]], [1.0, 4.0]), row_weights=np.array([3.0, 1.0]))
    assert res.values[0] == pytest.approx(1.75, rel=1e-14)


def test_harmonic_rows_and_upsampling_by_hand():
    from jointrig.identify.balance import harmonic_rows, upsample

    cols = np.array([[1 + 2j, 3 - 1j, 0.5j], [2.0, -1j, 4 + 4j]])
    rhs = np.array([7.0, 1 + 1j, -2j])
    A, F, harm, part = harmonic_rows(cols, rhs, 2)
    np.testing.assert_array_equal(harm, [0, 1, 1, 2, 2])
    np.testing.assert_array_equal(part, [0, 0, 1, 0, 1])
    np.testing.assert_array_equal(A, [[1, 2], [3, 0], [-1, -1], [0, 4], [0.5, 4]])
    np.testing.assert_array_equal(F, [7, 1, 1, 0, -2])
    # Upsampling a band-limited record is exact; the Nyquist line is dropped.
    th = 2 * np.pi * np.arange(16) / 16
    x = 0.2 + np.cos(3 * th) + 0.5 * np.sin(th)
    th4 = 2 * np.pi * np.arange(64) / 64
    np.testing.assert_allclose(upsample(x, 4), 0.2 + np.cos(3 * th4) + 0.5 * np.sin(th4), atol=1e-13)
    assert upsample(x, 1) is x
    np.testing.assert_allclose(upsample((-1.0) ** np.arange(8), 2), np.zeros(16), atol=1e-15)
    np.testing.assert_allclose(upsample(np.cos(2 * np.pi * np.arange(9) / 9), 2),
                               np.cos(2 * np.pi * np.arange(18) / 18), atol=1e-14)  # odd length


def test_spectral_rate_and_harmonic_range():
    from jointrig.identify.balance import _check_harmonics

    w = 7.0
    t = np.arange(2 * 32) * 2 * np.pi / (w * 32)
    np.testing.assert_allclose(spectral_rate(np.sin(2 * w * t), w, 2), 2 * w * np.cos(2 * w * t), atol=1e-12)
    rec = linear_record(20.0, 100.0)
    with pytest.raises(RecordError, match="n_harmonics=-1"):
        _check_harmonics(rec, -1)
    _check_harmonics(rec, 0)
    with pytest.raises(ValueError, match="torque_share must be in"):
        equivalent_system([rec], (Viscous(), Power(1)), n_harmonics=3, torque_share=0.0)


def test_spectral_rate_of_a_stack_of_records_each_at_its_own_frequency():
    # Three records of 2 periods x 32 samples stacked (3, 64), one omega each as a column (3, 1)
    # (the kink correction's call): each row is differentiated along its own samples, the last
    # axis, at its own frequency: d/dt of cos(n w t + 0.3) exactly (harmonics 1..3, below Nyquist);
    # round-off, 1e-12 absolute against rates of up to 3 x 9 = 27 rad/s.
    w = np.array([[5.0], [7.0], [9.0]])
    k = np.arange(2 * 32)
    n = np.array([[1], [2], [3]])
    t = k * 2 * np.pi / (w * 32)
    rate = spectral_rate(np.cos(n * w * t + 0.3), w, 2)
    assert rate.shape == (3, 64)
    np.testing.assert_allclose(rate, -n * w * np.sin(n * w * t + 0.3), atol=1e-12)

def test_two_dof_form_with_bearing_drag_in_closed_form():
    # Two flywheels, a linear joint and a viscous drag of each flywheel to ground, under M0 cos(w t)
    # on flywheel 1: the steady state from the 2 x 2 dynamic stiffness. The direct form with
    # bearings returns J1, J2, c, k, b1, b2 to round-off (exact rows, noise-free).
    from jointrig.identify import two_dof_system

    b1, b2, M0 = 3.0, 7.0, 400.0
    recs = []
    for w in (15.0, 30.0, 45.0, 70.0):
        Z = np.array([[K - J1 * w * w + 1j * w * (C + b1), -(K + 1j * w * C)],
                      [-(K + 1j * w * C), K - J2 * w * w + 1j * w * (C + b2)]])
        X1, X2 = np.linalg.solve(Z, [M0, 0.0])
        t = np.arange(N) * 2 * np.pi / (w * N)
        e = np.exp(1j * w * t)
        recs.append(SteadyStateRecord(w, t, M0 * np.cos(w * t), (X1 * e).real, (X2 * e).real, None, None, 1))
    res = solve(two_dof_system(recs, (Viscous(), Power(1)), n_harmonics=4, bearings=True))
    truth = {"J1_kgm2": J1, "J2_kgm2": J2, "c_Nms_per_rad": C, "k_Nm_per_rad": K,
             "bearing1_damping_Nms_per_rad": b1, "bearing2_damping_Nms_per_rad": b2}
    assert res.success
    for name, value in truth.items():
        assert res.value(name) == pytest.approx(value, rel=1e-9), name  # measured 1.1e-14


def test_stacking_systems_of_different_parameters_is_refused():
    from jointrig.identify.balance import LinearSystem

    a = equivalent_system([linear_record(30.0, 100.0)], (Viscous(), Power(1)), n_harmonics=3, torque_share=0.6)
    b = equivalent_system([linear_record(40.0, 100.0)], (Viscous(), Power(1), Power(3)), n_harmonics=3,
                          torque_share=0.6)
    with pytest.raises(ValueError, match="parameter names differ"):
        LinearSystem.stack([a, b])
    assert LinearSystem.stack([a, a]).F.size == 2 * a.F.size


def test_torque_share_must_lie_in_the_unit_interval():
    rec = linear_record(30.0, 100.0)
    assert equivalent_system([rec], (Viscous(), Power(1)), n_harmonics=3, torque_share=1.0).F.size > 0
    for bad in (0.0, 1.5):
        with pytest.raises(ValueError, match=r"torque_share must be in \(0, 1\]"):
            equivalent_system([rec], (Viscous(), Power(1)), n_harmonics=3, torque_share=bad)


def test_a_rank_deficient_system_gives_the_minimum_norm_solution_and_says_so():
    # Two copies of the stiffness column: any split of k between them fits; the pseudo-inverse
    # returns the minimum-norm one (an even split), and the result reports the rank.
    from jointrig.identify.balance import LinearSystem

    s = equivalent_system([linear_record(w, 100.0) for w in (20.0, 40.0)], (Viscous(), Power(1)), n_harmonics=3,
                          torque_share=J2 / (J1 + J2))
    k_col = s.A[:, s.names.index("k_Nm_per_rad")]
    # a right-hand side off the columns' span (1e-3 perturbation): the null direction must get
    # no share of the residual either
    F = s.F * (1 + 1e-3 * np.random.default_rng(0).standard_normal(s.F.size))
    dup = LinearSystem(np.column_stack([s.A, k_col]), F, s.names + ("k_copy",), s.row_record, s.row_harmonic,
                       s.row_part, s.row_equation)
    res = solve(dup)
    full = solve(LinearSystem(s.A, F, s.names, s.row_record, s.row_harmonic, s.row_part, s.row_equation))
    assert not res.success and res.message.startswith("rank-deficient: rank 3 < 4 unknowns")
    assert res.value("k_Nm_per_rad") == pytest.approx(res.value("k_copy"), rel=1e-9)
    assert res.value("k_Nm_per_rad") + res.value("k_copy") == pytest.approx(full.value("k_Nm_per_rad"), rel=1e-9)
    assert res.value("Je_kgm2") == pytest.approx(full.value("Je_kgm2"), rel=1e-9)


def test_a_zero_right_hand_side_and_the_default_harmonics():
    from jointrig.identify.balance import LinearSystem

    s = equivalent_system([linear_record(w, 100.0) for w in (20.0, 40.0)], (Viscous(), Power(1)), n_harmonics=3,
                          torque_share=0.6)
    res = solve(LinearSystem(s.A, np.zeros_like(s.F), s.names, s.row_record, s.row_harmonic, s.row_part,
                             s.row_equation))
    assert np.all(res.values == 0) and res.relative_residual == math.inf
    # identify's default balances harmonics 0..9: per record the mean's real row and the real
    # and imaginary rows of harmonics 1..9
    recs = [linear_record(w, 100.0, n_periods=1) for w in (20.0, 40.0)]
    res = identify(recs, (Viscous(), Power(1)), torque_share=J2 / (J1 + J2))
    assert res.n_rows == 2 * (1 + 2 * 9)
