"""The native (C) passive callback computes what the Python reference computes, to the rounding of
the elementary functions (conftest.CALLBACK_RTOL says why not bit for bit on every machine)."""


import mujoco
import pytest

from jointrig.vocab.plant import PeriodicDrive
from jointrig.rig import SimulationConfig, load_rig, simulate_steady_state
from jointrig.studies.hidden_effects import HIDDEN_EFFECTS

from conftest import CALLBACK_RTOL, MODELS_DIR, assert_records_agree as _agree, needs_cc

pytestmark = needs_cc


# Every Python run below names its backend: the default ("auto") is the native callback where a
# C compiler is found, and a comparison of the default with "native" would hold C against itself
# (it did, until scripts/deliberate_faults.py found a fault in the Python step that no test caught).


@pytest.mark.parametrize("case", list(HIDDEN_EFFECTS))
def test_every_effect_gives_identical_trajectories(rig, case):
    plant = HIDDEN_EFFECTS[case][0]
    cfg = SimulationConfig(n_periods=2)
    python, _ = simulate_steady_state(rig, 40.0, 2500.0, cfg, law=plant, backend="python")
    native, _ = simulate_steady_state(rig, 40.0, 2500.0, cfg, law=plant, backend="native")
    _agree(python, native)


def test_an_iwan_joint_stepped_in_c_gives_identical_trajectories(rig):
    # 33 sliders committed after every step in C (jointrig_run) against the Python loop (32
    # elements, not the default 128: the C and Python steps loop over any count alike, and the
    # Python loop's time grows with it, 3.3 s against 9.4 s).
    from jointrig.vocab.law import Iwan, JointLaw, Power, Viscous

    law = JointLaw((Viscous(), Power(1), Iwan(0.02, -0.3, 0.1, elements=32)), (5.0, 500.0, 40.0))
    cfg = SimulationConfig(n_periods=2)
    _agree(simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="python")[0],
               simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="native")[0])


def test_a_stribeck_friction_gives_identical_trajectories(rig):
    from jointrig.vocab.law import Coulomb, JointLaw, Power, Stribeck, Viscous

    law = JointLaw((Viscous(), Power(1), Coulomb(), Stribeck(0.5)), (5.0, 500.0, 20.0, 15.0))
    cfg = SimulationConfig(n_periods=2)
    _agree(simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="python")[0],
               simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="native")[0])


def test_a_tanh_friction_gives_identical_trajectories(rig):
    from jointrig.vocab.law import JointLaw, Power, TanhFriction, Viscous

    law = JointLaw((Viscous(), Power(1), TanhFriction(0.5)), (5.0, 500.0, 20.0))
    cfg = SimulationConfig(n_periods=2)
    _agree(simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="python")[0],
               simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="native")[0])


def test_a_cogging_torque_gives_identical_trajectories(rig):
    from jointrig.vocab.law import Cogging, JointLaw, Power, Viscous

    law = JointLaw((Viscous(), Power(1), Cogging(125.0), Cogging(125.0, True)), (5.0, 500.0, 30.0, -20.0))
    cfg = SimulationConfig(n_periods=2)
    _agree(simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="python")[0],
               simulate_steady_state(rig, 25.0, 400.0, cfg, law=law, backend="native")[0])


def test_a_damping_in_contact_gives_identical_trajectories(rig):
    from jointrig.vocab.law import ContactDamping, JointLaw, Power

    law = JointLaw((ContactDamping(0.02), Power(1, 0.02), Power(3, 0.02)), (100.0, 2000.0, 200.0))
    cfg = SimulationConfig(n_periods=2)
    _agree(simulate_steady_state(rig, 25.0, 1500.0, cfg, law=law, backend="python")[0],
           simulate_steady_state(rig, 25.0, 1500.0, cfg, law=law, backend="native")[0])


def test_hat_law_and_a_replayed_multiharmonic_drive(rig):
    drive = PeriodicDrive(30.0, (0, 1000.0, 50 - 20j, 0, 10j))
    _agree(simulate_steady_state(rig, 30.0, 1000.0, SimulationConfig(), drive=drive, backend="python")[0],
               simulate_steady_state(rig, 30.0, 1000.0, SimulationConfig(), drive=drive, backend="native")[0])
    hat = load_rig(MODELS_DIR / "two_flywheels_hat.xml")
    _agree(simulate_steady_state(hat, 30.0, 1000.0, SimulationConfig(), backend="python")[0],
               simulate_steady_state(hat, 30.0, 1000.0, SimulationConfig(), backend="native")[0])


