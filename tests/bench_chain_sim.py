"""An independent bench for drive trains: a chain of flywheels integrated by scipy, for the tests.

Nothing here uses jointrig. Flywheel i (0-based here) obeys

    J_i phi_i'' = T_i(t) - M_i + M_(i-1) - b_i phi_i'

with M_j the torque of joint j, written out again from :class:`bench_sim.Joint` (the same
independent law the two-flywheel bench uses: dead-zone free play, a phi^2, gamma phi^3,
q v|v|, dry friction with a Stribeck peak, a Jenkins element, Segalman's continuum Iwan
element under Masing's rule, and a Maxwell element outside the catalogue: a spring in series
with a dashpot, whose torque is a state). One joint, ``special``, may carry these effects; its
dry friction and its Jenkins slider switch at events as in :mod:`bench_sim` (stuck, the two
flywheels of that joint move with one acceleration, the friction holding whatever torque
keeps them so, until it exceeds the static friction), so the integrator never steps across a
discontinuity. Bearing drag ``b_i`` acts on any flywheel.

:func:`measured_runs` samples whole periods of the steady state (found by integrating period
by period until the state repeats to 1e-8 of its swing; DOP853 at rtol 1e-10 leaves a floor near
1e-9 there) and adds white noise at a stated SNR
to every angle and drive torque, the way a bench with an encoder per flywheel records.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Optional, Sequence

import numpy as np
from scipy.integrate import solve_ivp

from bench_sim import Joint


@dataclass(frozen=True)
class Train:
    """A chain: inertias (kg m^2), one :class:`bench_sim.Joint` per joint (its J1, J2, b1, b2,
    delay fields unused), bearing drags (N m s/rad) and the joint with non-smooth effects."""

    J: tuple
    joints: tuple
    b: tuple = (0.0, 0.0, 0.0, 0.0)
    special: int = 0
    #: a constant torque on each body (N m; empty: none): a motor's mean torque and the pump's
    #: mean load, summing to 0 on a train free to turn; it preloads every joint between them
    loads: tuple = ()

    @property
    def N(self) -> int:
        return len(self.J)


#: The test train: motor side, two couplings, load; modes 66, 173, 214 rad/s, damped 12-36%.
TRAIN = Train(J=(1.0, 0.5, 0.5, 1.0),
              joints=(Joint(c=30.0, k=1.0e4, gamma=3.0e5), Joint(c=20.0, k=5.0e3, gamma=1.5e5),
                      Joint(c=30.0, k=1.0e4, gamma=3.0e5)))


def with_effect(train: Train, joint: int, **effect) -> Train:
    """The train with an effect at joint ``joint`` (1-based) (fields of :class:`bench_sim.Joint`)."""
    joints = list(train.joints)
    joints[joint - 1] = replace(joints[joint - 1], **effect)
    return replace(train, joints=tuple(joints), special=joint - 1)


# The right-hand side works on Python floats (lists): with arrays of four elements numpy's
# per-call overhead was most of the bench's time. Same operations in the same order.

def _drives(drive: dict, t: float, N: int, loads: tuple = ()) -> list:
    T = list(loads) if loads else [0.0] * N
    for i, (w, M0) in drive.items():
        T[i - 1] += M0 * math.cos(w * t)
    return T


def _maxwell_at(train: Train) -> int:
    """Where the special joint's Maxwell torque sits in the state: after the angles, the rates
    and the Jenkins slider's torque (if any)."""
    return 2 * train.N + (1 if train.joints[train.special].Fs else 0)


def _torques(train: Train, y: list, mode: dict, friction: bool = True) -> list:
    """Every joint's torque (N m); the special joint's dry friction left out when not ``friction``."""
    N = train.N
    M = [0.0] * (N - 1)
    for j, jt in enumerate(train.joints):
        u, r = y[j] - y[j + 1], y[N + j] - y[N + j + 1]
        m = jt.smooth_torque(u, r)
        if j == train.special:
            if friction and jt.static and mode["s"] != 0:
                m += jt.sliding(r) * mode["s"]
            if jt.Fs:
                m += y[2 * N] if mode["j"] == 0 else jt.Fs * mode["j"]
            if jt.Fi:
                m += jt.iwan_torque(u, mode)
            if jt.km:
                m += y[_maxwell_at(train)]
        M[j] = m
    return M


