"""The one verdict (identify.verdict.judge) at its thresholds, for any diagnosis: pure, fast.

The held-out bound is not a constant: it is what a right model misses in that comparison
(studies.chain_validate.RightModelError), times the chi-square bound at the verdict's false-alarm
rate. Here each boundary is checked on both sides, and the bound itself against a Monte Carlo
of its own premise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointrig.identify.verdict import CHI2_PER_DOF_OK, RIG_FIDELITY, Grounds, Verdict, judge
from jointrig.present.notes import verdict_text
from jointrig.studies.notes import NO_STEADY_STATE, NoReplay
from jointrig.studies.chain_validate import RightModelError

BOUND = 1.4  # a bound as the comparisons give it (1.4-1.6 on the independent bench)


@pytest.mark.parametrize("c2,ratio,verdict", [
    (CHI2_PER_DOF_OK, BOUND, "no_misfit"),               # both bounds inclusive
    (CHI2_PER_DOF_OK * 1.001, 1.0, "unexplained"),
    (1.0, BOUND * 1.001, "unexplained"),
    (0.5, 1.0, "no_misfit"),
])
def test_the_nominal_model_explains_the_data_only_within_both_bounds(c2, ratio, verdict):
    v = judge((), c2, ratio, ratio, BOUND)
    assert v.verdict == verdict, v
    assert v.grounds is (Grounds.NOMINAL_FITS if verdict == "no_misfit" else Grounds.NOMINAL_MISFITS)
    reason = verdict_text(v)
    assert f"at most {CHI2_PER_DOF_OK:g}" in reason and f"at most {BOUND:.3g}" in reason
    if verdict == "unexplained":
        assert reason.startswith("no catalogued cause is significant, but the nominal model does not explain")


@pytest.mark.parametrize("c2,ratio,nominal,lost,verdict", [
    (1.0, BOUND, BOUND * 1.001, (), "explained"),       # inclusive for the extension, strict for the nominal
    (1.0, BOUND * 1.001, 50.0, (), "unexplained"),      # beyond what a right model misses
    (1.0, 1.0, BOUND, (), "explained"),                 # not resolved there, but leaning its way: the fit decides
    (1.0, 1.2, 1.1, (), "unexplained"),                 # not resolved, and the nominal predicts better
    (1.0, 1.0, 1.0, (), "unexplained"),                 # not resolved, and the nominal predicts as well (gain 1)
    (CHI2_PER_DOF_OK * 1.001, 1.0, 50.0, (), "unexplained"),
    (1.0, 1.0, math.nan, ("3", "7"), "explained"),      # the nominal has no steady state there
    (1.0, 1.0, math.nan, (), "unexplained"),
    (3.0, 1.0, math.nan, ("3",), "unexplained"),        # a lost nominal does not excuse a misfit
])
def test_an_extension_is_adopted_only_when_it_predicts_like_a_right_model_and_the_nominal_does_not(
        c2, ratio, nominal, lost, verdict):
    gain = nominal / ratio if math.isfinite(nominal) else math.nan  # the errors' ratio, as the caller's
    v = judge(("coulomb_friction",), c2, ratio, nominal, BOUND, nominal_lost=lost, gain=gain)
    assert v.verdict == verdict, v
    reason = verdict_text(v)
    if verdict == "explained" and lost:
        assert v.grounds is Grounds.NOMINAL_LOST
        assert f"no periodic steady state in held-out run(s) {', '.join(lost)}, the extended model does" in reason
    elif verdict == "explained" and nominal > BOUND:
        assert v.grounds is Grounds.CONFIRMED
        assert (f"the nominal model's held-out error is {nominal:.3g} times what it would miss were it right (at most "
                f"{BOUND:.3g}): the held-out runs confirm") in reason
    elif verdict == "explained":
        assert v.grounds is Grounds.FIT_EVIDENCE
        assert "the held-out runs do not resolve it (the nominal model's held-out error is" in reason and \
            reason.endswith("adopted on the fit's evidence")
    elif c2 <= CHI2_PER_DOF_OK and ratio <= BOUND:
        assert v.grounds is Grounds.NOT_CONFIRMED
        assert reason.startswith("the best extension (coulomb_friction) is not confirmed") and \
            "predicts the held-out runs as well (held-out error" in reason and reason.endswith("nothing is adopted")
    else:
        assert v.grounds is Grounds.FAILS_VALIDATION
        assert reason.startswith("the best extension (coulomb_friction) fails validation") and \
            reason.endswith("nothing is adopted")


def test_the_nominal_model_is_judged_against_its_own_bound_where_given():
    # the nominal model's yardstick is what it would miss were it right (fewer parameters, its own
    # covariance), not the extended model's
    assert judge(("backlash",), 1.0, 1.0, 3.0, BOUND, nominal_bound=2.5).verdict == "explained"
    assert judge(("backlash",), 1.0, 1.0, 3.0, BOUND, nominal_bound=3.5).verdict == "unexplained"


def test_the_words_follow_the_causes_and_the_held_out_data():
    one = judge(("backlash",), 1.0, 1.2, 10.0, BOUND)
    two = judge(("coulomb_friction", "backlash"), 1.0, 1.2, 10.0, BOUND, later_periods=True)
    assert verdict_text(one).startswith("backlash explains the data: chi2/dof 1 (at most 2), held-out error 1.2 times "
                                        "what")
    assert verdict_text(two).startswith("coulomb_friction + backlash explain the data")
    assert "error on the held-out later periods 1.2 times what a right model misses (at most 1.4)" in verdict_text(two)
    assert two.later_periods and two.causes == ("coulomb_friction", "backlash") and not one.later_periods


DIVERGED = NoReplay("extended", "run 3", NO_STEADY_STATE, "diverged")
WHY = "the extended model reaches no periodic steady state under the measured drive of run 3: diverged"


@pytest.mark.parametrize("causes, failures, words", [
    ((), (DIVERGED,), f"the nominal model could not be checked on held-out runs: {WHY}; it cannot be the train"),
    (("backlash at joint 1",), (DIVERGED,), f"the best extension (backlash at joint 1) is not adopted: {WHY}"),
    (("backlash at joint 1",), (), "the best extension (backlash at joint 1) is not adopted: no held-out run"),
])
def test_a_model_that_could_not_be_checked_is_unexplained_with_the_validations_reasons(causes, failures, words):
    # why no replay could be compared (the validation's failed replays) is quoted, after the model judged
    v = Verdict("unexplained", Grounds.UNCHECKED, causes, unchecked=failures)
    assert verdict_text(v) == words


def test_every_grounds_has_words_and_a_json_value():
    # every branch has its sentence (none raises, none leaves a figure unformatted as a field name)
    for g in Grounds:
        v = Verdict("unexplained", g, ("backlash",), 1.0, 1.2, 1.4, 3.0, 1.5, 2.5, nominal_lost=("3",),
                    unchecked=(DIVERGED,), cycle=("backlash", "backlash + hysteresis"))
        text = verdict_text(v)
        assert text and "{" not in text and "Grounds" not in text, (g, text)
        assert g.value == g.name.lower()
    # a verdict says "later periods" only when told the held-out data are later periods
    plain = verdict_text(Verdict("no_misfit", Grounds.NOMINAL_FITS, (), 1.0, 1.0, 1.4))
    assert "held-out error 1 times" in plain and "later periods" not in plain


def test_the_chi_square_bound_and_the_rigs_fidelity_are_the_stated_ones():
    assert CHI2_PER_DOF_OK == 2.0
    assert RIG_FIDELITY == 1e-5


@pytest.mark.parametrize("sizes", [
    np.ones(40),                                 # white noise on 20 harmonics of one joint
    np.r_[np.full(4, 20.0), np.ones(36)],        # a few dominant components (the fundamental, a resonance)
    np.r_[np.full(2, 50.0), np.ones(18)],
])
def test_a_right_models_error_exceeds_the_bound_about_as_often_as_alpha_says(sizes):
    # The premise of RightModelError.bound: the squared error of a right model is a sum of
    # independent Gaussian components of known sizes; the bound sets the effective degrees of
    # freedom by Welch-Satterthwaite. Over 200 000 draws the exceedance must be within a factor
    # of 3 of alpha (1e-2 here, so the count is ~2000 and its Poisson spread 2%): the
    # approximation is only that of matching two moments, which misses the tail by less.
    rng = np.random.default_rng(7)
    lam = np.asarray(sizes, float)
    dof = float(lam.sum() ** 2 / np.sum(lam ** 2))
    r = RightModelError(float(lam.sum()), 0.0, 0.0, 0.0, dof, alpha=1e-2, draws=0)
    err2 = (rng.standard_normal((200_000, lam.size)) ** 2) @ lam
    rate = float(np.mean(np.sqrt(err2) / r.relative > r.bound))
    assert 1e-2 / 3 <= rate <= 3e-2, (rate, dof, r.bound)


@pytest.mark.parametrize("k,m", [(14.5, 60.0), (31.0, 130.0)])
def test_a_right_models_error_over_an_estimated_total_exceeds_the_bound_about_as_often_as_alpha_says(k, m):
    # The total a right model misses is itself estimated (the noise from a few periods' spread):
    # the squared ratio is then F(k, m), not chi2(k)/k. Error and estimate drawn independently,
    # 200 000 times; alpha 1e-2, the exceedance within 0.8-1.2 of it (Poisson spread 2%); the
    # chi-square bound alone would be exceeded far more often (checked too).
    rng = np.random.default_rng(11)
    err2 = rng.chisquare(k, 200_000) / k
    total = rng.chisquare(m, 200_000) / m
    r = RightModelError(1.0, 0.0, 0.0, 0.0, k, alpha=1e-2, draws=4, estimate_dof=m)
    known = RightModelError(1.0, 0.0, 0.0, 0.0, k, alpha=1e-2, draws=4)
    rate = float(np.mean(np.sqrt(err2 / total) > r.bound))
    assert 0.8e-2 <= rate <= 1.2e-2, (rate, r.bound)
    assert float(np.mean(np.sqrt(err2 / total) > known.bound)) > 1.3e-2


def test_the_bound_falls_with_more_components_and_a_lower_false_alarm_rate_raises_it():
    few, many = (RightModelError(1.0, 0.0, 0.0, 0.0, k, 1e-3, 4) for k in (5.0, 500.0))
    assert few.bound > many.bound > 1.0
    assert RightModelError(1.0, 0.0, 0.0, 0.0, 40.0, 1e-4, 4).bound > RightModelError(1.0, 0.0, 0.0, 0.0, 40.0, 1e-2, 4).bound
    # the parts add as variances
    r = RightModelError(4e-6, 3e-6, 2e-6, 1e-6, 10.0, 1e-3, 4)
    assert r.relative == pytest.approx(math.sqrt(1e-5), rel=1e-12)


def test_a_verdict_held_only_under_another_models_fidelity_is_unexplained():
    # studies.chain_validate.measured_diagnosis found a cycle: the fidelity measured on A adopts B,
    # on B, A. An explained or no-misfit verdict becomes unexplained and says both models; an
    # unexplained one stands with its own grounds.
    from jointrig.identify.verdict import unsettled

    explained = judge(("a",), 1.0, 1.0, 2 * BOUND, BOUND)
    assert explained.verdict == "explained"
    v = unsettled(explained, "a", "a + b")
    assert (v.verdict, v.grounds, v.cycle, v.causes) == ("unexplained", Grounds.FIDELITY_CYCLE, ("a", "a + b"), ("a",))
    reason = verdict_text(v)
    assert reason.startswith("no model is adopted under its own fidelity") and "replay of a leads" in reason
    assert "to a + b" in reason and "chi2/dof 1 (at most" in reason, reason
    nominal = unsettled(judge((), 1.0, 1.0, 1.0, BOUND), "the nominal model", "a")
    assert nominal.grounds is Grounds.FIDELITY_CYCLE and "the last (the nominal model:" in verdict_text(nominal)
    failed = judge(("a",), 1.0, 2 * BOUND, 2 * BOUND, BOUND)
    assert unsettled(failed, "a", "b") is failed
