"""Virtual phase-resonance test on the MuJoCo rig: the backbone and damping as a lab measures them.

A lab drives the joint's mode with a phase-locked loop: the drive frequency is adjusted until
the response lags the force by 90 degrees, then the level is stepped. At phase resonance the
drive balances the dissipation alone, so (the relative coordinate's equation
``Je phi'' + f = share M``, first harmonics ``Phi = -i A`` against a real ``M0``)

    natural frequency  omega_n = omega                        (k_sec = Je omega^2)
    dissipation        E = pi share M0 A                      (the drive's work per cycle)
    damping ratio      zeta = E / (2 pi k_sec A^2) = share M0 / (2 Je omega^2 A)

Here the loop is a root search: for each drive level the steady state is simulated in the rig
(native callback) at trial frequencies and the phase lag of the relative angle's fundamental is
brought to 90 degrees by Brent's method (to ``xtol`` in omega). The result is the measured
card, independent of any describing function, to hold the identified card against.
"""

from __future__ import annotations

import cmath
import math
from typing import Optional, Sequence

from scipy.optimize import brentq

from jointrig.vocab.law import JointLaw
from jointrig.identify.card import CardPoint, JointCard, dissipation_slope
from jointrig.identify.harmonics import fourier_coefficients
from jointrig.vocab.plant import Plant

from jointrig.rig.model import RigModel
from jointrig.rig.simulate import SimulationConfig, simulate_steady_state

__all__ = ["phase_resonance"]


def _fundamentals(rig: RigModel, omega: float, level: float, law, config: SimulationConfig) -> tuple[complex, complex]:
    rec, _ = simulate_steady_state(rig, omega, level, config, law=law)
    phi = fourier_coefficients(rec.phi_rad, rec.n_periods, 1)[1]
    m = fourier_coefficients(rec.torque_Nm, rec.n_periods, 1)[1]
    return phi, m


def phase_resonance(rig: RigModel, levels_Nm: Sequence[float], *, law: Optional[JointLaw | Plant] = None,
                    omega_bracket_rad_s: tuple[float, float] = (5.0, 200.0), xtol_rad_s: float = 1e-6,
                    config: SimulationConfig = SimulationConfig(), progress=None) -> JointCard:
    """The card measured by phase resonance at each drive level (N m, on flywheel 1).

    Raises:
      ValueError: a level where the phase lag does not cross 90 degrees inside the bracket
        (the message gives the lags at both ends).
    """
    say = progress or (lambda msg: None)
    je, share = rig.Je_kgm2, rig.torque_share
    lo, hi = omega_bracket_rad_s
    points = []
    for level in levels_Nm:
        if not (level > 0 and math.isfinite(level)):
            raise ValueError(f"phase_resonance: drive levels must be finite and > 0 N m, got {level!r}")

        # Brent's method asks again for the bracket's ends, and the root it returns has been
        # simulated already: each frequency is simulated once per level (26 runs instead of 35
        # for three levels of an Iwan joint, the same numbers)
        seen: dict[float, tuple[complex, complex]] = {}

        def fundamentals(w: float, level=level, seen=seen) -> tuple[complex, complex]:
            if w not in seen:
                seen[w] = _fundamentals(rig, w, level, law, config)
            return seen[w]

        def lag(w: float) -> float:
            phi, m = fundamentals(w)
            return cmath.phase(phi / m) + math.pi / 2  # 0 at a 90-degree lag

        a, b = lag(lo), lag(hi)
        if not a * b < 0:
            raise ValueError(f"phase_resonance: at {level:g} N m the phase lag does not cross 90 degrees between "
                             f"{lo:g} and {hi:g} rad/s (lag {math.degrees(math.pi / 2 - a):.1f} and "
                             f"{math.degrees(math.pi / 2 - b):.1f} degrees); widen omega_bracket_rad_s")
        w = brentq(lag, lo, hi, xtol=xtol_rad_s)
        phi, m = fundamentals(w)
        amp = abs(phi)
        k = je * w * w
        e = math.pi * share * abs(m) * amp
        zeta = e / (2 * math.pi * k * amp * amp)
        say(f"{level:g} N m: phase resonance at {w:.6g} rad/s, amplitude {amp:.4g} rad, damping ratio {zeta:.4g}")
        points.append(CardPoint(amp, w, w, zeta, e, k, e / (math.pi * w * amp * amp), amplitude_rad_std=0.0,
                                run=f"{level:g} N m"))
    points.sort(key=lambda p: p.amplitude_rad)
    return JointCard("phase_resonance", je, tuple(points), *dissipation_slope(points))
