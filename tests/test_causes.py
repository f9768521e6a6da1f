"""One cause catalogue and one evidence measure for every pipeline (identify.causes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointrig.identify.causes import CATALOGUE, OSCILLATOR_CAUSES, at, by_name, evidence, forward_select

JOINT = at("joint")
from jointrig.identify.extend import _added_term
from jointrig.vocab.law import Monomial, Power


def test_every_selection_is_drawn_from_the_one_catalogue():
    names = [c.name for c in CATALOGUE]
    assert len(names) == len(set(names))
    for selection in (JOINT, OSCILLATOR_CAUSES):
        assert all(any(c is k for k in CATALOGUE) for c in selection)
    # the causes both pipelines seek are the very same entries
    shared = {c.name for c in JOINT} & {c.name for c in OSCILLATOR_CAUSES}
    assert shared == {"asymmetric_stiffness"}
    assert by_name("drive_delay") is next(c for c in OSCILLATOR_CAUSES if c.name == "drive_delay")
    with pytest.raises(KeyError, match="quartic"):
        by_name("quartic")


def test_the_oscillator_adds_each_causes_own_term():
    added = {c.name: _added_term(c) for c in OSCILLATOR_CAUSES}
    assert added["drive_delay"] is None  # a late input is a parameter of the simulation, not a term
    assert added["asymmetric_stiffness"] == Power(2) and added["quintic_stiffness"] == Power(5)
    assert added["cubic_damping"] == Monomial(0, 3) and added["amplitude_damping"] == Monomial(2, 1)


def test_evidence_by_hand():
    # chi-square(1) survival at 10 is erfc(sqrt(5)) = 1.565e-3; BIC 10 - ln(100) = 5.395.
    score, p, sig = evidence(10.0, 1, 100, alpha=1e-2, n_causes=1)
    assert score == pytest.approx(10.0 - math.log(100.0), rel=1e-15)
    assert p == pytest.approx(math.erfc(math.sqrt(5.0)), rel=1e-12)
    assert sig  # p < 1e-2 and the score is positive
    assert not evidence(10.0, 1, 100, alpha=1e-2, n_causes=10)[2]  # Bonferroni: p > 1e-3
    assert not evidence(10.0, 3, 100, alpha=1.0, n_causes=1)[2]  # significant, but 3 parameters do not pay
    # A cause already in the model adds no parameter: its refit's round-off is no evidence.
    assert evidence(2.6e-8, 0, 100, alpha=1.0, n_causes=1) == (2.6e-8, 1.0, False)
    # a drop below one: chi-square(1) survival at 0.5 is erfc(0.5); a rise counts as no drop
    assert evidence(0.5, 1, 100)[1] == pytest.approx(math.erfc(0.5), rel=1e-12)
    assert evidence(-3.0, 2, 100)[1] == 1.0
    # the default family-wise level is 1e-3: a drop of 12 with one parameter (p = 5.3e-4) passes
    # it, a drop of 10 (p = 1.6e-3) does not
    assert evidence(12.0, 1, 100)[2] and not evidence(10.0, 1, 100)[2]


def test_forward_select_adopts_until_nothing_earns_it_and_drops_first_only_causes():
    # A toy pipeline whose base is the tuple of adopted names: each round ranks the causes left
    # by a fixed strength, adoption takes the best if it is strong enough. "angle_skew" is
    # first_only: it stays in the pool of round 1 only.
    strength = {"coulomb_friction": 5.0, "backlash": 3.0, "angle_skew": 4.0, "drive_delay": 0.5}
    pool = [by_name(n) for n in strength]
    seen, looked = [], []

    def rank(base, remaining, rnd):
        seen.append((rnd, tuple(c.name for c in remaining)))
        return sorted(((c.name, strength[c.name]) for c in remaining), key=lambda s: -s[1])

    def adopt(base, ranked):
        best = ranked[0]
        return (best, base + (best[0],)) if best[1] > 1.0 else None

    sel = forward_select((), pool, rank=rank, adopt=adopt, max_effects=5, name_of=lambda s: s[0],
                         after=lambda base, chosen, ranked, remaining: looked.append((base, len(remaining))))
    assert sel.base == ("coulomb_friction", "backlash")
    assert [s[0] for s in sel.adopted] == ["coulomb_friction", "backlash"]
    assert seen == [(0, ("coulomb_friction", "backlash", "angle_skew", "drive_delay")),
                    (1, ("backlash", "drive_delay")), (2, ("drive_delay",))]
    assert looked == [(("coulomb_friction",), 2), (("coulomb_friction", "backlash"), 1)]
    assert len(sel.rounds) == 3 and sel.rounds[0][0] == ("coulomb_friction", 5.0)
    # max_effects caps the rounds that adopt; an empty pool ends the loop without a round
    assert forward_select((), pool, rank=rank, adopt=adopt, max_effects=1, name_of=lambda s: s[0]).base == \
        ("coulomb_friction",)
    assert forward_select((), [], rank=rank, adopt=adopt, max_effects=3).rounds == ()


def test_chi2_survival_by_hand():
    # chi-square(1): erfc(sqrt(x / 2)); chi-square(2): exp(-x / 2); chi-square(3):
    # erfc(sqrt(h)) + 2 sqrt(h / pi) exp(-h), h = x / 2. No drop (x <= 0) leaves p = 1.
    from jointrig.identify.causes import chi2_survival

    for x in (1e-6, 0.5, 3.0, 40.0, 700.0):
        h = x / 2
        assert chi2_survival(x, 1) == pytest.approx(math.erfc(math.sqrt(h)), rel=1e-12, abs=1e-300)
        assert chi2_survival(x, 2) == pytest.approx(math.exp(-h), rel=1e-12, abs=1e-300)
        assert chi2_survival(x, 3) == pytest.approx(math.erfc(math.sqrt(h)) + 2 * math.sqrt(h / math.pi) * math.exp(-h),
                                                    rel=1e-12, abs=1e-300)
    assert chi2_survival(0.0, 3) == 1.0 and chi2_survival(-2.0, 1) == 1.0
    for bad in (0, 1.5, -1):
        with pytest.raises(ValueError, match="whole number"):
            chi2_survival(1.0, bad)


# ---------------------------------------------------------------------------- one profile search


class _Fit:
    """A stand-in for a diagnosis's fit: what identify.causes.profile reads (chi2, dof)."""

    def __init__(self, chi2: float, dof: int = 100):
        self.chi2, self.dof = chi2, dof


def test_the_profile_search_finds_a_parabolas_minimum_and_its_standard_error():
    # chi2(h) = 50 + ((h - 0.3) / 0.01)^2 on [0, 1]: minimum at 0.3 (to Brent's tolerance, 1e-6
    # of the range), standard error where chi2 rises by 1: 0.01 (the fit's chi2/dof 0.5 < 1
    # leaves it unscaled; the central difference of a parabola is exact to round-off).
    from jointrig.identify.causes import profile

    cause = by_name("backlash")
    seen = []
    found = profile(lambda h: seen.append(h) or _Fit(50.0 + ((h - 0.3) / 0.01) ** 2), cause, 0.0, 1.0)
    assert found.value == pytest.approx(0.3, abs=2e-6) and found.fit.chi2 == pytest.approx(50.0, abs=1e-6)
    assert found.std_error == pytest.approx(0.01, rel=1e-4)
    assert min(seen) == 0.0 and max(seen) == 1.0  # the grid spans the bounds


def test_the_profile_search_refines_the_deeper_of_two_basins_even_when_the_grid_misses_it():
    # Two basins: a broad one at 0.7 (chi2 15) and a narrow deep one at 0.33 (chi2 10), whose
    # floor the 17-point grid (step 1/16) samples only on its flank (22.25 at 0.3125): the best
    # grid point sits in the broad basin, the deep one's is the second local minimum. Searching
    # both finds the deep minimum; searching the best grid point's alone stops at 0.7.
    from jointrig.identify import causes as C
    from jointrig.identify.causes import profile

    def chi2(h):
        return min(15.0 + 200.0 * (h - 0.7) ** 2, 10.0 + ((h - 0.33) / 0.005) ** 2)

    saved = C.PROFILE_BASINS
    try:
        C.PROFILE_BASINS = 1
        assert profile(lambda h: _Fit(chi2(h)), by_name("backlash"), 0.0, 1.0).value == pytest.approx(0.7, abs=1e-5)
    finally:
        C.PROFILE_BASINS = saved

    found = profile(lambda h: _Fit(chi2(h)), by_name("backlash"), 0.0, 1.0)
    assert found.value == pytest.approx(0.33, abs=1e-5) and found.fit.chi2 == pytest.approx(10.0, abs=1e-6)


