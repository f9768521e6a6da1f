"""An independent bench for the tests: scipy ODE solvers and a DAQ-style file writer.

Nothing here uses jointrig (not the MuJoCo rig, not ``vocab.law``, not the project's
writer). The two-flywheel equations are written out again:

    J1 phi1'' = T(t - delay) - M - b1 phi1'
    J2 phi2'' = M - b2 phi2'
    M = c v + cc v [|phi| > gap] + k d(phi) + a d(phi)^2 + gamma d(phi)^3 + (Fc + Fx exp(-(v/vs)^2)) sgn(v)
        + q v |v| + f_J + f_I

with ``phi = phi1 - phi2``, ``v = phi'``, ``d`` the dead zone of half width ``gap`` (free play),
``cc`` a damping that acts only while the free play is taken up (in contact), ``f_J`` a
Jenkins element (spring ``Fs / r`` in series with a slider that slips at ``Fs``) and
``f_I`` Segalman's Iwan element as a continuum (its backbone in closed form, Masing's rule after
every rate reversal; not the project's 32-element discretisation).
Dry friction (sliding either way, with a Stribeck peak Fx falling off over the rate vs, or
stuck: the flywheels then move as one body until the torque needed to hold the joint exceeds
the static friction Fc + Fx) and the Jenkins slider switch at events
(``solve_ivp`` with terminal events, then a restart in the new mode), so the integrator never
steps across a discontinuity. Extra
effects outside the catalogue (for the diagnosis's open-world tests) are in ``Joint.extra``.

The DAQ (:func:`measure`) samples at a fixed rate that is not commensurate with the drive,
starts at an arbitrary phase, adds small sensor offsets and white noise, and writes CSV the
way a lab's logger does: units in the header, time stamps rounded to 1e-7 s, no ``omega``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Optional

import numpy as np
from scipy.integrate import solve_ivp


@dataclass(frozen=True)
class Joint:
    J1: float = 2.0
    J2: float = 2.0
    c: float = 100.0
    k: float = 2000.0
    gamma: float = 200.0
    a: float = 0.0
    gap: float = 0.0
    cc: float = 0.0  # damping in contact only (N m s/rad): beyond the free play, none within it
    Fc: float = 0.0
    Fx: float = 0.0  # Stribeck excess of the static friction over the sliding one (N m)
    vs: float = 1.0  # Stribeck rate (rad/s): sliding friction Fc + Fx exp(-(v/vs)^2)
    q: float = 0.0
    Fs: float = 0.0  # Jenkins slip torque (N m)
    r: float = 0.0  # Jenkins slip angle (rad)
    Fi: float = 0.0  # Iwan macroslip torque (N m); a continuum of sliders, Segalman's density
    smax: float = 0.0  # Iwan: the largest slip angle (rad)
    chi: float = -0.5
    beta: float = 0.1
    b1: float = 0.0
    b2: float = 0.0
    delay: float = 0.0
    #: a Maxwell element across the joint (outside the catalogue): a spring km (N m/rad) in series
    #: with a dashpot cm (N m s/rad), the relaxation of a rubber joint; its torque is a state
    km: float = 0.0
    cm: float = 0.0
    #: an extra joint torque (phi, v) -> N m outside the catalogue (smooth)
    extra: Optional[Callable[[float, float], float]] = field(default=None, compare=False)

    @property
    def static(self) -> float:
        """The friction that holds the joint stuck (N m)."""
        return self.Fc + self.Fx

    def sliding(self, v: float) -> float:
        """The size of the friction torque while sliding at rate v (N m)."""
        return self.Fc + (self.Fx * math.exp(-(v / self.vs) ** 2) if self.Fx else 0.0)

    def iwan_backbone(self, u: float) -> float:
        """Segalman's continuum Iwan element loaded from rest to angle u (N m), in closed form:
        density R s^chi on (0, smax] plus a Dirac S = beta K_d at smax; the sliders below u have
        slipped (each holds its slip torque), the others are springs at u."""
        x = abs(u)
        chi, smax = self.chi, self.smax
        kd = self.Fi / (smax * ((chi + 1) / (chi + 2) + self.beta))
        if x >= smax:
            g = self.Fi
        else:
            R = kd * (chi + 1) / smax ** (chi + 1)
            g = R * x ** (chi + 2) / (chi + 2) + x * (R * (smax ** (chi + 1) - x ** (chi + 1)) / (chi + 1) + self.beta * kd)
        return math.copysign(g, u)

    def iwan_torque(self, phi: float, mode: dict) -> float:
        """Masing's rule: from rest the backbone; after a reversal at (x_r, F_r) the backbone
        scaled by two, F_r + 2 g((phi - x_r)/2) (exact for the steady state's simple loops)."""
        if mode.get("xr") is None:
            return self.iwan_backbone(phi)
        return mode["Fr"] + 2.0 * self.iwan_backbone(0.5 * (phi - mode["xr"]))

    def smooth_torque(self, phi: float, v: float) -> float:
        d = math.copysign(max(abs(phi) - self.gap, 0.0), phi)
        m = self.c * v + self.k * d + self.a * d * d + self.gamma * d ** 3 + self.q * v * abs(v)
        if self.cc and abs(phi) > self.gap:
            m += self.cc * v
        if self.extra is not None:
            m += self.extra(phi, v)
        return m


#: The paper's joint and a stiff, lightly damped one.
PAPER = Joint()
LIGHT = Joint(c=5.0, k=20000.0, gamma=1.0e5)

#: Drive points (omega rad/s, M0 N m) per joint: around each joint's resonance, three levels.
POINTS = {
    "paper": tuple((w, m) for w in (25.0, 40.0, 55.0) for m in (1500.0, 2500.0, 3500.0)),
    "light": tuple((w, m) for w in (90.0, 115.0, 175.0) for m in (1000.0, 1700.0, 2400.0)),
}
JOINTS = {"paper": PAPER, "light": LIGHT}


def _rhs(joint: Joint, M0: float, w: float, mode: dict):
    J1, J2 = joint.J1, joint.J2

    def f(t, y):
        y = y.tolist()  # Python floats: the same arithmetic, at a third of numpy scalars' cost
        if joint.static and mode["s"] == 0:  # stuck: the flywheels move as one body
            T = M0 * math.cos(w * (t - joint.delay))
            a = (T - joint.b1 * y[2] - joint.b2 * y[3]) / (J1 + J2)
            return [y[2], y[3], a, a]
        phi = y[0] - y[1]
        v = y[2] - y[3]
        m = joint.smooth_torque(phi, v)
        if joint.static:
            m += joint.sliding(v) * mode["s"]
        if joint.Fs:
            m += y[4] if mode["j"] == 0 else joint.Fs * mode["j"]
        if joint.Fi:
            m += joint.iwan_torque(phi, mode)
        if joint.km:
            m += y[-1]
        T = M0 * math.cos(w * (t - joint.delay))
        a1 = (T - m - joint.b1 * y[2]) / J1
        a2 = (m - joint.b2 * y[3]) / J2
        dy = [y[2], y[3], a1, a2]
        if joint.Fs:
            dy.append(joint.Fs / joint.r * v if mode["j"] == 0 else 0.0)
        if joint.km:  # the Maxwell element's torque relaxes through its dashpot
            dy.append(joint.km * (v - y[-1] / joint.cm))
        return dy

    return f


def _events(joint: Joint, mode: dict, w: float = 0.0, M0: float = 0.0):
    ev = []
    if joint.gap:
        # the free play's kinks: restart there, so the integrator never steps across one
        def kink_up(t, y):
            return y[0] - y[1] - joint.gap
        def kink_down(t, y):
            return y[0] - y[1] + joint.gap
        for f, d in zip((kink_up, kink_down), mode["kinks"]):
            f.terminal = True
            f.direction = d  # the next crossing only: the one just passed does not fire again
            ev.append(f)
    if joint.static and mode["s"] == 0:
        def unsticks(t, y):
            return abs(_stick_torque(joint, w, M0, t, y, mode)) - joint.static
        unsticks.terminal = True
        unsticks.direction = 1
        ev.append(unsticks)
    elif joint.static:
        def rate_zero(t, y):
            return y[2] - y[3]
        rate_zero.terminal = True
        rate_zero.direction = -mode["s"]
        ev.append(rate_zero)
    if joint.Fi:
        def reverses(t, y):
            return y[2] - y[3]
        reverses.terminal = True
        reverses.direction = -mode["i"]
        ev.append(reverses)
    if joint.Fs:
        if mode["j"] == 0:
            def slips(t, y):
                return abs(y[4]) - joint.Fs
            slips.terminal = True
            slips.direction = 1
            ev.append(slips)
        else:
            def sticks(t, y):
                return y[2] - y[3]
            sticks.terminal = True
            sticks.direction = -mode["j"]
            ev.append(sticks)
    return ev


def simulate(joint: Joint, w: float, M0: float, t_eval: np.ndarray, y0: np.ndarray, mode: dict,
             t0: float = 0.0) -> tuple[np.ndarray, np.ndarray, dict]:
    """Integrate from (t0, y0, mode) to t_eval[-1]; states at t_eval (n, dim), final state, mode."""
    mode = dict(mode)
    t, y = t0, np.array(y0, float)
    out = np.empty((t_eval.size, y.size))
    i = 0
    while True:
        sel = t_eval[(t_eval >= t) & (np.arange(t_eval.size) >= i)]
        sol = solve_ivp(_rhs(joint, M0, w, mode), (t, t_eval[-1]), y, method="DOP853", rtol=1e-11,
                        atol=1e-12, t_eval=sel, events=_events(joint, mode, w, M0) or None)
        if not sol.success:
            raise RuntimeError(sol.message)
        k = len(sol.t) if sel.size else 0
        if k:
            out[i:i + k] = np.asarray(sol.y).T
        i += k
        if sol.status == 0:
            return out, out[-1].copy(), mode
        # an event: switch mode and restart exactly there
        fired = [j for j, te in enumerate(sol.t_events) if te.size]
        t = float(sol.t_events[fired[0]][0])
        y = np.array(sol.y_events[fired[0]][0], float)
        evs = _events(joint, mode, w, M0)
        name = evs[fired[0]].__name__
        if name.startswith("kink"):
            which = 0 if name == "kink_up" else 1
            dirs = list(mode["kinks"])
            dirs[which] = -dirs[which]
            mode["kinks"] = tuple(dirs)
        elif name == "rate_zero":
            need = _stick_torque(joint, w, M0, t, y, mode)
            if abs(need) <= joint.static:
                v = (joint.J1 * y[2] + joint.J2 * y[3]) / (joint.J1 + joint.J2)  # momentum kept
                y[2] = y[3] = v
                mode["s"] = 0
            else:
                mode["s"] = -mode["s"]
        elif name == "unsticks":
            mode["s"] = 1 if _stick_torque(joint, w, M0, t, y, mode) > 0 else -1
        elif name == "reverses":  # the Iwan element's branch starts again here
            mode["Fr"] = joint.iwan_torque(y[0] - y[1], mode)
            mode["xr"] = y[0] - y[1]
            mode["i"] = -mode["i"]
        elif name == "slips":
            mode["j"] = 1 if y[4] > 0 else -1
        else:  # sticks: slider holds its torque
            y[4] = joint.Fs * mode["j"]
            mode["j"] = 0
        # nudge past the event so it does not fire again at once
        t = math.nextafter(t, math.inf)


def _stick_torque(joint, w, M0, t, y, mode):
    """The friction torque that would hold the joint stuck now (N m): a rigid body of J1 + J2
    with common acceleration a = (T - b1 v1 - b2 v2) / (J1 + J2), so F = T - M_rest - b1 v1 - J1 a."""
    phi = y[0] - y[1]
    m_rest = joint.smooth_torque(phi, 0.0) + (y[-1] if joint.km else 0.0)
    T = M0 * math.cos(w * (t - joint.delay))
    a = (T - joint.b1 * y[2] - joint.b2 * y[3]) / (joint.J1 + joint.J2)
    return T - m_rest - joint.b1 * y[2] - joint.J1 * a


def _linear_start(joint: Joint, w: float, M0: float) -> np.ndarray:
    """Steady state of the linear part (c, k, b1, b2, delay) at t = 0: most of the transient gone."""
    Z = np.array([[-joint.J1 * w * w + 1j * w * (joint.c + joint.b1) + joint.k, -(1j * w * joint.c + joint.k)],
                  [-(1j * w * joint.c + joint.k), -joint.J2 * w * w + 1j * w * (joint.c + joint.b2) + joint.k]])
    F = np.array([M0 * np.exp(-1j * w * joint.delay), 0.0])
    X = np.linalg.solve(Z, F)
    y = [X[0].real, X[1].real, (1j * w * X[0]).real, (1j * w * X[1]).real]
    if joint.Fs:
        y.append(0.0)
    if joint.km:
        y.append(0.0)
    return np.array(y)


def _reduced(y: np.ndarray) -> np.ndarray:
    """The state without the absolute angle (the dynamics depend on phi1 - phi2 only)."""
    return np.concatenate([[y[0] - y[1]], y[2:]])


def _extrapolated(zs: list, y_last: np.ndarray) -> Optional[np.ndarray]:
    """Reduced rank extrapolation (Sidi 1986) of the period map's iterates ``zs`` (reduced
    states at successive period boundaries): the combination ``sum g_i z_(i+1)``, ``sum g_i = 1``,
    whose differences cancel best; exact for a linear map after dim + 1 periods. The absolute
    angle phi1 is kept from the last iterate. None if the system is degenerate."""
    Z = np.array(zs)
    U = np.diff(Z, axis=0)  # (k, n)
    scale = np.max(np.abs(Z), axis=0) + 1e-12
    G = (U / scale) @ (U / scale).T
    ones = np.ones(len(U))
    try:
        x = np.linalg.lstsq(G + 1e-14 * np.trace(G) * np.eye(len(U)), ones, rcond=None)[0]
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(x)) or abs(x.sum()) < 1e-300:
        return None
    z = (x / x.sum()) @ Z[1:]
    y = y_last.copy()
    y[1] = y[0] - z[0]
    y[2:] = z[1:]
    return y


