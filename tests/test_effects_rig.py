"""The rig carries every effect: each checked against an independent path."""

import copy
import math

import numpy as np
import pytest

from jointrig.vocab.law import Coulomb, Jenkins, JointLaw, Power, Viscous
from jointrig.vocab.plant import PeriodicDrive, Plant
from jointrig.rig import SimulationConfig, load_rig, simulate_steady_state
from jointrig.rig.model import DEFAULT_MODEL, RigModelError

from conftest import MODELS_DIR

NOMINAL = JointLaw((Viscous(), Power(1), Power(3)), (100.0, 2000.0, 200.0))
CFG = SimulationConfig(n_periods=1)


def test_bearing_drag_equals_mujocos_own_joint_damping(rig):
    # Independent path: MuJoCo's native joint damping on hinge phi2 is exactly a viscous drag of
    # flywheel 2 to ground. Its implicit treatment differs only in rounding under RK4 (MuJoCo
    # adds joint damping to qfrc_passive like our callback does); rtol 1e-9 of the swing.
    b2 = 5.0
    ours, _ = simulate_steady_state(rig, 40.0, 2000.0, CFG, law=Plant(NOMINAL, bearing2_damping_Nms_per_rad=b2))
    native = copy.copy(rig)
    m = copy.copy(rig.model)
    m.dof_damping[rig.dof_adr[1]] = b2
    object.__setattr__(native, "model", m)
    theirs, _ = simulate_steady_state(native, 40.0, 2000.0, CFG, law=NOMINAL)
    swing = np.ptp(theirs.phi2_rad)
    np.testing.assert_allclose(ours.phi2_rad, theirs.phi2_rad, rtol=0, atol=1e-9 * swing)
    np.testing.assert_allclose(ours.phi_rad, theirs.phi_rad, rtol=0, atol=1e-9 * swing)


def test_drive_delay_equals_a_phase_shifted_drive_and_records_the_undelayed_torque(rig):
    # A delay tau applied to M0 cos(w t) is the drive M0 cos(w t - w tau): same motion; the
    # record keeps the torque as recorded (undelayed). atol 1e-12 rad: identical arithmetic
    # up to the rounding of the phase.
    w, M0, tau = 40.0, 2000.0, 0.002
    delayed, _ = simulate_steady_state(rig, w, M0, CFG, law=Plant(NOMINAL, drive_delay_s=tau))
    shifted, _ = simulate_steady_state(rig, w, M0, CFG, law=NOMINAL,
                                       drive=PeriodicDrive(w, (0.0, M0 * np.exp(-1j * w * tau))))
    np.testing.assert_allclose(delayed.phi_rad, shifted.phi_rad, rtol=0, atol=1e-12)
    np.testing.assert_allclose(delayed.torque_Nm, M0 * np.cos(w * delayed.time_s), rtol=0, atol=1e-9)
    np.testing.assert_allclose(shifted.torque_Nm, M0 * np.cos(w * (shifted.time_s - tau)), rtol=0, atol=1e-9)


def test_hysteresis_rig_dissipates_what_the_jenkins_closed_form_says(rig):
    # Energy balance over a steady period: the drive's work equals the joint's dissipation,
    # viscous c * integral(phi'^2) plus the Jenkins loop 4 F (A_eff - d) on the actual motion
    # (the identifier's array path integrates its loop along the record). rtol 2e-6: measured
    # 2.1e-7 (1024 samples per period, trapezoid rule), 10x margin; the loop is 5% of the work,
    # so a slip torque 4% off shows as 2e-3 and fails.
    F, d = 50.0, 0.05
    law = JointLaw(NOMINAL.terms + (Jenkins(d),), NOMINAL.values + (F,))
    rec, _ = simulate_steady_state(rig, 40.0, 2000.0, SimulationConfig(n_periods=1, samples_per_period=1024),
                                   law=law)
    dt = rec.time_s[1] - rec.time_s[0]
    work_drive = np.sum(rec.torque_Nm * rec.rate1_rad_s) * dt
    viscous = 100.0 * np.sum(rec.rate_rad_s**2) * dt
    hyst = F * Jenkins(d)(rec.phi_rad, None)
    loop = -np.sum(0.5 * (hyst + np.roll(hyst, -1)) * (np.roll(rec.phi_rad, -1) - rec.phi_rad))
    assert work_drive == pytest.approx(viscous + abs(loop), rel=2e-6)
    assert abs(loop) > 0.02 * work_drive  # the hysteresis is a visible part of the dissipation


