"""Speed and scale without loss: rollouts, adaptive steady state, continuation, a dask cluster,
and the peer methods of scripts/bench_rig.py (timings are in the benchmarks, not here)."""

from __future__ import annotations

import dataclasses
import math
import threading

import mujoco
import numpy as np
import pytest

from jointrig.vocab.plant import PeriodicDrive
from jointrig.rig import SimulationConfig, make_callback, passive_callback, simulate_steady_state
from jointrig.rig.simulate import relative_departure, settle_bound
from jointrig.studies.sweep import SweepPlan, records_of, run_sweep, simulate_segment

from conftest import PROCESS_RTOL, assert_records_agree, needs_cc
from conftest import assert_identical_records as _identical


def _light(rig):
    """The paper's joint with light damping (damping ratio 0.056): transients of ~100 periods."""
    return rig.with_plant(rig.law.with_values(c_Nms_per_rad=5.0))


# --- adaptive steady state (pure) ---------------------------------------------------------

def test_settle_bound_of_a_geometric_transient_is_its_remaining_sum():
    r = 0.6
    changes = [r**p for p in range(1, 30)]
    for p in range(3, 29):
        done, bound, ratio = settle_bound(changes[:p], 1e-6)
        remaining = r ** (p + 1) / (1 - r)  # exact distance still to go after period p: sum r^j, j > p
        assert ratio == pytest.approx(r, rel=1e-12)
        assert bound == pytest.approx(remaining, rel=1e-9)
        assert done == (bound < 1e-6)


def test_settle_bound_floor_uses_the_last_decay_rate():
    # Decays at r = 0.1, then stalls at a floor of 1e-12 (round-off / drift).
    changes = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1.1e-12, 1.0e-12]
    done, bound, r = settle_bound(changes, 1e-10)
    assert done and r == pytest.approx(0.1) and bound == pytest.approx(1.0e-12 / 0.9)
    # A floor that is not small enough is refused: c / (1 - r_d) = 1.1e-9 > 1e-9.
    assert not settle_bound(changes[:-3] + [9.9e-10, 9.9e-10], 1e-9)[0]


def test_settle_bound_refuses_without_decay():
    assert not settle_bound([1e-5], 1e-3)[0]                      # one change: no rate yet
    assert not settle_bound([1e-5, 1e-5, 1e-5], 1e-3)[0]          # never decayed: a slow transient
    assert not settle_bound([1e-5, 0.95e-5, 0.9e-5], 1e-4)[0]     # r = 0.95: too slow to bound here
    assert settle_bound([1e-2, 1e-9], 1e-3)[0]                    # round-off level: settle_tol * 1e-3


def test_a_run_that_cannot_settle_before_its_cap_is_foreseen_and_one_that_can_is_not():
    from jointrig.rig.simulate import DECAY_WINDOW, settles_in_time

    tol = 1e-7
    # no history to judge on yet
    assert settles_in_time([0.1] * DECAY_WINDOW, tol, 10)
    # no periodic response: the changes wander around 2% without decaying
    wander = [0.02 * (1 + 0.3 * math.sin(p)) for p in range(DECAY_WINDOW + 20)]
    assert not settles_in_time(wander, tol, 900)
    # the slowest transient of the validation runs (r = 0.9): at 2.7e-5 after 100 periods, 1e-7
    # is 53 periods away: fine with 30 left (twice is the margin), not with 20
    fast = [0.9 ** p for p in range(DECAY_WINDOW + 1)]
    assert settles_in_time(fast, tol, 30)
    assert not settles_in_time(fast, tol, 20)
    # a light transient (r = 0.995, from 1): ln(1e-7 / 0.6) / ln(0.995) = 3100 more periods,
    # more than twice the 1500 left but not more than twice 1600
    slow = [0.995 ** p for p in range(DECAY_WINDOW + 1)]
    assert not settles_in_time(slow, tol, 1500)
    assert settles_in_time(slow, tol, 1600)
    # at the tolerance already: nothing to foresee
    assert settles_in_time(wander[:-1] + [1e-8], tol, 0)


def test_changes_hovering_below_the_tolerance_without_decay_are_refused():
    from jointrig.rig.simulate import DECAY_WINDOW, settles_in_time

    # What an undamped mode leaves after an extrapolation jump took its transient away: changes
    # around 0.8 settle_tol that never decay, so settle_bound can never bound them.
    hover = [0.8e-9 * (1 + 0.2 * math.sin(p)) for p in range(DECAY_WINDOW + 5)]
    assert not settles_in_time(hover, 1e-9, 10_000)
    # ... while changes at the round-off level settle outright: nothing to foresee
    assert settles_in_time(hover[:-1] + [1e-13], 1e-9, 0)


