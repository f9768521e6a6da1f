"""An independent bench for a single-axis linear drive, for the tests: a carriage on a guide with
dry friction, integrated by scipy. Nothing here uses jointrig.

The carriage (mass m, kg) obeys, while it slides (rate v != 0),

    m x'' = F(t) - c v - k x - A sin(2 pi x / p) - (Fc + (Fs - Fc) exp(-(v / vs)^2)) sign(v)

(c: the guide's viscous drag, N s/m; k: a spring to ground, N/m, 0 for a free axis; A, p: a
linear motor's cogging force and its pole pitch, N and m, A = 0 for none; Fc: the guide's dry
friction, N; Fs, vs: a Stribeck peak, the static friction above Fc and the speed over which it
falls to Fc, Fs <= Fc for none) and stands still while the force on it,
``|F(t) - k x - A sin(2 pi x / p)|``, is at most max(Fs, Fc). The switches are events of the integrator (DOP853, rtol 1e-10): sliding ends where v
crosses zero and the force there cannot overcome the friction; sticking ends where it can.
:func:`daq_file` writes one long run the way a motion controller's trace does: a fixed sample
rate, an absolute linear encoder (positions about its reading at rest), the motor's force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp


@dataclass(frozen=True)
class Carriage:
    m: float = 12.0      # kg
    c: float = 40.0      # N s/m
    k: float = 0.0       # N/m
    Fc: float = 25.0     # N
    cog: float = 0.0     # N, the cogging force's amplitude
    pitch: float = 0.01  # m, its period in x
    Fs: float = 0.0      # N, the static friction (a Stribeck peak above Fc; at most Fc: none)
    vs: float = 0.01     # m/s, the Stribeck speed: sliding friction Fc + (Fs - Fc) exp(-(v / vs)^2)

    @property
    def static(self) -> float:
        """The force that holds the carriage at rest (N): the Stribeck peak, or Fc."""
        return max(self.Fs, self.Fc)

    def sliding(self, v: float) -> float:
        """The guide's friction while it slides at rate v (N, its size)."""
        return self.Fc + (self.static - self.Fc) * math.exp(-(v / self.vs) ** 2)


def _simulate(car: Carriage, w: float, F0: float, t_eval: np.ndarray, y0, mode: int, t0: float):
    """Integrate from (t0, y0, mode) through t_eval: states at t_eval, final state and mode.
    ``mode``: +1 / -1 sliding with that sign of v, 0 stuck."""
    out = np.empty((t_eval.size, 2))
    t, y, i = t0, np.array(y0, float), 0

    def force(tt, x):
        return F0 * math.cos(w * tt) - car.k * x - car.cog * math.sin(2 * math.pi * x / car.pitch)

    while True:
        sel = t_eval[(t_eval >= t) & (np.arange(t_eval.size) >= i)]
        if mode == 0 and abs(force(t, y[0])) > car.static:  # a force that already exceeds the friction
            mode = 1 if force(t, y[0]) > 0 else -1
        if mode == 0:
            def rhs(tt, yy):
                return [0.0, 0.0]

            def unsticks(tt, yy):
                return abs(force(tt, yy[0])) - car.static
            unsticks.terminal, unsticks.direction = True, 1
            events = [unsticks]
        else:
            s = mode

            def rhs(tt, yy, s=s):
                return [yy[1], (force(tt, yy[0]) - car.c * yy[1] - s * car.sliding(yy[1])) / car.m]

            def stops(tt, yy):
                return yy[1]
            stops.terminal, stops.direction = True, -s
            events = [stops]
        sol = solve_ivp(rhs, (t, t_eval[-1]), y, method="DOP853", rtol=1e-10, atol=1e-13, t_eval=sel, events=events)
        if not sol.success:
            raise RuntimeError(sol.message)
        k = len(sol.t)
        if k:
            out[i:i + k] = np.asarray(sol.y).T
        i += k
        if sol.status == 0:
            return out, out[-1].copy(), mode
        t = float(sol.t_events[0][0])
        y = np.array(sol.y_events[0][0], float)
        if mode == 0:
            mode = 1 if force(t, y[0]) > 0 else -1
        else:
            y[1] = 0.0
            mode = 0 if abs(force(t, y[0])) <= car.static else -mode
        t = math.nextafter(t, math.inf)


