"""Drive trains: chain models, their simulation, and harmonic balance with N degrees of freedom."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jointrig.vocab.law import Power, Viscous
from jointrig.identify.chain import (ChainIdentifiabilityError, ChainRecord, ChainSpec, chain_system, identifiability,
                                     solve_banded)
from jointrig.identify.solve import solve
from jointrig.rig.chain import chain_model_xml, is_chain_model, load_chain
from jointrig.rig.model import RigModelError

from conftest import CALLBACK_RTOL, MODELS_DIR, PROCESS_RTOL, needs_cc

PUMP_TRAIN = MODELS_DIR / "pump_train.xml"


def _linear_chain_records(J, c, k, bearings, drives, omegas, n=64):
    """Exact steady states of a linear chain, from its dynamic stiffness matrix (no simulator)."""
    N = len(J)
    out = []
    for w in omegas:
        Z = -w**2 * np.diag(J) + 1j * w * np.diag(bearings)
        for j in range(N - 1):
            z = k[j] + 1j * w * c[j]
            Z[j:j + 2, j:j + 2] += z * np.array([[1, -1], [-1, 1]])
        T = np.array([drives.get(i + 1, 0) for i in range(N)], dtype=complex)
        X = np.linalg.solve(Z, T)
        t = np.arange(n) * 2 * np.pi / (w * n)
        e = np.exp(1j * w * t)
        out.append(ChainRecord(w, t, [np.real(T[i] * e) if (i + 1) in drives else None for i in range(N)],
                               [np.real(X[i] * e) for i in range(N)], [np.real(1j * w * X[i] * e) for i in range(N)]))
    return out


def test_banded_qr_solves_the_chain_as_the_dense_svd_does():
    # A 5-flywheel linear chain with a bearing, driven at both ends: exact steady states. The
    # block QR must give the dense solve's values (to round-off: 1e-12 of each parameter at a
    # condition number ~10) and their true values (the rows are exact).
    J, c, k = [0.5, 0.1, 0.8, 1.2, 0.3], [2.0, 1.0, 3.0, 0.5], [4e4, 2e4, 6e4, 1e4]
    recs = _linear_chain_records(J, c, k, [0, 0.5, 0, 0, 0], {1: 100.0, 5: 30j}, [30, 80, 150, 250, 400])
    spec = ChainSpec(((Viscous(), Power(1)),) * 4, bearings=(2,))
    banded = chain_system(recs, spec, n_harmonics=3)
    assert banded.density < 0.5  # most of [A] is structurally zero
    band, dense = solve_banded(banded), solve(banded.system)
    assert band.success and band.condition_number == pytest.approx(dense.condition_number, rel=1e-8)
    np.testing.assert_allclose(band.values, dense.values, rtol=1e-11)
    truth = dict(zip(spec.names, [0.5, 2, 4e4, 0.1, 0.5, 1, 2e4, 0.8, 3, 6e4, 1.2, 0.5, 1e4, 0.3]))
    for name, v in band.as_dict().items():
        assert v == pytest.approx(truth[name], rel=1e-10), name


def test_unmeasured_angle_and_missing_drive_are_refused_with_the_reason():
    recs = _linear_chain_records([0.5, 0.1, 0.8, 1.2], [2.0, 1.0, 3.0], [4e4, 2e4, 6e4], [0] * 4, {1: 100.0},
                                 [30.0, 80.0])
    spec = ChainSpec(((Viscous(), Power(1)),) * 3)
    blind = [ChainRecord(r.omega_rad_s, r.time_s, r.torques_Nm, r.angles_rad[:2] + (None,) + r.angles_rad[3:])
             for r in recs]
    with pytest.raises(ChainIdentifiabilityError, match=r"joint 2 \(flywheels 2-3\).*phi3.*joint 3 \(flywheels 3-4\)"):
        chain_system(blind, spec, n_harmonics=3)
    undriven = [ChainRecord(r.omega_rad_s, r.time_s, [None] * 4, r.angles_rad) for r in recs]
    with pytest.raises(ChainIdentifiabilityError, match="no flywheel has a recorded drive torque"):
        chain_system(undriven, spec, n_harmonics=3)
    # An end flywheel without its sensor: only the joint beside it is named.
    assert [r.split(":")[0] for r in identifiability(4, [True, True, True, False], [True, False, False, False])] \
        == ["joint 3 (flywheels 3-4)"]


@pytest.fixture(scope="session")
def pump_train_sweep(tmp_path_factory):
    """The README's command on the pump train: sweep, identify, write JSON and a recording."""
    from jointrig.cli import main

    out = tmp_path_factory.mktemp("pump_train")
    rc = main(["sweep", "--model", str(PUMP_TRAIN), "--json", str(out / "pt.json"), "--rrd", str(out / "pt.rrd"),
               "--no-store", "--quiet"])
    return rc, json.loads((out / "pt.json").read_text()), out / "pt.rrd"


@pytest.mark.xdist_group("pump_train")
def test_pump_train_identified_noise_free_within_1e_6(pump_train_sweep):
    # All four inertias and all three joint laws at once, noise-free. The rig's error is RK4's
    # at steps <= 50 us with 128 samples a period (measured 1.2e-7 on the cubic stiffness,
    # <= 7e-8 on the rest); the bound is 1e-6.
    rc, out, _ = pump_train_sweep
    assert rc == 0 and out["success"] and out["form"] == "chain" and out["n_flywheels"] == 4
    params = out["parameters"]
    assert set(params) == {"J1_kgm2", "J2_kgm2", "J3_kgm2", "J4_kgm2", "joint1_c_Nms_per_rad", "joint1_k_Nm_per_rad",
                           "joint2_c_Nms_per_rad", "joint2_k_Nm_per_rad", "joint2_gamma_Nm_per_rad3",
                           "joint3_c_Nms_per_rad", "joint3_k_Nm_per_rad"}
    for name, p in params.items():
        assert abs(p["rel_error"]) < 1e-6, (name, p)
    assert out["max_abs_rel_error"] < 1e-6


@pytest.mark.xdist_group("pump_train")
def test_pump_train_recording_has_a_view_per_joint_and_per_run(pump_train_sweep):
    from conftest import blueprint_views

    _, out, rrd = pump_train_sweep
    names, origins = blueprint_views(rrd)
    assert {f"restoring_force/joint{j}" for j in (1, 2, 3)} <= set(origins)
    assert sum(o.startswith("runs/") for o in origins) == len(out["sweep"]["points"])


def _edit(tmp_path, old, new, name="chain.xml"):
    text = PUMP_TRAIN.read_text()
    assert old in text
    p = tmp_path / name
    p.write_text(text.replace(old, new))
    return p


@pytest.mark.parametrize("old,new,message", [
    ('<actuatorfrc name="drive4_torque" actuator="drive4"/>', "", "drive4.*needs an actuatorfrc sensor 'drive4_torque'"),
    ('<numeric name="jointrig_joint3_c_Nms_per_rad" data="10"/>\n    <numeric name="jointrig_joint3_k_Nm_per_rad" data="120000"/>',
     "", "joint 3 \\(bodies 3-4\\) has no law"),
    ('name="jointrig_joint1_c_Nms_per_rad"', 'name="jointrig_joint1_c_Nms"', "joint 1: unknown law field.*joint1_c_Nms"),
    ('name="jointrig_joint1_c_Nms_per_rad" data="15"', 'name="jointrig_joint1_c_Nms_per_rad" data="-15"', "joint 1.*>= 0"),
    ('<joint name="phi3" type="hinge" axis="0 0 1"', '<joint name="phi3" type="hinge" axis="0 1 0"', "phi3.*axis"),
    ('<motor name="drive4" joint="phi4"', '<motor name="drive4" joint="phi3"', "drive4.*must drive joint 'phi4'"),
    ('name="jointrig_joint1_k_Nm_per_rad"', 'name="jointrig_joint7_k_Nm_per_rad"', "unknown field jointrig_joint7"),
    ("  </worldbody>", '  </worldbody>\n  <tendon><fixed name="jointrig_twist2"><joint joint="phi1" coef="1"/></fixed></tendon>',
     "tendon named 'jointrig_twist2' is the rig's own"),
])
def test_bad_chain_models_are_refused_naming_the_item(tmp_path, old, new, message):
    with pytest.raises(RigModelError, match=message):
        load_chain(_edit(tmp_path, old, new))