def test_the_profile_search_steps_in_the_log_of_a_log_scale_parameter_and_minimises_the_callers_objective():
    # An Iwan slip angle is searched in its logarithm: the grid's points are geometric over
    # [1e-4, 1]; the caller's objective (a penalty on the unphysical side, as the chain's)
    # decides, chi2 gives the standard error.
    from jointrig.identify.causes import PROFILE_GRID_POINTS, profile

    cause = by_name("micro_slip")
    assert cause.log_scale
    seen = []

    def solve(h):
        seen.append(h)
        return _Fit(20.0 + (math.log(h / 0.01) / 0.1) ** 2)

    found = profile(solve, cause, 1e-4, 1.0, objective=lambda f: f.chi2 + (1e6 if f.chi2 > 1e3 else 0.0))
    assert found.value == pytest.approx(0.01, rel=1e-5)
    grid = np.array(seen[:PROFILE_GRID_POINTS])
    assert np.allclose(np.diff(np.log(grid)), math.log(1e4) / (PROFILE_GRID_POINTS - 1))
    # chi2 = 20 + (ln(h/0.01)/0.1)^2: d2chi2/dh2 at 0.01 is 2/(0.1 * 0.01)^2 (the log's own
    # curvature vanishes at the minimum): a standard error of 0.1 * 0.01 = 1e-3 at the small
    # step; over +-1e-3 chi-square rises by `rise` (not quadratic in h there), which the second
    # pass takes: 1e-3 sqrt(2 / rise), 0.46% below (within PROFILE_SE_AGREE: no third pass)
    rise = (math.log(1.1) / 0.1) ** 2 + (math.log(0.9) / 0.1) ** 2
    assert found.std_error == pytest.approx(1e-3 * math.sqrt(2.0 / rise), rel=1e-4)


def test_a_profiles_standard_error_is_where_chi_square_rises_by_one_not_its_ripple_at_a_small_step():
    # chi2 = 50 + ((h - 0.3) / 0.01)^2 plus a ripple of 0.05 on the scale of 1e-5 (a law's kink, as
    # a free play's contact makes a twist zero's profile rough): the curvature at the small step
    # (1e-3 of the value, 3e-4) is mostly the ripple's and read a standard error of 1.35e-3, 7
    # times short; over +-1 standard error, again until two passes agree, chi-square rises by
    # one at 0.01. Within 10%: PROFILE_SE_AGREE, and the ripple's 0.1 on a rise of 2.
    from jointrig.identify.causes import profile

    def chi2(h):
        return 50.0 + ((h - 0.3) / 0.01) ** 2 + 0.05 * math.sin((h - 0.3) / 1e-5) ** 2

    found = profile(lambda h: _Fit(chi2(h)), by_name("backlash"), 0.2, 0.4)
    assert found.value == pytest.approx(0.3, abs=1e-4)
    small = math.sqrt(2.0 / ((chi2(0.3 + 3e-4) - 2 * chi2(0.3) + chi2(0.3 - 3e-4)) / 9e-8))
    assert small < 0.2 * 0.01  # what the small step alone gave
    assert found.std_error == pytest.approx(0.01, rel=0.1)


def test_the_profile_search_at_its_lower_bound_takes_the_one_sided_curvature():
    # chi2 = 50 + ((h - 0.3) / 0.01)^2 searched on [0.3, 1]: the minimum sits on the bound, where
    # the central difference would step outside; the one-sided second difference of a parabola
    # is exact: the standard error is 0.01 again.
    from jointrig.identify.causes import profile

    found = profile(lambda h: _Fit(50.0 + ((h - 0.3) / 0.01) ** 2), by_name("backlash"), 0.3, 1.0)
    assert found.value == pytest.approx(0.3, abs=1e-6) and found.std_error == pytest.approx(0.01, rel=1e-3)


def test_the_profile_search_at_its_upper_bound_takes_the_one_sided_curvature_too():
    # The mirror of the lower bound, on the rough profile of the test above: chi2 = 50 + ((h -
    # 0.3) / 0.01)^2 + the ripple, searched on [0.1, 0.3]. The passes over +-1 standard error
    # stopped at the upper bound and kept the small step's ripple (a twist's zero on its 0.01 rad
    # bound read 1.6e-5 rad: the independent bench's Stribeck joint, seed 6, 652 of those off the
    # truth); backward, as forward at the lower bound, they reach 0.01 (within 10% as above).
    from jointrig.identify.causes import profile

    def chi2(h):
        return 50.0 + ((h - 0.3) / 0.01) ** 2 + 0.05 * math.sin((h - 0.3) / 1e-5) ** 2

    found = profile(lambda h: _Fit(chi2(h)), by_name("backlash"), 0.1, 0.3)
    assert found.value == pytest.approx(0.3, abs=1e-4) and found.std_error == pytest.approx(0.01, rel=0.1)


def test_the_catalogue_says_what_each_cause_adds():
    # n_linear: the linear parameters a cause adds to the nominal model (its law terms, or the
    # two bearings), what a cause's score counts when it cannot be fitted; the model
    # structure's defaults are no offset, no delay, no gain error.
    from jointrig.identify.causes import NOMINAL, ModelSpec

    assert ModelSpec(()) == ModelSpec((), bearings=False, drive_delay_s=0.0, angle_offset_rad=0.0,
                                      angle2_delay_s=0.0, angle2_gain_error=0.0)
    for cause in CATALOGUE:
        ext = cause.extend(NOMINAL, 1e-3 if cause.bounds is not None else 0.0)
        added = len(ext.terms) - len(NOMINAL.terms) + (2 if ext.bearings else 0)
        assert cause.n_linear == added, (cause.name, cause.n_linear, added)


class _Avg:
    """A stand-in for a prepared run's period average: what the causes' bounds read."""

    def __init__(self, amplitude_rad: float, omega_rad_s: float):
        from jointrig.vocab.records import SteadyStateRecord

        t = np.arange(256) * (2 * math.pi / omega_rad_s) / 256
        phi = 0.05 + amplitude_rad * np.cos(omega_rad_s * t)  # a mean the bounds must ignore
        self.average = SteadyStateRecord(omega_rad_s, t, np.zeros_like(t), phi, None)


def test_the_causes_search_bounds_follow_the_runs_amplitudes_and_periods():
    # Two runs: 0.02 rad at 10 rad/s and 0.5 rad at 40 rad/s. Slip angles from 1e-3 of the
    # smallest amplitude, free play to 0.8 of the largest, a delay to 0.1 of the shortest period,
    # rates from the largest rate amplitude (0.5 * 40 = 20 rad/s), an encoder's zero within 0.01
    # rad and 0.1 of the smallest amplitude, a gain error within +-0.2.
    from jointrig.identify.causes import rate_amplitudes

    runs = [_Avg(0.02, 10.0), _Avg(0.5, 40.0)]
    assert by_name("hysteresis").bounds(runs) == pytest.approx((1e-3 * 0.02, 0.9 * 0.02), rel=1e-9)
    assert by_name("backlash").bounds(runs) == pytest.approx((1e-4 * 0.02, 0.8 * 0.5), rel=1e-9)
    assert by_name("micro_slip").bounds(runs) == pytest.approx((1e-3 * 0.02, 2.0 * 0.5), rel=1e-9)
    assert by_name("drive_delay").bounds(runs) == pytest.approx((0.0, 0.1 * 2 * math.pi / 40.0), rel=1e-9)
    assert rate_amplitudes(runs) == pytest.approx([0.2, 20.0], rel=1e-9)
    assert by_name("stribeck_friction").bounds(runs) == pytest.approx((0.02 * 0.2, 2.0 * 20.0), rel=1e-9)
    assert by_name("angle_offset").bounds(runs) == pytest.approx((-0.002, 0.002), rel=1e-9)
    assert by_name("angle_gain").bounds(runs) == (-0.2, 0.2)


