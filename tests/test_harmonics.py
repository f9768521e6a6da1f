"""Layer 1: Fourier extraction on analytic signals (closed forms)."""

import numpy as np
import pytest

from jointrig.identify.harmonics import fourier_coefficients, max_harmonic, synthesize, to_sine_cosine

N = 64  # samples per period


def _t(n_periods=1, n=N):
    return 2 * np.pi * np.arange(n * n_periods) / n  # omega t


def test_trig_polynomial_coefficients_exact():
    th = _t()
    x = 0.3 + 1.5 * np.cos(th) - 0.7 * np.sin(th) + 0.2 * np.cos(3 * th + 0.4)
    c = fourier_coefficients(x, 1, 5)
    X, Xs = to_sine_cosine(c)
    expected_X = [0.3, 1.5, 0, 0.2 * np.cos(0.4), 0, 0]
    expected_Xs = [0, -0.7, 0, -0.2 * np.sin(0.4), 0, 0]
    # atol 1e-14: exact in exact arithmetic; FFT round-off on O(1) values.
    np.testing.assert_allclose(X, expected_X, atol=1e-14)
    np.testing.assert_allclose(Xs, expected_Xs, atol=1e-14)


def test_cubic_of_cosine_closed_form():
    # (A cos t)^3 = 3/4 A^3 cos t + 1/4 A^3 cos 3t: the first harmonic of a cubic spring is 3/4 gamma A^3.
    A = 0.8
    x3 = (A * np.cos(_t())) ** 3
    c = fourier_coefficients(x3, 1, 4)
    np.testing.assert_allclose(c, [0, 0.75 * A**3, 0, 0.25 * A**3, 0], atol=1e-14)


def test_several_periods_average_and_match_single_period():
    th = _t(n_periods=3)
    x = np.cos(th) + 0.1 * np.sin(2 * th)
    np.testing.assert_allclose(fourier_coefficients(x, 3, 4), fourier_coefficients(x[:N], 1, 4), atol=1e-14)


def test_synthesize_inverts_coefficients():
    rng = np.random.default_rng(0)
    c = rng.normal(size=6) + 1j * rng.normal(size=6)
    c[0] = c[0].real
    x = synthesize(c, N)
    np.testing.assert_allclose(fourier_coefficients(x, 1, 5), c, atol=1e-13)


def test_batch_shape():
    x = np.vstack([np.cos(_t()), np.sin(_t())])
    assert fourier_coefficients(x, 1, 3).shape == (2, 4)


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_periods=3), "whole periods"),
    (dict(n_periods=0), "n_periods"),
    (dict(n_periods=1, n_harmonics=max_harmonic(N) + 1), "Nyquist"),
])
def test_bad_arguments_raise(kwargs, match):
    args = dict(n_periods=1, n_harmonics=3) | kwargs
    with pytest.raises(ValueError, match=match):
        fourier_coefficients(np.ones(N + 1 if args["n_periods"] == 3 else N), **args)


def test_max_harmonic_stays_strictly_below_nyquist():
    # 8 samples: Nyquist is harmonic 4, so 3 is the last one resolved; 9 samples: 4.
    assert (max_harmonic(8), max_harmonic(9), max_harmonic(3), max_harmonic(2)) == (3, 4, 1, 0)


def test_harmonic_range_edges():
    x = np.cos(_t())
    np.testing.assert_allclose(fourier_coefficients(x, 1, 0), [0.0], atol=1e-15)  # H = 0: the mean alone
    with pytest.raises(ValueError, match="outside"):
        fourier_coefficients(x, 1, -1)


def test_synthesize_several_periods_and_batches_in_closed_form():
    # Two records (rows) of 3 periods of 16 samples each: x = Re(C1 e^{i th}) + Re(C2 e^{2i th}).
    n, periods = 16, 3
    th = 2 * np.pi * np.arange(n * periods) / n
    c = np.array([[0.5, 1 - 2j, 0.25j], [-1.0, 0.5, 3 + 1j]])
    expected = np.real(c[:, :1] + c[:, 1:2] * np.exp(1j * th) + c[:, 2:3] * np.exp(2j * th))
    np.testing.assert_allclose(synthesize(c, n * periods, periods), expected, atol=1e-13)


