"""An independent simulator of a position-controlled linear axis, for the tests, written from the
physics alone. Nothing here uses jointrig.

The axis
--------
A carriage of mass m (kg) on a screw-driven linear guide, true position x (m, 0 at rest at
t = 0) and rate v = x' (m/s). While it slides (v != 0)

    m x'' = F(t) - c v - Fc sign(v) - F0

with c the viscous drag (N s/m), Fc the Coulomb (dry) friction (N) and F0 a constant offset force
(N: gravity on an inclined axis, a cable chain's drag; may be 0). Stick-slip is exact and
event-driven, never a smooth sign(): when v crosses zero the carriage sticks if |F - F0| <= Fc
at that instant, and then stays stuck (v = 0 exactly, x constant) until |F - F0| exceeds Fc; it
then slides in the direction of F - F0. If |F - F0| > Fc where v crosses zero it reverses
without stopping. Each hold interval is integrated with scipy.integrate.solve_ivp (DOP853,
rtol 1e-10, atol 1e-13 on x and v) with a terminal event at v = 0; the events fall inside the
intervals. Because F is constant over a hold interval, a stuck carriage can only break away at
a sample instant.

The controller
--------------
A discrete PD position controller at the DAQ rate fs (1 kHz, dt = 1 ms), its output held over
each sample interval (zero-order hold). In encoder coordinates (mm), with the reference
r_enc(t) = zero_mm + r(t):

    e_k = r_enc(t_k) - y_k                 (y_k: the measured, noisy, quantised position)
    v_k = (y_k - y_{k-1}) / dt             (y_{-1} = y_0; optional first-order low-pass,
                                            v_f,k = v_f,k-1 + a (v_k - v_f,k-1), a = 1 - exp(-2 pi fc dt))
    u_k = Kp e_k + Kd (r'(t_k) - v_k) + kv r'(t_k)      (errors and rates converted to m, m/s)
    F on [t_k, t_{k+1}) = gain * u_k  (+ the validation record's force pulses)

Kp (u/m), Kd and kv (u s/m) are in the controller's own unit u; gain is N per u (a drive's force
constant). :func:`design_pd` places the closed loop's natural frequency and damping (viscous
drag included).

The reference
-------------
r(t) = sum_i a_i [sin(i w t + phi_i) - sin(phi_i)] mm, w = 2 pi / T: periodic, smooth, r(0) = 0,
so the record starts at rest (x(0) = 0, v(0) = 0) with the controller engaged at t = 0.

The DAQ
-------
A CSV per record with columns ``time [s]``, ``x [mm]``, ``force [N]``: time from 0 at fs; x the
linear encoder's reading in its own absolute frame, y = round((zero_mm + 1000 x + n) / res) * res
(n white noise of std noise_mm; the grid is the encoder's counts about its absolute zero; every
case's zero_mm lies on the grid, so the readings are also on the grid about zero_mm); force the
applied motor force (controller output plus any pulse) plus optional white logging noise
(force_noise_N; it is not applied to the carriage).

A case has two records: ``<name>_id.csv`` from rest, and ``<name>_pulses.csv``, the validation
record: same axis, controller and reference, with one rectangular force pulse per reference
period (at a fixed phase, optionally alternating in sign) added to the controller's force and
logged with it, also from rest, with an independent noise realisation (seed + 1).
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

RTOL = 1e-10
ATOL = np.array([1e-13, 1e-13, 1e-12, 1e-12])  # x (m), v (m/s), the two dissipated energies (J)


# --------------------------------------------------------------------------- parameters

@dataclass(frozen=True)
class Axis:
    m: float    # kg
    c: float    # N s/m, viscous drag
    Fc: float   # N, Coulomb friction
    F0: float   # N, constant offset force (sign: it pushes towards -x when positive)


@dataclass(frozen=True)
class Controller:
    Kp: float                                  # u / m
    Kd: float                                  # u s / m
    gain: float = 1.0                          # N / u
    kv: float = 0.0                            # u s / m, velocity feed-forward
    velocity_cutoff_hz: float | None = None    # first-order low-pass of the rate estimate; None: raw


@dataclass(frozen=True)
class Reference:
    period_s: float
    amplitudes_mm: tuple[float, ...]   # of harmonics 1, 2, ...
    phases_rad: tuple[float, ...]

    def r_mm(self, t):
        """The reference, mm relative to the rest position (r(0) = 0)."""
        t = np.asarray(t, dtype=float)
        w = 2.0 * math.pi / self.period_s
        out = np.zeros_like(t)
        for i, (a, p) in enumerate(zip(self.amplitudes_mm, self.phases_rad), start=1):
            out = out + a * (np.sin(i * w * t + p) - math.sin(p))
        return out

    def rdot_mm_s(self, t):
        t = np.asarray(t, dtype=float)
        w = 2.0 * math.pi / self.period_s
        out = np.zeros_like(t)
        for i, (a, p) in enumerate(zip(self.amplitudes_mm, self.phases_rad), start=1):
            out = out + a * i * w * np.cos(i * w * t + p)
        return out

    def stroke_mm(self) -> float:
        r = self.r_mm(np.linspace(0.0, self.period_s, 20001))
        return float(r.max() - r.min())


@dataclass(frozen=True)
class Sensor:
    zero_mm: float = 312.457         # encoder reading at rest at t = 0
    resolution_mm: float = 0.001
    noise_mm: float = 0.002          # std of white noise before quantisation
    force_noise_N: float = 0.0       # std of white noise on the logged force only


@dataclass(frozen=True)
class Pulses:
    amplitude_N: float
    width_s: float = 0.03
    phase: float = 0.25              # start of the pulse as a fraction of the period
    alternate: bool = False          # sign (-1)^n in period n

    def force_N(self, t, period_s):
        t = np.asarray(t, dtype=float)
        cyc = t / period_s - self.phase
        n = np.floor(cyc)
        inside = (cyc - n) * period_s < self.width_s - 1e-12
        sign = np.where(n % 2 == 0, 1.0, -1.0) if self.alternate else 1.0
        return np.where(inside, self.amplitude_N * sign, 0.0)


def design_pd(m: float, c: float, f_n_hz: float, zeta: float, gain: float = 1.0) -> tuple[float, float]:
    """Kp, Kd (controller units) for a continuous-time closed loop m s^2 + (gain Kd + c) s + gain Kp
    with natural frequency f_n_hz and damping ratio zeta (the 1 ms hold and rate estimate add
    about 1 ms of delay, a few degrees of phase at these frequencies)."""
    w = 2.0 * math.pi * f_n_hz
    kp = m * w * w / gain
    kd = (2.0 * zeta * m * w - c) / gain
    if kd <= 0:
        raise ValueError("the drag alone damps more than asked")
    return kp, kd


# --------------------------------------------------------------------------- the plant

def _rhs(t, y, s, F, m, c, Fc, F0):
    v = y[1]
    return [v, (F - c * v - Fc * s - F0) / m, c * v * v, Fc * abs(v)]


def _stop_pos(t, y, s, F, m, c, Fc, F0):   # sliding forwards: v falls through 0
    return y[1]


_stop_pos.terminal = True
_stop_pos.direction = -1


def _stop_neg(t, y, s, F, m, c, Fc, F0):   # sliding backwards: v rises through 0
    return y[1]


_stop_neg.terminal = True
_stop_neg.direction = 1


@dataclass
class IntervalResult:
    x: float
    v: float
    diss_c: float          # J dissipated by c over the interval
    diss_f: float          # J dissipated by Fc
    stuck_time: float      # s spent stuck in the interval
    events: list           # (t, kind, F - F0, x): kind in "slip", "stick", "reverse"


def hold_interval(axis: Axis, t0: float, dt: float, x: float, v: float, F: float,
                  *, method: str = "DOP853") -> IntervalResult:
    """The carriage over one hold interval [t0, t0 + dt] under the constant force F, from (x, v);
    v == 0.0 means stuck. Exact stick-slip: terminal events at v = 0 (solve_ivp)."""
    m, c, Fc, F0 = axis.m, axis.c, axis.Fc, axis.F0
    net = F - F0
    t, t_end = t0, t0 + dt
    diss_c = diss_f = stuck_time = 0.0
    events = []
    for _ in range(50):
        if t >= t_end:
            break
        if v == 0.0:
            if abs(net) <= Fc:                  # stuck for the rest of the interval (F constant)
                stuck_time += t_end - t
                break
            s = 1.0 if net > 0 else -1.0
            if t == t0 and not events:          # stuck before this instant, breaks away now
                events.append((t, "slip", net, x))
        else:
            s = 1.0 if v > 0 else -1.0
        sol = solve_ivp(_rhs, (t, t_end), [x, v, 0.0, 0.0], method=method, rtol=RTOL, atol=ATOL,
                        first_step=t_end - t, events=_stop_pos if s > 0 else _stop_neg,
                        args=(s, F, m, c, Fc, F0))
        if sol.status == -1:
            raise RuntimeError(sol.message)
        if sol.status == 1 and sol.t_events[0].size:
            te = float(sol.t_events[0][0])
            ye = sol.y_events[0][0]
            x, v = float(ye[0]), 0.0
            diss_c += float(ye[2])
            diss_f += float(ye[3])
            events.append((te, "stick" if abs(net) <= Fc else "reverse", net, x))
            t = te
        else:
            x, v = float(sol.y[0, -1]), float(sol.y[1, -1])
            diss_c += float(sol.y[2, -1])
            diss_f += float(sol.y[3, -1])
            t = t_end
    else:
        raise RuntimeError("too many switches in one hold interval")
    return IntervalResult(x, v, diss_c, diss_f, stuck_time, events)


# --------------------------------------------------------------------------- the closed loop

@dataclass
class Record:
    t_s: np.ndarray
    x_true_m: np.ndarray
    v_true_m_s: np.ndarray
    y_measured_mm: np.ndarray
    force_N: np.ndarray             # logged: applied + logging noise
    force_applied_N: np.ndarray     # what acts on the carriage over [t_k, t_k+1)
    pulse_N: np.ndarray
    reference_mm: np.ndarray        # r_enc(t_k), encoder frame
    stuck: np.ndarray               # stuck over the whole hold interval starting at t_k
    diss_c_J: np.ndarray            # cumulative energy dissipated by c, at t_k
    diss_f_J: np.ndarray            # cumulative energy dissipated by Fc, at t_k
    events: list
    truth: dict = field(default_factory=dict)


def simulate(axis: Axis, controller: Controller, reference: Reference, sensor: Sensor, *,
             periods: float = 3.5, fs: float = 1000.0, pulses: Pulses | None = None,
             seed: int = 0, n_samples: int | None = None) -> Record:
    """The closed loop from rest for ``periods`` reference periods (or ``n_samples`` samples)."""
    t_wall = time.perf_counter()
    dt = 1.0 / fs
    n = int(n_samples) if n_samples is not None else int(round(periods * reference.period_s * fs))
    t = np.arange(n) * dt
    rng = np.random.default_rng(seed)
    pos_noise = rng.normal(0.0, sensor.noise_mm, n) if sensor.noise_mm > 0 else np.zeros(n)
    frc_noise = rng.normal(0.0, sensor.force_noise_N, n) if sensor.force_noise_N > 0 else np.zeros(n)
    r_enc = sensor.zero_mm + reference.r_mm(t)
    rdot_m_s = reference.rdot_mm_s(t) * 1e-3
    pulse = pulses.force_N(t, reference.period_s) if pulses is not None else np.zeros(n)
    a_filt = (1.0 - math.exp(-2.0 * math.pi * controller.velocity_cutoff_hz * dt)
              if controller.velocity_cutoff_hz else 1.0)
    res = sensor.resolution_mm

    x_true = np.zeros(n)
    v_true = np.zeros(n)
    y = np.zeros(n)
    f_app = np.zeros(n)
    stuck = np.zeros(n, dtype=bool)
    dc = np.zeros(n)
    df = np.zeros(n)
    events = []
    x, v = 0.0, 0.0
    v_f = 0.0
    stuck_time = 0.0
    for k in range(n):
        x_true[k], v_true[k] = x, v
        y[k] = np.round((sensor.zero_mm + 1e3 * x + pos_noise[k]) / res) * res
        v_raw = 0.0 if k == 0 else (y[k] - y[k - 1]) * 1e-3 / dt
        v_f = v_f + a_filt * (v_raw - v_f)
        e = (r_enc[k] - y[k]) * 1e-3
        u = controller.Kp * e + controller.Kd * (rdot_m_s[k] - v_f) + controller.kv * rdot_m_s[k]
        F = controller.gain * u + pulse[k]
        f_app[k] = F
        stuck[k] = v == 0.0 and abs(F - axis.F0) <= axis.Fc
        if k == n - 1:
            break
        step = hold_interval(axis, t[k], dt, x, v, F)
        x, v = step.x, step.v
        dc[k + 1] = dc[k] + step.diss_c
        df[k + 1] = df[k] + step.diss_f
        stuck_time += step.stuck_time
        events.extend(step.events)
    wall = time.perf_counter() - t_wall

    truth = {
        "axis": asdict(axis), "controller": asdict(controller), "reference": asdict(reference),
        "sensor": asdict(sensor), "pulses": asdict(pulses) if pulses is not None else None,
        "m_kg": axis.m, "c_N_s_m": axis.c, "Fc_N": axis.Fc, "F0_N": axis.F0,
        "period_s": reference.period_s, "fs_hz": fs, "periods": n * dt / reference.period_s,
        "seed": seed, "stroke_mm": reference.stroke_mm(),
        "stuck_time_fraction": stuck_time / (t[-1] - t[0]) if n > 1 else 0.0,
        "n_events": {kind: sum(1 for e in events if e[1] == kind) for kind in ("slip", "stick", "reverse")},
        "wall_s": wall,
    }
    return Record(t, x_true, v_true, y, f_app + frc_noise, f_app, pulse, r_enc, stuck, dc, df,
                  events, truth)


# --------------------------------------------------------------------------- the DAQ

def _decimals(resolution_mm: float) -> int:
    return max(6, int(math.ceil(-math.log10(resolution_mm))) + 3)


def write_daq_csv(path, record: Record) -> Path:
    """``time [s]``, ``x [mm]``, ``force [N]``, written to a temporary file then os.replace'd."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    res = record.truth.get("sensor", {}).get("resolution_mm", 0.001)
    xfmt = f"%.{_decimals(res)}f"
    data = np.column_stack([record.t_s, record.y_measured_mm, record.force_N])
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as f:
            np.savetxt(f, data, fmt=["%.6f", xfmt, "%.10g"], delimiter=",",
                       header="time [s],x [mm],force [N]", comments="")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


