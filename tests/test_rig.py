"""The rig: model checks, the callback's torque, scoping, steady state, divergence, scipy reference."""

import math

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from jointrig.vocab.law import JointLaw, Term, hat_law
from jointrig.vocab.plant import PeriodicDrive
from jointrig.rig import (DEFAULT_MODEL, RigModelError, SimulationConfig, SimulationError, SteadyStateNotReached, load_rig,
                 make_callback, passive_callback, simulate_steady_state)
from jointrig.rig.model import ACTUATOR

from conftest import ALL_MODELS, RIG_MODELS, needs_cc


@pytest.mark.parametrize("path", ALL_MODELS, ids=lambda p: p.name)
def test_every_model_names_everything(path):
    m = mujoco.MjModel.from_xml_path(str(path))
    for obj, n in ((mujoco.mjtObj.mjOBJ_JOINT, m.njnt), (mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu),
                   (mujoco.mjtObj.mjOBJ_SENSOR, m.nsensor), (mujoco.mjtObj.mjOBJ_BODY, m.nbody)):
        for i in range(1 if obj == mujoco.mjtObj.mjOBJ_BODY else 0, n):  # body 0 is the world
            assert mujoco.mj_id2name(m, obj, i), f"{path.name}: unnamed {obj.name} {i}"


@pytest.mark.parametrize("path", RIG_MODELS, ids=lambda p: p.name)
def test_every_rig_model_loads_with_the_papers_flywheels(path):
    rig = load_rig(path)
    # J1 = J2 = 2 kg m^2 (the paper's flywheels), exactly: set by explicit <inertial>.
    assert (rig.J1_kgm2, rig.J2_kgm2) == (2.0, 2.0)


def _state(rig, phi1, phi2, v1, v2, t):
    d = mujoco.MjData(rig.model)
    d.qpos[list(rig.qpos_adr)] = (phi1, phi2)
    d.qvel[list(rig.dof_adr)] = (v1, v2)
    d.time = t
    return d


