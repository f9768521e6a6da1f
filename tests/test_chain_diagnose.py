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

import pytest

from chain_cases import EFFECTS, TRAIN, run_case


@pytest.mark.slow
@pytest.mark.parametrize("cause,place", [("backlash", 2), ("coulomb_friction", 3), ("bearing_friction", 4),
                                         ("stribeck_friction", 2)])
def test_the_right_joint_and_cause_ranked_first_with_a_gain_of_5(cause, place):
    # Bounds of the issue: right place and cause first, gain >= 5 on held-out runs of another
    # level. The magnitude is checked to 15% of the bench's (the bench's law is not the
    # project's: a continuum Iwan, event-driven friction), which is 10x its standard error.
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