def test_extrapolation_finds_a_linear_maps_fixed_point_from_dim_plus_one_differences():
    from jointrig.rig.simulate import extrapolated_fixed_point

    rng = np.random.default_rng(3)
    # a contracting 3-state map (complex pair 0.9 e^{+-0.5i} and 0.6, as a lightly damped
    # joint's period map), states of different scales (angle, two rates)
    R = np.array([[0.9 * math.cos(0.5), -0.9 * math.sin(0.5), 0], [0.9 * math.sin(0.5), 0.9 * math.cos(0.5), 0],
                  [0, 0, 0.6]])
    Q = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    A = np.diag([1e-2, 5.0, 5.0]) @ Q @ R @ Q.T @ np.diag([1e2, 0.2, 0.2])
    b = np.array([1e-3, 2.0, -1.0])
    fixed = np.linalg.solve(np.eye(3) - A, b)
    z = [np.array([0.0, 0.0, 0.0])]
    for _ in range(4):
        z.append(A @ z[-1] + b)
    # exact but for the regularisation: dim + 1 differences in dim dimensions make a singular
    # Gram matrix by construction, and its 1e-14 * trace ridge leaves ~1e-9 (measured 1.2e-9)
    np.testing.assert_allclose(extrapolated_fixed_point(z), fixed, rtol=1e-8, atol=1e-14)
    # three iterates of this map are not enough: the answer is off by far more
    assert np.max(np.abs(extrapolated_fixed_point(z[:3]) - fixed) / np.abs(fixed)) > 1e-4
    # and no answer when nothing moves
    assert extrapolated_fixed_point([fixed, fixed, fixed]) is None


@needs_cc
@pytest.mark.parametrize("omega, amplitude", [(30.0, 4000.0), (45.0, 4000.0), (60.0, 2500.0)])
def test_accelerated_settling_agrees_with_plain_settling_in_fewer_periods(rig, omega, amplitude):
    # The lightly damped joint (decay 0.6-0.78 per period): the extrapolation jumps may only
    # shorten the settling, never move the steady state beyond what the two bounds allow
    # (<= settle_tol = 1e-9 each) plus the integration floor (~1e-11 of the swing).
    light = _light(rig)
    plain, p_info = simulate_steady_state(light, omega, amplitude, SimulationConfig(accelerate=False), backend="native")
    fast, f_info = simulate_steady_state(light, omega, amplitude, SimulationConfig(), backend="native")
    assert relative_departure(fast, plain) <= p_info.error_bound + f_info.error_bound + 1e-10
    # the absolute angles repeat too (the jumps keep the angular momentum)
    assert f_info.error_bound < 1e-9
    # measured: 44 -> 18, 64 -> 23, 87 -> 23 periods
    assert f_info.periods_simulated <= 0.6 * p_info.periods_simulated


def test_a_model_without_a_periodic_response_is_refused_long_before_its_cap(rig):
    # An undamped joint driven off its resonance (44.7 rad/s against 30 rad/s): the free
    # oscillation started from rest never decays, so the response never repeats from period to
    # period. The run is stopped by the foresight rule, with the message saying so, not after
    # max_periods: within a hundred periods of the window filling up (measured: period 103).
    from jointrig.rig import SteadyStateNotReached
    from jointrig.vocab.law import JointLaw, Power, Viscous

    undamped = JointLaw((Viscous(), Power(1)), (0.0, 2000.0))
    with pytest.raises(SteadyStateNotReached, match=r"no steady state in sight after 1\d\d periods"):
        simulate_steady_state(rig, 30.0, 1000.0, SimulationConfig(max_periods=100_000), law=undamped, backend="native")


# --- the rig -------------------------------------------------------------------------------

@needs_cc
@pytest.mark.parametrize("omega", [20.0, 90.0])  # 3 and 1 integrator steps per sample
def test_native_rollout_periods_are_bit_identical_to_stepping(rig, omega):
    rolled, info_r = simulate_steady_state(rig, omega, 2500.0, SimulationConfig(n_periods=2), backend="native")
    stepped, info_s = simulate_steady_state(rig, omega, 2500.0, SimulationConfig(n_periods=2),
                                            backend="native-stepped")
    _identical(rolled, stepped)
    assert info_r.periods_simulated == info_s.periods_simulated