def _discrete(mode: dict) -> tuple:
    """The mode's discrete part (the Iwan element's last reversal point is continuous: the next
    reversal sets it afresh)."""
    return mode["s"], mode["j"], mode["i"], mode["kinks"], mode["xr"] is None


def steady_state(joint: Joint, w: float, M0: float, *, tol: float = 1e-8, max_periods: int = 3000,
                 accelerate: bool = True):
    """State, time and mode at a period boundary once the state repeats to ``tol`` of its swing
    (DOP853 at rtol 1e-11 leaves a floor of ~5e-10 on the lightly damped joint).

    With ``accelerate`` the iteration of the period map is sped up by reduced rank
    extrapolation over chunks of dim + 2 periods in which the mode (stuck or sliding, the free
    play's side, the sliders) ends as it began; the acceptance test is the same (two successive
    simulated periods agree to ``tol``), so an extrapolation that goes wrong only costs periods.
    Measured on the independent-bench cases against plain iteration (``accelerate=False``): the
    next period's relative angle agrees to 3e-9 of its swing (1.3e-7 for the light joint's larger
    Iwan element, whose plain iteration stops at a per-period change of 1e-8 while still
    decaying by 0.9 per period), far below the DAQ noise of 2e-3; settling is 1.7-6x faster.
    The lightly damped joint settles in about 40 periods instead of 150-400."""
    T = 2 * math.pi / w
    y = _linear_start(joint, w, M0)
    phi = y[0] - y[1]
    mode = {"s": 1 if y[2] - y[3] >= 0 else -1, "j": 0, "i": 1 if y[2] - y[3] >= 0 else -1, "xr": None, "Fr": 0.0,
            "kinks": (1 if phi < joint.gap else -1, 1 if phi < -joint.gap else -1)}
    t = 0.0
    chunk = y.size + 2 if accelerate else 10
    prev = None
    done = 0
    while done < max_periods:
        grid = t + T * np.arange(1, chunk + 1)
        start_y, start_mode = y, dict(mode)
        ys, y, mode = simulate(joint, w, M0, grid, y, mode, t0=t)
        t = grid[-1]
        done += chunk
        scale = np.max(np.abs(ys[:, :4]), axis=0) + 1e-12
        change = np.max(np.abs(ys[-1, :4] - ys[-2, :4]) / scale)
        if prev is not None and change < tol:
            return t, y, mode
        prev = change
        if accelerate and _discrete(mode) == _discrete(start_mode) and change > 10 * tol:
            z = _extrapolated([_reduced(start_y)] + [_reduced(r) for r in ys], y)
            if z is not None:
                phi = z[0] - z[1]
                side = (1 if phi < joint.gap else -1, 1 if phi < -joint.gap else -1)
                if not joint.gap or side == mode["kinks"]:
                    y = z
                    prev = None  # the next chunk's own periods decide
    raise RuntimeError(f"no steady state after {max_periods} periods at omega = {w}, M0 = {M0}")


