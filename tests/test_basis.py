"""The joint law's basis terms: closed forms, scalar vs array paths, validation."""

import math

import numpy as np
import pytest

from jointrig.vocab.law import (AngleHat, Cogging, ContactDamping, Coulomb, Iwan, Jenkins, Stribeck, TanhFriction, JointLaw, Monomial, Power,
                                QuadraticDamping, Viscous, angle_hats, hat_law, hat_matrix, play, polynomial_law,
                                rate_hats)

KNOTS = (-0.6, -0.3, -0.1, 0.0, 0.1, 0.3, 0.6)


def test_hat_matrix_partition_of_unity_and_linear_reproduction():
    x = np.linspace(-1.0, 1.0, 201)  # beyond the end knots too
    H = hat_matrix(x, KNOTS)
    np.testing.assert_allclose(H.sum(axis=1), 1.0, atol=1e-15)
    # Piecewise-linear interpolation with linear end extrapolation reproduces any line exactly.
    np.testing.assert_allclose(H @ (2.0 * np.asarray(KNOTS) - 0.5), 2.0 * x - 0.5, atol=1e-13)


def test_hat_law_equals_numpy_interp_inside_and_extends_end_slopes():
    g = np.array([-2400, -900, -200, 0, 200, 900, 2400.0])
    law = hat_law(knots_rad=KNOTS, g_Nm=g)
    x = np.linspace(-0.6, 0.6, 97)
    np.testing.assert_allclose(law.elastic_torque(x), np.interp(x, KNOTS, g), atol=1e-12)
    slope = (g[-1] - g[-2]) / (KNOTS[-1] - KNOTS[-2])
    assert law.torque(0.8, 0.0) == pytest.approx(2400 + 0.2 * slope, rel=1e-14)


@pytest.mark.parametrize("term", [Viscous(), Power(0), Power(1), Power(3), Monomial(0, 3), Monomial(2, 1),
                                  Power(1, 0.2), Power(3, 0.2), Coulomb(), QuadraticDamping(),
                                  *angle_hats(KNOTS),
                                  *rate_hats((-2.0, 0.0, 2.0))])
def test_scalar_path_equals_array_path(term):
    # The MuJoCo callback evaluates with Python floats; the identifier with arrays: same numbers.
    rng = np.random.default_rng(1)
    phi = rng.uniform(-1, 1, 50)
    rate = rng.uniform(-3, 3, 50)
    arr = np.broadcast_to(term(phi, rate), phi.shape)
    scal = np.array([term(float(p), float(r)) for p, r in zip(phi, rate)])
    np.testing.assert_allclose(scal, arr, rtol=1e-15, atol=1e-15)


STATELESS = [Viscous(), Power(0), Power(1), Power(3), Monomial(0, 3), Monomial(2, 1), Power(1, 0.2), Power(3, 0.2),
             Coulomb(), QuadraticDamping(), Stribeck(2.0), TanhFriction(0.5), Cogging(20.0), Cogging(20.0, True),
             ContactDamping(0.2), *angle_hats(KNOTS),
             *rate_hats((-2.0, 0.0, 2.0))]


@pytest.mark.parametrize("term", STATELESS)
def test_a_term_without_sliders_evaluates_records_at_once_bit_for_bit(term):
    # The diagnosis evaluates such a term on all its records at once, (records, samples), and a
    # term with sliders record by record (identify.balance.law_rows): the same bits as row
    # by row, whatever the rows' lengths relative to numpy's SIMD blocks.
    assert not term.stateful
    rng = np.random.default_rng(2)
    phi = rng.uniform(-1, 1, (6, 1027))
    rate = rng.uniform(-3, 3, (6, 1027))
    rate[0, :5] = 0.0
    whole = np.broadcast_to(np.asarray(term(phi, rate), dtype=float), phi.shape)
    rows = np.stack([np.broadcast_to(np.asarray(term(p, r), dtype=float), p.shape) for p, r in zip(phi, rate)])
    assert np.array_equal(whole, rows)


