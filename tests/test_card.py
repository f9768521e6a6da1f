"""The joint card (identify/card.py): describing functions against closed forms, the card of a law
against the card from runs simulated in the rig, and the dissipation slopes of the regimes."""

import math

import numpy as np
import pytest

from jointrig.vocab import JointLaw, Power, Viscous
from jointrig.vocab.law import Coulomb, Iwan, Jenkins
from jointrig.identify.card import describing_function, law_card, runs_card
from jointrig.rig import SimulationConfig, simulate_steady_state

from conftest import needs_cc

JE = 1.0  # J1 = J2 = 2 kg m^2 (the paper's flywheels)
A = (0.01, 0.03, 0.1, 0.3)


def test_linear_viscous_joint_in_closed_form():
    law = JointLaw((Viscous(), Power(1)), (100.0, 2000.0))
    k, c = describing_function(law, 0.05, 37.0)
    # rtol 1e-12: trapezoidal sums of trigonometric polynomials are exact up to round-off.
    assert (k, c) == (pytest.approx(2000.0, rel=1e-12), pytest.approx(100.0, rel=1e-12))
    card = law_card(law, JE, A, covariance=np.diag([5.0**2, 0.0]))
    wn = math.sqrt(2000.0 / JE)
    for p in card.points:
        assert p.natural_frequency_rad_s == pytest.approx(wn, rel=1e-12)
        assert p.damping_ratio == pytest.approx(100.0 / (2 * math.sqrt(2000.0 * JE)), rel=1e-12)
        assert p.dissipation_J_per_cycle == pytest.approx(math.pi * 100.0 * wn * p.amplitude_rad**2, rel=1e-12)
        # Only c uncertain (5 N m s/rad): zeta and E scale with c, omega_n does not move
        # (central differences of linear functions: exact to round-off; 1e-6 of a relative step).
        assert p.damping_ratio_std == pytest.approx(5.0 / (2 * JE * wn), rel=1e-6)
        assert p.dissipation_J_per_cycle_std == pytest.approx(math.pi * 5.0 * wn * p.amplitude_rad**2, rel=1e-6)
        assert p.natural_frequency_rad_s_std == pytest.approx(0.0, abs=1e-9 * wn)
    assert card.dissipation_slope == pytest.approx(2.0, abs=1e-9)  # viscous: E ~ A^2


def test_a_linear_joints_backbone_on_another_inertia_and_a_trains_run_rows():
    # Je = 0.04 kg m^2 (a train's coupling between two light bodies): omega_n = sqrt(k / Je) and
    # zeta = c / (2 Je omega_n), exact to round-off. The rows of a joint's measured runs
    # (joint_runs_card: per period the twist's and the carried torque's coefficients) of the same
    # joint: k, c and E = pi c w A^2 exactly, and the natural frequency's standard error
    # 0.5 omega_n se(k) / k from the periods' spread of k (here +-1% alternating: se(k) = 0.01 k /
    # sqrt(P) with the P - 1 = 3 degrees of freedom's (P / (P - 1))^(1/2)).
    from jointrig.identify.card import JointRun, joint_runs_card

    je, c, k = 0.04, 3.0, 2.5e4
    law = JointLaw((Viscous(), Power(1)), (c, k))
    wn = math.sqrt(k / je)
    for p in law_card(law, je, A).points:
        assert p.natural_frequency_rad_s == pytest.approx(wn, rel=1e-12)
        assert p.damping_ratio == pytest.approx(c / (2 * je * wn), rel=1e-12)
    w, P = 300.0, 4
    Phi = np.zeros((P, 6), complex)
    Phi[:, 1] = 1e-3
    scale = 1.0 + 0.01 * np.array([1, -1, 1, -1])
    F = (k * scale[:, None] + 1j * w * c) * Phi
    card = joint_runs_card([JointRun("r", w, Phi, F)], je)
    q = card.points[0]
    assert q.secant_stiffness_Nm_per_rad == pytest.approx(k, rel=1e-12)
    assert q.equivalent_damping_Nms_per_rad == pytest.approx(c, rel=1e-12)
    assert q.dissipation_J_per_cycle == pytest.approx(math.pi * c * w * 1e-6, rel=1e-12)
    se_k = 0.01 * k * math.sqrt(P / (P - 1)) / math.sqrt(P)
    assert q.secant_stiffness_Nm_per_rad_std == pytest.approx(se_k, rel=1e-9)
    assert q.natural_frequency_rad_s == pytest.approx(wn, rel=1e-12)
    assert q.natural_frequency_rad_s_std == pytest.approx(0.5 * wn * se_k / k, rel=1e-9)
    assert q.dissipation_J_per_cycle_std == pytest.approx(0.0, abs=1e-12 * q.dissipation_J_per_cycle)  # c did not vary