def record(joint: Joint, w: float, M0: float, *, fs_Hz: float, n_periods: float, start_phase: float,
           from_rest: bool = False):
    """Clean samples at a fixed rate: time (from 0), recorded drive torque, phi1, phi2.
    ``from_rest``: the drive switched on at t = 0 at its crest with the flywheels at rest (no
    steady state sought, ``start_phase`` not used; at the crest the drive's impulse has no mean,
    so the train does not start turning as a whole), the transient recorded."""
    if from_rest:
        y0 = np.zeros_like(_linear_start(joint, w, M0))
        mode = {"s": 1, "j": 0, "i": 1, "xr": None, "Fr": 0.0, "kinks": (1 if joint.gap > 0 else -1, -1)}
        t_eval = np.arange(int(n_periods * 2 * math.pi / w * fs_Hz)) / fs_Hz
        ys, _, _ = simulate(joint, w, M0, t_eval, y0, mode, t0=0.0)
        return t_eval, M0 * np.cos(w * t_eval), ys[:, 0], ys[:, 1]
    t_ss, y, mode = steady_state(joint, w, M0)
    t_start = t_ss + start_phase / w
    n = int(n_periods * 2 * math.pi / w * fs_Hz)
    t_eval = t_start + np.arange(n) / fs_Hz
    ys, _, _ = simulate(joint, w, M0, t_eval, y, mode, t0=t_ss)
    torque = M0 * np.cos(w * t_eval)  # the torque as commanded and recorded (before any delay)
    return t_eval - t_start, torque, ys[:, 0], ys[:, 1]


