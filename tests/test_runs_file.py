"""The measured-runs file format: round trips, trimming, resampling and refused input."""

import math

import numpy as np
import pytest

from measured.runs import RunsFileError, estimate_omega, read_runs, write_runs
from rig import SimulationConfig, simulate_steady_state
from rig.measurement import add_noise


@pytest.fixture(scope="module")
def records(rig):
    cfg = SimulationConfig(n_periods=3, samples_per_period=64)
    return [simulate_steady_state(rig, w, 1000.0, cfg)[0] for w in (30.0, 50.0)]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_is_exact(tmp_path, records, suffix):
    path = write_runs(tmp_path / f"runs{suffix}", records, run_ids=["a", "b"])
    loaded = read_runs(path)
    assert loaded.run_ids == ("a", "b") and loaded.notes == () and loaded.has_both_angles
    for r, back in zip(records, loaded.records):
        # CSV keeps repr() of every float: exact.
        assert back.omega_rad_s == r.omega_rad_s and back.n_periods == 3
        np.testing.assert_array_equal(back.phi1_rad, r.phi1_rad)
        np.testing.assert_array_equal(back.torque_Nm, r.torque_Nm)


def test_relative_angle_only_and_units_header(tmp_path, records):
    rel = [add_noise(r, None, np.random.default_rng(0)) for r in records]
    rel = [type(r)(r.omega_rad_s, r.time_s, r.torque_Nm, r.phi_rad, None, n_periods=r.n_periods) for r in rel]
    path = write_runs(tmp_path / "rel.csv", rel)
    head = path.read_text().splitlines()[0]
    assert "time [s]" in head and "torque [N m]" in head and "phi [rad]" in head
    loaded = read_runs(path)
    assert not loaded.has_both_angles
    np.testing.assert_array_equal(loaded.records[0].phi_rad, records[0].phi_rad)


def test_fixed_rate_record_is_trimmed_and_resampled_with_a_note(tmp_path):
    # A bench samples at 1 kHz, whatever the drive: 2 pi / 30 s holds 209.44 samples. Without
    # an omega column the fundamental comes from the torque (periodogram peak, refined);
    # rtol 1e-7 on omega: 2.2 s of a clean sine pin the frequency far better than that.
    w = 30.0
    t = np.arange(0, 2.2, 1e-3)
    phi = 0.2 * np.cos(w * t - 0.3) + 0.01 * np.cos(3 * w * t)
    rows = ["run,time,torque,phi"] + [f"7,{ti!r},{800 * math.cos(w * ti)!r},{p!r}" for ti, p in zip(t.tolist(), phi.tolist())]
    path = tmp_path / "bench.csv"
    path.write_text("\n".join(rows) + "\n")
    loaded = read_runs(path)
    rec = loaded.records[0]
    assert rec.omega_rad_s == pytest.approx(w, rel=1e-7)
    assert rec.n_periods == int(2.2 * w / (2 * math.pi) + 1e-9) == 10
    assert any("estimated from the torque" in n for n in loaded.notes)
    assert any("resampled" in n and "trimmed to 10 whole periods" in n for n in loaded.notes)
    # Cubic-spline resampling of a 33x oversampled signal: error ~ (h w)^4 ~ 1e-6 of the swing.
    expect = 0.2 * np.cos(w * rec.time_s - 0.3) + 0.01 * np.cos(3 * w * rec.time_s)
    np.testing.assert_allclose(rec.phi_rad, expect, atol=2e-6 * 0.4)


def test_estimate_omega_from_a_non_integer_number_of_periods():
    t = np.arange(0, 10, 0.01)
    # 11.6 periods: a plain periodogram peak is biased by the negative-frequency image (6e-4 here).
    assert estimate_omega(t, np.cos(7.3 * t + 1.0)) == pytest.approx(7.3, rel=1e-9)


@pytest.mark.parametrize("text, match", [
    ("run,time,torque,phi1,phi2,temp\n", "unknown column.*temp"),
    ("run,time,phi1,phi2\n", r"missing column\(s\) \['torque'\]"),
    ("run,time,torque,phi\n0,0,1,nan\n", "column 'phi' holds 1 missing or non-finite.*run 0, data row 1"),
    ("run,time,torque,phi,phi1\n", "either 'phi' or"),
    ("run,time,torque,phi1\n", "expected 'phi1' and 'phi2'"),
    ("run,time,torque,phi\n" + "".join(f"0,{i * 0.01},{math.cos(i * 0.01 * 30)},{i}\n" for i in range(15)),
     "too short"),
    ("run,time,torque,phi,omega\n" + "".join(f"0,{i * 0.01},1,0,1.0\n" for i in range(40)), "at least 2 whole periods"),
    ("run,time,torque,phi\n0,0,1,x\n", "non-number"),
])
def test_bad_files_are_refused_with_the_column_named(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(RunsFileError, match=match):
        read_runs(path)


def test_missing_file_and_unknown_type(tmp_path):
    with pytest.raises(RunsFileError, match="no such file"):
        read_runs(tmp_path / "nope.csv")
    (tmp_path / "x.xlsx").write_text("")
    with pytest.raises(RunsFileError, match="expected .csv or .parquet"):
        read_runs(tmp_path / "x.xlsx")