def test_runs_of_a_linear_joint_give_its_stiffness_and_damping():
    # Exact steady states of Je phi'' + c phi' + k phi = s M0 cos(w t) (J1 = J2 = 2, s = 1/2): the
    # runs' rows are k and c themselves (the loop's first harmonic and area), to round-off.
    from jointrig.vocab.records import SteadyStateRecord

    c, k, M0, n, P = 100.0, 2000.0, 400.0, 64, 3
    recs = []
    for w in (20.0, 45.0):
        X = 0.5 * M0 / (k - JE * w * w + 1j * c * w)
        t = np.arange(P * n) * (2 * math.pi / w / n)
        recs.append(SteadyStateRecord(w, t, M0 * np.cos(w * t), (X * np.exp(1j * w * t)).real, None, n_periods=P))
    for q in runs_card(recs, 2.0, 2.0).points:
        assert q.secant_stiffness_Nm_per_rad == pytest.approx(k, rel=1e-9)
        assert q.equivalent_damping_Nms_per_rad == pytest.approx(c, rel=1e-9)


def test_light_damping_beside_a_stiff_spring_is_kept_at_a_high_frequency():
    # k = 1e6 N m/rad, c = 5e-4 N m s/rad at 1000 rad/s: the damping torque c A omega is 5e-7 of the
    # spring's k A, far above the round-off floor (1e-12 of the torque) below which a harmonic is
    # called none. The damping is the law's own c; rel 1e-6: the spring's part of the sine sum is
    # round-off, k eps / omega ~ 1e-13 N m s/rad against c (2e-10 relative).
    law = JointLaw((Viscous(), Power(1)), (5e-4, 1e6))
    k, c = describing_function(law, 0.01, 1000.0)
    assert k == pytest.approx(1e6, rel=1e-12)
    assert c == pytest.approx(5e-4, rel=1e-6)


def test_a_laws_card_at_given_frequencies_is_off_the_backbone():
    # A linear viscous joint at the runs' own frequencies (omegas_rad_s): each point is evaluated
    # at its omega, the natural frequency stays sqrt(k / Je), the dissipation is pi c omega A^2 and
    # the damping ratio is the loss factor's half E / (2 pi k A^2) = c omega / (2 k), not the
    # backbone's c / (2 Je omega_n). rel 1e-12: sums of trigonometric polynomials, exact to
    # round-off.
    c, k, je = 100.0, 2000.0, 0.5
    amps, omegas = (0.01, 0.05), (20.0, 90.0)
    card = law_card(JointLaw((Viscous(), Power(1)), (c, k)), je, amps, omegas_rad_s=omegas)
    for p, a, w in zip(card.points, amps, omegas):
        assert p.omega_rad_s == w
        assert p.natural_frequency_rad_s == pytest.approx(math.sqrt(k / je), rel=1e-12)
        assert p.dissipation_J_per_cycle == pytest.approx(math.pi * c * w * a * a, rel=1e-12)
        assert p.damping_ratio == pytest.approx(c * w / (2 * k), rel=1e-12)
        assert (p.secant_stiffness_Nm_per_rad, p.equivalent_damping_Nms_per_rad) == (
            pytest.approx(k, rel=1e-12), pytest.approx(c, rel=1e-12))


def test_a_laws_card_off_the_backbone_without_stiffness_still_has_its_dissipations_error():
    # Viscous damping and dry friction alone, at a run's frequency: the secant stiffness is 0, so
    # there is no natural frequency (nor its error), but the dissipation per cycle,
    # pi c omega A^2 + 4 F A, has an error from the law's covariance all the same:
    # var E = (pi omega A^2)^2 var c + (4 A)^2 var F (rel 1e-6: the describing function's midpoint
    # rule at dry friction's kink, about 1e-7, identify.card.N_THETA).
    c, F, a, w = 100.0, 20.0, 0.01, 30.0
    cov = np.diag([4.0, 0.25])
    card = law_card(JointLaw((Viscous(), Coulomb()), (c, F)), JE, (a,), omegas_rad_s=(w,), covariance=cov)
    p = card.points[0]
    assert math.isnan(p.natural_frequency_rad_s) and math.isnan(p.natural_frequency_rad_s_std)
    assert p.dissipation_J_per_cycle == pytest.approx(math.pi * c * w * a * a + 4 * F * a, rel=1e-6)
    assert p.dissipation_J_per_cycle_std == pytest.approx(
        math.hypot(math.pi * w * a * a * 2.0, 4 * a * 0.5), rel=1e-6)


@pytest.mark.parametrize("omegas", [(20.0, 30.0, 40.0), (20.0,), (20.0, 0.0)],
                         ids=["one_too_many", "one_too_few", "a_zero"])
def test_a_laws_card_needs_one_positive_frequency_per_amplitude(omegas):
    # Too many frequencies are not ignored, too few not an IndexError, a zero not left to the
    # describing function: each is refused up front with what law_card needs.
    law = JointLaw((Viscous(), Power(1)), (100.0, 2000.0))
    with pytest.raises(ValueError, match="one frequency > 0 per amplitude"):
        law_card(law, JE, (0.01, 0.05), omegas_rad_s=omegas)