def test_free_play_opens_the_elastic_terms_only():
    from jointrig.identify.causes import ModelSpec
    from jointrig.vocab.law import Viscous

    ext = by_name("backlash").extend(ModelSpec((Viscous(), Power(0), Power(1), Power(3))), 0.01)
    assert ext.terms == (Viscous(), Power(0), Power(1, 0.01), Power(3, 0.01))


class _Score:
    def __init__(self, effect, delta_chi2, n_params, significant=True):
        self.effect, self.delta_chi2, self.n_params, self.significant = effect, delta_chi2, n_params, significant


def test_a_richer_cause_without_its_own_evidence_goes_right_after_the_simpler_one():
    # Ranked by BIC: Stribeck (3 parameters, 12 more chi2 than dry friction: below chi2(2)'s 13.8
    # at alpha 1e-3), another cause, dry friction, a fourth. Stribeck moves to right after dry
    # friction; the others keep their order. With 20 more, it stays first.
    from jointrig.identify.causes import parsimonious

    names = lambda out: [s.effect for s in out]  # noqa: E731
    catalogue = {c.name: c for c in CATALOGUE}
    ranked = [_Score("stribeck_friction", 1012.0, 3), _Score("hysteresis", 1005.0, 2),
              _Score("coulomb_friction", 1000.0, 1), _Score("quadratic_damping", 900.0, 1)]
    assert names(parsimonious(ranked, catalogue, 100, 1e-3)) == [
        "hysteresis", "coulomb_friction", "stribeck_friction", "quadratic_damping"]
    ranked[0] = _Score("stribeck_friction", 1020.0, 3)
    assert names(parsimonious(ranked, catalogue, 100, 1e-3))[0] == "stribeck_friction"
    # 15 more: above chi2(2)'s 13.8, below chi2(4)'s 18.5 at 1e-3: the nested test's degrees of
    # freedom are the difference of the two parameter counts (2), not their sum
    ranked[0] = _Score("stribeck_friction", 1015.0, 3)
    assert names(parsimonious(ranked, catalogue, 100, 1e-3))[0] == "stribeck_friction"
    # an insignificant simpler cause does not demote it, nor does one at another place
    ranked[0], ranked[2] = _Score("stribeck_friction", 1012.0, 3), _Score("coulomb_friction", 1000.0, 1, False)
    assert names(parsimonious(ranked, catalogue, 100, 1e-3))[0] == "stribeck_friction"
    ranked[2] = _Score("coulomb_friction", 1000.0, 1)
    out = parsimonious(ranked, catalogue, 100, 1e-3, place_of=lambda s: 2 if s.effect == "coulomb_friction" else 1)
    assert names(out)[0] == "stribeck_friction"


# ------------------------------------------------------- what each cause carries (issue 36)


def test_each_selection_is_the_causes_sought_at_a_place():
    from jointrig.identify.causes import at

    assert [c.name for c in at("ground")] == ["coulomb_friction", "stribeck_friction", "quadratic_damping", "cogging"]
    assert [c.name for c in at("oscillator")] == ["asymmetric_stiffness", "drive_delay", "quintic_stiffness",
                                                   "cubic_damping", "amplitude_damping"]
    assert OSCILLATOR_CAUSES == at("oscillator") and [c.name for c in at("flywheel")] == ["bearing_friction"]
    assert [c.name for c in at("channel")] == ["angle_skew", "angle_gain"] and [c.name for c in at("drive")] == [
        "drive_delay"]
    assert "cogging" in {c.name for c in JOINT} and "bearing_friction" not in {c.name for c in JOINT}
    assert at() == () and at("nowhere") == ()


def test_a_magnitude_is_a_parameter_a_vector_length_or_the_largest_part():
    se = {"k": 0.5, "p_s": 3.0, "p_c": 4.0, "bearing1_damping_Nms_per_rad": 0.1,
          "bearing2_damping_Nms_per_rad": 0.2}.get
    plain = by_name("coulomb_friction")
    assert plain.magnitude_of({"joint2_coulomb_torque_Nm": 7.0}, lambda n: 0.25, "joint2_") == (
        "joint2_coulomb_torque_Nm", 7.0, 0.25)
    name, value, error = plain.magnitude_of({}, lambda n: math.nan)
    assert name == "coulomb_torque_Nm" and math.isnan(value) and math.isnan(error)
    # amplitude of s sin + c cos, its error by the delta method: sqrt((s ds)^2 + (c dc)^2) / A
    cogging = by_name("cogging")
    errors = {"cogging_sin_Nm": 0.3, "cogging_cos_Nm": 0.4}.get
    name, value, error = cogging.magnitude_of({"cogging_sin_Nm": 3.0, "cogging_cos_Nm": -4.0}, errors)
    assert name == "cogging_amplitude_Nm"
    assert (value, error) == pytest.approx((5.0, math.sqrt(0.9**2 + 1.6**2) / 5.0), rel=1e-15)
    # at zero amplitude the error is the parts' RMS error, not a division by zero
    assert cogging.magnitude_of({"cogging_sin_Nm": 0.0, "cogging_cos_Nm": 0.0}, errors)[1:] == pytest.approx(
        (0.0, math.sqrt((0.09 + 0.16) / 2)), rel=1e-15)
    bearing = by_name("bearing_friction")
    assert bearing.magnitude_of({"bearing1_damping_Nms_per_rad": -3.0, "bearing2_damping_Nms_per_rad": 2.0}, se) == (
        "bearing1_damping_Nms_per_rad", -3.0, 0.1)
    assert bearing.magnitude_of({"bearing1_damping_Nms_per_rad": 1.0, "bearing2_damping_Nms_per_rad": 2.0}, se) == (
        "bearing2_damping_Nms_per_rad", 2.0, 0.2)


def test_a_slip_angle_or_free_play_below_the_resolution_and_a_stribeck_rate_above_every_rate_degenerate():
    # The rules return values (the limit, the size, where the dry friction is); their words are the
    # report's, in the units of the bench (present.notes.rejection_text).
    from jointrig.identify.causes import BelowResolution, Limits, NoFalloff
    from jointrig.present.notes import rejection_text
    from jointrig.vocab.params import SLIDE

    lim = Limits(resolution_rad=1e-3, rate_top_rad_s=2.0, friction="coulomb_friction at joint 2")
    jenkins, iwan, gap, stribeck = (by_name(n).degenerate for n in ("hysteresis", "micro_slip", "backlash",
                                                                      "stribeck_friction"))
    assert jenkins(9.9e-4, lim) == BelowResolution("slip angle", 9.9e-4, 1e-3, "a Jenkins element",
                                                   "coulomb_friction at joint 2")
    assert rejection_text(jenkins(9.9e-4, lim)) == (
        "its slip angle 0.00099 rad is below the angle resolution 0.001 rad: a Jenkins element that never sticks is "
        "dry friction (see coulomb_friction at joint 2)")
    assert jenkins(1e-3, lim) is None and iwan(1e-3, lim) is None and gap(1e-3, lim) is None
    assert "largest slip angle" in rejection_text(iwan(5e-4, lim)) and "an Iwan element" in rejection_text(iwan(5e-4, lim))
    assert rejection_text(gap(5e-4, lim)).endswith("no free play is resolved")
    assert rejection_text(gap(5e-4, lim), SLIDE).startswith(
        "its half gap 0.0005 m is below the position resolution 0.001 m")
    assert stribeck(2.0, lim) is None and stribeck(1.0, lim) is None
    assert stribeck(2.5, lim) == NoFalloff(2.5, 2.0, "coulomb_friction at joint 2")
    assert rejection_text(stribeck(2.5, lim)) == (
        "its Stribeck rate 2.5 rad/s is above every run's rate amplitude (at most 2 rad/s): the friction does not fall "
        "off within the data; it is dry friction (see coulomb_friction at joint 2)")
    assert "(at most 2 m/s)" in rejection_text(stribeck(2.5, lim), SLIDE)
    assert by_name("coulomb_friction").degenerate is None and by_name("cogging").degenerate is None
    # A free play or a slip angle that the whole fit tells from its zero (chi-square rises by more
    # than 10.83 toward it: one parameter's likelihood ratio at alpha 1e-3) stands below one
    # sample's resolution; one whose zero is within that, or without a rise, is refused.
    told, untold = (Limits(1e-3, 2.0, "coulomb_friction at joint 2", zero_rise=r) for r in (10.9, 10.8))
    assert gap(5e-4, told) is None and jenkins(5e-4, told) is None and iwan(5e-4, told) is None
    assert gap(5e-4, untold) is not None and jenkins(5e-4, untold) is not None and iwan(5e-4, untold) is not None
    assert gap(5e-4, lim) is not None  # no rise computed: one sample's resolution decides


