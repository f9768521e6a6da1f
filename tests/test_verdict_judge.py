"""The one verdict (identify.verdict.judge) at its thresholds, for any diagnosis: pure, fast.

The figures that set the thresholds come from the independent bench (tests/test_verdict.py,
tests/test_independent_bench.py); here each boundary is checked on both sides.
"""

from __future__ import annotations

import math

import pytest

from jointrig.identify.verdict import (AT_NOISE, CHI2_PER_DOF_OK, GAIN_AT_NOISE, GAIN_OK, HELDOUT_EXTENDED_OK, HELDOUT_OK,
                                     RIG_FIDELITY, judge)


@pytest.mark.parametrize("c2,ratio,verdict", [
    (CHI2_PER_DOF_OK, HELDOUT_OK, "no_misfit"),               # both bounds inclusive
    (CHI2_PER_DOF_OK * 1.001, 1.0, "unexplained"),
    (1.0, HELDOUT_OK * 1.001, "unexplained"),
    (0.5, 1.0, "no_misfit"),
])
def test_the_nominal_model_explains_the_data_only_within_both_bounds(c2, ratio, verdict):
    v = judge((), c2, ratio, math.nan)
    assert v.verdict == verdict, v
    assert f"at most {CHI2_PER_DOF_OK:g}" in v.reason and f"at most {HELDOUT_OK:g}" in v.reason
    if verdict == "unexplained":
        assert v.reason.startswith("no catalogued cause is significant, but the nominal model does not explain")


@pytest.mark.parametrize("c2,ratio,gain,lost,verdict", [
    (1.0, HELDOUT_EXTENDED_OK, GAIN_OK, "", "explained"),          # every bound inclusive
    (1.0, HELDOUT_EXTENDED_OK * 1.001, 50.0, "", "unexplained"),   # the extension's own bound, not the nominal's
    (1.0, 20.0, 50.0, "", "explained"),                            # 20x the floor passes for an extension
    (1.0, 5.0, GAIN_OK * 0.999, "", "unexplained"),
    (CHI2_PER_DOF_OK * 1.001, 5.0, 50.0, "", "unexplained"),
    (1.0, 5.0, math.nan, "3, 7", "explained"),                     # the nominal has no steady state there
    (1.0, 5.0, math.nan, "", "unexplained"),
    (3.0, 5.0, math.nan, "3", "unexplained"),                      # a lost nominal does not excuse a misfit
])
def test_an_extension_is_adopted_only_when_it_fits_and_gains(c2, ratio, gain, lost, verdict):
    v = judge(("coulomb_friction",), c2, ratio, gain, nominal_lost=lost)
    assert v.verdict == verdict, v
    if verdict == "explained" and lost:
        assert f"no periodic steady state in held-out run(s) {lost}, the extended model does" in v.reason
    elif verdict == "explained":
        assert f"held-out gain {gain:.3g} (at least {GAIN_OK:g})" in v.reason
    else:
        assert v.reason.startswith("the best extension (coulomb_friction) fails validation") and \
            v.reason.endswith("nothing is adopted")
        if not math.isfinite(gain):
            assert "no held-out gain (the nominal model has no steady state in a held-out run)" in v.reason


def test_the_words_follow_the_causes_and_the_held_out_data():
    one = judge(("backlash",), 1.0, 2.0, 10.0)
    two = judge(("coulomb_friction", "backlash"), 1.0, 2.0, 10.0, held="error on the held-out later periods")
    assert one.reason.startswith("backlash explains the data: chi2/dof 1 (at most 2), held-out error 2 times")
    assert two.reason.startswith("coulomb_friction + backlash explain the data")
    assert "error on the held-out later periods 2 times the noise floor (at most 100)" in two.reason


def test_the_thresholds_are_the_measured_ones():
    # Set from the independent bench's cases (their derivation beside them in
    # identify/verdict.py): a change moves every verdict and must be deliberate.
    assert (CHI2_PER_DOF_OK, HELDOUT_OK, HELDOUT_EXTENDED_OK, GAIN_OK) == (2.0, 8.0, 100.0, 3.0)
    assert (GAIN_AT_NOISE, AT_NOISE) == (2.0, 2.0)
    assert RIG_FIDELITY == 1e-5


@pytest.mark.parametrize("ratio,gain,verdict", [
    (AT_NOISE, GAIN_AT_NOISE, "explained"),              # to the noise: a smaller gain confirms it (inclusive)
    (1.29, 2.78, "explained"),                           # the light joint's dry friction, run 1 held out
    (AT_NOISE * 1.001, GAIN_OK * 0.999, "unexplained"),  # not at the noise: the full gain is needed
    (1.0, GAIN_AT_NOISE * 0.999, "unexplained"),         # at the noise, but the nominal model was too
])
def test_an_extension_that_brings_the_held_out_error_to_the_noise_needs_a_smaller_gain(ratio, gain, verdict):
    v = judge(("coulomb_friction",), 1.0, ratio, gain)
    assert v.verdict == verdict, v
    if verdict == "explained":
        assert f"held-out gain {gain:.3g}, to the noise (at least {GAIN_AT_NOISE:g}" in v.reason