def test_runs_card_keeps_every_harmonic_below_nyquist_and_the_spread_of_the_periods():
    # A linear viscous joint (Je = 1, share 1/2) driven so that its twist is
    # A cos(th) + 0.1 A cos(7 th + 0.3), sampled 16 times a period: harmonics 1..7 lie below
    # Nyquist (8) and all go into the loop area, E = pi c omega sum n^2 |Phi_n|^2 =
    # pi c omega A^2 (1 + 49 / 100); without the 7th it would be a third smaller. The stiffness
    # alternates +-1% over the 4 periods: the secant stiffness's standard error is
    # 0.01 k / sqrt(P - 1) (the spread with P - 1 degrees of freedom over sqrt(P)), and the natural
    # frequency's 0.5 omega_n se(k) / k. rel 1e-9: the exact signals' coefficients to round-off;
    # the loop area and the stiffness do not depend on which period is stiffer.
    from jointrig.vocab.records import SteadyStateRecord

    c, k, w, a, n, P = 100.0, 2000.0, 30.0, 0.02, 16, 4
    th = 2 * math.pi * np.arange(P * n) / n
    phi = a * (np.cos(th) + 0.1 * np.cos(7 * th + 0.3))
    rate = -a * w * (np.sin(th) + 0.7 * np.sin(7 * th + 0.3))
    acc = -a * w * w * (np.cos(th) + 4.9 * np.cos(7 * th + 0.3))
    kq = k * np.repeat(1.0 + 0.01 * np.array([1, -1, 1, -1]), n)
    torque = 2.0 * (JE * acc + c * rate + kq * phi)  # share M = Je phi'' + c phi' + k phi
    rec = SteadyStateRecord(w, th / w, torque, phi, None, n_periods=P)
    (q,) = runs_card([rec], 2.0, 2.0).points
    assert q.amplitude_rad == pytest.approx(a, rel=1e-9)
    assert q.dissipation_J_per_cycle == pytest.approx(math.pi * c * w * a * a * 1.49, rel=1e-9)
    assert q.secant_stiffness_Nm_per_rad == pytest.approx(k, rel=1e-9)
    se_k = 0.01 * k / math.sqrt(P - 1)
    assert q.secant_stiffness_Nm_per_rad_std == pytest.approx(se_k, rel=1e-9)
    wn = math.sqrt(k / JE)
    assert q.natural_frequency_rad_s == pytest.approx(wn, rel=1e-9)
    assert q.natural_frequency_rad_s_std == pytest.approx(0.5 * wn * se_k / k, rel=1e-9)


def test_cubic_stiffening_backbone():
    law = JointLaw((Viscous(), Power(1), Power(3)), (100.0, 2000.0, 2e5))
    for a in A:
        assert describing_function(law, a, 50.0)[0] == pytest.approx(2000.0 + 0.75 * 2e5 * a * a, rel=1e-12)
    card = law_card(law, JE, A)
    wn = [p.natural_frequency_rad_s for p in card.points]
    assert wn == sorted(wn) and wn[-1] > 1.5 * wn[0]  # stiffening: the backbone bends right


def test_dry_friction_dissipates_4FA_slope_1():
    F = 60.0
    law = JointLaw((Power(1), Coulomb()), (2000.0, F))
    for a in A:
        k, c = describing_function(law, a, 40.0)
        # Relative 1e-6: the trapezoidal rule at the kinks of |sin| (second order, 4096 samples).
        assert c == pytest.approx(4 * F / (math.pi * a * 40.0), rel=1e-6)
        assert k == pytest.approx(2000.0, rel=1e-9)
    card = law_card(law, JE, A)
    for p in card.points:
        assert p.dissipation_J_per_cycle == pytest.approx(4 * F * p.amplitude_rad, rel=1e-6)
    assert card.dissipation_slope == pytest.approx(1.0, abs=1e-6)


def test_jenkins_element_masing_loop_in_closed_form():
    # Elastic-perfectly-plastic element (slip torque F, slip angle s, stiffness F/s): below s a
    # spring; above, k_eq = (F/s)/pi (beta - sin(2 beta)/2) with cos(beta) = 1 - 2 s/A
    # (Caughey 1960) and E = 4 F (A - s), the parallelogram's area.
    F, s = 50.0, 0.02
    law = JointLaw((Jenkins(s),), (F,))
    k, c = describing_function(law, 0.5 * s, 30.0)
    assert k == pytest.approx(F / s, rel=1e-12) and c == pytest.approx(0.0, abs=1e-9)
    for a in (0.03, 0.1, 0.3):
        k, c = describing_function(law, a, 30.0)
        beta = math.acos(1 - 2 * s / a)
        # Relative 1e-5: the slip starts between grid points (first order in the angle step).
        assert k == pytest.approx(F / s / math.pi * (beta - 0.5 * math.sin(2 * beta)), rel=1e-5)
        assert math.pi * c * 30.0 * a * a == pytest.approx(4 * F * (a - s), rel=1e-5)