def _accelerations(train: Train, T: list, y: list, M: list) -> list:
    N = train.N
    net = [T[i] - train.b[i] * y[N + i] for i in range(N)]
    for j in range(N - 1):
        net[j] -= M[j]
        net[j + 1] += M[j]
    return [net[i] / train.J[i] for i in range(N)]


def _stick_torque(train: Train, drive: dict, t: float, y, mode: dict) -> float:
    """The friction torque that would keep the special joint's two flywheels at one acceleration."""
    m = train.special
    y = [float(v) for v in y]
    a = _accelerations(train, _drives(drive, t, train.N, train.loads), y, _torques(train, y, mode, friction=False))
    Ja, Jb = train.J[m], train.J[m + 1]
    # a_m - f/Ja = a_(m+1) + f/Jb
    return (a[m] - a[m + 1]) / (1.0 / Ja + 1.0 / Jb)


def _rhs(train: Train, drive: dict, mode: dict):
    N, m = train.N, train.special
    jt = train.joints[m]

    def f(t, y):
        y = y.tolist()
        T = _drives(drive, t, N, train.loads)
        M = _torques(train, y, mode)
        a = _accelerations(train, T, y, M)
        if jt.static and mode["s"] == 0:  # stuck: friction holds the joint
            fr = _stick_torque(train, drive, t, y, mode)
            a[m] -= fr / train.J[m]
            a[m + 1] += fr / train.J[m + 1]
        dy = y[N:2 * N] + a
        if jt.Fs:
            dy.append(jt.Fs / jt.r * (y[N + m] - y[N + m + 1]) if mode["j"] == 0 else 0.0)
        if jt.km:  # the Maxwell element's torque relaxes through its dashpot
            dy.append(jt.km * (y[N + m] - y[N + m + 1] - y[_maxwell_at(train)] / jt.cm))
        return dy

    return f


def _events(train: Train, drive: dict, mode: dict):
    N, m = train.N, train.special
    jt = train.joints[m]
    ev = []

    def rel(y):
        return y[N + m] - y[N + m + 1]

    if jt.gap:
        def kink_up(t, y):
            return y[m] - y[m + 1] - jt.gap

        def kink_down(t, y):
            return y[m] - y[m + 1] + jt.gap
        for f, d in zip((kink_up, kink_down), mode["kinks"]):
            f.terminal, f.direction = True, d
            ev.append(f)
    if jt.static and mode["s"] == 0:
        def unsticks(t, y):
            return abs(_stick_torque(train, drive, t, y, mode)) - jt.static
        unsticks.terminal, unsticks.direction = True, 1
        ev.append(unsticks)
    elif jt.static:
        def rate_zero(t, y):
            return rel(y)
        rate_zero.terminal, rate_zero.direction = True, -mode["s"]
        ev.append(rate_zero)
    if jt.Fi:
        def reverses(t, y):
            return rel(y)
        reverses.terminal, reverses.direction = True, -mode["i"]
        ev.append(reverses)
    if jt.Fs:
        if mode["j"] == 0:
            def slips(t, y):
                return abs(y[2 * N]) - jt.Fs
            slips.terminal, slips.direction = True, 1
            ev.append(slips)
        else:
            def sticks(t, y):
                return rel(y)
            sticks.terminal, sticks.direction = True, -mode["j"]
            ev.append(sticks)
    return ev