def test_chain_models_are_told_from_two_flywheel_models():
    assert is_chain_model(PUMP_TRAIN) and is_chain_model(MODELS_DIR / "pump_train_worn.xml")
    assert not is_chain_model(MODELS_DIR / "two_flywheels.xml")
    rig = load_chain(PUMP_TRAIN)
    assert rig.inertias_kgm2 == (0.45, 0.06, 0.12, 0.35) and rig.driven == (1, 4)
    worn = load_chain(MODELS_DIR / "pump_train_worn.xml")
    assert {t.gap_rad for t in worn.plant.laws[1].terms if isinstance(t, Power)} == {0.001}
    assert all(getattr(t, "gap_rad", 0) == 0 for law in (worn.plant.laws[0], worn.plant.laws[2]) for t in law.terms)


def test_chain_sweep_refuses_what_it_cannot_do_before_simulating(tmp_path, capsys):
    from jointrig.cli import main

    out = str(tmp_path / "x.json")
    assert main(["sweep", "--model", str(PUMP_TRAIN), "--excitation", "multisine", "--json", out, "--quiet"]) == 2
    assert "chain model: --excitation multisine is not available for chains" in capsys.readouterr().err
    assert main(["sweep", "--model", str(PUMP_TRAIN), "--omegas", "300", "--drive-at", "2", "--json", out,
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--drive-at 2: " in err and "motors on flywheels [1, 4]" in err
    assert not (tmp_path / "x.json").exists()


def test_chain_simulates_the_inertias_asked_for():
    # The linear train's steady state is known exactly from its dynamic stiffness: with the
    # pump train's bodies scaled to other inertias the rig must reproduce it (RK4 at 128 steps a
    # period: 1e-5 of the twist).
    from jointrig.vocab.law import JointLaw
    from jointrig.identify.chain import ChainPlant
    from jointrig.identify.harmonics import fourier_coefficients
    from jointrig.vocab.plant import PeriodicDrive
    from jointrig.rig.chain import simulate_chain
    from jointrig.rig.simulate import SimulationConfig

    J, c, k, w = (1.0, 0.5, 0.5, 1.0), (30.0, 20.0, 30.0), (1e4, 5e3, 1e4), 80.0
    plant = ChainPlant(tuple(JointLaw((Viscous(), Power(1)), (ci, ki)) for ci, ki in zip(c, k)), (0.0,) * 4)
    rec, _ = simulate_chain(load_chain(PUMP_TRAIN).with_plant(plant), w, {1: PeriodicDrive.cosine(w, 150.0)},
                            SimulationConfig(samples_per_period=128, max_step_s=5e-4), inertias_kgm2=J)
    exact = _linear_chain_records(J, c, k, [0.0] * 4, {1: 150.0}, [w])[0]
    for j in range(3):
        sim = fourier_coefficients(rec.angles_rad[j] - rec.angles_rad[j + 1], 1, 1)[1]
        ref = fourier_coefficients(exact.angles_rad[j] - exact.angles_rad[j + 1], 1, 1)[1]
        assert abs(sim - ref) < 1e-5 * abs(ref), j


def _both_backends(rig, w, drives, cfg, plant):
    """The chain simulated by the Python and the C callback: every record channel within
    conftest.CALLBACK_RTOL of its peak (why not bit for bit: there); the Python one returned."""
    from jointrig.rig.chain import simulate_chain

    a, _ = simulate_chain(rig, w, drives, cfg, plant=plant, backend="python")
    b, _ = simulate_chain(rig, w, drives, cfg, plant=plant, backend="native")
    for x, y in zip(a.angles_rad + a.rates_rad_s + a.torques_Nm + (a.time_s,),
                    b.angles_rad + b.rates_rad_s + b.torques_Nm + (b.time_s,)):
        if x is None:
            assert y is None
        else:
            np.testing.assert_allclose(y, x, rtol=0, atol=CALLBACK_RTOL * max(np.abs(x).max(), 1e-300))
    return a


@needs_cc
@pytest.mark.parametrize("kind", ["hinge", "slide"])
def test_a_single_bodys_drag_and_law_to_ground_in_the_native_callback_agree_with_the_python_one(
        tmp_path, kind):
    # A single body with its drag alone, on a hinge and on a slide: the C callback dropped the
    # drag (it lived in joint blocks, and one body has none), so a single axis's nominal model
    # was replayed undamped. Now its records are the Python callback's (to CALLBACK_RTOL), and so are a
    # law to ground's (a block of its own, after the joints' and drags', as the Python callback
    # adds them): a guide's dry friction and spring, and one with a slider (the relative-angle
    # form's joint: a Jenkins element, committed in C after every step; an Iwan element's
    # sliders at a joint are the next test's, by the same C commit).
    import dataclasses

    from jointrig.identify.chain import ChainPlant
    from jointrig.studies.chain_sweep import CHAIN_CONFIG
    from jointrig.vocab.law import Coulomb, Jenkins, JointLaw, Power, Viscous
    from jointrig.vocab.plant import PeriodicDrive

    # The first three periods from rest, no steady state sought: the two callbacks are compared
    # on the same trajectory, transient included (settled to 1e-7, the drag's 0.4 s time
    # constant took some twenty periods of the Python callback)
    cfg = dataclasses.replace(CHAIN_CONFIG, absolute_angles_periodic=False, n_periods=3, samples_per_period=64,
                              max_step_s=2e-4, settle=False)
    drag_only = ChainPlant((), (30.0,), (None,))
    path = tmp_path / "one.xml"
    path.write_text(chain_model_xml(drag_only, (12.0,), (1,), kind=kind))
    one = load_chain(path)
    drives = {1: PeriodicDrive.cosine(20.0, 300.0)}
    a = _both_backends(one, 20.0, drives, cfg, drag_only)
    assert np.ptp(a.angles_rad[0]) > 0
    guided = ChainPlant((), (30.0,), (JointLaw((Coulomb(), Power(1)), (20.0, 4000.0)),))
    assert np.ptp(_both_backends(one, 20.0, drives, cfg, guided).angles_rad[0]) > 0
    hysteretic = ChainPlant((), (0.0,), (JointLaw((Viscous(), Power(1), Jenkins(0.01)), (5.0, 2000.0, 40.0)),))
    swing = np.ptp(_both_backends(one, 20.0, drives, cfg, hysteretic).angles_rad[0]) / 2
    assert swing > 0.01  # beyond the slip angle: the slider slips


@needs_cc
def test_sliders_at_joints_are_committed_in_c_as_in_the_python_callback(tmp_path):
    # A train whose joints hold a Jenkins and an Iwan element: the native callback steps the
    # period in C and commits every slider after every step (rig/native/jointrig_law.c,
    # jointrig_run), with the same records as the Python callback's stepping loop (to CALLBACK_RTOL).
    import dataclasses

    from jointrig.identify.chain import ChainPlant
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.chain_sweep import CHAIN_CONFIG
    from jointrig.vocab.law import Iwan, Jenkins, JointLaw, Power, Viscous
    from jointrig.vocab.plant import PeriodicDrive

    # the first three periods from rest, transient included (as the single body's test)
    cfg = dataclasses.replace(CHAIN_CONFIG, absolute_angles_periodic=False, n_periods=3, samples_per_period=64,
                              max_step_s=2e-4, settle=False)
    plant = ChainPlant((JointLaw((Viscous(), Power(1), Jenkins(0.005)), (10.0, 3000.0, 40.0)),
                        JointLaw((Viscous(), Power(1), Iwan(0.01)), (10.0, 3000.0, 30.0))), (1.0, 0.0, 2.0))
    rig = rig_of_bodies(3, (1, 3))
    drives = {1: PeriodicDrive.cosine(15.0, 200.0), 3: PeriodicDrive.cosine(15.0, 80.0)}
    rec = _both_backends(rig, 15.0, drives, cfg, plant)
    assert np.ptp(rec.angles_rad[0] - rec.angles_rad[1]) / 2 > 0.005


@needs_cc
@pytest.mark.parametrize("model", ["pump_train.xml", "pump_train_worn.xml"])
def test_native_chain_callback_agrees_with_the_python_one(model):
    # Every joint's law, the bearings and two drives (one of several harmonics) in C, summed in
    # the Python callback's order: the records agree to CALLBACK_RTOL. The worn train
    # holds free play; a Jenkins element at joint 3 adds sliders (stepped, committed per step).
    import dataclasses

    from jointrig.vocab.law import Jenkins, JointLaw
    from jointrig.identify.chain import ChainPlant
    from jointrig.vocab.plant import PeriodicDrive
    from jointrig.studies.chain_sweep import CHAIN_CONFIG

    rig = load_chain(MODELS_DIR / model)
    # bit identity does not depend on the step: a coarse one keeps the Python path quick
    cfg = dataclasses.replace(CHAIN_CONFIG, absolute_angles_periodic=False, n_periods=2, samples_per_period=64,
                              max_step_s=2e-4, settle_tol=1e-7)
    w = 300.0
    drives = {1: PeriodicDrive.cosine(w, 60.0), 4: PeriodicDrive(w, (0, 10 + 5j, 3j))}
    plants = [rig.plant]
    if model == "pump_train.xml":
        laws = list(rig.plant.laws)
        laws[2] = JointLaw(laws[2].terms + (Jenkins(2e-4),), laws[2].values + (8.0,))
        plants.append(ChainPlant(tuple(laws), (0.0, 1.5, 0.0, 2.0)))
    for plant in plants:
        # the Python callback named: the default is the C one where a compiler is found
        _both_backends(rig, w, drives, cfg, plant)


@needs_cc
def test_chain_sweep_in_threads_is_bit_identical_to_serial():
    # Two threads share one installed native callback (each simulation finds its blocks by its
    # MjData): the same records, bit for bit, in the order given.
    from jointrig.studies.chain_sweep import CHAIN_CONFIG, run_chain_sweep

    rig = load_chain(MODELS_DIR / "pump_train_worn.xml")
    points = [(300.0, 60.0, 1), (1200.0, 60.0, 1), (400.0, 30.0, 4), (600.0, 60.0, 1)]
    serial = run_chain_sweep(rig, points, CHAIN_CONFIG, backend="native")
    threaded = run_chain_sweep(rig, points, CHAIN_CONFIG, backend="native", workers=2)
    for a, b in zip(serial, threaded):
        assert (a.omega_rad_s, a.flywheel) == (b.omega_rad_s, b.flywheel)
        for x, y in zip(a.record.angles_rad + (a.record.time_s,), b.record.angles_rad + (b.record.time_s,)):
            np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError, match="need the native callback"):
        run_chain_sweep(rig, points, CHAIN_CONFIG, backend="python", workers=2)


def test_chain_fisher_information_predicts_the_scatter_of_the_estimates():
    # A linear 3-flywheel chain driven at flywheel 1 by four harmonics at once: one record
    # identifies J1..J3, c and k of both joints. With white noise on the encoders and the torque
    # cell, the scatter over 400 realisations of the estimates (generalised least squares with
    # the rows' covariance) must match sqrt(diag(F^-1)) of fisher_per_period (x the 4 periods
    # measured) to 15%: the Monte Carlo's own standard error on a standard deviation is 3.5%,
    # and errors in variables of second order at this noise (1e-3 of the swing) are smaller.
    from jointrig.identify.chain import fisher_per_period, row_covariance

    J, c, k, w = (0.5, 0.2, 0.8), (3.0, 2.0), (4e4, 2e4), 150.0
    N, P, H = 64, 4, 4
    t = np.arange(N * P) * 2 * np.pi / (w * N)
    drive = {1: 100.0, 2: 60j, 3: 40.0, 4: 30.0 - 20j}

    def Z(v):
        out = -v**2 * np.diag(J).astype(complex)
        for j in range(2):
            out[j:j + 2, j:j + 2] += (k[j] + 1j * v * c[j]) * np.array([[1, -1], [-1, 1]])
        return out

    X = {n: np.linalg.solve(Z(n * w), np.array([a, 0, 0])) for n, a in drive.items()}
    angles = [sum(np.real(X[n][i] * np.exp(1j * n * w * t)) for n in drive) for i in range(3)]
    torque = sum(np.real(a * np.exp(1j * n * w * t)) for n, a in drive.items())
    spec = ChainSpec(((Viscous(), Power(1)),) * 2)
    theta = [0.5, 3.0, 4e4, 0.2, 2.0, 2e4, 0.8]
    clean = ChainRecord(w, t, [torque, None, None], angles, None, P)
    sa, st = 1e-3 * np.std(angles[0] - angles[1]), 1e-3 * np.std(torque)
    F = fisher_per_period(clean, spec, theta, sigma_angle_rad=sa, sigma_torque_Nm=st, n_harmonics=H) * P
    predicted = np.sqrt(np.diag(np.linalg.inv(F)))
    _, C = row_covariance(clean, spec, theta, sigma_angle_rad=sa, sigma_torque_Nm=st, n_harmonics=H)
    L = np.linalg.cholesky(C)
    rng = np.random.default_rng(3)
    est = []
    for _ in range(400):
        noisy = ChainRecord(w, t, [torque + rng.normal(0, st, t.size), None, None],
                            [a + rng.normal(0, sa, t.size) for a in angles], None, P)
        s = chain_system([noisy], spec, n_harmonics=H, first_harmonic=1).system
        est.append(np.linalg.lstsq(np.linalg.solve(L, s.A), np.linalg.solve(L, s.F), rcond=None)[0])
    observed = np.std(est, axis=0, ddof=1)
    np.testing.assert_allclose(observed, predicted, rtol=0.15)
    assert np.allclose(np.mean(est, axis=0), theta, rtol=1e-3)


@pytest.mark.slow
@needs_cc
def test_chain_excitation_design_beats_the_default_plan_on_its_budget(tmp_path, monkeypatch):
    # Where to drive and which frequencies: the D-optimal allocation over (frequency, motor,
    # level) candidates, with the Fisher information of fisher_per_period, must give a larger
    # log det than the default chain plan for the same test time (it may choose the default's
    # own runs, so a D-efficiency below 1 would be a failure of the allocation), stay within the
    # budget, and include the modes among the candidates. Candidates thinned to keep it quick.
    import jointrig.commands.design_excitation as de
    from jointrig.cli import main

    monkeypatch.setattr(de, "CHAIN_RELATIVE_OMEGAS", (0.1, 0.5))
    rig = load_chain(PUMP_TRAIN)
    cands = de.chain_candidates(rig, 60.0)
    assert {i for _, _, i in cands} == {1, 4} and {a for _, a, _ in cands} == {60.0, 120.0}
    assert any(abs(w - 295.2) < 0.1 for w, _, _ in cands) and any(abs(w - 2817.3) < 0.1 for w, _, _ in cands)
    out = tmp_path / "design.json"
    assert main(["design", "--model", str(PUMP_TRAIN), "--native", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["d_efficiency"] > 1
    periods = [r["periods"] for r in d["design"]]
    cost = sum(k * 2 * np.pi / r["omega_rad_s"] + d["setup_s"] for k, r in zip(periods, d["design"]))
    assert cost <= d["budget_s"] + 1e-9


def test_two_flywheel_loader_points_a_chain_to_its_loader():
    from jointrig.rig import load_rig

    with pytest.raises(RigModelError, match="chain model .* rig.chain.load_chain"):
        load_rig(PUMP_TRAIN)


@needs_cc
def test_chain_maximum_likelihood_standard_errors_hold_at_40_db():
    # The pump train's 10 runs, measured 5 times at 40 dB (8 periods each): every inertia and law
    # parameter by errors-in-variables ML, with its standard error. If the standard errors are
    # right, z = (estimate - truth) / standard error is a standard normal: the mean of z^2 over
    # 5 x 11 values lies in 1 +- 3 sqrt(2/55) = [0.43, 1.57], no |z| exceeds 4.5 (a 1e-5 tail
    # over 55 draws), and V/dof of every fit has a chi-square p above 1e-3.
    from jointrig.identify.chain import ml_identify_chain
    from jointrig.studies.chain_sweep import CHAIN_CONFIG, CHAIN_PLAN, run_chain_sweep
    from jointrig.rig.measurement import measure_chain

    rig = load_chain(PUMP_TRAIN)
    clean = [p.record for p in run_chain_sweep(rig, CHAIN_PLAN, CHAIN_CONFIG, backend="native")]
    truth = {**{f"J{i}_kgm2": J for i, J in enumerate(rig.inertias_kgm2, start=1)}, **rig.plant.parameters()}
    z = []
    for seed in range(5):
        rng = np.random.default_rng(seed)
        res = ml_identify_chain([measure_chain(r, 40.0, rng, n_periods=8) for r in clean], rig.plant.spec())
        assert res.success and res.p_value > 1e-3, (seed, res.cost, res.dof)
        z += [(res.value(n) - truth[n]) / res.std_error(n) for n in res.names]
    z = np.array(z)
    assert 0.43 < float(np.mean(z**2)) < 1.57, z
    assert np.max(np.abs(z)) < 4.5, z


def test_chain_sweep_on_a_dask_cluster_gives_the_local_records(tmp_path):
    # Two worker processes rebuild the chain from the model text; the records come back in the
    # order given, those of a local sweep (to conftest.PROCESS_RTOL: another process), and the
    # store then serves them bit for bit.
    pytest.importorskip("dask.distributed")
    from jointrig.studies.chain_sweep import CHAIN_CONFIG, run_chain_sweep

    rig = load_chain(MODELS_DIR / "pump_train.xml")
    points = [(1200.0, 60.0, 1), (400.0, 30.0, 4), (2000.0, 60.0, 1)]
    backend = "auto"  # native wherever a C compiler builds it, else Python: the same on both sides
    local = run_chain_sweep(rig, points, CHAIN_CONFIG, backend=backend)
    remote = run_chain_sweep(rig, points, CHAIN_CONFIG, backend=backend, workers=2, executor="dask",
                             store=tmp_path / "store")
    again = run_chain_sweep(rig, points, CHAIN_CONFIG, backend=backend, store=tmp_path / "store")
    for a, b, c in zip(local, remote, again):
        assert (a.omega_rad_s, a.flywheel) == (b.omega_rad_s, b.flywheel) == (c.omega_rad_s, c.flywheel)
        for x, y, z in zip(a.record.angles_rad, b.record.angles_rad, c.record.angles_rad):
            np.testing.assert_allclose(y, x, rtol=0, atol=PROCESS_RTOL * np.abs(x).max())
            np.testing.assert_array_equal(y, z)


def test_a_law_to_ground_with_memory_moves_a_body_as_the_same_joint_moves_two_flywheels(tmp_path):
    # A body's law to ground may hold sliders (a guide's pre-sliding, the relative-angle form's
    # joint). Two flywheels of 2 kg m^2 joined by a law with a Jenkins element, driven on the
    # first, twist as one body of 1 kg m^2 tied to the frame by the same law under half the
    # drive: phi'' = T/2 - M(phi) in both. RK4 is invariant under that linear change of
    # coordinates and the sliders commit after the same steps, so the two rigs agree to rounding
    # (1e-10 of the twist asked; 1e-14 measured). The one body's law is written to a model file and read back.
    import dataclasses

    from jointrig.identify.chain import ChainPlant
    from jointrig.rig.chain import chain_model_xml, rig_of_bodies, simulate_chain
    from jointrig.studies.chain_sweep import CHAIN_CONFIG
    from jointrig.vocab.law import Jenkins, JointLaw
    from jointrig.vocab.plant import PeriodicDrive

    law = JointLaw((Viscous(), Power(1), Jenkins(2e-3)), (20.0, 2e4, 60.0))
    cfg = dataclasses.replace(CHAIN_CONFIG, absolute_angles_periodic=False, n_periods=2, samples_per_period=128)
    omega = 60.0
    two, _ = simulate_chain(rig_of_bodies(2, (1,)), omega, {1: PeriodicDrive.cosine(omega, 600.0)}, cfg,
                            plant=ChainPlant((law,), (0.0, 0.0)), inertias_kgm2=(2.0, 2.0))
    path = tmp_path / "one.xml"
    path.write_text(chain_model_xml(ChainPlant((), (0.0,), (law,)), (1.0,), (1,)))
    one_rig = load_chain(path)
    assert one_rig.plant.grounds[0].as_dict() == law.as_dict()
    one, _ = simulate_chain(one_rig, omega, {1: PeriodicDrive.cosine(omega, 300.0)}, cfg)
    twist = two.angles_rad[0] - two.angles_rad[1]
    slip = np.ptp(twist) / 2
    assert slip > 2 * 2e-3  # the slider slips: its memory is exercised
    np.testing.assert_allclose(one.angles_rad[0] - one.angles_rad[0].mean(), twist - twist.mean(), rtol=0,
                               atol=1e-10 * slip)


def _resting_motion(n: int = 4096, omega: float = 2.0):
    """One period of a body that slides out and back and rests twice (a C-infinity rate: bump
    lobes, exactly zero on the rests): its samples, rate and acceleration, exact."""
    t = np.arange(n) * (2 * np.pi / omega) / n
    s = (np.arange(n) / n) % 0.5 * 4.0 - 1.0  # -1..1 over each half period: a lobe on (-0.7, 0.7), rest beyond
    u = s / 0.7
    inside = np.abs(u) < 1
    bump = np.zeros(n)
    bump[inside] = np.exp(-1.0 / (1.0 - u[inside] ** 2))
    dbump = np.zeros(n)
    dbump[inside] = bump[inside] * (-2.0 * u[inside] / (1.0 - u[inside] ** 2) ** 2)
    sign = np.where(np.arange(n) < n // 2, 1.0, -1.0)
    v = 0.3 * sign * bump / np.exp(-1.0)
    dsdt = 4.0 * omega / (2 * np.pi)  # ds/dt, and du/dt = ds/dt / 0.7
    a = 0.3 * sign * dbump / np.exp(-1.0) * dsdt / 0.7
    x = np.cumsum(v) * (t[1] - t[0])
    return t, x - x.mean(), v, a, omega


def test_a_body_that_sticks_is_balanced_exactly_once_its_rests_are_masked():
    # While a body rests, its dry friction is whatever force holds it (here the drive, half the
    # friction's size), not F_c sign(rate). Its equation balanced over the whole period leaves
    # that force as a residual (23% of the balanced drive); weighted by the stick mask (0 on
    # the rests) it holds wherever it is kept: the residual is round-off (4e-16) and the mass, drag and
    # friction come out exact (to 1e-7: the spectral acceleration of a bump on 4096 samples).
    from jointrig.identify.chain import stick_mask
    from jointrig.vocab.law import Coulomb

    t, x, v, a, omega = _resting_motion()
    m, c, Fc = 12.0, 40.0, 25.0
    F = np.where(v != 0, m * a + c * v + Fc * np.sign(v), 0.5 * Fc * np.cos(omega * t))
    rec = ChainRecord(omega, t, [F], [x], [v])
    spec = ChainSpec((), bearings=(1,), grounds=((Coulomb(),),))
    mask = stick_mask(v)
    assert mask is not None and mask[v == 0].max() == 0.0 and 0.3 < mask.mean() < 0.8
    masked = identify_from(rec, spec, [(mask,)])
    got = dict(zip(spec.names, masked.values))
    truth = {"J1_kgm2": m, "bearing1_damping_Nms_per_rad": c, "ground1_coulomb_torque_Nm": Fc}
    for name, value in truth.items():
        assert got[name] == pytest.approx(value, rel=1e-7), (name, got)
    assert masked.relative_residual < 1e-7
    assert identify_from(rec, spec, None).relative_residual > 0.1


def test_a_constant_force_on_a_masked_body_is_read_and_left_out_it_bends_the_rest():
    # Gravity on an inclined axis (F0 = 16 N against the drive) acts while the body slides; the
    # cell reads it in its mean, which the balance leaves out. A stick mask multiplies it, so it
    # enters every harmonic of the mask: without a constant it is a residual no parameter takes
    # up here (the mask of these two equal rests has only even harmonics, the rest only odd
    # ones; on the servo carriage, whose rests differ, it bent the mass by 5%), with one
    # (identify.chain_diagnose.with_constants) the fit and F0 are exact to 1e-7 (the masked
    # balance's own exactness, the test above).
    from jointrig.identify.chain import stick_mask
    from jointrig.identify.chain_diagnose import with_constants
    from jointrig.vocab.law import Constant, Coulomb

    t, x, v, a, omega = _resting_motion()
    m, c, Fc, F0 = 12.0, 40.0, 25.0, 16.0
    F = np.where(v != 0, m * a + c * v + Fc * np.sign(v) + F0, F0 + 0.5 * Fc * np.cos(omega * t))
    rec = ChainRecord(omega, t, [F], [x], [v])
    plain = ChainSpec((), bearings=(1,), grounds=((Coulomb(),),))
    masks = [(stick_mask(v),)]
    spec = with_constants(plain, masks)
    assert spec.grounds == ((Coulomb(), Constant()),) and with_constants(spec, [(None,)]) == plain
    fit = identify_from(rec, spec, masks)
    got = dict(zip(spec.names, fit.values))
    truth = {"J1_kgm2": m, "bearing1_damping_Nms_per_rad": c, "ground1_coulomb_torque_Nm": Fc,
             "ground1_constant_torque_Nm": F0}
    for name, value in truth.items():
        assert got[name] == pytest.approx(value, rel=1e-7), (name, got)
    assert fit.relative_residual < 1e-7
    assert identify_from(rec, plain, masks).relative_residual > 0.1


def test_a_free_bodys_replay_takes_the_constant_load_that_leaves_it_no_drift():
    # A carriage under a measured force walks off by whatever mean force the fit misses; its
    # position controller held it on the bench. without_drift finds the load by secant steps:
    # on a drift linear in the load (a free body sliding against viscous drag alone, mean rate
    # = (load - 3.7 N) / c) it lands on 3.7 N in two, with a drift below DRIFT_TOL of the swing.
    from jointrig.studies.chain_validate import DRIFT_TOL, without_drift

    omega, c = 2.0, 150.0
    t = np.linspace(0.0, 2 * np.pi / omega, 256, endpoint=False)
    calls = []

    def simulate(loads):
        calls.append(loads)
        v = 0.05 * np.cos(omega * t) + (loads[0] - 3.7) / c
        x = np.cumsum(v) * (t[1] - t[0])
        return ChainRecord(omega, t, [0.5 * np.cos(omega * t)], [x], [v])

    sim, used = without_drift(simulate, (0.0,), (0,), (30.0,))
    assert used[0] == pytest.approx(3.7, rel=1e-9) and len(calls) == 3
    assert abs(np.mean(sim.rate(0))) * 2 * np.pi / omega < DRIFT_TOL * np.std(sim.angles_rad[0])
    _, unchanged = without_drift(simulate, (1.0,), (), (30.0,))
    assert unchanged == (1.0,) and len(calls) == 4


def test_only_a_body_with_a_constant_and_no_spring_to_the_frame_is_held_against_drift():
    # studies.chain_validate.drifting_bodies: a fitted constant marks a body that may stick; a
    # spring to the frame anywhere in the line holds it (no search), none lets it walk off.
    from types import SimpleNamespace

    from jointrig.studies.chain_validate import drifting_bodies
    from jointrig.vocab.law import Constant, Coulomb

    free = ChainSpec((), grounds=((Coulomb(), Constant()),))
    sprung = ChainSpec((), grounds=((Coulomb(), Constant(), Power(1)),))
    plain = ChainSpec((), grounds=((Coulomb(),),))
    assert drifting_bodies(SimpleNamespace(spec=free)) == (0,)
    assert drifting_bodies(SimpleNamespace(spec=sprung)) == ()
    assert drifting_bodies(SimpleNamespace(spec=plain)) == ()


def identify_from(rec, spec, masks):
    from jointrig.identify.chain import solve_banded

    return solve_banded(chain_system([rec], spec, n_harmonics=40, first_harmonic=1, masks=masks))


def test_a_body_that_only_slides_through_rest_is_not_masked():
    # A sinusoid dwells below 3% of its peak rate for 1.9% of the period: no rest, no mask (its
    # harmonic balance is exact); a rate that rests a tenth of the period is masked there.
    from jointrig.identify.chain import stick_mask

    n = 4096
    phase = 2 * np.pi * np.arange(n) / n
    assert stick_mask(np.sin(phase)) is None
    assert stick_mask(np.sin(phase) * (1 + 0.3 * np.cos(2 * phase))) is None
    resting = np.sin(phase) * (np.abs(np.sin(phase)) > np.sin(0.05 * np.pi))
    mask = stick_mask(resting)
    assert mask is not None and mask[resting == 0].max() == 0 and np.all(mask[np.abs(resting) > 0.1] == 1)
    assert stick_mask(np.zeros(n)) is None


def test_the_bands_ripple_about_rest_is_no_slide():
    # A rate that rests 60% of its period, rings there at 15% of its peak (the band's ripple
    # about rest on a record of a joint that sticks most of its cycle) and slides twice: the mask
    # keeps the two slides (one across the period's end) and nothing of the ripple; a stretch
    # that reaches 30% of the peak is a slide.
    from jointrig.identify.chain import SLIP_PEAK_FRACTION, STICK_RATE_FRACTION, stick_mask

    n = 4000
    phase = 2 * np.pi * (np.arange(n) / n + 0.1)  # the first slide straddles the period's end
    slides = np.abs(np.sin(phase)) > np.sin(0.3 * np.pi)
    ripple = 0.15 * np.sin(200 * phase) * (np.abs(np.sin(phase)) < 0.2)  # about the middle of each rest
    rate = np.where(slides, np.sin(phase), 0.0) + ripple
    mask = stick_mask(rate)
    assert mask is not None and np.all(mask[~slides] == 0)
    assert np.all(mask[slides & (np.abs(rate) >= STICK_RATE_FRACTION)] == 1)
    assert np.count_nonzero(np.diff(np.r_[mask, mask[0]]) > 0) == 2
    bigger = stick_mask(np.where(slides, np.sin(phase), 0.0) + ripple * (SLIP_PEAK_FRACTION + 0.01) / 0.15)
    assert np.count_nonzero(np.diff(np.r_[bigger, bigger[0]]) > 0) > 2


def test_a_joint_that_sticks_most_of_its_cycle_is_fitted_where_it_slides():
    # The independent bench's paper joint with 650 N m of dry friction sticks 57-65% of the cycle
    # at 1500 N m (20-27% at 3500). Its bodies' sum holds no joint torque, so with the sum alone
    # the joint's law has no column at all; the undriven body's own equation where the joint
    # slides (issue 50) identifies it. Noise-free, 20 harmonics: c 0.03%, k 0.46%, gamma 1.6%,
    # the friction 0.02%, the inertias 0.02% (the band-limited balance beside the slides'
    # ends); bounded at 4x that for another machine's rounding of the events.
    from dataclasses import replace as _replace

    from bench_sim import PAPER, record, with_effect

    from jointrig.identify.chain import ChainRecord, chain_system
    from jointrig.identify.chain_diagnose import _Problem, nominal_spec, prepare_chain_runs, zeroed_joints
    from jointrig.vocab.law import Coulomb

    joint, M = with_effect(PAPER, Fc=650.0), 512
    recs = []
    for w, M0 in ((25.0, 1500.0), (25.0, 3500.0), (55.0, 1500.0), (55.0, 3500.0)):
        t, T, p1, p2 = record(joint, w, M0, fs_Hz=M * w / (2 * np.pi), n_periods=3.001, start_phase=0.3)
        recs.append(ChainRecord(w, t[:3 * M], (T[:3 * M], None), (p1[:3 * M], p2[:3 * M]), None, 3, M0, source=f"{w}"))
    runs = tuple(prepare_chain_runs(recs, band=20))
    spec = nominal_spec(2)
    spec = _replace(spec, joints=(spec.joints[0] + (Coulomb(),),))
    problem = _Problem(runs, 20, 4.0, 1e-3, (False, False), (True,))
    assert problem.merged() == [(0,)] * 4
    left_out = [1.0 - float(np.mean(m[0])) for m in problem.slipping()]
    assert left_out[0] > 0.55 and left_out[1] > 0.2, left_out
    # the sum alone: no row holds the joint's law; with the slides: every term has its rows
    averages = [r.average for r in runs]
    alone = chain_system(averages, spec, n_harmonics=20, first_harmonic=1, merged=problem.merged()).system
    both = chain_system(averages, spec, n_harmonics=20, first_harmonic=1, merged=problem.merged(),
                        slipping=problem.slipping()).system
    law = [k for k, n in enumerate(spec.names) if n.startswith("joint1_")]
    assert not np.any(alone.A[:, law]) and np.all(np.any(both.A[:, law], axis=0))
    assert set(both.row_equation.tolist()) == {0, 3}  # the sum (equation 0), body 2's own (N + 1)
    fit, _ = problem.fit(spec)
    got = fit.as_dict()
    for name, true, rel in (("joint1_c_Nms_per_rad", 100.0, 2e-3), ("joint1_k_Nm_per_rad", 2000.0, 2e-2),
                            ("joint1_gamma_Nm_per_rad3", 200.0, 7e-2), ("joint1_coulomb_torque_Nm", 650.0, 1e-3),
                            ("J1_kgm2", 2.0, 1e-3), ("J2_kgm2", 2.0, 1e-3)):
        assert abs(got[name] / true - 1) <= rel, (name, got[name])
    # a linear spring's zero matters where its body is balanced only while the joint slides
    linear = _replace(spec, joints=(tuple(t for t in spec.joints[0] if getattr(t, "power", 1) <= 1),))
    assert zeroed_joints(linear) == [] and zeroed_joints(linear, problem.slipping()) == [1]


def test_a_drives_lag_in_the_rig_acts_later_and_is_recorded_as_commanded():
    # A plant whose drives act tau = 0.2 ms after they are recorded: its angles are those of the
    # same plant without a lag under the drive turned by -n omega tau (to CALLBACK_RTOL: numpy's
    # complex exp below and cmath's in PeriodicDrive.delayed may round the coefficient's last bit
    # otherwise), and its record holds the drive as commanded, the cosine itself (to round-off,
    # 1e-12 of the level).
    from dataclasses import replace as dc_replace

    from jointrig.vocab.law import JointLaw
    from jointrig.identify.chain import ChainPlant
    from jointrig.vocab.plant import PeriodicDrive
    from jointrig.rig.chain import simulate_chain
    from jointrig.rig.simulate import SimulationConfig

    w, tau = 300.0, 2e-4
    plant = ChainPlant(tuple(JointLaw((Viscous(), Power(1)), (ci, ki)) for ci, ki in
                             zip((15.0, 20.0, 10.0), (4e5, 2.5e4, 1.2e5))), (0.0,) * 4)
    rig = load_chain(PUMP_TRAIN)
    cfg = SimulationConfig(samples_per_period=128, max_step_s=5e-5)
    lagged, _ = simulate_chain(rig.with_plant(dc_replace(plant, drive_delay_s=tau)), w,
                               {1: PeriodicDrive.cosine(w, 60.0)}, cfg)
    turned = PeriodicDrive(w, (0.0, 60.0 * np.exp(-1j * w * tau)))
    direct, _ = simulate_chain(rig.with_plant(plant), w, {1: turned}, cfg)
    for a, b in zip(lagged.angles_rad, direct.angles_rad):
        np.testing.assert_allclose(b, a, rtol=0, atol=CALLBACK_RTOL * np.abs(a).max())
    np.testing.assert_allclose(lagged.torques_Nm[0], 60.0 * np.cos(w * lagged.time_s), rtol=0, atol=1e-12 * 60.0)
    assert np.max(np.abs(direct.torques_Nm[0] - lagged.torques_Nm[0])) > 0.05 * 60.0


def test_a_delayed_record_is_the_record_shifted_in_time():
    # x(t - tau) of a band-limited periodic record (the drives' lag in a train's balance,
    # identify.harmonics.shift_periodic), exact to round-off (1e-13): two periods of
    # cos(w t) + 0.3 sin(3 w t) delayed by a fraction of a sample; no delay returns the record.
    from jointrig.identify.harmonics import shift_periodic

    w, tau, n = 5.0, 0.0123, 512
    t = np.arange(n) * (2 * 2 * np.pi / w) / n

    def x(s):
        return np.cos(w * s) + 0.3 * np.sin(3 * w * s)

    np.testing.assert_allclose(shift_periodic(x(t), 2, w, tau), x(t - tau), rtol=0, atol=1e-13)
    np.testing.assert_allclose(shift_periodic(x(t), 2, w, 0.0), x(t), rtol=0, atol=1e-13)


def test_the_banded_solve_weighs_rows_as_the_dense_one_does():
    # Row weights (a noise model) change the solution of rows that do not hold exactly: the block
    # QR with weights gives the dense weighted solve's values (to 1e-10).
    J, c, k = [0.5, 0.1, 0.8, 1.2], [2.0, 1.0, 3.0], [4e4, 2e4, 6e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0, 0], {1: 100.0, 4: 30j}, [30, 80, 150, 250])
    spec = ChainSpec(((Power(1),),) * 3)  # no damping in the model: the rows do not hold
    banded = chain_system(recs, spec, n_harmonics=3)
    w = np.random.default_rng(1).uniform(0.2, 5.0, banded.system.F.size)
    np.testing.assert_allclose(solve_banded(banded, row_weights=w).values, solve(banded.system, row_weights=w).values,
                               rtol=1e-10)
    assert not np.allclose(solve_banded(banded, row_weights=w).values, solve_banded(banded).values, rtol=1e-6)


def test_an_equation_weighted_by_ones_is_the_equation():
    # A mask of ones on every body's equation (joints on both sides, a law to ground) gives the
    # rows of the unmasked balance, to round-off (the masked inertia column is the spectral
    # acceleration's, the unmasked one j w times the rate's: 1e-9 of the largest entry).
    from jointrig.vocab.law import Coulomb

    J, c, k = [0.5, 0.1, 0.8], [2.0, 1.0], [4e4, 2e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0], {1: 100.0}, [30, 80, 150], n=128)
    spec = ChainSpec(((Viscous(), Power(1)),) * 2, bearings=(2,), grounds=((), (Coulomb(),), ()))
    plain = chain_system(recs, spec, n_harmonics=5).system
    ones = [tuple(np.ones(r.time_s.size) for _ in range(3)) for r in recs]
    masked = chain_system(recs, spec, n_harmonics=5, masks=ones).system
    scale = np.max(np.abs(plain.A))
    np.testing.assert_allclose(masked.A, plain.A, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(masked.F, plain.F, rtol=0, atol=1e-9 * np.max(np.abs(plain.F)))


def test_a_joint_that_sticks_is_balanced_exactly_by_its_bodies_summed_equation():
    # While a joint sticks, its torque is a reaction, not its law's: here an extra torque pair
    # +R, -R on its two bodies over a fifth of one run's period (a window: harmonics far above
    # the band). Balanced body by body, that run's rows leave R as a residual; with the joint's
    # two bodies' equations summed in that run (R cancels) the balance is exact, and the other
    # runs identify the joint's law: parameters to 1e-9, residual round-off. The banded solve of
    # the merged rows (a block whose band reaches the next body's) equals the dense one.
    J, c, k = [0.45, 0.06, 0.12, 0.35], [15.0, 20.0, 10.0], [4e5, 2.5e4, 1.2e5]
    recs = _linear_chain_records(J, c, k, [0.0] * 4, {1: 60.0}, [150.0, 300.0, 600.0, 1200.0], n=256)
    first = recs[0]
    phase = np.arange(first.time_s.size) / first.time_s.size
    R = np.where((phase > 0.3) & (phase < 0.5), 4.0, 0.0)
    stuck = ChainRecord(first.omega_rad_s, first.time_s, [first.torques_Nm[0], R, -R, None], first.angles_rad,
                        first.rates_rad_s)
    recs = [stuck] + recs[1:]
    spec = ChainSpec(((Viscous(), Power(1)),) * 3)
    truth = dict(zip(spec.names, [0.45, 15.0, 4e5, 0.06, 20.0, 2.5e4, 0.12, 10.0, 1.2e5, 0.35]))
    merged = [(1,), (), (), ()]
    banded = chain_system(recs, spec, n_harmonics=20, first_harmonic=1, merged=merged)
    res = solve_banded(banded)
    for name, value in zip(res.names, res.values):
        assert value == pytest.approx(truth[name], rel=1e-9), name
    assert res.relative_residual < 1e-10
    np.testing.assert_allclose(res.values, solve(banded.system).values, rtol=1e-9)
    # bodies 2 and 3 of the stuck run: one summed equation; every other run keeps four
    eqs = banded.system.row_equation[banded.system.row_record == 0]
    assert sorted(set(eqs.tolist())) == [0, 1, 3]
    assert solve_banded(chain_system(recs, spec, n_harmonics=20, first_harmonic=1)).relative_residual > 1e-3


def test_a_chain_sweep_store_of_another_simulator_version_is_not_reused(tmp_path, monkeypatch):
    # A change in how a law is simulated (a joint's dry friction now held by a constraint) must
    # not reuse a store's points: the store's default folder and its manifest carry the
    # simulator's version, and a store written by another version is refused before any run.
    from jointrig.rig.simulate import SimulationConfig
    from jointrig.studies import chain_sweep
    from jointrig.studies.sweep import SweepStoreMismatch

    rig = load_chain(PUMP_TRAIN)
    config = SimulationConfig(n_periods=2)
    here = chain_sweep.default_chain_store(rig, config, tmp_path)
    store = tmp_path / "store"
    store.mkdir()
    old = dict(chain_sweep._manifest(rig, config), simulator=chain_sweep.SIMULATOR_VERSION - 1)
    (store / "manifest.json").write_text(json.dumps(old))
    v = chain_sweep.SIMULATOR_VERSION
    with pytest.raises(SweepStoreMismatch, match=rf"another version of the simulator \(its manifest.json: {v - 1}, "
                                                 rf"this one: {v}\)"):
        chain_sweep.run_chain_sweep(rig, [(150.0, 60.0, 1)], config, store=store)
    monkeypatch.setattr(chain_sweep, "SIMULATOR_VERSION", chain_sweep.SIMULATOR_VERSION + 1)
    assert chain_sweep.default_chain_store(rig, config, tmp_path) != here


def test_a_records_channels_are_named_by_their_body_and_a_callers_array_stays_its_own():
    # A malformed channel is named by its body (1-based); a writeable array handed in is copied
    # (the caller may change it later), a read-only float array is shared (a record rebuilt with
    # one channel replaced keeps the others, and their memoised columns).
    from jointrig.vocab.records import RecordError

    t = np.arange(64) * 2 * np.pi / (10.0 * 64)
    x = np.sin(10.0 * t)
    with pytest.raises(RecordError, match="'angles_rad' of flywheel 2 has shape"):
        ChainRecord(10.0, t, [x, None], [x, x[:10]])
    with pytest.raises(RecordError, match="'torques_Nm' of flywheel 1 holds non-finite"):
        ChainRecord(10.0, t, [np.full(64, np.nan), None], [x, x])
    mine = x.copy()
    rec = ChainRecord(10.0, t, [mine, None], [mine, x])
    assert mine.flags.writeable and rec.angles_rad[0] is not mine and not rec.angles_rad[0].flags.writeable
    again = ChainRecord(10.0, t, rec.torques_Nm, rec.angles_rad)
    assert again.angles_rad[0] is rec.angles_rad[0] and again.torques_Nm[0] is rec.torques_Nm[0]


def test_a_joints_zero_offset_is_taken_off_its_twist():
    # Two bodies driven each, a cubic joint law of the twist less its zero u = phi1 - phi2 - o:
    # with the offset o in the spec the balance is exact (to round-off); with -o it is not.
    from jointrig.identify.chain import solve_banded

    J1, J2, k, g, o = 0.5, 0.2, 2.0e4, 3.0e8, 2e-3
    recs = []
    for w in (30.0, 70.0):
        n = 256
        t = np.arange(n) * 2 * np.pi / (w * n)
        p1, p2 = 0.01 * np.cos(w * t) + o, 0.004 * np.sin(w * t)
        u = p1 - p2 - o
        M = k * u + g * u**3
        T1 = J1 * -w**2 * (p1 - o) + M
        T2 = J2 * -w**2 * p2 - M
        recs.append(ChainRecord(w, t, [T1, T2], [p1, p2]))
    spec = ChainSpec(((Power(1), Power(3)),), offsets_rad=(o,))
    res = solve_banded(chain_system(recs, spec, n_harmonics=6, first_harmonic=1))
    np.testing.assert_allclose(res.values, [J1, k, g, J2], rtol=1e-9)
    wrong = solve_banded(chain_system(recs, ChainSpec(((Power(1), Power(3)),), offsets_rad=(-o,)), n_harmonics=6,
                                      first_harmonic=1))
    assert wrong.relative_residual > 1e-3


def test_the_banded_solve_refuses_bad_weights_and_its_covariance_is_the_dense_ones():
    # Weights that are not one finite positive number per row are refused; the standard errors
    # and covariance of the block QR are the dense weighted solve's (to 1e-9).
    J, c, k = [0.5, 0.1, 0.8, 1.2], [2.0, 1.0, 3.0], [4e4, 2e4, 6e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0, 0], {1: 100.0, 4: 30j}, [30, 80, 150, 250])
    banded = chain_system(recs, ChainSpec(((Power(1),),) * 3), n_harmonics=3)
    m = banded.system.F.size
    for bad in (np.ones(m - 1), np.r_[np.ones(m - 1), np.nan], np.r_[np.ones(m - 1), 0.0], -np.ones(m)):
        with pytest.raises(ValueError, match="row_weights must be"):
            solve_banded(banded, row_weights=bad)
    w = np.random.default_rng(1).uniform(0.2, 5.0, m)
    mine, dense = solve_banded(banded, row_weights=w), solve(banded.system, row_weights=w)
    np.testing.assert_allclose(mine.std_errors, dense.std_errors, rtol=1e-9)
    np.testing.assert_allclose(mine.covariance, dense.covariance, rtol=1e-8, atol=1e-12 * np.max(np.abs(dense.covariance)))


def test_a_plants_drag_and_laws_to_ground_sit_at_their_bodies():
    # A plant with drag at body 2 and a law to ground at body 3 names them there, its structure
    # holds them there, and the plant of its own values is itself.
    from jointrig.identify.chain import ChainPlant, plant_of_values
    from jointrig.vocab.law import Coulomb, JointLaw

    law = JointLaw((Viscous(), Power(1)), (2.0, 1e4))
    plant = ChainPlant((law, law, law), (0.0, 1.5, 0.0, 0.0), grounds=(None, None, JointLaw((Coulomb(),), (4.0,)), None))
    p = plant.parameters()
    assert p["bearing2_damping_Nms_per_rad"] == 1.5 and p["ground3_coulomb_torque_Nm"] == 4.0
    assert not any(k.startswith(("bearing1", "bearing3", "ground1", "ground2")) for k in p)
    spec = plant.spec()
    assert spec.bearings == (2,) and spec.grounds == ((), (), (Coulomb(),), ())
    again = plant_of_values(p, spec)
    assert again.bearings_Nms_per_rad == (0.0, 1.5, 0.0, 0.0) and again.grounds == plant.grounds


def test_a_channel_read_late_and_scaled_is_balanced_exactly_once_corrected():
    # Body 2's angle of an exact linear chain read 0.4 ms late and 3% too large (a multiplexed
    # DAQ's skew, a line count set wrong): with the spec's channel values the rows are exact again
    # (the truth to 1e-9), without them the fit misses; reading a record and correcting it gives
    # it back (to round-off: both are exact on its harmonics).
    from dataclasses import replace as rep

    from jointrig.identify.chain import channel_corrected

    J, c, k = [0.5, 0.1, 0.8], [2.0, 1.0], [4e4, 2e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0], {1: 100.0}, [30, 80, 150, 250])
    recs = [rep(r, rates_rad_s=None) for r in recs]
    spec = ChainSpec(((Viscous(), Power(1)),) * 2)
    read = rep(spec, channel_delays_s=(0.0, 4e-4, 0.0), channel_gains=(0.0, 0.03, 0.0))
    assert read.reads_channels and not spec.reads_channels
    measured = [channel_corrected(r, read, read=True) for r in recs]
    np.testing.assert_allclose(measured[0].angles_rad[1][:8], 1.03 * np.interp(
        recs[0].time_s[:8] - 4e-4, recs[0].time_s, recs[0].angles_rad[1], period=recs[0].time_s[-1] * 64 / 63),
        atol=2e-3 * np.ptp(recs[0].angles_rad[1]))  # a read 0.4 ms late, 3% large (interpolated: 0.2%)
    assert measured[0].angles_rad[0] is recs[0].angles_rad[0]  # body 1's channel is the reference
    back = channel_corrected(measured[1], read)
    np.testing.assert_allclose(back.angles_rad[1], recs[1].angles_rad[1], atol=1e-12 * np.ptp(recs[1].angles_rad[1]))
    truth = dict(zip(spec.names, [0.5, 2.0, 4e4, 0.1, 1.0, 2e4, 0.8]))
    fit = solve_banded(chain_system(measured, read, n_harmonics=3))
    for n, v in zip(fit.names, fit.values):
        assert v == pytest.approx(truth[n], rel=1e-9), n
    wrong = solve_banded(chain_system(measured, spec, n_harmonics=3))
    assert max(abs(v / truth[n] - 1) for n, v in zip(wrong.names, wrong.values)) > 1e-3


@pytest.mark.parametrize("field, values, message", [
    ("channel_delays_s", (1e-4, 0.0, 0.0), "0 for body 1"),
    ("channel_gains", (0.0, 0.1), "one finite number per body"),
    ("channel_gains", (0.0, -1.0, 0.0), "must be > -1"),
    ("channel_delays_s", (0.0, float("nan"), 0.0), "one finite number per body"),
])
def test_a_channels_skew_and_scale_are_checked(field, values, message):
    with pytest.raises(ValueError, match=message):
        ChainSpec(((Viscous(),),) * 2, **{field: values})


def test_a_banded_systems_density_is_the_share_of_its_blocks_and_masks_need_no_oversampling():
    J, c, k = [0.5, 0.1, 0.8], [2.0, 1.0], [4e4, 2e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0], {1: 100.0}, [30, 80])
    banded = chain_system(recs, ChainSpec(((Viscous(), Power(1)),) * 2), n_harmonics=3)
    m, p = banded.system.A.shape
    inside = np.zeros((m, p), bool)
    for r0, r1, c0, c1 in banded.spans:
        inside[r0:r1, c0:c1] = True
    assert banded.density == pytest.approx(inside.sum() / (m * p), rel=1e-15) and banded.density < 1
    assert not np.any(banded.system.A[~inside])  # nothing outside the blocks
    with pytest.raises(ValueError, match="masks need oversample 1"):
        chain_system(recs, ChainSpec(((Viscous(), Power(1)),) * 2), n_harmonics=3, oversample=2,
                     masks=[(np.ones(recs[0].time_s.size), None, None)] * len(recs))


