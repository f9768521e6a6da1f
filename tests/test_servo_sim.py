"""Checks of tests/bench_servo_sim.py, the independent simulator of a position-controlled linear
axis (PD loop at 1 kHz, exact event-driven stick-slip). Nothing here uses jointrig: the
references are closed forms, a fine fixed-step integration and conservation of energy."""

from __future__ import annotations

import math

import numpy as np
import pytest

import bench_servo_sim as bench

# The records are built once per worker (a module fixture caches them); the tests are grouped so
# that each of pytest-xdist's two workers builds about half of them (about 6 s each).
GROUP = {"sticky": "servo_sim_a", "incline": "servo_sim_a", "sticky+pulses": "servo_sim_a",
         "heavy_chain": "servo_sim_b", "light_fast": "servo_sim_b", "sticky_incline": "servo_sim_b"}
RECORD_KEYS = [pytest.param(k, marks=pytest.mark.xdist_group(GROUP[k]))
               for k in [*bench.CASES, "sticky+pulses"]]
CASE_NAMES = [pytest.param(k, marks=pytest.mark.xdist_group(GROUP[k])) for k in bench.CASES]
group_a = pytest.mark.xdist_group("servo_sim_a")
group_b = pytest.mark.xdist_group("servo_sim_b")


WRITTEN = "sticky"   # this case is made by write_case (its files are checked, its records reused)


@pytest.fixture(scope="module")
def case_folder(tmp_path_factory):
    return tmp_path_factory.mktemp("servo_case")


@pytest.fixture(scope="module")
def records(case_folder):
    cache = {}

    def get(key):
        if key not in cache:
            name, _, extra = key.partition("+")
            if name == WRITTEN:
                truth, cache[name], cache[name + "+pulses"] = bench.write_case(
                    case_folder, name, seed=0, return_records=True)
                cache["truth"] = truth
            else:
                cache[key] = bench.simulate_case(name, pulses=extra == "pulses", seed=1 if extra else 0)
        return cache[key]
    return get


def _periods(rec):
    n_per = int(round(rec.truth["period_s"] * rec.truth["fs_hz"]))
    assert abs(n_per - rec.truth["period_s"] * rec.truth["fs_hz"]) < 1e-9
    return n_per


# --------------------------------------------------------------------------- the integrator

def _rk4_span(axis, x, v, forces, dt, substeps):
    """Classical RK4, fixed step dt / substeps, F held over each interval, sliding in the sign of
    the initial v (the span has no stick; asserted on the way)."""
    s = math.copysign(1.0, v)
    h = dt / substeps
    m, c, Fc, F0 = axis.m, axis.c, axis.Fc, axis.F0
    xs, vs = [x], [v]
    for F in forces:
        def acc(vv):
            return (F - c * vv - Fc * s - F0) / m
        for _ in range(substeps):
            k1x, k1v = v, acc(v)
            k2x, k2v = v + 0.5 * h * k1v, acc(v + 0.5 * h * k1v)
            k3x, k3v = v + 0.5 * h * k2v, acc(v + 0.5 * h * k2v)
            k4x, k4v = v + h * k3v, acc(v + h * k3v)
            x += h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x)
            v += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
            assert v * s > 0, "the span was to have no stick"
        xs.append(x)
        vs.append(v)
    return np.array(xs), np.array(vs)


@group_a
def test_sliding_span_matches_fine_fixed_step_integration(records):
    """300 sliding hold intervals of a closed-loop record, re-integrated by RK4 at 50 us steps with
    the logged (applied) forces. RK4's own error is ~(h c/m)^5 / 120 ~ 1e-20 relative, nothing;
    solve_ivp restarts every interval, so its error may add up over the n intervals to at most
    n (rtol |state| + atol). Tolerance: that bound (about 1e-9 m, 1e-9 m/s here)."""
    rec = records("incline")
    axis = bench.CASES["incline"]["axis"]
    n_span = 300
    ev_t = np.array([e[0] for e in rec.events])
    dt = 1.0 / rec.truth["fs_hz"]
    # the first window of n_span intervals with no event (stick, slip, reversal) within a sample of it
    k0 = next(k for k in range(0, rec.t_s.size - n_span - 1, 25)
              if rec.v_true_m_s[k] != 0.0
              and not np.any((ev_t >= rec.t_s[k] - dt) & (ev_t <= rec.t_s[k + n_span] + dt)))
    assert np.all(rec.v_true_m_s[k0:k0 + n_span + 1] * rec.v_true_m_s[k0] > 0)
    sl = slice(k0, k0 + n_span + 1)
    xs, vs = _rk4_span(axis, rec.x_true_m[k0], rec.v_true_m_s[k0],
                       rec.force_applied_N[k0:k0 + n_span], dt, substeps=20)
    tol_x = n_span * (bench.RTOL * np.abs(xs).max() + bench.ATOL[0])
    tol_v = n_span * (bench.RTOL * np.abs(vs).max() + bench.ATOL[1])
    assert np.abs(rec.x_true_m[sl] - xs).max() <= tol_x
    assert np.abs(rec.v_true_m_s[sl] - vs).max() <= tol_v
    assert tol_x < 2e-9 and tol_v < 2e-9