def test_a_rejection_is_said_with_the_benchs_names():
    from jointrig.identify.causes import FeedsEnergy, Unphysical
    from jointrig.present.notes import rejection_text
    from jointrig.vocab.params import SLIDE

    neg = Unphysical("ground1_quadratic_damping_Nms2_per_rad2", -82.0)
    assert rejection_text(neg) == "fitted with an unphysical negative ground1_quadratic_damping_Nms2_per_rad2 = -82: rejected"
    assert rejection_text(neg, SLIDE) == "fitted with an unphysical negative ground1_quadratic_damping_Ns2_per_m2 = -82: rejected"
    assert rejection_text(FeedsEnergy("joint1_c_Nms_per_rad", -71.1, 5.0)) == (
        "the extended model would hold a negative joint1_c_Nms_per_rad = -71.1 +- 5: it would feed energy in")
    with pytest.raises(TypeError, match="no words for a rejection of type str"):
        rejection_text("rejected")


def test_the_cogging_search_spans_its_orders_on_a_grid_finer_than_chi_squares_oscillation():
    from jointrig.identify import causes as c

    runs = [_Avg(0.1, 10.0), _Avg(0.4, 10.0)]
    cogging = by_name("cogging")
    lo, hi = cogging.bounds(runs)
    # from two periods between rest and the largest swing (4 pi / 0.4) to 20 rad of phase at
    # the smallest (20 / 0.1)
    assert (lo, hi) == pytest.approx((4 * math.pi / 0.4, 200.0), rel=1e-12)
    assert cogging.n_trials(runs) == pytest.approx((hi - lo) * 0.4 / math.pi, rel=1e-12)
    step = c.COGGING_GRID / 0.4
    assert cogging.grid_points(runs, lo, hi) == math.ceil((hi - lo) / step) + 1
    # a narrow range keeps the catalogue's 17 points; a cause without its own grid always has them
    assert cogging.grid_points(runs, lo, lo + step) == c.PROFILE_GRID_POINTS
    assert by_name("backlash").grid_points(runs, 0.0, 1e3) == c.PROFILE_GRID_POINTS
    assert by_name("backlash").n_trials(runs) == 1.0
    # one order near the bounds' ratio: still at least one trial
    assert c._cogging_trials([_Avg(5.0, 10.0)]) == pytest.approx((20.0 - 4 * math.pi) / math.pi, rel=1e-12)
    spec = cogging.extend(c.ModelSpec((Power(1),)), 125.0)
    from jointrig.vocab.law import Cogging

    assert spec.terms == (Power(1), Cogging(125.0), Cogging(125.0, quadrature=True))
    assert cogging.extend(spec, 60.0).terms == (Power(1), Cogging(60.0), Cogging(60.0, quadrature=True))


def test_a_score_says_where_and_reads_the_same_in_json_for_two_flywheels_and_a_train():
    from jointrig.identify.causes import Ambiguity, CauseScore, Place

    class _Fitted:
        def parameters(self):
            return {"k_Nm_per_rad": 500.0}

    mag = ("joint2_backlash_half_gap_rad", 1e-3, 1e-5)
    at_joint = CauseScore("backlash", 90.0, 1, 84.0, 1e-20, True, _Fitted(), mag, where=Place("joint", 2))
    assert (at_joint.label, at_joint.effect, at_joint.place, at_joint.at_joint, at_joint.ground) == (
        "backlash at joint 2", "backlash", 2, True, False)
    js = at_joint.as_json()
    assert js["label"] == "backlash at joint 2" and js["place"] == {"kind": "joint", "number": 2}
    assert js["effect"] == "backlash"
    assert js["magnitude"] == {"name": mag[0], "value": 1e-3, "std_error": 1e-5}
    assert js["parameters"] == {"k_Nm_per_rad": 500.0} and js["signature"] == {} and js["n_params"] == 1
    ground = CauseScore("coulomb_friction", 5.0, 1, 1.0, 0.02, False, None, ("m", 1.0, 0.1), where=Place("ground", 1))
    assert ground.label == "coulomb_friction to ground at body 1" and ground.ground and not ground.at_joint
    assert ground.as_json()["place"] == {"kind": "ground", "number": 1} and ground.as_json()["parameters"] == {}
    drag = CauseScore("bearing_friction", 5.0, 1, 1.0, 0.02, False, None, ("m", 1.0, 0.1), where=Place("flywheel", 3))
    assert drag.label == "bearing_friction at flywheel 3" and not drag.at_joint and not drag.ground
    assert drag.as_json()["place"] == {"kind": "flywheel", "number": 3}
    two = CauseScore("backlash", 90.0, 1, 84.0, 1e-20, True, None, mag)
    assert two.label == "backlash" and two.place is None and two.at_joint and not two.ground
    assert two.as_json()["place"] is None and two.as_json()["label"] == "backlash"
    from jointrig.identify.causes import AT_CHANNEL, TO_GROUND
    from jointrig.present.diagnosis_json import ambiguity_json
    from jointrig.present.notes import separation_text

    a = Ambiguity(("backlash at joint 2", "coulomb_friction at joint 3"), 4, ((4, 12.5), (1, 3.25)))
    words = ("driving flywheel 4 separates backlash at joint 2 from coulomb_friction at joint 3 best (Fisher "
             "information per run at the measured frequencies and torque, linearised: flywheel 4: 12.5, flywheel 1: "
             "3.25)")
    assert separation_text(a) == words
    assert ambiguity_json(a) == {"effects": ["backlash at joint 2", "coulomb_friction at joint 3"],
                                 "excitation": words, "separating_drive_body": 4}
    ground = Ambiguity(("a", "b"), unplaced=TO_GROUND)
    assert ambiguity_json(ground)["separating_drive_body"] is None and "for a law to ground" in separation_text(ground)
    assert "a channel's lag or scale" in separation_text(Ambiguity(("a", "b"), unplaced=AT_CHANNEL))
    with pytest.raises(ValueError, match="names neither a drive nor why not"):
        separation_text(Ambiguity(("a", "b")))
    # Two causes at one place: no drive tells them apart; the runs that would are named.
    from jointrig.identify.causes import SAME_PLACE, separating_excitation

    same = Ambiguity(("micro_slip at joint 1", "hysteresis at joint 1"), unplaced=SAME_PLACE,
                     excitation=separating_excitation("micro_slip", "hysteresis"))
    assert separation_text(same).startswith("micro_slip at joint 1 and hysteresis at joint 1 act at the same place, "
                                            "so every drive moves them alike; runs at several small amplitudes")
    assert ambiguity_json(same)["separating_drive_body"] is None and separation_text(same).endswith(" would")
    assert separating_excitation("hysteresis", "micro_slip") == separating_excitation("micro_slip", "hysteresis")
    assert separating_excitation("cogging", "micro_slip").startswith("a sweep over amplitude at fixed frequency")


