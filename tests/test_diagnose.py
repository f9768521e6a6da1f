"""The diagnosis finds effects hidden in rig data it is not told about.

Every case (``studies.hidden_effects``) simulates the paper's joint with one hidden effect (or none,
or two) over omega = 25, 40, 55 rad/s x M0 = 1500, 2500, 3500 N m (9 runs, 16 periods each),
measures it at 40 dB SNR on torque and both angles, writes and reads the measured-runs CSV, and
runs the
whole product path (:func:`studies.validate.run_diagnosis`): fit on 6 runs, hold out runs 1, 4, 7
(the middle amplitude at each frequency), validate in the rig.

Acceptance (issue 4): the hidden effect ranked first; its magnitude within 15%; gain >= 5
on the held-out runs; for ``none`` nothing significant. Magnitudes are modest: each effect is
checked to be at most ~5% of the peak joint torque where it is a torque.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from jointrig.identify.causes import CAUSES, DIMENSIONLESS
from jointrig.measured.runs import read_runs, write_runs
from jointrig.studies.hidden_effects import HIDDEN_EFFECTS as CASES
from jointrig.studies.hidden_effects import simulate_case
from jointrig.studies.validate import run_diagnosis

# One worker runs this module: its session-scoped fixture is computed once (pytest-xdist
# --dist loadgroup), not once per worker.
pytestmark = pytest.mark.xdist_group("diagnose")

_cache: dict = {}


def measured(rig, tmp_path_factory, case, *, snr_db=40.0, seed=None):
    """(records read back from CSV, peak joint torque in N m) for a case, simulated once."""
    key = (case, snr_db, seed)
    if key not in _cache:
        records, peak = simulate_case(rig, case, snr_db=snr_db, seed=seed)
        path = tmp_path_factory.mktemp("data") / f"{case}.csv"
        write_runs(path, records)
        _cache[key] = (read_runs(path).records, peak)
    return _cache[key]


@pytest.fixture(scope="session")  # once per worker, even when xdist interleaves other modules
def reports(rig, tmp_path_factory):
    out = {}

    def get(case):
        if case not in out:
            records, peak = measured(rig, tmp_path_factory, case)
            out[case] = (run_diagnosis(records, rig=rig), peak)
        return out[case]
    return get


@pytest.mark.parametrize("case", [c for c in CASES if c != "none"])
def test_hidden_effect_is_ranked_first_sized_and_pays_off(reports, case):
    report, peak = reports(case)
    d = report.diagnosis
    truth = CASES[case][1]
    hidden = set(case.split("+"))
    first = d.causes[0]
    assert first.effect in hidden, [(c.effect, round(c.score)) for c in d.causes]
    assert first.significant
    assert set(d.effects) == hidden, d.effects  # found, and nothing invented beside it
    params = d.extended.effect_parameters()
    for name, value in truth.items():
        # 15%: the bound; the standard errors here are 0.2-3% of the values.
        assert params[name] == pytest.approx(value, rel=0.15), (name, params[name])
        if name.endswith("_Nm") and not name.startswith("a_"):
            assert value <= 0.05 * peak  # a modest effect: <= 5% of the peak joint torque
    # The even term's gain is measured on harmonics 1.. only since the sensors' zero counts as
    # arbitrary (issue 11): its DC shift, most of the nominal model's error, is no longer
    # compared, and the gain fell from 13.9 to 4.98 with the model itself unchanged (a 203 ->
    # 207). 4.5 for that case; the independent bench's asymmetric cases reach >= 5.
    bound = 4.5 if case == "asymmetric_stiffness" else 5.0
    assert report.gain >= bound, (report.validation_rms("nominal"), report.validation_rms("extended"))
    # The extended model leaves only noise: chi2/dof at most about 1 (below 1 where the
    # model-fidelity floor, 1e-3 of each run's torque, exceeds the noise; 1.3 allows for the
    # weight estimates' 30 degrees of freedom).
    assert 0.5 < d.extended.chi2 / d.extended.dof < 1.3


def test_nominal_data_invents_nothing(reports):
    report, _ = reports("none")
    d = report.diagnosis
    assert d.effects == () and not any(c.significant for c in d.causes), [(c.effect, c.p_value) for c in d.causes]
    assert d.nominal.chi2 / d.nominal.dof < 1.3
    # The nominal law is recovered: k and c within 1% (standard errors ~0.1%).
    p = d.nominal.as_dict()
    assert p["k_Nm_per_rad"] == pytest.approx(2000, rel=0.01) and p["c_Nms_per_rad"] == pytest.approx(100, rel=0.01)
    # Nothing adopted, so the check that counts is that the nominal model predicts the held-out
    # runs in the rig to their noise floor (measured 0.89x; 3x leaves room for other seeds).
    assert report.verdict.verdict == "no_misfit"
    assert report.validation_rms("nominal") < 3 * report.noise_floor_rad, report.validation_rms("nominal") / report.noise_floor_rad


def test_magnitude_names_carry_units():
    # The two-flywheel diagnosis reports in SI; the oscillator's monomials (x^2 x', x'^3) are in
    # the units of its data (volts for the Silverbox) and are named by their powers.
    for name in (c.magnitude for c in CAUSES):
        assert name.split("_")[-1] in {"Nm", "rad", "rad2", "s"} or "_per_" in name or name in DIMENSIONLESS, name


def test_relative_angle_only_uses_the_equivalent_form(rig, tmp_path_factory):
    # The same dry-friction data with only phi = phi1 - phi2: Je instead of J1, J2; bearing
    # friction cannot be tested (it acts on absolute rates) and says so.
    records, _ = measured(rig, tmp_path_factory, "coulomb_friction")
    rel = [type(r)(r.omega_rad_s, r.time_s, r.torque_Nm, r.phi_rad, None, n_periods=r.n_periods) for r in records]
    report = run_diagnosis(rel, rig=rig)
    d = report.diagnosis
    assert d.form == "equivalent" and "Je_kgm2" in d.nominal.names
    assert d.effects == ("coulomb_friction",)
    assert d.extended.as_dict()["coulomb_torque_Nm"] == pytest.approx(95.0, rel=0.15)
    bearing = next(c for c in d.causes if c.effect == "bearing_friction")
    assert not bearing.significant and "needs both flywheel angles" in bearing.note
    assert report.gain >= 5.0


def test_a_jenkins_element_that_never_sticks_is_named_dry_friction(rig, tmp_path_factory):
    # At 20 dB the transition after each reversal that tells a Jenkins element from dry
    # friction drowns in noise: the Jenkins fit's slip angle falls below what the angles
    # resolve, and the tool names it by its physics, dry friction (issue 11), instead of
    # offering "hysteresis" as an equal rival.
    from jointrig.present.diagnosis_report import format_report, report_json

    records, _ = measured(rig, tmp_path_factory, "coulomb_friction", snr_db=20.0, seed=5)
    report = run_diagnosis(records, rig=rig)
    d = report.diagnosis
    assert d.effects[0] == "coulomb_friction"
    jenkins = next(c for c in d.causes if c.effect == "hysteresis")
    assert not jenkins.significant and "never sticks is dry friction" in jenkins.note
    assert "hysteresis" not in d.effects
    text = format_report(report)
    assert "never sticks is dry friction" in text
    js = report_json(report)
    assert not any("hysteresis" in a["effects"] for a in js["ambiguities"])


@pytest.mark.parametrize("case, low, high", [("coulomb_friction", 0.95, 1.0), ("quadratic_damping", 0.95, 1.0),
                                             ("hysteresis", 0.5, 0.95), ("backlash", 0.0, 0.1)])
def test_signature_tells_dissipative_from_elastic_causes(reports, case, low, high):
    # The cause's own joint torque at the fundamental: in quadrature with the angle for dry
    # friction and damping (share near 1), in phase for free play (near 0), in between for a
    # Jenkins element (its spring acts before it slips: 0.86 here). The bounds leave a margin
    # of several hundredths around what a few-percent effect gives at 40 dB.
    report, _ = reports(case)
    share = report.diagnosis.steps[0].signature["dissipative"]
    assert low <= share <= high, share
    assert report.diagnosis.steps[0].signature["odd>=3"] > 0.05  # odd harmonics carry part of the evidence


def test_noise_is_estimated_from_period_to_period_variation():
    # White noise of known sigma on a periodic record: the per-sample noise estimate and the
    # noise variance of the averaged relative-angle coefficients. 5%: the median over ~127
    # pooled harmonics of a variance with 2 (P - 1) = 30 degrees of freedom each.
    import numpy as np

    from jointrig.identify.diagnose import prepare_runs
    from jointrig.vocab.records import SteadyStateRecord

    N, P, w = 256, 16, 10.0
    rng = np.random.default_rng(0)
    t = np.arange(N * P) * 2 * np.pi / (w * N)
    x = np.cos(w * t) + 0.1 * np.cos(3 * w * t)
    rec = SteadyStateRecord(w, t, 100 * x + rng.normal(0, 0.5, x.size), x + rng.normal(0, 0.01, x.size), None,
                            n_periods=P)
    run = prepare_runs([rec])[0]
    assert run.noise_std["torque"] == pytest.approx(0.5, rel=0.05)
    assert run.noise_std["phi1"] == pytest.approx(0.01, rel=0.05)
    assert np.median(run.phi_noise_var[1:N // 2]) == pytest.approx(0.01**2 / (N * P), rel=0.1)
    assert set(run.kept["phi"][:2]) == {1, 3}  # the two harmonics that are there, and no noise
    assert len(run.kept["phi"]) == 2


@pytest.mark.parametrize("case", ["none", "hysteresis", "micro_slip"])
def test_identified_card_agrees_with_virtual_phase_resonance(rig, reports, case):
    # The card of the model the diagnosis adopted (identified from the noisy runs) against a
    # virtual phase-resonance test of the true joint in the rig (studies/phase_resonance.py) at
    # two levels: the paper's joint, a Jenkins joint and an Iwan joint. Measured: every
    # quantity within 1.02 of the card's standard errors (propagated from the fit's
    # covariance); asked within 3. The phase-resonance result has no standard error: it is the
    # true joint, up to Brent's 1e-4 rad/s (2e-6 of omega_n).
    from jointrig.identify.card import law_card
    from jointrig.studies.joint_card import identified_law
    from jointrig.studies.phase_resonance import phase_resonance

    report, _ = reports(case)
    law, je, cov, name, _ = identified_law(report)
    assert name.startswith("nominal") if case == "none" else name == f"extended: {case}"
    pr = phase_resonance(rig, [1500.0, 3500.0], law=CASES[case][0], xtol_rad_s=1e-4, omega_bracket_rad_s=(10.0, 150.0))
    card = law_card(law, je, [p.amplitude_rad for p in pr.points], covariance=cov, inertia_index=0)
    for p, q in zip(pr.points, card.points):
        for key in ("natural_frequency_rad_s", "damping_ratio", "dissipation_J_per_cycle"):
            se = getattr(q, key + "_std")
            assert 0 < se and abs(getattr(q, key) - getattr(p, key)) < 3 * se, (key, getattr(q, key), getattr(p, key), se)
    assert abs(card.dissipation_slope - pr.dissipation_slope) < 3 * card.dissipation_slope_std


def test_the_report_says_which_generalisation_the_held_out_runs_test(reports):
    from jointrig.studies.validate import generalisation_kind

    fit = [(25.0, 1500.0, 0), (25.0, 3500.0, 0), (55.0, 1500.0, 0), (55.0, 3500.0, 0)]
    assert generalisation_kind(fit, [(25.0, 1500.0 * 1.005, 0)]).endswith("(another realisation only)")
    assert "drive levels between the fitted ones (2500 N m)" in generalisation_kind(fit, [(25.0, 2500.0, 0)])
    assert "frequencies the fit did not see (40 rad/s" in generalisation_kind(fit, [(40.0, 1500.0, 0)])
    text = generalisation_kind(fit, [(70.0, 5000.0, 3)])
    assert "another excitation" in text and "extrapolation in drive level (5000 N m" in text
    assert "extrapolation in frequency (70 rad/s" in text
    # The default hold-out of the 3 x 3 grid (runs 1, 4, 7: the middle level at each frequency).
    report, _ = reports("none")
    assert report.generalisation == ("the held-out runs test drive levels between the fitted ones (2500 N m)")


def test_causes_scored_and_runs_validated_in_forked_workers_give_the_same_report(rig, tmp_path_factory, reports,
                                                                                  monkeypatch):
    # The causes of a round are independent, and so are the validation runs: in two forked
    # processes they give the same numbers, bit for bit, as in one (the fixture's report ran in
    # one: tests/conftest.py sets JOINTRIG_WORKERS=1).
    report, _ = reports("backlash")
    records, _ = measured(rig, tmp_path_factory, "backlash")
    monkeypatch.setenv("JOINTRIG_WORKERS", "2")
    with warnings.catch_warnings():
        # Python >= 3.12 warns when a process with threads forks (an xdist worker has execnet's);
        # the workers only compute, they take no lock another thread could hold.
        warnings.simplefilter("ignore", DeprecationWarning)
        two = run_diagnosis(records, rig=rig)
    one = report.diagnosis
    assert [c.effect for c in two.diagnosis.causes] == [c.effect for c in one.causes]
    assert [c.delta_chi2 for c in two.diagnosis.causes] == [c.delta_chi2 for c in one.causes]
    assert two.diagnosis.effects == one.effects
    np.testing.assert_array_equal(two.diagnosis.extended.values, one.extended.values)
    for a, b in zip(two.runs, report.runs, strict=True):
        np.testing.assert_array_equal(a.phi_nominal_rad, b.phi_nominal_rad)
        np.testing.assert_array_equal(a.phi_extended_rad, b.phi_extended_rad)
    assert two.gain == report.gain


def test_kink_correction_adds_only_out_of_band_harmonics_and_batches_exactly():
    # The diagnosis takes its inertia, torque and viscous columns from the band-limited rate
    # because the kink correction adds harmonics above the band only (identify.diagnose._Columns):
    # in the band the corrected rate's coefficients equal the band-limited ones to round-off
    # (1e-12 of the largest), and out of band it adds something. Periods corrected together are
    # corrected as one by one, and without a given band-limited rate it is computed the same.
    from jointrig.identify.balance import spectral_rate
    from jointrig.identify.diagnose import kink_corrected_rate, kink_first_pass
    from jointrig.identify.harmonics import fourier_coefficients

    M, band = 4096, 20
    omegas = np.array([25.0, 40.0, 55.0])
    th = 2 * np.pi * np.arange(M) / M
    phi = np.stack([0.2 * np.sin(th) + 0.01 * np.sin(3 * th + k) + 0.004 * np.cos(7 * th) for k in range(3)])
    v_bl = spectral_rate(phi, omegas[:, None], 1)
    batch = kink_corrected_rate(phi, omegas, band, 300.0)
    np.testing.assert_array_equal(batch, kink_corrected_rate(phi, omegas, band, 300.0, band_limited_rate=v_bl))
    for k, w in enumerate(omegas):
        one = kink_corrected_rate(phi[k], w, band, 300.0, band_limited_rate=v_bl[k])
        np.testing.assert_allclose(batch[k], one, rtol=0, atol=1e-12 * np.abs(one).max())
    C, C_bl = fourier_coefficients(batch, 1, M // 2 - 1), fourier_coefficients(v_bl, 1, M // 2 - 1)
    scale = np.abs(C_bl).max()
    assert np.abs(C[:, : band + 1] - C_bl[:, : band + 1]).max() < 1e-12 * scale
    assert np.abs(C[:, band + 1:]).max() > 1e-4 * scale
    assert np.array_equal(kink_corrected_rate(phi, omegas, band, 0.0), v_bl)
    # The first pass does not depend on the jump: one computed for the records serves every jump
    # (a profile search's trials), with the same result as computing it afresh.
    first = kink_first_pass(phi, omegas, band, band_limited_rate=v_bl)
    for jump in (300.0, 45.0, 2000.0):
        np.testing.assert_array_equal(kink_corrected_rate(phi, omegas, band, jump, first_pass=first),
                                      kink_corrected_rate(phi, omegas, band, jump))


def test_kink_rate_move_bound_holds_and_the_sign_proof_never_claims_a_sign_it_does_not_have():
    # A profile search skips the refit at a trial's settled jump when the kink-corrected rate there
    # is proven to have the signs of the rate at the jump it fitted (identify.diagnose._sign_proof):
    # dry friction's column, sign(rate), is then the same bit for bit. The proof rests on a bound
    # of how far the rate moves (_rate_move_bound). Scanned over jumps 1e-7 to 10% away on both
    # sides of three jumps 10x apart, the bound is never below the rate's actual largest move in
    # a record and within 10x of it (measured 1.4-6.7x: each of its two terms alone falls short
    # somewhere), and the proof never holds where the computed rate's signs differ (the scan
    # reaches jumps where they do); it holds for moves of 1e-6 of the jump.
    from jointrig.identify.diagnose import _kinked, _rate_move_bound, _sign_proof, kink_first_pass

    M, band = 4096, 20
    omegas = np.array([25.0, 40.0, 55.0])
    th = 2 * np.pi * np.arange(M) / M
    phi = np.stack([0.2 * np.sin(th) + 0.01 * np.sin(3 * th + k) + 0.004 * np.cos(7 * th) for k in range(3)])
    first = kink_first_pass(phi, omegas, band)
    proven = changed = bounded = 0
    for j0 in (300.0, 3000.0, 30000.0):
        at = _kinked(first, band, j0)
        for rel in np.concatenate([-np.geomspace(1e-7, 0.1, 25), np.geomspace(1e-7, 0.1, 25)]):
            j = j0 * (1 + rel)
            exact = _kinked(first, band, j).rate_rad_s
            moved = np.abs(exact - at.rate_rad_s).max(axis=1)
            bound = _rate_move_bound(first, band, at, j0, j)
            if bound is not None:
                bounded += 1
                assert np.all(bound >= moved) and np.all(bound <= 10 * moved), (j0, rel, bound / moved)
            same = np.array_equal(np.sign(exact), np.sign(at.rate_rad_s))
            proof = _sign_proof(first, band, at, j0, j, at.rate_rad_s)
            assert same or not proof, f"proved the signs at jump {j} (relative move {rel:.3g}), but they differ"
            proven += proof
            changed += not same
            if abs(rel) <= 1e-6:
                assert proof, f"a move of {rel:.3g} of the jump {j0} is not proven"
    assert changed >= 10 and proven >= 40 and bounded >= 100
    # a fixed addition (flywheel 2's correction) counts: the proof reads the rate it is given
    at = _kinked(first, band, 300.0)
    shifted = at.rate_rad_s - at.rate_rad_s.min(axis=1, keepdims=True)  # a zero in every record
    assert not _sign_proof(first, band, at, 300.0, 300.0 * (1 + 1e-7), shifted)


def test_refit_skipped_at_a_proven_jump_gives_the_same_profile_bit_for_bit(rig, tmp_path_factory, reports,
                                                                          monkeypatch):
    # With dry friction in the base, a profile search's trials used to fit twice: at the start jump
    # and at the jump that fit implies. Where the second system is the first bit for bit
    # (identify.diagnose._Columns.same_system: dry friction's sign(rate) is the only column that
    # sees the jump, and its signs stay) the refit is skipped. Scoring free play on the dry
    # friction case with and without the skip gives the same evidence, values and standard errors
    # bit for bit, with fewer fits; Stribeck friction, whose column sees the rate's values, is
    # never skipped and comes out the same too.
    import jointrig.identify.diagnose as D
    from jointrig.identify.causes import by_name

    report, problem = _fit_problem(rig, tmp_path_factory, reports, "coulomb_friction")
    _, plain = _fit_problem(rig, tmp_path_factory, reports, "coulomb_friction")
    base, w = D.fit(problem, report.diagnosis.extended.spec)
    calls = []
    solve_once = D._solve_once
    monkeypatch.setattr(D, "_solve_once", lambda *a: calls.append(a[-1]) or solve_once(*a))
    for name in ("backlash", "stribeck_friction"):
        calls.clear()
        skipped = D.score_cause(problem, by_name(name), base, w, 10, 1e-3)
        n_skipped = len(calls)
        calls.clear()
        with monkeypatch.context() as m:
            m.setattr(D._Problem, "same_system", lambda self, spec, a, b: False)
            full = D.score_cause(plain, by_name(name), base, w, 10, 1e-3)
        assert n_skipped < 0.8 * len(calls) if name == "backlash" else n_skipped == len(calls)
        assert skipped.delta_chi2 == full.delta_chi2 and skipped.magnitude == full.magnitude, name
        assert np.array_equal(skipped.fit.values, full.fit.values), name
        assert np.array_equal(skipped.fit.std_errors, full.fit.std_errors), name
        assert skipped.fit.profile_std_errors == full.fit.profile_std_errors, name


def _fit_problem(rig, tmp_path_factory, reports, kind: str):
    """The fixture case's report and the diagnosis's harmonic-balance problem on its fit runs,
    as ``identify.diagnose.diagnose`` builds it."""
    import jointrig.identify.diagnose as D

    report, _ = reports(kind)
    records, _ = measured(rig, tmp_path_factory, kind)
    prepared = D.prepare_runs(records, band=report.band)
    runs = tuple(r for i, r in enumerate(prepared) if i not in report.holdout)
    return report, D._Problem(runs, report.diagnosis.form, report.diagnosis.n_harmonics, 0.5,
                              2.0 * (min(r.n_periods for r in runs) - 1))


def test_row_variance_pools_each_harmonic_and_equation_as_the_mean_of_its_rows(rig, tmp_path_factory, reports):
    # The weights' noise variance is pooled per run over the rows of one harmonic in one
    # equation (its real and imaginary part), plus the fidelity floor (identify.diagnose
    # _Problem.row_variance, by bincount). Against the per-group loop it replaced, on the
    # dry-friction case's nominal and extended models: the same bits (numpy's mean sums fewer
    # than 8 values in order, as bincount does).
    import jointrig.identify.diagnose as D

    report, problem = _fit_problem(rig, tmp_path_factory, reports, "coulomb_friction")
    for spec in (D.NOMINAL, report.diagnosis.extended.spec):
        f, _ = D.fit(problem, spec)
        like = problem.system(spec)
        got = problem.row_variance(spec, f.values, like)
        want = np.empty(like.F.size)
        jump = D._coulomb_jump(spec, like.names, f.values)
        for i, run in enumerate(problem.runs):
            s = problem._periods[i].system(spec, jump)
            v = (s.F - s.A @ f.values).reshape(run.n_periods, -1).var(axis=0, ddof=1) / len(run.fine_periods)
            rows = np.flatnonzero(like.row_record == i)
            h, e = like.row_harmonic[rows], like.row_equation[rows]
            size2 = float(np.max(np.abs(np.column_stack([like.A[rows] * f.values, like.F[rows]])))) ** 2
            pooled = v.copy()
            for hh in np.unique(h):
                for ee in np.unique(e):
                    sel = (h == hh) & (e == ee)
                    assert sel.sum() == 2  # the real and the imaginary part
                    pooled[sel] = v[sel].mean() + problem.fidelity**2 * size2
            want[rows] = pooled
        scale = np.max(np.abs(like.F))
        np.testing.assert_array_equal(got, np.maximum(want, (1e-12 * scale) ** 2))


def test_kink_iteration_from_a_neighbours_jump_settles_where_it_does_from_zero(rig, tmp_path_factory, reports,
                                                                              monkeypatch):
    # A profile search starts each trial's kink iteration from its nearest solved neighbour's jump
    # (identify.diagnose._solve, start_jump). Started 10% off, or at the settled jump itself, the
    # fit lands where it lands from no kinks at all: the jump settles to KINK_RTOL (1e-6), and the
    # whole kink correction moves the friction torque by ~1e-4 of itself, so the values agree to
    # 1e-9 of each (with margin). At the settled jump one fit suffices, not three.
    import jointrig.identify.diagnose as D

    report, problem = _fit_problem(rig, tmp_path_factory, reports, "coulomb_friction")
    spec = report.diagnosis.extended.spec
    _, w = D.fit(problem, spec)
    calls = []
    solve_once = D._solve_once
    monkeypatch.setattr(D, "_solve_once", lambda *a: calls.append(a[-1]) or solve_once(*a))
    cold = D._solve(problem, spec, w)
    assert len(calls) == 3 and calls[0] == 0.0
    settled = D._coulomb_jump(spec, cold.names, cold.values)
    assert settled > 0
    for start in (0.9 * settled, 1.1 * settled, settled):
        calls.clear()
        warm = D._solve(problem, spec, w, start)
        np.testing.assert_allclose(warm.values, cold.values, rtol=1e-9, atol=0)
        assert abs(warm.chi2 - cold.chi2) <= 1e-9 * cold.chi2
    assert calls == [settled]


def test_columns_computed_in_forked_workers_serve_the_next_rounds(rig, tmp_path_factory, reports):
    # A forked worker's harmonic-balance columns would die with it; it hands them back
    # (identify.diagnose._with_new_columns) and the parent keeps them, so the next round's
    # workers find a slider law's profile grid computed. Scoring the cause again here then
    # computes no column of its law term and gives the same score bit for bit.
    import jointrig.identify.diagnose as D
    from jointrig.identify.causes import by_name
    from jointrig.vocab.law import Jenkins

    report, problem = _fit_problem(rig, tmp_path_factory, reports, "coulomb_friction")
    base, w = D.fit(problem, D.NOMINAL)
    causes = [by_name("hysteresis"), by_name("quadratic_damping")]

    def jenkins_columns():
        return {k for k in problem.columns_memo if k[0] == "law" and isinstance(k[1], Jenkins)}

    assert not jenkins_columns()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # see the test above
        forked, _ = D._score_all(problem, causes, base, w, 2, 1e-3, workers=2)
    kept = jenkins_columns()
    assert len(kept) >= 17  # the profile's grid, at least
    again = D.score_cause(problem, causes[0], base, w, 2, 1e-3)
    assert jenkins_columns() == kept
    assert again.delta_chi2 == forked[0].delta_chi2
    np.testing.assert_array_equal(again.fit.values, forked[0].fit.values)


def test_a_rival_check_done_with_the_next_round_gives_what_it_gives_alone(rig, tmp_path_factory, reports):
    # The rivals of an adopted cause are checked together with the next round's causes, in the
    # same forked processes (identify.diagnose._score_all, check=): a rival's score on the new base
    # is the round's own score of it (scored once), a rival outside the round is scored too, and
    # the reverse (the adopted cause on the rival's refitted model) is what it is computed alone,
    # bit for bit.
    import jointrig.identify.diagnose as D
    from jointrig.identify.causes import by_name

    report, problem = _fit_problem(rig, tmp_path_factory, reports, "coulomb_friction")
    base, w = D.fit(problem, D.NOMINAL)
    names = ("coulomb_friction", "hysteresis", "quadratic_damping")
    first = {n: D.score_cause(problem, by_name(n), base, w, 3, 1e-3) for n in names}
    best, rivals = first["coulomb_friction"], (first["hysteresis"], first["quadratic_damping"])
    new_base = D.fit(problem, best.fit.spec)
    check = D._RivalCheck(best, by_name("coulomb_friction"), rivals, new_base, 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # see the test above
        scores, outcome = D._score_all(problem, [by_name("quadratic_damping")], *new_base, 2, 1e-3, workers=2,
                                       rivals_by_name={n: by_name(n) for n in names}, check=check)
    assert [s.effect for s in scores] == ["quadratic_damping"]
    assert outcome[1][0] is scores[0]  # the rival in the round: its round score
    for rival, (r_given_b, b_given_r) in zip(rivals, outcome):
        alone = D.score_cause(problem, by_name(rival.effect), *new_base, 2, 1e-3)
        assert (r_given_b.effect, r_given_b.delta_chi2) == (rival.effect, alone.delta_chi2)
        reverse = D.score_cause(problem, by_name("coulomb_friction"), *D.fit(problem, rival.fit.spec), 2, 1e-3)
        assert (b_given_r.effect, b_given_r.delta_chi2) == ("coulomb_friction", reverse.delta_chi2)
        assert b_given_r.delta_chi2 > 0


def test_a_cause_stays_adopted_only_if_the_model_without_it_fails(rig, tmp_path_factory, reports):
    # Parsimony after the forward selection (identify.diagnose._needed): on the dry-friction
    # case, a quadratic damping forced in beside the friction is dropped (the model without it
    # explains the data as well), the friction stays; on dry friction with free play both stay.
    import jointrig.identify.diagnose as D
    from jointrig.identify.causes import CAUSES

    by_name = {c.name: c for c in CAUSES}
    for case, forced, kept in (("coulomb_friction", "quadratic_damping", ["coulomb_friction"]),
                               ("coulomb_friction+backlash", "backlash", ["coulomb_friction", "backlash"])):
        report, problem = _fit_problem(rig, tmp_path_factory, reports, case)
        nominal, w = D.fit(problem, D.NOMINAL)
        first = D.score_cause(problem, by_name["coulomb_friction"], nominal, w, 1, 1e-3)
        with_first, w1 = D.fit(problem, first.fit.spec)
        second = D.score_cause(problem, by_name[forced], with_first, w1, 1, 1e-3)
        final = D.fit(problem, second.fit.spec)
        steps, current = D._needed(problem, [first, second], final, by_name, 1e-3, lambda msg: None)
        assert [s.effect for s in steps] == kept, (case, second.delta_chi2)
        assert {t.name for t in current.spec.terms} == {t.name for t in D._spec_of(steps, current, by_name).terms}