def measure(joint: Joint, points, path: Path, *, noise: float = 0.002, seed: int = 0, fs_Hz: float = 5000.0,
            n_periods: float = 8.4, columns=("run", "Time [s]", "Torque [N m]", "phi1 [rad]", "phi2 [rad]"),
            transform: Optional[Callable] = None, relative: bool = False, from_rest: bool = False,
            noise_seed: Optional[int] = None) -> Path:
    """Simulate every (omega, M0) point and write one CSV as a DAQ would (module docstring).

    ``noise``: standard deviation of each channel's white noise relative to its RMS (one for every
    channel, or one per channel in the file's order: torque, then the angles).
    ``transform(t, torque, phi1, phi2) -> same``: a measurement artefact applied before the noise.
    ``relative``: one twist sensor across the joint instead of two encoders: the columns ``run,
    Time [s], Torque [N m], phi [rad]``, phi1 - phi2 with one channel's offset and noise.
    ``from_rest``: each run recorded from the drive's start with the flywheels at rest
    (:func:`record`).
    ``noise_seed``: the noise from its own generator, so that one ``seed``'s runs (their start
    phases and offsets) can be written with many draws of the noise; by default the noise is drawn
    from ``seed``'s generator between the runs (another file than any ``noise_seed`` gives).
    """
    rng = np.random.default_rng(seed)
    noise_rng = rng if noise_seed is None else np.random.default_rng(noise_seed)
    offsets = rng.uniform(-1, 1, 3) * np.array([0.5, 2e-3, 2e-3])  # N m, rad, rad
    lines = [",".join(columns[:4]) if relative else ",".join(columns)]
    if relative:
        lines[0] = lines[0].replace("phi1 [rad]", "phi [rad]")
    for i, (w, M0) in enumerate(points):
        t, T, p1, p2 = record(joint, w, M0, fs_Hz=fs_Hz, n_periods=n_periods, start_phase=rng.uniform(0, 2 * math.pi),
                              from_rest=from_rest)
        if transform is not None:
            t, T, p1, p2 = transform(t, T, p1, p2)
        chans = []
        for x, off, level in zip((T, p1 - p2) if relative else (T, p1, p2), offsets, np.broadcast_to(noise, (3,))):
            rms = float(np.std(x))
            chans.append(x + off + level * rms * noise_rng.standard_normal(x.size))
        for k in range(t.size):
            lines.append(f"{i},{t[k]:.7f},{chans[0][k]:.6f}," + ",".join(f"{c[k]:.9f}" for c in chans[1:]))
    path.write_text("\n".join(lines) + "\n")
    return path