def test_the_profile_search_below_a_vertex_outside_its_range_takes_the_one_sided_curvature():
    # chi2 = 50 + ((h - 0.25) / 0.01)^2 searched on [0.3, 1]: the vertex lies outside, the minimum
    # on the bound; the one-sided second difference of a parabola (the points above the bound) is
    # still exact: 0.01, the fit's chi2/dof 0.75 leaving it unscaled. One below the bound would
    # read another side of the parabola.
    from jointrig.identify.causes import profile

    found = profile(lambda h: _Fit(50.0 + ((h - 0.25) / 0.01) ** 2), by_name("backlash"), 0.3, 1.0)
    assert found.value == pytest.approx(0.3, abs=1e-6) and found.std_error == pytest.approx(0.01, rel=1e-6)


def test_the_profiles_standard_error_stops_when_two_passes_agree():
    # chi2 = 50 + ((h - 0.5) / 0.01)^2 on [0, 1]: the curvature at 1e-3 of the value and again
    # over +-1 standard error agree exactly (a parabola), so the search stops after that one pass:
    # two trials for the first difference, two for the pass (not the three passes of a profile
    # whose passes disagree)
    from jointrig.identify.causes import profile

    aside = []

    def solve_aside(h):
        aside.append(h)
        return _Fit(50.0 + ((h - 0.5) / 0.01) ** 2)

    found = profile(lambda h: _Fit(50.0 + ((h - 0.5) / 0.01) ** 2), by_name("backlash"), 0.0, 1.0,
                    solve_aside=solve_aside)
    assert found.std_error == pytest.approx(0.01, rel=1e-6) and len(aside) == 4, aside


def test_a_causes_improvement_is_shared_by_harmonic_class():
    # rows of harmonics 0..5 dropping 1..6: the mean 1, the fundamental 2, the even 3 + 5, the
    # odd from 3 up 4 + 6, of 21
    from jointrig.identify.causes import harmonic_shares

    shares = harmonic_shares(np.arange(1.0, 7.0), np.arange(6))
    assert shares == pytest.approx({"mean": 1 / 21, "fundamental": 2 / 21, "even": 8 / 21, "odd>=3": 10 / 21},
                                   rel=1e-15)
    assert harmonic_shares(np.zeros(3), np.array([1, 2, 3])) == {"mean": 0.0, "fundamental": 0.0, "even": 0.0,
                                                                 "odd>=3": 0.0}


def test_a_channels_skew_is_sought_either_way_within_a_twentieth_of_the_shortest_period():
    # Runs at 10 and 20 rad/s: the skew is searched over +-5% of 2 pi / 20 s, the scale over
    # +-20%; both only against the nominal model (a sensor's fault shows in the whole record).
    from types import SimpleNamespace

    runs = [SimpleNamespace(average=SimpleNamespace(omega_rad_s=w)) for w in (10.0, 20.0)]
    b = 0.05 * 2 * math.pi / 20.0
    assert by_name("angle_skew").bounds(runs) == (pytest.approx(-b, rel=1e-15), pytest.approx(b, rel=1e-15))
    assert by_name("angle_gain").bounds(runs) == (-0.2, 0.2)
    assert {c.name for c in CATALOGUE if c.first_only} == {"angle_skew", "angle_gain"}


def test_forward_selection_stops_at_the_first_round_that_adopts_nothing():
    calls = []

    def rank(base, pool, rnd):
        calls.append(rnd)
        return list(pool)

    chosen = forward_select("base", JOINT[:3], rank=rank, adopt=lambda base, ranked: None, max_effects=3)
    assert calls == [0] and chosen.adopted == () and len(chosen.rounds) == 1 and chosen.base == "base"


def test_evidence_is_significant_only_with_a_positive_score():
    # A drop whose p is far below the level but whose BIC score is just negative (the cause's
    # parameters cost more than they explain) is not significant; just positive, it is.
    n_rows, q = 10**6, 2  # a drop of 27.6: p ~ 1e-6
    cost = q * math.log(n_rows)
    for margin, significant in ((-0.5, False), (0.5, True)):
        score, p, sig = evidence(cost + margin, q, n_rows, 1e-3)
        assert score == pytest.approx(margin, abs=1e-12) and p < 1e-3 and sig is significant


def test_the_dissipative_share_is_the_fundamentals_quadrature_part():
    # 0 for a torque in phase with the motion (a spring), 1 in quadrature (a damper), sin(a) for
    # one a radians off, whatever the sizes of torque and motion; None without a fundamental.
    from jointrig.identify.causes import fundamental_quadrature

    t = np.arange(64) * 2 * math.pi / 64
    motion = 0.03 * np.cos(t)
    assert fundamental_quadrature([500.0 * np.cos(t)], [motion]) == pytest.approx(0.0, abs=1e-12)
    assert fundamental_quadrature([500.0 * np.sin(t)], [motion]) == pytest.approx(1.0, rel=1e-12)
    assert fundamental_quadrature([7.0 * np.cos(t + 0.4), 80.0 * np.cos(t + 0.4)], [motion, 2 * motion]) == \
        pytest.approx(math.sin(0.4), rel=1e-12)
    assert fundamental_quadrature([np.ones(64)], [motion]) is None


def test_the_profile_search_reaches_its_tolerance_on_a_narrow_range():
    # Brent's tolerance is 1e-6 of the searched range, whatever its size: a quartic well at
    # 3.7e-4 on [0, 1e-3] (not a parabola, which Brent's interpolation would hit at once) is
    # found to 2e-9, the grid's step being 6.25e-5.
    from jointrig.identify.causes import profile

    def chi2(h):
        u = (h - 3.7e-4) / 1e-4
        return _Fit(50.0 + u**4 + 0.01 * u**2)

    found = profile(chi2, by_name("backlash"), 0.0, 1e-3)
    assert found.value == pytest.approx(3.7e-4, abs=2e-9)


def test_the_profile_search_at_zero_and_on_a_flat_profile():
    # A minimum at a lower bound of 0 (a free play the data do not show): the curvature's step is
    # 1e-6 of the range there (1e-3 of a zero value would be no step), and the one-sided
    # difference of the parabola gives its standard error, 0.01. A flat profile has no
    # curvature: no standard error (NaN), not a division by zero.
    from jointrig.identify.causes import profile

    found = profile(lambda h: _Fit(50.0 + (h / 0.01) ** 2), by_name("backlash"), 0.0, 1.0)
    assert found.value == 0.0 and found.std_error == pytest.approx(0.01, rel=1e-3)
    flat = profile(lambda h: _Fit(50.0), by_name("backlash"), 0.0, 1.0)
    assert math.isnan(flat.std_error)


def test_only_an_even_stiffness_reads_as_a_zero_offset():
    # a = -3 gamma delta holds for an even stiffness beside a cubic; no other cause is what an
    # angle's zero offset makes of the law, so no other is read as one.
    assert [c.name for c in CATALOGUE if c.reads_as_offset] == ["asymmetric_stiffness"]


def test_a_profile_whose_valley_is_flat_takes_its_error_from_where_chi_square_rises_by_one():
    # identify.causes._half_width: on a parabola tried on a grid, the interpolated crossings of
    # min + 1 give its exact half width where the trials bracket it (a linear interpolation
    # between grid points: within the chord's error, 2% here); a valley that never rises above
    # the level on one side reaches that side's end of the range.
    from jointrig.identify.causes import _half_width

    xs = np.linspace(0.0, 2.0, 201)
    para = {float(x): 4.0 * (x - 1.0) ** 2 for x in xs}  # rises by 1 at 1 +- 0.5
    assert _half_width(para, 1.0, 1.0, 0.0, 2.0) == pytest.approx(0.5, rel=0.02)
    flat = {float(x): (0.0 if x < 1.0 else 4.0 * (x - 1.0) ** 2) for x in xs}
    assert _half_width(flat, 1.0, 1.0, 0.0, 2.0) == pytest.approx((1.5 - 0.0) / 2, rel=0.02)
    assert math.isnan(_half_width({float(x): 0.0 for x in xs}, 1.0, 1.0, 0.0, 2.0))  # not determined
    # A valley linear between coarse trials (2 |x - 1| at steps of 0.4 from 1.0): the linear
    # interpolation is exact there, the crossings at 0.5 and 1.5 to round-off.
    vee = {1.0 + d: 2.0 * abs(d) for d in (-0.8, -0.4, 0.0, 0.4, 0.8)}
    assert _half_width(vee, 1.0, 1.0, 0.0, 2.0) == pytest.approx(0.5, rel=1e-12)


