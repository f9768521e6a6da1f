"""Noisy records: the errors-in-variables ML harmonic balance against the Cramer-Rao bound.

The Monte Carlo here is the cheap version of scripts/bench_identification.py (40 instead of
200 realisations); its tolerances follow from that count (stated at each assertion).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from jointrig.vocab.law import Power, Viscous
from jointrig.identify.eiv import _debiased, average_periods, crlb, ml_identify
from jointrig.vocab.records import RecordError
from jointrig.rig.measurement import add_noise, repeat_periods
from jointrig.studies.montecarlo import monte_carlo

# One worker runs this module: its session-scoped fixture is computed once (pytest-xdist
# --dist loadgroup), not once per worker.
pytestmark = pytest.mark.xdist_group("eiv")

N_MC = 40


def test_noise_variance_of_the_mean_from_the_periods(default_sweep):
    rec = repeat_periods(default_sweep[4], 8)
    rng = np.random.default_rng(3)
    sigma = 0.01
    noisy = dataclasses.replace(rec, phi1_rad=rec.phi_rad + rng.normal(0, sigma, rec.n_samples), phi2_rad=None,
                                rate1_rad_s=None, rate2_rad_s=None,
                                torque_Nm=rec.torque_Nm + rng.normal(0, 2 * sigma, rec.n_samples))
    avg = average_periods(noisy)
    # Pooled over N (P - 1) = 256 x 7 degrees of freedom: relative std sqrt(2 / 1792) = 3.3%; 4 sigma.
    assert avg.var_phi_rad2 == pytest.approx(sigma**2 / 8, rel=4 * math.sqrt(2 / 1792))
    assert avg.var_torque_Nm2 == pytest.approx(4 * sigma**2 / 8, rel=4 * math.sqrt(2 / 1792))
    np.testing.assert_allclose(avg.phi_rad, noisy.phi_rad.reshape(8, -1).mean(axis=0))


def test_debiased_cube_removes_the_phantom_stiffness():
    phi = np.linspace(-0.3, 0.3, 11)
    var = 1e-3
    # E[(x + n)^3] = x^3 + 3 var x, so the unbiased column is x^3 - 3 var x (Gauss-Hermite is exact).
    np.testing.assert_allclose(_debiased(Power(3), phi, 0 * phi, var, 0.0), phi**3 - 3 * var * phi, rtol=0, atol=1e-15)
    # Linear terms are unbiased: unchanged but for the rule's round-off.
    np.testing.assert_allclose(_debiased(Power(1), phi, 0 * phi, var, 0.0), phi, rtol=0, atol=1e-16)
    np.testing.assert_allclose(_debiased(Viscous(), phi, phi, var, 1.0), phi, rtol=0, atol=1e-15)


def test_records_without_noise_information_are_refused(default_sweep, rig):
    with pytest.raises(RecordError, match="at least 2"):
        ml_identify(default_sweep[:2], rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    with pytest.raises(RecordError, match="identical"):
        ml_identify([repeat_periods(r, 4) for r in default_sweep[:2]], rig.law.terms, n_harmonics=9,
                    torque_share=rig.torque_share)


def test_a_record_with_one_channel_noise_free_is_refused(default_sweep, rig):
    # The ML weights need both channels' noise: an exactly periodic torque (a generator's
    # setpoint logged instead of a measured torque) beside noisy angles is refused too, and so
    # are noisy torques beside identical angles.
    rng = np.random.default_rng(5)
    base = [repeat_periods(r, 4) for r in default_sweep[:2]]
    noisy_phi = [dataclasses.replace(r, phi1_rad=r.phi_rad + rng.normal(0, 1e-4, r.n_samples), phi2_rad=None,
                                     rate1_rad_s=None, rate2_rad_s=None) for r in base]
    noisy_torque = [dataclasses.replace(r, torque_Nm=r.torque_Nm + rng.normal(0, 1.0, r.n_samples)) for r in base]
    for recs in (noisy_phi, noisy_torque):
        with pytest.raises(RecordError, match="identical"):
            ml_identify(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)


def test_a_noise_free_average_has_no_noise(default_sweep):
    avg = average_periods(default_sweep[0], noise_free=True)
    assert (avg.var_phi_rad2, avg.var_torque_Nm2) == (0.0, 0.0)
    np.testing.assert_array_equal(avg.phi_rad, default_sweep[0].phi_rad.reshape(default_sweep[0].n_periods, -1).mean(0))


def test_crlb_scales_with_the_noise(default_sweep, rig):
    theta = [rig.Je_kgm2, *rig.law.values]
    kw = dict(n_periods=8, n_harmonics=9, torque_share=rig.torque_share)
    n = len(default_sweep)
    a = crlb(default_sweep, rig.law.terms, theta, var_phi_rad2=[1e-8] * n, var_torque_Nm2=[1e-2] * n, **kw)
    b = crlb(default_sweep, rig.law.terms, theta, var_phi_rad2=[4e-8] * n, var_torque_Nm2=[4e-2] * n, **kw)
    np.testing.assert_allclose(b, 4 * a, rtol=1e-9)  # linear in the noise variance
    assert np.all(np.linalg.eigvalsh(a) > 0)


@pytest.fixture(scope="session")  # once per worker, even when xdist interleaves other modules
def mc40(default_sweep, rig):
    truth = {"Je_kgm2": rig.Je_kgm2, **rig.law.as_dict()}
    return monte_carlo(default_sweep, rig.law.terms, truth, snr_db=40.0, n_runs=N_MC, n_periods=8, n_harmonics=9,
                       torque_share=rig.torque_share, seed=11)


def test_monte_carlo_40db_unbiased(mc40):
    # The mean of N_MC estimates has a standard deviation std / sqrt(N_MC) = 0.16 std: the
    # target |bias| < 0.2 std plus 3 of those.
    for p in mc40.parameters:
        assert abs(p.bias_over_std) < 0.2 + 3 / math.sqrt(N_MC), p.name
    # ...while plain least squares on the same records is biased far beyond that (noise in [A]).
    assert max(abs(p.ls_bias_over_std) for p in mc40.parameters) > 3


def test_monte_carlo_40db_efficient(mc40):
    # Observed variance / true variance ~ chi2(N_MC - 1) / (N_MC - 1): within its 0.1% and 99.9%
    # quantiles, an estimator of efficiency >= 0.8 shows an observed efficiency above 0.8 / q_hi.
    lo, hi = stats.chi2.ppf([0.001, 0.999], N_MC - 1) / (N_MC - 1)
    for p in mc40.parameters:
        assert 0.8 / hi <= p.efficiency <= 1 / lo, p.name


def test_monte_carlo_40db_coverage(mc40):
    # Coverage of 95% intervals over N_MC realisations: binomial, 0.1% lower quantile.
    lo = stats.binom.ppf(0.001, N_MC, 0.95) / N_MC
    for p in mc40.parameters:
        assert lo <= p.coverage <= 1.0, p.name


def test_encoder_quantises_the_angles(default_sweep):
    rec = repeat_periods(default_sweep[3], 2)
    q = 1e-3
    m = add_noise(rec, 40.0, np.random.default_rng(0), encoder_resolution_rad=q)
    for x in (m.phi1_rad, m.phi2_rad):
        counts = x / q
        np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-6)  # whole counts
    assert "encoder 0.001 rad/count" in m.source
    with pytest.raises(ValueError, match="encoder_resolution_rad"):
        add_noise(rec, 40.0, np.random.default_rng(0), encoder_resolution_rad=0.0)


def test_fixed_bench_sampling_rate_is_coherent_and_identifiable(rig):
    from jointrig.rig import SimulationConfig
    from jointrig.rig.simulate import coherent_omega
    from jointrig.studies.sweep import SweepPlan, records_of, run_sweep

    fs = 300.0
    with pytest.raises(ValueError, match="not coherent"):
        SimulationConfig(sample_rate_Hz=fs).samples_for(45.0)
    plan = SweepPlan((10.0, 45.0, 90.0), (4000.0,)).coherent(fs)
    assert plan.omegas_rad_s[1] == pytest.approx(coherent_omega(45.0, fs)) and abs(plan.omegas_rad_s[1] - 45.0) < 0.3
    records = records_of(run_sweep(rig, plan, SimulationConfig(sample_rate_Hz=fs)))
    for r in records:  # every run sampled at fs: N = fs T samples per period, whatever the frequency
        assert r.samples_per_period == round(fs * 2 * math.pi / r.omega_rad_s)
        np.testing.assert_allclose(np.diff(r.time_s), 1 / fs, rtol=1e-9)
    rng = np.random.default_rng(8)
    noisy = [add_noise(repeat_periods(r, 8), 40.0, rng) for r in records]
    res = ml_identify(noisy, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    truth = {"Je_kgm2": rig.Je_kgm2, **rig.law.as_dict()}
    for name, value in truth.items():  # 4 standard errors: a 6e-5 chance each if they are right
        assert abs(res.value(name) - value) < 4 * res.std_error(name), name


def test_crlb_equals_the_closed_form_of_a_linear_joint():
    # A linear joint measured with noise on the torque only: the balance rows are linear in
    # (Je, c, k) with exact regressors, so the bound is the Gauss-Markov covariance
    # (sum_runs P A' A / v)^-1, v = s^2 2 sigma^2 / N the variance of one real Fourier row of the
    # averaged torque (complex coefficient (2/N) sum x e^-i.., white noise sigma^2 per sample).
    from jointrig.vocab.records import SteadyStateRecord

    Je, c, k, s, M0, N, P, sigma2 = 1.0, 100.0, 2000.0, 0.5, 400.0, 64, 8, 4.0
    rows, recs = [], []
    for w in (20.0, 45.0, 70.0):
        X = s * M0 / (k - Je * w * w + 1j * c * w)
        t = np.arange(N) * (2 * math.pi / w / N)
        recs.append(SteadyStateRecord(w, t, M0 * np.cos(w * t), (X * np.exp(1j * w * t)).real, None, n_periods=1))
        a = np.array([-(w * w) * X, 1j * w * X, X])  # columns of Je, c, k at the fundamental
        rows += [a.real, a.imag]
    A = np.array(rows)
    v = s * s * 2 * sigma2 / N
    closed = np.linalg.inv(P * A.T @ A / v)
    bound = crlb(recs, (Viscous(), Power(1)), [Je, c, k], var_phi_rad2=[0.0] * 3, var_torque_Nm2=[sigma2] * 3,
                 n_periods=P, n_harmonics=5, torque_share=s)
    # round-off only: 1e-9 of each element's scale sqrt(C_ii C_jj) (the c-Je and c-k
    # covariances are ~0 here, at 1e-17 of the scale)
    scale = np.sqrt(np.outer(np.diag(closed), np.diag(closed)))
    assert np.all(np.abs(bound - closed) <= 1e-9 * scale), (bound, closed)
    np.testing.assert_allclose(np.diag(bound), np.diag(closed), rtol=1e-9)


def test_crlb_refuses_noise_variances_that_do_not_match_its_runs_one_to_one():
    # One angle and one torque variance per run: a list one short would silently drop the last
    # run's information (a bound for fewer runs than asked, too large and no error), so it is
    # refused, as is a list one too long.
    from jointrig.vocab.records import SteadyStateRecord

    Je, c, k, s, M0, N = 1.0, 100.0, 2000.0, 0.5, 400.0, 64
    recs = []
    for w in (20.0, 45.0, 70.0):
        X = s * M0 / (k - Je * w * w + 1j * c * w)
        t = np.arange(N) * (2 * math.pi / w / N)
        recs.append(SteadyStateRecord(w, t, M0 * np.cos(w * t), (X * np.exp(1j * w * t)).real, None, n_periods=1))
    kw = dict(n_periods=8, n_harmonics=5, torque_share=s)
    bound = crlb(recs, (Viscous(), Power(1)), [Je, c, k], var_phi_rad2=[0.0] * 3, var_torque_Nm2=[4.0] * 3, **kw)
    assert bound.shape == (3, 3)
    for n_phi, n_torque in ((3, 2), (2, 3), (3, 4)):
        with pytest.raises(ValueError):
            crlb(recs, (Viscous(), Power(1)), [Je, c, k], var_phi_rad2=[0.0] * n_phi,
                 var_torque_Nm2=[4.0] * n_torque, **kw)


def test_crlb_of_a_cubic_joint_takes_the_true_cube_as_its_column():
    # The bound evaluates the law's columns on the true (noise-free) motion: for gamma phi^3 on
    # phi = Re(X e^(i w t)) the cube's harmonics are (3/4)|X|^2 X at the fundamental and X^3 / 4 at
    # the third, not a column debiased for angle noise the true motion does not have. Torque
    # noise only, so the bound is the Gauss-Markov covariance of those columns (as above).
    from jointrig.vocab.records import SteadyStateRecord

    Je, c, k, gamma, s, M0, N, P, sigma2 = 1.0, 100.0, 2000.0, 5e4, 0.5, 400.0, 64, 8, 4.0
    rows, recs = [], []
    for w in (20.0, 45.0, 70.0):
        X = s * M0 / (k - Je * w * w + 1j * c * w)
        t = np.arange(N) * (2 * math.pi / w / N)
        recs.append(SteadyStateRecord(w, t, M0 * np.cos(w * t), (X * np.exp(1j * w * t)).real, None, n_periods=1))
        first = np.array([-(w * w) * X, 1j * w * X, X, 0.75 * abs(X) ** 2 * X])
        third = np.array([0, 0, 0, X**3 / 4])
        rows += [first.real, first.imag, third.real, third.imag]
    A = np.array(rows)
    v = s * s * 2 * sigma2 / N
    closed = np.linalg.inv(P * A.T @ A / v)
    bound = crlb(recs, (Viscous(), Power(1), Power(3)), [Je, c, k, gamma], var_phi_rad2=[0.0] * 3,
                 var_torque_Nm2=[sigma2] * 3, n_periods=P, n_harmonics=5, torque_share=s)
    # round-off: 1e-9 of each variance (the cube's harmonics are exact on 64 samples)
    np.testing.assert_allclose(np.diag(bound), np.diag(closed), rtol=1e-9)


def test_reported_standard_errors_match_the_monte_carlo_spread(mc40):
    # The estimator's own standard errors against the spread of its estimates, from both sides.
    # Per parameter, std / mean(se) of a right se lies within sqrt of the chi2(N_MC - 1) 0.1% and
    # 99.9% quantiles (0.68..1.34 at 40 draws). Pooled over the 4 parameters (geometric mean)
    # the sampling error shrinks, and the band [0.8, 1.25] catches standard errors 25% too small
    # (ratio 1.43) or 3x too large (0.36) while a right one passes (measured: 1.08 pooled,
    # 1.02-1.12 per parameter).
    lo, hi = np.sqrt(stats.chi2.ppf([0.001, 0.999], N_MC - 1) / (N_MC - 1))
    ratios = []
    for p in mc40.parameters:
        r = p.std / p.mean_std_error
        assert lo <= r <= hi, (p.name, r)
        ratios.append(r)
    pooled = float(np.exp(np.mean(np.log(ratios))))
    assert 0.8 <= pooled <= 1.25, (pooled, ratios)
    # Coverage of the 95% intervals pooled over parameters and realisations (4 x 40 = 160):
    # the binomial 0.1% and 99.9% quantiles; se 25% too small covers ~86%, 3x too large ~100%.
    n = N_MC * len(mc40.parameters)
    pooled_cov = np.mean([p.coverage for p in mc40.parameters])
    cov_lo, cov_hi = stats.binom.ppf([0.001, 0.999], n, 0.95) / n
    assert cov_lo <= pooled_cov <= cov_hi, pooled_cov


def test_halves_are_the_first_and_second_half_of_the_periods():
    # Periods of constant value p (p = 0..P-1): each half's mean is the mean of its p's, its
    # noise the variance of its p's over its count (exact arithmetic); below 4 periods no halves.
    from jointrig.identify.eiv import _halves
    from jointrig.vocab.records import SteadyStateRecord

    def record(P, N=8):
        x = np.repeat(np.arange(P, dtype=float), N)
        t = np.arange(P * N) * (2 * np.pi / (10.0 * N))
        return SteadyStateRecord(10.0, t, x.copy(), x.copy(), None, None, None, P)

    assert _halves(record(3)) is None
    a, b = _halves(record(4))
    assert (a.n_periods, b.n_periods) == (2, 2)
    np.testing.assert_array_equal(a.phi_rad, 0.5) and np.testing.assert_array_equal(b.phi_rad, 2.5)
    a, b = _halves(record(7))  # 3 and 4 periods
    assert (a.n_periods, b.n_periods) == (3, 4)
    assert a.phi_rad[0] == pytest.approx(1.0) and b.phi_rad[0] == pytest.approx(4.5)
    assert a.var_phi_rad2 == pytest.approx(1.0 / 3) and b.var_phi_rad2 == pytest.approx((5 / 3) / 4)


def test_law_derivatives_by_central_difference():
    # The noise map's derivative of a term along phi or phi': exact for quadratics, h^2 for a
    # cube with h = 1e-6 of the signal's own largest value (1e-12 relative here, asked 1e-9).
    from jointrig.identify.eiv import _derivative

    phi = np.linspace(-0.1, 0.1, 11)
    rate = 100.0 * np.linspace(1.0, -1.0, 11)  # rates a thousand times the angles
    np.testing.assert_allclose(_derivative(Power(3), phi, rate, "phi"), 3 * phi**2, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(_derivative(Viscous(), phi, rate, "rate"), 1.0, rtol=1e-9)
    np.testing.assert_allclose(_derivative(Viscous(), phi, rate, "phi"), 0.0, atol=1e-9)
    from jointrig.vocab.law import QuadraticDamping

    # v|v| at v = 0: the difference straddles the kink and gives h = 1e-4 instead of 0.
    np.testing.assert_allclose(_derivative(QuadraticDamping(), phi, rate, "rate"), 2 * np.abs(rate), rtol=1e-9,
                               atol=1.01e-4)


def test_columns_of_a_law_nonlinear_in_the_rate_are_debiased_on_average():
    # A rate-cubic term (phi'^3) on a noisy mean period: the rate is the band-limited derivative
    # of the noisy angle, so its noise variance is var_phi * sum(D1[:, 0]^2) and E[phi'^3] gains
    # 3 phi' var_rate. _prepare's debiased column must average (over noise draws) to the clean
    # column; the undebiased one (noisy=False) must not. The noise makes the bias 1.0% of the
    # column; 1500 draws put the Monte Carlo error of the mean at 0.11% of it (measured: the
    # debiased mean 1.7 of its errors off at worst, the undebiased 17).
    # Bounds: every row within 4 Monte Carlo standard errors for the debiased column (Gaussian
    # mean of 1500 draws), and the undebiased column's worst row beyond 10 of them.
    from jointrig.vocab.law import Monomial
    from jointrig.identify.eiv import PeriodAverage, _prepare

    n, w = 64, 10.0
    t = np.arange(n) * 2 * math.pi / (w * n)
    phi0 = 0.1 * np.cos(w * t) + 0.02 * np.sin(3 * w * t)
    term = Monomial(0, 3)
    kw = dict(n_harmonics=5, share=0.5, rate_band=10)
    clean = _prepare(PeriodAverage(w, phi0, np.zeros(n), 0.0, 0.0, 1, "clean"), (term,), noisy=False, **kw).A[:, 1]
    var_phi = 4e-6
    rng = np.random.default_rng(7)
    deb, raw = [], []
    for _ in range(1500):
        avg = PeriodAverage(w, phi0 + rng.normal(0.0, math.sqrt(var_phi), n), np.zeros(n), var_phi, 0.0, 1, "noisy")
        deb.append(_prepare(avg, (term,), **kw).A[:, 1])
        raw.append(_prepare(avg, (term,), noisy=False, **kw).A[:, 1])
    deb, raw = np.array(deb), np.array(raw)
    se = deb.std(axis=0, ddof=1) / math.sqrt(len(deb))
    big = np.abs(clean) > 0.05 * np.max(np.abs(clean))  # rows that carry the term
    assert np.all(np.abs(deb.mean(axis=0) - clean)[big] < 4 * se[big])
    assert np.max(np.abs(raw.mean(axis=0) - clean)[big] / se[big]) > 10


def test_the_ml_cost_of_a_right_model_is_chi_square(mc40):
    # V = sum e' C^-1 e at the optimum is chi-square with `dof` degrees of freedom when the model
    # and the noise model hold. Measured: mean 0.945 over the 40 realisations (0.79-1.17 each;
    # slightly below 1 because the noise variances are estimated from 8 periods). Asked
    # [0.8, 1.25], the band of the standard errors: a cost of the residuals summed without
    # squaring (about 0) or doubled falls far outside.
    mean = float(np.mean(mc40.cost_over_dof))
    assert len(mc40.cost_over_dof) == N_MC
    assert 0.8 <= mean <= 1.25, mean


def test_every_start_of_the_ml_search_is_exact_on_consistent_rows():
    # The ML search starts from weighted least squares, generalised least squares and
    # instrumental variables. On rows without noise (a linear joint in closed form, as in the
    # CRLB test) each start must return the true (Je, c, k) to round-off: a scaling or a sign
    # slip in any of them would show here, though Levenberg-Marquardt might still recover.
    from jointrig.identify.eiv import PeriodAverage, iterated_gls, _instrumental, _prepare, scaled_ls_start
    from jointrig.vocab.records import SteadyStateRecord

    Je, c, k, s, M0, N = 1.0, 100.0, 2000.0, 0.5, 400.0, 64
    terms = (Viscous(), Power(1))
    runs = []
    for w in (20.0, 45.0, 70.0):
        X = s * M0 / (k - Je * w * w + 1j * c * w)
        t = np.arange(N) * (2 * math.pi / w / N)
        avg = average_periods(SteadyStateRecord(w, t, M0 * np.cos(w * t), (X * np.exp(1j * w * t)).real, None,
                                                n_periods=1), noise_free=True)
        # noise variances only weight the rows (the rows themselves are exact)
        avg = PeriodAverage(avg.omega_rad_s, avg.phi_rad, avg.torque_Nm, 1e-10, 1e-2, 1, avg.source)
        runs.append(_prepare(avg, terms, 5, s, 5, noisy=False))
    truth = np.array([Je, c, k])
    start = scaled_ls_start(runs)
    np.testing.assert_allclose(start, truth, rtol=1e-9)  # measured 9e-16 (GLS 6e-15, IV 2e-16)
    np.testing.assert_allclose(iterated_gls(runs, start * 1.1), truth, rtol=1e-9)  # from a start 10% off
    np.testing.assert_allclose(_instrumental(runs, [(r, r) for r in runs], truth), truth, rtol=1e-9)


def test_the_ml_residual_is_whitened_by_the_full_row_covariance(default_sweep, rig):
    # |L^-1 (A theta - F)|^2 = r' C(theta)^-1 r with C = L L' the rows' covariance, which the
    # cubic term makes non-diagonal (noise in phi enters every harmonic of phi^3): whitening by
    # the wrong triangle, or by the diagonal alone, changes the likelihood.
    from jointrig.identify.eiv import _whitened, linearised, prepare_eiv_runs

    rng = np.random.default_rng(11)
    recs = [add_noise(repeat_periods(r, 4), 40.0, rng) for r in default_sweep[3:6]]
    runs = prepare_eiv_runs(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    # a strong cubic term (gamma 1e4 times the joint's) couples the harmonics' noise
    theta = np.array([rig.Je_kgm2, *rig.law.values]) * np.array([1.0, 1.0, 1.0, 1e4])
    direct = 0.0
    for r in runs:
        C = r.covariance(theta)
        corr = C / np.sqrt(np.outer(np.diag(C), np.diag(C)))
        assert np.max(np.abs(corr - np.eye(len(C)))) > 0.05  # the test needs a coupled covariance
        res = r.A @ theta - r.F
        direct += float(res @ np.linalg.solve(C, res))
    w = _whitened(runs, theta)
    assert float(w @ w) == pytest.approx(direct, rel=1e-9)  # round-off
    A, F = linearised(runs, theta)
    assert float(np.sum((A @ theta - F) ** 2)) == pytest.approx(direct, rel=1e-9)


def test_the_ml_estimate_is_the_likelihoods_minimum_and_a_torque_share_of_0_is_refused(default_sweep, rig):
    # The search runs to the optimum, not a step past its start: there the cost's gradient
    # vanishes (within 1e-3 per standard error: the search's tolerances are 1e-12), and moving
    # any parameter alone by a tenth of its standard error raises the cost by what the bowl's
    # curvature, the inverse covariance, says (0.01 SE^2 (cov^-1)_ii, within 30%: the cubic and
    # the rows' covariance change with the parameters).
    from jointrig.identify.eiv import _whitened, prepare_eiv_runs

    rng = np.random.default_rng(12)
    recs = [add_noise(repeat_periods(r, 4), 40.0, rng) for r in default_sweep[3:6]]
    res = ml_identify(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    runs = prepare_eiv_runs(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    theta = np.asarray(res.values)
    cost = lambda t: float(np.sum(_whitened(runs, t) ** 2))  # noqa: E731
    assert cost(theta) == pytest.approx(res.cost, rel=1e-9)
    h = 1e-6 * np.abs(theta)
    grad = np.array([(cost(theta + e) - cost(theta - e)) / (2 * e[i]) for i, e in enumerate(np.diag(h))])
    assert np.all(np.abs(grad * np.asarray(res.std_errors)) < 1e-3), grad * np.asarray(res.std_errors)
    curvature = np.diag(np.linalg.inv(np.asarray(res.covariance)))
    for i, se in enumerate(res.std_errors):
        step = np.zeros_like(theta)
        step[i] = 0.1 * se
        expected = 0.01 * se**2 * curvature[i]
        assert cost(theta + step) - cost(theta) == pytest.approx(expected, rel=0.3), i
    with pytest.raises(ValueError, match=r"torque_share must be in \(0, 1\]"):
        ml_identify(recs, rig.law.terms, n_harmonics=9, torque_share=0.0)


def test_the_scaled_start_takes_a_run_without_drive_as_it_is():
    # Each run's rows are scaled by its torque's size; a run whose balanced torque is zero (no
    # drive reached it) is kept unscaled rather than divided by zero, and the start is the other
    # runs' exact solution (their rows hold theta = (2, -3) exactly).
    from types import SimpleNamespace

    from jointrig.identify.eiv import scaled_ls_start

    theta = np.array([2.0, -3.0])
    A1 = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    A0 = np.array([[0.5, 0.2], [0.1, 0.3]])
    runs = [SimpleNamespace(A=A1, F=A1 @ theta), SimpleNamespace(A=A0, F=np.zeros(2))]
    start = scaled_ls_start(runs[:1])
    assert np.allclose(start, theta, rtol=1e-12)
    both = scaled_ls_start(runs)
    assert np.all(np.isfinite(both))


def test_a_rate_terms_column_is_debiased_by_the_rates_noise_alone():
    # 2 b(x) - E[b(x + n)] for b = rate^3 with the rate's noise variance 0.5 (rad/s)^2 and no angle
    # noise: E[(v + n)^3] = v^3 + 3 s^2 v, so the column is v^3 - 1.5 v (exact: the rule is
    # exact for a cube); a variance below 1 is noise all the same
    from jointrig.identify.eiv import _debiased
    from jointrig.vocab.law import Monomial

    v = np.linspace(-2.0, 2.0, 9)
    col = _debiased(Monomial(0, 3), np.zeros_like(v), v, 0.0, 0.5)
    np.testing.assert_allclose(col, v**3 - 1.5 * v, atol=1e-12)


def test_records_of_two_or_three_periods_are_identified_without_the_halves_start(default_sweep, rig):
    # Below 4 periods a record has no two halves to take instruments from: the ML search starts
    # from generalised least squares alone, and the estimate is the right joint's all the same.
    # 40 dB, a fixed seed: every parameter within 4 of its standard errors of the truth (measured:
    # at most 2.1 over 8 seeds each of 2 and 3 periods; a right model's estimate is ~N(truth, SE)).
    truth = np.array([rig.Je_kgm2, *rig.law.values])
    for P in (2, 3):
        rng = np.random.default_rng(3)
        recs = [add_noise(repeat_periods(r, P), 40.0, rng) for r in default_sweep[3:6]]
        res = ml_identify(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
        assert res.success and res.n_runs == 3, res.message
        z = (np.asarray(res.values) - truth) / np.asarray(res.std_errors)
        assert np.all(np.abs(z) < 4), (P, z)


def test_of_two_minima_the_ml_search_keeps_the_lower_cost(default_sweep, rig):
    # Under heavy noise the likelihood can hold two minima: the one Levenberg-Marquardt reaches
    # from the generalised-least-squares start alone (solve_penalised without a penalty) and the
    # one from the instrumental start. ml_identify refines both and keeps the lower cost. Three
    # runs a third of the sweep apart, 4 periods, 20 dB, seed 0: the two minima's costs are 36.08
    # and 28.39 (measured), far apart against the search's tolerances (ftol 1e-12 relative): the
    # kept cost must lie below the GLS start's minimum by more than 1 (7.7 measured).
    from jointrig.identify.eiv import prepare_eiv_runs, solve_penalised

    rng = np.random.default_rng(0)
    recs = [add_noise(repeat_periods(r, 4), 20.0, rng) for r in default_sweep[0:18:6]]
    res = ml_identify(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    runs = prepare_eiv_runs(recs, rig.law.terms, n_harmonics=9, torque_share=rig.torque_share)
    gls_only = solve_penalised(runs, rig.law.terms, None)
    assert res.success and gls_only.success
    assert res.cost < gls_only.cost - 1.0, (gls_only.cost, res.cost)


def test_the_cached_fourier_rows_and_derivatives_hold_their_values_and_are_read_only():
    from jointrig.identify.eiv import _row_operator, _unit_derivative

    # Both are cached and shared by every run prepared after: a caller writing into one would
    # change every later fit, so they are read-only. Their values: the rows read C_0, Re C_n,
    # Im C_n of x = Re sum C_n exp(i n theta), and the derivative of cos(2 theta) is
    # -2 sin(2 theta); 1e-14 (sums of 8 products of numbers of order 1, round-off ~1e-15).
    theta = 2 * np.pi * np.arange(8) / 8
    M = _row_operator(8, 3)
    np.testing.assert_allclose(M @ (2 + np.cos(theta) - 0.5 * np.sin(3 * theta)), [2, 1, 0, 0, 0, 0, 0.5],
                               rtol=0, atol=1e-14)
    D = _unit_derivative(8, 1, 3)
    np.testing.assert_allclose(D @ np.cos(2 * theta), -2 * np.sin(2 * theta), rtol=0, atol=1e-14)
    for cached in (M, D):
        with pytest.raises(ValueError, match="read-only"):
            cached[0, 0] = 1.0
    assert _row_operator(8, 3) is M and M[0, 0] == pytest.approx(1 / 8)


def test_a_fit_with_one_degree_of_freedom_left_has_its_chi_square_p_value():
    # One run of a joint that is a damper alone, balanced on harmonics 0..1: 3 rows (the mean,
    # cos and sin of the fundamental) for 2 unknowns (Je in phase with the angle, c in
    # quadrature), one degree of freedom left. The cost is then chi-square(1) under the model and
    # its p-value is chi2.sf(cost, 1), a number in (0, 1], not nan (nan is for a fit with no
    # degree of freedom, or a penalised one). 8 periods, noise 1e-3 of each channel's swing: the
    # estimate within 4 standard errors of the truth. Same formula, so round-off: 1e-12 relative.
    from jointrig.vocab.records import SteadyStateRecord

    Je, c, s, M0, N, P, w = 1.0, 100.0, 0.5, 400.0, 64, 8, 30.0
    X = s * M0 / (-Je * w * w + 1j * c * w)
    t = np.arange(N * P) * (2 * math.pi / w / N)
    rng = np.random.default_rng(4)
    phi = (X * np.exp(1j * w * t)).real + 1e-3 * abs(X) * rng.standard_normal(t.size)
    u = M0 * np.cos(w * t) + 1e-3 * M0 * rng.standard_normal(t.size)
    res = ml_identify([SteadyStateRecord(w, t, u, phi, None, n_periods=P)], (Viscous(),), n_harmonics=1,
                      torque_share=s)
    assert res.success and (res.n_rows, res.dof) == (3, 1)
    assert np.all(np.abs(res.values - [Je, c]) < 4 * res.std_errors), (res.values, res.std_errors)
    assert 0 < res.p_value <= 1
    assert res.p_value == pytest.approx(float(stats.chi2.sf(res.cost, 1)), rel=1e-12)


def test_the_spectral_derivative_keeps_harmonics_up_to_its_band_and_none_above():
    # identify.eiv._derivative_operator: harmonics 1..band differentiated exactly (the band's
    # own included), band + 1 removed; 64 samples a period resolve both
    from jointrig.identify.eiv import _derivative_operator

    N, w, band = 64, 30.0, 5
    theta = 2 * math.pi * np.arange(N) / N
    D = _derivative_operator(N, w, 1, band)
    np.testing.assert_allclose(D @ np.cos(band * theta), -band * w * np.sin(band * theta), atol=1e-9)
    np.testing.assert_allclose(D @ np.cos((band + 1) * theta), 0.0, atol=1e-9)
    D2 = _derivative_operator(N, w, 2, band)
    np.testing.assert_allclose(D2 @ np.sin(2 * theta), -(2 * w) ** 2 * np.sin(2 * theta), atol=1e-7)