@needs_cc
def test_error_bound_holds_against_a_longer_run(rig):
    # Light damping near resonance: r ~ 0.7 per period, so the bound is far above the
    # integration floor (~1e-11) at settle_tol 1e-6; the reference runs 60 periods longer
    # (0.7^60 ~ 5e-10 of what is left: exact to 1e-15).
    light = _light(rig)
    cfg = SimulationConfig(settle_tol=1e-6, absolute_angles_periodic=False)
    rec, info = simulate_steady_state(light, 45.0, 4000.0, cfg, backend="native")
    n = info.periods_simulated + 60
    ref, _ = simulate_steady_state(light, 45.0, 4000.0, dataclasses.replace(cfg, min_periods=n, max_periods=n + 1,
                                                                            settle_tol=0.5), backend="native")
    err = relative_departure(rec, ref)
    assert 0.3 < info.decay_ratio < 0.95
    assert err <= info.error_bound
    # The bound is not vacuous: the error is within a factor 10 of it.
    assert err > info.error_bound / 10


@needs_cc
def test_continuation_reaches_the_same_steady_state(rig):
    light = _light(rig)
    cfg = SimulationConfig()
    tasks = [(w, 4000.0, None) for w in (40.0, 45.0, 50.0)]
    rest = simulate_segment(light, tasks, cfg, backend="native", continuation=False)
    cont = simulate_segment(light, tasks, cfg, backend="native", continuation=True)
    for a, b in zip(rest, cont):
        # Both within their bounds (<= settle_tol = 1e-9) of the same steady state, plus the
        # integration floor (~1e-11).
        assert relative_departure(b.record, a.record) <= a.settle.error_bound + b.settle.error_bound + 1e-10
    assert cont[0].settle.periods_simulated == rest[0].settle.periods_simulated  # first starts from rest


def test_start_state_keeps_a_general_drive_periodic(rig):
    # From a displaced state under a two-harmonic drive, the rigid rotation still repeats.
    from jointrig.rig.simulate import StartState

    drive = PeriodicDrive(30.0, (0, 1000.0, 200j))
    rec, info = simulate_steady_state(rig, 30.0, 1000.0, SimulationConfig(n_periods=2), drive=drive,
                                      start=StartState(0.3, -0.2, 5.0, -1.0))
    # The two logged periods repeat (relative angle, and the rates including the rigid one) to
    # twice the settle bound plus the integration floor (1e-11 of the swing).
    n = rec.samples_per_period
    for x in (rec.phi_rad, rec.rate1_rad_s, rec.rate2_rad_s):
        assert np.max(np.abs(x[:n] - x[n:])) < (2 * info.error_bound + 1e-11) * np.ptp(x)
    with pytest.raises(ValueError, match="finite"):
        simulate_steady_state(rig, 30.0, 1000.0, SimulationConfig(), start=StartState(math.nan, 0, 0, 0))


@needs_cc
def test_native_sessions_overlap_across_threads():
    from jointrig.rig.native_callback import native_session, session_active

    inside = threading.Barrier(2)
    seen = []

    def worker():
        with native_session():
            inside.wait()
            seen.append(session_active() and mujoco.get_mjcb_passive() is not None)
            inside.wait()

    threads = [threading.Thread(target=worker) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert seen == [True, True]
    assert mujoco.get_mjcb_passive() is None and not session_active()


# --- a dask cluster ------------------------------------------------------------------------

@pytest.mark.parametrize("backend", [pytest.param("native", marks=needs_cc), "python"])
def test_dask_local_cluster_of_two_workers_gives_the_local_records(rig, backend, tmp_path):
    pytest.importorskip("dask.distributed")
    plan = SweepPlan((10.0, 45.0, 90.0), (2500.0,))
    local = run_sweep(rig, plan, SimulationConfig(), backend=backend)
    store = tmp_path / "store"
    remote = run_sweep(rig, plan, SimulationConfig(), backend=backend, workers=2, executor="dask", store=store)
    for a, b in zip(records_of(local), records_of(remote)):  # another process (conftest.PROCESS_RTOL says why)
        assert_records_agree(a, b, rtol=PROCESS_RTOL)
    # The client stored every point; a second run resumes from the store without a cluster,
    # with the workers' records bit for bit.
    again = run_sweep(rig, plan, SimulationConfig(), store=store)
    assert all(p.from_store for p in again)
    for a, b in zip(records_of(remote), records_of(again)):
        _identical(a, b)


def test_executor_arguments_are_checked(rig):
    plan = SweepPlan((10.0,), (400.0,))
    with pytest.raises(ValueError, match="executor"):
        run_sweep(rig, plan, executor="ray")
    with pytest.raises(ValueError, match="scheduler"):
        run_sweep(rig, plan, scheduler="tcp://nowhere:8786")


# --- peers ---------------------------------------------------------------------------------

def test_native_polynomial_stiffness_agrees_with_the_callback_law(rig):
    """MuJoCo's own stiffness="k 0 gamma" and damping c on a relative hinge (studies/peers.py) and
    the rig's passive callback give the same free decay: an independent check of the law."""
    from jointrig.studies.peers import peer_model_xml

    h, n, phi0 = 5e-4, 2000, 0.4
    m = rig.model.__copy__()
    m.opt.timestep = h
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    d = mujoco.MjData(m)
    q1, q2 = rig.qpos_adr
    d.qpos[q1], d.qpos[q2] = phi0 / 2, -phi0 / 2
    ours = np.empty(n)
    with passive_callback(make_callback(rig, rig.law, PeriodicDrive.cosine(1.0, 0.0), [])):
        for i in range(n):
            mujoco.mj_step(m, d)
            ours[i] = d.qpos[q1] - d.qpos[q2]
    law = rig.law.as_dict()
    pm = mujoco.MjModel.from_xml_string(peer_model_xml(rig.J1_kgm2, rig.J2_kgm2, law["k_Nm_per_rad"],
                                                       law["c_Nms_per_rad"], law["gamma_Nm_per_rad3"], h))
    pd = mujoco.MjData(pm)
    pd.qpos[:] = (phi0 / 2, -phi0)  # flywheel 2 relative to flywheel 1
    theirs = np.empty(n)
    for i in range(n):
        mujoco.mj_step(pm, pd)
        theirs[i] = -pd.qpos[1]
    # Same ODE, same RK4 step, different coordinates and summation order: round-off only.
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-12 * phi0)
    assert abs(ours[-1]) < 1e-3 * phi0  # it decayed: the comparison covered the whole motion