@pytest.mark.parametrize("law", [
    JointLaw((Viscous(), Power(1)), (100.0, 2000.0)),
    JointLaw((Viscous(), Power(1), Power(3), Coulomb()), (100.0, 2000.0, 200.0, 60.0)),  # paper's + dry friction
], ids=["linear", "dry_friction"])
def test_card_from_runs_is_the_laws_loop_along_the_measured_motion(rig, law):
    # Runs simulated in the rig (not by the card's code), read back without the law: each
    # run's secant stiffness and loop area must be those of the law's torque along the
    # run's own motion (every harmonic), to the rig's integration error and the sampling.
    from jointrig.identify.harmonics import fourier_coefficients

    runs = ((25.0, 1500.0), (40.0, 2500.0), (55.0, 3500.0), (30.0, 600.0))
    records = [simulate_steady_state(rig, w, m, SimulationConfig(n_periods=3), law=law)[0] for w, m in runs]
    card = runs_card(records, 2.0, 2.0)
    assert card.inertia_kgm2 == pytest.approx(JE)
    by_omega = {r.omega_rad_s: r for r in records}
    linear = len(law.terms) == 2
    for p in card.points:
        if not (linear or p.amplitude_rad > 0.2):
            # The small run (600 N m at 30 rad/s) sticks for part of each cycle: there the
            # friction torque is whatever holds the joint, not F sign(rate), so neither the
            # law along the motion nor the describing function is the measurement. Its secant
            # stiffness is 8% below the describing function's (measured); the card reports
            # what the runs show.
            k, _ = describing_function(law, p.amplitude_rad, p.omega_rad_s)
            assert 0.85 * k < p.secant_stiffness_Nm_per_rad < k
            continue
        r = by_omega[p.omega_rad_s]
        n = np.arange(21)
        Phi = fourier_coefficients(r.phi_rad, r.n_periods, 20)
        F = fourier_coefficients(np.asarray(law.torque(r.phi_rad, r.rate_rad_s)), r.n_periods, 20)
        # Linear: 2e-8 (RK4) measured. Friction: the law's jump sampled 256 times a period
        # aliases into the first harmonic, 1.7e-3 on k and 1.6e-5 on E (measured): 5e-3, 1e-4.
        assert p.secant_stiffness_Nm_per_rad == pytest.approx(float(np.real(F[1] / Phi[1])), rel=5e-3)
        assert p.dissipation_J_per_cycle == pytest.approx(math.pi * float(np.sum(n * np.imag(F * np.conj(Phi)))),
                                                          rel=1e-4)
        # Against the describing function (a pure cosine): equal for the linear joint (2e-8),
        # and with friction where the motion is nearly harmonic (k within 1.1%, E within 2.4e-4,
        # measured): 2e-2 and 1e-3.
        k, c = describing_function(law, p.amplitude_rad, p.omega_rad_s)
        assert p.secant_stiffness_Nm_per_rad == pytest.approx(k, rel=2e-2)
        assert p.dissipation_J_per_cycle == pytest.approx(math.pi * c * p.omega_rad_s * p.amplitude_rad**2, rel=1e-3)


def test_virtual_phase_resonance_agrees_with_the_law_card(rig):
    # The rig driven at 90 degrees of phase lag at each level (studies/phase_resonance.py) measures
    # the backbone without any describing function. The paper's joint is nearly linear at
    # these levels and its motion at resonance nearly harmonic: omega_n and zeta agree to
    # 2.6e-6 (measured); asked 1e-5.
    from jointrig.studies.phase_resonance import phase_resonance

    pr = phase_resonance(rig, [400.0, 4000.0], xtol_rad_s=1e-5)
    card = law_card(rig.law, rig.Je_kgm2, [p.amplitude_rad for p in pr.points])
    for p, q in zip(pr.points, card.points):
        assert q.natural_frequency_rad_s == pytest.approx(p.natural_frequency_rad_s, rel=1e-5)
        assert q.damping_ratio == pytest.approx(p.damping_ratio, rel=1e-5)
        assert q.dissipation_J_per_cycle == pytest.approx(p.dissipation_J_per_cycle, rel=1e-5)


def test_virtual_phase_resonance_of_a_jenkins_joint(rig):
    # A lightly damped joint (c = 5 N m s/rad, k = 500 N m/rad) with a Jenkins element of
    # 40 N m slipping at 0.02 rad: at 400 N m it is in macroslip with a nearly harmonic
    # motion. Measured against the describing function: omega_n 5.1e-4, zeta 1.2e-3, E 1.8e-4
    # apart; asked 2e-3, 5e-3, 1e-3 (the single-harmonic view of the slip's corners).
    # The brent tolerance 1e-4 rad/s is 4e-6 of omega_n.
    from jointrig.studies.phase_resonance import phase_resonance

    law = JointLaw((Viscous(), Power(1), Jenkins(0.02)), (5.0, 500.0, 40.0))
    pr = phase_resonance(rig, [400.0], law=law, xtol_rad_s=1e-4, omega_bracket_rad_s=(15.0, 40.0))
    (p,) = pr.points
    (q,) = law_card(law, rig.Je_kgm2, [p.amplitude_rad]).points
    assert q.natural_frequency_rad_s == pytest.approx(p.natural_frequency_rad_s, rel=2e-3)
    assert q.damping_ratio == pytest.approx(p.damping_ratio, rel=5e-3)
    assert q.dissipation_J_per_cycle == pytest.approx(p.dissipation_J_per_cycle, rel=1e-3)


