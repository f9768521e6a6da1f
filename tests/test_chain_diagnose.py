"""Which joint of a drive train is worn: the chain diagnosis on data of the independent bench.

Data come from tests/bench_chain_sim.py (scipy, event-driven stick-slip and sliders; nothing
of jointrig), measured at 40 dB; the gain is measured by replaying held-out runs of another
level in the MuJoCo chain rig. The suite runs three places (the middle and last joints, the last
flywheel), each with another kind of cause (elastic and profiled, dissipative, outside the
joints), Stribeck friction at the middle joint (once it is adopted, dry friction at that joint
adds no parameter: a candidate of q = 0, never significant), and the clean train; scripts/bench_chain_cases.py runs every catalogued effect at every
joint and bearing drag at every flywheel (the table in the README; 25 of 25 pass).
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from chain_cases import EFFECTS, TRAIN, run_case


@pytest.mark.slow
@pytest.mark.parametrize("cause,place", [("backlash", 2), ("bearing_friction", 4)])
def test_the_right_joint_and_cause_ranked_first_with_a_gain_of_5(cause, place):
    # Bounds of the issue: right place and cause first, gain >= 5 on held-out runs of another
    # level. The magnitude is checked to 15% of the bench's (the bench's law is not the
    # project's: a continuum Iwan, event-driven friction), which is 10x its standard error.
    # The suite runs a joint's and a body's cause; every cause at every place (dry friction at
    # joint 3 and Stribeck friction at joint 2 among them, 25 s each) is the benchmark's,
    # with the same bounds (scripts/bench_chain_cases.py); a train's sticking dry friction is
    # tests/test_train_files.py's.
    r = run_case(cause, place)
    kind = "flywheel" if cause == "bearing_friction" else "joint"
    assert r.first == r.found == f"{cause} at {kind} {place}", (r.first, r.found)
    assert r.gain >= 5, r.gain
    name, value, se = r.magnitude
    if cause == "backlash":
        truth = EFFECTS["backlash"](1.0)["gap"]
    elif cause == "coulomb_friction":
        truth = EFFECTS["coulomb_friction"](1.0)["Fc"]
    elif cause == "stribeck_friction":  # the static excess, halved at the softer middle joint
        truth = EFFECTS["stribeck_friction"](TRAIN.joints[place - 1].k / 1.0e4)["Fx"]
    else:
        truth = 4.0
    assert value == pytest.approx(truth, rel=0.15), (name, value, se)


def test_a_clean_train_gets_no_cause():
    # Nothing hidden: no candidate of the 25 (7 causes at 3 joints, bearings at 4 flywheels)
    # passes the Bonferroni-corrected test at alpha = 1e-3; chi2/dof of the nominal fit is
    # that of the noise (1 +- 3 / sqrt(dof), with the fidelity floor below it).
    r = run_case("none", 1)
    assert r.found == "nothing", r.found
    d = r.diagnosis
    assert d.nominal.chi2 / d.nominal.dof < 1 + 3 / math.sqrt(d.nominal.dof)


def test_drive_information_respects_the_trains_symmetry():
    # Which drive separates quadratic damping at joint 1 from the same at joint 3? On a
    # mirror-symmetric train, driving flywheel 1 tells them apart exactly as well as driving
    # flywheel 4 (and 2 as 3), and the ends differ from the middle (the effect grows with the
    # twist, which depends on where the train is driven). The figure must not depend on which
    # candidate is named first, and two identical effects at one place are never separated.
    # (Round-off: 1e-9.)
    from jointrig.vocab.law import JointLaw, QuadraticDamping
    from jointrig.identify.chain_diagnose import drive_information

    J, c, k = (1.0, 0.5, 0.5, 1.0), (30.0, 20.0, 30.0), (1e4, 5e3, 1e4)
    damping = JointLaw((QuadraticDamping(),), (10.0,))
    omegas = (40.0, 66.0, 110.0, 175.0)
    a, b = ("joint", 1, damping), ("joint", 3, damping)
    info = drive_information(J, c, k, omegas, 100.0, 0.5, a, b)
    assert info[1] == pytest.approx(info[4], rel=1e-9) and info[2] == pytest.approx(info[3], rel=1e-9)
    assert abs(info[1] - info[2]) > 0.1 * info[1] > 0
    swapped = drive_information(J, c, k, omegas, 100.0, 0.5, b, a)
    assert swapped == pytest.approx(info, rel=1e-12)
    same = drive_information(J, c, k, omegas, 100.0, 0.5, a, a)
    assert max(same.values()) < 1e-12 * max(info.values())


def test_a_candidates_own_torque_is_its_joint_law_less_the_nominal_terms():
    # What separating_drive weighs for a joint candidate: free play's own torque is the elastic
    # torque with the gap minus the one without; an added term's is that term's alone.
    import numpy as np

    from jointrig.identify.causes import CauseScore, Place, by_name
    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import Candidate, ChainFit, _effect_law
    from jointrig.vocab.law import Coulomb, Power, Viscous

    def score(terms, values):
        spec = ChainSpec((tuple(terms),))
        names = spec.names
        vals = {"J1_kgm2": 2.0, "J2_kgm2": 2.0} | {f"joint1_{t.name}": v for t, v in zip(terms, values)}
        fit = ChainFit(spec, names, np.array([vals[n] for n in names]), np.zeros(len(names)), 0.0, 10, np.zeros(10))
        return CauseScore("x", 0.0, 1, 0.0, 1.0, True, fit, ("m", 0.0, 0.0))

    phi = np.linspace(-0.05, 0.05, 11)
    gap = score((Viscous(), Power(1, 0.01), Power(3, 0.01)), (5.0, 1e4, 1e6))
    own = _effect_law(Candidate(by_name("backlash"), Place("joint", 1)), gap)
    expected = 1e4 * (Power(1, 0.01)(phi, 0 * phi) - phi) + 1e6 * (Power(3, 0.01)(phi, 0 * phi) - phi**3)
    # the difference of torques of up to 125 N m, evaluated in another order: round-off only
    np.testing.assert_allclose(own.torque(phi, 0.3 + 0 * phi), expected, rtol=1e-12, atol=1e-9)
    rub = score((Viscous(), Power(1), Power(3), Coulomb()), (5.0, 1e4, 1e6, 20.0))
    own = _effect_law(Candidate(by_name("coulomb_friction"), Place("joint", 1)), rub)
    np.testing.assert_allclose(own.torque(phi, np.sign(phi) + 0.5), 20.0 * np.sign(np.sign(phi) + 0.5), atol=1e-9)


#: The linear 4-body train of :func:`_linear_problem`: inertias (kg m^2), joint damping (N m s/rad)
#: and stiffness (N m/rad), by parameter name (also scripts/coverage_periods.py's truth).
LINEAR_J, LINEAR_C, LINEAR_K = (0.45, 0.06, 0.12, 0.35), (15.0, 20.0, 10.0), (4e5, 2.5e4, 1.2e5)
LINEAR_TRUTH = {**{f"J{i}_kgm2": v for i, v in enumerate(LINEAR_J, start=1)},
                **{f"joint{j}_c_Nms_per_rad": v for j, v in enumerate(LINEAR_C, start=1)},
                **{f"joint{j}_k_Nm_per_rad": v for j, v in enumerate(LINEAR_K, start=1)}}


def _carriage_runs(car, levels_N=(150.0,), noise: float = 1e-2, P: int = 4, n: int = 1000) -> tuple:
    """The independent bench's carriage (tests/bench_slide_sim.py: scipy, exact stick-slip events)
    driven at 2 Hz by each force amplitude of ``levels_N`` in turn, P steady periods of n samples,
    white noise of ``noise`` times each channel's RMS (one generator, seed 3, across the levels),
    prepared as the diagnosis prepares runs (harmonics 1-20)."""
    import numpy as np

    from bench_slide_sim import _simulate, steady_state
    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.chain_diagnose import prepare_chain_runs

    w, rng, recs = 4 * math.pi, np.random.default_rng(3), []
    for F0 in levels_N:
        t0, y, mode = steady_state(car, w, F0)
        t = t0 + np.arange(P * n) * (2 * math.pi / w) / n
        ys, _, _ = _simulate(car, w, F0, t, y, mode, t0)
        x = ys[:, 0] + rng.normal(0, noise * np.std(ys[:, 0]), t.size)
        F = F0 * np.cos(w * t) + rng.normal(0, noise * F0 / math.sqrt(2), t.size)
        recs.append(ChainRecord(w, t - t0, [F], [x], None, P))
    return tuple(prepare_chain_runs(recs, band=20))


def _linear_problem(seed: int = 0, fidelity: float = 1e-3, bearings=(0.0, 0.0, 0.0, 0.0), read=None, periods: int = 4,
                    noise: float = 1e-3):
    """A 4-body linear train's runs at five frequencies (exact steady states from its dynamic
    stiffness, tests/test_chain.py), ``periods`` periods each with white noise of ``noise`` times
    each channel's RMS (1e-3: 60 dB), and the
    chain diagnosis's problem on them with the nominal fit. ``read``: a spec whose channel skews
    and scales the angles are read with."""
    from dataclasses import replace

    import numpy as np

    from jointrig.identify.chain import ChainRecord, channel_corrected
    from jointrig.identify.chain_diagnose import _Problem, nominal_spec, prepare_chain_runs
    from test_chain import _linear_chain_records

    rng = np.random.default_rng(seed)
    J, c, k = list(LINEAR_J), list(LINEAR_C), list(LINEAR_K)
    recs = []
    for r in _linear_chain_records(J, c, k, list(bearings), {1: 60.0}, [150.0, 300.0, 600.0, 1200.0, 2000.0]):
        P = periods
        if read is not None:
            r = channel_corrected(replace(r, rates_rad_s=None), read, read=True)

        def noisy(x):
            return None if x is None else np.tile(x, P) + rng.normal(0, noise * np.std(x), x.size * P)

        t = np.arange(r.time_s.size * P) * (r.time_s[1] - r.time_s[0])
        recs.append(ChainRecord(r.omega_rad_s, t, [noisy(x) for x in r.torques_Nm], [noisy(x) for x in r.angles_rad],
                                None, P))
    runs = prepare_chain_runs(recs, band=20)
    problem = _Problem(tuple(runs), 20, 2.0 * (periods - 1), fidelity)
    return problem, problem.fit(nominal_spec(4))


def test_a_bodys_reversal_jumps_by_twice_its_static_friction_over_its_mass():
    # The jump of a body's acceleration where its rate reverses, the size the kink correction
    # restores: 2 (F_c + F_x) / m with dry friction and a Stribeck excess to ground, nothing
    # without values, without friction to ground or with no positive mass.
    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import _Problem
    from jointrig.vocab.law import Coulomb, Stribeck, Viscous

    p = _Problem((), 20, 6.0, 1e-3)
    spec = ChainSpec(((Viscous(),),), grounds=((), (Coulomb(), Stribeck(0.01))))
    values = {"J2_kgm2": 120.0, "ground2_coulomb_torque_Nm": 25.0, "ground2_stribeck_torque_Nm": 5.0}
    assert p.jumps(spec, values).sizes == (0.0, pytest.approx(0.5, rel=1e-15), 0.0)
    assert not p.jumps(spec, None) and p.jumps(spec, None).sizes == (0.0, 0.0, 0.0)
    assert p.jumps(spec, dict(values, J2_kgm2=0.0)).sizes == (0.0, 0.0, 0.0)
    assert p.jumps(ChainSpec(((Viscous(),),)), values).sizes == (0.0, 0.0, 0.0)


def test_the_candidates_are_every_cause_at_its_places_the_drives_lag_once_and_channels_past_the_first():
    from jointrig.identify.chain_diagnose import CHANNEL_CAUSES, GROUND_CAUSES, JOINT_CAUSES, candidates

    one = [c.label for c in candidates(1, drives=())]
    assert one == ["bearing_friction at flywheel 1"] + [f"{c.name} to ground at body 1" for c in GROUND_CAUSES]
    four = [c.label for c in candidates(4)]
    assert {c.name for c in CHANNEL_CAUSES} == {"angle_skew", "angle_gain"}
    # body 1's channel is the reference of the others' (its skew is the drives' lag)
    assert len(four) == 3 * len(JOINT_CAUSES) + 4 + 1 + 3 * 2 and four[3 * len(JOINT_CAUSES) + 4] == \
        "drive_delay at the drives"
    assert four[-2:] == ["angle_skew at body 4's angle channel", "angle_gain at body 4's angle channel"]
    assert not any("to ground" in label for label in four)  # no friction to ground on a train yet


def test_a_law_to_ground_sees_its_own_bodys_motion():
    import numpy as np

    from jointrig.identify.causes import Place
    from jointrig.identify.chain_diagnose import GROUND_CAUSES, Candidate

    problem, _ = _linear_problem()
    rec = problem.runs[1].average
    x, v = Candidate(GROUND_CAUSES[0], Place("ground", 2)).motion(rec)
    np.testing.assert_array_equal(x, rec.angles_rad[1])
    np.testing.assert_array_equal(v, rec.rate(1))


def test_the_drives_lag_on_data_without_one_stays_at_zero_and_is_no_place_to_drive():
    # On runs at five frequencies without a lag, the lag's profile stays at its lower bound, 0:
    # not significant, no rejection note (a lag of 0 is no unphysical negative one). Two joints'
    # candidates get a flywheel to drive that separates them; the lag, which is no place on the
    # line, gets none, and the reason.
    from jointrig.identify.chain_diagnose import JOINT_CAUSES, Candidate, candidates, score, separating_drive
    from jointrig.identify.causes import Place

    problem, (nominal, w) = _linear_problem()
    lag = [c for c in candidates(4) if c.at_drive][0]
    s = score(problem, lag, nominal, w, 10, 1e-3)
    assert s.magnitude[0] == "drive_delay_s" and s.magnitude[1] == 0.0 and not s.significant and s.note is None
    friction = next(c for c in JOINT_CAUSES if c.name == "coulomb_friction")
    a, b = Candidate(friction, Place("joint", 1)), Candidate(friction, Place("joint", 3))
    sa, sb = (score(problem, x, nominal, w, 10, 1e-3) for x in (a, b))
    from jointrig.identify.causes import AT_CHANNEL
    from jointrig.present.notes import separation_text

    amb = separating_drive(problem, a, b, sa, sb)
    body, why = amb.separating_drive, separation_text(amb)
    assert body in (1, 2, 3, 4) and why.startswith(f"driving flywheel {body} separates") and amb.effects == (
        sa.label, sb.label)
    amb = separating_drive(problem, a, lag, sa, s)
    assert amb.separating_drive is None and amb.unplaced == AT_CHANNEL and "lag" in separation_text(amb)


def test_a_fitted_free_play_is_among_the_fits_parameters():
    # The half gap a profile search set (not a linear column) is listed with the linear values,
    # at its joint, as the JSON and the model file take it.
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate

    problem, (nominal, w) = _linear_problem()
    spec = Candidate(by_name("backlash"), Place("joint", 2)).extend(nominal.spec, 2e-6)
    params = problem.solve(spec, w).parameters()
    assert params["joint2_backlash_half_gap_rad"] == 2e-6 and "joint1_backlash_half_gap_rad" not in params


def test_the_separating_information_is_per_unit_noise_at_every_flywheel():
    # The information is the separable part's squared norm over the rows' noise variance: half
    # the noise, four times the information; one entry per flywheel 1..N.
    from jointrig.vocab.law import JointLaw, QuadraticDamping
    from jointrig.identify.chain_diagnose import drive_information

    J, c, k = (1.0, 0.5, 0.5, 1.0), (30.0, 20.0, 30.0), (1e4, 5e3, 1e4)
    damping = JointLaw((QuadraticDamping(),), (10.0,))
    a, b = ("joint", 1, damping), ("flywheel", 3, 4.0)
    one = drive_information(J, c, k, (40.0, 110.0), 100.0, 1.0, a, b)
    half = drive_information(J, c, k, (40.0, 110.0), 100.0, 0.5, a, b)
    assert sorted(one) == [1, 2, 3, 4]
    assert all(half[d] == pytest.approx(4.0 * one[d], rel=1e-12) for d in one)


def test_prepared_runs_keep_their_start_and_name_their_channels_by_body():
    # Each run's averaged period starts where the record starts, and the noise of every channel
    # is named by its body's number (torque1 on the driven body 1, phi1..phi4).
    problem, _ = _linear_problem()
    run = problem.runs[2]
    assert run.average.time_s[0] == 0.0 and run.periods[0].time_s[0] == 0.0
    assert run.periods[0].source.endswith("(period 1, band-limited)")
    assert run.average.source.endswith("(period average, band-limited)")
    assert set(run.noise_std) == {"torque1", "phi1", "phi2", "phi3", "phi4"}
    assert run.average.torques_Nm[1] is None and run.average.torques_Nm[0] is not None


def test_a_fitted_lag_is_among_the_fits_parameters_and_a_jump_corrects_the_rate():
    # The drives' lag in a structure is listed with the fit's parameters; a body with a jump at
    # its reversals gets its rate with the kinks restored (a rate the record did not hold), the
    # others keep theirs (None: the spectral derivative).
    from dataclasses import replace as dc_replace

    problem, (nominal, w) = _linear_problem()
    assert problem.solve(dc_replace(nominal.spec, drive_delay_s=1e-5), w).parameters()["drive_delay_s"] == 1e-5
    assert "drive_delay_s" not in nominal.parameters()
    from jointrig.identify.chain_diagnose import Jumps

    jumps = Jumps((0.0, 50.0, 0.0, 0.0))
    (avg,) = problem.records(jumps, periods=False)[0]
    periods = problem.records(jumps, periods=True)[0]
    assert avg.rates_rad_s[1] is not None and avg.rates_rad_s[0] is None
    assert len(periods) == problem.runs[0].n_periods and all(r.rates_rad_s[1] is not None for r in periods)
    assert all(r[0].rates_rad_s == (None,) * 4 for r in problem.records(Jumps((0.0,) * 4), periods=False))


def test_a_train_read_wrong_says_which_joint_feeds_energy_in():
    # A fit with a significantly negative stiffness at joint 2 (and positive inertias) names joint
    # 2 alone; a plausible fit says nothing.
    import numpy as np

    from jointrig.identify.chain_diagnose import ChainFit, implausible_train_fit, nominal_spec

    spec = nominal_spec(3)
    names = spec.names
    good = {n: (1.0 if n.startswith("J") else 100.0) for n in names}
    bad = dict(good, joint2_k_Nm_per_rad=-9.0)

    def fit(values):
        v = np.array([values[n] for n in names])
        return ChainFit(spec, names, v, np.full(v.size, 0.1), 1.0, 100, np.zeros(100))

    from jointrig.identify.chain_diagnose import ReadWrong
    from jointrig.present.notes import plausibility_text

    assert implausible_train_fit(fit(good)) == ()
    said = implausible_train_fit(fit(bad))
    assert said == (ReadWrong((), (2,)),)
    assert plausibility_text(said[0]).startswith("joint(s) 2 come out with a negative stiffness")


def test_weights_from_the_periods_spread_give_a_right_model_the_noises_chi_square():
    # The right structure on noisy exact data, weighted by each row's period-to-period spread
    # (pooled per harmonic and equation) without a fidelity floor: chi2/dof is the noise's,
    # 1 within 4 / sqrt(dof) (chi-square's spread, with the weights' own scatter).
    import math

    _, (nominal, _) = _linear_problem(fidelity=0.0)
    assert abs(nominal.chi2 / nominal.dof - 1.0) < 4.0 / math.sqrt(nominal.dof), (nominal.chi2, nominal.dof)


def test_a_drag_that_would_feed_energy_in_rejects_the_extension():
    # An extended fit holding a bearing drag more than 2 standard errors below zero (5 and 2.5) is
    # refused with that reason; one within 2 standard errors of zero (1.9, 1.5) is not. A drag
    # without a finite standard error is refused when below zero at all, and not at exactly zero.
    import math

    import numpy as np

    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, ChainFit, _rejection, nominal_spec

    problem, _ = _linear_problem()
    spec = Candidate(by_name("bearing_friction"), Place("flywheel", 2)).extend(nominal_spec(4), 0.0)
    names = spec.names

    def fit(drag, se=0.1):
        v = np.array([drag if n.startswith("bearing") else 1.0 for n in names])
        return ChainFit(spec, names, v, np.where([n.startswith("bearing") for n in names], se, 0.1), 1.0, 100,
                        np.zeros(100))

    from jointrig.identify.causes import FeedsEnergy
    from jointrig.present.notes import rejection_text

    cand = Candidate(by_name("quadratic_damping"), Place("joint", 1))
    said = _rejection(problem, cand, fit(-0.5), ("x", 1.0, 0.1))
    assert said == FeedsEnergy("bearing2_damping_Nms_per_rad", -0.5, 0.1)
    assert rejection_text(said).endswith("would feed energy in")
    assert _rejection(problem, cand, fit(-0.25), ("x", 1.0, 0.1)) == FeedsEnergy("bearing2_damping_Nms_per_rad",
                                                                               -0.25, 0.1)
    for drag in (-0.2, -0.19, -0.15):  # (exactly 2 standard errors is not beyond them)
        assert _rejection(problem, cand, fit(drag), ("x", 1.0, 0.1)) is None
    assert isinstance(_rejection(problem, cand, fit(-1e-9, math.nan), ("x", 1.0, 0.1)), FeedsEnergy)
    assert _rejection(problem, cand, fit(0.0, math.nan), ("x", 1.0, 0.1)) is None


def test_a_carriage_sliding_through_rest_is_fitted_with_its_kinks_restored():
    # One carriage of the independent bench (tests/bench_slide_sim.py: 12 kg, 40 N s/m, 25 N)
    # driven at 150 N, 4 whole periods at 40 dB. Its dry friction makes the acceleration jump by
    # 2 F_c / m at every reversal; the fit restores the rate's kinks at the fitted friction and
    # refits until the jump settles: the friction within 3 standard errors of the bench's, and a
    # chi-square below the fit at the band-limited rate's.
    import math

    from bench_slide_sim import Carriage
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _Problem, nominal_spec

    problem = _Problem(_carriage_runs(Carriage()), 20, 6.0, 1e-3, (True,))
    assert problem.masks() is None  # it slides through rest: nothing to mask
    spec = Candidate(by_name("coulomb_friction"), Place("ground", 1)).extend(nominal_spec(1), 0.0)
    f, wts = problem.fit(spec)
    fc, se = f.as_dict()["ground1_coulomb_torque_Nm"], f.std_error("ground1_coulomb_torque_Nm")
    assert abs(fc - 25.0) < 3 * se, (fc, se)
    jumps = problem.jumps(spec, f.as_dict())
    assert jumps.sizes[0] == 2 * fc / f.as_dict()["J1_kgm2"]
    plain = problem._fit_of(spec, wts, *problem._solve_once(spec, wts, None), None)
    assert f.chi2 < plain.chi2


def test_a_joints_reversal_jumps_the_twists_acceleration_shared_by_its_bodies():
    # Dry friction F in joint 2 flips by 2F where the twist rate reverses: body 2's acceleration
    # jumps by 2F/J2, body 3's by 2F/J3 the other way, the twist's by their sum; body 2 takes
    # the share (1/J2) / (1/J2 + 1/J3) of it. Nothing jumps at a joint without dry friction.
    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import Jumps, _Problem
    from jointrig.vocab.law import Coulomb, Power, Viscous

    p = _Problem((), 20, 6.0, 1e-3)
    spec = ChainSpec(((Viscous(),), (Power(1), Coulomb()), (Viscous(),)))
    values = {"J1_kgm2": 1.0, "J2_kgm2": 0.5, "J3_kgm2": 0.25, "J4_kgm2": 2.0, "joint1_c_Nms_per_rad": 1.0,
              "joint2_k_Nm_per_rad": 1e4, "joint2_coulomb_torque_Nm": 3.0, "joint3_c_Nms_per_rad": 1.0}
    jumps = p.jumps(spec, values)
    assert jumps.sizes == (0.0, 0.0, 0.0, 0.0, 0.0, pytest.approx(2 * 3.0 * (2.0 + 4.0), rel=1e-15), 0.0)
    assert jumps.shares[1] == pytest.approx(2.0 / 6.0, rel=1e-15)
    assert jumps and not Jumps((0.0,) * 7)
    assert jumps.settled(Jumps(tuple(s * (1 + 1e-9) for s in jumps.sizes))) and not jumps.settled(None)
    assert not jumps.settled(Jumps(tuple(s * 1.1 for s in jumps.sizes)))


def test_a_twist_at_the_noise_is_not_resolved_and_its_joint_is_summed_only_if_it_may_stick():
    # The linear train's twists stand far above their noise (60 dB): resolved, and the
    # coupling's (joint 2) does not rest. Make bodies 2 and 3 move alike (joint 2 stuck the whole period; only noise is left
    # in its twist): not resolved, so its bodies' equations are summed in that run, but only
    # where a model may let joint 2 stick. A joint stuck the whole period in every run is left balanced.
    from dataclasses import replace

    import numpy as np

    from jointrig.identify.chain_diagnose import _Problem, twist_resolved

    problem, _ = _linear_problem()
    runs = problem.runs
    assert all(twist_resolved(r, j) for r in runs for j in range(3))
    assert _Problem(runs, 20, 6.0, 1e-3, (), (False, True, False)).merged() is None

    def stuck(run, rng=np.random.default_rng(5)):
        def alike(rec):
            a = list(rec.angles_rad)
            a[2] = a[1] + rng.normal(0, 1e-3 * np.std(a[1]), a[1].size)
            return replace(rec, angles_rad=tuple(a))
        return replace(run, average=alike(run.average), periods=tuple(alike(p) for p in run.periods))

    held = (stuck(runs[0]),) + runs[1:]
    assert not twist_resolved(held[0], 1) and twist_resolved(held[0], 0)
    assert _Problem(held, 20, 6.0, 1e-3, (), (False, True, False)).merged() == [(1,), (), (), (), ()]
    assert _Problem(held, 20, 6.0, 1e-3, (), (False, False, False)).merged() is None
    everywhere = tuple(stuck(r) for r in runs)
    assert _Problem(everywhere, 20, 6.0, 1e-3, (), (False, True, False)).merged() is None


def test_the_standard_errors_cover_although_each_rows_variance_comes_from_four_periods():
    # Every row is weighted by a variance estimated from its residual's spread over the P = 4
    # periods (nu = 6 degrees of freedom); the inverse of such an estimate is nu / (nu - 2) = 1.5
    # times too large on average, and the covariance carries that factor as the chi-square does
    # (identify.estimates.weighted_chi2). The linear train balanced at its one excited harmonic
    # (no row holds only noise: scripts/coverage_periods.py shows what those add), 100 seeds:
    # the RMS of z = (value - truth) / SE over the ten parameters is 1 for calibrated errors
    # (1.16 without the factor, 0.95 with it). The bound 0.88-1.12 is about 3 of its standard
    # errors (1000 z's, correlated within a seed: some 300 independent, 4% each).
    import numpy as np

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import _Problem
    from jointrig.vocab.law import Power, Viscous

    spec = ChainSpec(tuple((Viscous(), Power(1)) for _ in LINEAR_K))
    z = []
    for seed in range(100):
        problem, _ = _linear_problem(seed)
        fit, _ = _Problem(problem.runs, 1, problem.nu, 1e-9).fit(spec)
        values = fit.parameters()
        z += [(values[n] - t) / fit.std_error(n) for n, t in LINEAR_TRUTH.items()]
    assert 0.88 <= float(np.sqrt(np.mean(np.square(z)))) <= 1.12


def test_the_reported_values_carry_no_bias_from_harmonics_that_hold_noise_alone():
    # Balanced at harmonics 1..20, the linear train's rows at 2..20 hold noise alone; the noise
    # of the measured angles in the balance's matrix pulls the least-squares values towards zero
    # (errors in variables): -0.42 standard errors at bodies 3-4 over 400 seeds at P = 4
    # (scripts/coverage_periods.py). The compensated values (_Problem.compensated: the matrix's
    # noise covariance from the periods' spread taken out) read mean z -0.01..+0.03 there. Over
    # these 60 seeds: the mean z of each of the six parameters is within 0.39 of 0 (3 standard
    # errors of a mean of 60 unit z's; measured +0.08..+0.12, least squares -0.33..-0.37), and
    # each seed's shift from the least-squares value is +0.25..+0.60 standard errors on average
    # (measured +0.45..+0.47: the bias it removes; this bound is what fails without it).
    import numpy as np

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import _Problem
    from jointrig.vocab.law import Power, Viscous

    spec = ChainSpec(tuple((Viscous(), Power(1)) for _ in LINEAR_K))
    names = ["J3_kgm2", "J4_kgm2", "joint2_c_Nms_per_rad", "joint3_c_Nms_per_rad", "joint2_k_Nm_per_rad",
             "joint3_k_Nm_per_rad"]
    z, shift = [], []
    for seed in range(60):
        problem, _ = _linear_problem(seed, fidelity=1e-9, periods=4)
        plain, w = problem.fit(spec)
        fit = problem.compensated(plain, w)
        z.append([(fit.value(n) - LINEAR_TRUTH[n]) / fit.std_error(n) for n in names])
        shift.append([(fit.value(n) - plain.value(n)) / plain.std_error(n) for n in names])
    assert np.all(np.abs(np.mean(z, axis=0)) <= 0.39), np.mean(z, axis=0)
    assert np.all((np.mean(shift, axis=0) >= 0.25) & (np.mean(shift, axis=0) <= 0.60)), np.mean(shift, axis=0)


def test_a_fit_of_noise_free_periods_is_left_as_it_is_by_the_compensation():
    # Every period of an exact steady state is the same: no spread, nothing to take out. The
    # values may move by rounding alone (1e-9 relative: the normal equations' digits).
    import numpy as np

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import _Problem
    from jointrig.vocab.law import Power, Viscous

    spec = ChainSpec(tuple((Viscous(), Power(1)) for _ in LINEAR_K))
    problem, _ = _linear_problem(0, fidelity=1e-9, periods=4, noise=0.0)
    plain, w = problem.fit(spec)
    fit = problem.compensated(plain, w)
    assert np.allclose(fit.values, plain.values, rtol=1e-9, atol=0.0)
    assert np.allclose(fit.std_errors, plain.std_errors, rtol=1e-9, atol=0.0)


def test_a_joint_may_stick_where_the_nominal_law_or_significant_evidence_gives_it_dry_friction():
    # The linear train has no dry friction: no joint's Coulomb candidate is significant, so no
    # joint's equations are ever summed (a stiff shaft's noisy twist rate may rest by the rule's
    # measure, and summing there would only lose rows). A nominal law with dry friction at joint
    # 2 lets that joint stick, and only it.
    from dataclasses import replace

    from jointrig.identify.chain_diagnose import _joints_that_may_stick, candidates, nominal_spec
    from jointrig.vocab.law import Coulomb

    problem, _ = _linear_problem()
    pool = candidates(4)
    assert _joints_that_may_stick(problem, nominal_spec(4), pool, 1e-3) == (False, False, False)
    spec = nominal_spec(4)
    joints = list(spec.joints)
    joints[1] = joints[1] + (Coulomb(),)
    assert _joints_that_may_stick(problem, replace(spec, joints=tuple(joints)), pool, 1e-3) == (False, True, False)


@pytest.mark.slow  # slow: two whole diagnoses of a 3-body train (about 75 s on one core)
def test_a_clean_train_gets_no_cause_and_a_bodys_drag_is_named_at_its_body():
    # The whole diagnosis on exact steady states of the linear train (60 dB): without any effect,
    # no candidate of the 38 (9 causes at 3 joints, drag at 4 bodies, the drives' lag, the skew
    # and scale of bodies 2-4's angle channels; each twist's zero is part of the nominal model
    # under its cubic term, not a cause) is significant and nothing is adopted, nothing
    # rests or is summed, and the noise per channel is the runs' median. With 4 N m s/rad of drag at body 3 it is ranked first, adopted alone
    # and sized within 3 standard errors (the evidence's own scatter).
    import numpy as np

    from jointrig.identify.chain_diagnose import diagnose_chain

    problem, _ = _linear_problem()
    d = diagnose_chain(problem.runs, n_harmonics=20, workers=1)
    assert d.steps == () and len(d.first_round) == 38 and not any(s.significant for s in d.first_round)
    assert d.rests == () and d.stuck_joints == () and d.plausibility == () and d.ambiguities == ()
    assert d.final is d.nominal and d.found is None
    assert d.noise_std["phi1"] == float(np.median([r.noise_std["phi1"] for r in problem.runs]))
    assert d.nu == 6.0 and d.n_harmonics == 20

    dragged, _ = _linear_problem(bearings=(0.0, 0.0, 4.0, 0.0))
    d = diagnose_chain(dragged.runs, n_harmonics=20, workers=1)
    assert [s.label for s in d.steps] == ["bearing_friction at flywheel 3"] == [d.first_round[0].label]
    name, value, se = d.found.magnitude
    assert name == "bearing3_damping_Nms_per_rad" and abs(value - 4.0) < 3 * se, (value, se)
    assert d.reduced_chi2(d.final) < d.reduced_chi2(d.nominal)

    # two drags: both adopted (the default allows two effects), each at its body
    both, _ = _linear_problem(bearings=(6.0, 0.0, 4.0, 0.0))
    d = diagnose_chain(both.runs, n_harmonics=20, workers=1)
    assert sorted(s.label for s in d.steps) == ["bearing_friction at flywheel 1", "bearing_friction at flywheel 3"]
    fitted = d.final.as_dict()
    for name, truth in (("bearing1_damping_Nms_per_rad", 6.0), ("bearing3_damping_Nms_per_rad", 4.0)):
        assert abs(fitted[name] - truth) < 3 * d.final.std_error(name), (name, fitted[name])


@pytest.mark.slow  # slow: a whole diagnosis of a train (about 25 s on one core)
def test_the_drives_lag_is_a_candidate_from_two_frequencies_on():
    # A lag only turns every harmonic by a fixed angle at one frequency, where a law can do the
    # same: it is scored once the runs hold two frequencies (apart by more than 1e-3), whatever
    # their number.
    from dataclasses import replace

    from jointrig.identify.chain_diagnose import diagnose_chain

    problem, _ = _linear_problem()
    two = problem.runs[:2]  # 150 and 300 rad/s
    labels = [s.label for s in diagnose_chain(two, n_harmonics=20, workers=1).first_round]
    assert len(labels) == 38 and "drive_delay at the drives" in labels

    def at(run, w):  # the same samples, read at another frequency
        def rec(r):
            return replace(r, omega_rad_s=w, time_s=r.time_s * (r.omega_rad_s / w))
        return replace(run, average=rec(run.average), periods=tuple(rec(p) for p in run.periods))

    same = (two[0], at(two[1], 150.0 * (1 + 5e-4)))
    labels = [s.label for s in diagnose_chain(same, n_harmonics=20, workers=1).first_round]
    assert len(labels) == 37 and "drive_delay at the drives" not in labels


def test_a_trains_misfit_is_described_at_every_joint_and_a_places_law_is_its_own():
    # The linear train fitted without the drag it has at body 3: the residual is measured at
    # each of its three joints, named in order; a joint's place law is its fitted law with the
    # inertia of its two bodies' mode, and a single body's is its drag to ground with its mass.
    import math

    import numpy as np

    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.chain_diagnose import (_Problem, nominal_spec, place_law, plant_and_inertias,
                                                  prepare_chain_runs, train_joint_runs, train_misfit)
    from test_chain import _linear_chain_records

    dragged, (fit, _) = _linear_problem(bearings=(0.0, 0.0, 4.0, 0.0))
    m = train_misfit(dragged.runs, [str(k) for k in range(5)], [60.0] * 5, fit, 20)
    assert [name for name, _ in m.by_place] == ["joint 1", "joint 2", "joint 3"]
    places = train_joint_runs(dragged.runs, [str(k) for k in range(5)], fit, 20)
    assert len(places) == 3 and all(len(p) == 5 for p in places)
    assert all(r.phi.shape == (4, 21) == r.torque.shape for p in places for r in p)
    assert all(math.isfinite(r) and r > 0 for _, r in m.by_place)
    law, J = place_law(fit, 1)
    p = fit.as_dict()
    assert law == plant_and_inertias(fit)[0].laws[1]
    assert J == p["J2_kgm2"] * p["J3_kgm2"] / (p["J2_kgm2"] + p["J3_kgm2"])

    rng = np.random.default_rng(2)
    recs = []
    for r in _linear_chain_records([12.0], [], [], [40.0], {1: 150.0}, [5.0, 10.0, 20.0]):
        t = np.arange(r.time_s.size * 3) * (r.time_s[1] - r.time_s[0])
        recs.append(ChainRecord(r.omega_rad_s, t, [np.tile(r.torques_Nm[0], 3) + rng.normal(0, 0.01, t.size)],
                                [np.tile(r.angles_rad[0], 3) + rng.normal(0, 1e-6, t.size)], None, 3))
    single = _Problem(tuple(prepare_chain_runs(recs, band=20)), 20, 4.0, 1e-3)
    f1, _ = single.fit(nominal_spec(1))
    law, mass = place_law(f1, 0)
    assert len(train_joint_runs(single.runs, ["a", "b", "c"], f1, 20)) == 1
    assert mass == f1.as_dict()["J1_kgm2"] and law.values[-1] == f1.as_dict()["bearing1_damping_Nms_per_rad"]
    # noise of 0.01 N on 150 N and 1e-6 m on swings of 3 to 40 cm: the scatter is far below these
    # bounds (1e-3 and 5%), which catch a value read from the wrong place, not the estimator's noise
    assert abs(mass - 12.0) < 1e-3 * 12.0 and abs(law.values[-1] - 40.0) < 0.05 * 40.0


def test_information_is_none_for_an_effect_without_a_torque():
    # An effect that adds no torque along the motion cannot be told from anything: no drive gives
    # information (0, not a division by zero).
    from jointrig.identify.chain_diagnose import drive_information
    from jointrig.vocab.law import JointLaw, Viscous

    nothing = ("joint", 2, JointLaw((Viscous(),), (0.0,)))
    drag = ("flywheel", 3, 4.0)
    chain = ([0.45, 0.06, 0.12, 0.35], [15.0, 20.0, 10.0], [4e5, 2.5e4, 1.2e5], [150.0, 600.0], 60.0, 0.04)
    for first, second in ((nothing, drag), (drag, nothing)):
        assert drive_information(*chain, first, second) == {1: 0.0, 2: 0.0, 3: 0.0, 4: 0.0}
    assert all(v > 0 for v in drive_information(*chain, ("joint", 2, JointLaw((Viscous(),), (5.0,))), drag).values())


def test_what_a_candidates_motion_resolves_is_three_noise_deviations_of_its_band():
    # The angle resolution a slip angle or a free play is judged against: 3 standard deviations
    # of one sample of the band-limited period average of the candidate's two angles, the
    # largest over the runs (identify.chain_diagnose.angle_resolution).
    import math

    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, angle_resolution

    problem, _ = _linear_problem()
    cand = Candidate(by_name("backlash"), Place("joint", 2))
    want = max(3.0 * math.hypot(r.noise_std["phi2"], r.noise_std["phi3"])
               * math.sqrt(min(1.0, 41 / r.samples_per_period) / r.n_periods) for r in problem.runs)
    assert angle_resolution(problem, cand) == pytest.approx(want, rel=1e-12) and want > 0


def test_a_fits_zero_offset_is_named_at_its_joint_and_a_negative_friction_jumps_nothing():
    # A fit whose structure holds a zero offset at joint 2 lists it as joint 2's; a friction to
    # ground fitted negative (nonphysical) makes no jump (the kink correction needs a positive
    # one).
    from dataclasses import replace

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import _Problem
    from jointrig.vocab.law import Coulomb, Viscous

    problem, (nominal, w) = _linear_problem()
    spec = replace(nominal.spec, offsets_rad=(0.0, 3e-4, 0.0))
    params = problem.solve(spec, w).parameters()
    assert params["joint2_angle_offset_rad"] == 3e-4
    assert "joint1_angle_offset_rad" not in params and "joint3_angle_offset_rad" not in params
    p = _Problem((), 20, 6.0, 1e-3)
    ground = ChainSpec(((Viscous(),),), grounds=((), (Coulomb(),)))
    assert p.jumps(ground, {"J2_kgm2": 120.0, "ground2_coulomb_torque_Nm": -25.0}).sizes == (0.0, 0.0, 0.0)


def test_a_joint_whose_twist_rests_is_summed_there_and_reported():
    # Joint 2's twist made to rest a fifth of run 0's period (flat, resolved far above the noise)
    # in a model whose coupling has dry friction: its bodies' equations are summed in that run
    # alone, and the diagnosis reports it with the share of the period its twist rests.
    from dataclasses import replace

    import numpy as np

    from jointrig.identify.chain import rest_share
    from jointrig.identify.chain_diagnose import _Problem, diagnose_chain, nominal_spec, twist_resolved
    from jointrig.vocab.law import Coulomb

    problem, _ = _linear_problem()
    runs = problem.runs

    def resting(rec):
        a = list(rec.angles_rad)
        M = a[1].size
        u = np.sin(2 * np.pi * np.arange(M) / M)
        flat = np.clip(u, -0.8, 0.8) * np.std(a[1] - a[2]) * 3.0
        a[2] = a[1] - flat
        return replace(rec, angles_rad=tuple(a))

    held = (replace(runs[0], average=resting(runs[0].average), periods=tuple(resting(p) for p in runs[0].periods)),)
    held += runs[1:]
    assert twist_resolved(held[0], 1)
    assert _Problem(held, 20, 6.0, 1e-3, (), (False, True, False)).merged() == [(1,), (), (), (), ()]
    spec = nominal_spec(4)
    joints = list(spec.joints)
    joints[1] = joints[1] + (Coulomb(),)
    d = diagnose_chain(held, n_harmonics=20, workers=1, nominal=replace(spec, joints=tuple(joints)), max_effects=0)
    share = rest_share(held[0].average.rate(1) - held[0].average.rate(2))
    assert (0, 2, share, True) in [s[:4] for s in d.stuck_joints] and share > 0.1
    assert [k for k, j, *_ in d.stuck_joints if j == 2] == [0]  # the coupling's twist moves in the others


def test_the_separating_drive_takes_a_joints_law_and_a_bodys_drag_as_each_is(monkeypatch):
    # A joint cause and a body's drag, both scored on the linear train: the drive that tells them
    # apart is named with the information of every drive (each effect evaluated as its kind), at
    # the runs' drive amplitude (60 N m; its band-limited average's half peak-to-peak, to the
    # 60 dB noise) and torque noise.
    import jointrig.identify.chain_diagnose as cd
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, score, separating_drive

    seen = []

    def spy(*args, **kw):
        seen.append(args)
        return information(*args, **kw)

    information = cd.drive_information
    monkeypatch.setattr(cd, "drive_information", spy)

    problem, (nominal, w) = _linear_problem(bearings=(0.0, 0.0, 4.0, 0.0))
    joint = Candidate(by_name("quadratic_damping"), Place("joint", 2))
    drag = Candidate(by_name("bearing_friction"), Place("flywheel", 3))
    sj, sd = (score(problem, c, nominal, w, 32, 1e-3) for c in (joint, drag))
    from jointrig.present.notes import separation_text

    amb = separating_drive(problem, joint, drag, sj, sd)
    drive, why = amb.separating_drive, separation_text(amb)
    assert drive in (1, 2, 3, 4) and f"driving flywheel {drive} separates" in why
    assert [d for d, _ in amb.information][0] == drive and sorted(d for d, _ in amb.information) == [1, 2, 3, 4]
    assert all(f"flywheel {i}:" in why for i in range(1, 5))
    (_, _, _, omegas, torque, sigma, *_), = seen
    assert torque == pytest.approx(60.0, rel=1e-2) and omegas == pytest.approx([150.0, 300.0, 600.0, 1200.0, 2000.0])
    # 1e-3 of the torque's std, per sample; within 20%, 3 of its standard errors: a median over 31
    # harmonics of 6 degrees of freedom each is within about 13% on the variance, 6.5% on the std
    assert sigma == pytest.approx(1e-3 * 60.0 / 2 ** 0.5, rel=0.2)


def test_two_causes_at_one_place_are_told_apart_by_other_runs_not_by_a_drive():
    # Every drive moves two causes at one joint alike, so no drive information is computed (the
    # problem is not read); the ambiguity names the runs that separate the pair.
    from jointrig.identify.causes import SAME_PLACE, CauseScore, Place, by_name, separating_excitation
    from jointrig.identify.chain_diagnose import Candidate, separating_drive

    here = Place("joint", 2)
    a, b = Candidate(by_name("coulomb_friction"), here), Candidate(by_name("hysteresis"), here)
    sa, sb = (CauseScore(c.cause.name, 50.0, 1, 40.0, 1e-9, True, None, ("m", 1.0, 0.1), where=here) for c in (a, b))
    amb = separating_drive(None, a, b, sa, sb)
    assert amb.effects == ("coulomb_friction at joint 2", "hysteresis at joint 2") and amb.separating_drive is None
    assert amb.unplaced == SAME_PLACE and amb.excitation == separating_excitation("coulomb_friction", "hysteresis")
    assert "add a low-amplitude run" in amb.excitation


@pytest.mark.parametrize("delay_s, gain", [(2e-5, 0.0), (-2e-5, 0.0), (0.0, 0.02)])
def test_a_channel_read_late_or_scaled_is_found_at_its_body_with_its_size(delay_s, gain):
    # Body 3's angle read 20 us late or early (the search reaches +-5% of the fastest run's
    # period, 157 us; a skew has either sign) or 2% too large: the cause at body 3's channel is significant and its size within 3
    # standard errors of the truth (60 dB of noise), and it explains more than the same cause at
    # another body's channel.
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import Candidate, score
    from jointrig.vocab.law import Power, Viscous

    read = ChainSpec(((Viscous(), Power(1)),) * 3, channel_delays_s=(0.0, 0.0, delay_s, 0.0),
                     channel_gains=(0.0, 0.0, gain, 0.0))
    problem, (nominal, w) = _linear_problem(read=read)
    cause = by_name("angle_skew" if delay_s else "angle_gain")
    here = score(problem, Candidate(cause, Place("channel", 3)), nominal, w, 38, 1e-3)
    there = score(problem, Candidate(cause, Place("channel", 2)), nominal, w, 38, 1e-3)
    name, value, se = here.magnitude
    assert name == ("angle3_delay_s" if delay_s else "angle3_gain_error")
    assert here.significant and abs(value - (delay_s or gain)) <= 3 * se, (value, se)
    assert here.delta_chi2 > there.delta_chi2
    assert here.label == f"{cause.name} at body 3's angle channel"


def test_a_places_covariance_is_its_laws_and_its_modes_inertia():
    # The card's model curves carry the fit's covariance mapped onto (the mode's inertia, the
    # law's values): the law's block as the fit has it, the inertia's variance to first order
    # in the two bodies' (J_a J_b / (J_a + J_b)).
    import numpy as np

    from jointrig.identify.chain_diagnose import place_covariance, place_law

    problem, (fit, _) = _linear_problem()
    law, je = place_law(fit, 1)
    cov = place_covariance(fit, 1)
    idx = {n: i for i, n in enumerate(fit.names)}
    names = [f"joint2_{n}" for n in law.names]
    block = fit.covariance[np.ix_([idx[n] for n in names], [idx[n] for n in names])]
    np.testing.assert_allclose(cov[1:, 1:], block, rtol=1e-12)
    Ja, Jb = fit.as_dict()["J2_kgm2"], fit.as_dict()["J3_kgm2"]
    g = np.zeros(len(fit.names))
    g[idx["J2_kgm2"]], g[idx["J3_kgm2"]] = (Jb / (Ja + Jb)) ** 2, (Ja / (Ja + Jb)) ** 2
    assert cov[0, 0] == pytest.approx(g @ fit.covariance @ g, rel=1e-12)
    assert je == pytest.approx(Ja * Jb / (Ja + Jb), rel=1e-12)


def test_the_last_bodys_inertia_is_checked_for_plausibility_too():
    import numpy as np

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import ChainFit, implausible_train_fit
    from jointrig.vocab.law import Power

    spec = ChainSpec(((Power(1),),) * 2)
    names = spec.names  # J1, joint1_k, J2, joint2_k, J3

    def fit(values):
        return ChainFit(spec, names, np.array(values, float), np.full(len(names), 0.01), 10.0, 100,
                        np.zeros(100))
    from jointrig.identify.chain_diagnose import ReadWrong, UndeterminedInertia
    from jointrig.present.notes import plausibility_text
    from jointrig.vocab.params import SLIDE

    assert implausible_train_fit(fit([1.0, 1e4, 1.0, 1e4, 1.0])) == ()
    said = implausible_train_fit(fit([1.0, 1e4, 1.0, 1e4, -0.5]))
    assert said == (ReadWrong(((3, -0.5, 0.01),), ()),)
    text = plausibility_text(said[0])
    assert "body(ies) 3" in text and "J3 = -0.5 +- 0.01" in text and "position columns" in text
    assert "m3 = -0.5 +- 0.01" in plausibility_text(said[0], SLIDE)  # a carriage's mass by its name
    # within two standard errors of zero (either side) it is not determined, not read wrong
    for J3 in (-0.015, 0.015):
        (said,) = implausible_train_fit(fit([1.0, 1e4, 1.0, 1e4, J3]))
        assert said == UndeterminedInertia(((3, J3, 0.01),))
        text = plausibility_text(said)
        assert "body(ies) 3" in text and "not determined by these runs" in text and "position columns" not in text
    # judged on the kept (extended) model: its last body undetermined, the first two not; the
    # nominal fit's own inertias are all plausible (a dry friction can hide a carriage's mass)
    kept = fit([1.0, 1e4, 1.0, 1e4, 0.015])
    assert implausible_train_fit(fit([1.0, 1e4, 1.0, 1e4, 1.0]), kept) == (UndeterminedInertia(((3, 0.015, 0.01),)),)
    kept = fit([0.015, 1e4, 1.0, 1e4, 1.0])
    assert implausible_train_fit(fit([1.0, 1e4, 1.0, 1e4, 1.0]), kept) == (UndeterminedInertia(((1, 0.015, 0.01),)),)


def test_a_joint_cards_runs_read_its_twist():
    # The card's runs at joint 2 of the linear train: each period's twist harmonics are phi2 - phi3's.
    import numpy as np

    from jointrig.identify.chain_diagnose import train_joint_runs
    from jointrig.identify.harmonics import fourier_coefficients

    problem, (fit, _) = _linear_problem()
    places = train_joint_runs(problem.runs[:2], ["a", "b"], fit, 5)
    assert len(places) == 3 and [jr.run for jr in places[1]] == ["a", "b"]
    period = problem.runs[0].periods[0]
    twist = fourier_coefficients(period.angles_rad[1] - period.angles_rad[2], 1, 5)
    np.testing.assert_allclose(places[1][0].phi[0], twist, rtol=1e-12, atol=1e-15)


def test_the_separating_information_of_two_drags_is_the_smaller_ones_rows_in_closed_form():
    # Drags at the two bodies of a 2-body chain load different equations: neither takes up any of
    # the other, and the information is the smaller drag torque's squared amplitude at the
    # fundamental, |w X_i b_i|^2, over the noise, X = Z(w)^-1 e_d T (Z the dynamic stiffness).
    import numpy as np

    from jointrig.identify.chain_diagnose import drive_information

    J, c, k, T, w, sigma = (2.0, 0.5), (30.0,), (1e4,), 100.0, 60.0, 0.5
    info = drive_information(J, c, k, (w,), T, sigma, ("flywheel", 1, 4.0), ("flywheel", 2, 3.0))
    z = k[0] + 1j * w * c[0]
    Z = np.array([[-w**2 * J[0] + z, -z], [-z, -w**2 * J[1] + z]])
    for d in (1, 2):
        X = np.linalg.solve(Z, np.eye(2)[d - 1] * T)
        expected = min(abs(w * X[0] * 4.0) ** 2, abs(w * X[1] * 3.0) ** 2) / sigma**2
        assert info[d] == pytest.approx(expected, rel=1e-12), d


def test_a_free_plays_bounds_read_the_twist_and_a_stribeck_rate_the_twist_rate():
    # The search bounds of a cause read the run where its place swings most: of the twist for a
    # free play, of the twist's rate for a Stribeck rate (rad/s). On the linear train's runs at
    # 150, 1200 and 2000 rad/s joint 1 twists most at the first and fastest at the last (the
    # rate is the twist times omega), so each cause reads the run of its own kind.
    import numpy as np

    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _Problem, _twist_runs

    full, _ = _linear_problem()
    problem = _Problem(tuple(full.runs[i] for i in (0, 3, 4)), 20, 6.0, 1e-3)
    gap, peak = (Candidate(by_name(n), Place("joint", 1)) for n in ("backlash", "stribeck_friction"))
    twists = [gap.motion(r.average) for r in problem.balanced_runs(gap)]
    by_twist = int(np.argmax([np.ptp(x) for x, _ in twists]))
    by_rate = int(np.argmax([np.ptp(v) for _, v in twists]))
    assert by_twist != by_rate  # the case that tells the two readings apart
    (g,), (p,) = _twist_runs(problem, gap), _twist_runs(problem, peak)
    np.testing.assert_array_equal(g.average.phi_rad, twists[by_twist][0])
    np.testing.assert_array_equal(p.average.phi_rad, twists[by_rate][0])


def test_no_drive_is_named_to_tell_a_law_to_ground_from_a_joint():
    # The linearised drive information holds joints and drags only: a law to ground beside a
    # joint's cause (either way round) gets no drive, and the reason.
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, score, separating_drive

    problem, (nominal, w) = _linear_problem()
    ground = Candidate(by_name("coulomb_friction"), Place("ground", 2))
    joint = Candidate(by_name("coulomb_friction"), Place("joint", 2))
    sg, sj = (score(problem, c, nominal, w, 10, 1e-3) for c in (ground, joint))
    for pair in ((ground, joint, sg, sj), (joint, ground, sj, sg)):
        from jointrig.present.notes import separation_text

        amb = separating_drive(problem, *pair)
        assert amb.separating_drive is None and "no linearised drive information for a law to ground" in \
            separation_text(amb)


def _one_body_problem(terms=None):
    """One body of 2 kg m^2 tied to the frame by c 5 N m s/rad and k 2000 N m/rad (the
    relative-angle form's joint), exact steady states at five frequencies from its dynamic
    stiffness, 4 periods each with 60 dB of noise; the problem and its fit of ``terms`` to
    ground (default the paper's law, the relative-angle form's nominal model)."""
    import numpy as np

    from jointrig.identify.chain import ChainRecord, ChainSpec
    from jointrig.identify.chain_diagnose import _Problem, nominal_spec, prepare_chain_runs

    rng = np.random.default_rng(3)
    recs, n, P = [], 64, 4
    for w in (20.0, 26.0, 32.0, 40.0, 55.0):
        X = 100.0 / (2000.0 - 2.0 * w**2 + 1j * w * 5.0)
        t = np.arange(n * P) * 2 * np.pi / (w * n)
        x, T = np.real(X * np.exp(1j * w * t)), 100.0 * np.cos(w * t)
        recs.append(ChainRecord(w, t, [T + rng.normal(0, 1e-3 * np.std(T), T.size)],
                                [x + rng.normal(0, 1e-3 * np.std(x), x.size)], None, P))
    problem = _Problem(tuple(prepare_chain_runs(recs, band=20)), 20, 2.0 * (P - 1), 1e-3)
    spec = nominal_spec(1, twist=True) if terms is None else ChainSpec((), grounds=(tuple(terms),))
    return problem, problem.fit(spec)[0]


def test_a_single_bodys_card_law_is_its_law_to_ground_whose_damping_holds_the_drag():
    # The relative-angle form's card: the law of its one place is the body's law to ground (its
    # viscous term holds any drag, not a second one beside it), the mode's inertia the body's,
    # and the covariance the fit's, on (J1, the law's values), exactly.
    import numpy as np

    from jointrig.identify.chain_diagnose import place_covariance, place_law

    _, fit = _one_body_problem()
    law, je = place_law(fit, 0)
    names = [f"ground1_{n}" for n in law.names]
    assert law.names == ("c_Nms_per_rad", "k_Nm_per_rad", "gamma_Nm_per_rad3") and je == fit.as_dict()["J1_kgm2"]
    assert law.values == pytest.approx([fit.as_dict()[n] for n in names], rel=1e-15)
    assert law.values[1] == pytest.approx(2000.0, rel=0.01)  # its standard error 0.1% at 60 dB: 10 of them
    idx = [fit.names.index(n) for n in ["J1_kgm2"] + names]  # a selection of the fit's: equal to round-off
    np.testing.assert_allclose(place_covariance(fit, 0), fit.covariance[np.ix_(idx, idx)], rtol=1e-12)


def test_a_single_bodys_missing_spring_is_its_law_to_grounds_elastic_misfit():
    # A model of the body's law to ground without its linear spring: the misfit is placed at
    # body 1 to ground and is elastic (in phase with the angle at the fundamental).
    from jointrig.identify.chain_diagnose import train_misfit
    from jointrig.vocab.law import Power, Viscous

    problem, fit = _one_body_problem((Viscous(), Power(3)))
    m = train_misfit(problem.runs, [str(k) for k in range(5)], [100.0] * 5, fit, 20)
    assert m.where == "body 1 to ground" and len(m.by_place) == 1 and m.by_place[0][1] > 0.05
    assert m.character.dissipative_share < 0.1, m.character


def test_a_single_bodys_card_covariance_sums_what_its_law_value_sums():
    # place_covariance of one body maps the fit's covariance onto (J1, the law's values) as
    # place_law builds the law: a drag beside a law without damping is a viscous term of its
    # own (its variance the drag's); a drag beside a law with damping is summed into that term
    # (its variance that of the sum: var(c) + var(b) + 2 cov(c, b)). Fits made by hand.
    import numpy as np

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import ChainFit, place_covariance, place_law
    from jointrig.vocab.law import Power, Viscous

    def fit(grounds):
        spec = ChainSpec((), bearings=(1,), grounds=(grounds,))
        names = spec.names
        values = np.arange(1.0, len(names) + 1.0)
        rng = np.random.default_rng(4)
        a = rng.normal(size=(len(names), len(names)))
        return ChainFit(spec, names, values, np.ones(len(names)), 0.0, 10, np.zeros(10), covariance=a @ a.T)

    spring = fit((Power(1),))  # names: J1, bearing1, ground1_k
    law, _ = place_law(spring, 0)
    assert law.names == ("k_Nm_per_rad", "c_Nms_per_rad")
    idx = [spring.names.index(n) for n in ("J1_kgm2", "ground1_k_Nm_per_rad", "bearing1_damping_Nms_per_rad")]
    np.testing.assert_allclose(place_covariance(spring, 0), spring.covariance[np.ix_(idx, idx)], rtol=1e-12)
    damped = fit((Viscous(), Power(1)))
    law, _ = place_law(damped, 0)
    vals = damped.as_dict()
    assert law.names == ("c_Nms_per_rad", "k_Nm_per_rad")
    assert law.values[0] == vals["ground1_c_Nms_per_rad"] + vals["bearing1_damping_Nms_per_rad"]
    T = np.zeros((3, len(damped.names)))
    T[0, damped.names.index("J1_kgm2")] = 1.0
    T[1, damped.names.index("ground1_c_Nms_per_rad")] = T[1, damped.names.index("bearing1_damping_Nms_per_rad")] = 1.0
    T[2, damped.names.index("ground1_k_Nm_per_rad")] = 1.0
    np.testing.assert_allclose(place_covariance(damped, 0), T @ damped.covariance @ T.T, rtol=1e-12)


def test_the_balance_fidelity_keeps_each_replayed_runs_own_index():
    # identify.chain_diagnose.balance_fidelity: the balance's misfit on each fitted run's
    # noise-free replay, at the fit's own values. A run whose replay reached no steady state is
    # None: it is unmeasured, and every other run keeps its own index (the row variances look
    # the misfit up by it). On exact steady states of the 4-body linear train the misfit is the
    # fit's parameter error through the balance: a run's entries are the same whether or not
    # the run before it was replayed (to round-off), and nonzero (the noisy fit is not exact).
    import numpy as np

    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.chain_diagnose import balance_fidelity, prepare_chain_runs
    from test_chain import _linear_chain_records

    _, (fit, _) = _linear_problem()
    J, c, k = [0.45, 0.06, 0.12, 0.35], [15.0, 20.0, 10.0], [4e5, 2.5e4, 1.2e5]
    exact = []
    for r in _linear_chain_records(J, c, k, [0.0] * 4, {1: 60.0}, [150.0, 300.0, 600.0, 1200.0, 2000.0]):
        t = np.arange(r.time_s.size * 2) * (r.time_s[1] - r.time_s[0])
        exact.append(ChainRecord(r.omega_rad_s, t, [None if x is None else np.tile(x, 2) for x in r.torques_Nm],
                                 [np.tile(x, 2) for x in r.angles_rad], None, 2))
    replays = prepare_chain_runs(exact, band=20)
    every = balance_fidelity(replays, fit, 20)
    some = balance_fidelity([None, None] + replays[2:], fit, 20)
    assert every.unmeasured == () and some.unmeasured == (0, 1)
    assert {key[0] for key in some.variance} == {2, 3, 4} and {key[0] for key in every.variance} == set(range(5))
    for key, v in some.variance.items():
        assert v == pytest.approx(every.variance[key], rel=1e-9, abs=1e-30), key
    assert max(some.variance.values()) > 0
    with pytest.raises(ValueError, match="no run was replayed"):
        balance_fidelity([None] * 5, fit, 20)


@pytest.mark.parametrize("ratio, resolved", [(4.5, False), (5.5, True)])
def test_a_twist_is_resolved_when_it_stands_five_times_above_its_noise_in_the_band(ratio, resolved):
    # identify.chain_diagnose.twist_resolved: the RMS of a twist's band-limited period average
    # against the RMS its two encoders' noise leaves in the band's 2 band real coefficients,
    # sqrt(s1^2 + s2^2) sqrt(2 band / (N P)); RESOLVED_SNR = 5 (the pump train's coupling stuck the
    # whole period reads 0.9-1.3, a twist that moves 20 or more).
    import math

    import numpy as np

    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.chain_diagnose import ChainRun, twist_resolved

    N, P, band, s1, s2 = 256, 4, 20, 3e-4, 4e-4
    floor = math.hypot(s1, s2) * math.sqrt(2 * band / (N * P))
    t = np.arange(N) / N * 2 * math.pi
    amplitude = ratio * floor * math.sqrt(2)  # a sine's RMS is its amplitude over sqrt 2
    avg = ChainRecord(1.0, t, (np.ones(N), None), (amplitude * np.sin(t), 0 * t), None, 1)
    run = ChainRun(avg, (avg,) * P, {"phi1": s1, "phi2": s2, "torque1": 0.0}, N, band)
    assert twist_resolved(run, 0) is resolved


def test_every_kind_of_place_has_its_words_and_its_rules():
    # issue 53: what a cause does at a place is the place's (identify.chain_diagnose.AT_PLACE), how
    # it reads is identify.causes.PLACE_WORDS; a kind with one and not the other, or a kind that
    # is neither, is refused
    import pytest

    from jointrig.identify.causes import PLACE_WORDS, Place
    from jointrig.identify.chain_diagnose import AT_PLACE

    assert AT_PLACE.keys() == PLACE_WORDS.keys()
    with pytest.raises(ValueError, match="a place is one of .*got 'shaft'"):
        Place("shaft", 1)
    assert [Place(k, 2).describe() for k in ("joint", "flywheel", "ground", "channel")] == [
        "at joint 2", "at flywheel 2", "to ground at body 2", "at body 2's angle channel"]
    assert Place("drive", None).describe() == "at the drives"


def test_a_cause_extends_its_own_place_and_leaves_every_other_one_as_it_was():
    # A joint's cause reads and writes its own joint's twist zero, a channel's its own channel's
    # skew and scale: on a train whose joints and channels all differ, every other entry stays
    # (survivors of mutation seed 20261202 on the places' lines read a neighbour's entry)
    from dataclasses import replace

    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, nominal_spec

    spec = replace(nominal_spec(4), offsets_rad=(0.01, 0.02, 0.03), channel_delays_s=(0.0, 1e-4, 2e-4, 3e-4),
                   channel_gains=(0.0, 0.01, 0.02, 0.03))
    gap = Candidate(by_name("backlash"), Place("joint", 2)).extend(spec, 0.005)
    assert gap.offsets_rad == spec.offsets_rad and gap.joints[0] == spec.joints[0] == gap.joints[2]
    assert gap.joints[1] != spec.joints[1]
    zero = Candidate(by_name("angle_offset"), Place("joint", 3)).extend(spec, 0.05)
    assert zero.offsets_rad == (0.01, 0.02, 0.05)
    skew = Candidate(by_name("angle_skew"), Place("channel", 3)).extend(spec, 5e-4)
    assert skew.channel_delays_s == (0.0, 1e-4, 5e-4, 3e-4) and skew.channel_gains == spec.channel_gains
    scale = Candidate(by_name("angle_gain"), Place("channel", 3)).extend(spec, 0.04)
    assert scale.channel_gains == (0.0, 0.01, 0.04, 0.03) and scale.channel_delays_s == spec.channel_delays_s


def test_an_adopted_causes_parameter_on_an_end_of_its_search_is_listed_with_that_end():
    # ChainDiagnosis.on_bounds: each adopted cause's profiled parameter against the search range
    # its profile had (a Stribeck rate: from the fastest run's rate amplitude). At the lower end
    # it is listed with that end; inside the range, or for a cause without a profile, not.
    import math
    from dataclasses import replace

    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _on_bounds, _twist_runs

    problem, fit = _one_body_problem()
    peak, dry = (Candidate(by_name(n), Place("ground", 1)) for n in ("stribeck_friction", "coulomb_friction"))
    lo, hi = peak.cause.bounds(_twist_runs(problem, peak))
    name = peak.profiled_name()
    assert name == "ground1_stribeck_velocity_rad_s" and 0 < lo < hi
    assert _on_bounds(problem, [dry, peak], replace(fit, profiled=((name, lo, 0.1 * lo),))) == ((name, "lower", lo),)
    middle = math.sqrt(lo * hi)
    assert _on_bounds(problem, [dry, peak], replace(fit, profiled=((name, middle, 0.1 * lo),))) == ()
    assert _on_bounds(problem, [dry, peak], replace(fit, profiled=((name, hi, 0.1 * lo),))) == ((name, "upper", hi),)


def test_a_profiled_error_carries_the_rows_correlations_as_a_linear_ones_does():
    # A free play's half gap is profiled: its error is chi-square's curvature, every row weighted
    # on its own. One encoder's noise enters both equations beside it, which the linear
    # parameters' sandwich counts (_Problem.cross_covariance); _widened multiplies the profile's
    # error by the same sandwich on the balance's Jacobian extended by the gap's own column
    # (_correlated_rows). On the train the factor is not 1 (the rows beside joint 2 are
    # correlated), and the reported error is the profile's times it, to round-off. The same
    # factor multiplies the error that widens the linear parameters.
    import math
    from dataclasses import replace

    import numpy as np

    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _correlated_rows, _twist_runs, _widened

    problem, (nominal, w) = _linear_problem(periods=6)
    twist = min(float(np.ptp(r.average.angles_rad[1] - r.average.angles_rad[2])) / 2 for r in problem.runs)
    cand = Candidate(by_name("backlash"), Place("joint", 2))
    gap, se = 0.3 * twist, 0.01 * twist
    fit, w = problem.fit(cand.extend(nominal.spec, gap))
    fit = replace(fit, profiled=((cand.profiled_name(), gap, se),))
    lo, hi = cand.cause.bounds(_twist_runs(problem, cand))
    step = max(1e-3 * gap, 1e-6 * (hi - lo))
    factor = _correlated_rows(problem, cand, fit, gap, step, w)
    assert math.isfinite(factor) and abs(factor - 1.0) > 1e-3, factor  # 1.00105 here (seed 0 of the noise, fixed)
    # A gap wider than every run's twist moves nothing: its column is zero, and so is no factor
    reach = max(float(np.max(np.abs(r.average.angles_rad[1] - r.average.angles_rad[2]))) for r in problem.runs)
    assert _correlated_rows(problem, cand, fit, 2.0 * reach, step, w) == 1.0
    widened = _widened(problem, [cand], fit, w)
    assert widened.profiled == ((cand.profiled_name(), gap, pytest.approx(se * factor, rel=1e-12)),)
    # and the stiffness the gap moves is widened by it (its error grows: a slope taken between
    # h - step and h + step, not zero)
    k = fit.names.index("joint2_k_Nm_per_rad")
    assert widened.std_errors[k] > fit.std_errors[k] * (1 + 1e-6)
    # The factor is the gap's own entry of the sandwich, wherever its column stands: the same with
    # the gap's column first in the Jacobian instead of last.
    import numpy as np

    jumps = problem.jumps(fit.spec, fit.as_dict())
    banded = problem.system(fit.spec, jumps)
    below, above = (problem.system(cand.extend(fit.spec, x), jumps).system.A for x in (gap - step, gap + step))
    J = np.column_stack([(above - below) @ np.asarray(fit.values) / (2 * step), banded.system.A])
    Q = problem.cross_covariance(banded, fit.spec, fit.as_dict(), w, columns=J)
    n = np.sqrt(np.einsum("mi,m,mi->i", J, w, J))  # (unit columns: the raw J'WJ is ill-conditioned)
    B = np.linalg.inv((J / n).T @ ((J / n) * w[:, None]))
    assert factor == pytest.approx(math.sqrt(1 + (B @ (Q / np.outer(n, n)) @ B)[0, 0] / B[0, 0]), rel=1e-9)  # round-off


def test_a_linear_error_is_at_least_what_the_periods_own_scatter_gives_it():
    # _Problem._period_scatter: each period's residual through the estimate's map, its sample
    # covariance over the periods over P; a parameter's variance is raised to it where larger,
    # the correlations kept, times chi2/dof above 1; periods that agree change nothing.
    import numpy as np

    from jointrig.identify.chain_diagnose import _Problem

    cov = np.array([[1.0, 0.5], [0.5, 4.0]])  # correlation 0.25
    An, n, w, M = np.eye(2), np.ones(2), np.ones(2), np.eye(2)  # residual rows are the scores
    a = np.array([3.0, -3.0, 3.0, -3.0, 0.0])  # sample variance 9, over P = 5: 1.8 > 1
    periods = [(np.arange(2), np.zeros((5, 2, 2)), np.column_stack([a, np.zeros(5)]), None, None)]
    out = _Problem._period_scatter(cov, np.zeros(2), M, An, n, w, periods, 1.0)[0]
    assert out[0, 0] == pytest.approx(1.8) and out[1, 1] == pytest.approx(4.0)
    assert out[0, 1] / math.sqrt(out[0, 0] * out[1, 1]) == pytest.approx(0.25)
    assert _Problem._period_scatter(cov, np.zeros(2), M, An, n, w, periods, 2.0)[0][0, 0] == pytest.approx(3.6)
    # a fit better than its noise (chi2/dof below 1) does not shrink it
    assert _Problem._period_scatter(cov, np.zeros(2), M, An, n, w, periods, 0.5)[0][0, 0] == pytest.approx(1.8)
    # scores in a column's own units: a column scaled by n = 10 reads a tenth of the scatter
    scaled = _Problem._period_scatter(cov, np.zeros(2), M, An, np.array([10.0, 1.0]), w, periods, 1.0)[0]
    assert scaled[0, 0] == pytest.approx(1.0)
    same = [(np.arange(2), np.zeros((5, 2, 2)), np.tile([0.7, 0.2], (5, 1)), None, None)]
    assert np.array_equal(_Problem._period_scatter(cov, np.zeros(2), M, An, n, w, same, 1.0)[0], cov)


def test_the_periods_scatter_is_each_periods_weighted_residual_about_their_mean():
    # The residual is F - A theta, weighted by each row's weight, taken about the periods' mean; a
    # run of one period adds nothing; a parameter whose variance is 0 leaves the covariance as it
    # is. By hand: row 0's residuals 1 + a_p - 0.5 A_p with A_p = 2 +- 0.2 (a column's own noise),
    # weighted 2 (M = 1): scores 8, -4.2, 8.2, -4, 2, their sample variance 37.22.
    import numpy as np

    from jointrig.identify.chain_diagnose import _Problem

    theta = np.array([0.5, 0.0])
    a = np.array([4.0, -2.0, 4.0, -2.0, 1.0])  # mean 1, sample variance 9
    As = np.zeros((5, 2, 2))
    As[:, 0, 0] = [2.0, 2.2, 1.8, 2.0, 2.0]
    Fs = np.column_stack([1.0 + a, np.zeros(5)])
    periods = [(np.arange(2), As, Fs, None, None),
               (np.arange(2), np.zeros((1, 2, 2)), np.array([[50.0, 0.0]]), None, None)]  # one period: nothing
    cov = np.diag([0.5, 4.0])
    out = _Problem._period_scatter(cov, theta, np.eye(2), np.eye(2), np.ones(2), np.array([2.0, 1.0]), periods, 1.0)[0]
    assert out[0, 0] == pytest.approx(148.88 / 4 / 5) and out[1, 1] == pytest.approx(4.0)
    # two periods are enough for a scatter
    two = [(np.arange(2), As[:2], Fs[:2], None, None)]
    assert _Problem._period_scatter(cov, theta, np.eye(2), np.eye(2), np.ones(2), np.array([2.0, 1.0]), two,
                                    1.0)[0][0, 0] == pytest.approx(6.1 ** 2 * 2 / 2)
    flat = np.diag([0.0, 4.0])
    assert np.array_equal(_Problem._period_scatter(flat, theta, np.eye(2), np.eye(2), np.ones(2), np.array([2.0, 1.0]),
                                                   periods, 1.0)[0], flat)


def test_an_errors_degrees_of_freedom_are_those_of_what_it_is_read_from():
    # _Problem._period_scatter's second value: where the periods' scatter stands, the
    # Welch-Satterthwaite count of its runs' parts (P - 1 each); elsewhere that of the weights'
    # groups of rows (nu each, at least nu). By hand: two runs of 5 periods whose scores' sample
    # variances are 9 and 1 (over P: 1.8, 0.2) give (2.0)^2 / (1.8^2/4 + 0.2^2/4) = 4.88 degrees
    # of freedom, not 8: the error is mostly the first run's.
    import numpy as np

    from jointrig.identify.chain_diagnose import _Problem

    An, n, w, M = np.eye(2), np.ones(2), np.ones(2), np.eye(2)
    a = np.array([3.0, -3.0, 3.0, -3.0, 0.0])
    runs = [(np.array([0, 1]), np.zeros((5, 2, 2)), np.column_stack([a, np.zeros(5)]), None, None),
            (np.array([2, 3]), np.zeros((5, 2, 2)), np.column_stack([a / 3, np.zeros(5)]), None, None)]
    A4 = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    cov = np.diag([0.1, 4.0])  # parameter 0: the scatter (2.0) stands; parameter 1: the model's
    groups = np.array([0, 1, 2, 3])
    out, dofs = _Problem._period_scatter(cov, np.zeros(2), M, A4, n, np.ones(4), runs, 1.0, groups, 8.0)
    assert out[0, 0] == pytest.approx(2.0)
    assert dofs[0] == pytest.approx(4.0 / (1.8 ** 2 / 4 + 0.2 ** 2 / 4))
    # parameter 1's variance is its two groups' alike: 2 nu
    assert dofs[1] == pytest.approx(16.0)
    # without groups, no degrees of freedom (the errors are then taken as known)
    assert _Problem._period_scatter(cov, np.zeros(2), M, A4, n, np.ones(4), runs, 1.0)[1] is None


def test_a_t_interval_from_a_few_periods_scatter_covers_where_1_96_errors_do_not():
    # One parameter read from the mean of P = 4 periods, its error from their scatter alone (3
    # degrees of freedom): over 4000 draws value +- t SE holds the truth 95% of the time (binomial
    # SE 0.35%: within 93.5-96.5%), value +- 1.96 SE about 86% (below 90%).
    import numpy as np

    from jointrig.identify.chain_diagnose import _Problem
    from jointrig.identify.estimates import interval_factor

    rng = np.random.default_rng(3)
    P, m, theta = 4, 6, 1.5
    A = rng.normal(size=(m, 1))
    n = np.sqrt(np.sum(A ** 2, axis=0))
    An = A / n
    M = An.T @ An
    t_hits = z_hits = 0
    draws = 4000
    for _ in range(draws):
        Fs = A[:, 0] * theta + rng.normal(size=(P, m))
        est = float(np.linalg.lstsq(A, Fs.mean(axis=0), rcond=None)[0][0])
        periods = [(np.arange(m), np.tile(A, (P, 1, 1)), Fs, None, None)]
        cov, dofs = _Problem._period_scatter(np.array([[1e-12]]), np.array([est]), M, An, n, np.ones(m), periods, 1.0,
                                             np.zeros(m, dtype=int), 2.0 * (P - 1))
        se = math.sqrt(cov[0, 0])
        t_hits += abs(est - theta) <= interval_factor(dofs[0]) * se
        z_hits += abs(est - theta) <= 1.96 * se
    assert dofs[0] == pytest.approx(P - 1)
    assert 0.935 <= t_hits / draws <= 0.965
    assert z_hits / draws < 0.90


def test_a_carriage_that_rests_part_of_its_period_has_rows_correlated_across_harmonics():
    # The carriage of the independent bench with 90 N of dry friction under 150 N rests a quarter
    # of each period: its equation is balanced with the rests masked out, and the mask mixes the
    # harmonics, so one encoder's noise correlates rows of different harmonics. The fit's
    # covariance carries them (_Problem.cross_covariance's masked branch, with no joint to
    # merge): not None, symmetric, and the errors move beside the fit without them (by 3-12%
    # here; 1% is far above round-off). The friction is within 3 standard errors of the bench's.
    import numpy as np

    from bench_slide_sim import Carriage
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _Problem, nominal_spec

    problem = _Problem(_carriage_runs(Carriage(Fc=90.0)), 20, 6.0, 1e-3, (True,))
    assert problem.masks() is not None and problem.slipping() is None
    spec = Candidate(by_name("coulomb_friction"), Place("ground", 1)).extend(nominal_spec(1), 0.0)
    fit, wts = problem.fit(spec)
    fc, se = fit.as_dict()["ground1_coulomb_torque_Nm"], fit.std_error("ground1_coulomb_torque_Nm")
    assert abs(fc - 90.0) < 3 * se, (fc, se)
    Q = problem.cross_covariance(problem.system(spec, problem.jumps(spec, fit.as_dict())), spec, fit.as_dict(), wts)
    assert Q is not None
    np.testing.assert_allclose(Q, Q.T, rtol=1e-12, atol=1e-12 * np.max(np.abs(Q)))
    plain = problem.solve(spec, wts, covariance=False)
    assert np.max(np.abs(fit.std_errors / plain.std_errors - 1)) > 0.01


def test_a_stribeck_law_gives_way_to_dry_friction_where_its_peak_is_not_told_from_zero():
    # Parsimony in the final model (_reduced): the carriage of the independent bench at 60 and
    # 150 N, 0.1% noise. With level dry friction (25 N) a Stribeck law adopted in its place
    # gives way to it: the steps and the adopted causes name dry friction, its speed is no
    # longer profiled, and the friction is the bench's within 3 standard errors. With a peak
    # (static 45 N, falling off at 0.02 m/s) the Stribeck law stays, its excess many standard
    # errors from zero (its size is issue 50's; only that it is told from zero is checked).
    from dataclasses import replace

    from bench_slide_sim import Carriage
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _Problem, _reduced, nominal_spec, score, with_constants

    def reduced(car):
        problem = _Problem(_carriage_runs(car, (60.0, 150.0), noise=1e-3), 20, 6.0, 1e-3, (True,))
        structure = with_constants(nominal_spec(1), problem.masks())
        nominal, w8 = problem.fit(structure)
        dry, peak = (Candidate(by_name(c), Place("ground", 1)) for c in ("coulomb_friction", "stribeck_friction"))
        s_dry, s_peak = (score(problem, c, nominal, w8, 2, 0.01) for c in (dry, peak))
        assert s_dry.significant and s_peak.significant
        current, wcur = problem.fit(s_peak.fit.spec)
        adopted = [peak]
        steps, (fit, _) = _reduced(problem, structure, adopted, [s_peak], [[s_dry, s_peak]],
                                   (replace(current, profiled=s_peak.fit.profiled), wcur), 0.01,
                                   {dry.label: dry, peak.label: peak})
        return [s.label for s in steps], [c.label for c in adopted], fit

    steps, adopted, fit = reduced(Carriage())
    assert steps == adopted == ["coulomb_friction to ground at body 1"]
    assert fit.profiled == () and not any("stribeck" in n for n in fit.names)
    fc, se = fit.as_dict()["ground1_coulomb_torque_Nm"], fit.std_error("ground1_coulomb_torque_Nm")
    assert abs(fc - 25.0) < 3 * se, (fc, se)
    steps, adopted, fit = reduced(Carriage(Fs=45.0, vs=0.02))
    assert steps == adopted == ["stribeck_friction to ground at body 1"]
    assert [p[0] for p in fit.profiled] == ["ground1_stribeck_velocity_rad_s"]
    assert fit.as_dict()["ground1_stribeck_torque_Nm"] > 5 * fit.std_error("ground1_stribeck_torque_Nm")


def test_a_cause_adopted_first_that_a_later_one_makes_redundant_leaves_the_final_model():
    # Backward parsimony (_reduced, _weakest): on the carriage of the independent bench (25 N of
    # dry friction, no quadratic drag; 60 and 150 N, 0.1% noise) a quadratic drag taken first
    # stands for the dry friction not yet in (it lowers chi-square by 6.8e4 against the nominal
    # model, with a negative drag that a rule rejects; here it is adopted regardless, as a cause
    # found first for another's effect would be). Once the dry friction is in, its removal no
    # longer raises chi-square significantly and it goes. The dry friction stays (its own
    # removal is tested too) and reads the bench's 25 N within 3 standard errors.
    from dataclasses import replace

    from bench_slide_sim import Carriage
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _Problem, _reduced, nominal_spec, score, with_constants

    problem = _Problem(_carriage_runs(Carriage(), (60.0, 150.0), noise=1e-3), 20, 6.0, 1e-3, (True,))
    structure = with_constants(nominal_spec(1), problem.masks())
    nominal, w0 = problem.fit(structure)
    quad, dry = (Candidate(by_name(c), Place("ground", 1)) for c in ("quadratic_damping", "coulomb_friction"))
    round1 = [score(problem, c, nominal, w0, 2, 0.01) for c in (quad, dry)]
    assert round1[0].delta_chi2 > 1e4
    first, w1 = problem.fit(round1[0].fit.spec)
    round2 = [score(problem, dry, first, w1, 1, 0.01)]
    assert round2[0].significant
    both, w2 = problem.fit(round2[0].fit.spec)
    adopted = [quad, dry]
    steps, (fit, _) = _reduced(problem, structure, adopted, [round1[0], round2[0]], [round1, round2],
                               (replace(both, profiled=()), w2), 0.01, {quad.label: quad, dry.label: dry})
    assert [s.label for s in steps] == [c.label for c in adopted] == ["coulomb_friction to ground at body 1"]
    assert not any("quadratic" in n for n in fit.names)
    fc, se = fit.as_dict()["ground1_coulomb_torque_Nm"], fit.std_error("ground1_coulomb_torque_Nm")
    assert abs(fc - 25.0) < 3 * se, (fc, se)


def test_the_band_may_reach_the_highest_harmonic_a_period_resolves_and_no_further():
    # 41 samples a period resolve harmonics 1..20 (strictly below Nyquist): a band of 20 is
    # prepared, 21 is refused naming the band.
    import numpy as np

    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.chain_diagnose import prepare_chain_runs
    from jointrig.vocab.records import RecordError

    w, P, n = 10.0, 3, 41
    t = np.arange(P * n) * (2 * math.pi / w) / n
    rng = np.random.default_rng(0)
    noisy = [a * f(w * t) + s * rng.standard_normal(t.size) for a, f, s in
             ((1.0, np.cos, 1e-3), (1.0, np.sin, 1e-4), (0.5, np.sin, 1e-4))]
    rec = ChainRecord(w, t, (noisy[0], None), (noisy[1], noisy[2]), None, P)
    assert prepare_chain_runs([rec], band=20)[0].band == 20
    with pytest.raises(RecordError, match="band is 21"):
        prepare_chain_runs([rec], band=21)


@pytest.mark.parametrize("friction_N, rests", [(25.0, False), (90.0, True)])
def test_a_dry_friction_columns_periods_are_the_averages_with_each_switch_moved(friction_N, rests):
    # _Problem.switched: in each period's balance the dry friction's column is the average's, its
    # switches moved by the period's own shift (identify.kink.switch_shifts); every other column
    # is the period's own. The shifts are deviations from the average's, so over the periods they
    # nearly cancel (not exactly: a switch that moves earlier runs along the slope before it, one
    # that moves later along the slope after, measured here as 1-sample differences that differ by
    # the rate's curvature). Sliding through rest (25 N) each period's column departs from the
    # average's, their mean ten times less; resting (90 N) the body's equation is masked at its
    # switches, and the mask read there leaves the average's column as it is.
    import numpy as np

    from bench_slide_sim import Carriage
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _Problem, nominal_spec

    problem = _Problem(_carriage_runs(Carriage(Fc=friction_N)), 20, 6.0, 1e-3, (True,))
    assert (problem.masks() is not None) == rests
    spec = Candidate(by_name("coulomb_friction"), Place("ground", 1)).extend(nominal_spec(1), 0.0)
    banded = problem.system(spec)
    own = list(problem.period_systems(spec, banded))
    moved = problem.switched(spec, banded, None, own)
    c = list(banded.system.names).index("ground1_coulomb_torque_Nm")
    (rows, A0, F0, h0, e0), (rows1, A1, F1, h1, e1) = own[0], moved[0]
    assert np.array_equal(rows, rows1) and np.array_equal(F0, F1) and np.array_equal(e0, e1)
    others = [k for k in range(A0.shape[2]) if k != c]
    assert np.array_equal(A1[:, :, others], A0[:, :, others])
    average = banded.system.A[rows, c]
    scale = np.max(np.abs(average))
    departs = np.max(np.abs(A1[:, :, c] - average), axis=1)
    if rests:
        assert np.all(departs <= 1e-12 * scale)
    else:
        assert np.min(departs) > 1e-4 * scale
        assert np.max(np.abs(A1[:, :, c].mean(axis=0) - average)) < 0.1 * np.min(departs)
    # a model without dry friction has nothing to move
    plain = nominal_spec(1)
    b = problem.system(plain)
    periods = list(problem.period_systems(plain, b))
    assert problem.switched(plain, b, None, periods) is periods


def test_a_joints_mean_torque_carries_its_laws_error_and_its_zeros_own():
    # mean_joint_torque: k (mean twist - zero) over the records, its error the law's covariance
    # along that column, plus (dq/dzero * SE of the zero)^2 where the zero was profiled (a fit
    # that profiled none adds nothing). Twist 0.3 + 0.05 sin, zero 0.05, k = 1000 +- 2:
    # q = 250 N m, SE 0.25 * 2 = 0.5; with the zero's SE 0.01, sqrt(0.5^2 + (1000 * 0.01)^2).
    import dataclasses

    import numpy as np

    from jointrig.identify.chain import ChainRecord, ChainSpec
    from jointrig.identify.chain_diagnose import TWIST_ZERO, ChainFit, mean_joint_torque
    from jointrig.vocab.law import Power

    n, w = 64, 2 * math.pi
    t = np.arange(n) / n
    x1 = 0.3 + 0.1 * np.sin(w * t)
    rec = ChainRecord(w, t, (np.cos(w * t), None), (x1, x1 - 0.3 - 0.05 * np.sin(w * t)), None, 1)
    spec = ChainSpec(((Power(1),),), offsets_rad=(0.05,))
    names = spec.names  # J1, joint1_k, J2
    fit = ChainFit(spec, names, np.array([1.0, 1000.0, 1.0]), np.array([0.1, 2.0, 0.1]), 10.0, 100, np.zeros(100),
                   covariance=np.diag([0.01, 4.0, 0.01]))
    q, se = mean_joint_torque(fit, [rec], 1)
    assert q == pytest.approx(250.0, rel=1e-12) and se == pytest.approx(0.5, rel=1e-9)
    zeroed = dataclasses.replace(fit, profiled=(("joint1_" + TWIST_ZERO.profiled, 0.05, 0.01),))
    assert mean_joint_torque(zeroed, [rec], 1)[1] == pytest.approx(math.sqrt(0.25 + 100.0), rel=1e-6)
    assert math.isnan(mean_joint_torque(zeroed, [rec], 1, with_error=False)[1])


@pytest.mark.parametrize("periods", [2, 4])
def test_a_joints_dry_friction_moves_its_switches_in_both_its_bodies_equations(periods):
    # _Problem.switched at a joint: the shift of its twist rate's switches (identify.kink.
    # switch_shifts, a column that jumps by 2 at zero rate) enters body 2's equation with + and
    # body 3's with - (joint 2 of the 4-body linear train), and no other equation. Exact: each
    # period's departure from the average's column is the harmonic rows of the shifts'
    # coefficients (round-off 1e-12 of the column), from two periods a run on.
    import numpy as np

    from jointrig.identify.balance import harmonic_rows
    from jointrig.identify.causes import Place, by_name
    from jointrig.identify.chain_diagnose import Candidate
    from jointrig.identify.kink import switch_shifts

    problem, (nominal, _) = _linear_problem(periods=periods, noise=1e-2)
    spec = Candidate(by_name("coulomb_friction"), Place("joint", 2)).extend(nominal.spec, 0.0)
    banded = problem.system(spec)
    own = list(problem.period_systems(spec, banded))
    moved = problem.switched(spec, banded, None, own)
    c = list(banded.system.names).index("joint2_coulomb_torque_Nm")
    for k, ((rows, A0, _, _, e), (_, A1, _, _, _)) in enumerate(zip(own, moved)):
        run = problem.runs[k]
        departs = A1[:, :, c] - banded.system.A[rows, c]
        scale = np.max(np.abs(banded.system.A[rows, c]))
        avg, per = run.average, run.periods
        twist = [r.rate(1) - r.rate(2) for r in per]
        shifts = switch_shifts(avg.rate(1) - avg.rate(2), np.array(twist), 2 * np.pi / avg.omega_rad_s)
        dA, _, harm, _ = harmonic_rows(shifts.coefficients(problem.n_harmonics, 2.0), np.zeros(problem.n_harmonics + 1),
                                       problem.n_harmonics)
        expect = dA[harm >= 1].T
        np.testing.assert_allclose(departs[:, e == 1], expect, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(departs[:, e == 2], -expect, rtol=0, atol=1e-12 * scale)
        assert not np.any(departs[:, (e == 0) | (e == 3)])
        assert np.abs(expect).max() > 1e-3 * scale


def test_an_intervals_factor_is_students_t_at_the_errors_degrees_of_freedom():
    # interval_factor: the two-sided 95% quantile of Student's t (tables: 12.706 at 1, 2.571 at 5,
    # 2.086 at 20 degrees of freedom; to the tables' 4 digits), the normal 1.95996 for a known
    # error (inf) and for a count so large the two agree; a count below 1 (a Satterthwaite figure
    # of a tiny part) is read as 1, the widest interval, never a narrower one.
    from jointrig.identify.estimates import interval_factor

    assert interval_factor(1.0) == pytest.approx(12.706, abs=5e-4)
    assert interval_factor(5.0) == pytest.approx(2.5706, abs=5e-5)
    assert interval_factor(20.0) == pytest.approx(2.0860, abs=5e-5)
    assert interval_factor(math.inf) == pytest.approx(1.959964, abs=1e-6)
    assert interval_factor(1e9) == interval_factor(math.inf)
    assert interval_factor(0.3) == interval_factor(1.0)
    assert interval_factor(5.0, level=0.90) == pytest.approx(2.0150, abs=5e-5)


def test_a_chosen_model_is_refitted_under_its_own_values_weights_only_where_that_settles(monkeypatch):
    # _Problem.settled: the linear train at 10% noise (20 dB), where the values still move between
    # the search's two reweightings. The refit is kept where the weights at its values read its
    # chi-square within SETTLED_RTOL (checked here against a direct recomputation), its profiled
    # parameters held; with a tolerance of 0 nothing settles and the fit comes back as it was.
    from dataclasses import replace

    import numpy as np

    from jointrig.identify import chain_diagnose as cd
    from jointrig.identify.estimates import weighted_chi2

    problem, (nominal, w) = _linear_problem(noise=0.1)
    nominal = replace(nominal, profiled=(("joint1_angle_offset_rad", 0.0, 1.0),))
    got, wg = problem.settled(nominal, w)
    assert got is not nominal and got.profiled == nominal.profiled
    banded = problem.system(got.spec)
    own = 1.0 / problem.row_variance(got.spec, got.values, banded, problem.jumps(got.spec, got.as_dict()))
    assert abs(weighted_chi2(got.residual, own, problem.nu, got.dof)[1] - got.chi2) <= cd.SETTLED_RTOL * got.chi2
    assert not np.array_equal(wg, w)
    monkeypatch.setattr(cd, "SETTLED_RTOL", 0.0)
    same, ws = problem.settled(nominal, w)
    assert same is nominal and ws is w
    # a refit that is not finite (a singular system) is no refit: the fit comes back as it was
    monkeypatch.setattr(cd, "SETTLED_RTOL", 0.05)
    solve = cd._Problem.solve
    monkeypatch.setattr(cd._Problem, "solve", lambda self, spec, weights, covariance=True: replace(
        solve(self, spec, weights, covariance), values=np.full(len(nominal.values), np.nan)))
    same, ws = problem.settled(nominal, w)
    assert same is nominal and ws is w


def test_a_joint_cards_uncertainty_carries_the_profiled_parameters_that_shape_its_law():
    # place_uncertainty on a fit made by hand: two bodies, a joint of viscous damping, a spring
    # and a Jenkins element whose slip angle (0.02 rad) was profiled beside the twist's zero.
    # The covariance is place_covariance's, bordered by the slip angle's covariance with the
    # place's values (the fit's cross-covariance mapped as the values are: the mode's inertia
    # from J1 and J2) and its own variance; its shape is the law's terms a step either side. The
    # twist's zero moves no term of the law and is left out. Exact: selections and one product.
    import numpy as np

    from jointrig.identify.chain import ChainSpec
    from jointrig.identify.chain_diagnose import ChainFit, ProfiledSpread, place_covariance, place_uncertainty
    from jointrig.vocab.law import Jenkins, Power, Viscous

    terms = (Viscous(), Power(1), Jenkins(0.02))
    spec = ChainSpec((terms,), offsets_rad=(0.001,))
    names = spec.names
    values = np.array([2.0 if n.startswith("J") else 10.0 for n in names])
    rng = np.random.default_rng(7)
    a = rng.normal(size=(len(names), len(names)))
    cross = rng.normal(size=(len(names), 2))
    S = np.array([[4e-6, 1e-7], [1e-7, 9e-8]])
    h = 2e-5
    below = (replace(spec, joints=((Viscous(), Power(1), Jenkins(0.02 - h)),)), replace(spec, offsets_rad=(0.001 - 1e-6,)))
    above = (replace(spec, joints=((Viscous(), Power(1), Jenkins(0.02 + h)),)), replace(spec, offsets_rad=(0.001 + 1e-6,)))
    bare = ChainFit(spec, names, values, np.ones(len(names)), 0.0, 10, np.zeros(10), covariance=a @ a.T)
    fit = replace(bare, profiled_spread=ProfiledSpread(("joint1_hysteresis_slip_angle_rad", "joint1_angle_offset_rad"),
                                                        (h, 1e-6), below, above, cross, S))

    cov0 = place_covariance(fit, 0)
    assert place_uncertainty(bare, 0) == (pytest.approx(cov0, rel=1e-15), ())
    cov, shapes = place_uncertainty(fit, 0)
    assert shapes == (((Viscous(), Power(1), Jenkins(0.02 - h)), (Viscous(), Power(1), Jenkins(0.02 + h)), h),)
    p = cov0.shape[0]
    assert cov.shape == (p + 1, p + 1)
    np.testing.assert_array_equal(cov[:p, :p], cov0)
    T = np.zeros((p, len(names)))  # (Je, c, k, F): Je = J1 J2 / (J1 + J2) to first order
    T[0, names.index("J1_kgm2")] = T[0, names.index("J2_kgm2")] = 0.25
    for r, n in enumerate(("c_Nms_per_rad", "k_Nm_per_rad", "hysteresis_slip_torque_Nm"), start=1):
        T[r, names.index("joint1_" + n)] = 1.0
    np.testing.assert_allclose(cov[:p, p], T @ cross[:, 0], rtol=1e-12)
    np.testing.assert_allclose(cov[p, :p], T @ cross[:, 0], rtol=1e-12)
    assert cov[p, p] == S[0, 0]


def test_a_free_play_below_resolution_stands_only_where_chi_square_tells_it_from_no_play():
    # A half gap below one sample's resolution (identify.chain_diagnose._rejection): on the linear
    # train, which has no play, a gap of half the resolution fits no better than none, so the
    # rise to the search's lower end (no play) is not significant and the play is refused as below
    # resolution; the same fit with chi-square 11 below its zero's (above 10.83, one parameter's
    # likelihood ratio at 1e-3) stands, and one 10.7 below is refused.
    from dataclasses import replace

    from jointrig.identify.causes import BelowResolution, Place, by_name
    from jointrig.identify.chain_diagnose import Candidate, _rejection, _search_range, angle_resolution

    problem, (nominal, w) = _linear_problem()
    cand = Candidate(by_name("backlash"), Place("joint", 2))
    resolution = angle_resolution(problem, cand)
    h = 0.5 * resolution
    ext = problem.solve(cand.extend(nominal.spec, h), w)
    mag = ("joint2_half_gap_rad", h, 0.1 * h)
    said = _rejection(problem, cand, ext, mag, nominal.spec, w)
    assert said == BelowResolution("half gap", h, resolution, "", "coulomb_friction at joint 2"), said
    at_zero = problem.solve(cand.extend(nominal.spec, _search_range(problem, cand)[1]), w, covariance=False).chi2
    assert _rejection(problem, cand, replace(ext, chi2=at_zero - 11.0), mag, nominal.spec, w) is None
    assert isinstance(_rejection(problem, cand, replace(ext, chi2=at_zero - 10.7), mag, nominal.spec, w),
                      BelowResolution)
    # without the base the rise is not computed, and the size below resolution is refused
    assert isinstance(_rejection(problem, cand, replace(ext, chi2=at_zero - 11.0), mag), BelowResolution)