def simulate(train: Train, drive: dict, t_eval: np.ndarray, y0, mode: dict, t0: float = 0.0):
    """Integrate from (t0, y0, mode) to t_eval[-1]: states at t_eval, final state, final mode."""
    N, m = train.N, train.special
    jt = train.joints[m]
    mode = dict(mode)
    t, y = t0, np.array(y0, float)
    out = np.empty((t_eval.size, y.size))
    i = 0
    while True:
        sel = t_eval[(t_eval >= t) & (np.arange(t_eval.size) >= i)]
        evs = _events(train, drive, mode)
        sol = solve_ivp(_rhs(train, drive, mode), (t, t_eval[-1]), y, method="DOP853", rtol=1e-10, atol=1e-12,
                        t_eval=sel, events=evs or None)
        if not sol.success:
            raise RuntimeError(sol.message)
        k = len(sol.t) if sel.size else 0
        if k:
            out[i:i + k] = np.asarray(sol.y).T
        i += k
        if sol.status == 0:
            return out, out[-1].copy(), mode
        fired = [e for e, te in enumerate(sol.t_events) if te.size]
        t = float(sol.t_events[fired[0]][0])
        y = np.array(sol.y_events[fired[0]][0], float)
        name = evs[fired[0]].__name__
        if name.startswith("kink"):
            which = 0 if name == "kink_up" else 1
            dirs = list(mode["kinks"])
            dirs[which] = -dirs[which]
            mode["kinks"] = tuple(dirs)
        elif name == "rate_zero":
            need = _stick_torque(train, drive, t, y, mode)
            if abs(need) <= jt.static:
                Ja, Jb = train.J[m], train.J[m + 1]
                v = (Ja * y[N + m] + Jb * y[N + m + 1]) / (Ja + Jb)  # momentum kept
                y[N + m] = y[N + m + 1] = v
                mode["s"] = 0
            else:
                mode["s"] = -mode["s"]
        elif name == "unsticks":
            mode["s"] = 1 if _stick_torque(train, drive, t, y, mode) > 0 else -1
        elif name == "reverses":
            u = y[m] - y[m + 1]
            mode["Fr"] = jt.iwan_torque(u, mode)
            mode["xr"] = u
            mode["i"] = -mode["i"]
        elif name == "slips":
            mode["j"] = 1 if y[2 * N] > 0 else -1
        else:  # sticks
            y[2 * N] = jt.Fs * mode["j"]
            mode["j"] = 0
        t = math.nextafter(t, math.inf)


def _linear_start(train: Train, drive: dict) -> np.ndarray:
    """The linear part's steady state at t = 0 (one drive frequency): most of the transient gone."""
    N = train.N
    w = next(iter(drive.values()))[0]
    Z = -w**2 * np.diag(train.J).astype(complex) + 1j * w * np.diag(train.b)

    def maxwell(jt):  # the Maxwell element's complex stiffness
        return jt.km * 1j * w * jt.cm / (jt.km + 1j * w * jt.cm) if jt.km else 0.0

    for j, jt in enumerate(train.joints):
        Z[j:j + 2, j:j + 2] += (jt.k + 1j * w * jt.c + maxwell(jt)) * np.array([[1, -1], [-1, 1]])
    F = np.array([drive[i + 1][1] if (i + 1) in drive else 0.0 for i in range(N)], dtype=complex)
    # the rigid rotation of a free chain: pin its mean by the pseudo-inverse (a cosine drive from
    # rest keeps it periodic)
    X = np.linalg.lstsq(Z, F, rcond=None)[0]
    if train.loads:  # the static twist under the mean loads (the linear springs')
        K = np.zeros((N, N))
        for j, jt in enumerate(train.joints):
            K[j:j + 2, j:j + 2] += jt.k * np.array([[1, -1], [-1, 1]])
        X = X + np.linalg.lstsq(K, np.asarray(train.loads, float), rcond=None)[0]
    y = list(X.real) + list((1j * w * X).real)
    m, jt = train.special, train.joints[train.special]
    if jt.Fs:
        y.append(0.0)
    if jt.km:
        y.append((maxwell(jt) * (X[m] - X[m + 1])).real)
    return np.array(y)


def steady_period(train: Train, drive: dict, samples: int, *, tol: float = 1e-8, max_periods: int = 2000):
    """One period of the steady state sampled at ``samples`` points: (t, states (samples, dim))."""
    t, y, mode, T = steady_state(train, drive, tol=tol, max_periods=max_periods)
    t_eval = t + np.arange(samples) * T / samples
    ys, _, _ = simulate(train, drive, np.append(t_eval, t_eval[-1] + T / samples), y, mode, t0=t)
    return t_eval - t, ys[:-1]