def test_iwan_joint_dissipation_in_closed_form_and_its_slopes():
    # Segalman's four-parameter Iwan element (macroslip torque F, s_max, chi, beta). Its
    # elements (slip s_i, stiffness k_i) each trace a parallelogram of area 4 k_i s_i (A - s_i)
    # once A > s_i, so the discretised element dissipates exactly sum 4 k_i s_i (A - s_i); the
    # continuum in micro-slip 4 R A^(3+chi) / ((chi+2)(chi+3)) (Segalman 2005), slope 3 + chi.
    F, smax, chi, beta = 40.0, 0.02, -0.5, 0.1
    iw = Iwan(smax, chi, beta)
    law = JointLaw((iw,), (F,))
    slips, stiff = iw.slips_and_stiffnesses
    kd = 1 / (smax * ((chi + 1) / (chi + 2) + beta))
    R = kd * (chi + 1) / smax ** (chi + 1)
    for a in (0.005, 0.01, 0.015, 0.02, 0.05, 0.2):
        _, c = describing_function(law, a, 30.0)
        e = math.pi * c * 30.0 * a * a
        exact = F * sum(4 * k * s * (a - s) for s, k in zip(slips, stiff) if s < a)
        # Relative 2e-6: the slips start between grid points (first order in the angle step;
        # 8e-7 measured).
        assert e == pytest.approx(exact, rel=2e-6)
        if a <= smax:
            # The discretisation (128 elements of equal stiffness) against the continuum: below
            # 0.33% at a = s_max/4 (measured at 32 elements; it falls as 1 / elements^2); asked 0.5%.
            assert e == pytest.approx(F * 4 * R * a ** (chi + 3) / ((chi + 2) * (chi + 3)), rel=5e-3)
    micro = law_card(JointLaw((Power(1), iw), (500.0, F)), JE, [0.25 * smax, 0.5 * smax, smax])
    # Slope 3 + chi = 2.5 in micro-slip; the discretisation moves it by 0.01 (measured 2.50x).
    assert micro.dissipation_slope == pytest.approx(3 + chi, abs=0.03)
    # Macroslip: E = 4 F A - 4 F sum k_i s_i^2, slope A / (A - sum k_i s_i^2) -> 1.
    macro = law_card(JointLaw((Power(1), iw), (500.0, F)), JE, [20 * smax, 40 * smax])
    c0 = sum(k * s * s for s, k in zip(slips, stiff))
    for p in macro.points:
        assert p.dissipation_J_per_cycle == pytest.approx(4 * F * (p.amplitude_rad - c0), rel=2e-6)
    assert macro.dissipation_slope == pytest.approx(1.0, abs=0.03)


@pytest.mark.slow
def test_virtual_phase_resonance_of_an_iwan_joint_in_micro_slip(rig):
    # A lightly damped joint (c = 0.5 N m s/rad, k = 500 N m/rad) with an Iwan element (40 N m,
    # s_max = 0.05 rad, chi = -0.5, beta = 0.1): at 3, 6 and 12 N m it stays in micro-slip
    # (amplitudes 0.009-0.025 rad). Measured against the describing function: omega_n 1.3e-4,
    # zeta 2.6e-3, E 2.9e-3 apart (the single-harmonic view of the sliders' corners); asked
    # 1e-3, 1e-2, 1e-2. Both give the dissipation slope 2.43 (the 3 + chi = 2.5 of the Iwan
    # element, pulled towards the viscous 2 by c): asked 0.02 apart. settle_tol 1e-6 moves
    # the results by < 1e-5 against 1e-9 (measured).
    from jointrig.studies.phase_resonance import phase_resonance

    law = JointLaw((Viscous(), Power(1), Iwan(0.05)), (0.5, 500.0, 40.0))
    pr = phase_resonance(rig, [3.0, 6.0, 12.0], law=law, xtol_rad_s=1e-3, omega_bracket_rad_s=(30.0, 55.0),
                         config=SimulationConfig(n_periods=2, settle_tol=1e-6))
    card = law_card(law, rig.Je_kgm2, [p.amplitude_rad for p in pr.points])
    assert max(p.amplitude_rad for p in pr.points) < 0.05
    for p, q in zip(pr.points, card.points):
        assert q.natural_frequency_rad_s == pytest.approx(p.natural_frequency_rad_s, rel=1e-3)
        assert q.damping_ratio == pytest.approx(p.damping_ratio, rel=1e-2)
        assert q.dissipation_J_per_cycle == pytest.approx(p.dissipation_J_per_cycle, rel=1e-2)
    assert card.dissipation_slope == pytest.approx(pr.dissipation_slope, abs=0.02)
    assert 2.3 < pr.dissipation_slope < 2.5