def _stop_time(axis, v0: float, F: float) -> float:
    """When a carriage sliding forwards at v0 under a held force F comes to rest (closed form)."""
    a = (F - axis.F0 - axis.Fc) / axis.c
    return axis.m / axis.c * math.log((v0 - a) / (-a))


def _closed_form(axis, v0, F, s, tau):
    """x - x0 and v after tau of sliding in sign s from v0 under the constant force F."""
    a = (F - axis.F0 - axis.Fc * s) / axis.c          # the rate it tends to
    k = axis.c / axis.m
    v = a + (v0 - a) * math.exp(-k * tau)
    dx = a * tau + (v0 - a) * (1.0 - math.exp(-k * tau)) / k
    return dx, v


def test_stick_and_reversal_inside_one_interval_match_closed_form():
    """Within a hold interval the sliding motion is an exponential in closed form. A carriage
    braked to rest sticks where v = 0 (|F - F0| <= Fc); one pushed hard enough reverses there and
    slides back. Tolerances: event time 1e-9 s and states 1e-11 (rtol 1e-10 on states of ~0.1,
    root finding to machine precision on the dense output)."""
    axis = bench.Axis(m=20.0, c=100.0, Fc=30.0, F0=10.0)
    dt = 1e-3
    # stick: v0 = 2 mm/s forwards, F - F0 = -20 N (|.| <= Fc): stops after about 0.8 ms
    v0, F = 0.002, -10.0
    t_star = _stop_time(axis, v0, F)
    assert 0 < t_star < dt
    res = bench.hold_interval(axis, 0.0, dt, 0.01, v0, F)
    assert [e[1] for e in res.events] == ["stick"]
    assert abs(res.events[0][0] - t_star) < 1e-9
    dx, _ = _closed_form(axis, v0, F, 1.0, t_star)
    assert res.v == 0.0 and abs(res.x - (0.01 + dx)) < 1e-11
    assert abs(res.stuck_time - (dt - t_star)) < 1e-9
    # reversal: F - F0 = -90 N < -Fc: stops at t1 and slides backwards to dt
    v0, F = 0.002, -80.0
    t1 = _stop_time(axis, v0, F)
    assert 0 < t1 < dt
    res = bench.hold_interval(axis, 0.0, dt, 0.0, v0, F)
    assert [e[1] for e in res.events] == ["reverse"]
    assert abs(res.events[0][0] - t1) < 1e-9
    dx1, _ = _closed_form(axis, v0, F, 1.0, t1)
    dx2, v2 = _closed_form(axis, 0.0, F, -1.0, dt - t1)
    assert abs(res.x - (dx1 + dx2)) < 1e-11 and abs(res.v - v2) < 1e-11 and res.v < 0
    # break-away from rest: only if |F - F0| > Fc, then in the direction of F - F0
    assert bench.hold_interval(axis, 0.0, dt, 0.0, 0.0, 39.9).stuck_time == dt
    res = bench.hold_interval(axis, 0.0, dt, 0.0, 0.0, -20.5)
    assert res.events[0][1] == "slip" and res.x < 0 and res.v < 0


# --------------------------------------------------------------------------- stick-slip