def test_a_plant_refuses_grounds_of_another_length_and_a_negative_drag():
    from jointrig.identify.chain import ChainPlant
    from jointrig.vocab.law import JointLaw

    law = JointLaw((Power(1),), (1e4,))
    with pytest.raises(TypeError, match="one JointLaw or None per body"):
        ChainPlant((law,), (0.0, 0.0), (None,))
    with pytest.raises(TypeError, match="one JointLaw or None per body"):
        ChainPlant((law,), (0.0, 0.0), (None, "spring"))
    with pytest.raises(ValueError):
        ChainPlant((law,), (0.0, -1.0))


def test_a_banded_solves_results_are_read_only():
    # A result is shared by every caller that reads it (a profile's cache, the report): its
    # values, standard errors and covariance cannot be written.
    J, c, k = [0.5, 0.1, 0.8], [2.0, 1.0], [4e4, 2e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0], {1: 100.0}, [30, 80, 150, 250])
    res = solve_banded(chain_system(recs, ChainSpec(((Viscous(), Power(1)),) * 2), n_harmonics=3))
    for arr in (res.values, res.std_errors, res.covariance):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 0.0


def test_equations_masked_by_ones_are_the_unmasked_ones_whatever_each_joints_law():
    # A mask of ones keeps every sample: the masked rows are the unmasked ones (to round-off:
    # 1e-12 of the largest entry), each joint's own law at its own bodies (the joints' laws
    # differ: the masked path must take joint j's terms for body j + 1's left neighbour).
    J, c, k = [0.5, 0.1, 0.8], [2.0, 1.0], [4e4, 2e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0], {1: 100.0}, [30, 80, 150, 250])
    spec = ChainSpec(((Viscous(), Power(1)), (Viscous(), Power(1), Power(3))))
    plain = chain_system(recs, spec, n_harmonics=3).system
    ones = [tuple(np.ones(r.time_s.size) for _ in range(3)) for r in recs]
    masked = chain_system(recs, spec, n_harmonics=3, masks=ones).system
    scale = np.abs(plain.A).max()
    np.testing.assert_allclose(masked.A, plain.A, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(masked.F, plain.F, rtol=0, atol=1e-12 * np.abs(plain.F).max())


def test_a_spec_refuses_grounds_of_another_length_and_a_column_the_data_do_not_excite():
    # One tuple of law terms per body, no more, no fewer; and the parameters whose columns are
    # zero in every row (a body that never moves in the records: its inertia and its drag) are
    # named, not solved for.
    with pytest.raises(ValueError, match="one tuple of law terms per body"):
        ChainSpec(((Viscous(), Power(1)),), grounds=((),))
    J, c, k = [0.5, 0.1, 0.8], [2.0, 1.0], [4e4, 2e4]
    recs = _linear_chain_records(J, c, k, [0, 0, 0], {1: 100.0}, [30, 80, 150, 250])
    still = [ChainRecord(r.omega_rad_s, r.time_s, r.torques_Nm, r.angles_rad[:2] + (0 * r.angles_rad[2],),
                         r.rates_rad_s[:2] + (0 * r.rates_rad_s[2],)) for r in recs]
    system = chain_system(still, ChainSpec(((Viscous(), Power(1)),) * 2, bearings=(3,)), n_harmonics=3)
    with pytest.raises(ValueError, match=r"\['J3_kgm2', 'bearing3_damping_Nms_per_rad'\] have an all-zero column"):
        solve_banded(system)


def test_a_replay_started_on_the_measured_motion_reaches_that_steady_state():
    # A carriage (12 kg, 40 N s/m) with a linear motor's cogging (3 N, 10 mm pitch) driven at 47 N:
    # a steady state in every pitch of the cogging. From rest the rig settles in one; started from a
    # record's state at t = 0 (studies.chain_validate.start_of) it settles in that record's, here the
    # same motion a pitch on: its positions a pitch from the first's to 1e-6 of the swing (the rig's
    # settle tolerance, 1e-7, and the band-limited start).
    import math

    from jointrig.identify.chain import ChainPlant
    from jointrig.rig.chain import rig_of_bodies, simulate_chain
    from jointrig.rig.simulate import SimulationConfig
    from jointrig.studies.chain_validate import start_of
    from jointrig.vocab.law import Cogging, JointLaw
    from jointrig.vocab.plant import PeriodicDrive

    z, w = 2 * math.pi / 0.01, 12.566
    law = JointLaw((Viscous(), Cogging(z), Cogging(z, quadrature=True)), (40.0, 3.0, 0.0))
    rig = rig_of_bodies(1, (1,), "slide")
    plant = ChainPlant((), (0.0,), (law,))
    cfg = SimulationConfig(samples_per_period=256, max_step_s=2e-4, absolute_angles_periodic=False)
    drives = {1: PeriodicDrive.cosine(w, 47.0)}
    rest, _ = simulate_chain(rig, w, drives, cfg, plant=plant, inertias_kgm2=(12.0,), backend="python")
    angles, rates = start_of(rest, 20)
    shifted = (tuple(a + 0.01 for a in angles), rates)  # the same motion a pitch on
    again, _ = simulate_chain(rig, w, drives, cfg, plant=plant, inertias_kgm2=(12.0,), backend="python",
                              start=shifted)
    swing = float(np.ptp(rest.angles_rad[0]))
    np.testing.assert_allclose(again.angles_rad[0] - 0.01, rest.angles_rad[0], rtol=0, atol=1e-6 * swing)
    with pytest.raises(ValueError, match="one finite angle and rate per body"):
        simulate_chain(rig, w, drives, cfg, plant=plant, inertias_kgm2=(12.0,), start=((0.0, 1.0), (0.0, 0.0)))