@pytest.mark.parametrize("name, law, follows", [
    ("jenkins", JointLaw((Viscous(), Power(1), Jenkins(0.02)), (0.1, 500.0, 40.0)), True),
    ("iwan", JointLaw((Viscous(), Power(1), Iwan(0.05)), (0.1, 500.0, 40.0)), True),
    ("viscous", JointLaw((Viscous(), Power(1)), (5.0, 500.0)), False),
    ("paper", JointLaw((Viscous(), Power(1), Power(3)), (100.0, 2000.0, 2e5)), False),
])
def test_masing_check_on_rig_runs(rig, name, law, follows):
    # Three runs (150, 250, 400 N m at 20, 22, 25 rad/s) simulated in the rig, read without the
    # law. Slider joints follow Masing's rule: implied backbones 2.4% (Jenkins) and 1.6% (Iwan)
    # apart on 8 harmonics, measured, within the 4% fidelity (c = 0.1 N m s/rad adds a little
    # rate dependence); rate-dependent damping does not: 16% (viscous, light) and 102% (the
    # paper's joint), more than 3 times the fidelity.
    from jointrig.identify.card import MASING_FIDELITY, masing_check
    from jointrig.rig.measurement import add_noise

    runs = ((20.0, 150.0), (22.0, 250.0), (25.0, 400.0))
    records = [simulate_steady_state(rig, w, m, SimulationConfig(n_periods=4), law=law, backend="native")[0]
               for w, m in runs]
    check = masing_check(records, 2.0, 2.0)
    assert check.follows is follows and not check.skipped and len(check.runs) == 3
    assert (check.discrepancy < MASING_FIDELITY) if follows else (check.discrepancy > 3 * MASING_FIDELITY)
    # At 40 dB the inertia term amplifies the angle's noise n^2 times in the loop: with 20
    # harmonics the check may say it cannot tell (None) but never the wrong answer; with its
    # default 8 it judges every joint right.
    noisy = [add_noise(r, 40.0, np.random.default_rng(1)) for r in records]
    wide = masing_check(noisy, 2.0, 2.0, n_harmonics=20)
    assert wide.follows in (follows, None)
    judged = masing_check(noisy, 2.0, 2.0)
    assert judged.follows is follows


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("case, adopted", [("paper", ()), ("jenkins", ("hysteresis",)), ("iwan", ("micro_slip",))])
def test_identified_card_and_runs_card_agree_with_phase_resonance(rig, case, adopted):
    # studies/card_check.py: a stepped-sine test at 40 dB is diagnosed (the paper's nominal model
    # plus the causes it adopts), and the identified card is held against a virtual
    # phase-resonance test at the amplitudes that test reached; the phase-resonance runs,
    # measured at 40 dB, give the runs' card. Bands:
    # - identified card: 3 of its standard errors (from the fit's covariance) plus the describing
    #   function's own single-harmonic bias, which the true law's card has against phase
    #   resonance too (up to 2.9e-3 for the Iwan joint's damping; 1e-9 for the paper's joint).
    #   Measured: within 0.87 standard errors of the true law's card everywhere (seed 1).
    # - runs' card: 3 standard errors (period spread and the fitted inertias' covariance: without
    #   the latter the paper's joint's dissipation was 3.5 of its errors off). Measured: 1.46.
    # - dissipation slopes (E against A along the backbone): 3 standard errors of the identified
    #   one. Closed forms of the slopes are tested on the laws above (2, 1, 3 + chi).
    from jointrig.studies.card_check import check_card

    check = check_card(rig, case)
    assert check.adopted == adopted
    for c in check.comparisons:
        bias = abs(c.true_law - c.phase_resonance)
        assert abs(c.identified - c.phase_resonance) <= 3 * c.identified_std + bias, c
        assert abs(c.runs_z) <= 3, c
    pr, ident = check.phase_resonance, check.identified
    assert ident.dissipation_slope == pytest.approx(pr.dissipation_slope, abs=3 * ident.dissipation_slope_std)


@pytest.mark.parametrize("lo, hi", [(0.004, 0.07), (0.003, 0.02), (1e-4, 0.5)])
def test_card_amplitude_tick_labels_never_overlap(lo, hi):
    # issue 37: the card's tick labels ran into each other when the amplitudes spanned more than
    # a decade (matplotlib labels the minor ticks of a log axis over about a decade)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jointrig.present.card import _amplitude_ticks

    fig, ax = plt.subplots(figsize=(5, 3.75))  # one panel of the card's 10 x 7.5 in figure
    x = np.geomspace(lo, hi, 25)
    ax.plot(x, x)
    ax.set_xscale("log")
    _amplitude_ticks(ax, x)
    fig.canvas.draw()
    boxes = [t.get_window_extent() for t in ax.get_xticklabels(which="both")
             if t.get_visible() and t.get_text() and lo <= t.get_position()[0] <= hi]
    plt.close(fig)
    assert len(boxes) >= 2, boxes
    boxes.sort(key=lambda b: b.x0)
    assert all(a.x1 <= b.x0 for a, b in zip(boxes, boxes[1:])), [(b.x0, b.x1) for b in boxes]


def test_the_cards_figure_of_a_law_that_dissipates_nothing_draws_without_a_warning():
    # the dissipation panel is on a log scale only where some value is positive: a purely elastic
    # law (a nominal fit whose damping is nil) drew with matplotlib's "no positive values"
    # warning on the user's console (an error here: filterwarnings = error)
    from jointrig.identify.card import MasingCheck, law_card
    from jointrig.present.card import card_png
    from jointrig.studies.joint_card import CardReport
    from jointrig.vocab.law import JointLaw, Power

    card = law_card(JointLaw((Power(1),), (2000.0,)), 1.0, [0.01, 0.02, 0.05])
    assert all(p.dissipation_J_per_cycle == 0 for p in card.points)
    png = card_png(CardReport(card, card, card, MasingCheck((), math.nan, math.nan, ("", ""), None)))
    assert png.startswith(b"\x89PNG")


