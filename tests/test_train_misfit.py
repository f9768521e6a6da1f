"""Where a train's unexplained misfit is, and what it looks like (identify.chain_diagnose.train_misfit).

Exact records of a two-body train (no noise) whose joint is stiffer than the fitted model
says: the residual the description reads at the joint must be the missing stiffness times the
twist, whatever the drive on the second body; a single body's residual to ground, the missing
drag times its rate. The measured files of an unexplained train (a Maxwell element in the
pump train's coupling; a slide's cogging too weak to validate) are in tests/test_train_files.py.
"""

import math

import numpy as np
import pytest

from jointrig.identify.chain import ChainRecord
from jointrig.identify.chain_diagnose import ChainFit, nominal_spec, prepare_chain_runs, train_misfit

W, A = 7.0, 0.02  # rad/s, rad
J = (2.0, 1.5)
K_TRUE, K_FIT, C = 1200.0, 1000.0, 40.0


def _fit(spec, values: dict) -> ChainFit:
    names = tuple(values)
    return ChainFit(spec, names, np.array([values[n] for n in names]), np.zeros(len(names)), 0.0, 100,
                    np.zeros(100))


def _record(n_periods=3, samples=256):
    t = np.arange(n_periods * samples) * (2 * math.pi / W) / samples
    x1 = A * np.cos(W * t)
    x2 = 0.3 * A * np.cos(W * t + 0.4)
    v1, v2 = -A * W * np.sin(W * t), -0.3 * A * W * np.sin(W * t + 0.4)
    a1, a2 = -W * W * x1, -W * W * x2
    f = K_TRUE * (x1 - x2) + C * (v1 - v2)  # the joint's true torque, on body 2, minus on body 1
    return ChainRecord(W, t, (J[0] * a1 + f, J[1] * a2 - f), (x1 + 0.5, x2 + 0.5), None, n_periods, 1.0,
                       source="exact")


def test_the_residual_at_a_joint_is_what_its_law_misses():
    # 1e-9 of the joint torque: the spectral derivatives of exact band-limited periods
    run = prepare_chain_runs([_record()], band=10)[0]
    fit = _fit(nominal_spec(2), {"J1_kgm2": J[0], "joint1_c_Nms_per_rad": C, "joint1_k_Nm_per_rad": K_FIT,
                                 "joint1_gamma_Nm_per_rad3": 0.0, "J2_kgm2": J[1]})
    m = train_misfit([run], ["r"], [1.0], fit, band=10)
    assert m.where == "joint 1" and m.by_place[0][0] == "joint 1"
    twist = m.samples.phi_rad[0]
    residual = m.samples.residual_Nm[0]
    expected = (K_TRUE - K_FIT) * twist
    assert np.max(np.abs(residual - expected)) < 1e-9 * np.max(np.abs(K_TRUE * twist))
    # the missing stiffness: elastic, odd, on the fundamental alone
    c = m.character
    assert c.dissipative_share < 1e-6 and c.even_share < 1e-12 and c.top_harmonics[0] == 1
    # its share of the joint's measured torque (k_true twist + c twist'), RMS over RMS
    share = (K_TRUE - K_FIT) / abs(K_TRUE + 1j * W * C)  # one harmonic: the ratio of amplitudes
    assert m.by_place[0][1] == pytest.approx(share, rel=1e-9)


def test_a_constant_torque_that_a_laws_zero_gives_is_no_misfit():
    # The model's twist zero 0.05 rad off: its law reads a constant -K_FIT * 0.05 more along the
    # measured motion. The balance fits harmonics 1 and up, so the residual is the one without
    # the offset, (K_TRUE - K_FIT) times the twist about its own mean, and has no mean of its own.
    from dataclasses import replace

    run = prepare_chain_runs([_record()], band=10)[0]
    values = {"J1_kgm2": J[0], "joint1_c_Nms_per_rad": C, "joint1_k_Nm_per_rad": K_FIT,
              "joint1_gamma_Nm_per_rad3": 0.0, "J2_kgm2": J[1]}
    m = train_misfit([run], ["r"], [1.0], _fit(replace(nominal_spec(2), offsets_rad=(0.05,)), values), band=10)
    twist, residual = m.samples.phi_rad[0], m.samples.residual_Nm[0]
    expected = (K_TRUE - K_FIT) * (twist - np.mean(twist))
    assert np.max(np.abs(residual - expected)) < 1e-9 * np.max(np.abs(K_TRUE * twist))
    assert abs(np.mean(residual)) < 1e-9 * K_FIT * 0.05


def test_a_single_bodys_residual_is_its_missing_drag_in_its_own_units():
    t = np.arange(3 * 256) * (2 * math.pi / W) / 256
    x = A * np.cos(W * t)
    drive = J[0] * (-W * W * x) + 2 * C * (-A * W * np.sin(W * t))  # the true drag is 2 C
    rec = ChainRecord(W, t, (drive,), (x,), None, 3, 1.0, source="exact")
    run = prepare_chain_runs([rec], band=10)[0]
    fit = _fit(nominal_spec(1), {"J1_kgm2": J[0], "bearing1_damping_Nms_per_rad": C})
    m = train_misfit([run], ["r"], [1.0], fit, band=10, kind="slide")
    assert m.where == "body 1 to ground"
    rate = -A * W * np.sin(W * np.linspace(0, 2 * math.pi / W, m.samples.residual_Nm[0].size, endpoint=False))
    assert np.max(np.abs(m.samples.residual_Nm[0] - C * rate)) < 1e-9 * C * A * W
    from jointrig.present.misfit_words import misfit_texts

    character, surface = misfit_texts(m)
    assert "residual force to ground" in character and "dissipative at the fundamental" in character
    assert " N over x " in surface and " m/s" in surface and "N m" not in surface