def steady_state(car: Carriage, w: float, F0: float, *, tol: float = 1e-9, max_periods: int = 500):
    """(t, state, mode) once the motion repeats period to period to ``tol`` of its swing."""
    T = 2 * math.pi / w
    t, y, mode = 0.0, np.array([0.0, 0.0]), 0
    prev = None
    for p in range(max_periods):
        grid = t + T * np.linspace(0, 1, 65)[1:]
        ys, y, mode = _simulate(car, w, F0, grid, y, mode, t)
        t = grid[-1]
        v = ys[:, 1]
        if prev is not None and np.max(np.abs(v - prev)) < tol * (np.ptp(v) + 1e-12):
            return t, y, mode
        prev = v
    raise RuntimeError(f"no steady state after {max_periods} periods")


def _trace(car: Carriage, w: float, F0: float, rng, fs_Hz: float, n_periods: float, snr_db: float,
           at_rest_m: float, force_offset_N: float = 0.0):
    t, y, mode = steady_state(car, w, F0)
    T = 2 * math.pi / w
    start = t + rng.uniform(0, T)
    n = int(n_periods * T * fs_Hz)
    t_eval = start + np.arange(n) / fs_Hz
    ys, _, _ = _simulate(car, w, F0, t_eval, y, mode, t)
    x = ys[:, 0]
    F = F0 * np.cos(w * t_eval)
    F_meas = F + force_offset_N + rng.normal(0.0, np.std(F) * 10 ** (-snr_db / 20), n)
    x_meas = at_rest_m + x + rng.normal(0.0, np.std(x) * 10 ** (-snr_db / 20), n)
    return t_eval - start, F_meas, x_meas


def daq_file(car: Carriage, w: float, F0: float, path, *, fs_Hz: float = 10000.0, n_periods: float = 30.4,
             snr_db: float = 40.0, at_rest_m: float = 0.3512, seed: int = 0, force_offset_N: float = 0.0):
    """One long run of the drive at ``w`` rad/s and ``F0`` N, written as a motion controller's trace:
    ``time [s], force [N], x [mm]`` at a fixed rate from a random phase, the absolute encoder's
    position (``at_rest_m`` plus the motion), white noise at ``snr_db`` on both; the force sensor
    reads ``force_offset_N`` at rest (or a constant load acts: gravity on the axis, a cable's drag)."""
    t, F, x = _trace(car, w, F0, np.random.default_rng(seed), fs_Hz, n_periods, snr_db, at_rest_m, force_offset_N)
    lines = ["time [s],force [N],x [mm]"]
    lines += [f"{tt:.5f},{f:.5f},{xx * 1e3:.6f}" for tt, f, xx in zip(t, F, x)]
    path.write_text("\n".join(lines) + "\n")
    return path


def daq_runs(car: Carriage, points, path, *, fs_Hz: float = 10000.0, n_periods: float = 6.3, snr_db: float = 40.0,
             at_rest_m: float = 0.3512, seed: int = 0, force_offset_N: float = 0.0):
    """Several runs, one per ``(omega rad/s, force amplitude N)``, in one file with a ``run`` column
    (the same trace as :func:`daq_file`, ``force_offset_N`` too; the carriage is not moved between
    runs, so every run's positions are about where its steady state settled)."""
    rng = np.random.default_rng(seed)
    lines = ["run,time [s],force [N],x [mm]"]
    for r, (w, F0) in enumerate(points):
        t, F, x = _trace(car, w, F0, rng, fs_Hz, n_periods, snr_db, at_rest_m, force_offset_N)
        lines += [f"{r},{tt:.5f},{f:.5f},{xx * 1e3:.6f}" for tt, f, xx in zip(t, F, x)]
    path.write_text("\n".join(lines) + "\n")
    return path


if __name__ == "__main__":
    # python tests/bench_slide_sim.py OUT.csv: one long run of the carriage (12 kg, 40 N s/m, 25 N of
    # dry friction) at 2 Hz and 150 N, the file of the README and docs/drive-trains.md.
    import sys
    from pathlib import Path

    print(daq_file(Carriage(), 12.566, 150.0, Path(sys.argv[1])))