@pytest.mark.parametrize("key", RECORD_KEYS)
def test_stick_slip_conditions(records, key):
    """Exact, not approximate: while stuck v == 0.0 and x does not change (bit for bit) and
    |F - F0| <= Fc; every slide start (and every sample at rest that is not stuck) has
    |F - F0| > Fc and moves in the direction of F - F0; every stick has |F - F0| <= Fc."""
    rec = records(key)
    ax = rec.truth["axis"]
    F0, Fc = ax["F0"], ax["Fc"]
    net = rec.force_applied_N - F0
    k = np.nonzero(rec.stuck[:-1])[0]
    assert k.size > 0
    assert np.all(rec.v_true_m_s[k] == 0.0) and np.all(rec.v_true_m_s[k + 1] == 0.0)
    assert np.all(rec.x_true_m[k + 1] == rec.x_true_m[k])
    assert np.all(np.abs(net[k]) <= Fc)
    # at rest at a sample but not stuck: breaks away in the interval
    j = np.nonzero((rec.v_true_m_s[:-1] == 0.0) & ~rec.stuck[:-1])[0]
    assert j.size > 0
    assert np.all(np.abs(net[j]) > Fc)
    assert np.all(np.sign(rec.x_true_m[j + 1] - rec.x_true_m[j]) == np.sign(net[j]))
    slips = [e for e in rec.events if e[1] == "slip"]
    sticks = [e for e in rec.events if e[1] == "stick"]
    assert len(slips) == j.size
    assert all(abs(e[2]) > Fc for e in slips) and all(abs(e[2]) <= Fc for e in sticks)
    # the force at each event is the one held over its interval
    dt = 1.0 / rec.truth["fs_hz"]
    for e in rec.events:
        kk = min(int(math.floor(e[0] / dt + 1e-9)), rec.t_s.size - 1)
        assert e[2] == net[kk]
    # a sliding carriage never has v == 0.0 at a sample unless it stuck
    moving = rec.v_true_m_s != 0.0
    assert not np.any(moving[:-1] & rec.stuck[:-1])


def _dwell_runs(stuck, gap):
    """(start, end) of the stretches where the carriage is stuck, micro-slips of at most ``gap``
    samples between stuck intervals (noise on the rate estimate nudging it near Fc) merged."""
    idx = np.nonzero(stuck)[0]
    if idx.size == 0:
        return []
    breaks = np.nonzero(np.diff(idx) > gap + 1)[0]
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]] + 1
    return list(zip(starts, ends))


@group_a
def test_sticky_case_sticks_at_reversals(records):
    """The 'sticky' case stands still for a noticeable part of the cycle (>= 8 % of the time), and
    its long dwells (> 50 ms; micro-slips of <= 5 ms inside merged) are reversals: the carriage
    moves one way over the 100 ms before and the other way over the 100 ms after, by > 0.1 mm."""
    rec = records("sticky")
    assert rec.truth["stuck_time_fraction"] >= 0.08
    runs = [(a, b) for a, b in _dwell_runs(rec.stuck, 5) if b - a > 50]
    assert len(runs) >= 6   # two reversals per period, 3.5 periods
    x = rec.x_true_m
    for a, b in runs:
        if a >= 100 and b + 100 < x.size:
            before, after = x[a] - x[a - 100], x[b + 100] - x[b]
            assert before * after < 0 and min(abs(before), abs(after)) > 1e-4
            assert np.abs(x[a:b] - x[a]).max() < 5e-6   # stands (micro-slips of a few um at most)


# --------------------------------------------------------------------------- energy

@pytest.mark.parametrize("key", RECORD_KEYS)
def test_energy_balance(records, key):
    """Work of F - F0 = change of kinetic energy + energy dissipated by c and by Fc. The work is
    exact from the samples (F is constant over each interval: sum (F_k - F0)(x_k+1 - x_k)); the
    dissipations are integrals carried by the integrator. Tolerance 1e-8 of the gross work
    (100 x rtol). Also: Fc's dissipation is Fc times the distance travelled (no reversal inside an
    interval in these records), same tolerance."""
    rec = records(key)
    ax = rec.truth["axis"]
    dx = np.diff(rec.x_true_m)
    dw = (rec.force_applied_N[:-1] - ax["F0"]) * dx
    work = dw.sum()
    dke = 0.5 * ax["m"] * (rec.v_true_m_s[-1] ** 2 - rec.v_true_m_s[0] ** 2)
    diss = rec.diss_c_J[-1] + rec.diss_f_J[-1]
    gross = np.abs(dw).sum()
    assert diss > 0.1 * gross
    assert abs(work - dke - diss) <= 1e-8 * gross
    assert rec.truth["n_events"]["reverse"] == 0
    assert abs(rec.diss_f_J[-1] - ax["Fc"] * np.abs(dx).sum()) <= 1e-8 * gross


# --------------------------------------------------------------------------- the loop

