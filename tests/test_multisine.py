"""Odd random-phase multisines: the signal, and what its non-excited lines reveal in the rig."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointrig.identify import identify
from jointrig.vocab.law import JointLaw, Power
from jointrig.identify.multisine import line_levels, odd_multisine
from jointrig.rig import SimulationConfig, simulate_steady_state
from jointrig.studies.sweep import DEFAULT_MULTISINE, run_multisines

# One worker runs this module: its session-scoped fixture is computed once (pytest-xdist
# --dist loadgroup), not once per worker.
pytestmark = pytest.mark.xdist_group("multisine")


def test_odd_multisine_lines_phases_and_rms():
    ms = odd_multisine(2.0, 35, 500.0, seed=4)
    odd = set(range(1, 36, 2))
    assert set(ms.excited) | set(ms.detection) == odd and not set(ms.excited) & set(ms.detection)
    for g in range(0, 18, 3):  # one detection line in each complete group of three odd lines
        assert len(set(ms.detection) & {1 + 2 * g, 3 + 2 * g, 5 + 2 * g}) == 1
    t = np.arange(4096) * (2 * math.pi / 2.0) / 4096
    x = ms.drive(t)
    assert math.sqrt(np.mean(x**2)) == pytest.approx(500.0, rel=1e-12)  # exact on a whole period
    c = np.array(ms.drive.coeffs)
    assert np.all(c[::2] == 0)                                           # no even lines
    assert ms == odd_multisine(2.0, 35, 500.0, seed=4)                   # seeded
    with pytest.raises(ValueError, match="at least 3"):
        odd_multisine(2.0, 3, 500.0)


@pytest.fixture(scope="session")  # once per worker, even when xdist interleaves other modules
def multisine_runs(rig):
    return run_multisines(rig, DEFAULT_MULTISINE, SimulationConfig(samples_per_period=512))


def test_detection_lines_show_odd_distortion_growing_with_level(multisine_runs):
    low, high = (line_levels(rec, ms) for rec, _, ms in multisine_runs)
    # An odd law: even lines hold round-off only (measured 1e-23 of the excited power).
    assert high.even < 1e-15 * high.excited
    # The cubic term's odd distortion (measured -56 dB at RMS 2000 N m) grows as level^4
    # relative to the excited lines (distortion power ~ A^6, excited ~ A^2): (2000/300)^4 = 2000.
    assert high.odd_detection > 1e-7 * high.excited
    ratio = (high.odd_detection / high.excited) / (low.odd_detection / low.excited)
    # Measured 1776 against 1975: the A^4 law is the cubic term's leading order; at RMS 2000 N m
    # the response also limits itself (the stiffened joint moves less), so 30% is allowed.
    assert ratio == pytest.approx((2000 / 300) ** 4, rel=0.3)


def test_even_lines_reveal_an_asymmetric_law(rig):
    law = JointLaw(rig.law.terms + (Power(2),), rig.law.values + (300.0,))
    ms = odd_multisine(2.5, 35, 2000.0, seed=0)
    rec, _ = simulate_steady_state(rig, 2.5, 2000.0, SimulationConfig(samples_per_period=512), law=law,
                                   drive=ms.drive)
    lv = line_levels(rec, ms)
    assert lv.even > 1e-5 * lv.excited  # a quadratic spring mixes odd lines into even ones


def test_two_multisines_identify_the_joint(rig, multisine_runs):
    res = identify([r for r, _, _ in multisine_runs], rig.law.terms, n_harmonics=DEFAULT_MULTISINE.n_harmonics,
                   torque_share=rig.torque_share)
    truth = {"Je_kgm2": rig.Je_kgm2, **rig.law.as_dict()}
    for name, value in truth.items():
        # 1e-5: RK4 at 0.49 ms and 512 samples per period (measured 1.6e-7 on gamma).
        assert res.value(name) == pytest.approx(value, rel=1e-5), name