def test_synthesize_puts_a_nyquist_harmonic_on_the_alternating_line():
    # 8 samples, harmonic 4 is Nyquist: only Re(C4) is seen, as Re(C4) (-1)^k.
    k = np.arange(8)
    c = np.array([0.0, 0.0, 0.0, 0.0, 0.75 - 5j])
    np.testing.assert_allclose(synthesize(c, 8), 0.75 * (-1.0) ** k, atol=1e-14)
    with pytest.raises(ValueError, match="need more than 8 samples"):
        synthesize(np.ones(6), 8)  # harmonic 5 over 8 samples would fold


def test_two_periods_up_to_the_nyquist_line_round_trip_and_one_more_harmonic_is_refused():
    # 16 samples over 2 periods: harmonic 4 of the period sits on the Nyquist bin (8 of 16), which
    # holds the cosine alone; harmonic 5 has no bin. A signal with lines 0..4 (the Nyquist one a
    # cosine) is synthesised from its coefficients exactly, and its lines below the Nyquist one
    # are read back (fourier_coefficients stops below it).
    from jointrig.identify.harmonics import fourier_coefficients, synthesize

    n, periods = 16, 2
    t = np.arange(n) / n * periods  # in periods
    x = 0.5 + np.cos(2 * np.pi * t + 0.3) + 0.25 * np.sin(2 * np.pi * 3 * t) + 0.125 * np.cos(2 * np.pi * 4 * t)
    C = np.array([0.5, np.exp(0.3j), 0.0, 0.25 * np.exp(-0.5j * np.pi), 0.125])
    np.testing.assert_allclose(synthesize(C, n, periods), x, rtol=0, atol=1e-14)
    below = x - 0.125 * np.cos(2 * np.pi * 4 * t)
    np.testing.assert_allclose(fourier_coefficients(below, periods, 3), C[:4], rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match="5 harmonics over 2 period"):
        synthesize(np.zeros(6), n, periods)


def test_a_shift_moves_each_record_by_its_own_frequency():
    # Two records of two periods each, with their own frequencies (shape (2, 1)): each moved 1 ms
    # later is itself at t - 1 ms, to round-off.
    from jointrig.identify.harmonics import shift_periodic

    w = np.array([[20.0], [35.0]])
    n = 64
    t = np.arange(n)[None, :] * (2 * 2 * np.pi / w / n)  # two periods of each

    def x(s):
        return np.cos(w * s) + 0.3 * np.sin(3 * w * s - 0.2)

    np.testing.assert_allclose(shift_periodic(x(t), 2, w, 1e-3), x(t - 1e-3), rtol=0, atol=1e-13)


def test_an_odd_records_top_line_keeps_its_phase():
    # 7 samples a period hold harmonics 0..3, and the third is a full complex line (only an even
    # record's top bin is a Nyquist line, which holds a cosine alone): a sine there comes back
    from jointrig.identify.harmonics import fourier_coefficients, synthesize

    t = np.arange(7) / 7 * 2 * np.pi
    x = 0.3 + np.cos(t) + 0.5 * np.sin(3 * t + 0.4)
    np.testing.assert_allclose(synthesize(fourier_coefficients(x, 1, 3), 7), x, atol=1e-12)


def test_a_single_record_and_a_stack_of_records_are_shifted_alike():
    # shift_periodic reads the samples along the last axis: one record (n,) with a scalar omega,
    # and records stacked by run and channel (2, 2, n) with one omega per run, each moved 1 ms
    # later is itself at t - 1 ms, to round-off (1e-13, as above).
    from jointrig.identify.harmonics import shift_periodic

    n = 64

    def x(w, s):
        return np.cos(w * s) + 0.3 * np.sin(3 * w * s - 0.2)

    w = 20.0
    t = np.arange(n) * (2 * 2 * np.pi / w / n)  # two periods
    np.testing.assert_allclose(shift_periodic(x(w, t), 2, w, 1e-3), x(w, t - 1e-3), rtol=0, atol=1e-13)
    ws = np.array([20.0, 35.0])[:, None, None]
    ts = np.arange(n)[None, None, :] * (2 * 2 * np.pi / ws / n)
    stack = np.concatenate([x(ws, ts), 0.5 * x(ws, ts + 0.01)], axis=1)  # (2 runs, 2 channels, n)
    moved = np.concatenate([x(ws, ts - 1e-3), 0.5 * x(ws, ts + 0.01 - 1e-3)], axis=1)
    np.testing.assert_allclose(shift_periodic(stack, 2, ws, 1e-3), moved, rtol=0, atol=1e-13)