def test_polynomial_law_names_and_values():
    law = polynomial_law(c_Nms_per_rad=100, k_Nm_per_rad=2000, gamma_Nm_per_rad3=200)
    assert law.as_dict() == {"c_Nms_per_rad": 100.0, "k_Nm_per_rad": 2000.0, "gamma_Nm_per_rad3": 200.0}
    assert law.torque(0.1, 2.0) == pytest.approx(100 * 2 + 2000 * 0.1 + 200 * 0.001, rel=1e-15)


@pytest.mark.parametrize("make, match", [
    (lambda: JointLaw((Viscous(),), (1.0, 2.0)), "1 terms but 2 values"),
    (lambda: JointLaw((Viscous(), Viscous()), (1.0, 2.0)), "duplicate"),
    (lambda: JointLaw((Viscous(),), (float("nan"),)), "finite"),
    (lambda: AngleHat((0.0, 0.0, 1.0), 0), "strictly increasing"),
    (lambda: AngleHat((0.0, 1.0), 2), "outside"),
    (lambda: Power(-1), "power"),
    (lambda: Monomial(0, 1), "Viscous"),
    (lambda: Power(0, 0.1), "free play"),
    (lambda: Power(1, -0.1), "gap_rad"),
    (lambda: Jenkins(0.0), "slip_rad"),
    (lambda: Iwan(0.0), "slip_rad"),
    (lambda: Stribeck(0.0), "velocity_rad_s"),
    (lambda: Iwan(0.1, chi=-1.0), "chi"),
    (lambda: Iwan(0.1, chi=0.2), "chi"),
    (lambda: Iwan(0.1, beta=-0.1), "beta"),
    (lambda: Iwan(0.1, elements=1), "elements"),
    (lambda: hat_law(knots_rad=KNOTS, g_Nm=[1.0, 2.0]), "7 knots but 2 values"),
])
def test_invalid_laws_raise(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_backlash_dead_zone_and_dry_friction_closed_forms():
    # Free play +-0.2 rad: no torque inside, the stiffness acts on the engaged angle beyond.
    k = Power(1, 0.2)
    assert k(0.15, 0.0) == 0.0 and k(-0.2, 0.0) == 0.0
    assert k(0.5, 0.0) == pytest.approx(0.3, rel=1e-15) and k(-0.5, 0.0) == pytest.approx(-0.3, rel=1e-15)
    assert Power(3, 0.2)(0.5, 0.0) == pytest.approx(0.3**3, rel=1e-14)
    assert Power(1, 0.2).name == Power(1).name == "k_Nm_per_rad"  # same parameter, with free play
    assert (Coulomb()(0.0, 2.5), Coulomb()(0.0, -1e-9), Coulomb()(0.0, 0.0)) == (1.0, -1.0, 0.0)
    assert QuadraticDamping()(0.0, -3.0) == -9.0


def test_jenkins_loop_dissipates_four_slip_torque_times_excess_amplitude():
    # Closed form: a Jenkins element (slip torque F, slip angle d) driven by phi = A cos t
    # traces a parallelogram of area 4 F (A - d) per cycle for A > d. rtol 1e-3: the trapezoid
    # rule over 4096 samples cuts the loop's two corners between samples (~1/4096 each).
    F, d, A = 50.0, 0.05, 0.3
    t = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    phi = A * np.cos(t)
    tau = F * Jenkins(d)(phi, None)
    loop = np.sum(0.5 * (tau + np.roll(tau, -1)) * (np.roll(phi, -1) - phi))
    assert abs(loop) == pytest.approx(4 * F * (A - d), rel=1e-3)
    assert np.max(np.abs(tau)) == pytest.approx(F, rel=1e-12)


def test_jenkins_array_path_equals_stepping_the_play_operator():
    # The rig commits the slider state with play() after every step and evaluates
    # Jenkins.torque from it; the identifier's array path runs the operator over the record.
    # On a periodic record (second pass) both give the same numbers.
    j = Jenkins(0.04)
    t = np.linspace(0, 2 * np.pi, 256, endpoint=False)
    phi = 0.2 * np.cos(t) + 0.05 * np.cos(3 * t + 0.4)
    z = 0.0
    for _ in range(2):
        out = []
        for v in phi:
            out.append(j.torque(float(v), z))
            z = play(float(v), z, j.slip_rad)
    np.testing.assert_allclose(out, j(phi, None), rtol=0, atol=1e-15)
    with pytest.raises(TypeError, match="state"):
        j(0.1, 0.0)


def test_jenkins_vectorised_play_equals_sample_by_sample_on_rough_signals():
    # The array path runs the play operator by monotone runs; on random walks with flat steps
    # (noisy records) it must give exactly what stepping play() gives.
    rng = np.random.default_rng(7)
    for _ in range(50):
        x = np.cumsum(rng.normal(0, 0.1, int(rng.integers(2, 300))))
        x[rng.integers(1, x.size, 3)] = x[rng.integers(0, x.size, 3)]
        j = Jenkins(float(rng.uniform(0.01, 0.5)))
        z = 0.0
        for _ in range(2):
            out = []
            for v in x.tolist():
                z = play(v, z, j.slip_rad)
                out.append((v - z) / j.slip_rad)
        np.testing.assert_allclose(j(x, None), out, rtol=0, atol=1e-14)


def _walks(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """``n`` random walks of 2-299 samples with three flat steps each, a single sample and a
    constant record: what a play operator's runs must handle."""
    records = [np.cumsum(rng.normal(0, 0.1, int(rng.integers(2, 300)))) for _ in range(n)]
    for x in records:
        x[rng.integers(1, x.size, 3)] = x[rng.integers(0, x.size, 3)]
    return records + [np.array([0.3]), np.full(5, -0.2)]


def test_the_play_operators_last_state_from_the_runs_ends_is_the_full_pass_s():
    # The periodic state a Jenkins or Iwan column starts its pass from is the first pass's last
    # sample, taken from each monotone run's last sample only (vocab.law._play_end): the same
    # number, bit for bit, as running the whole pass, for one slider or several, on random walks
    # with flat steps, a single sample and a constant record.
    from jointrig.vocab.law import monotone_runs, _play_array, _play_end

    for x in _walks(np.random.default_rng(11), 40):
        for slip, z0 in ((0.05, 0.0), (np.array([0.01, 0.1, 0.7]), np.array([0.0, 0.2, -0.4]))):
            runs = monotone_runs(x)
            assert np.array_equal(_play_end(x, slip, z0, runs), _play_array(x, slip, z0, runs)[..., -1])


def test_the_weighted_sum_of_sliders_without_forming_them_is_the_sum_of_the_formed_ones():
    # An Iwan element's column is sum_i k_i (x - z_i) over its sliders; vocab.law._play_sum reads
    # it from sorted thresholds per monotone run instead of forming every slider (33 x the record).
    # On random walks with flat steps, a single sample and a constant record, for 1, 3 and 33
    # sliders from arbitrary states, it equals the formed sum to 1e-13 of the largest torque
    # (measured 1.6e-14: cumulative sums that cancel).
    from jointrig.vocab.law import monotone_runs, _play_array, _play_sum

    rng = np.random.default_rng(5)
    for x in _walks(rng, 60):
        for m in (1, 3, 33):
            slip, k, z0 = np.sort(rng.uniform(0.01, 0.7, m)), rng.uniform(0.1, 2.0, m), rng.uniform(-0.3, 0.3, m)
            runs = monotone_runs(x)
            formed = k @ (x[None, :] - _play_array(x, slip, z0, runs))
            np.testing.assert_allclose(_play_sum(x, slip, k, z0, runs), formed, rtol=0,
                                       atol=1e-13 * np.abs(formed).max())


@pytest.mark.parametrize("chi, beta", [(-0.5, 0.1), (-0.2, 0.0), (0.0, 1.0)])
def test_iwan_elements_keep_the_stiffness_and_the_macroslip_torque(chi, beta):
    # Segalman's density R s^chi on (0, s_max] plus a Dirac S = beta K_d at s_max: per N m of
    # macroslip torque the elements' stiffnesses sum to K_T = (1 + beta) / (s_max (beta +
    # (chi+1)/(chi+2))) and their slip torques to 1, exactly (round-off: 1e-14).
    iw = Iwan(0.02, chi, beta, elements=16)
    slips, stiff = iw.slips_and_stiffnesses
    assert len(slips) == iw.n_states == 16 + (beta > 0)
    assert sum(k * s for k, s in zip(stiff, slips)) == pytest.approx(1.0, rel=1e-14)
    assert sum(stiff) == pytest.approx((1 + beta) / (0.02 * (beta + (chi + 1) / (chi + 2))), rel=1e-14)
    assert all(0 < a < b for a, b in zip(slips, slips[1:])) and slips[-1] <= 0.02
    # Below the first slip angle it is a spring of stiffness K_T; past s_max it slides at F_S.
    phi = np.array([0.0, 0.5 * slips[0], 0.0, -0.5 * slips[0]])
    np.testing.assert_allclose(iw(phi, None), phi * iw.stiffness_per_torque, rtol=1e-12, atol=1e-15)
    big = 0.5 * np.cos(np.linspace(0, 2 * np.pi, 64, endpoint=False))
    assert np.max(iw(big, None)) == pytest.approx(1.0, rel=1e-14)


def test_iwan_array_path_equals_stepping_its_sliders():
    # The rig evaluates Iwan.step_torque and commits every slider after each step; the
    # identifier's array path finds every slider's periodic state from a first pass's run ends,
    # then sums the sliders along the record (vocab.law._play_sum) without forming them.
    iw = Iwan(0.05, -0.3, 0.2, elements=8)
    t = np.linspace(0, 2 * np.pi, 256, endpoint=False)
    phi = 0.04 * np.cos(t) + 0.01 * np.cos(3 * t + 0.4)
    state = [0.0] * iw.n_states
    for _ in range(2):
        out = []
        for v in phi.tolist():
            out.append(iw.step_torque(v, state, 0))
            iw.commit(v, state, 0)
    np.testing.assert_allclose(out, iw(phi, None), rtol=0, atol=1e-13)
    with pytest.raises(TypeError, match="state"):
        iw(0.1, 0.0)


def test_stribeck_friction_scalar_and_array_paths_and_its_model_fields(tmp_path):
    # sign(v) exp(-(v/vs)^2): F_x at a vanishing rate, F_x/e at v = vs, ~0 far beyond; the
    # scalar (callback) and array (identifier) paths agree; the MJCF fields read back the term.
    from jointrig.rig import load_rig
    from jointrig.rig.model import DEFAULT_MODEL, identified_model_xml
    from jointrig.vocab.plant import Plant

    s = Stribeck(0.5)
    v = np.array([-2.0, -0.5, -1e-9, 0.0, 1e-9, 0.5, 2.0])
    np.testing.assert_allclose(s(None, v), [-math.exp(-16), -math.exp(-1), -1, 0, 1, math.exp(-1), math.exp(-16)],
                               rtol=1e-15)
    assert [s(0.0, float(x)) for x in v] == pytest.approx(list(s(None, v)), rel=1e-15, abs=0)
    law = JointLaw((Viscous(), Power(1), Coulomb(), s), (5.0, 500.0, 20.0, 15.0))
    path = tmp_path / "stribeck.xml"
    path.write_text(identified_model_xml(Plant(law), (2.0, 2.0), template=DEFAULT_MODEL))
    back = load_rig(path)
    assert back.law == law and back.plant.parameters()["stribeck_velocity_rad_s"] == 0.5


def test_tanh_friction_scalar_and_array_paths_and_its_model_fields(tmp_path):
    # tanh(v / vt): 0 at rest, tanh(1) at v = vt, odd, -> sign(v) far beyond (dry friction);
    # the scalar (callback) and array (identifier) paths agree to round-off (libm's tanh and
    # numpy's differ in the last bit); the MJCF fields read back the term and a negative torque
    # (energy fed in) or a missing transition rate is refused, naming the field.
    from jointrig.rig import load_rig
    from jointrig.rig.model import DEFAULT_MODEL, identified_model_xml
    from jointrig.vocab.law import FieldError, law_terms_from_fields
    from jointrig.vocab.plant import Plant

    f = TanhFriction(0.5)
    v = np.array([-50.0, -0.5, -1e-9, 0.0, 1e-9, 0.5, 50.0])
    np.testing.assert_allclose(f(None, v), [-1, -math.tanh(1), -2e-9, 0, 2e-9, math.tanh(1), 1], rtol=1e-15)
    assert [f(0.0, float(x)) for x in v] == pytest.approx(list(f(None, v)), rel=1e-15, abs=0)
    assert f.dissipative and not f.elastic
    law = JointLaw((Viscous(), Power(1), f), (5.0, 500.0, 20.0))
    path = tmp_path / "tanh.xml"
    path.write_text(identified_model_xml(Plant(law), (2.0, 2.0), template=DEFAULT_MODEL))
    back = load_rig(path)
    assert back.law == law and back.plant.parameters()["tanh_friction_velocity_rad_s"] == 0.5
    with pytest.raises(FieldError, match="jointrig_tanh_friction_torque_Nm must be >= 0"):
        law_terms_from_fields({"tanh_friction_torque_Nm": [-1.0], "tanh_friction_velocity_rad_s": [0.5]})
    with pytest.raises(FieldError, match="go together"):
        law_terms_from_fields({"tanh_friction_torque_Nm": [1.0]})
    with pytest.raises(ValueError, match="velocity_rad_s"):
        TanhFriction(0.0)


def test_a_cogging_torque_is_a_sine_of_the_angle_and_reads_back_from_a_model_file(tmp_path):
    # A sin(z phi + p) as its sine and cosine parts: the values, the amplitude the pair implies,
    # the model file's fields (z shared) and their refusals.
    from jointrig.rig.model import DEFAULT_MODEL, identified_model_xml, load_rig
    from jointrig.vocab.law import FieldError, law_terms_from_fields
    from jointrig.vocab.plant import Plant

    s, c = Cogging(125.0), Cogging(125.0, quadrature=True)
    phi = np.array([-0.3, 0.0, 0.01, 0.2])
    np.testing.assert_array_equal(s(phi, 0 * phi), np.sin(125.0 * phi))
    np.testing.assert_array_equal(c(phi, 0 * phi), np.cos(125.0 * phi))
    # the scalar (callback) path is libm's sin, the array path numpy's: two implementations that
    # need not round alike on every CPU (numpy may dispatch its own SIMD sin); 4 ulp of the
    # result (rel 1e-15, abs for the zero) is round-off, a wrong phase or order moves it by 1e-2
    assert [s(float(x), 0.0) for x in phi] == pytest.approx(list(np.sin(125.0 * phi)), rel=1e-15, abs=1e-15)
    assert s.elastic and c.elastic and not s.dissipative and (s.name, c.name) == ("cogging_sin_Nm", "cogging_cos_Nm")
    law = JointLaw((Viscous(), Power(1), s, c), (5.0, 500.0, 30.0, -40.0))
    plant = Plant(law)
    params = plant.parameters()
    # hypot(30, -40) and 2 pi / z: one rounding each
    assert params["cogging_amplitude_Nm"] == pytest.approx(50.0, rel=1e-15)
    assert params["cogging_pitch_rad"] == pytest.approx(2 * math.pi / 125.0, rel=1e-15)
    path = tmp_path / "cogging.xml"
    path.write_text(identified_model_xml(plant, (2.0, 2.0), template=DEFAULT_MODEL))
    assert load_rig(path).law == law
    only_sine = law_terms_from_fields({"cogging_sin_Nm": [3.0], "cogging_order_rad_per_rad": [8.0]})
    assert only_sine == [(Cogging(8.0), 3.0)]
    with pytest.raises(FieldError, match="cogging_order_rad_per_rad goes with"):
        law_terms_from_fields({"cogging_sin_Nm": [3.0]})
    with pytest.raises(FieldError, match="must be > 0"):
        law_terms_from_fields({"cogging_cos_Nm": [3.0], "cogging_order_rad_per_rad": [0.0]})
    with pytest.raises(ValueError, match="order_per_rad"):
        Cogging(-1.0)


def test_damping_in_contact_acts_beyond_the_free_play_and_its_samples_carry_their_share(tmp_path):
    # The rig's callback (scalar path) applies c phi' where |phi| > gap, nothing within. The
    # balance's samples (array path) carry the share of each sample's interval in contact, so a
    # column moves smoothly with the gap: its mean over a period of a sine is the exact share
    # 1 - (2/pi) asin(gap/A) to second order in the step (here 64 samples: within 1e-3), and
    # moving the gap by a tenth of a sample's step moves it (the bare indicator would not).
    from jointrig.rig.model import DEFAULT_MODEL, identified_model_xml, load_rig
    from jointrig.vocab.law import FieldError, contact_share, law_terms_from_fields
    from jointrig.vocab.plant import Plant

    t = ContactDamping(0.3)
    assert [t(x, 2.0) for x in (-0.5, -0.3, 0.0, 0.29, 0.31)] == [2.0, 0.0, 0.0, 0.0, 2.0]
    assert t.dissipative and not t.elastic and t.name == "contact_c_Nms_per_rad"
    phi = np.sin(2 * np.pi * (np.arange(64) + 0.37) / 64)
    exact = 1 - 2 / np.pi * math.asin(0.3)
    assert abs(contact_share(phi, 0.3).mean() - exact) < 1e-3
    assert abs(np.mean(phi > 0.3) * 2 - exact) > 4 * abs(contact_share(phi, 0.3).mean() - exact)  # the bare one: worse
    step = 2 * np.pi / 64 * math.sqrt(1 - 0.3**2)
    assert contact_share(phi, 0.3 + 0.1 * step).mean() < contact_share(phi, 0.3).mean()
    np.testing.assert_array_equal(contact_share(np.array([0.5, 0.6, 0.7]), 0.3), 1.0)
    np.testing.assert_array_equal(contact_share(np.array([0.0, 0.1, -0.1]), 0.3), 0.0)
    law = JointLaw((ContactDamping(0.02), Power(1, 0.02), Power(3, 0.02)), (100.0, 2000.0, 200.0))
    path = tmp_path / "contact.xml"
    path.write_text(identified_model_xml(Plant(law), (2.0, 2.0), template=DEFAULT_MODEL))
    assert load_rig(path).law == law
    with pytest.raises(FieldError, match="needs jointrig_backlash_half_gap_rad > 0"):
        law_terms_from_fields({"contact_c_Nms_per_rad": [3.0]})
    with pytest.raises(FieldError, match="must be >= 0"):
        law_terms_from_fields({"contact_c_Nms_per_rad": [-3.0], "backlash_half_gap_rad": [0.1]})
    with pytest.raises(ValueError, match="gap_rad"):
        ContactDamping(0.0)


def test_upsampling_keeps_the_top_line_of_an_odd_record_and_drops_an_even_ones_nyquist():
    # 7 samples hold harmonics 0..3, the top one whole: upsampled twice it is the same cosine on 14.
    # 8 samples: harmonic 4 is the Nyquist line, whose sine is lost, so it is dropped.
    from jointrig.identify.balance import upsample

    k7, k14 = np.arange(7), np.arange(14)
    np.testing.assert_allclose(upsample(np.cos(2 * np.pi * 3 * k7 / 7 + 0.4), 2), np.cos(2 * np.pi * 3 * k14 / 14 + 0.4),
                               rtol=0, atol=1e-14)
    k8, k16 = np.arange(8), np.arange(16)
    x = np.cos(2 * np.pi * k8 / 8) + np.cos(np.pi * k8)
    np.testing.assert_allclose(upsample(x, 2), np.cos(2 * np.pi * k16 / 16), rtol=0, atol=1e-14)


def test_a_law_oversampled_without_a_weight_is_balanced_and_a_weight_needs_the_plain_grid():
    # A linear term's coefficients are the same on the twice finer grid (its samples interpolate
    # exactly); a weight (a body's stick mask) is defined on the record's own samples only.
    from jointrig.identify.balance import law_rows, upsample
    from jointrig.identify.harmonics import fourier_coefficients
    from jointrig.vocab.law import Power

    n = 32
    phi = np.cos(2 * np.pi * np.arange(n) / n) * 0.01
    phi.setflags(write=False)
    rows = law_rows((Power(1),), (phi, np.zeros(n)), (None, None), lambda: upsample(phi, 2),
                    lambda: upsample(np.zeros(n), 2), 1, 3, 2)
    np.testing.assert_allclose(rows[0], fourier_coefficients(phi, 1, 3), rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="a weight needs oversample 1"):
        law_rows((Power(1),), (phi, np.zeros(n)), (None, None), lambda: phi, lambda: phi, 1, 3, 2, weight=np.ones(n))


def test_a_weighted_law_row_needs_the_records_own_samples():
    # a weight multiplies each sample of the law's torque: on an oversampled grid it has no
    # samples to multiply, and law_rows says so
    from jointrig.identify.balance import law_rows
    from jointrig.identify.harmonics import fourier_coefficients
    from jointrig.vocab.law import Power

    phi = np.cos(np.arange(16) / 16 * 2 * np.pi)
    with pytest.raises(ValueError, match="a weight needs oversample 1"):
        law_rows((Power(1),), (phi, np.zeros(16)), (None, None), lambda: phi, lambda: phi, 1, 3, 2,
                 weight=np.ones(16))
    # on the record's own samples the weight multiplies the torque: half of each sample here
    half = law_rows((Power(1),), (phi, np.zeros(16)), (None, None), lambda: phi, lambda: phi, 1, 3, 1,
                    weight=np.full(16, 0.5))
    np.testing.assert_allclose(half[0], 0.5 * fourier_coefficients(phi, 1, 3), atol=1e-15)


def test_law_rows_of_one_motion_under_two_weights_are_each_their_own():
    # A train's bodies stick at different samples: one motion balanced under two stick masks.
    # The rows are memoised by the arrays they come from, the weight among them: the second
    # mask's rows are its own torque's coefficients, not the first's from the memo (round-off).
    from jointrig.identify.balance import law_rows
    from jointrig.identify.harmonics import fourier_coefficients
    from jointrig.vocab.law import Power

    phi = np.cos(np.arange(16) / 16 * 2 * np.pi)
    still = np.zeros(16)
    first, second = (np.arange(16) < 8).astype(float), (np.arange(16) >= 8).astype(float)
    for w in (first, second, first):
        rows = law_rows((Power(1),), (phi, still), (None, None), lambda: phi, lambda: still, 1, 3, 1, weight=w)
        np.testing.assert_allclose(rows[0], fourier_coefficients(phi * w, 1, 3), atol=1e-15)


def test_a_single_dof_systems_law_rows_are_taken_at_the_records_own_samples():
    # single_dof_system balances the samples it is given: a dry friction's column is its torque's
    # Fourier coefficients at those samples (as the same rows of the sign of the rate itself
    # given as the forcing), not on a finer grid, where the sign's jumps alias otherwise
    from jointrig.identify.balance import single_dof_system

    t = np.arange(16) / 16 * 2 * np.pi + 0.1
    x, rate = np.cos(t), -np.sin(t)
    s = single_dof_system(omega_rad_s=1.0, n_periods=1, x=x, rate=rate, forcing=np.sign(rate), terms=(Coulomb(),),
                          n_harmonics=5)
    np.testing.assert_allclose(s.A[:, list(s.names).index(Coulomb().name)], s.F, rtol=0, atol=1e-14)


def test_a_single_dof_systems_rows_belong_to_record_0_unless_told_and_to_equation_0():
    # single_dof_system's rows carry the record they come from (the row_record a stacked
    # system's standard errors and residuals are grouped by): 0 for a record balanced alone.
    from jointrig.identify.balance import single_dof_system

    t = np.arange(16) / 16 * 2 * np.pi
    kw = dict(omega_rad_s=1.0, n_periods=1, x=np.cos(t), rate=-np.sin(t), forcing=np.cos(t), terms=(Coulomb(),),
              n_harmonics=5)
    alone = single_dof_system(**kw)
    assert alone.F.size == 2 * 5 + 1 and set(alone.row_record) == {0} and set(alone.row_equation) == {0}
    assert set(single_dof_system(**kw, record_index=3).row_record) == {3}


def test_assemble_from_harmonic_1_lays_out_cosine_and_sine_rows_without_the_mean():
    # first_harmonic=1 balances harmonics 1..H: per record and equation a cosine (real part) and
    # a sine (imaginary part) row for each, the mean left out; the rows are the coefficients'
    # parts themselves (exact copies). 0 keeps the mean's cosine row; nothing else is accepted.
    from jointrig.identify.balance import assemble

    C = np.array([[[5.0, 1 + 2j, 3 - 4j]], [[6.0, 7 + 8j, 9 - 1j]]])  # (2 records, 1 equation, H + 1 = 3)
    F = np.array([[[0.5, 0.1 + 0.2j, 0.3 + 0.4j]], [[0.6, 0.7 - 0.8j, 0.9]]])
    s = assemble(C[None], F, ("k",), first_harmonic=1)
    np.testing.assert_array_equal(s.A[:, 0], [1, 2, 3, -4, 7, 8, 9, -1])
    np.testing.assert_array_equal(s.F, [0.1, 0.2, 0.3, 0.4, 0.7, -0.8, 0.9, 0.0])
    np.testing.assert_array_equal(s.row_harmonic, [1, 1, 2, 2] * 2)
    np.testing.assert_array_equal(s.row_part, [0, 1] * 4)
    np.testing.assert_array_equal(s.row_record, [0] * 4 + [1] * 4)
    with_mean = assemble(C[None], F, ("k",), first_harmonic=0)
    np.testing.assert_array_equal(with_mean.A[:, 0], [5, 1, 2, 3, -4, 6, 7, 8, 9, -1])
    with pytest.raises(ValueError, match="first_harmonic must be 0 or 1"):
        assemble(C[None], F, ("k",), first_harmonic=2)


def test_a_systems_row_layout_is_shared_by_every_system_of_its_shape_and_read_only():
    # assemble's row layout (each row's record, harmonic, part and equation) is computed once per
    # shape and shared by every system of that shape: a caller writing into one system's layout
    # would relabel the rows of every later system, so it is read-only, and a later system of the
    # same shape reads the layout as it is (exact small integers).
    from jointrig.identify.balance import assemble

    C = np.array([[[5.0, 1 + 2j, 3 - 4j]], [[6.0, 7 + 8j, 9 - 1j]]])  # (2 records, 1 equation, H + 1 = 3)
    F = np.zeros((2, 1, 3), complex)
    s = assemble(C[None], F, ("k",), first_harmonic=1)
    for layout in (s.row_record, s.row_harmonic, s.row_part, s.row_equation):
        with pytest.raises(ValueError, match="read-only"):
            layout[0] = 7
    later = assemble(2 * C[None], F, ("c",), first_harmonic=1)
    np.testing.assert_array_equal(later.row_harmonic, [1, 1, 2, 2] * 2)
    np.testing.assert_array_equal(later.row_part, [0, 1] * 4)
    np.testing.assert_array_equal(later.row_record, [0] * 4 + [1] * 4)
    np.testing.assert_array_equal(later.row_equation, [0] * 8)


def test_the_equivalent_systems_rows_balance_equation_0_and_the_two_dof_forms_each_flywheels_own():
    # row_equation: 0 is the relative coordinate (the equivalent one-degree-of-freedom form has no
    # other) or flywheel 1, 1 is flywheel 2; per record the two-dof form lays out flywheel 1's
    # rows (the mean, then harmonics 1..3: 7 rows), then flywheel 2's.
    from jointrig.identify.balance import equivalent_system, two_dof_system
    from jointrig.vocab.records import SteadyStateRecord

    th = 2 * np.pi * np.arange(16) / 16
    recs = [SteadyStateRecord(10.0 * k, th / (10.0 * k), 5.0 * np.cos(th), 0.02 * np.cos(th + 0.1),
                              0.01 * np.cos(th + 0.3), n_periods=1) for k in (1, 2)]
    eq = equivalent_system(recs, (Power(1),), n_harmonics=3, torque_share=0.5)
    assert eq.F.size == 2 * 7
    np.testing.assert_array_equal(eq.row_equation, 0)
    np.testing.assert_array_equal(eq.row_record, [0] * 7 + [1] * 7)
    two = two_dof_system(recs, (Power(1),), n_harmonics=3)
    np.testing.assert_array_equal(two.row_equation, ([0] * 7 + [1] * 7) * 2)