def steady_state(train: Train, drive: dict, *, tol: float = 1e-8, max_periods: int = 2000):
    """The state once the response repeats to ``tol`` of its swing: (t, y, mode, period)."""
    N, m = train.N, train.special
    jt = train.joints[m]
    w = next(iter(drive.values()))[0]
    T = 2 * math.pi / w
    y = _linear_start(train, drive)
    u, r = y[m] - y[m + 1], y[N + m] - y[N + m + 1]
    mode = {"s": 1 if r >= 0 else -1, "j": 0, "i": 1 if r >= 0 else -1, "xr": None, "Fr": 0.0,
            "kinks": (1 if u < jt.gap else -1, 1 if u < -jt.gap else -1)}
    t = 0.0
    done = 0
    while done < max_periods:
        grid = t + T * np.arange(1, 6)
        ys, y, mode = simulate(train, drive, grid, y, mode, t0=t)
        t = grid[-1]
        done += 5
        rel = np.concatenate([ys[:, :N - 1] - ys[:, 1:N], ys[:, N:2 * N]], axis=1)
        scale = np.max(np.abs(rel), axis=0) + 1e-12
        if np.max(np.abs(rel[-1] - rel[-2]) / scale) < tol:
            return t, y, mode, T
    raise RuntimeError(f"no steady state after {max_periods} periods for drive {drive}")


@dataclass(frozen=True)
class Measured:
    """One measured run: whole periods at ``samples`` per period, noisy angles and drive torques."""

    omega_rad_s: float
    time_s: np.ndarray
    angles_rad: tuple
    torques_Nm: tuple
    amplitude_Nm: float = math.nan
    n_periods: int = 8


def measured_runs(train: Train, points, *, snr_db: float = 40.0, n_periods: int = 8, samples: int = 128,
                  seed: int = 0) -> list[Measured]:
    """Every ``(omega rad/s, amplitude N m, driven flywheel 1-based)`` point, measured: the steady
    period repeated ``n_periods`` times, white noise at ``snr_db`` on each angle and drive torque."""
    rng = np.random.default_rng(seed)
    out = []
    for w, M0, i in points:
        t, ys = steady_period(train, {i: (w, M0)}, samples)
        T = 2 * math.pi / w
        time = (t[None, :] + T * np.arange(n_periods)[:, None]).ravel()

        def noisy(x):
            x = np.tile(x, n_periods)
            sd = np.sqrt(np.mean((x - x.mean()) ** 2)) * 10 ** (-snr_db / 20)
            return x + rng.normal(0.0, sd, x.size)

        angles = tuple(noisy(ys[:, k]) for k in range(train.N))
        torques = tuple(noisy(M0 * np.cos(w * t)) if k + 1 == i else None for k in range(train.N))
        out.append(Measured(w, time, angles, torques, M0, n_periods))
    return out


#: The pump train's sweep and two held-out runs of other levels (omega rad/s, N m, driven body):
#: studies.chain_sweep.CHAIN_PLAN + HELD_OUT, written out again.
PUMP_POINTS = [(150.0, 60.0, 1), (250.0, 60.0, 1), (300.0, 60.0, 1), (330.0, 120.0, 1), (600.0, 60.0, 1),
               (1200.0, 60.0, 1), (2000.0, 60.0, 1), (3000.0, 60.0, 1), (400.0, 30.0, 4), (1500.0, 30.0, 4),
               (300.0, 90.0, 1), (800.0, 45.0, 4)]

#: The pump train of models/pump_train.xml, written out again for this bench: motor, coupling hub,
#: gearbox, pump (kg m^2); motor shaft, elastomer coupling (progressive), pump shaft.
PUMP_TRAIN = Train(J=(0.45, 0.06, 0.12, 0.35),
                   joints=(Joint(c=15.0, k=4.0e5, gamma=0.0), Joint(c=20.0, k=2.5e4, gamma=1.25e7),
                           Joint(c=10.0, k=1.2e5, gamma=0.0)))


#: Encoder readings at rest (rad), the same in every run: absolute encoders never zeroed read the
#: train's angle when it was assembled (0.7 rad), and each differs from its neighbour by where the
#: joint between them came to rest: the worn coupling (joint 2, +-1 mrad of free play) anywhere in
#: its play (here 0.4 mrad), the stiff shafts within a few encoder counts (1e-5 rad).
ENCODERS_AT_REST_RAD = (0.7, 0.7 - 1e-5, 0.7 - 1e-5 - 4e-4, 0.7 - 4e-4)