@pytest.mark.parametrize("name", CASE_NAMES)
def test_periodic_steady_state_after_transient(records, name):
    """From rest the loop settles to a periodic steady state. Bound: the record's last two periods
    of the true position agree within 0.1 % of the stroke (the encoder noise, a few um, moves
    the stick positions and the loop by about that; measured 2-4 um); the first period differs
    from the third by more than 0.3 % of the stroke (the start from rest); the transient is over
    within half a period; tracking error after the first period below 6 % of the stroke (the
    friction's dead band Fc / (gain Kp) makes most of it)."""
    rec = records(name)
    n_per = _periods(rec)
    n = rec.t_s.size
    assert 3 * n_per <= n <= 4 * n_per
    x = rec.x_true_m * 1e3
    stroke = rec.truth["stroke_mm"]
    bound = 1e-3 * stroke
    last_two = np.abs(x[n - 2 * n_per:n - n_per] - x[n - n_per:]).max()
    assert last_two <= bound
    d_first = np.abs(x[:n_per] - x[2 * n_per:3 * n_per])
    assert d_first.max() > 3 * bound
    assert np.nonzero(d_first > bound)[0].max() < n_per // 2
    # starts at rest, at the encoder's zero
    assert rec.x_true_m[0] == 0.0 and rec.v_true_m_s[0] == 0.0
    sensor = rec.truth["sensor"]
    assert abs(rec.y_measured_mm[0] - sensor["zero_mm"]) <= 5 * sensor["noise_mm"] + sensor["resolution_mm"]
    err = np.abs(rec.reference_mm - rec.y_measured_mm)[n_per:]
    assert err.max() <= 0.06 * stroke


def _loop_poles(axis, ctrl, dt):
    """The linear (friction-free) sampled loop: exact ZOH plant, backward-difference rate with the
    first-order filter, one-sample hold. State (x, v, x_prev, v_f)."""
    m, c = axis.m, axis.c
    k = c / m
    e = math.exp(-k * dt)
    Ad = np.array([[1.0, (1 - e) / k], [0.0, e]])
    Bd = np.array([(dt - (1 - e) / k) / c, (1 - e) / c])
    a = 1.0 - math.exp(-2 * math.pi * ctrl.velocity_cutoff_hz * dt) if ctrl.velocity_cutoff_hz else 1.0
    # v_f,k = (1-a) v_f,k-1 + a (x_k - x_k-1)/dt ; F_k = -gain (Kp x_k + Kd v_f,k)
    vf_row = np.array([a / dt, 0.0, -a / dt, 1 - a])
    f_row = -ctrl.gain * (ctrl.Kp * np.array([1.0, 0, 0, 0]) + ctrl.Kd * vf_row)
    M = np.zeros((4, 4))
    M[:2, :2] = Ad
    M[:2, :] += np.outer(Bd, f_row)
    M[2, 0] = 1.0
    M[3, :] = vf_row
    z = np.linalg.eigvals(M).astype(complex)
    z = z[np.abs(z) > 1e-12]   # without the filter v_f is no state: a pole at z = 0 (s = -inf)
    return np.log(z) / dt


@pytest.mark.parametrize("name", CASE_NAMES)
def test_loop_design_is_well_damped(name):
    """The sampled linear loop's dominant poles (slowest pair) lie at 2-22 Hz with damping
    0.45-1 (designed 0.6-1; the 1 ms hold and rate estimate cost a little)."""
    case = bench.CASES[name]
    s = _loop_poles(case["axis"], case["controller"], 1e-3)
    assert np.all(s.real < 0)
    dom = s[np.argsort(np.abs(s))[:2]]
    wn = np.sqrt(np.prod(np.abs(dom))) if np.all(np.abs(dom.imag) < 1e-9) else np.abs(dom[0])
    zeta = 1.0 if np.all(np.abs(dom.imag) < 1e-9) else -dom[0].real / np.abs(dom[0])
    assert 2.0 <= wn / (2 * math.pi) <= 22.0
    assert 0.45 <= zeta <= 1.0 + 1e-9


