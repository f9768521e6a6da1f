"""Real records (issue 50): a separate validation record (``jointrig diagnose DATA --validate
OTHER`` fits every run of DATA and holds out every run of OTHER, as benchmarks give one), and a
record from rest (its transient found and cut by the loader, the steady periods after it fitted).

Both files come from the independent bench (tests/bench_sim.py: the paper's joint with 40 N m of
dry friction, 0.2% noise, sensor offsets), written separately as a lab records them: the fit
record at the outer frequencies and levels (25 and 55 rad/s, 1500 and 3500 N m), the validation
record at the middle frequency (40 rad/s, 2500 and 3500 N m), each with its own seed and sensor
offsets.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bench_sim import JOINTS, measure, with_effect
from jointrig.cli import main as cli


def _records(tmp_path):
    bench = with_effect(JOINTS["paper"], Fc=40.0)
    fit = measure(bench, [(w, m) for w in (25.0, 55.0) for m in (1500.0, 3500.0)], tmp_path / "fit.csv", seed=11,
                  fs_Hz=2000.0, n_periods=6.5)
    other = measure(bench, [(40.0, 2500.0), (40.0, 3500.0)], tmp_path / "other.csv", seed=12, fs_Hz=2000.0,
                    n_periods=6.5)
    return fit, other


@pytest.mark.slow
def test_a_separate_record_is_held_out_whole_and_the_friction_holds_on_it(tmp_path, capsys):
    # Fitted on the four runs of one file, validated on the two of the other: the friction found
    # and sized within 3 standard errors, the verdict explained on the other record's runs.
    fit, other = _records(tmp_path)
    out = tmp_path / "d.json"
    assert cli(["diagnose", str(fit), "--validate", str(other), "--json", str(out), "-q"]) == 0
    text = capsys.readouterr().out
    j = json.loads(out.read_text())
    assert j["fit_runs"] == ["0", "1", "2", "3"] and j["held_out_runs"] == ["validate:0", "validate:1"], j
    assert j["verdict"]["verdict"] == "explained", j["verdict"]
    # dry friction first (a second, small cogging of 2.9 +- 0.4 N m is adopted beside it on this seed:
    # not what this test is about; the calibration of a second cause is issue 48's)
    assert j["extended"]["effects"][0] == "coulomb_friction at joint 1", j["extended"]["effects"]
    value, se = (j["extended"][k]["joint1_coulomb_torque_Nm"] for k in ("parameters", "std_errors"))
    assert abs(value - 40.0) <= 3 * se, (value, se)
    assert "held out for validation: validate:0, validate:1" in text


def test_validate_beside_holdout_is_refused_before_anything_is_read(tmp_path, capsys):
    missing = tmp_path / "not-there.csv"
    assert cli(["diagnose", str(missing), "--validate", str(missing), "--holdout", "0", "-q"]) == 2
    assert "give one of them" in capsys.readouterr().err


def test_a_validation_record_of_another_bench_is_refused_naming_it(tmp_path, capsys):
    # the validation record holds the relative angle alone, the fit record both angles
    fit, other = _records(tmp_path)
    rows = [line.split(",") for line in other.read_text().splitlines()]
    one = tmp_path / "one.csv"
    one.write_text("\n".join(",".join(r[:3] + ["phi [rad]" if k == 0 else f"{float(r[3]) - float(r[4]):.9f}"])
                             for k, r in enumerate(rows)) + "\n")
    assert cli(["diagnose", str(fit), "--validate", str(one), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"--validate {one}" in err and "another bench" in err, err


def test_a_transient_is_told_from_steady_periods_by_their_lowest_harmonics():
    # identify.periods.transient_periods: steady noisy periods are never cut; a decaying transient
    # on top is cut while it stands out of the last two periods' difference; noise-free periods
    # that agree to the rig's settling are not cut either.
    from jointrig.identify.periods import transient_periods

    rng = np.random.default_rng(0)
    P, n = 8, 256
    t = np.arange(P * n) / n  # in periods
    steady = np.sin(2 * np.pi * t) + 0.3 * np.sin(6 * np.pi * t)
    for seed in range(20):  # noise of 1% of the swing: nothing cut
        noisy = steady + 0.01 * np.random.default_rng(seed).standard_normal(t.size)
        assert transient_periods([noisy], P) == 0
    decaying = steady + 0.5 * np.exp(-t / 0.7) + 0.01 * rng.standard_normal(t.size)  # e^-1 per 0.7 period
    cut = transient_periods([decaying], P)
    assert 2 <= cut <= 5, cut  # 0.5 e^(-k/0.7) against the noise's 1e-2/sqrt(256) per coefficient
    assert transient_periods([steady + 1e-9 * np.sin(40 * t)], P) == 0  # round-off: below TRANSIENT_FLOOR
    assert transient_periods([steady], 2) == 0  # two periods: nothing to compare with
    # a free body's position moving from period to period is no transient when its own mean is dropped
    ramp = steady + 0.2 * np.floor(t)
    assert transient_periods([ramp], P, (True,)) == 0 and transient_periods([ramp], P) > 0


def test_a_noise_free_transient_is_cut_above_the_floor_on_the_harmonics_compared():
    # identify.periods.transient_periods on noise-free periods (the last two agree exactly, so the
    # bound is TRANSIENT_FLOOR): the first period's fundamental off by eps of the swing departs by
    # eps / 2 on one of the 11 coefficients compared (harmonics 0..10), an RMS of 0.15 eps: cut at
    # eps = 1e-4 (15 times the floor), not at 2e-6 (0.3 of it).
    from jointrig.identify.periods import TRANSIENT_FLOOR, TRANSIENT_HARMONICS, transient_periods

    P, n = 8, 256
    t = np.arange(P * n) / n  # in periods
    steady = np.sin(2 * np.pi * t) + 0.3 * np.sin(6 * np.pi * t)
    first = (t < 1).astype(float)
    swing = float(np.ptp(steady))
    assert 0.15 * 1e-4 > 10 * TRANSIENT_FLOOR and 0.15 * 2e-6 < 0.5 * TRANSIENT_FLOOR
    assert transient_periods([steady + 1e-4 * swing * first * np.sin(2 * np.pi * t)], P) == 1
    assert transient_periods([steady + 2e-6 * swing * first * np.sin(2 * np.pi * t)], P) == 0
    # harmonics 0..TRANSIENT_HARMONICS are compared, and no higher: a departure of 1e-3 of the
    # swing (far above the floor) on harmonic 10 alone is a transient, on harmonic 11 alone not
    H = TRANSIENT_HARMONICS
    assert transient_periods([steady + 1e-3 * swing * first * np.cos(2 * np.pi * H * t)], P) == 1
    assert transient_periods([steady + 1e-3 * swing * first * np.cos(2 * np.pi * (H + 1) * t)], P) == 0
    # fewer where a period holds fewer samples: 8 a period compare harmonics 0..3 (below the Nyquist
    # line 4), so a departure on harmonic 3 alone is cut
    t8 = np.arange(P * 8) / 8
    x8 = np.sin(2 * np.pi * t8) + 1e-2 * (t8 < 1) * np.cos(2 * np.pi * 3 * t8 + 0.3)
    assert transient_periods([x8], P) == 1
    # the count is the documented one, harmonics 0..10 (TRANSIENT_FACTOR's false alarms of about
    # 1e-8 are reckoned over 2 x 11 coefficients a channel): harmonic 11 alone is never a transient
    assert transient_periods([steady + 1e-3 * swing * first * np.cos(2 * np.pi * 11 * t)], P) == 0


def test_a_leading_period_is_compared_with_the_last_period_the_record_settles_to():
    # identify.periods.transient_periods: the last period is the steady state a transient departs
    # from, the last two periods' difference d (here 1e-3 of the swing on the fundamental) its
    # noise scale. Three periods: a first period 4.5 d from the last (3.5 d from the middle one) is
    # cut; one 3.5 d from the last (4.5 d from the middle one) is not. The margins, 0.5 d either
    # side of TRANSIENT_FACTOR = 4, are far above round-off (the coefficients are exact to ~1e-16).
    from jointrig.identify.periods import TRANSIENT_FACTOR, transient_periods

    P, n = 3, 64
    t = np.arange(P * n) / n  # in periods
    steady = np.sin(2 * np.pi * t) + 0.3 * np.sin(6 * np.pi * t)
    d = 1e-3 * float(np.ptp(steady)) * np.sin(2 * np.pi * t)
    first, last = (t < 1).astype(float), (t >= 2).astype(float)
    assert TRANSIENT_FACTOR == 4.0
    assert transient_periods([steady + d * last - 3.5 * d * first], P) == 1  # 4.5 d from the last
    assert transient_periods([steady + d * last + 4.5 * d * first], P) == 0  # 3.5 d from the last


def test_a_record_from_rest_takes_its_fundamental_from_after_its_first_period():
    # A servo carriage's force from rest (tests/bench_servo_sim.py, the sticky axis on an incline:
    # 3.5 periods of a 3.5 s reference, 1 kHz) read 1.78812 +- 0.00023 rad/s over the whole record,
    # 30 standard errors below the reference's 1.79520: the transient at its start is fitted as
    # if periodic. measured.runs._steady_fundamental estimates it again after the first period
    # and takes that where the two differ by more than STEADY_FUNDAMENTAL_SE combined standard
    # errors: within 3 of its own standard errors of the truth (1.2 here), said in a note; the
    # first period is then cut as a transient. A steady record keeps its whole-record estimate.
    from bench_servo_sim import simulate_case

    from jointrig.identify.periods import estimate_fundamental
    from jointrig.measured.runs import _steady_fundamental

    rec = simulate_case("sticky_incline", seed=0)
    t, F, true = rec.t_s, rec.force_N, 2 * math.pi / 3.5
    whole = estimate_fundamental(t, F, harmonics=10)
    assert abs(whole.omega_rad_s - true) > 10 * whole.std_error_rad_s
    notes = []
    got = _steady_fundamental(t, F, whole, "0", notes)
    from jointrig.present.notes import note_text

    assert abs(got.omega_rad_s - true) < 3 * got.std_error_rad_s and "a record from rest" in note_text(notes[0])
    longer = simulate_case("sticky_incline", seed=0, periods=5.5)
    steady = slice(3500, None)  # four and a half steady periods after the first
    w = estimate_fundamental(longer.t_s[steady], longer.force_N[steady], harmonics=10)
    kept = []
    assert _steady_fundamental(longer.t_s[steady], longer.force_N[steady], w, "0", kept) is w and not kept


@pytest.mark.slow
def test_records_from_rest_are_diagnosed_on_their_steady_periods(tmp_path, capsys):
    # The paper's joint, nothing missing, each of six runs recorded from the drive's start at rest
    # (6.5 periods each): the loader cuts every run's transient (said in the notes), and the
    # diagnosis holds out runs of another kind as with steady records; stiffness and damping within
    # 3 standard errors. One record of 3.5 periods from rest leaves 2 steady periods (its latest 3
    # whole ones, the first of them a transient): too few to split (refused, naming --validate),
    # diagnosed with a separate validation record. One of 4.5 leaves 3: split (issue 50 item 1).
    pts = [(w, m) for w in (25.0, 40.0, 55.0) for m in (1500.0, 3500.0)]
    rest = measure(JOINTS["paper"], pts, tmp_path / "rest.csv", seed=5, fs_Hz=2000.0, n_periods=6.5, from_rest=True)
    out = tmp_path / "d.json"
    assert cli(["diagnose", str(rest), "--json", str(out), "-q"]) == 0
    j = json.loads(out.read_text())
    assert sum("are a transient" in n for n in j["notes"]) == 6, j["notes"]
    assert j["verdict"]["verdict"] == "no_misfit", j["verdict"]
    for name, truth in (("joint1_k_Nm_per_rad", 2000.0), ("joint1_c_Nms_per_rad", 100.0)):
        v, se = j["nominal"]["parameters"][name], j["nominal"]["std_errors"][name]
        assert abs(v - truth) <= 3 * se, (name, v, se)
    short = measure(JOINTS["paper"], [(40.0, 2500.0)], tmp_path / "short.csv", seed=5, fs_Hz=2000.0, n_periods=3.5,
                    from_rest=True)
    assert cli(["diagnose", str(short), "-q"]) == 2
    assert "--validate OTHER" in capsys.readouterr().err
    # 4.5 periods from rest leave 3 steady ones: fitted on the first two (their difference is
    # the noise estimate), validated on the third (its noise floor from the fit's noise per sample):
    # the right model predicts it within 3 floors. The verdict is not asserted: a noise estimate
    # from two periods has one degree of freedom per line, and a cause can reach significance on
    # it (measured here: a bearing drag, refused by the held-out period, so UNEXPLAINED).
    three = measure(JOINTS["paper"], [(40.0, 2500.0)], tmp_path / "three.csv", seed=5, fs_Hz=2000.0, n_periods=4.5,
                    from_rest=True)
    assert cli(["diagnose", str(three), "--json", str(out), "-q"]) == 0
    j = json.loads(out.read_text())
    assert j["held_out_runs"] == ["0 (later periods)"] and j["validation"]["kind"] == "held_out_periods"
    ratio = j["validation"]["nominal_error"] / j["validation"]["noise_floor"]
    assert ratio <= 3, ratio  # a right model at its noise (0.2% per sample, one period held out)
    for name, truth in (("joint1_k_Nm_per_rad", 2000.0), ("joint1_c_Nms_per_rad", 100.0)):
        v, se = j["nominal"]["parameters"][name], j["nominal"]["std_errors"][name]
        assert abs(v - truth) <= 3 * se, (name, v, se)
    other = measure(JOINTS["paper"], [(25.0, 1500.0), (55.0, 3500.0)], tmp_path / "other.csv", seed=6, fs_Hz=2000.0,
                    n_periods=6.5)
    # fitted on its 2 steady periods, validated on the other record's runs: the right model
    # predicts them within its bound; the verdict is not asserted, as above (two periods' noise
    # estimate; measured: chi2/dof 3.0 here, the held-out error 0.23 times what a right model misses)
    assert cli(["diagnose", str(short), "--validate", str(other), "--json", str(out), "-q"]) == 0
    j = json.loads(out.read_text())
    right = j["validation"]["right_model"]
    assert j["validation"]["nominal_error"] <= right["bound"] * right["error"], j["validation"]
    for name, truth in (("joint1_k_Nm_per_rad", 2000.0), ("joint1_c_Nms_per_rad", 100.0)):
        v, se = j["nominal"]["parameters"][name], j["nominal"]["std_errors"][name]
        assert abs(v - truth) <= 3 * se, (name, v, se)


@pytest.mark.slow
def test_a_replay_that_reaches_no_steady_state_is_compared_over_the_records_own_span():
    # Issue 50, item 4: "no steady state" is never the reason a right model is refused. The clean
    # 4-inertia train of the independent bench (40 dB, right nominal model): its held-out runs
    # replayed with a cap of 3 periods, which no replay settles in, are replayed instead over
    # their own 16 periods from their measured state, and the comparison says so. The error
    # must match the settled replay's: within 3 noise floors, as the settled one is (the start
    # state is the period average's, harmonics 0..10: what is left of a transient from it is
    # far below the noise).
    from dataclasses import replace as _replace

    from chain_cases import ESTIMATION, HELD_OUT, HELD_OUT_PERIODS, RIG_CONFIG, _pump_train, records
    from bench_chain_sim import TRAIN, measured_runs

    from jointrig.identify.chain_diagnose import diagnose_chain, prepare_chain_runs
    from jointrig.rig.chain import load_chain
    from jointrig.studies.chain_validate import validate_chain

    est = records(measured_runs(TRAIN, ESTIMATION, snr_db=40.0, seed=3))
    held = records(measured_runs(TRAIN, HELD_OUT, snr_db=40.0, seed=1003, n_periods=HELD_OUT_PERIODS))
    d = diagnose_chain(prepare_chain_runs(est))
    assert not d.steps
    rig = load_chain(_pump_train())
    settled = validate_chain(rig, d, held, config=RIG_CONFIG)
    capped = validate_chain(rig, d, held, config=_replace(RIG_CONFIG, max_periods=3, accelerate=False))
    assert settled.spanned == () and len(capped.spanned) == len(held), capped.spanned
    assert capped.spanned[0].model == "nominal" and capped.failures == ()
    for v in (settled, capped):
        assert v.nominal_error <= 3 * v.noise_floor, (v.nominal_error, v.noise_floor)


def test_a_held_out_periods_noise_floor_is_the_same_from_its_spread_or_from_the_fits_noise():
    # The held-out comparison's noise: over several periods from their period-to-period spread,
    # over one period from the fit's noise per sample (each coefficient C_n = 2 X_n of white
    # noise sigma over N samples: E|C_n|^2 = 4 sigma^2 / N, and the mean of P periods 1/P of it).
    # Pure noise on three encoders (sigma 1e-3, 2e-3, 1.5e-3 rad), 64 periods of 128 samples:
    # both estimates within 10% of the expected sum (the spread's estimate over 10 harmonics x 2
    # twists x 63 degrees of freedom each scatters by about 2%); and the floor adds the rig's own
    # fidelity in quadrature.
    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.verdict import RIG_FIDELITY
    from jointrig.studies.chain_validate import _floor, _noise_parts

    rng = np.random.default_rng(0)
    P, N, band, sig = 64, 128, 10, (1e-3, 2e-3, 1.5e-3)
    t = np.arange(P * N) * (2 * np.pi / 10.0) / N
    angles = tuple(rng.normal(0.0, s, P * N) for s in sig)
    rec = ChainRecord(10.0, t, (np.zeros(P * N), None, None), angles, None, P, 1.0, source="noise")
    expected = 4 * band * ((sig[0] ** 2 + sig[1] ** 2) + (sig[1] ** 2 + sig[2] ** 2)) / N
    assert _noise_parts(rec, band).sum() == pytest.approx(expected / P, rel=0.1)
    one = ChainRecord(10.0, t[:N], (np.zeros(N), None, None), tuple(a[:N] for a in angles), None, 1, 1.0, source="one")
    noise_std = {f"phi{i}": s for i, s in enumerate(sig, start=1)}
    assert _noise_parts(one, band, noise_std).sum() == pytest.approx(expected, rel=1e-12)
    assert _noise_parts(one, band).sum() == 0.0  # one period, no noise given: nothing to say
    assert _floor(4e-6, 1.0) == pytest.approx(math.sqrt(4e-6 + RIG_FIDELITY ** 2), rel=1e-12)
    assert _floor(-1.0, 1.0) == pytest.approx(RIG_FIDELITY, rel=1e-12)


def test_the_gain_is_the_nominal_error_over_the_extended_one():
    # relative errors are below 1: a gain of 10 is 0.1 over 0.01; infinite only where the extended
    # model's error is 0, NaN where a model was not simulated
    from jointrig.studies.chain_validate import ChainValidation

    assert ChainValidation(0.1, 0.01, 0.001, ()).gain == pytest.approx(10.0, rel=1e-12)
    assert ChainValidation(0.1, 0.0, 0.001, ()).gain == math.inf
    assert math.isnan(ChainValidation(0.1, math.nan, 0.001, ()).gain)
    assert math.isnan(ChainValidation(math.nan, 0.01, 0.001, ()).gain)


def test_a_held_out_drive_keeps_its_harmonics_above_the_band_where_they_stand_out_of_the_noise():
    # studies.chain_validate.held_drive_lines: a 3 s period at 1 kHz, 3 periods, 1% noise. A sine
    # drive keeps the band (40): its harmonics above hold noise alone (each passes 4 standard
    # errors with probability about exp(-8); this seed's pass none). With a 0.04 s force pulse in
    # every period the lines run on to the rig's limit (MAX_HARM - 1; the pulse's spectrum falls
    # to its first zero at harmonic 75 and rises again); the replay's step caps them (8 steps
    # to a cycle of the highest); one period gives no noise estimate, so the band alone.
    import numpy as np

    from jointrig.identify.chain import ChainRecord
    from jointrig.rig.native_callback import MAX_HARM
    from jointrig.studies.chain_validate import held_drive_lines

    N, P, w = 3000, 3, 2 * math.pi / 3.0
    t = np.arange(N * P) * (3.0 / N)
    rng = np.random.default_rng(4)
    sine = 100.0 * np.sin(w * t)
    pulse = np.where((t % 3.0) < 0.04, 45.0, 0.0)

    def record(force, periods=P):
        n = N * periods
        x = 0.01 * np.sin(w * t[:n] - 0.3)
        return ChainRecord(w, t[:n], (force[:n] + rng.normal(0, 1.0, n),), (x + rng.normal(0, 1e-6, n),), None,
                           periods)
    assert held_drive_lines(record(sine), 40) == 40
    assert held_drive_lines(record(sine + pulse), 40) == MAX_HARM - 1
    step = 2 * math.pi / (w * 8 * 100)  # 8 steps to a cycle of harmonic 100
    assert held_drive_lines(record(sine + pulse), 40, step) == 100
    assert held_drive_lines(record(sine + pulse, 1), 40) == 40


@pytest.mark.slow
def test_a_position_controlled_carriage_from_rest_is_explained_by_its_dry_friction(tmp_path):
    # A 25 kg carriage on an inclined axis (16 N of gravity against the drive, 30 N of dry
    # friction, 150 N s/m of drag) under a PD controller at 1 kHz, recorded once from rest for
    # 3.5 periods of its reference, validated on a second record with force pulses on top
    # (tests/bench_servo_sim.py, an independent scipy simulator with exact stick-slip). It
    # rests 5% of its period, so its equation is balanced where it slides, and the constant
    # force enters every harmonic of that mask. Tolerances: the (mass 2%, drag and
    # friction 5%, the offset 10%) and 3 standard errors each; at harmonics 1..40 they read
    # +0.81% (2.9 standard errors: the balance's bias at that band, which the report names),
    # -0.24%, +0.04% and +0.03%; at 1..80, -0.02% (0.2), +0.02%, -0.03% and +0.03%. The held-out
    # replay carries the pulses' drive above the band (studies.chain_validate.held_drive_lines):
    # cut at harmonic 40 it missed the record by 3.2 times what a right model misses.
    from bench_servo_sim import write_case

    truth = write_case(tmp_path, "incline", seed=0)["axis"]
    out = tmp_path / "d.json"
    assert cli(["diagnose", str(tmp_path / "incline_id.csv"), "--validate", str(tmp_path / "incline_pulses.csv"),
                "--band", "40", "--json", str(out), "-q"]) == 0
    got = json.loads(out.read_text())
    assert got["verdict"]["verdict"] == "explained", got["verdict"]["reason"]
    ext = got["extended"]
    assert ext["effects"] == ["coulomb_friction to ground at body 1"]
    values, errors = ext["parameters"], ext["std_errors"]

    def named(start):
        return next(n for n in values if n.startswith(start))
    for start, true, rel in (("m1_", truth["m"], 0.02), ("guide1_damping_", truth["c"], 0.05),
                             ("ground1_coulomb_force_", truth["Fc"], 0.05),
                             ("ground1_constant_force_", truth["F0"], 0.10)):
        n = named(start)
        assert abs(values[n] - true) <= rel * true and abs(values[n] - true) <= 3 * errors[n], (n, values[n], true)
