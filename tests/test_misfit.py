"""What an unexplained misfit looks like (identify/misfit.py), on residuals of known form.

Each run is one period of a cosine motion ``A cos(theta)`` with a measured torque that departs
from the model's by a chosen residual; the character's shares, harmonics, slopes and phases
have closed forms on such runs (exact to round-off: whole periods, trigonometric sums), and
the measurements suggested follow from them. The residual runs of real diagnoses are in
tests/test_open_world.py (two flywheels) and tests/test_train_files.py (trains).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointrig.identify.misfit import (HIGH_SHARE, ResidualRun, distinct_settings, misfit_character,
                                      residual_samples, residual_surface, same_setting)
from jointrig.identify.misfit import next_measurements as measurement_values
from jointrig.present.misfit_words import JOINT_WORDS, Words, character_text, measurement_text, surface_text


def next_measurements(c, surface, runs, words=JOINT_WORDS):
    """The measurements that would tell more, in words."""
    return tuple(measurement_text(m, words) for m in measurement_values(c, surface, runs))

N = 256


def _run(run_id, omega, amplitude, residual, *, K=1000.0):
    """A run whose joint torque is ``K phi`` plus ``residual(theta, phi, rate)`` (N m)."""
    theta = 2 * math.pi * np.arange(N) / N
    phi = amplitude / 1000.0 * np.cos(theta)  # rad: the drive level sets the swing
    rate = -amplitude / 1000.0 * omega * np.sin(theta)
    model = K * phi
    return ResidualRun(str(run_id), omega, amplitude, phi, model + residual(theta, phi, rate), model)


def test_an_elastic_odd_residual_on_the_fundamental():
    # a missing stiffness of 10% of K: in phase with the angle, odd, on harmonic 1; 100 / 1100 of the
    # measured torque (K + 100) phi
    runs = [_run(i, w, 1.0, lambda th, p, v: 100.0 * p) for i, w in enumerate((20.0, 30.0, 40.0))]
    c = misfit_character(runs, 10)
    assert c.relative == pytest.approx((100 / 1100,) * 3, rel=1e-12)
    assert c.even_share == pytest.approx(0.0, abs=1e-12) and c.dissipative_share == pytest.approx(0.0, abs=1e-12)
    assert c.top_harmonics[0] == 1 and c.high_share == pytest.approx(0.0, abs=1e-12)
    assert c.phase_deg == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    assert "odd in phi (symmetric)" in character_text(c) and "conservative (elastic)" in character_text(c)


def test_a_dissipative_residual_is_in_quadrature():
    runs = [_run(i, w, 1.0, lambda th, p, v: 2.0 * v) for i, w in enumerate((20.0, 30.0, 40.0))]
    c = misfit_character(runs, 10)
    assert c.dissipative_share == pytest.approx(1.0, rel=1e-12)
    assert [abs(p) for p in c.phase_deg] == pytest.approx([90.0] * 3, rel=1e-9)
    # its size grows with the frequency at one level: slope 1 against omega, 0 against the level
    assert c.frequency_slope == pytest.approx(1.0, abs=1e-9) and c.amplitude_slope == pytest.approx(0.0, abs=1e-9)
    assert "dissipative at the fundamental" in character_text(c) and "grows with frequency" in character_text(c)


def test_two_runs_give_no_slope():
    # three unknowns (a size, a slope against frequency, one against the level) need three runs:
    # two give none (0, "about independent"), not the least-norm guess two equations would
    runs = [_run(i, w, a, lambda th, p, v: 2.0 * v) for i, (w, a) in enumerate(((20.0, 1.0), (40.0, 2.0)))]
    c = misfit_character(runs, 10)
    assert (c.frequency_slope, c.amplitude_slope) == (0.0, 0.0)
    assert misfit_character(runs + [_run(2, 30.0, 1.0, lambda th, p, v: 2.0 * v)], 10).frequency_slope == \
        pytest.approx(1.0, abs=1e-9)


def test_an_even_residual_and_its_measurements():
    # a phi^2 term: harmonic 2 alone (its mean is left out), even; the surface is not point-symmetric
    runs = [_run(i, 30.0, a, lambda th, p, v: 3e4 * p * p) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = misfit_character(runs, 10)
    assert c.even_share == pytest.approx(1.0, rel=1e-12) and c.top_harmonics[0] == 2
    # its size goes with the swing squared: slope 2 against the level
    assert c.amplitude_slope == pytest.approx(2.0, abs=1e-9)
    surface = residual_surface(runs)
    steps = next_measurements(c, surface, runs)
    assert any(s.startswith("runs with a mean (preload) torque and a check of the angle sensors' zero") for s in steps)
    assert not any(s.startswith("runs at more drive levels") for s in steps)  # three levels are there


def test_a_ripple_calls_for_a_quasi_static_ramp_and_a_few_levels_for_more():
    runs = [_run(i, w, 1.0, lambda th, p, v: 5.0 * np.cos(6 * th)) for i, w in enumerate((20.0, 30.0))]
    c = misfit_character(runs, 10)
    assert c.top_harmonics[0] == 6 and c.high_share == pytest.approx(1.0, rel=1e-12) and c.high_share > HIGH_SHARE
    assert "100% of it on harmonics 4 and up" in character_text(c)
    steps = next_measurements(c, residual_surface(runs), runs)
    assert any(s.startswith("a slow, quasi-static ramp of the joint angle") for s in steps)
    assert any(s.startswith("runs at more drive levels (the runs hold 1)") for s in steps)


def test_a_turning_phase_between_frequencies_at_one_level():
    # the residual's axis at the fundamental: in phase at 20 rad/s, 60 deg on at 40 rad/s
    a = _run("a", 20.0, 1.0, lambda th, p, v: 50.0 * np.cos(th))
    b = _run("b", 40.0, 1.0, lambda th, p, v: 50.0 * np.cos(th - math.radians(60)))
    c = misfit_character([a, b], 10)
    assert c.phase_span_deg == pytest.approx(60.0, rel=1e-9)
    assert "turns by 60 deg between frequencies" in character_text(c)
    # at different levels the turn is no evidence (the axis may move with the amplitude)
    b2 = _run("b", 40.0, 2.0, lambda th, p, v: 50.0 * np.cos(th - math.radians(60)))
    assert misfit_character([a, b2], 10).phase_span_deg == 0.0


def test_the_worst_runs_and_the_words_of_a_slide():
    runs = [_run(i, 30.0, 1.0, lambda th, p, v, s=s: s * p) for i, s in enumerate((10.0, 300.0, 100.0))]
    c = misfit_character(runs, 10)
    assert c.worst_runs == ("1", "2")
    slide = Words("force to ground", "x", "position", "N", "m", "force", "position encoder's", "position encoder")
    text = character_text(c, slide)
    assert "the residual force to ground is 0.23 of the force to ground at most" in text  # 300 / 1300 and "odd in x" in text
    assert character_text(c, JOINT_WORDS) == character_text(c)
    surface = surface_text(residual_surface(runs), slide)
    assert "over (x, x')" in surface and " N over x " in surface and "N m" not in surface


def test_residual_samples_are_centred_angles_rates_and_the_residual():
    runs = [_run(0, 30.0, 1.0, lambda th, p, v: 100.0 * p)]
    s = residual_samples(runs)
    np.testing.assert_allclose(s.phi_rad[0], runs[0].phi_resolved_rad, atol=1e-15)  # its mean is already 0
    rate = -1e-3 * 30.0 * np.sin(2 * math.pi * np.arange(N) / N)
    np.testing.assert_allclose(s.rate_rad_s[0], rate, atol=1e-12)
    np.testing.assert_allclose(s.residual_Nm[0], 100.0 * runs[0].phi_resolved_rad, atol=1e-12)


def test_settings_within_a_tolerance_are_one():
    assert distinct_settings([25.0, 25.0004, 40.0, 39.99, 55.0]) == [25.0, 39.99, 55.0]
    assert distinct_settings([100.0, 104.0, 106.0], rel=0.05) == [100.0, 106.0]
    assert same_setting(1500.0, 1502.0, 0.05) and not same_setting(1500.0, 1600.0, 0.05)
    assert same_setting(25.0, 25.2, 0.01) and not same_setting(25.0, 25.3, 0.01)
    # "within" includes the tolerance itself, in both: 5 is 4 (1 + 0.25) and |5 - 4| is 0.2 of 5, exact
    # in binary floating point
    assert distinct_settings([4.0, 5.0], rel=0.25) == [4.0] and same_setting(4.0, 5.0, 0.2)
    assert distinct_settings([4.0, 5.000001], rel=0.25) == [4.0, 5.000001] and not same_setting(4.0, 5.000001, 0.2)


def test_a_cubic_residual_is_odd_and_its_phase_is_the_angles():
    # gamma phi^3: harmonics 1 and 3, none even; on a motion that starts 0.5 rad into its cycle,
    # its fundamental is still in phase with the angle (the phase is relative to the angle's)
    theta = 2 * math.pi * np.arange(N) / N
    phi = 1e-3 * np.cos(theta + 0.5)
    run = ResidualRun("0", 30.0, 1.0, phi, 1000.0 * phi + 5e9 * phi**3, 1000.0 * phi)
    c = misfit_character([run, _run(1, 40.0, 1.0, lambda th, p, v: 5e9 * p**3)], 10)
    assert c.even_share == pytest.approx(0.0, abs=1e-12) and set(c.top_harmonics[:2]) == {1, 3}
    assert c.phase_deg == pytest.approx((0.0, 0.0), abs=1e-9)


def test_a_repeated_setting_tells_run_order_and_a_near_one_does_not():
    # runs 0 and 3 repeat a setting (omega within 1%, level within 5%); a run 2% off in omega does not
    sweep = [(0, 25.0, 1.0, 20.0), (1, 40.0, 1.0, 20.0), (2, 55.0, 1.0, 20.0)]
    cos3 = lambda s: (lambda th, p, v: s * np.cos(3 * th))  # noqa: E731
    base = [_run(i, w, a, cos3(s)) for i, w, a, s in sweep]
    c = misfit_character(base + [_run(3, 25.2, 1.04, cos3(40.0))], 10)
    assert c.repeat_change == pytest.approx(0.5, rel=1e-9) and c.repeat_runs == ("0", "3")
    assert math.isnan(misfit_character(base + [_run(3, 25.5, 1.0, cos3(40.0))], 10).repeat_change)


def test_a_repeated_settings_change_is_relative_at_any_size_of_the_residual():
    # The change between two runs of one setting is relative to their residuals' size: residuals of
    # 0.02 and 0.04 N m on harmonic 3 (a slide's small forces, a joint of 10 N m/rad) change by
    # half, as 20 and 40 N m do (the test above), and ask to repeat the runs (above REPEAT_CHANGE);
    # exact to round-off (whole periods).
    from jointrig.identify.misfit import REPEAT_CHANGE, REPEAT_WITH_TEMPERATURE, next_measurements as asked

    cos3 = lambda s: (lambda th, p, v: s * np.cos(3 * th))  # noqa: E731
    runs = [_run(0, 25.0, 1.0, cos3(0.02), K=10.0), _run(1, 40.0, 1.0, cos3(0.03), K=10.0),
            _run(2, 25.0, 1.0, cos3(0.04), K=10.0)]
    c = misfit_character(runs, 10)
    assert c.repeat_change == pytest.approx(0.5, rel=1e-9) and c.repeat_runs == ("0", "2")
    assert c.repeat_change > REPEAT_CHANGE
    assert any(m.kind == REPEAT_WITH_TEMPERATURE and m.runs == ("0", "2") for m in asked(c, residual_surface(runs), runs))


def test_the_residuals_axis_turns_modulo_half_a_turn():
    # 150 deg apart is an axis 30 deg apart: a residual and its negative lie on one axis
    a = _run("a", 20.0, 1.0, lambda th, p, v: 50.0 * np.cos(th))
    b = _run("b", 40.0, 1.0, lambda th, p, v: 50.0 * np.cos(th - math.radians(150)))
    assert misfit_character([a, b], 10).phase_span_deg == pytest.approx(30.0, rel=1e-9)
    # across the +-180 deg cut: phases +100 and -100 deg differ by 200 deg, an axis turned by 20 deg
    # (round-off of the phases: 1e-9 relative)
    a = _run("a", 20.0, 1.0, lambda th, p, v: 50.0 * np.cos(th + math.radians(100)))
    b = _run("b", 40.0, 1.0, lambda th, p, v: 50.0 * np.cos(th - math.radians(100)))
    c = misfit_character([a, b], 10)
    assert c.phase_deg == pytest.approx((100.0, -100.0), rel=1e-9)
    assert c.phase_span_deg == pytest.approx(20.0, rel=1e-9)


def test_what_is_not_asked_for():
    # a ripple in the rate (sin 6 theta: odd in the rate, so dissipative) asks for no angle ramp;
    # an even residual that grows faster than the drive asks for no sensor calibration (that is for
    # odd ones); an odd elastic one asks for no preload runs
    ripple = [_run(i, w, 1.0, lambda th, p, v: 5.0 * np.sin(6 * th)) for i, w in enumerate((20.0, 30.0))]
    c = misfit_character(ripple, 10)
    assert not any("quasi-static ramp" in s for s in next_measurements(c, residual_surface(ripple), ripple))
    even = [_run(i, 30.0, a, lambda th, p, v: 3e4 * p * p) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = misfit_character(even, 10)
    assert c.amplitude_slope > 1.5 and not any("static calibration" in s
                                               for s in next_measurements(c, residual_surface(even), even))
    odd = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = misfit_character(odd, 10)
    steps = next_measurements(c, residual_surface(odd), odd)
    assert not any("preload" in s for s in steps) and any("static calibration" in s for s in steps)


def test_a_small_ripple_is_still_a_ripple_and_no_residual_reads_as_none():
    # The shares are of the residual's own power, whatever its size against the torque: a ripple
    # of 1% of the torque on harmonics 5, 6, 7 and 1 is 3/4 on harmonics 4 and up, and the three
    # largest harmonics are named (the residual's relative power is far below 1 here). A model
    # that leaves nothing has no share anywhere (0, not NaN: the JSON stays strict) and no top
    # harmonic (none holds any power).
    ripple = lambda th, p, v: 0.01 * (np.cos(5 * th) + 0.9 * np.cos(6 * th) + 0.8 * np.cos(7 * th)) + 0.02 * np.cos(th)  # noqa: E731
    runs = [_run(i, w, 1.0, ripple) for i, w in enumerate((20.0, 30.0))]
    c = misfit_character(runs, 10)
    high = (1 + 0.81 + 0.64) / (1 + 0.81 + 0.64 + 4)
    assert c.high_share == pytest.approx(high, rel=1e-9)
    assert c.top_harmonics == (1, 5, 6)
    none = [_run(i, w, 1.0, lambda th, p, v: 0.0 * th) for i, w in enumerate((20.0, 30.0))]
    c = misfit_character(none, 10)
    assert (c.even_share, c.high_share, c.dissipative_share) == (0.0, 0.0, 0.0)
    assert c.top_harmonics == ()


def test_how_the_misfit_scales_with_the_drive_is_put_in_words():
    # the amplitude slope's words: above 1.5 faster than the drive, above 0.5 with it
    runs = [_run(i, 30.0, a, lambda th, p, v: 100.0 * p) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = misfit_character(runs, 10)
    assert c.amplitude_slope == pytest.approx(1.0, abs=1e-9) and "grows with the drive (slope 1)" in character_text(c)
    from dataclasses import replace

    assert "grows faster than the drive" in character_text(replace(c, amplitude_slope=2.0))
    assert "about independent of the drive level" in character_text(replace(c, amplitude_slope=0.4))


def test_a_misfit_partly_elastic_that_grows_with_frequency_asks_for_a_stepped_sine():
    # the residual c(omega) v + k(omega) phi at one level, its two parts equal at every frequency
    # (its axis does not turn: 45 deg throughout): both parts (the surface's elastic share between
    # 0.3 and 0.7) and a size growing with the frequency; the same growth from a stiffness alone
    # (elastic share near 1) does not ask for it
    mixed = [_run(i, w, 1.0, lambda th, p, v, w=w: 0.05 * w * (v + w * p)) for i, w in enumerate((20.0, 40.0, 80.0))]
    c = misfit_character(mixed, 10)
    surface = residual_surface(mixed)
    assert 0.3 <= surface.elastic_share <= 0.7 and c.frequency_slope > 0.5 and c.phase_span_deg < 30.0
    assert any(s.startswith("a stepped sine at one drive level") for s in next_measurements(c, surface, mixed))
    stiff = [_run(i, w, 1.0, lambda th, p, v, w=w: 0.05 * w * w * p) for i, w in enumerate((20.0, 40.0, 80.0))]
    c = misfit_character(stiff, 10)
    surface = residual_surface(stiff)
    assert surface.elastic_share > 0.7 and c.frequency_slope > 0.5
    assert not any(s.startswith("a stepped sine") for s in next_measurements(c, surface, stiff))
    # nor do both parts at a size that does not change with the frequency
    flat = [_run(i, w, 1.0, lambda th, p, v, w=w: 50.0 * (v / w + p)) for i, w in enumerate((20.0, 40.0, 80.0))]
    c = misfit_character(flat, 10)
    surface = residual_surface(flat)
    assert 0.3 <= surface.elastic_share <= 0.7 and abs(c.frequency_slope) < 1e-9
    assert not any(s.startswith("a stepped sine") for s in next_measurements(c, surface, flat))


def test_each_runs_residual_counts_against_its_own_torque_and_harmonic_4_is_a_ripple():
    # Runs of very different torque (0.01 and 0.1 N m, a slide's small forces alike): a ripple of
    # 10% of the first run's torque on harmonic 5 outweighs one of 5% of the second's on harmonic 6,
    # although the second is the larger in N m. Harmonic 4 already counts as a ripple.
    small = _run("a", 20.0, 1.0, lambda th, p, v: 1e-3 * np.cos(5 * th), K=10.0)
    large = _run("b", 30.0, 1.0, lambda th, p, v: 5e-3 * np.cos(6 * th), K=100.0)
    assert misfit_character([small, large], 10).top_harmonics[:2] == (5, 6)
    four = [_run(i, w, 1.0, lambda th, p, v: 5.0 * np.cos(4 * th)) for i, w in enumerate((20.0, 30.0))]
    assert misfit_character(four, 10).high_share == pytest.approx(1.0, rel=1e-12)


def test_a_run_without_residual_does_not_turn_the_axis():
    # only runs whose residual sits on the fundamental take part in the axis's turn: a run the
    # model fits exactly has no axis
    a = _run("a", 20.0, 1.0, lambda th, p, v: 0.0 * th)
    b = _run("b", 40.0, 1.0, lambda th, p, v: 50.0 * np.cos(th - math.radians(60)))
    assert misfit_character([a, b], 10).phase_span_deg == 0.0


def test_the_measurements_asked_for_start_above_their_thresholds():
    # next_measurements' thresholds are "more than": a misfit exactly at one asks for nothing, one
    # just above it asks; two drive levels ask for more levels (three are the fewest that tell a
    # slope from a line with a check), three do not. The base misfit (odd, elastic, three levels at
    # one frequency) asks for neither a stepped sine nor preload runs.
    from dataclasses import replace

    from jointrig.identify.misfit import PHASE_SPAN_RESONANT_DEG

    runs = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0, 4.0))]
    c, s = misfit_character(runs, 10), residual_surface(runs)

    def asks(text, character=c, surface=s, rs=runs):
        return any(text in m for m in next_measurements(character, surface, rs))

    assert not asks("stepped sine") and not asks("preload") and not asks("more drive levels")
    assert not asks("stepped sine", replace(c, phase_span_deg=PHASE_SPAN_RESONANT_DEG))
    assert asks("stepped sine", replace(c, phase_span_deg=PHASE_SPAN_RESONANT_DEG + 1e-9))
    assert not asks("preload", replace(c, even_share=0.6))
    assert asks("preload", replace(c, even_share=0.6 + 1e-9))
    # a misfit that grows faster than the drive (slope above 1.5) on odd harmonics asks for a
    # sensor calibration
    assert not asks("static calibration", replace(c, amplitude_slope=1.5))
    assert asks("static calibration", replace(c, amplitude_slope=1.5 + 1e-9))
    assert asks("static calibration", replace(c, amplitude_slope=2.0))
    # ... odd: an even share below 0.4 ("less than")
    assert not asks("static calibration", replace(c, amplitude_slope=2.0, even_share=0.4))
    assert asks("static calibration", replace(c, amplitude_slope=2.0, even_share=0.4 - 1e-9))
    # a surface that is not point-symmetric asks for them too, below its threshold ("less than")
    assert not asks("preload", surface=replace(s, symmetric_share=0.3))
    assert asks("preload", surface=replace(s, symmetric_share=0.3 - 1e-9))
    # the description's words share the threshold: at 0.6 a residual is "both odd and even"
    assert "both odd and even" in character_text(replace(c, even_share=0.6))
    assert "(an asymmetry)" in character_text(replace(c, even_share=0.6 + 1e-9))
    # every even harmonic counts as even: a residual on harmonic 4 alone is even through and through
    four = [_run(i, w, 1.0, lambda th, p, v: 10.0 * np.cos(4 * th)) for i, w in enumerate((20.0, 30.0))]
    assert misfit_character(four, 10).even_share == pytest.approx(1.0, rel=1e-12)
    two = runs[:2]
    assert asks("runs at more drive levels (the runs hold 2)", misfit_character(two, 10), residual_surface(two), two)


def test_a_stepped_sine_is_asked_above_a_frequency_slope_of_one_half_either_way():
    # The frequency slope's threshold is "more than" too, on its size: a misfit partly elastic
    # (the surface's elastic share 0.5) whose size goes as omega^0.5 exactly asks for no stepped
    # sine, one just above (either sign: a size that falls with the frequency as fast) does. The
    # base misfit (an odd stiffness at one frequency) has no axis turn to ask for it otherwise.
    from dataclasses import replace

    runs = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0, 4.0))]
    c, s = misfit_character(runs, 10), replace(residual_surface(runs), elastic_share=0.5)
    assert c.phase_span_deg == 0.0

    def asks(slope):
        return any("stepped sine" in m for m in next_measurements(replace(c, frequency_slope=slope), s, runs))

    assert not asks(0.5) and not asks(-0.5)
    assert asks(0.5 + 1e-9) and asks(-0.5 - 1e-9)


def test_a_stepped_sine_is_asked_for_a_surface_partly_elastic_at_the_words_bounds():
    # "Partly elastic" is the surface's words' middle: an elastic share of 0.3 and of 0.7 reads
    # "both elastic and dissipative" (below 0.3 "of the rate", above 0.7 "elastic"), so a misfit
    # growing with the frequency (slope 1) asks for a stepped sine at both bounds and not beyond.
    from dataclasses import replace

    runs = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = replace(misfit_character(runs, 10), frequency_slope=1.0)
    s = residual_surface(runs)
    assert c.phase_span_deg == 0.0

    def asks(share):
        return any("stepped sine" in m for m in next_measurements(c, replace(s, elastic_share=share), runs))

    for share in (0.3, 0.7):
        assert "both elastic and dissipative" in surface_text(_surface(elastic_share=share))
        assert asks(share)
    assert not asks(0.3 - 1e-9) and not asks(0.7 + 1e-9)

def test_a_misfit_counts_against_the_torques_harmonics_not_its_mean_and_a_run_at_rest_stays_finite():
    # The relative misfit is its RMS over the measured torque's RMS on harmonics 1..band: a mean
    # torque (a preload, a cell's offset) does not shrink it (10 N m on the fundamental against a
    # measured 11 N m there: 10/11, whatever the 1000 N m mean). A run whose drive level reads zero
    # (a record at rest beside driven ones) keeps every figure finite, with no warning (the suite
    # turns warnings into errors).
    runs = [_run(i, w, 1.0, lambda th, p, v: 10.0 * np.cos(th) + 1000.0) for i, w in enumerate((20.0, 30.0, 40.0))]
    assert misfit_character(runs, 10).relative == pytest.approx((10.0 / 11.0,) * 3, rel=1e-9)
    rest = _run("rest", 25.0, 0.0, lambda th, p, v: 2.0 * np.cos(2 * th))
    c = misfit_character(runs + [rest], 10)
    assert all(math.isfinite(x) for x in (c.amplitude_slope, c.frequency_slope, c.even_share, c.high_share)), c


def test_of_equal_changes_between_repeated_runs_the_first_pair_is_named():
    # Three runs of one setting whose residuals' magnitudes change by exactly as much between the
    # first and each of the others (sqrt 2 of their size) and not at all between those two: the
    # first pair found is the one named, not a later one of the same change.
    a = _run("a", 25.0, 1.0, lambda th, p, v: 10.0 * np.cos(2 * th))
    b = _run("b", 25.0, 1.0, lambda th, p, v: 10.0 * np.cos(3 * th))
    c = _run("c", 25.0, 1.0, lambda th, p, v: 10.0 * np.cos(3 * th))
    ch = misfit_character([a, b, c], 10)
    assert ch.repeat_change == pytest.approx(math.sqrt(2), rel=1e-9) and ch.repeat_runs == ("a", "b")


def test_a_run_whose_residual_is_not_on_the_fundamental_turns_no_axis():
    # A third run whose residual is 20 times larger on harmonic 3 than on its fundamental (share 1/401
    # there) has no axis worth a phase: the span stays the 30 deg of the two runs on the fundamental.
    a = _run("a", 20.0, 1.0, lambda th, p, v: 50.0 * np.cos(th))
    b = _run("b", 40.0, 1.0, lambda th, p, v: 50.0 * np.cos(th - math.radians(30)))
    c = _run("c", 60.0, 1.0, lambda th, p, v: 2.5 * np.cos(th - math.radians(80)) + 50.0 * np.cos(3 * th))
    assert misfit_character([a, b, c], 10).phase_span_deg == pytest.approx(30.0, rel=1e-9)


def test_the_measurements_asked_for_are_values_with_words_in_the_places_units():
    # what to measure next is a value (its kind and the runs' own counts); the words are made in
    # present/misfit_words.py, in the place's quantities
    from jointrig.identify import misfit as mf
    from jointrig.present.misfit_words import PLACE_WORDS
    from jointrig.vocab.params import SLIDE

    runs = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0))]
    got = measurement_values(misfit_character(runs, 10), residual_surface(runs), runs)
    assert mf.NextMeasurement(mf.MORE_LEVELS, count=2) in got and mf.NextMeasurement(mf.REPEAT_START_END) in got
    kinds = (mf.MORE_FREQUENCIES, mf.QUASI_STATIC_RAMP, mf.SENSOR_CALIBRATION, mf.PRELOAD_AND_ZERO, mf.MORE_LEVELS,
             mf.REPEAT_WITH_TEMPERATURE, mf.REPEAT_START_END)
    slide = PLACE_WORDS[(SLIDE, True)]
    for k in kinds:
        text = measurement_text(mf.NextMeasurement(k, count=4, runs=("a", "b")), slide)
        assert text and "joint torque" not in text and "angle encoder" not in text, (k, text)
    assert "the runs hold 4" in measurement_text(mf.NextMeasurement(mf.MORE_LEVELS, count=4))
    assert "between runs a and b" in measurement_text(mf.NextMeasurement(mf.REPEAT_WITH_TEMPERATURE, runs=("a", "b")))
    assert "ramp of the position with the force to ground" in measurement_text(
        mf.NextMeasurement(mf.QUASI_STATIC_RAMP), slide)
    with pytest.raises(ValueError, match="no words for a measurement of kind 'x'"):
        measurement_text(mf.NextMeasurement("x"))


def _surface(**kw):
    """A hand-made restoring surface on a 3 x 3 grid (the middle knots at 0), every knot supported."""
    from jointrig.identify.surface import RestoringSurface

    base = dict(phi_knots_rad=np.array([-0.1, 0.0, 0.1]), rate_knots_rad_s=np.array([-2.0, 0.0, 2.0]),
                torque_Nm=np.array([[-5.0, -4.0, -3.0], [-1.0, 0.0, 1.0], [3.0, 4.0, 5.0]]),
                supported=np.ones((3, 3), bool), rms_Nm=4.0, fit_rms_Nm=0.4, elastic_share=0.9, symmetric_share=0.9)
    return RestoringSurface(**(base | kw))


def test_a_surfaces_words_follow_its_shares_and_its_supported_sections():
    s = _surface()
    text = surface_text(s)
    assert "a joint torque of the joint angle (elastic)" in text and "point-symmetric (a symmetric law)" in text
    assert "carries 99% of the residual's power" in text
    assert "its stiffness section S(phi, 0) spans -4 to 4 N m over phi -0.1 to 0.1 rad" in text
    assert "its damping section S(0, phi') spans -1 to 1 N m over phi' -2 to 2 rad/s" in text
    # the shares' bounds: more than 0.7 symmetric, less than 0.3 not, in between partly
    assert "partly point-symmetric" in surface_text(_surface(symmetric_share=0.7))
    assert "not point-symmetric" in surface_text(_surface(symmetric_share=0.3 - 1e-9))
    assert "both elastic and dissipative" in surface_text(_surface(elastic_share=0.7))
    assert "of the rate (dissipative)" in surface_text(_surface(elastic_share=0.3 - 1e-9))
    # round-off of the solve (1e-9 of the residual's RMS) reads as 0
    tiny = _surface(torque_Nm=np.array([[-5.0, 1e-12, -3.0], [-1.0, 2.0, 1.0], [3.0, 4.0, 5.0]]))
    assert "spans 0 to 4 N m over phi" in surface_text(tiny)
    # a section with one supported knot is no section
    one = np.ones((3, 3), bool)
    one[0, 1] = one[2, 1] = False
    assert "stiffness section" not in surface_text(_surface(supported=one))


def test_a_repeated_settings_change_at_its_bound_is_no_sign_of_run_order():
    runs = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = misfit_character(runs, 10)
    from dataclasses import replace

    from jointrig.identify.misfit import REPEAT_CHANGE

    at = replace(c, repeat_change=REPEAT_CHANGE, repeat_runs=("0", "1"))
    assert "no sign of run order or time" in character_text(at)
    assert "depends on run order or time" in character_text(replace(at, repeat_change=REPEAT_CHANGE + 1e-9))


def test_a_places_words_and_where_a_trains_misfit_is():
    from types import SimpleNamespace

    from jointrig.present.misfit_words import PLACE_WORDS, places_text, words_of
    from jointrig.vocab.params import HINGE, SLIDE

    assert set(PLACE_WORDS) == {(HINGE, False), (HINGE, True), (SLIDE, False), (SLIDE, True)}
    assert words_of(SimpleNamespace(kind=HINGE, single=False)) == JOINT_WORDS
    assert words_of(SimpleNamespace(kind=HINGE, single=True)).torque == "torque to ground"
    assert words_of(SimpleNamespace(kind=SLIDE, single=False)).torque == "joint force"
    assert places_text(SimpleNamespace(where="joint 1", by_place=(("joint 1", 0.2),))) == "at joint 1"
    two = places_text(SimpleNamespace(where="joint 2", by_place=(("joint 1", 0.05), ("joint 2", 0.2))))
    assert two.startswith("at joint 2, where the residual torque is largest (0.2 of the torque there; joint 1 0.05")


def test_a_characters_words_at_its_bounds():
    # dissipative above a share of 0.6 (partly between 0.4 and 0.6); faster than the drive above a
    # slope of 1.5, not at it; the share on harmonics 4 and up said only above 0.3
    from dataclasses import replace

    runs = [_run(i, 30.0, a, lambda th, p, v: 5e9 * p**3) for i, a in enumerate((1.0, 2.0, 4.0))]
    c = misfit_character(runs, 10)
    assert ", dissipative at the fundamental" in character_text(replace(c, dissipative_share=0.7))
    assert "partly dissipative" in character_text(replace(c, dissipative_share=0.6))
    assert "grows with the drive (slope 1.5)" in character_text(replace(c, amplitude_slope=1.5))
    assert "harmonics 4 and up" not in character_text(replace(c, high_share=0.1))
    assert "40% of it on harmonics 4 and up" in character_text(replace(c, high_share=0.4))
    # at exactly the bound it is not said, as the quasi-static ramp is not asked there
    # (identify.misfit.next_measurements: high_share > HIGH_SHARE, strictly)
    assert "harmonics 4 and up" not in character_text(replace(c, high_share=HIGH_SHARE))
    assert "30% of it on harmonics 4 and up" in character_text(replace(c, high_share=HIGH_SHARE + 1e-9))


def test_a_damping_sections_round_off_reads_as_zero():
    tiny = _surface(torque_Nm=np.array([[-5.0, -4.0, -3.0], [1e-12, 2.0, 1.0], [3.0, 4.0, 5.0]]))
    assert "its damping section S(0, phi') spans 0 to 2 N m" in surface_text(tiny)
