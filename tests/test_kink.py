"""The kink correction of a dry friction's band-limited rate (identify/kink.py)."""

import numpy as np

from jointrig.identify.balance import spectral_rate
from jointrig.identify.harmonics import fourier_coefficients
from jointrig.identify.kink import kink_corrected_rate, kink_first_pass, switch_shifts


def test_kink_correction_adds_only_out_of_band_harmonics_and_batches_exactly():
    # A diagnosis takes its inertia, torque and viscous columns from the band-limited rate
    # because the kink correction adds harmonics above the band only: in the band the corrected
    # rate's coefficients equal the band-limited ones to round-off (1e-12 of the largest), and
    # out of band it adds something. Periods corrected together are corrected as one by one, and
    # without a given band-limited rate it is computed the same.
    M, band = 4096, 20
    omegas = np.array([25.0, 40.0, 55.0])
    th = 2 * np.pi * np.arange(M) / M
    phi = np.stack([0.2 * np.sin(th) + 0.01 * np.sin(3 * th + k) + 0.004 * np.cos(7 * th) for k in range(3)])
    v_bl = spectral_rate(phi, omegas[:, None], 1)
    batch = kink_corrected_rate(phi, omegas, band, 300.0)
    np.testing.assert_array_equal(batch, kink_corrected_rate(phi, omegas, band, 300.0, band_limited_rate=v_bl))
    for k, w in enumerate(omegas):
        one = kink_corrected_rate(phi[k], w, band, 300.0, band_limited_rate=v_bl[k])
        np.testing.assert_allclose(batch[k], one, rtol=0, atol=1e-12 * np.abs(one).max())
    C, C_bl = fourier_coefficients(batch, 1, M // 2 - 1), fourier_coefficients(v_bl, 1, M // 2 - 1)
    scale = np.abs(C_bl).max()
    assert np.abs(C[:, : band + 1] - C_bl[:, : band + 1]).max() < 1e-12 * scale
    assert np.abs(C[:, band + 1:]).max() > 1e-4 * scale
    assert np.array_equal(kink_corrected_rate(phi, omegas, band, 0.0), v_bl)
    # The first pass does not depend on the jump: one computed for the records serves every jump
    # (a profile search's trials), with the same result as computing it afresh.
    first = kink_first_pass(phi, omegas, band, band_limited_rate=v_bl)
    for jump in (300.0, 45.0, 2000.0):
        np.testing.assert_array_equal(kink_corrected_rate(phi, omegas, band, jump, first_pass=first),
                                      kink_corrected_rate(phi, omegas, band, jump))


def test_the_kinks_restored_are_the_rates_own_above_the_band():
    # A rate whose slope jumps by -J sign(v') at each of its zero crossings, as dry friction's
    # does: a smooth part plus J/2 B2((t - t_c)/T) per crossing (B2 the periodic Bernoulli
    # polynomial x^2 - x + 1/6, whose slope jumps by -1 at 0), the crossings found by iteration.
    # Given only its band-limited angle (harmonics 1..20), the corrected rate is that rate to
    # 2e-5 of its peak (measured 1.8e-5: the crossings' two passes), where the band-limited rate
    # is 2e-3 off: the kinks' harmonics above the band restored with their phases and sizes.
    M, band, w, J = 4096, 20, 2 * np.pi, 0.8
    t = np.arange(M) / M
    smooth = np.sin(2 * np.pi * t + 0.3) + 0.2 * np.cos(6 * np.pi * t)

    def crossings(v):
        up = v > 0
        i = np.flatnonzero(up != np.roll(up, -1))
        return (i + v[i] / (v[i] - v[(i + 1) % M])) / M, np.sign(v[(i + 1) % M] - v[i])

    def with_kinks(tc, rising):
        x = np.mod(t[:, None] - tc[None, :], 1.0)
        return smooth + (J * rising * 0.5 * (x * x - x + 1.0 / 6.0)).sum(axis=1)

    tc, rising = crossings(smooth)
    for _ in range(20):
        tc, rising = crossings(with_kinks(tc, rising))
    v = with_kinks(tc, rising)
    V = np.fft.rfft(v)
    h = np.arange(1, band + 1)
    Phi = np.zeros_like(V)
    Phi[1:band + 1] = V[1:band + 1] / (1j * h * w)
    phi = np.fft.irfft(Phi, n=M)
    v = v - v.mean()
    plain = kink_corrected_rate(phi, w, band, 0.0)
    assert np.abs(plain - v).max() > 1e-3 * np.abs(v).max()
    assert np.abs(kink_corrected_rate(phi, w, band, J) - v).max() < 2e-5 * np.abs(v).max()


def _sign_coefficients(v: np.ndarray, n_harmonics: int) -> np.ndarray:
    """sign(v)'s coefficients with its switches at the linearly interpolated crossings (exact for
    a piecewise-constant column, no sampling of the switch)."""
    M = v.size
    up = v > 0
    i = np.flatnonzero(up != np.roll(up, -1))
    t = (i + v[i] / (v[i] - v[(i + 1) % M])) / M  # in periods
    h = np.arange(1, n_harmonics + 1)
    # d/dt sign(v) = sum_c 2 s_c delta(t - t_c) (s_c the crossing's direction): C_h of sign is that over i h w
    s = np.sign(v[(i + 1) % M] - v[i])
    dC = (2.0 * s[:, None] * 2.0 * np.exp(-2j * np.pi * np.outer(t, h))).sum(axis=0)  # T * C_h of the derivative
    return dC / (2j * np.pi * h)


def test_a_switch_moves_by_the_rate_over_its_slope_and_its_coefficients_are_the_columns_first_order_change():
    M, T = 512, 0.25
    t = np.arange(M) / M * T  # sample n at n dt, as fourier_coefficients reads it
    v = np.sin(2 * np.pi * t / T + 0.7)
    dr = np.array([[1e-5], [-2e-5], [1e-5]])  # each period's rate: v + dr (their mean is v)
    shifts = switch_shifts(v, v + dr, T)
    crossings = (np.array([np.pi, 2 * np.pi]) - 0.7) / (2 * np.pi) * T
    assert np.allclose(np.sort(shifts.at_s), crossings, atol=1e-4 * T)  # linear interpolation of the sine
    # a constant dr moves both switches by dr / |v'| (s per unit jump); one sample's difference
    # reads the sine's slope to about (w dt)^2 / 6 = 2.5e-5 of it: tolerance 1e-3
    assert np.allclose(shifts.area_s, dr / (2 * np.pi / T), rtol=1e-3, atol=0)
    # the coefficients are sign(v)'s change when a period's dr is added, to first order: the
    # rest is of relative size h w tau / 2 (2e-4 at the 20th harmonic here, tau = dr / |v'|) and
    # the slope's read (above): tolerance 1e-3 of the change
    H = 20
    got = shifts.coefficients(H, jump=2.0)
    for p, d in enumerate(dr[:, 0]):
        exact = _sign_coefficients(v + d, H) - _sign_coefficients(v, H)
        assert np.allclose(got[p, 1:], exact, rtol=0, atol=1e-3 * np.abs(exact).max())
    # a weight (a stick mask) is read at each switch: zero at the falling one leaves the rising one
    mask = np.ones(M)
    falling = int(round(crossings[0] / T * M))
    mask[falling - 3: falling + 3] = 0.0
    rising = np.abs(shifts.at_s - crossings[1]) < 1e-3
    E = np.exp(-2j * np.pi * np.outer(shifts.at_s / T, np.arange(H + 1))) * np.where(np.arange(H + 1) == 0, 1, 2) / T
    assert np.allclose(shifts.coefficients(H, jump=2.0, weight=mask), 2.0 * (shifts.area_s * rising) @ E,
                       rtol=0, atol=1e-12 * np.abs(got).max())


def test_a_kinked_switch_is_moved_along_the_side_it_moves_to():
    # a rate that rises at 1 before its crossing and at 3 after (dry friction's jump in the
    # acceleration): a higher rate moves the switch earlier, along the slope before it
    M, T = 400, 1.0
    t = (np.arange(M) + 0.5) / M - 0.25  # crossing at t = 0.25 s from the start
    v = np.where(t < 0, t, 3.0 * t)
    v = np.where(np.arange(M) < M * 0.75 - 0.5, v, -(t - 0.5) * 3.0)  # and a fall further on
    dr = np.array([[2e-4], [-2e-4]])
    shifts = switch_shifts(v, v + dr, T)
    rising = int(np.argmin(np.abs(shifts.at_s - 0.25)))
    assert abs(shifts.area_s[0, rising] - 2e-4 / 1.0) < 1e-9
    assert abs(shifts.area_s[1, rising] + 2e-4 / 3.0) < 1e-9


def test_the_periods_scatter_of_switch_shifts_is_the_averages_switch_noise():
    # over many draws of band-limited noise (20 harmonics, as the diagnosis's rates are) on each
    # period's rate, the average's crossings move with variance s2 / (P v'^2), s2 the noise's
    # variance at a point; each draw's own estimate, the periods' sample variance of their shifts
    # over P, must have that mean. 4000 draws hold a variance to +-2.2%: tolerance 8%.
    rng = np.random.default_rng(5)
    M, T, P, H, s = 256, 1.0, 6, 20, 0.002
    n = np.arange(M)
    v0 = np.sin(2 * np.pi * n / M + 0.7)  # crossings far from the period's ends
    basis = np.vstack([f(2 * np.pi * h * n / M) for h in range(1, H + 1) for f in (np.cos, np.sin)])
    truth = H * s**2 / P / (2 * np.pi / T) ** 2  # the noise's variance at a point is H s^2
    moved, estimated = [], []
    for _ in range(4000):
        per = v0 + s * rng.standard_normal((P, 2 * H)) @ basis
        shifts = switch_shifts(per.mean(axis=0), per, T)
        assert shifts.at_s.size == 2
        moved.append(np.sort(shifts.at_s))
        estimated.append(shifts.area_s.var(axis=0, ddof=1) / P)
    assert np.allclose(np.var(moved, axis=0), truth, rtol=0.08)
    assert np.allclose(np.mean(estimated, axis=0), truth, rtol=0.08)


def test_a_crossing_between_a_periods_last_and_first_sample_is_corrected_as_any_other():
    # The period wraps round: a record's period may start anywhere, so a zero crossing of the rate
    # can fall between its last sample and its first. The correction of a period rolled so that
    # one does is the unrolled period's correction, rolled (to round-off); were that crossing
    # missed, the period's count would be odd and it would keep its band-limited rate.
    M, band, w = 1024, 20, 40.0
    th = 2 * np.pi * np.arange(M) / M
    phi = 0.2 * np.sin(th + 0.3) + 0.01 * np.sin(3 * th)
    v = spectral_rate(phi, w, 1)
    i0 = int(np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))[0]) + 1  # v changes sign between i0 - 1 and i0
    for edge in (-1, 0, 1):  # the crossing between samples 0 and 1, the last and the first, M-2 and M-1
        s = (edge - i0) % M
        rolled = np.roll(phi, s)
        vr = spectral_rate(rolled, w, 1)
        assert np.sign(vr[edge - 1]) != np.sign(vr[edge]), edge
        got, want = kink_corrected_rate(rolled, w, band, 300.0), np.roll(kink_corrected_rate(phi, w, band, 300.0), s)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max(), err_msg=str(edge))
        assert np.abs(got - vr).max() > 1e-4 * np.abs(want).max()  # it did correct