def test_a_profiles_slope_is_the_fits_values_per_unit_of_the_profiled_parameter():
    # Profiled.slope: d(values)/d(h) by a difference of the fits either side of the best value,
    # what Profiled.widened carries into the linear parameters' errors; values linear in h
    # (3 h and -h) give it to round-off (1e-9 relative: a difference over a step of 1e-3 h).
    from jointrig.identify.causes import profile

    class _Valued(_Fit):
        def __init__(self, h):
            super().__init__(50.0 + ((h - 0.3) / 0.01) ** 2)
            self.values = np.array([3.0 * h, -h])

    found = profile(_Valued, by_name("backlash"), 0.0, 1.0)
    assert found.slope == pytest.approx([3.0, -1.0], rel=1e-9)


def test_a_drops_degrees_of_freedom_are_its_groups_weight_estimates_pooled():
    # Satterthwaite over the groups of rows that share a variance estimate of nu degrees of
    # freedom: a drop in one group carries that group's nu alone; spread evenly over K groups,
    # K nu; weighted by each group's energy between; nothing changed, no meaning (inf).
    import math

    from jointrig.identify.causes import effective_dof

    assert effective_dof([5.0, 0.0, 0.0], 10.0) == pytest.approx(10.0)
    assert effective_dof([2.0] * 8, 10.0) == pytest.approx(80.0)
    assert effective_dof([3.0, 1.0], 10.0) == pytest.approx(16.0)
    assert effective_dof([0.0, 0.0], 10.0) == math.inf and effective_dof([1.0], math.inf) == math.inf


def test_a_drop_with_estimated_weights_is_tested_near_its_level():
    # Rows in groups of two (a harmonic's cosine and sine) share a variance estimated from
    # nu = 10 degrees of freedom (six periods); a cause's column lies in 1, 3 or 10 groups. With
    # the cause absent its drop in the corrected chi-square (x (nu - 2) / nu) is tested at
    # alpha = 5%, 10000 draws each (binomial standard error of the rate 4% of alpha): with the
    # weights' degrees of freedom (identify.causes.evidence with nu and nu_eff) the false alarms
    # are 0.85-1.15 alpha (measured 0.96-1.01); as chi-square(1), the weights taken as known,
    # 1.3 alpha or more over 10 groups (measured 1.05, 1.30, 1.58: the weights that fit a drop
    # also weigh it; at alpha = 1e-3 chi-square reads 4.5-5.4 alpha, these 1.07-1.8).
    import numpy as np

    from jointrig.identify.causes import effective_dof, evidence

    rng = np.random.default_rng(11)
    nu, n, alpha = 10.0, 10_000, 0.05
    for x in (np.array([1.0, 1.0] + [0.0] * 18), np.array([1.0, 1.0, 0.7, 0.7, 0.5, 0.5] + [0.0] * 14), np.ones(20)):
        groups = x.size // 2
        r = rng.normal(size=(n, x.size))
        w = 1.0 / (rng.chisquare(nu, size=(n, groups)).repeat(2, axis=1) / nu)  # each group's estimate (truth 1)
        b = (w * x * r).sum(axis=1, keepdims=True) / (w * x * x).sum(axis=1, keepdims=True)
        drop = (w * (r ** 2 - (r - b * x) ** 2)).sum(axis=1) * (nu - 2) / nu
        energy = (w * (b * x) ** 2).reshape(n, groups, 2).sum(axis=2)  # what the fit changes, per group
        with_dof = sum(evidence(d, 1, 10_000, alpha, 1, nu, effective_dof(e, nu))[1] < alpha
                       for d, e in zip(drop, energy)) / n
        assert 0.85 * alpha <= with_dof <= 1.15 * alpha, (np.count_nonzero(x), with_dof / alpha)
    known = sum(evidence(d, 1, 10_000, alpha)[1] < alpha for d in drop) / n
    assert known >= 1.3 * alpha, known / alpha


def test_the_detection_threshold_is_the_drop_the_evidence_test_calls_significant_at_its_level():
    # detection_limit's threshold and evidence's p are one distribution: the drop at the
    # threshold has p equal to the level (to the F quantile's round-off, 1e-9 relative), with
    # the weights' degrees of freedom and without; a drop's p uses them from nu_eff > 2 on; no
    # finite nu or none above 0 leaves the degrees of freedom undefined (inf).
    import math

    from jointrig.identify.causes import _drop_threshold, effective_dof, evidence

    for q, nu, nu_eff in ((1, 10.0, 10.0), (3, 10.0, 37.0), (2, 6.0, 2.5), (1, math.inf, math.inf)):
        t = _drop_threshold(q, 1e-4, nu, nu_eff)
        assert evidence(t, q, 10, 1.0, 1, nu, nu_eff)[1] == pytest.approx(1e-4, rel=1e-9), (q, nu, nu_eff)
    assert evidence(9.0, 1, 10, 1.0, 1, 10.0, 2.5)[1] > 2 * evidence(9.0, 1, 10)[1]  # 0.0059 against 0.0027
    assert effective_dof([1.0], 0.0) == math.inf


def test_damping_in_contact_turns_the_laws_damping_into_one_beyond_the_free_play():
    # contact_damping: the nominal c phi' becomes contact_c phi' beyond the gap, the elastic terms
    # engage beyond it; re-profiling a free play moves the contact damping's gap with the
    # springs'; a law without damping is left as it is (no cause to add)
    from jointrig.identify.causes import NOMINAL, ModelSpec
    from jointrig.vocab.law import ContactDamping

    contact = by_name("contact_damping")
    assert contact.extend(NOMINAL, 0.01).terms == (ContactDamping(0.01), Power(1, 0.01), Power(3, 0.01))
    assert by_name("backlash").extend(contact.extend(NOMINAL, 0.01), 0.02).terms == (
        ContactDamping(0.02), Power(1, 0.02), Power(3, 0.02))
    springs = ModelSpec((Power(1), Power(3)))
    assert contact.extend(springs, 0.01) == springs


def test_a_profile_on_an_end_of_its_search_is_told_and_said():
    # A best value within 1e-4 of the search range (log for a log-scale parameter) lies on that
    # end: there the runs do not rule out a value beyond it and the standard error is one-sided
    # (the Stribeck carriage of scripts/bench_stribeck.py: 0.0676 m/s on the lower end of its search).
    import math

    from jointrig.identify.causes import ON_BOUND_SHARE, on_search_bound
    from jointrig.present.text import on_bound_lines

    lo, hi = 0.0674, 6.74
    assert on_search_bound(lo * (1 + 1e-6), lo, hi, True) == "lower"
    assert on_search_bound(hi * (1 - 1e-6), lo, hi, True) == "upper"
    inside = lo * math.exp(2 * ON_BOUND_SHARE * math.log(hi / lo))
    assert on_search_bound(inside, lo, hi, True) == "" and on_search_bound(0.5, 0.0, 1.0) == ""
    assert on_search_bound(2 * ON_BOUND_SHARE, 0.0, 1.0) == "" and on_search_bound(0.5 * ON_BOUND_SHARE, 0.0, 1.0) == "lower"
    assert on_search_bound(math.nan, lo, hi) == "" and on_search_bound(1.0, 1.0, 1.0) == ""
    # "within" the share includes its edge, on either end, and the share is of the range's width
    assert on_search_bound(ON_BOUND_SHARE, 0.0, 1.0) == "lower" and on_search_bound(1.0 - ON_BOUND_SHARE, 0.0, 1.0) == "upper"
    assert on_search_bound(5.0 * ON_BOUND_SHARE, 0.0, 10.0) == "lower"
    # a log-scale range that reaches 0 (or a value at 0) is judged on the linear scale, not refused
    assert on_search_bound(0.5 * ON_BOUND_SHARE, 0.0, 1.0, True) == "lower" and on_search_bound(0.0, 1e-3, 1.0, True) == "lower"
    (line,) = on_bound_lines((("ground1_stribeck_velocity_rad_s", "lower", lo),))
    assert "lies on the lower end of its search (0.0674 rad/s)" in line and "a smaller value" in line, line
    assert "one-sided" in line and on_bound_lines(()) == []