def with_effect(joint: Joint, **kw) -> Joint:
    return replace(joint, **kw)


# ------------------------------------------------------------------ effects outside the catalogue


def late_channel(delay_s: float, channel: int = 3):
    """A measurement artefact: one channel (3: phi2) sampled ``delay_s`` late (a multiplexed
    DAQ, a filter's group delay), by cubic interpolation of the clean record."""
    from scipy.interpolate import CubicSpline

    def transform(t, T, p1, p2):
        chans = [t, T, p1, p2]
        chans[channel] = CubicSpline(t, chans[channel])(t - delay_s)
        keep = t >= delay_s  # no extrapolation: the first samples are dropped from every channel
        return tuple(c[keep] - (t[keep][0] if i == 0 else 0) for i, c in enumerate(chans))

    return transform


def scaled_channel(gain: float, channel: int = 3):
    """A measurement artefact: one channel (3: phi2) read ``gain`` times the truth (an encoder's
    line count or a gear ratio set wrong)."""
    def transform(t, T, p1, p2):
        chans = [t, T, p1, p2]
        chans[channel] = gain * chans[channel]
        return tuple(chans)

    return transform


def torque_calibration(cubic: float, full_scale_Nm: float):
    """A torque cell whose reading is ``T + cubic * T^3 / full_scale^2`` (a calibration error)."""
    def transform(t, T, p1, p2):
        return t, T + cubic * T**3 / full_scale_Nm**2, p1, p2

    return transform


def maxwell(joint: Joint, km: float, relaxation_s: float) -> Joint:
    """The joint with a Maxwell element (spring ``km`` in series with a dashpot of relaxation
    time ``relaxation_s``) across it: stiffness and damping that depend on frequency (rubber)."""
    return with_effect(joint, km=km, cm=km * relaxation_s)


def cogging(amplitude_Nm: float, pitch_rad: float):
    """A joint torque periodic in the angle (detents, a cogging coupling): A sin(2 pi phi / pitch)."""
    return lambda phi, v: amplitude_Nm * math.sin(2 * math.pi * phi / pitch_rad)