def test_a_drive_of_two_hundred_harmonics_is_replayed_natively_and_more_than_the_rig_takes_refused(rig):
    # A fit at --band 100 replays drives of 100 harmonics, and a held-out record's drive with
    # force pulses holds harmonics far above a fit's band (studies.chain_validate.held_drive_lines):
    # harmonics 0..200 run in C as in Python (to CALLBACK_RTOL, conftest); the rig's drive takes
    # harmonics up to MAX_HARM - 1 (255), and a longer one is refused by name.
    import numpy as np

    from jointrig.rig.native_callback import MAX_HARM

    rng = np.random.default_rng(1)
    coeffs = (0, 1000.0) + tuple(complex(*(3.0 * rng.standard_normal(2))) for _ in range(199))
    drive = PeriodicDrive(30.0, coeffs)
    cfg = SimulationConfig(n_periods=1, max_step_s=5e-5)
    _agree(simulate_steady_state(rig, 30.0, 1000.0, cfg, drive=drive, backend="python")[0],
           simulate_steady_state(rig, 30.0, 1000.0, cfg, drive=drive, backend="native")[0])
    too_long = PeriodicDrive(30.0, (0, 1000.0) + (1.0,) * (MAX_HARM - 1))
    with pytest.raises(ValueError, match=f"harmonics up to {MAX_HARM - 1}"):
        simulate_steady_state(rig, 30.0, 1000.0, cfg, drive=too_long, backend="native")


def test_parallel_native_sweep_equals_the_serial_python_sweep(rig, tmp_path):
    # Threads share the one installed native callback, each simulation finding its own
    # parameters by its MjData; every point is independent, so the records are identical.
    from jointrig.studies.sweep import SweepPlan, records_of, run_sweep

    plan = SweepPlan(omegas_rad_s=(10.0, 45.0, 90.0), amplitudes_Nm=(400.0, 4000.0))
    serial = records_of(run_sweep(rig, plan, SimulationConfig(), backend="python"))
    parallel = records_of(run_sweep(rig, plan, SimulationConfig(), backend="native", workers=2, store=tmp_path / "s"))
    for a, b in zip(serial, parallel):
        _agree(a, b)
    assert mujoco.get_mjcb_passive() is None
    with pytest.raises(ValueError, match="needs the native callback"):
        run_sweep(rig, plan, SimulationConfig(), backend="python", workers=2)


def test_the_oscillator_free_run_in_c_is_the_python_free_run():
    # The Silverbox's free runs: a one-degree-of-freedom law with even and odd stiffness, a rate
    # monomial and an input delay (so the input is zero for the first stage times), under a
    # sampled random input; the C block against the Python callback, every sample within
    # CALLBACK_RTOL of the output's peak.
    import numpy as np

    from jointrig.identify.signals import BandlimitedInput
    from jointrig.rig.oscillator import simulate_free_run
    from jointrig.vocab.law import JointLaw, Monomial, Power, Viscous

    law = JointLaw((Viscous(), Power(1), Power(2), Power(3), Monomial(2, 1)), (0.3, 900.0, -40.0, 2e4, 5.0))
    u = BandlimitedInput(np.random.default_rng(3).normal(0.0, 0.5, 700), 610.35)
    runs = {b: simulate_free_run(law, 1.0, u, 700, 610.35, substeps=8, delay_s=2.5e-4, backend=b)
            for b in ("python", "native")}
    assert np.std(runs["python"]) > 1e-4  # it moves
    np.testing.assert_allclose(runs["native"], runs["python"], rtol=0,
                               atol=CALLBACK_RTOL * np.abs(runs["python"]).max())


def test_auto_backend_falls_back_to_python_where_native_cannot_run(rig, monkeypatch):
    # No compiler on the machine: "auto" simulates with the Python callback (and says why not),
    # an explicit choice is kept; with a compiler, a law with a term that has no C case falls
    # back too. The Python run is checked to be the very run the explicit Python backend gives.
    from jointrig.rig import native_callback as nc
    from jointrig.vocab.law import JointLaw, Power, Term, Viscous

    monkeypatch.setattr(nc, "_checked", True)
    monkeypatch.setattr(nc, "_unavailable", "no C compiler found (set CC)")
    assert nc.unsupported([rig.plant]) == "no C compiler found (set CC)"
    assert nc.choose_native("auto", [rig.plant]) is False
    assert nc.choose_native("native", [rig.plant]) is True
    assert nc.choose_native("python", [rig.plant]) is False
    with pytest.raises(ValueError, match="backend must be one of .*'auto'.*got 'C'"):
        nc.choose_native("C", [rig.plant])
    with pytest.raises(ValueError, match="backend must be one of"):
        simulate_steady_state(rig, 40.0, 2500.0, SimulationConfig(), backend="fast")
    cfg = SimulationConfig(n_periods=1)
    auto, _ = simulate_steady_state(rig, 40.0, 2500.0, cfg)
    python, _ = simulate_steady_state(rig, 40.0, 2500.0, cfg, backend="python")
    _agree(auto, python)

    monkeypatch.setattr(nc, "_unavailable", None)

    class Cubed(Term):  # a user's own term: Python only
        name = "cubed_rate_Nms3_per_rad3"

        def __call__(self, phi, rate):
            return rate**3

    law = JointLaw((Viscous(), Power(1), Cubed()), (100.0, 2000.0, 0.01))
    assert "no term Cubed" in nc.unsupported([law])
    assert nc.choose_native("auto", [law]) is False
    assert nc.choose_native("auto", [rig.plant]) is True