@pytest.fixture(scope="session")  # once per worker, even when xdist interleaves other modules
def peer_records(rig):
    pytest.importorskip("mujoco.sysid._src")
    points = run_sweep(rig, SweepPlan((10.0, 45.0, 90.0), (4000.0,)), SimulationConfig())
    return records_of(points), [p.settle.timestep_s for p in points]


def test_mujoco_sysid_recovers_the_joint_with_shifted_sensor_times(rig, peer_records):
    from jointrig.studies.peers import sysid_identify

    records, steps = peer_records
    truth = rig.law.as_dict()
    start = {"k_Nm_per_rad": 2600.0, "c_Nms_per_rad": 70.0, "gamma_Nm_per_rad3": 400.0}
    got = sysid_identify(records, rig.J1_kgm2, rig.J2_kgm2, start, steps)
    # 2e-3: the held control is the drive averaged over each step, which the rig does not
    # hold (measured 7e-4 on gamma, 3e-5 on k, 2e-5 on c for these records).
    for name, value in truth.items():
        assert got.parameters[name] == pytest.approx(value, rel=2e-3), name
    # Without the one-step shift of the sensor times, gamma is off by ~30% (the pitfall).
    unshifted = sysid_identify(records, rig.J1_kgm2, rig.J2_kgm2, start, steps, _sensor_shift_steps=0.0)
    assert abs(unshifted.parameters["gamma_Nm_per_rad3"] / truth["gamma_Nm_per_rad3"] - 1) > 0.05


def test_pysindy_recovers_the_joint(rig, peer_records):
    pytest.importorskip("pysindy")
    from jointrig.studies.peers import sindy_identify

    records, _ = peer_records
    got = sindy_identify(records, rig.J1_kgm2, rig.J2_kgm2)
    # 2e-3: second-order finite differences at 256 samples per period err by
    # ~(2 pi / 256)^2 / 6 = 1e-4 in the acceleration, more on the small cubic term.
    for name, value in rig.law.as_dict().items():
        assert got.parameters[name] == pytest.approx(value, rel=2e-3), name


def test_dask_workers_simulate_the_clients_law_not_the_files(rig):
    # A rig given another law in memory has the same file (and digest): the workers must get
    # the law with the task, or they would silently simulate the file's.
    pytest.importorskip("dask.distributed")
    light = _light(rig)
    plan = SweepPlan((45.0,), (2500.0,))
    local = records_of(run_sweep(light, plan, SimulationConfig()))
    remote = records_of(run_sweep(light, plan, SimulationConfig(), workers=1, executor="dask"))
    assert_records_agree(local[0], remote[0], rtol=PROCESS_RTOL)  # not the file's law (c 100, not 5)


def test_law_with_values_changes_only_the_named_parameters(rig):
    light = rig.law.with_values(c_Nms_per_rad=5.0)
    assert light.as_dict() == {**rig.law.as_dict(), "c_Nms_per_rad": 5.0} and light.terms == rig.law.terms
    with pytest.raises(ValueError, match="no parameters"):
        rig.law.with_values(k_bogus=1.0)