# --------------------------------------------------------------------------- the cases

def _case(axis, f_n_hz, zeta, gain, reference, sensor, pulses, *, kv_frac=0.0, cutoff=None):
    kp, kd = design_pd(axis.m, axis.c, f_n_hz, zeta, gain)
    ctrl = Controller(Kp=kp, Kd=kd, gain=gain, kv=kv_frac * axis.c / gain, velocity_cutoff_hz=cutoff)
    return {"axis": axis, "controller": ctrl, "reference": reference, "sensor": sensor,
            "pulses": pulses, "f_n_hz": f_n_hz, "zeta": zeta}


CASES = {
    # Heavy friction, soft loop, no offset: sticks for a good part of the cycle at reversals.
    "sticky": _case(Axis(m=40.0, c=80.0, Fc=55.0, F0=0.0), 5.0, 0.7, 1.0,
                    Reference(4.0, (20.0, 3.0), (-math.pi / 2, 0.3)),
                    Sensor(zero_mm=312.457, resolution_mm=0.001, noise_mm=0.002),
                    Pulses(amplitude_N=80.0, width_s=0.03, phase=0.3, alternate=True)),
    # Inclined axis: F0 about Fc / 2, stiffer loop, filtered rate, u in A (250 N/A).
    "incline": _case(Axis(m=25.0, c=150.0, Fc=30.0, F0=16.0), 10.0, 0.8, 250.0,
                     Reference(3.0, (15.0, 4.0, 1.5), (-math.pi / 2, 1.1, -0.4)),
                     Sensor(zero_mm=1024.318, resolution_mm=0.001, noise_mm=0.002),
                     Pulses(amplitude_N=45.0, width_s=0.04, phase=0.6, alternate=False),
                     cutoff=150.0),
    # Heavy carriage, strong drag, cable chain pulling backwards, viscous feed-forward.
    "heavy_chain": _case(Axis(m=60.0, c=350.0, Fc=40.0, F0=-12.0), 6.0, 0.9, 100.0,
                         Reference(5.0, (25.0, 5.0), (-math.pi / 2, 0.0)),
                         Sensor(zero_mm=45.210, resolution_mm=0.001, noise_mm=0.003,
                                force_noise_N=0.5),
                         Pulses(amplitude_N=60.0, width_s=0.05, phase=0.15, alternate=True),
                         kv_frac=1.0, cutoff=100.0),
    # Light, fast, stiff: small friction, fine encoder, noisy force log.
    "light_fast": _case(Axis(m=15.0, c=50.0, Fc=12.0, F0=5.0), 18.0, 0.6, 1.0,
                        Reference(2.0, (10.0, 2.0), (-math.pi / 2, -0.7)),
                        Sensor(zero_mm=87.6405, resolution_mm=0.0005, noise_mm=0.001,
                               force_noise_N=0.3),
                        Pulses(amplitude_N=25.0, width_s=0.02, phase=0.45, alternate=False),
                        cutoff=200.0),
    # Sticky and inclined the other way (F0 about -Fc / 2), very soft loop.
    "sticky_incline": _case(Axis(m=30.0, c=200.0, Fc=60.0, F0=-28.0), 7.0, 1.0, 1.0,
                            Reference(3.5, (18.0, 2.5), (-math.pi / 2, 0.9)),
                            Sensor(zero_mm=500.000, resolution_mm=0.001, noise_mm=0.002),
                            Pulses(amplitude_N=90.0, width_s=0.025, phase=0.8, alternate=True)),
}


