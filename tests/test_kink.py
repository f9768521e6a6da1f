"""The kink correction of a dry friction's band-limited rate (identify/kink.py)."""

import numpy as np

from jointrig.identify.balance import spectral_rate
from jointrig.identify.harmonics import fourier_coefficients
from jointrig.identify.kink import kink_corrected_rate, kink_first_pass


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