def test_the_detection_limit_is_the_size_whose_drop_passes_the_test_with_its_power():
    # One parameter, weights taken as known, 100 rows: the threshold is chi-square(1)'s 1e-3
    # quantile (10.83, above the BIC's ln 100 = 4.6), and the size found with probability 0.95 is
    # SE (sqrt(10.83) + z_0.95), in closed form (to scipy's quantiles, 1e-12). A score without a
    # standard error above zero rules nothing out.
    import math
    from dataclasses import replace

    from scipy.stats import chi2, norm

    from jointrig.identify.causes import CauseScore, detection_limit

    s = CauseScore("coulomb_friction", 0.0, 1, 0.0, 1.0, False, None, ("coulomb_torque_Nm", 0.3, 2.0))
    want = 2.0 * (math.sqrt(chi2.isf(1e-3, 1)) + norm.isf(0.05))
    assert detection_limit(s, 100, 1e-3) == pytest.approx(want, rel=1e-12)
    assert detection_limit(s, 100, 1e-3, n_causes=10) == pytest.approx(2.0 * (math.sqrt(chi2.isf(1e-4, 1))
                                                                               + norm.isf(0.05)), rel=1e-12)
    # over a million rows the BIC's ln(1e6) = 13.8 is the larger threshold
    assert detection_limit(s, 1_000_000, 1e-3) == pytest.approx(2.0 * (math.sqrt(math.log(1e6)) + norm.isf(0.05)),
                                                                 rel=1e-12)
    assert math.isnan(detection_limit(replace(s, magnitude=("coulomb_torque_Nm", 0.3, 0.0)), 100, 1e-3))


def test_a_size_is_resolved_beyond_the_tests_normal_quantile_of_its_standard_error():
    # identify.causes.resolved: two-sided at alpha, 3.29 standard errors at 1e-3. The worn joint's
    # six periods (make-data --periods 6 --seed 3) read a Stribeck excess of 25.5 +- 13.0 N m
    # beside a sliding friction of 34.8 +- 12.9: not resolved, so the final model names dry
    # friction (identify.chain_diagnose._reduced); the carriage's 4.75 +- 0.12 N is.
    from jointrig.identify.causes import resolved

    assert not resolved(25.5, 13.0, 1e-3) and resolved(4.75, 0.12, 1e-3)
    assert resolved(3.3, 1.0, 1e-3) and not resolved(3.28, 1.0, 1e-3)  # the quantile, 3.2905
    assert resolved(-3.3, 1.0, 1e-3)  # a size is told from zero on either side
    assert resolved(2.6, 1.0, 1e-2) and not resolved(2.5, 1.0, 1e-2)  # 2.5758 at 1e-2
    assert not resolved(5.0, float("nan")) and not resolved(float("nan"), 1.0)


class _Trial:
    """A profile trial's fit: its chi-square and degrees of freedom (what profile reads)."""

    def __init__(self, chi2: float, dof: int = 10):
        self.chi2, self.dof = chi2, dof


def test_a_profile_searches_a_basin_at_either_end_of_its_grid():
    # identify.causes.profile over [0, 1] (17 grid points, 1/16 apart): the best value 0.03 lies
    # inside the first grid interval (chi-square 0.09 at the grid's first point, 0.105 at its
    # second: a local minimum at the end), and chi-square falls towards the other end (0.05 at 1,
    # 0.06 at its neighbour). Both ends' basins are searched: the first holds the best fit.
    from types import SimpleNamespace

    from jointrig.identify.causes import profile

    def chi2(h):
        return min(100.0 * (h - 0.03) ** 2, 0.05 + 0.16 * (1.0 - h))

    got = profile(lambda h: _Trial(chi2(h)), SimpleNamespace(log_scale=False), 0.0, 1.0)
    assert got.value == pytest.approx(0.03, abs=1e-4) and got.fit.chi2 < 1e-6
    # mirrored: the best value inside the last interval, the first end's basin shallower
    got = profile(lambda h: _Trial(chi2(1.0 - h)), SimpleNamespace(log_scale=False), 0.0, 1.0)
    assert got.value == pytest.approx(0.97, abs=1e-4)


def test_a_profiled_errors_scale_with_a_fit_worse_than_its_noise():
    # chi-square 40 + 100 (h - 0.15)^2 on 10 degrees of freedom: it rises by one at 0.1 from the
    # best value, and the fit is 2 times worse than its noise in RMS (chi2/dof 4), so the error is
    # scaled by 2 as the linear ones are: 0.2. The range [0.11, 0.19] leaves no room for a pass
    # over +-1 standard error (of 0.2, nor of an unscaled 0.1 or a wrongly scaled 0.05), so the
    # first curvature stands.
    from types import SimpleNamespace

    from jointrig.identify.causes import profile

    got = profile(lambda h: _Trial(40.0 + 100.0 * (h - 0.15) ** 2), SimpleNamespace(log_scale=False), 0.11, 0.19)
    assert got.value == pytest.approx(0.15, abs=1e-5) and got.std_error == pytest.approx(0.2, rel=1e-3)


def test_a_profiled_parameters_uncertainty_widens_the_linear_ones_by_its_slope():
    # widened: cov + G S G^T; a parameter without a finite error is left out, and without a
    # covariance the fit is returned as it is. Two parameters that move the linear ones alike add
    # up when their errors are positively correlated and cancel when fully anti-correlated.
    from dataclasses import dataclass, field

    from jointrig.identify.causes import widened

    @dataclass(frozen=True)
    class Fit:
        covariance: object = None
        std_errors: object = field(default_factory=lambda: np.array([1.0, 2.0]))

    fit = Fit(np.diag([1.0, 4.0]))
    g = np.array([10.0, 0.0])
    wide = widened(fit, [g], [0.1])
    assert np.allclose(wide.covariance, [[2.0, 0.0], [0.0, 4.0]]) and np.allclose(wide.std_errors, [math.sqrt(2), 2.0])
    assert widened(fit, [g], [float("nan")]) is fit
    assert widened(Fit(None), [g], [0.1]).covariance is None
    both = widened(fit, [g, g], [0.1, 0.1])  # uncorrelated: 1 + 1 + 1
    assert both.covariance[0, 0] == pytest.approx(3.0)
    together = widened(fit, [g, g], [0.1, 0.1], np.array([[1.0, 1.0], [1.0, 1.0]]))  # 1 + (1 + 1)^2
    apart = widened(fit, [g, g], [0.1, 0.1], np.array([[1.0, -1.0], [-1.0, 1.0]]))
    assert together.covariance[0, 0] == pytest.approx(5.0) and apart.covariance[0, 0] == pytest.approx(1.0)
    assert np.allclose(apart.std_errors, [1.0, 2.0])
    # a parameter without a finite error drops out with its row and column of the correlation
    assert widened(fit, [g, g], [float("nan"), 0.1], np.array([[1.0, 1.0], [1.0, 1.0]])).covariance[0, 0] == \
        pytest.approx(2.0)
    # errors with degrees of freedom: the added part is taken as known (Welch-Satterthwaite), so a
    # variance doubled by it has four times the degrees of freedom; an untouched one keeps its own
    @dataclass(frozen=True)
    class Counted(Fit):
        std_error_dofs: object = None

    counted = widened(Counted(np.diag([1.0, 4.0]), std_error_dofs=np.array([5.0, 7.0])), [g], [0.1])
    assert np.allclose(counted.std_error_dofs, [20.0, 7.0])


