"""The restoring-force surface of a misfit: a residual joint torque over (phi, phi'), without a catalogue.

Masri and Caughey's restoring-force surface method (J. Appl. Mech. 46, 1979) plots the joint
torque against the relative angle and rate at every sample; any law of the form M(phi, phi')
is a surface there, and its shape names no cause in advance. Here the samples are the residual
joint torque that the final model leaves along the measured motion (one period of every run),
and the surface is represented by bilinear hat functions on a knot grid (eq. 8-9 of the paper
in two dimensions: ``r(phi, v) = sum_ij S_ij h_i(phi) h_j(v)``), fitted by least squares with a
small second-difference penalty that only bridges the gaps between the runs' loops.

The data cover only the loops the runs drew, so the surface is marked ``supported`` at the
knots with samples close by; numbers and plots use those knots only. Its two sections are
those of the method: the **stiffness section** ``S(phi, 0)`` (the elastic part of the misfit
against the angle) and the **damping section** ``S(0, v)`` (its dissipative part against the
rate). The split of the surface into parts even and odd in the rate (elastic and dissipative)
and in the angle (symmetric and asymmetric) is computed over knot pairs that are both supported.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from jointrig.vocab.law import hat_matrix

__all__ = ["RestoringSurface", "restoring_surface"]

#: Knot grid (odd counts, so that 0 is a knot of both axes).
N_PHI_KNOTS = 21
N_RATE_KNOTS = 21
#: Penalty weight relative to the mean diagonal of the normal equations: small enough that the
#: fit follows the samples where they are (measured: the fit leaves < 1% of a smooth residual's
#: RMS on the tests' loops), large enough to bridge the empty cells between loops.
PENALTY = 1e-3
#: A knot is supported when its hat functions carry at least this many samples' weight.
SUPPORT = 2.0


@dataclass(frozen=True)
class RestoringSurface:
    """A residual joint torque as a surface over the relative angle and rate (SI units).

    Attributes:
      phi_knots_rad, rate_knots_rad_s: the grid (symmetric about 0, odd counts).
      torque_Nm: ``(n_phi, n_rate)`` surface values at the knots.
      supported: ``(n_phi, n_rate)`` knots with samples close by (the rest is interpolation).
      rms_Nm: RMS of the residual samples; fit_rms_Nm: RMS of the samples minus the surface.
      elastic_share: power of the part even in the rate over the whole (1: a torque of the
        angle alone; 0: of the rate alone), over knots supported together with their mirror.
      symmetric_share: power of the part odd in the angle and the rate together,
        ``S(-phi, -v) = -S(phi, v)`` (a symmetric law), over the whole.
    """

    phi_knots_rad: np.ndarray
    rate_knots_rad_s: np.ndarray
    torque_Nm: np.ndarray
    supported: np.ndarray
    rms_Nm: float
    fit_rms_Nm: float
    elastic_share: float
    symmetric_share: float

    @property
    def stiffness_section(self) -> tuple[np.ndarray, np.ndarray]:
        """``(phi_rad, torque_Nm)`` of ``S(phi, 0)`` at the supported knots."""
        j = self.rate_knots_rad_s.size // 2
        keep = self.supported[:, j]
        return self.phi_knots_rad[keep], self.torque_Nm[keep, j]

    @property
    def damping_section(self) -> tuple[np.ndarray, np.ndarray]:
        """``(rate_rad_s, torque_Nm)`` of ``S(0, v)`` at the supported knots."""
        i = self.phi_knots_rad.size // 2
        keep = self.supported[i, :]
        return self.rate_knots_rad_s[keep], self.torque_Nm[i, keep]

    def evaluate(self, phi_rad: np.ndarray, rate_rad_s: np.ndarray) -> np.ndarray:
        """The surface at given points (N m; bilinear between knots, constant beyond the grid)."""
        return np.einsum("ni,ij,nj->n", hat_matrix(phi_rad, self.phi_knots_rad), self.torque_Nm,
                         hat_matrix(rate_rad_s, self.rate_knots_rad_s))

    def as_json(self) -> dict:
        return {"phi_knots_rad": self.phi_knots_rad.tolist(), "rate_knots_rad_s": self.rate_knots_rad_s.tolist(),
                "torque_Nm": np.where(self.supported, self.torque_Nm, np.nan).tolist(),
                "rms_Nm": self.rms_Nm, "fit_rms_Nm": self.fit_rms_Nm, "elastic_share": self.elastic_share,
                "symmetric_share": self.symmetric_share}


def _share(part: np.ndarray, whole: np.ndarray) -> float:
    total = float(np.sum(whole ** 2))
    return float(np.sum(part ** 2)) / total if total > 0 else 0.0


def restoring_surface(phi_rad: Sequence[np.ndarray], rate_rad_s: Sequence[np.ndarray],
                      residual_Nm: Sequence[np.ndarray], *, n_phi: int = N_PHI_KNOTS,
                      n_rate: int = N_RATE_KNOTS) -> RestoringSurface:
    """The residual's restoring-force surface from samples of every run (pure).

    ``phi_rad``, ``rate_rad_s``, ``residual_Nm``: per run, equal-length arrays (for example one
    band-limited period). The knots span the largest |phi| and |phi'| of the samples.
    """
    if not (len(phi_rad) == len(rate_rad_s) == len(residual_Nm)) or not len(phi_rad):
        raise ValueError("restoring_surface: phi_rad, rate_rad_s and residual_Nm need one array per run, "
                         f"got {len(phi_rad)}, {len(rate_rad_s)} and {len(residual_Nm)}")
    if n_phi < 3 or n_rate < 3 or n_phi % 2 == 0 or n_rate % 2 == 0:
        raise ValueError(f"restoring_surface: knot counts must be odd and >= 3, got {n_phi} and {n_rate}")
    x = np.concatenate([np.ravel(a) for a in phi_rad]).astype(float)
    v = np.concatenate([np.ravel(a) for a in rate_rad_s]).astype(float)
    r = np.concatenate([np.ravel(a) for a in residual_Nm]).astype(float)
    if not (x.size == v.size == r.size) or not np.all(np.isfinite(np.concatenate([x, v, r]))):
        raise ValueError("restoring_surface: each run's phi, rate and residual must be finite and of one length")
    top_x = max(float(np.max(np.abs(x))), 1e-300)
    top_v = max(float(np.max(np.abs(v))), 1e-300)
    kx = np.linspace(-top_x, top_x, n_phi)
    kv = np.linspace(-top_v, top_v, n_rate)
    Hx, Hv = hat_matrix(x, kx), hat_matrix(v, kv)
    B = (Hx[:, :, None] * Hv[:, None, :]).reshape(x.size, n_phi * n_rate)
    # second differences (rows 1, -2, 1) along each axis of the grid
    Dx = np.kron(np.diff(np.eye(n_phi), 2, axis=0), np.eye(n_rate))
    Dv = np.kron(np.eye(n_phi), np.diff(np.eye(n_rate), 2, axis=0))
    BtB = B.T @ B
    lam = PENALTY * float(np.trace(BtB)) / BtB.shape[0]
    S = np.linalg.solve(BtB + lam * (Dx.T @ Dx + Dv.T @ Dv), B.T @ r).reshape(n_phi, n_rate)
    weight = B.sum(axis=0).reshape(n_phi, n_rate)
    supported = weight >= SUPPORT
    # Parities over knots supported together with their mirror images.
    both_v = supported & supported[:, ::-1]
    both_pv = supported & supported[::-1, ::-1]
    even_v = 0.5 * (S + S[:, ::-1])
    odd_pv = 0.5 * (S - S[::-1, ::-1])
    fit_res = r - np.einsum("ni,ij,nj->n", Hx, S, Hv)
    return RestoringSurface(kx, kv, S, supported, float(np.sqrt(np.mean(r ** 2))),
                            float(np.sqrt(np.mean(fit_res ** 2))),
                            _share(even_v[both_v], S[both_v]), _share(odd_pv[both_pv], S[both_pv]))