@group_a
def test_pulses_once_per_period_at_fixed_phase(records):
    """The validation record's pulses: one rectangle per period of width_s (to the sample) at the
    case's phase, alternating in sign when asked, and part of the logged force."""
    rec = records("sticky+pulses")
    p = rec.truth["pulses"]
    n_per = _periods(rec)
    width = int(round(p["width_s"] * rec.truth["fs_hz"]))
    on = rec.pulse_N != 0
    starts = np.nonzero(np.diff(on.astype(int)) == 1)[0] + 1
    assert np.allclose(starts % n_per, round(p["phase"] * n_per))
    n_expected = int(np.floor((rec.t_s.size - width) / n_per - p["phase"])) + 1
    assert len(starts) == n_expected and all(on[s:s + width].all() and not on[s + width] for s in starts)
    signs = np.sign(rec.pulse_N[starts])
    assert np.all(np.abs(rec.pulse_N[starts]) == p["amplitude_N"])
    assert np.all(signs[1:] == -signs[:-1]) if p["alternate"] else np.all(signs == signs[0])
    assert np.array_equal(rec.force_N, rec.force_applied_N)  # this case logs without noise


# --------------------------------------------------------------------------- the DAQ file

HEADER = "time [s],x [mm],force [N]"


def _read(path):
    with open(path) as f:
        header = f.readline().rstrip("\n")
    return header, np.loadtxt(path, delimiter=",", skiprows=1)


def _check_daq(d, rec, sensor):
    """time from 0 at 1 kHz (printed to 1 us); x on the encoder's grid (to 1e-6 of a count) about
    its absolute zero and about the rest reading zero_mm (on the grid in every case), equal to the
    record's y to 1e-9 mm, the first reading zero_mm within 5 noise std + 1 count; force equal to
    the logged force to 1e-9 relative (10 significant digits written); 3-4 periods."""
    res, zero = sensor["resolution_mm"], sensor["zero_mm"]
    n_per = int(round(rec.truth["period_s"] * 1000))
    assert 3 * n_per <= len(d) <= 4 * n_per and len(d) == rec.t_s.size
    assert d[0, 0] == 0.0
    assert np.allclose(d[:, 0], np.arange(len(d)) / 1000.0, rtol=0, atol=1e-9)
    assert np.allclose(np.diff(d[:, 0]), 1e-3, rtol=0, atol=2e-9)
    counts = d[:, 1] / res
    assert np.abs(counts - np.round(counts)).max() < 1e-6
    about_zero = (d[:, 1] - zero) / res
    assert np.abs(about_zero - np.round(about_zero)).max() < 1e-6
    assert abs(d[0, 1] - zero) <= 5 * sensor["noise_mm"] + res
    assert np.allclose(d[:, 1], rec.y_measured_mm, rtol=0, atol=1e-9)
    assert np.allclose(d[:, 2], rec.force_N, rtol=1e-9, atol=1e-12)


@group_a
def test_write_case_files(records, case_folder):
    """write_case: ``<name>_id.csv`` and ``<name>_pulses.csv`` with the exact header and the checks
    of _check_daq; the validation file's force carries the pulses; no temporary file left; the
    returned truth holds the parameters and the seeds (id: seed, pulses: seed + 1)."""
    rec_id, rec_pu = records(WRITTEN), records(WRITTEN + "+pulses")
    truth = records("truth")
    assert sorted(p.name for p in case_folder.iterdir()) == [f"{WRITTEN}_id.csv", f"{WRITTEN}_pulses.csv"]
    for kind, rec in (("id", rec_id), ("pulses", rec_pu)):
        header, d = _read(case_folder / f"{WRITTEN}_{kind}.csv")
        assert header == HEADER
        _check_daq(d, rec, truth["sensor"])
        assert truth["records"][kind]["seed"] == (0 if kind == "id" else 1)
    assert np.all(rec_id.pulse_N == 0) and np.any(rec_pu.pulse_N != 0)
    axis = bench.CASES[WRITTEN]["axis"]
    assert ((truth["m_kg"], truth["c_N_s_m"], truth["Fc_N"], truth["F0_N"])
            == (axis.m, axis.c, axis.Fc, axis.F0))
    assert truth["pulses"]["amplitude_N"] == bench.CASES[WRITTEN]["pulses"].amplitude_N


@group_b
def test_daq_csv_fine_encoder_and_force_noise(records, tmp_path):
    """write_daq_csv on a case with a 0.5 um encoder and force-logging noise: the same checks; the
    logged force differs from the applied one by the noise only (std 0.3 N within 10 %)."""
    rec = records("light_fast")
    path = bench.write_daq_csv(tmp_path / "run.csv", rec)
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"]
    header, d = _read(path)
    assert header == HEADER
    _check_daq(d, rec, rec.truth["sensor"])
    noise = rec.force_N - rec.force_applied_N
    assert abs(noise.std() / rec.truth["sensor"]["force_noise_N"] - 1) < 0.1