def _coupled_chi2(sigma, rho, truth, floor=5.0):
    """chi-square of two parameters with errors ``sigma`` correlated ``rho`` (a quadratic) and the
    errors a profile of each alone reads there: sqrt(2 / H_ii)."""
    C = np.array([[sigma[0] ** 2, rho * sigma[0] * sigma[1]], [rho * sigma[0] * sigma[1], sigma[1] ** 2]])
    Ci = np.linalg.inv(C)
    calls = []

    def chi2(x):
        calls.append(np.array(x))
        d = np.asarray(x, dtype=float) - truth
        return float(d @ Ci @ d) + floor

    return chi2, 1.0 / np.sqrt(np.diag(Ci)), calls


def test_two_coupled_profiled_parameters_reach_their_joint_minimum_with_marginal_errors():
    # Each profiled alone stops short of the joint minimum and reads its error given the other;
    # joint_minimum moves both to the minimum (a quadratic: Newton's first step lands on it) and
    # multiplies each error by sqrt(H_ii (H^-1)_ii) = 1 / sqrt(1 - rho^2) for two. Differences of
    # a quadratic are exact: 1e-9 is rounding.
    from jointrig.identify.causes import joint_minimum

    truth = np.array([0.3, -0.2])
    chi2, conditional, calls = _coupled_chi2((1.0, 2.0), 0.97, truth)
    start = np.array([0.3 - 0.5, 0.0])  # where a pass of one at a time would leave them
    got = joint_minimum(chi2, start, conditional, [-10, -10], [10, 10])
    assert np.allclose(got.values, truth, atol=1e-9)
    # chi-square's differences (9 calls for two parameters), one step tried and kept, the
    # differences again, and a step below a twentieth of an error ends it untried: 19 calls
    assert len(calls) == 19
    # half an error off is still a step worth taking (a twentieth is not)
    near = joint_minimum(chi2, truth + 0.5 * conditional * np.array([1.0, -1.0]), conditional, [-10, -10], [10, 10])
    assert np.allclose(near.values, truth, atol=1e-9)
    assert np.allclose(got.widen, 1 / math.sqrt(1 - 0.97 ** 2), rtol=1e-9)
    assert np.allclose(conditional * got.widen, [1.0, 2.0], rtol=1e-9)  # the marginal errors
    assert got.correlation[0, 1] == pytest.approx(0.97, abs=1e-9)
    # uncoupled: nothing is widened
    free, e, _ = _coupled_chi2((1.0, 2.0), 0.0, truth)
    assert np.allclose(joint_minimum(free, start, e, [-10, -10], [10, 10]).widen, 1.0, atol=1e-9)


def test_the_joint_search_takes_at_most_three_newton_steps():
    # A quartic valley: each Newton step leaves two thirds of the way, chi-square falls every time,
    # and the search stops after JOINT_STEPS = 3 kept steps (9 calls of differences before each
    # and after the last, one trial each), short of the minimum.
    from jointrig.identify.causes import joint_minimum

    calls = []

    def quartic(x):
        calls.append(1)
        return float(np.sum((np.asarray(x) - [1.0, -1.0]) ** 4))

    got = joint_minimum(quartic, [-2.0, 2.0], [0.1, 0.1], [-10, -10], [10, 10])
    assert len(calls) == 4 * 9 + 3
    assert 0.05 < abs(got.values[0] - 1.0) < 3.0 and quartic(got.values) < quartic(np.array([-2.0, 2.0]))


def test_a_direction_chi_square_does_not_see_moves_nothing():
    # chi-square of the first parameter alone (the second one has no effect on the rows): its
    # Hessian is singular, not positive definite, so neither moves and nothing is widened, rather
    # than a Newton step through a singular matrix. Differences of a quadratic are exact.
    from jointrig.identify.causes import joint_minimum

    got = joint_minimum(lambda x: float((x[0] - 1.0) ** 2), [0.5, 0.2], [1.0, 1.0], [-10, -10], [10, 10])
    assert np.array_equal(got.values, [0.5, 0.2]) and np.array_equal(got.widen, [1.0, 1.0])
    assert np.array_equal(got.correlation, np.eye(2))


def test_a_drop_whose_weights_have_two_degrees_of_freedom_or_fewer_is_tested_as_chi_square():
    # The scaled F of estimated weights needs nu_eff > 2 (its scale q (nu_eff - 2) / nu_eff is 0
    # at 2): at 2 and below, and with weights taken as known, the drop is chi-square(q).
    from jointrig.identify.causes import chi2_survival, evidence

    for nu_eff in (2.0, 1.5, math.inf):
        assert evidence(3.0, 1, 100, 0.01, 1, 10.0, nu_eff)[1] == chi2_survival(3.0, 1)
    assert evidence(3.0, 1, 100, 0.01, 1, 10.0, 2.5)[1] != chi2_survival(3.0, 1)  # above 2: the scaled F


def test_a_negative_size_is_unphysical_for_friction_damping_and_delay_but_not_for_a_stiffness():
    # Cause.nonnegative (default True): a fitted dry friction, damping or delay below zero is
    # rejected as unphysical (identify.chain_diagnose._rejection); a stiffness term or an offset
    # may have either sign.
    from jointrig.identify.causes import Place, Unphysical, by_name
    from jointrig.identify.chain_diagnose import Candidate, _rejection

    for name in ("coulomb_friction", "quadratic_damping", "bearing_friction", "drive_delay"):
        assert by_name(name).nonnegative, name
    for name in ("asymmetric_stiffness", "angle_offset"):
        assert not by_name(name).nonnegative, name
    cand = Candidate(by_name("coulomb_friction"), Place("joint", 1))
    assert _rejection(None, cand, None, ("joint1_coulomb_torque_Nm", -3.0, 1.0)) == \
        Unphysical("joint1_coulomb_torque_Nm", -3.0)


def test_a_joint_step_stays_in_the_search_range_and_only_where_chi2_falls():
    # The minimum beyond a range's end: the values stop on it. A chi-square that is not convex
    # there (a saddle): the values stay and nothing is widened.
    from jointrig.identify.causes import joint_minimum

    chi2, e, _ = _coupled_chi2((1.0, 2.0), 0.9, np.array([3.0, 0.0]))
    got = joint_minimum(chi2, [0.0, 0.0], e, [-1.0, -1.0], [1.0, 1.0])
    assert got.values[0] == 1.0 and -1.0 <= got.values[1] <= 1.0
    assert chi2(got.values) < chi2(np.zeros(2))

    def saddle(x):
        return float(x[0] ** 2 - x[1] ** 2)

    flat = joint_minimum(saddle, [0.1, 0.1], [1.0, 1.0], [-5, -5], [5, 5])
    assert np.allclose(flat.values, [0.1, 0.1]) and np.allclose(flat.widen, 1.0)
    assert np.allclose(flat.correlation, np.eye(2))


def test_an_oscillators_polynomial_causes_take_either_sign():
    # The one-coordinate oscillator's extensions (the Silverbox: y'' + law(y, y') = u) are terms of
    # a law, not dissipations: a quintic that softens, a damping that falls with the rate or with
    # the amplitude are laws such a system has, so none is refused for its sign (survivor of
    # mutation seed 20261210: the amplitude damping's flag).
    names = {"quintic_stiffness", "cubic_damping", "amplitude_damping"}
    assert names <= {c.name for c in OSCILLATOR_CAUSES}
    assert not any(by_name(n).nonnegative for n in names)


def test_a_drop_with_known_weights_is_not_rescaled():
    # Weights known (nu infinite: no spread estimated them) leave a drop in chi-square as it is,
    # whatever degrees of freedom the drop is given: scale 1, and the test is the F test at the
    # drop's own nu_eff unscaled (survivor of mutation seed 20261210: the constant of the
    # non-finite branch).
    from scipy.stats import f

    from jointrig.identify.causes import _drop_scale

    assert _drop_scale(math.inf, 40.0) == 1.0 and _drop_scale(10.0, math.inf) == 1.0
    _, p, _ = evidence(12.0, 2, 400, nu=math.inf, nu_eff=40.0)
    assert p == pytest.approx(float(f.sf(12.0 / (2 * 38.0 / 40.0), 2, 40.0)), rel=1e-12)
