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