@pytest.mark.parametrize("path", RIG_MODELS, ids=lambda p: p.name)
def test_callback_torque_equals_law_evaluated_independently(path):
    rig = load_rig(path)
    p = rig.law.as_dict()
    fields = {rig.model.numeric(i).name: rig.model.numeric(i).data[0] for i in range(rig.model.nnumeric)}
    gap = fields.get("jointrig_backlash_half_gap_rad", 0.0)
    dry = fields.get("jointrig_coulomb_torque_Nm", 0.0)
    if "k_Nm_per_rad" in p:
        def independent(phi, rate):  # written out by hand from the MJCF fields
            e = phi - np.clip(phi, -gap, gap)  # engaged angle beyond the free play
            return (p["c_Nms_per_rad"] * rate + p["k_Nm_per_rad"] * e + p.get("gamma_Nm_per_rad3", 0) * e**3
                    + dry * np.sign(rate))
    else:
        knots = rig.model.numeric("jointrig_knots_rad").data
        g = rig.model.numeric("jointrig_g_Nm").data

        def independent(phi, rate):
            return p["c_Nms_per_rad"] * rate + np.interp(phi, knots, g)  # inside the knot range
    omega, M0 = 7.0, 123.0
    rng = np.random.default_rng(3)
    for _ in range(20):
        phi1, phi2, v1, v2 = rng.uniform(-0.3, 0.3, 4)
        t = rng.uniform(0, 10)
        d = _state(rig, phi1, phi2, v1, v2, t)
        errors = []
        with passive_callback(make_callback(rig, rig.law, PeriodicDrive.cosine(omega, M0), errors)):
            mujoco.mj_forward(rig.model, d)
        assert not errors
        tau = independent(phi1 - phi2, v1 - v2)
        a, b = rig.dof_adr
        # rtol 1e-12: the same arithmetic in a different order.
        np.testing.assert_allclose(d.qfrc_passive[[a, b]], [-tau, tau], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(d.actuator_force[rig.actuator_id], M0 * math.cos(omega * t), rtol=1e-14)
        np.testing.assert_allclose(d.sensordata[rig.sensor_adr["drive_torque"]], M0 * math.cos(omega * t),
                                   rtol=1e-14)


@pytest.mark.parametrize("backend", ["python", pytest.param("native", marks=needs_cc)])
def test_callback_is_scoped_and_refuses_to_share(rig, backend):
    assert mujoco.get_mjcb_passive() is None
    simulate_steady_state(rig, 40.0, 100.0, SimulationConfig(max_step_s=2e-3, samples_per_period=16), backend=backend)
    assert mujoco.get_mjcb_passive() is None  # restored after use

    def foreign(m, d):
        pass

    mujoco.set_mjcb_passive(foreign)
    try:
        with pytest.raises(RuntimeError, match="already installed"):
            simulate_steady_state(rig, 40.0, 100.0, SimulationConfig(samples_per_period=16))
        assert mujoco.get_mjcb_passive() is foreign  # left as we found it
    finally:
        mujoco.set_mjcb_passive(None)
    with passive_callback(foreign):
        with pytest.raises(RuntimeError, match="another jointrig simulation"):
            with passive_callback(foreign):
                pass
    assert mujoco.get_mjcb_passive() is None


class _Failing(Term):
    """A basis term whose evaluation raises, as a user's broken law would."""

    name = "failing_Nm"
    elastic = False

    def __call__(self, phi, rate):
        return 1 / 0


def test_callback_exception_becomes_simulation_error(rig):
    bad = JointLaw((_Failing(),), (1.0,))
    with pytest.raises(SimulationError, match="callback failed: ZeroDivisionError"):
        simulate_steady_state(rig, 40.0, 100.0, SimulationConfig(samples_per_period=16), law=bad)
    assert mujoco.get_mjcb_passive() is None


def test_rig_matches_scipy_reference_of_eq12(rig):
    """The rig's relative motion is the solution of eq. (12) (independent integrator: scipy DOP853)."""
    omega = 1.0
    record, info = simulate_steady_state(rig, omega, 400.0, SimulationConfig())

    def rhs(t, y):
        phi, rate = y
        return [rate, 200 * math.cos(omega * t) - 100 * rate - 2000 * phi - 200 * phi**3]

    T = 2 * math.pi / omega
    t0 = record.time_s[0]
    sol = solve_ivp(rhs, (0, t0 + T), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14,
                    t_eval=record.time_s, dense_output=False)
    # atol 1e-9 rad on a 0.1 rad swing: RK4 at dt = 4.9e-4 s (global error ~1e-10 here) plus
    # the scipy tolerance; the transient has decayed by exp(-27.6 t0) < 1e-20.
    np.testing.assert_allclose(record.phi_rad, sol.y[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(record.rate_rad_s, sol.y[1], rtol=0, atol=1e-8)


def test_drive_is_evaluated_at_continuous_time(rig):
    # The logged drive torque is M0 cos(omega t) at the sample times, to round-off: no hold, no delay.
    record, _ = simulate_steady_state(rig, 30.0, 250.0, SimulationConfig())
    np.testing.assert_allclose(record.torque_Nm, 250.0 * np.cos(30.0 * record.time_s), rtol=0, atol=1e-9)


def test_steady_state_detection(rig):
    cfg = SimulationConfig(settle_tol=1e-9, n_periods=2)
    record, info = simulate_steady_state(rig, 20.0, 400.0, cfg)
    n = record.samples_per_period
    swing = np.ptp(record.phi_rad)
    # The estimated distance from the exact steady state is within the tolerance, and the two
    # logged periods, each within that distance of it, agree to twice the bound plus the
    # integration floor (1e-11 of the swing).
    assert np.max(np.abs(record.phi_rad[:n] - record.phi_rad[n:])) < (2 * info.error_bound + 1e-11) * swing
    with pytest.raises(SteadyStateNotReached, match="no steady state after 2 periods"):
        simulate_steady_state(rig, 90.0, 400.0, SimulationConfig(max_periods=2, min_periods=2))


def test_diverging_simulation_raises(rig):
    stiff = hat_law(knots_rad=(-1.0, 1.0), g_Nm=(-1e9, 1e9), c_Nms_per_rad=1.0)  # k = 1e9: RK4 unstable at dt 5e-4
    with pytest.raises(SimulationError, match="MuJoCo warned|non-finite"):
        simulate_steady_state(rig, 10.0, 400.0, SimulationConfig(), law=stiff)
    assert mujoco.get_mjcb_passive() is None


def test_a_mujoco_warning_is_a_divergence_that_names_the_warnings(rig):
    # A diagnosis words a fitted model's divergence from the warnings alone (studies.notes.DIVERGED),
    # not from the rig's advice to its own user (a smaller max_step_s, which diagnose does not take).
    from jointrig.rig.simulate import Diverged, _check_warnings

    d = mujoco.MjData(rig.model)
    _check_warnings(d, "quiet")  # no warning: nothing raised
    d.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number = 2
    with pytest.raises(Diverged, match="reduce max_step_s") as got:
        _check_warnings(d, "r1")
    assert got.value.warnings == "mjWARN_BADQACC x2 (info 0)" and isinstance(got.value, SimulationError)


def test_determinism(rig):
    a, _ = simulate_steady_state(rig, 45.0, 4000.0, SimulationConfig())
    b, _ = simulate_steady_state(rig, 45.0, 4000.0, SimulationConfig())
    for name in ("time_s", "torque_Nm", "phi1_rad", "phi2_rad", "rate1_rad_s", "rate2_rad_s"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def _write_variant(tmp_path, edit, name="variant.xml"):
    spec = mujoco.MjSpec.from_file(str(DEFAULT_MODEL))
    edit(spec)
    path = tmp_path / name
    path.write_text(spec.to_xml())
    return path


@pytest.mark.parametrize("edit, match", [
    (lambda s: [s.delete(x) for x in (s.sensor("phi2"), s.sensor("rate2"), s.joint("phi2"))],
     "no joint named 'phi2'"),
    (lambda s: [s.delete(x) for x in (s.sensor("drive_torque"), s.actuator(ACTUATOR))],
     f"no actuator named '{ACTUATOR}'"),
    (lambda s: s.delete(s.sensor("rate1")), "no sensor named 'rate1'"),
    (lambda s: s.add_numeric(name="jointrig_zeta", data=[1.0]), "unknown joint-law field.*jointrig_zeta"),
    (lambda s: [s.delete(s.numeric(n)) for n in ("jointrig_c_Nms_per_rad", "jointrig_k_Nm_per_rad",
                                                 "jointrig_gamma_Nm_per_rad3")], "no joint law"),
])
def test_bad_models_raise_errors_naming_file_and_item(tmp_path, edit, match):
    path = _write_variant(tmp_path, edit)
    with pytest.raises(RigModelError, match=match) as err:
        load_rig(path)
    assert str(path) in str(err.value)


def test_missing_and_invalid_files(tmp_path):
    with pytest.raises(RigModelError, match="no such model file"):
        load_rig(tmp_path / "nope.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(RigModelError, match="could not compile"):
        load_rig(bad)


def test_simulation_config_validation():
    with pytest.raises(TypeError):
        SimulationConfig(max_step=1e-3)  # unknown keyword
    with pytest.raises(ValueError, match="samples_per_period"):
        SimulationConfig(samples_per_period=4)
    with pytest.raises(ValueError, match="integrator"):
        SimulationConfig(integrator="Verlet")
    cfg = SimulationConfig(max_step_s=1e-3, samples_per_period=100)
    assert cfg.timestep_s(1.0) <= 1e-3
    assert cfg.steps_per_sample(1.0) * 100 * cfg.timestep_s(1.0) == pytest.approx(2 * math.pi, rel=1e-15)


def test_simulated_inertias_are_those_asked_for(tmp_path):
    # MuJoCo 4 precomputes the mass matrix of simple bodies: scaling body_inertia without
    # mj_setConst left the file's inertias in force (the validation of identified models then
    # simulated the wrong flywheels). A rig asked for (J1, J2) = (3, 1) must give the very
    # record of a model file compiled with them (same arithmetic: bit for bit).
    from jointrig.rig.model import identified_model_xml

    rig = load_rig()
    asked, _ = simulate_steady_state(rig, 30.0, 400.0, inertias_kgm2=(3.0, 1.0))
    path = tmp_path / "j31.xml"
    path.write_text(identified_model_xml(rig.plant, (3.0, 1.0)))
    compiled, _ = simulate_steady_state(load_rig(path), 30.0, 400.0)
    np.testing.assert_array_equal(asked.phi1_rad, compiled.phi1_rad)
    np.testing.assert_array_equal(asked.phi2_rad, compiled.phi2_rad)
    own, _ = simulate_steady_state(rig, 30.0, 400.0)
    assert np.max(np.abs(own.phi_rad - compiled.phi_rad)) > 0.1 * np.ptp(compiled.phi_rad)