def daq_file(train: Train, points, path, *, fs_Hz: float = 20000.0, n_periods: float = 8.3, snr_db: float = 40.0,
             offsets_rad=ENCODERS_AT_REST_RAD, seed: int = 0, angle_unit: str = "mrad", torque_lead_s: float = 0.0,
             cell_offset_Nm: float = 0.0, loads_by_run: Optional[Sequence[tuple]] = None):
    """Every ``(omega rad/s, amplitude N m, driven flywheel)`` point recorded as a lab's DAQ writes a
    drive train's test: a fixed sample rate (not a whole number of samples per period), from a
    random phase of the steady state, ``n_periods`` periods (an incomplete last one), encoders not
    zeroed (their readings at rest, ``offsets_rad``, the same in every run), white noise at
    ``snr_db`` on every angle and on the torque cell of each motor (an idle motor's cell reads
    noise about 0), angles in ``angle_unit`` (rad or mrad), time in ms. One CSV, one block of rows
    per run. ``torque_lead_s``: the torque cells read the torque that acts this much later (a
    current loop's or an amplifier's lag between the recorded and the acting torque).
    ``cell_offset_Nm``: what every torque cell reads at zero torque. The train's ``loads``: a
    driven body's cell reads its mean load too (the motor holds it); a load elsewhere (a pump's)
    is not measured. ``loads_by_run``: per point, the train's ``loads`` in that run instead (a
    pump whose mean load changes with its speed)."""
    scale = {"rad": 1.0, "mrad": 1e3}[angle_unit]
    rng = np.random.default_rng(seed)
    driven = sorted({i for _, _, i in points})
    N = train.N
    header = (["run", "t [ms]"] + [f"torque{i} [N m]" for i in driven]
              + [f"phi{i} [{angle_unit}]" for i in range(1, N + 1)])
    lines = [",".join(header)]
    base = train
    for r, (w, M0, i) in enumerate(points):
        train = replace(base, loads=tuple(loads_by_run[r])) if loads_by_run is not None else base
        drive = {i: (w, M0)}
        t, y, mode, T = steady_state(train, drive)
        start = t + rng.uniform(0, T)
        n = int(n_periods * T * fs_Hz)
        t_eval = start + np.arange(n) / fs_Hz
        ys, _, _ = simulate(train, drive, t_eval, y, mode, t0=t)
        # each cell reads its motor's torque: the drive and the body's mean load
        torques = {d: (M0 * np.cos(w * (t_eval + torque_lead_s)) if d == i else np.zeros(n))
                   + (train.loads[d - 1] if train.loads else 0.0) for d in driven}
        cells = []
        for d in driven:  # a torque cell's noise is set by its range: the drive's level here
            cells.append(torques[d] + cell_offset_Nm + rng.normal(0.0, M0 / math.sqrt(2) * 10 ** (-snr_db / 20), n))
        for k in range(N):
            x = ys[:, k]
            sd = float(np.std(x)) * 10 ** (-snr_db / 20)
            cells.append((x + offsets_rad[k] + rng.normal(0.0, sd, n)) * scale)
        ms = (t_eval - start) * 1e3
        for k in range(n):
            # 10 significant digits: at 8, an encoder zero of pi rad written in mrad steps by 1e-7 rad,
            # the noise of the 3000 rad/s runs, and a step that drifts slowly with the sample phase
            # is not in the period-to-period spread (chi2/dof 1.8-2.4 instead of 1.1)
            lines.append(f"{r},{ms[k]:.4f}," + ",".join(f"{c[k]:.10g}" for c in cells))
    path.write_text("\n".join(lines) + "\n")
    return path


if __name__ == "__main__":
    # python tests/bench_chain_sim.py OUT.csv: the worn pump train (+-1 mrad of free play in the
    # coupling) as a DAQ records it, the file of docs/drive-trains.md (diagnose it with
    # --columns time=t).
    import sys
    from pathlib import Path

    print(daq_file(with_effect(PUMP_TRAIN, 2, gap=1e-3), PUMP_POINTS, Path(sys.argv[1])))