@pytest.mark.parametrize("k", [0.0, -0.5], ids=["no_spring", "a_weak_negative_spring"])
def test_a_law_without_positive_stiffness_has_no_backbone(k):
    # Viscous damping alone (k = 0) or beside a weak negative spring (|k| < 1 N m/rad): there is
    # no natural frequency, so the backbone's point is NaN throughout, not a square root of a
    # negative stiffness nor a describing function at omega = 0. Exact: NaN is NaN.
    card = law_card(JointLaw((Viscous(), Power(1)), (100.0, k)), JE, (0.01, 0.05))
    for p in card.points:
        assert all(math.isnan(v) for v in (p.natural_frequency_rad_s, p.damping_ratio, p.dissipation_J_per_cycle,
                                           p.secant_stiffness_Nm_per_rad, p.equivalent_damping_Nms_per_rad))


def test_the_dissipation_slope_of_two_weighted_points_is_their_errors_propagated():
    # Two amplitudes with known relative errors leave no degree of freedom: the slope is the
    # line through them, (ln E2 - ln E1) / (ln A2 - ln A1), and its standard error the points'
    # relative errors propagated, hypot(r1, r2) / (ln A2 - ln A1), unscaled (there is no residual
    # to scale by). rel 1e-12: a 2x2 weighted least-squares solve, exact to round-off.
    from jointrig.identify.card import CardPoint, dissipation_slope

    a1, a2, e1, e2, r1, r2 = 0.01, 0.04, 3.0, 50.0, 0.02, 0.05
    pts = [CardPoint(a, 20.0, 20.0, 0.01, e, 1000.0, 1.0, dissipation_J_per_cycle_std=r * e)
           for a, e, r in ((a1, e1, r1), (a2, e2, r2))]
    slope, se, rate, rate_se = dissipation_slope(pts)
    span = math.log(a2 / a1)
    assert slope == pytest.approx(math.log(e2 / e1) / span, rel=1e-12)
    assert se == pytest.approx(math.hypot(r1, r2) / span, rel=1e-12)
    assert math.isnan(rate) and math.isnan(rate_se)


def test_the_dissipation_slope_of_points_without_errors_is_ordinary_least_squares():
    # Points whose dissipation carries no standard error: equal weights, the error scaled by the
    # residual over n - 2 degrees of freedom, as scipy.stats.linregress gives it (rel 1e-9: two
    # closed forms of one 5-point regression). Below that, a line through two points has no
    # residual to scale by: NaN, not a number that looks measured.
    from scipy import stats

    from jointrig.identify.card import CardPoint, dissipation_slope

    amps, energies = (0.01, 0.02, 0.03, 0.05, 0.08), (3.0, 11.0, 29.0, 70.0, 210.0)
    pts = [CardPoint(a, 20.0, 20.0, 0.01, e, 1000.0, 1.0) for a, e in zip(amps, energies)]
    slope, se, rate, _ = dissipation_slope(pts)
    ref = stats.linregress(np.log(amps), np.log(energies))
    assert slope == pytest.approx(ref.slope, rel=1e-9) and se == pytest.approx(ref.stderr, rel=1e-9)
    assert math.isnan(rate)
    assert math.isnan(dissipation_slope(pts[:2])[1])
    three = stats.linregress(np.log(amps[:3]), np.log(energies[:3]))  # one degree of freedom
    assert dissipation_slope(pts[:3])[1] == pytest.approx(three.stderr, rel=1e-9)


@pytest.mark.parametrize("rel, scaled", [(0.01, True), (0.5, False)])
def test_weighted_points_scale_their_error_by_the_residual_only_where_it_exceeds_them(rel, scaled):
    # Weights 1 / rel^2 (relative errors on E are errors on ln E): the slope's error is the
    # weighted fit's, times sqrt(chi2 / dof) where the points scatter more than their errors say
    # (1% errors on points 10-30% off a line), and unscaled where less (50% errors); the reference
    # is the same regression by scipy's lstsq on rows scaled by their weights (rel 1e-9)
    from jointrig.identify.card import CardPoint, dissipation_slope

    amps, energies = (0.01, 0.02, 0.03, 0.05, 0.08), (3.0, 11.0, 29.0, 70.0, 210.0)
    pts = [CardPoint(a, 20.0, 20.0, 0.01, e, 1000.0, 1.0, dissipation_J_per_cycle_std=rel * e)
           for a, e in zip(amps, energies)]
    X = np.column_stack([np.ones(5), np.log(amps)]) / rel
    y = np.log(energies) / rel
    beta, chi2, *_ = np.linalg.lstsq(X, y, rcond=None)
    cov = np.linalg.inv(X.T @ X)
    scale = float(chi2[0]) / 3
    assert (scale > 1) is scaled
    slope, se, _, _ = dissipation_slope(pts)
    assert slope == pytest.approx(beta[1], rel=1e-9)
    assert se == pytest.approx(math.sqrt(cov[1, 1] * max(1.0, scale)), rel=1e-9)
    # three points: one degree of freedom, scaled alike
    _, chi2_3, *_ = np.linalg.lstsq(X[:3], y[:3], rcond=None)
    cov3 = np.linalg.inv(X[:3].T @ X[:3])
    assert dissipation_slope(pts[:3])[1] == pytest.approx(math.sqrt(cov3[1, 1] * max(1.0, float(chi2_3[0]))),
                                                          rel=1e-9)


