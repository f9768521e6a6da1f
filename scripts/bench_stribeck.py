#!/usr/bin/env python3
"""A carriage whose guide has a narrow Stribeck peak: what the diagnosis reads, and what the
harmonic balance could read.

    python scripts/bench_stribeck.py [--db 40] [--seed 0]      # the diagnosis of a DAQ file
    python scripts/bench_stribeck.py --reference               # the balance on exact rates

The carriage of tests/bench_slide_sim.py (12 kg, 40 N s/m) with a guide of 20 N sliding
friction and 30 N static, falling off over 0.01 m/s (``Carriage(Fc=20, Fs=30, vs=0.01)``), 9
runs at 1, 2 and 4 Hz and 80, 150, 300 N: it slides through rest in every run, and its rate
passes the peak in 1-4 ms at a reversal.

- Default: the scipy bench writes the runs as a DAQ does (10 kHz, white noise ``--db`` below
  each channel's RMS, the encoder's own zero); ``jointrig.diagnose`` reads them. One row per
  parameter: fitted, its standard error, the truth and z. About 4 min on 2 cores.
- ``--reference``: no diagnosis. The fitted runs' exact steady states (the scipy bench on 16
  times the diagnosis's samples) balanced at harmonics 1..20 with columns of mass, drag, dry
  friction and a Stribeck peak over a grid of Stribeck speeds, noise-free, the friction columns
  taken along (a) the exact rate, (b) the exact rate at the diagnosis's 4096 samples per period,
  (c) the rate the diagnosis builds: harmonics 1..20 of the position, the dry friction's kinks
  restored (``identify.kink``). What harmonics 1..20 identify when the rate is right, and what
  the band-limited rate costs. About 10 s.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from bench_slide_sim import Carriage, _simulate, daq_runs, steady_state  # noqa: E402

CARRIAGE = Carriage(Fc=20.0, Fs=30.0, vs=0.01)
POINTS = [(w, F) for w in (6.283, 12.566, 25.13) for F in (80.0, 150.0, 300.0)]
HELD_OUT = (1, 4, 7)  # the middle level, as the diagnosis holds out (studies.holdout)
TRUTH = {"J1_kgm2": CARRIAGE.m, "bearing1_damping_Nms_per_rad": CARRIAGE.c,
         "ground1_coulomb_torque_Nm": CARRIAGE.Fc, "ground1_stribeck_torque_Nm": CARRIAGE.Fs - CARRIAGE.Fc,
         "ground1_stribeck_velocity_rad_s": CARRIAGE.vs}
H = 20


def diagnosis(db: float, seed: int) -> int:
    from jointrig import diagnose

    with tempfile.TemporaryDirectory() as tmp:
        print(f"writing 9 runs at {db:g} dB (seed {seed}) ...", file=sys.stderr, flush=True)
        path = daq_runs(CARRIAGE, POINTS, Path(tmp) / "axis.csv", snr_db=db, seed=seed)
        print("diagnosing ...", file=sys.stderr, flush=True)
        t0 = time.time()
        d = diagnose(path)
    extended = d.json().get("extended") or {}
    print(f"verdict {d.verdict}; adopted: {', '.join(extended.get('effects') or ['nothing'])} ({time.time() - t0:.0f} s)")
    for b in extended.get("on_search_bound", []):
        print(f"{b['parameter']} lies on the {b['side']} end of its search ({b['bound']:.4g})")
    values, errors = d.parameters(), d.std_errors()
    print(f"{'parameter':36s} {'fitted':>12s} {'SE':>10s} {'truth':>8s} {'z':>7s}")
    for name, v in values.items():
        truth = TRUTH.get(name)
        z = (v - truth) / errors[name] if truth is not None and errors[name] > 0 else math.nan
        print(f"{name:36s} {v:12.6g} {errors[name]:10.2g} {truth if truth is not None else math.nan:8.4g} {z:7.2f}")
    return 0


def reference() -> int:
    from jointrig.identify.harmonics import fourier_coefficients, synthesize
    from jointrig.identify.kink import FINE_SAMPLES, kink_corrected_rate
    from jointrig.vocab.law import Coulomb, Stribeck

    exact_samples = 16 * FINE_SAMPLES
    runs = []
    for k, (w, F0) in enumerate(POINTS):
        if k in HELD_OUT:
            continue
        print(f"exact steady state at {w:g} rad/s, {F0:g} N ...", file=sys.stderr, flush=True)
        t, y, mode = steady_state(CARRIAGE, w, F0)
        te = t + (2 * math.pi / w) * np.arange(exact_samples) / exact_samples
        states, _, _ = _simulate(CARRIAGE, w, F0, te, y, mode, t)
        x = synthesize(fourier_coefficients(states[:, 0], 1, H), FINE_SAMPLES)  # band-limited, as the diagnosis keeps it
        runs.append((w, states[:, 1], F0 * np.cos(w * te), x))
    jump = 2.0 * CARRIAGE.Fs / CARRIAGE.m  # the acceleration's jump at a reversal, as the diagnosis restores it

    rates = {"exact rate, fine grid": lambda w, v, x: v,
             f"exact rate, {FINE_SAMPLES} samples": lambda w, v, x: v[:: v.size // FINE_SAMPLES],
             "band 1..20, kinks restored": lambda w, v, x: kink_corrected_rate(x, w, H, jump)}

    def fit(rate_of, vs):
        rows, rhs = [], []
        for w, v, force, x in runs:
            r = rate_of(w, v, x)
            c = [fourier_coefficients(law(None, r), 1, H)[1:] for law in (Coulomb(), Stribeck(vs))]
            acc, rate, drive = (fourier_coefficients(q, 1, H)[1:] for q in (v, v, force))
            A = np.column_stack([1j * w * np.arange(1, H + 1) * acc, rate, c[0], c[1]])
            rows.append(np.vstack([A.real, A.imag]))
            rhs.append(np.concatenate([drive.real, drive.imag]))
        A, b = np.vstack(rows), np.concatenate(rhs)
        scale = np.linalg.norm(A, axis=0)
        theta = np.linalg.lstsq(A / scale, b, rcond=None)[0]
        res = b - (A / scale) @ theta
        return float(res @ res), theta / scale

    grid = np.geomspace(0.003, 0.1, 31)
    print(f"truth: m {CARRIAGE.m} kg, c {CARRIAGE.c} N s/m, Fc {CARRIAGE.Fc} N, excess {CARRIAGE.Fs - CARRIAGE.Fc} N "
          f"over {CARRIAGE.vs} m/s; harmonics 1..{H} of the 6 fitted runs, noise-free")
    for name, rate_of in rates.items():
        fits = [fit(rate_of, g) for g in grid]
        best = int(np.argmin([f[0] for f in fits]))
        m, c, fc, fx = fits[best][1]
        print(f"{name:31s} best Stribeck speed {grid[best]:.4f} m/s: excess {fx:6.2f} N, Fc {fc:.3f} N, m {m:.4f} kg, "
              f"c {c:.3f} N s/m")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--db", type=float, default=40.0, help="noise level, dB below each channel's RMS (default 40)")
    p.add_argument("--seed", type=int, default=0, help="the noise's seed (default 0)")
    p.add_argument("--reference", action="store_true", help="the balance on exact rates instead of a diagnosis")
    args = p.parse_args(argv)
    return reference() if args.reference else diagnosis(args.db, args.seed)


if __name__ == "__main__":
    sys.exit(main())