def simulate_case(name: str, *, pulses: bool = False, seed: int = 0, periods: float = 3.5) -> Record:
    c = CASES[name]
    rec = simulate(c["axis"], c["controller"], c["reference"], c["sensor"], periods=periods,
                   pulses=c["pulses"] if pulses else None, seed=seed)
    rec.truth["case"] = name
    rec.truth["f_n_hz"], rec.truth["zeta"] = c["f_n_hz"], c["zeta"]
    return rec


def write_case(folder, name: str, seed: int = 0, *, return_records: bool = False):
    """``<name>_id.csv`` (from rest) and ``<name>_pulses.csv`` (validation, seed + 1) in folder;
    returns the truth: the parameters and each record's own truth (with return_records, also the
    two Record objects: ``truth, record_id, record_pulses``)."""
    folder = Path(folder)
    rec_id = simulate_case(name, seed=seed)
    rec_pu = simulate_case(name, pulses=True, seed=seed + 1)
    p_id = write_daq_csv(folder / f"{name}_id.csv", rec_id)
    p_pu = write_daq_csv(folder / f"{name}_pulses.csv", rec_pu)
    truth = {k: v for k, v in rec_id.truth.items()
             if k not in ("seed", "stuck_time_fraction", "n_events", "wall_s", "pulses")}
    truth.update({"case": name, "pulses": asdict(CASES[name]["pulses"]),
                  "files": {"id": str(p_id), "pulses": str(p_pu)},
                  "records": {"id": rec_id.truth, "pulses": rec_pu.truth}})
    return (truth, rec_id, rec_pu) if return_records else truth