@pytest.mark.parametrize("n", [15, 16])
def test_masing_check_bands_a_coarsely_sampled_run_to_its_harmonics_below_nyquist(n):
    # Runs sampled 15 or 16 times a period hold harmonics 1..7 below Nyquist, fewer than the
    # check's default 8: each run's loop is band-limited to exactly 7 (an integer), the last one
    # of an odd count included. A linear spring with light viscous damping, twist
    # A cos(th) + 0.1 A cos(7 th + 0.3) at two amplitudes. The band is an integer count, exact.
    from jointrig.identify.card import masing_check
    from jointrig.vocab.records import SteadyStateRecord

    c, k, w, P = 1.0, 2000.0, 30.0, 3
    recs = []
    for a in (0.02, 0.03):
        th = 2 * math.pi * np.arange(P * n) / n
        phi = a * (np.cos(th) + 0.1 * np.cos(7 * th + 0.3))
        rate = -a * w * (np.sin(th) + 0.7 * np.sin(7 * th + 0.3))
        acc = -a * w * w * (np.cos(th) + 4.9 * np.cos(7 * th + 0.3))
        recs.append(SteadyStateRecord(w, th / w, 2.0 * (JE * acc + c * rate + k * phi), phi, None, n_periods=P))
    check = masing_check(recs, 2.0, 2.0)
    assert [r.highest_harmonic for r in check.runs] == [7, 7]
    assert all(type(r.highest_harmonic) is int for r in check.runs)


def test_a_cards_standard_errors_carry_a_profiled_shape_as_draws_of_the_whole_covariance_scatter():
    # A Jenkins joint (c 5, k 500, slip torque 40 N m at a slip angle s = 0.02 rad, the card
    # check's), its slip angle profiled: the fit's values move with s along its profile (slopes G),
    # and their covariance is the widened C + G S G^T. Drawn 600 times from the joint covariance
    # of (Je, c, k, F, s), the card's rows scatter as law_card's errors with the shape's column
    # say (600 draws hold a standard deviation to 2.9%: within 10%, 3.4 of those), and not as the
    # widened values' covariance alone with the law held at its profiled shape says (the joint
    # card's model rows before: off by more than 25% in some row at these amplitudes).
    c, k, F, s = 5.0, 500.0, 40.0, 0.02
    terms = (Viscous(), Power(1), Jenkins(s))
    C = np.diag([0.01, 0.2, 4.0, 0.5]) ** 2               # (Je, c, k, F) at a fixed slip angle
    G = np.array([0.0, 40.0, -2.0e4, 2000.0])             # d(Je, c, k, F) / d s along the profile
    S = np.array([[0.0005**2]])                           # the slip angle's own variance (2.5%: first order holds)
    top = C + np.outer(G, G) * S[0, 0]
    full = np.block([[top, (G * S[0, 0])[:, None]], [(G * S[0, 0])[None, :], S]])
    h = 1e-3 * s
    shapes = [((Viscous(), Power(1), Jenkins(s - h)), (Viscous(), Power(1), Jenkins(s + h)), h)]
    amps = (0.01, 0.1)  # sticking and slipping
    law = JointLaw(terms, (c, k, F))
    new = law_card(law, JE, amps, covariance=full, inertia_index=0, shapes=shapes)
    old = law_card(law, JE, amps, covariance=top, inertia_index=0)

    rng = np.random.default_rng(5)
    draws = rng.multivariate_normal(np.array([JE, c, k, F, s]), full, size=600)
    rows = np.array([[(p.natural_frequency_rad_s, p.damping_ratio, p.dissipation_J_per_cycle)
                      for p in law_card(JointLaw((Viscous(), Power(1), Jenkins(d[4])), tuple(d[1:4])), d[0], amps).points]
                     for d in draws])
    scatter = rows.std(axis=0, ddof=1)
    said = np.array([[p.natural_frequency_rad_s_std, p.damping_ratio_std, p.dissipation_J_per_cycle_std]
                     for p in new.points])
    before = np.array([[p.natural_frequency_rad_s_std, p.damping_ratio_std, p.dissipation_J_per_cycle_std]
                       for p in old.points])
    np.testing.assert_allclose(said, scatter, rtol=0.10)
    assert np.max(np.abs(before / scatter - 1)) > 0.25, before / scatter


def test_a_describing_function_needs_both_an_amplitude_and_a_frequency():
    # Either one at 0 (or below) is refused by name, not turned into a card row of NaN.
    law = JointLaw((Viscous(), Power(1)), (100.0, 2000.0))
    for a, w in ((0.0, 10.0), (0.01, 0.0), (-0.01, 10.0)):
        with pytest.raises(ValueError, match="amplitude_rad > 0 and omega_rad_s > 0"):
            describing_function(law, a, w)