def test_worn_model_declares_its_effects_in_mjcf():
    rig = load_rig(MODELS_DIR / "two_flywheels_worn.xml")
    p = rig.plant.parameters()
    assert p["coulomb_torque_Nm"] == 60.0 and p["backlash_half_gap_rad"] == 0.03
    assert any(isinstance(t, Coulomb) for t in rig.law.terms)


def test_an_iwan_joint_written_as_mjcf_reads_back_to_the_same_plant(tmp_path):
    from jointrig.vocab.law import Iwan, JointLaw, Power, Viscous
    from jointrig.vocab.plant import Plant
    from jointrig.rig.model import identified_model_xml

    plant = Plant(JointLaw((Viscous(), Power(1), Iwan(0.02, -0.3, 0.25)), (5.0, 500.0, 40.0)))
    path = tmp_path / "iwan.xml"
    path.write_text(identified_model_xml(plant, (2.0, 2.0)))
    back = load_rig(path).plant
    assert back.law == plant.law and back.parameters() == plant.parameters()
    assert back.parameters()["iwan_stiffness_Nm_per_rad"] == pytest.approx(40.0 * 1.25 / (0.02 * (0.25 + 0.7 / 1.7)))


@pytest.mark.parametrize("fields, match", [
    ('<numeric name="jointrig_hysteresis_slip_torque_Nm" data="5"/>', "go together"),
    ('<numeric name="jointrig_drive_delay_s" data="-1"/>', ">= 0"),
    ('<numeric name="jointrig_bogus_Nm" data="1"/>', "unknown joint-law field"),
    ('<numeric name="jointrig_iwan_slip_angle_rad" data="0.02"/>', "go together"),
    ('<numeric name="jointrig_iwan_chi" data="-0.5"/>', "shape an Iwan element"),
    ('<numeric name="jointrig_iwan_slip_torque_Nm" data="5"/><numeric name="jointrig_iwan_slip_angle_rad" '
     'data="0.02"/><numeric name="jointrig_iwan_chi" data="0.5"/>', r"in \(-1, 0\]"),
])
def test_bad_effect_fields_are_refused(tmp_path, fields, match):
    text = DEFAULT_MODEL.read_text().replace("<custom>", "<custom>\n    " + fields)
    path = tmp_path / "bad.xml"
    path.write_text(text)
    with pytest.raises(RigModelError, match=match):
        load_rig(path)


def test_general_drive_must_have_no_constant_and_match_omega(rig):
    with pytest.raises(ValueError, match="constant"):
        PeriodicDrive(10.0, (1.0, 100.0))
    with pytest.raises(ValueError, match="differs"):
        simulate_steady_state(rig, 10.0, 100.0, CFG, drive=PeriodicDrive.cosine(11.0, 100.0))
    assert math.isclose(PeriodicDrive(10.0, (0, 3 + 4j)).amplitude_Nm, 5.0)


def test_drive_evaluator_equals_the_vectorised_drive():
    # The callback's scalar evaluator (Horner in exp(i w t)) and the array path agree;
    # 1e-12 relative: rounding of a 4-term complex polynomial.
    drive = PeriodicDrive(7.0, (0.0, 100.0, 5 - 3j, 0.0, 2j))
    t = np.linspace(0.0, 3.0, 101)
    f = drive.evaluator(0.01)
    np.testing.assert_allclose([f(v) for v in t], drive(t - 0.01), rtol=0, atol=1e-12 * 100)
