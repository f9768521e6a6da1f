"""Measured-runs files as labs have them: hand-written files with analytic expected values.

Nothing here is written by ``measured.runs.write_runs`` except the one round trip that checks
the writer itself. Signals are band-limited periodic functions of known coefficients, so every
column the loader returns has an exact expected value at the record's own sample times.
"""

import hashlib
import math
import os

import numpy as np
import pytest

from jointrig.measured.runs import RunsFileError, estimate_omega, read_runs, write_runs
from conftest import note_words

W = 60.0  # rad/s


def torque(t):
    return 1000.0 * np.cos(W * t)


def phi1(t):
    return 0.3 * np.cos(W * t - 0.5) + 0.02 * np.cos(3 * W * t + 0.2)


def phi2(t):
    return 0.1 * np.cos(W * t - 1.5) - 0.01 * np.sin(2 * W * t)


def csv_text(t, *, head="run,time,torque,phi1,phi2", fmt="{:.9f}", run="0", scale=(1, 1, 1, 1), sep=",",
             extra=None):
    lines = [head]
    for i, ti in enumerate(t):
        vals = [fmt.format(ti * scale[0]), repr(float(torque(ti) * scale[1])), repr(float(phi1(ti) * scale[2])),
                repr(float(phi2(ti) * scale[3]))]
        if extra is not None:
            vals.append(extra(i))
        lines.append(sep.join([run] + vals))
    return "\n".join(lines) + "\n"


def check_columns(rec, atol):
    t = rec.time_s
    np.testing.assert_allclose(rec.torques_Nm[0], torque(t), atol=atol * 1000)
    np.testing.assert_allclose(rec.angles_rad[0], phi1(t), atol=atol * 0.3)
    np.testing.assert_allclose(rec.angles_rad[1], phi2(t), atol=atol * 0.3)


def test_a_record_from_rest_keeps_its_latest_whole_periods(tmp_path):
    # 1740 samples (3.4 periods of 512) whose first 0.3 period settles from rest (every channel off its
    # steady course by a decaying exp(-t / (0.02 T))): the 0.4 period left over goes from the
    # start, so the three whole periods kept are the settled ones (no transient cut; the first
    # three would have held the transient and lost a period to it), and every column is the
    # analytic steady one (the transient's trace there, exp(-20) of it, 2e-9 of the swing).
    T = 2 * math.pi / W
    t = np.arange(int(3.4 * 512)) * (T / 512)
    away = np.exp(-t / (0.02 * T))
    lines = ["run,time,torque,phi1,phi2"] + [
        f"0,{ti:.12f},{float(torque(ti) - 800.0 * a)!r},{float(phi1(ti) - 0.3 * a)!r},{float(phi2(ti) + 0.1 * a)!r}"
        for ti, a in zip(t, away)]
    path = tmp_path / "from_rest.csv"
    path.write_text("\n".join(lines) + "\n")
    loaded = read_runs(path)
    rec = loaded.records[0]
    assert rec.n_periods == 3 and rec.time_s[0] == pytest.approx(t[t.size - 3 * 512], abs=1e-12)
    words = note_words(loaded.notes)
    assert any("the first 204 samples" in n for n in words) and not any("transient" in n for n in words), words
    check_columns(rec, 1e-8)


def test_whole_periods_without_omega_define_their_fundamental(tmp_path):
    # 512 samples per period, 4.5 periods, time stamps rounded to 1 ns: the record repeats every
    # 512 samples, so omega is 2 pi / (512 dt) to the stamps' precision (1e-9 relative at most),
    # the incomplete half period at the start is dropped, and every column is the analytic one.
    dt = 2 * math.pi / W / 512
    t = 0.37 + np.arange(int(4.5 * 512)) * dt
    path = tmp_path / "bench.csv"
    path.write_text(csv_text(t))
    loaded = read_runs(path)
    rec = loaded.records[0]
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-9) and rec.n_periods == 4 and rec.samples_per_period == 512
    assert any("repeats every 512 samples" in n for n in note_words(loaded.notes))
    assert any("the first 256 samples" in n for n in note_words(loaded.notes))
    assert rec.time_s[0] == pytest.approx(0.37 + 256 * dt, abs=1e-9)  # the latest whole periods
    # the values are the file's own (the clock is the only change): measured 4e-11 of the
    # swing, the 1 ns stamps' rounding averaged by the clock fit; 1e-9 leaves 25x
    check_columns(rec, 1e-9)


def test_fixed_rate_record_keeps_every_period_by_least_squares(tmp_path):
    # 5 kHz, not commensurate (523.6 samples per period), from an arbitrary phase: harmonics
    # 0..128 of each whole period by least squares on its own samples are exact for these
    # 3-harmonic signals; the frequency comes from the torque's line (noise-free: ~1e-12).
    t = 1.234 + np.arange(5000) / 5000.0
    path = tmp_path / "daq.csv"
    path.write_text(csv_text(t, fmt="{:.7f}"))
    loaded = read_runs(path)
    rec = loaded.records[0]
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-9)
    assert rec.n_periods == int(1.0 * W / (2 * math.pi)) == 9
    assert any("not a whole number (a fixed sample rate)" in n and "9 whole periods" in n for n in note_words(loaded.notes))
    # time stamps rounded to 1e-7 s (5e-4 of a step): the clock fit averages it out; measured
    # 4e-14 of the swing (least squares is exact for these 3-harmonic signals); 1e-11 leaves 250x
    check_columns(rec, 1e-11)


def test_fixed_rate_with_noise_is_unbiased_and_keeps_the_noise(tmp_path):
    rng = np.random.default_rng(0)
    t = np.arange(4000) / 2000.0
    noise = 0.002
    lines = ["run,time,torque,phi1,phi2"]
    for ti in t:
        lines.append(f"a,{ti:.7f},{torque(ti) + noise * 1000 * rng.standard_normal():.6f},"
                     f"{phi1(ti) + noise * 0.3 * rng.standard_normal():.9f},{phi2(ti) + noise * 0.1 * rng.standard_normal():.9f}")
    path = tmp_path / "noisy.csv"
    path.write_text("\n".join(lines) + "\n")
    rec = read_runs(path).records[0]
    # omega from the torque's line: its standard error here is ~4e-4 rad/s (CRLB of a 2 s
    # record at 0.2% noise); 5 standard errors
    assert rec.omega_rad_s == pytest.approx(W, abs=2e-3)
    # the period average of phi2 against the analytic one: 0.2% noise over 19 periods
    N, P = rec.samples_per_period, rec.n_periods
    avg = rec.angles_rad[1].reshape(P, N).mean(axis=0)
    err = avg - phi2(rec.time_s[:N])
    assert np.sqrt(np.mean(err**2)) < 3 * noise * 0.1  # noise of the average is ~noise/sqrt(P) per sample


@pytest.mark.parametrize("variant", ["units_in_header", "units_row", "semicolon_decimal_comma_bom", "mapping",
                                     "quoted_fields_and_text_labels"])
def test_lab_dialects_give_the_same_record(tmp_path, variant):
    # Plain numbers take numpy's C reader, anything else the csv module (measured.formats._read_csv):
    # both give the same record.
    dt = 2 * math.pi / W / 256
    t = np.arange(3 * 256) * dt
    path = tmp_path / "lab.csv"
    kw = {}
    if variant == "units_in_header":
        text = csv_text(t, head="Run,Time [ms],Torque [N mm],phi1 (deg),phi2 [mrad]", fmt="{:.9f}",
                        scale=(1e3, 1e3, 180 / math.pi, 1e3))
        text = text.replace("Run,", "run,", 1)
    elif variant == "units_row":
        text = csv_text(t, head="run,time,torque,phi1,phi2\n-,s,Nm,deg,rad", scale=(1, 1, 180 / math.pi, 1))
    elif variant == "semicolon_decimal_comma_bom":
        text = "\ufeff" + csv_text(t, head="run;time;torque;phi1;phi2", sep=";").replace(".", ",")
    elif variant == "quoted_fields_and_text_labels":
        head, *body = csv_text(t, run="bench A").splitlines()
        text = "\n".join([head] + [",".join(f'"{v}"' for v in ln.split(",")) for ln in body]) + "\n"
    else:
        text = csv_text(t, head="Lauf,Zeit,M_an,enc_1,enc_2,temperature", extra=lambda i: "21.5")
        kw = {"columns": "run=Lauf,time=Zeit,torque=M_an,phi1=enc_1,phi2=enc_2"}
    path.write_bytes(text.encode("utf-8"))
    loaded = read_runs(path, **kw)
    rec = loaded.records[0]
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-8) and rec.n_periods == 3
    assert loaded.run_ids == (("bench A",) if variant == "quoted_fields_and_text_labels" else ("0",))
    # time written to 9 decimals (of s, or of ms): measured 1.5e-10 of the swing at most; 1e-8
    check_columns(rec, 1e-8)
    if variant == "mapping":
        assert any("temperature" in n and "ignored" in n for n in note_words(loaded.notes))
    if variant in ("units_in_header", "units_row"):
        assert not any("SI assumed" in n for n in note_words(loaded.notes))


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_a_decimal_comma_first_written_below_the_twentieth_row_is_one(tmp_path, sep):
    # A logger at rest writes whole numbers ("0", not "0,0"): its decimal commas show only further
    # down. measured.formats looks at the first 20 data rows to choose numpy's reader; the rest
    # decides too (the first comma in data row 26 was refused: "'25,5' is a non-number").
    from jointrig.measured.formats import read_tables

    rows = [sep.join([str(i), "0", "0", "0"]) for i in range(25)] + [sep.join(["25,5", "1,25", "-0,125", "2,5e-3"])]
    path = tmp_path / "rest.txt"
    path.write_text("\n".join([sep.join(["time", "torque", "phi1", "phi2"])] + rows) + "\n")
    cols = read_tables(path)[0].columns
    # the same decimal strings as the literals: equal exactly
    assert cols["time"].tolist() == [*map(float, range(25)), 25.5]
    assert [cols[c][-1] for c in ("torque", "phi1", "phi2")] == [1.25, -0.125, 2.5e-3]
    assert not cols["torque"][:25].any()


def test_units_option_and_sidecar(tmp_path):
    dt = 2 * math.pi / W / 128
    t = np.arange(2 * 128) * dt
    path = tmp_path / "deg.csv"
    path.write_text(csv_text(t, scale=(1e3, 1, 180 / math.pi, 180 / math.pi)))
    # measured 1.2e-13 (unit conversion round-off); 1e-11
    check_columns(read_runs(path, units="time=ms,phi1=deg,phi2=deg").records[0], 1e-11)
    (tmp_path / "deg.csv.meta.json").write_text('{"units": {"time": "ms", "phi1": "deg", "phi2": "deg"}}')
    loaded = read_runs(path)
    check_columns(loaded.records[0], 1e-11)
    assert any("meta.json" in n for n in note_words(loaded.notes))


def test_relative_angle_only(tmp_path):
    dt = 2 * math.pi / W / 64
    t = np.arange(2 * 64) * dt
    lines = ["time,torque,phi"] + [f"{float(ti)!r},{float(torque(ti))!r},{float(phi1(ti) - phi2(ti))!r}" for ti in t]
    (tmp_path / "rel.csv").write_text("\n".join(lines) + "\n")
    loaded = read_runs(tmp_path / "rel.csv")
    rec = loaded.records[0]
    # one body, the joint's twist, driven by the default share of the torque (two equal flywheels)
    assert rec.n_flywheels == 1 and loaded.torque_share == 0.5 and loaded.run_ids == ("0",)
    # The input's SHA-256 (in every report and JSON) is the file's own: `sha256sum rel.csv` checks it.
    assert loaded.sha256 == hashlib.sha256((tmp_path / "rel.csv").read_bytes()).hexdigest()
    np.testing.assert_allclose(rec.angles_rad[0], phi1(rec.time_s) - phi2(rec.time_s), atol=1e-12)
    np.testing.assert_allclose(rec.torques_Nm[0], 0.5 * torque(rec.time_s), atol=1e-9)


def test_folder_of_runs_one_file_each(tmp_path):
    dt = 2 * math.pi / W / 64
    t = np.arange(2 * 64) * dt
    txt = csv_text(t, head="time,torque,phi1,phi2")
    for name in ("b_run", "a_run"):
        (tmp_path / f"{name}.csv").write_text("\n".join(ln.split(",", 1)[1] if i else ln
                                                        for i, ln in enumerate(txt.splitlines())) + "\n")
    loaded = read_runs(tmp_path)
    assert loaded.run_ids == ("a_run", "b_run") and len(loaded.sha256) == 64
    # A folder's digest covers every file: changing one byte of one file changes it.
    before = loaded.sha256
    (tmp_path / "b_run.csv").write_text((tmp_path / "b_run.csv").read_text().replace("time", "Time", 1))
    assert read_runs(tmp_path).sha256 != before
    # A folder holding a single file reads as that file, with the file's own digest.
    single = tmp_path / "one"
    single.mkdir()
    (single / "a_run.csv").write_bytes((tmp_path / "a_run.csv").read_bytes())
    one = read_runs(single)
    assert one.run_ids == ("a_run",)
    assert one.sha256 == hashlib.sha256((single / "a_run.csv").read_bytes()).hexdigest()
    check_columns(loaded.records[1], 1e-8)  # time written to 1 ns: measured 2e-9 of the swing


def test_parquet_timestamp_column(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    dt_ns = 200_000  # 0.2 ms
    n = 4 * 524
    t = np.arange(n) * dt_ns * 1e-9
    stamps = np.datetime64("2026-11-23T10:00:00", "ns") + (np.arange(n) * dt_ns).astype("timedelta64[ns]")
    pq.write_table(pa.table({"time": stamps, "torque": torque(t), "phi1": phi1(t), "phi2": phi2(t)}),
                   tmp_path / "ts.parquet")
    rec = read_runs(tmp_path / "ts.parquet").records[0]
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-9)
    check_columns(rec, 1e-11)  # exact ns stamps, fixed rate by least squares: measured 3e-14


def _signals(t):
    return {"time": t, "torque": torque(t), "phi1": phi1(t), "phi2": phi2(t)}


def test_matlab_hdf5_tdms_uff_readers(tmp_path):
    import h5py
    import pyuff
    import scipy.io
    from nptdms import ChannelObject, TdmsWriter

    dt = 2 * math.pi / W / 128
    t = np.arange(3 * 128) * dt
    sig = _signals(t)
    scipy.io.savemat(tmp_path / "r.mat", sig)
    with h5py.File(tmp_path / "r.h5", "w") as f:
        for run in ("low", "high"):
            g = f.create_group(run)
            for k, v in sig.items():
                g.create_dataset(k, data=v * (180 / math.pi if k == "phi2" else 1))
                g[k].attrs["units"] = "deg" if k == "phi2" else ("s" if k == "time" else ("N m" if k == "torque" else "rad"))
    with TdmsWriter(tmp_path / "r.tdms") as w:
        w.write_segment([ChannelObject("run7", k, v, properties={"wf_increment": dt, "wf_start_offset": 0.0,
                                                                   "unit_string": "Nm" if k == "torque" else "rad"})
                         for k, v in sig.items() if k != "time"])
    uff = pyuff.UFF(str(tmp_path / "r.uff"))
    for k in ("torque", "phi1", "phi2"):
        uff.write_sets(pyuff.prepare_58(binary=0, id1=k, func_type=1, load_case_id=3, rsp_node=1, rsp_dir=1,
                                        ref_node=1, ref_dir=1, data=sig[k], x=t, abscissa_spacing=1,
                                        abscissa_min=0.0, abscissa_inc=dt, ordinate_axis_units_lab="N m" if k == "torque" else "rad",
                                        abscissa_axis_units_lab="s", abscissa_spec_data_type=17,
                                        ordinate_spec_data_type=0, orddenom_spec_data_type=0,
                                        z_axis_spec_data_type=0, ord_data_type=4), mode="add")
    for name, runs in (("r.mat", ("0",)), ("r.h5", ("high", "low")), ("r.tdms", ("run7",)), ("r.uff", ("3",))):
        loaded = read_runs(tmp_path / name)
        assert loaded.run_ids == runs, name
        # UFF 58 in ASCII stores the abscissa increment as E13.5 (6 digits): the clock, and so
        # omega, are right to ~1e-6 there; elsewhere to round-off
        rel = 2e-5 if name == "r.uff" else 1e-8
        for rec in loaded.records:
            assert rec.omega_rad_s == pytest.approx(W, rel=rel), name
            # measured 2.2e-6 (UFF, the increment's 6 digits) and 4e-15 (binary formats)
            check_columns(rec, 1e-5 if name == "r.uff" else 1e-12)


def test_round_trip_of_the_projects_writer(tmp_path):
    dt = 2 * math.pi / W / 64
    t = np.arange(3 * 64) * dt
    from jointrig.vocab.records import SteadyStateRecord

    rec = SteadyStateRecord(W, t, torque(t), phi1(t), phi2(t), n_periods=3)
    for suffix in (".csv", ".parquet"):
        path = write_runs(tmp_path / f"w{suffix}", [rec, rec], run_ids=["a", "b"])
        loaded = read_runs(path)
        assert loaded.run_ids == ("a", "b")
        back = loaded.records[1]
        assert back.omega_rad_s == W and back.n_periods == 3
        np.testing.assert_array_equal(back.angles_rad[1], rec.phi2_rad)
        np.testing.assert_array_equal(back.torques_Nm[0], rec.torque_Nm)
        umask = os.umask(0)
        os.umask(umask)
        assert path.stat().st_mode & 0o777 == 0o666 & ~umask  # as open() makes files, not mkstemp's 0600


def test_estimate_omega_from_a_non_integer_number_of_periods():
    t = np.arange(0, 10, 0.01)
    assert estimate_omega(t, np.cos(7.3 * t + 1.0)) == pytest.approx(7.3, rel=1e-9)


def test_omega_column_checked_against_the_data(tmp_path):
    dt = 2 * math.pi / W / 512
    t = np.arange(4 * 512) * dt
    # 20% off: refused; 1e-5 off (a logger's rounding): the record's own period is used, with a note
    for omega, ok in ((W * 1.2, False), (W * (1 + 1e-5), True), (W, True)):
        path = tmp_path / "w.csv"
        path.write_text(csv_text(t, head="run,time,torque,phi1,phi2,omega", extra=lambda i: repr(omega)))
        if ok:
            assert read_runs(path).records[0].omega_rad_s == pytest.approx(W, rel=1e-9)
        else:
            with pytest.raises(RunsFileError, match=r"does not repeat at that period: it repeats at 60"):
                read_runs(path)


def test_drift_refused_and_common_rotation_removed(tmp_path):
    dt = 2 * math.pi / W / 256
    t = np.arange(4 * 256) * dt
    lines = ["time,torque,phi1,phi2"] + [f"{float(ti)!r},{float(torque(ti))!r},{float(phi1(ti) + 0.05 * ti)!r},{float(phi2(ti))!r}"
                                         for ti in t]
    (tmp_path / "slip.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(RunsFileError, match="relative angle phi1 - phi2 drifts"):
        read_runs(tmp_path / "slip.csv")
    lines = ["time,torque,phi1,phi2"] + [f"{float(ti)!r},{float(torque(ti))!r},{float(phi1(ti) + 3 * ti)!r},"
                                         f"{float(phi2(ti) + 3 * ti)!r}" for ti in t]
    (tmp_path / "spin.csv").write_text("\n".join(lines) + "\n")
    loaded = read_runs(tmp_path / "spin.csv")
    assert any("rotate steadily at 3 rad/s" in n for n in note_words(loaded.notes))
    check_columns(loaded.records[0], 1e-12)  # the rotation removed by its fitted slope: measured 9e-15


@pytest.mark.parametrize("quantity, unit, factor", [
    # Written out by hand from the definitions, not read from measured.runs.UNITS.
    ("time", "s", 1.0), ("time", "sec", 1.0), ("time", "ms", 1e-3), ("time", "us", 1e-6), ("time", "µs", 1e-6),
    ("time", "ns", 1e-9), ("time", "min", 60.0),
    ("angle", "rad", 1.0), ("angle", "mrad", 1e-3), ("angle", "urad", 1e-6), ("angle", "µrad", 1e-6),
    ("angle", "deg", math.pi / 180), ("angle", "°", math.pi / 180), ("angle", "degree", math.pi / 180),
    ("angle", "degrees", math.pi / 180), ("angle", "rev", 2 * math.pi), ("angle", "turn", 2 * math.pi),
    ("torque", "N m", 1.0), ("torque", "N mm", 1e-3), ("torque", "N cm", 1e-2), ("torque", "kN m", 1e3),
    ("torque", "mN m", 1e-3), ("torque", "N*m", 1.0), ("torque", "N·m", 1.0), ("torque", "Nm", 1.0),
    ("frequency", "rad/s", 1.0), ("frequency", "Hz", 2 * math.pi), ("frequency", "rpm", 2 * math.pi / 60),
    ("frequency", "1/min", 2 * math.pi / 60), ("frequency", "deg/s", math.pi / 180),
])
def test_every_unit_converts_by_its_definition(tmp_path, quantity, unit, factor):
    # One run of 2 periods at 128 samples; the column of the quantity is written in the unit,
    # the others in SI; what is read back must be the SI signal (relative 1e-12: the
    # conversion's round-off; omega is checked against the data's own period).
    dt = 2 * math.pi / W / 128
    t = np.arange(2 * 128) * dt
    column = {"time": "time", "angle": "phi1", "torque": "torque", "frequency": "omega"}[quantity]
    scale = {"time": (1 / factor, 1, 1, 1), "angle": (1, 1, 1 / factor, 1), "torque": (1, 1 / factor, 1, 1),
             "frequency": (1, 1, 1, 1)}[quantity]
    extra = (lambda i: repr(W / factor)) if quantity == "frequency" else None
    head = "run,time,torque,phi1,phi2" + (",omega" if extra else "")
    path = tmp_path / "u.csv"
    path.write_text(csv_text(t, head=head, fmt="{:.17g}", scale=scale, extra=extra))
    rec = read_runs(path, units=f"{column}={unit}").records[0]
    np.testing.assert_allclose(rec.time_s[:3], t[:3] - t[0] + rec.time_s[0], rtol=1e-12, atol=1e-15)
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-9)
    check_columns(rec, 1e-11)


# --- the pure period functions the loader is built on, by hand (identify/periods.py) --------

def test_uniform_clock_and_its_worst_stamp():
    from jointrig.identify.periods import uniform_clock

    t = 0.5 + 1e-3 * np.arange(10)
    t[6] += 2e-5  # 0.02 of a step late
    c = uniform_clock(t)
    # The least-squares line leans towards the late stamp by its leverage (1/10 + (6-4.5)^2/82.5
    # of it), in steps of the fitted dt.
    lev = 0.1 + 1.5**2 / 82.5
    assert c.worst_index == 6 and c.max_deviation == pytest.approx(2e-5 * (1 - lev) / c.dt_s, rel=1e-9)
    assert c.dt_s == pytest.approx(1e-3, rel=1e-3) and c.times(3)[0] == pytest.approx(c.t0_s)
    with pytest.raises(ValueError, match="sample 1 at"):
        uniform_clock(np.array([0.0, 0.0, 1.0]))


def test_harmonics_per_period_by_hand():
    from jointrig.identify.periods import ls_harmonics

    # min(floor((N - 1)/2) - 1, floor(0.4 N), cap), at least 1
    assert [ls_harmonics(n) for n in (3, 10, 64, 1000)] == [1, 3, 25, 128]
    assert ls_harmonics(64, max_share=0.1) == 6 and ls_harmonics(64, cap=7) == 7


def test_linear_drift_in_closed_form():
    from jointrig.identify.periods import linear_drift

    w, dt = 10.0, 2 * math.pi / 10.0 / 50
    t = 3.0 + np.arange(200) * dt  # 4 whole periods, starting anywhere
    x = 0.5 * np.cos(w * t) + 0.1 * np.sin(3 * w * t) + 2e-3 * (t - 3.0)
    d = linear_drift(t, x, w)
    assert d.slope == pytest.approx(2e-3, rel=1e-9)
    assert d.over_record == pytest.approx(2e-3 * 200 * dt, rel=1e-9)
    assert d.t_stat > 1e3 and d.t_stat == pytest.approx(d.slope / d.std_error)
    # With white noise of 0.01, the slope's standard error is sigma / sqrt(sum (t - mean)^2)
    # (the trend column is orthogonal to whole periods of the harmonics): within 10% (the
    # residual variance from 200 - 22 samples).
    rng = np.random.default_rng(3)
    noisy = linear_drift(t, 0.5 * np.cos(w * t) + 0.01 * rng.standard_normal(t.size), w)
    assert noisy.std_error == pytest.approx(0.01 / np.sqrt(np.sum((t - t.mean()) ** 2)), rel=0.1)
    assert abs(noisy.t_stat) < 4


@pytest.mark.parametrize("length, whole", [(3.5, 3), (1.6, 1)])
def test_periods_by_least_squares_in_closed_form(length, whole):
    from jointrig.identify.periods import periods_by_least_squares

    # 3.5 (1.6) periods of a three-harmonic signal at 37.3 samples per period: three whole periods
    # (one), each resynthesised exactly on 32 samples, residual zero; with one more harmonic (7)
    # than the fit keeps, the residual is its RMS. Less than a period is refused.
    w = 5.0
    dt = 2 * math.pi / w / 37.3

    def signal(t):
        return 1.0 + np.cos(w * t) - 0.3 * np.sin(2 * w * t) + 0.2 * np.cos(3 * w * t + 1)

    t = np.arange(int(length * 37.3)) * dt
    x = signal(t)
    fit = periods_by_least_squares(t, x, w, samples_per_period=32, harmonics=3)
    assert (fit.n_periods, fit.samples_per_period, fit.harmonics) == (whole, 32, 3)
    tt = np.arange(whole * 32) * (2 * math.pi / w / 32)
    np.testing.assert_allclose(fit.samples[0], signal(tt), atol=1e-12)
    assert fit.residual_rms[0] < 1e-12
    extra = periods_by_least_squares(t, x + 0.05 * np.cos(7 * w * t), w, samples_per_period=32, harmonics=3)
    assert extra.residual_rms[0] == pytest.approx(0.05 / math.sqrt(2), rel=0.05)
    with pytest.raises(ValueError, match="less than one period"):
        periods_by_least_squares(t[: int(0.8 * 37.3)], x[: int(0.8 * 37.3)], w, samples_per_period=32)


def test_estimate_fundamental_to_round_off_and_its_standard_error_is_the_crlb():
    from jointrig.identify.periods import estimate_fundamental

    # Noise-free: 10.3 periods at 37.3 samples per period, two harmonics: omega to round-off
    # (2e-16 measured, after the parabolic steps that follow the bounded search, which alone
    # stops near 1e-11; 1e-13 asked).
    w, fs = 7.0, 7.0 / (2 * math.pi) * 37.3
    t = 3.0 + np.arange(int(10.3 * 37.3)) / fs
    x = np.cos(w * t + 0.4) + 0.3 * np.sin(2 * w * t)
    f = estimate_fundamental(t, x)
    assert f.omega_rad_s == pytest.approx(w, rel=1e-13)
    # A short record, 45 samples at 5.3 per period: the periodogram's first guess must use the
    # record's own sample spacing, or the search's bracket (+-2 padded bins, 3% here) misses the
    # tone (a spacing of span / (n + 1) put it 1.6% off); to round-off as above.
    fs_short = w / (2 * math.pi) * 5.3
    t = 1.0 + np.arange(45) / fs_short
    assert estimate_fundamental(t, np.cos(w * t + 0.4)).omega_rad_s == pytest.approx(w, rel=1e-13)
    # A noisy sinusoid: the reported standard error is the Cramer-Rao bound of a real tone's
    # frequency, var = 24 s^2 / (A^2 dt^2 N (N^2 - 1)) (Kay 1993, eq. 3.41 with SNR A^2 / 2s^2;
    # 12 is a complex exponential's), within 15% (0.9% measured);
    # the spread over 40 noise seeds within 30% of it (40 samples: the spread's own error ~11%);
    # the noise variance within 10% with its degrees of freedom n - (2H + 1) - 1.
    n, dt, s = 2000, 1 / fs, 0.01
    t = np.arange(n) * dt
    crlb = math.sqrt(24 * s**2 / (dt**2 * n * (n**2 - 1)))
    rng = np.random.default_rng(3)
    est = []
    for _ in range(40):
        f = estimate_fundamental(t, np.cos(w * t + 1.0) + s * rng.standard_normal(n), harmonics=3)
        est.append(f.omega_rad_s)
        assert f.std_error_rad_s == pytest.approx(crlb, rel=0.15)
    assert f.noise_var == pytest.approx(s**2, rel=0.1) and f.dof == n - (2 * 3 + 1) - 1
    assert float(np.std(est, ddof=1)) == pytest.approx(crlb, rel=0.3)
    assert abs(float(np.mean(est)) - w) < 3 * crlb / math.sqrt(40) * 1.3


def test_a_precise_motion_channel_sharpens_a_noisy_drives_fundamental():
    from jointrig.identify.periods import estimate_fundamental, with_second_channel

    # A drive at 10% noise, the motion (another phase, a harmonic) at 0.1%: the combined
    # frequency's error is the inverse-variance combination's, each estimate's Cramer-Rao bound
    # (the test above) scaled by its amplitude: 100 times smaller than the drive's alone here.
    # Over 40 noise seeds its spread within 30% of its standard error (the spread's own error
    # ~11%), and the drive's fit is returned at the combined frequency.
    w, fs, n = 7.0, 7.0 / (2 * math.pi) * 37.3, 2000
    t = np.arange(n) / fs
    rng = np.random.default_rng(5)
    est, errs = [], []
    for _ in range(40):
        drive = np.cos(w * t) + 0.1 * rng.standard_normal(n)
        motion = 0.5 * np.sin(w * t + 0.3) + 0.05 * np.cos(3 * w * t) + 5e-4 * rng.standard_normal(n)
        alone = estimate_fundamental(t, drive, harmonics=3)
        both = with_second_channel(t, drive, motion, alone)
        assert both.std_error_rad_s < alone.std_error_rad_s / 50
        assert both.rss == pytest.approx(float(np.sum((drive - np.mean(drive) - np.cos(w * t)) ** 2)), rel=0.02)
        est.append(both.omega_rad_s)
        errs.append(both.std_error_rad_s)
    assert float(np.std(est, ddof=1)) == pytest.approx(float(np.mean(errs)), rel=0.3)
    # A channel that repeats at another period (more than 4 combined errors away) is not
    # combined; nor is one that does not vary.
    other = np.sin(1.01 * w * t)
    assert with_second_channel(t, drive, other, alone) == alone
    assert with_second_channel(t, drive, np.zeros(n), alone) == alone


def test_the_reader_reads_the_fundamental_from_the_motion_too(tmp_path):
    # A DAQ's file at 2 kHz (not commensurate), the torque at 10% noise, the encoders at 0.1%:
    # omega is read from the torque and the twist together. Alone, the torque's standard error
    # here is about 5e-3 rad/s (its periodic fit, the test above's bound); with the twist, 20 times
    # smaller, and over 10 seeds every omega within 4 of those of the truth (the old reader, the
    # torque alone: 6.2e-3 off on seed 0).
    from jointrig.identify.periods import estimate_fundamental

    w, fs = 31.7, 2000.0
    t = np.arange(int(6.4 * 2 * math.pi / w * fs)) / fs
    for seed in range(10):
        rng = np.random.default_rng(seed)
        torque = 1500.0 * np.cos(w * t) + 106.0 * rng.standard_normal(t.size)
        phi1 = 0.3 * np.sin(w * t + 0.2) + 0.02 * np.cos(3 * w * t) + 2e-4 * rng.standard_normal(t.size)
        phi2 = 0.2 * np.sin(w * t - 0.4) + 1.5e-4 * rng.standard_normal(t.size)
        path = tmp_path / f"daq{seed}.csv"
        path.write_text("run,Time [s],Torque [N m],phi1 [rad],phi2 [rad]\n" + "".join(
            f"0,{a:.7f},{b:.6f},{c:.9f},{d:.9f}\n" for a, b, c, d in zip(t, torque, phi1, phi2)))
        got = read_runs(path).records[0].omega_rad_s
        alone = estimate_fundamental(t, torque)
        assert alone.std_error_rad_s > 4e-3
        assert abs(got - w) < 4 * alone.std_error_rad_s / 20, (seed, got - w, alone.std_error_rad_s)


def test_a_record_with_no_residual_degree_of_freedom_still_has_a_fundamental():
    from jointrig.identify.periods import estimate_fundamental

    # Four samples of a tone (0.75 of a period at 5.3 samples a period): harmonics 0..1 and omega
    # are 4 parameters, no degree of freedom is left for the noise. The estimate is still returned
    # (omega to round-off: 3e-15 measured, 1e-12 asked), its degrees of freedom counted as 1 (not
    # 0: no division by zero) and its noise variance the round-off floor (1e-9 of the RMS, squared).
    w = 7.0
    t = 2.0 + np.arange(4) * (2 * math.pi / w / 5.3)
    x = np.cos(w * t + 0.4)
    f = estimate_fundamental(t, x)
    assert (f.harmonics, f.dof) == (1, 1)
    assert f.omega_rad_s == pytest.approx(w, rel=1e-12)
    assert f.noise_var == pytest.approx((1e-9 * float(np.std(x))) ** 2, rel=1e-6)
    assert math.isfinite(f.std_error_rad_s) and f.std_error_rad_s < 1e-6 * w


def test_periodic_rss_is_the_residual_of_harmonics_only():
    from jointrig.identify.periods import periodic_rss

    # A ramp is not periodic: the residual about harmonics 0..3 is what least squares on those
    # columns alone leaves (a trend column would take it all).
    w = 2.0
    t = np.linspace(0.0, 10.0, 400)
    x = 0.5 * t + np.cos(w * t)
    B = np.column_stack([np.ones_like(t)] + [f(n * w * t) for n in (1, 2, 3) for f in (np.cos, np.sin)])
    r = x - B @ np.linalg.lstsq(B, x, rcond=None)[0]
    assert periodic_rss(t, x, w, 3) == pytest.approx(float(r @ r), rel=1e-10) and float(r @ r) > 1.0


def test_periodic_rss_of_a_third_of_a_period_is_the_least_squares_residual():
    from jointrig.identify.periods import periodic_rss

    # 20 samples at 60 a period, a third of a period, with harmonics 0..6: the columns are
    # nearly dependent over so short a span (normal matrix condition 1e14 after column scaling),
    # so the residual is the least squares one (computed here on explicit columns) only by SVD:
    # 1e-8 relative asked (4e-10 measured over 30 noise draws, the round-off of two bases of
    # condition 1e7; the normal equations miss by 1e-6, median).
    w, t0, H = 7.0, 0.3, 6
    t = t0 + np.arange(20) * (2 * math.pi / w / 60)
    B = np.column_stack([np.ones_like(t)] + [f(n * w * (t - t0)) for n in range(1, H + 1) for f in (np.cos, np.sin)])
    rng = np.random.default_rng(0)
    for _ in range(10):
        x = np.cos(w * t + 0.4) + 0.3 * np.sin(2 * w * t) + 0.01 * rng.standard_normal(t.size)
        r = x - B @ np.linalg.lstsq(B, x, rcond=None)[0]
        assert periodic_rss(t, x, w, H) == pytest.approx(float(r @ r), rel=1e-8)


def test_the_fundamental_of_two_or_three_samples_has_a_nan_standard_error_where_its_rss_is_flat():
    from jointrig.identify.periods import estimate_fundamental

    # Two or three samples: harmonics 0..1 fit every sample at any frequency, so the RSS is
    # round-off everywhere and its curvature, the standard error's denominator, is round-off of
    # either sign or exactly 0 (about 3 records in 100 here). Where it is not positive the
    # standard error is nan; it is never a division by zero. 300 seeded records, so that
    # several land on an exact 0 (the chance that none does is about 1e-4).
    rng = np.random.default_rng(0)
    w = 7.0
    for _ in range(300):
        n, per_period, phase = int(rng.integers(2, 4)), rng.uniform(2.2, 30.0), rng.uniform(0.0, 2 * math.pi)
        t = rng.uniform(0.0, 5.0) + np.arange(n) * (2 * math.pi / w / per_period)
        f = estimate_fundamental(t, np.cos(w * t + phase))
        assert math.isnan(f.std_error_rad_s) or f.std_error_rad_s > 0
        assert f.rss < 1e-20  # every sample fitted: round-off (1e-30 measured)



def _harmonic_columns(w: float, harmonics: int = 3):
    """The least-squares columns of a period's fit at ``w`` rad/s: a constant, then the cosine and
    sine of harmonics 1..``harmonics`` (as ``periods_by_least_squares`` fits each period)."""
    def columns(tt):
        return np.column_stack([np.ones_like(tt)] + [f(n * w * tt) for n in range(1, harmonics + 1)
                                                      for f in (np.cos, np.sin)])
    return columns

def test_periods_by_least_squares_fits_each_whole_period_on_its_own_samples_alone():
    from jointrig.identify.periods import periods_by_least_squares

    # 37 samples a period exactly, so a sample falls on every period boundary: it starts the
    # next period and does not end the last. With noise (0.05) each period's fit is the least
    # squares of its own 37 samples (computed here on explicit columns, then resynthesised on
    # 32 samples a period) and the residual's RMS is over the 3 x 37 samples, each counted once:
    # 1e-12 (round-off of well-conditioned 7-column fits; a boundary sample counted twice or
    # not at all moves the fit by ~1e-3).
    w, M, P = 5.0, 37, 3
    T = 2 * math.pi / w
    t = np.arange(P * M + 1) * (T / M)  # and the first sample of a fourth period
    rng = np.random.default_rng(2)
    x = np.cos(w * t) - 0.3 * np.sin(2 * w * t) + 0.05 * rng.standard_normal(t.size)
    fit = periods_by_least_squares(t, x, w, samples_per_period=32, harmonics=3)
    assert (fit.n_periods, fit.harmonics) == (P, 3)

    columns = _harmonic_columns(w)

    ss = 0.0
    for p in range(P):
        own = slice(p * M, (p + 1) * M)
        coef = np.linalg.lstsq(columns(t[own]), x[own], rcond=None)[0]
        ss += float(np.sum((x[own] - columns(t[own]) @ coef) ** 2))
        grid = p * T + np.arange(32) * (T / 32)
        np.testing.assert_allclose(fit.samples[0, p * 32:(p + 1) * 32], columns(grid) @ coef, atol=1e-12)
    assert fit.residual_rms[0] == pytest.approx(math.sqrt(ss / (P * M)), rel=1e-12)


def test_a_sample_a_ten_thousandth_of_a_step_before_a_periods_end_is_that_periods_last():
    from jointrig.identify.periods import periods_by_least_squares

    # A millisecond clock and a period 37.0001 steps long: samples 37, 74 and 111 fall 1e-4,
    # 2e-4 and 3e-4 of a step (1e-7 s and more) before a period's end, inside it. Each period's
    # fit is the least squares of its own samples (38, 37 and 37 of them, computed here on
    # explicit columns) and the residual's RMS is over all 112: 1e-12 relative (round-off of
    # 7-column fits; a boundary sample dropped moves it by ~1e-2).
    dt, M, P = 1e-3, 37.0001, 3
    T = M * dt
    w = 2 * math.pi / T
    t = np.arange(112) * dt
    rng = np.random.default_rng(5)
    x = np.cos(w * t) - 0.3 * np.sin(2 * w * t) + 0.05 * rng.standard_normal(t.size)
    fit = periods_by_least_squares(t, x, w, samples_per_period=32, harmonics=3)
    assert (fit.n_periods, fit.harmonics) == (P, 3)

    columns = _harmonic_columns(w)

    ss, bounds = 0.0, (0, 38, 75, 112)
    for p in range(P):
        own = slice(bounds[p], bounds[p + 1])
        assert np.all((t[own] >= p * T) & (t[own] < (p + 1) * T))
        coef = np.linalg.lstsq(columns(t[own]), x[own], rcond=None)[0]
        ss += float(np.sum((x[own] - columns(t[own]) @ coef) ** 2))
    assert fit.residual_rms[0] == pytest.approx(math.sqrt(ss / 112), rel=1e-12)


def test_periods_by_least_squares_lowers_its_harmonics_to_the_condition_asked():
    from jointrig.identify.periods import periods_by_least_squares

    w = 5.0
    dt = 2 * math.pi / w / 37.3
    t = np.arange(int(3.5 * 37.3)) * dt
    x = np.cos(w * t) + 0.2 * np.cos(3 * w * t)
    # An output grid of 8 (9) samples holds harmonics up to 3 (4): the default (0.4 of 37.3 is
    # 14) is cut there.
    assert periods_by_least_squares(t, x, w, samples_per_period=8).harmonics == 3
    assert periods_by_least_squares(t, x, w, samples_per_period=9).harmonics == 4
    # A record of exactly 3 whole periods (37 samples each) holds 3 periods, not 2.
    t37 = np.arange(3 * 37) * (2 * math.pi / w / 37)
    assert periods_by_least_squares(t37, np.cos(w * t37), w, samples_per_period=32).n_periods == 3
    # No basis is better conditioned than 1: H falls to 1, and the condition number reported is
    # that of the first period's columns at H = 1 (computed here by hand).
    fit = periods_by_least_squares(t, x, w, samples_per_period=32, harmonics=6, max_condition=1.0)
    assert fit.harmonics == 1
    sel = t < 2 * math.pi / w - 1e-9 * dt
    B = np.column_stack([np.ones(sel.sum()), np.cos(w * t[sel]), np.sin(w * t[sel])])
    assert fit.condition_number == pytest.approx(np.linalg.cond(B), rel=1e-9)
    # The third harmonic is then left in the residual: its RMS 0.2 / sqrt(2), within 5%.
    assert fit.residual_rms[0] == pytest.approx(0.2 / math.sqrt(2), rel=0.05)


def test_uniform_clock_names_the_first_stamp_that_does_not_increase():
    from jointrig.identify.periods import uniform_clock

    t = np.arange(10) * 0.1
    t[4] = t[3]  # sample 4 repeats sample 3; sample 8 steps back
    t[8] = t[6]
    with pytest.raises(ValueError, match=r"sample 4 at 0\.3"):
        uniform_clock(t)


def test_a_clock_stamped_in_unix_seconds_is_fitted_about_its_own_mean():
    # A 1024 Hz logger stamping Unix time (1.8e9 s): each stamp 1.8e9 + k / 1024 needs 41 bits, so
    # every stamp is exact in a double and the clock is exactly uniform. Fitted about the stamps'
    # mean, the step, origin and deviations are exact to round-off of the centred stamps
    # (rel 1e-12, deviation < 1e-9 of a step); offsetting by the mean the other way (t + mean, ~3.6e9)
    # rounds every stamp to 4.8e-7 s and gives a step 2.5e-6 off and a worst stamp 1.2e-3 of a
    # step "late" on 1000 samples, measured.
    from jointrig.identify.periods import uniform_clock

    dt, t0 = 1.0 / 1024, 1.8e9
    t = t0 + np.arange(1000) * dt
    c = uniform_clock(t)
    assert c.dt_s == pytest.approx(dt, rel=1e-12)
    assert c.t0_s == pytest.approx(t0, abs=1e-9 * dt)
    assert c.max_deviation < 1e-9


# --- edges the mutation run found unpinned (scripts/mutation_test.py, measured/runs.py) ---------------

def _one_run_csv(tmp_path, n_samples, *, name="r.csv", omega=None):
    dt = 2 * math.pi / W / 64  # 64 samples a period
    t = np.arange(n_samples) * dt
    text = csv_text(t, head="run,time,torque,phi1,phi2" + (",omega" if omega is not None else ""),
                    extra=(lambda i: repr(omega)) if omega is not None else None)
    (tmp_path / name).write_text(text)
    return tmp_path / name


def test_samples_per_period_is_at_least_16(tmp_path):
    path = _one_run_csv(tmp_path, 3 * 64)
    with pytest.raises(RunsFileError, match="samples_per_period must be an integer >= 16, got 15"):
        read_runs(path, samples_per_period=15)
    assert read_runs(path, samples_per_period=16).records[0].samples_per_period == 16


def test_an_omega_column_must_be_positive(tmp_path):
    with pytest.raises(RunsFileError, match="column 'omega' must be one positive value per run, got 0..0 rad/s"):
        read_runs(_one_run_csv(tmp_path, 3 * 64, omega=0.0))


def test_an_incomplete_last_period_is_named_in_a_note_and_a_clean_clock_in_none(tmp_path):
    # 2 periods of 64 samples and 10 samples more, omega stated: 138 samples hold 2.156 periods.
    loaded = read_runs(_one_run_csv(tmp_path, 2 * 64 + 10, omega=W))
    assert loaded.records[0].n_periods == 2
    assert any("138 samples hold 2.156 periods; the first 10 samples (an incomplete period, where a record from rest settles) are not used" in n
               for n in note_words(loaded.notes)), loaded.notes
    # The clock was written to 1e-9 s: far inside a uniform clock, so no jitter note.
    assert not any("deviate" in n for n in note_words(loaded.notes)), loaded.notes


def test_an_empty_column_mapping_is_refused(tmp_path):
    with pytest.raises(RunsFileError, match="'torque' needs a non-empty value"):
        read_runs(_one_run_csv(tmp_path, 3 * 64), columns={"torque": ""})


def test_a_folder_skips_files_that_are_not_runs(tmp_path):
    _one_run_csv(tmp_path, 3 * 64, name="a_run.csv")
    (tmp_path / "notes.md").write_text("# test log\nthe bench was warm\n")
    (tmp_path / "b_run.csv.bak").write_text("not a run")
    loaded = read_runs(tmp_path)
    assert len(loaded.records) == 1 and loaded.run_ids == ("0",)  # the file's own run column names it


def test_duplicate_column_names_are_refused(tmp_path):
    # (pyarrow's read_table refused this file with an internal "Multiple matches for FieldRef"
    # message before the reader's own check could name the column: now read with ParquetFile.)
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(3 * 64) * (2 * math.pi / W / 64)
    table = pa.Table.from_arrays([pa.array(t), pa.array(torque(t)), pa.array(phi1(t)), pa.array(phi1(t)),
                                  pa.array(phi2(t))], names=["time", "torque", "phi1", "phi1", "phi2"])
    pq.write_table(table, tmp_path / "dup.parquet")
    with pytest.raises(RunsFileError, match=r"column name\(s\) \['phi1'\] appear more than once"):
        read_runs(tmp_path / "dup.parquet")


def test_the_writer_states_omega_and_the_comment(tmp_path):
    loaded = read_runs(_one_run_csv(tmp_path, 3 * 64, omega=W))
    out = write_runs(tmp_path / "out.csv", loaded.records, comment="bench 3, warm")
    text = out.read_text().splitlines()
    assert text[0] == "# jointrig measured runs" and text[1] == "# bench 3, warm"
    assert "omega" in text[2]  # the header: omega is written unless asked not to
    plain = write_runs(tmp_path / "plain.csv", loaded.records, with_omega=False).read_text().splitlines()
    assert plain[1].startswith("run") and "omega" not in plain[1]


def test_a_tiny_drift_that_is_significant_is_not_refused(tmp_path):
    # A drift is refused only when it is both significant and large against the swing: a
    # noise-free relative angle creeping by 2e-6 rad over the record (t statistic in the
    # thousands, but 5e-6 of the 0.4 rad swing) is a steady-state record, read unchanged.
    dt = 2 * math.pi / W / 256
    t = np.arange(4 * 256) * dt
    creep = 2e-6 / t[-1]
    lines = ["time,torque,phi1,phi2"] + [f"{float(ti)!r},{float(torque(ti))!r},{float(phi1(ti) + creep * ti)!r},"
                                         f"{float(phi2(ti))!r}" for ti in t]
    (tmp_path / "creep.csv").write_text("\n".join(lines) + "\n")
    rec = read_runs(tmp_path / "creep.csv").records[0]
    np.testing.assert_allclose(rec.angles_rad[0], phi1(rec.time_s) + creep * rec.time_s, atol=1e-12)


def _mat_v73(path, datasets: dict):
    """A MATLAB v7.3 file as MATLAB writes it: HDF5 behind a 512-byte text header (scipy's
    loadmat refuses it with NotImplementedError, so the loader must read it as HDF5)."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        for k, v in datasets.items():
            f.create_dataset(k, data=np.asarray(v)[:, None])  # MATLAB stores vectors as (n, 1)
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 12:00:00 2026 HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(head.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM")


def test_matlab_struct_arrays_v73_and_hdf5_layouts(tmp_path):
    import h5py
    import scipy.io

    dt = 2 * math.pi / W / 128
    t = np.arange(3 * 128) * dt
    sig = _signals(t)
    # A struct array, one element per run, labelled by a text field; a scalar note field is not a
    # column, omega is kept; 2-D (1, n) row vectors as MATLAB saves them.
    runs = np.empty((1, 2), dtype=object)
    for i, label in enumerate(("slow", "fast")):
        runs[0, i] = {**{k: v[None, :] for k, v in sig.items()}, "run": label, "omega": W, "gain": 3.0}
    scipy.io.savemat(tmp_path / "s.mat", {"runs": runs})
    loaded = read_runs(tmp_path / "s.mat")
    assert loaded.run_ids == ("slow", "fast")
    assert not any("gain" in n for n in note_words(loaded.notes))  # not a column, so no column "ignored"
    for rec in loaded.records:
        assert rec.omega_rad_s == W
        check_columns(rec, 1e-12)
    # One struct, no run label: named by the variable and its index; a matrix and a text scalar
    # beside it are ignored.
    scipy.io.savemat(tmp_path / "one.mat", {"test": {**sig}, "calibration": np.eye(3), "operator": "A. N. Other"})
    assert read_runs(tmp_path / "one.mat").run_ids == ("test(1)",)
    # Plain vectors stored as (n, 1) columns beside a matrix that is not a channel
    scipy.io.savemat(tmp_path / "cols.mat", {**{k: v[:, None] for k, v in sig.items()}, "calibration": np.eye(3)})
    check_columns(read_runs(tmp_path / "cols.mat").records[0], 1e-12)
    # v7.3: HDF5 behind MATLAB's header, vectors as (n, 1) datasets
    _mat_v73(tmp_path / "big.mat", sig)
    rec = read_runs(tmp_path / "big.mat").records[0]
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-8)
    check_columns(rec, 1e-12)
    # HDF5 with units in the dataset names and in a bytes attribute "unit"; a text dataset and a
    # compound one beside the channels are not columns
    with h5py.File(tmp_path / "u.h5", "w") as f:
        f.create_dataset("time [ms]", data=t * 1e3)
        f.create_dataset("torque [kN m]", data=sig["torque"] / 1e3)
        f.create_dataset("phi1", data=np.degrees(sig["phi1"]))
        f["phi1"].attrs["unit"] = b"deg"
        f.create_dataset("phi2 [mrad]", data=sig["phi2"] * 1e3)
        f.create_dataset("operator", data=np.array([b"A. N. Other"]))
        f.create_dataset("flags", data=np.zeros(3, dtype=[("a", "i4"), ("b", "f8")]))
    rec = read_runs(tmp_path / "u.h5").records[0]
    check_columns(rec, 1e-12)


def test_parquet_duration_time_and_units_in_the_schema_metadata(tmp_path):
    # Time as a duration since the start (timedelta, as pandas writes elapsed time), units stated
    # in the schema's metadata (as the project's writer and some loggers do), not in the names.
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    dt_ns = 250_000
    n = 3 * 419
    t = np.arange(n) * dt_ns * 1e-9
    elapsed = (np.arange(n) * dt_ns).astype("timedelta64[ns]")
    table = pa.table({"time": elapsed, "torque": torque(t) / 1e3, "phi1": np.degrees(phi1(t)), "phi2": phi2(t)})
    meta = {b"units": repr({"torque": "kN m", "phi1": "deg", "not a column": "V", 3: "rad"}).encode()}
    pq.write_table(table.replace_schema_metadata(meta), tmp_path / "d.parquet")
    rec = read_runs(tmp_path / "d.parquet").records[0]
    # whole-ns stamps at a fixed rate: omega to round-off (a clock read 1e-9 off would show)
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-11)
    check_columns(rec, 1e-11)


def test_matlab_cell_arrays_scalars_and_element_names(tmp_path):
    import scipy.io

    dt = 2 * math.pi / W / 128
    t = np.arange(3 * 128) * dt
    sig = _signals(t)
    # Vectors with a cell array of channel names, an empty cell array and omega as a scalar
    # variable beside them: the cells are no runs, omega holds for the record.
    scipy.io.savemat(tmp_path / "v.mat", {**sig, "omega": W, "names": np.array(["torque", "phi1"], dtype=object),
                                         "empty": np.empty((0,), dtype=object)})
    loaded = read_runs(tmp_path / "v.mat")
    assert loaded.run_ids == ("0",) and loaded.records[0].omega_rad_s == W
    check_columns(loaded.records[0], 1e-12)
    # A struct array whose second element lacks the torque: the error names that element.
    runs = np.empty((1, 2), dtype=object)
    runs[0, 0] = dict(sig)
    runs[0, 1] = {k: v for k, v in sig.items() if k != "torque"}
    runs[0, 1]["force"] = sig["torque"]
    scipy.io.savemat(tmp_path / "bad.mat", {"runs": runs})
    with pytest.raises(RunsFileError, match=r"bad\.mat runs\(2\): missing column\(s\) torque;"):
        read_runs(tmp_path / "bad.mat")


# pyuff's writer leaves its file handles to the garbage collector (type 151 and binary 58 sets)
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_tdms_and_uff_edges(tmp_path):
    import pyuff
    from nptdms import ChannelObject, TdmsWriter

    dt = 2 * math.pi / W / 128
    t = np.arange(3 * 128) * dt
    sig = _signals(t)
    # TDMS: absolute time stamps as a channel (a 1.25 kHz clock, whole microseconds: npTDMS
    # writes stamps to the microsecond; the loader reads the file's 2^-64 s fractions raw);
    # units in the channel names when there is no unit_string property
    ts = np.arange(400) * 800e-6
    s2 = _signals(ts)
    # (the record crosses a whole second of the clock; an empty channel beside them is skipped)
    stamps = np.datetime64("2026-11-23T10:00:59.9", "us") + (np.arange(400) * 800).astype("timedelta64[us]")
    with TdmsWriter(tmp_path / "s.tdms") as w:
        w.write_segment([ChannelObject("bench", "time", stamps), ChannelObject("bench", "spare", np.zeros(0)),
                         ChannelObject("bench", "torque [kN m]", s2["torque"] / 1e3),
                         ChannelObject("bench", "phi1 [deg]", np.degrees(s2["phi1"])),
                         ChannelObject("bench", "phi2", s2["phi2"], properties={"unit_string": "rad"})])
    rec = read_runs(tmp_path / "s.tdms").records[0]
    # omega and the columns to round-off (measured 0 and 2e-14 of the swing; stamps read as
    # npTDMS's datetime64 would be whole us too here, but would drop a finer clock's digits)
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-11)
    check_columns(rec, 1e-11)
    # TDMS: no time channel and no waveform timing: the missing time is named
    with TdmsWriter(tmp_path / "nt.tdms") as w:
        w.write_segment([ChannelObject("run1", k, v) for k, v in sig.items() if k != "time"])
    with pytest.raises(RunsFileError, match=r"missing column\(s\) time;"):
        read_runs(tmp_path / "nt.tdms")
    # TDMS: waveform timing with a zero step is refused by name
    with TdmsWriter(tmp_path / "z.tdms") as w:
        w.write_segment([ChannelObject("run1", k, v, properties={"wf_increment": 0.0, "wf_start_offset": 0.0})
                         for k, v in sig.items() if k != "time"])
    with pytest.raises(RunsFileError, match="wf_increment = 0.0; expected a positive sample step"):
        read_runs(tmp_path / "z.tdms")
    # TDMS: waveform timing without a start offset starts at 0 s (NI's default for
    # wf_start_offset): the time column is the increment's multiples, to round-off
    with TdmsWriter(tmp_path / "w.tdms") as w:
        w.write_segment([ChannelObject("run1", k, v, properties={"wf_increment": dt}) for k, v in sig.items()
                         if k != "time"])
    rec = read_runs(tmp_path / "w.tdms").records[0]
    np.testing.assert_allclose(rec.time_s, t, rtol=0, atol=1e-12)
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-8)
    # UFF: a type-151 header set is skipped; no load case id: run "0"; units from the names
    # when the unit label is empty
    uff = pyuff.UFF(str(tmp_path / "e.uff"))
    uff.write_sets(pyuff.prepare_151(model_name="bench", description="jointrig test", db_app="none",
                                     date_db_created="23-Nov-26", time_db_created="12:00:00", version_db1=0,
                                     version_db2=0, file_type=0, date_db_saved="23-Nov-26",
                                     time_db_saved="12:00:00", program="test", date_db_written="23-Nov-26",
                                     time_db_written="12:00:00"), mode="add")
    for k, name in (("torque", "torque [kN m]"), ("phi1", "phi1 [deg]"), ("phi2", "phi2")):
        scale = {"torque": 1e-3, "phi1": 180 / math.pi, "phi2": 1.0}[k]
        uff.write_sets(pyuff.prepare_58(binary=1, id1=name, func_type=1, rsp_node=1, rsp_dir=1, ref_node=1,
                                        ref_dir=1, data=sig[k] * scale, x=t, abscissa_spacing=1, abscissa_min=0.0,
                                        abscissa_inc=dt, ordinate_axis_units_lab="", abscissa_axis_units_lab="s",
                                        abscissa_spec_data_type=17, ordinate_spec_data_type=0,
                                        orddenom_spec_data_type=0, z_axis_spec_data_type=0, ord_data_type=4),
                       mode="add")
    import gc

    gc.collect()  # pyuff's open handles are closed here, inside this test's warning filter
    loaded = read_runs(tmp_path / "e.uff")
    assert loaded.run_ids == ("0",)
    check_columns(loaded.records[0], 1e-5)  # the increment written with 6 digits (E13.5): measured 2.2e-6


def test_whitespace_separated_columns(tmp_path):
    # A text export with columns separated by spaces (MATLAB's save -ascii, many loggers' .txt)
    dt = 2 * math.pi / W / 64
    t = np.arange(3 * 64) * dt
    path = tmp_path / "bench.txt"
    path.write_text("time  torque   phi1   phi2\n" + "".join(
        f"{float(ti)!r}   {float(torque(ti))!r}  {float(phi1(ti))!r}\t{float(phi2(ti))!r}\n" for ti in t))
    rec = read_runs(path).records[0]
    assert rec.omega_rad_s == pytest.approx(W, rel=1e-12)
    check_columns(rec, 1e-12)


def test_a_common_rotation_is_removed_when_only_the_quieter_angle_shows_it(tmp_path):
    # Flywheel 1 barely moves (0.03 rad swing), flywheel 2 swings 1 rad, and both rotate at
    # 5e-4 rad/s: over the record (2e-4 rad) that is beyond the drift share (1e-3 of the swing) of
    # flywheel 1 but not of flywheel 2. It is still a rotation of both (the relative angle is
    # steady): removed, not refused.
    dt = 2 * math.pi / W / 256
    t = np.arange(4 * 256) * dt
    p1 = 0.01 * np.cos(W * t - 0.5) + 0.005 * np.cos(3 * W * t)
    p2 = 0.5 * np.cos(W * t - 1.5)
    lines = ["time,torque,phi1,phi2"] + [f"{float(a)!r},{float(torque(a))!r},{float(b + 5e-4 * a)!r},{float(c + 5e-4 * a)!r}"
                                         for a, b, c in zip(t, p1, p2)]
    (tmp_path / "spin.csv").write_text("\n".join(lines) + "\n")
    loaded = read_runs(tmp_path / "spin.csv")
    assert any("rotate steadily at 0.0005 rad/s" in n for n in note_words(loaded.notes)), loaded.notes
    rec = loaded.records[0]
    np.testing.assert_allclose(rec.angles_rad[0], 0.01 * np.cos(W * rec.time_s - 0.5) + 0.005 * np.cos(3 * W * rec.time_s),
                               atol=1e-12)


def test_the_one_noise_estimator_agrees_with_the_sample_variance_and_the_noise_level():
    # identify.periods.period_spectra is every identifier's noise estimator. Parseval: its
    # per-harmonic variances of the mean period sum (white_variance) to the mean over the samples
    # of each sample's variance over the periods divided by P, to round-off (1e-14), for even and
    # odd N. On white noise of sigma 0.3 the robust per-sample level (raw_noise_std, a median over
    # N/2 - 1 = 255 harmonics, each a chi-square(2 (P - 1)) variable, debiased to a mean) is within
    # 3 of its standard errors at 8 periods and at 2 (the median of a variance's n draws has a
    # relative SE of about 1.25 sqrt(2 / (d n)), half that on the std: 2.5% at P = 8, 5.5% at P = 2;
    # not debiased, the median read 17% low at P = 2).
    from jointrig.identify.periods import period_spectra, raw_noise_std, white_variance

    rng = np.random.default_rng(3)
    for N, P in ((512, 8), (511, 8), (512, 2)):
        sigma = 0.3
        x = sigma * rng.standard_normal((P, N)) + np.cos(2 * np.pi * 3 * np.arange(N) / N)
        X, mean, var = period_spectra(x.reshape(-1), P)
        assert X.shape == (P, N // 2 + 1)
        np.testing.assert_allclose(mean, np.fft.rfft(x.mean(axis=0)) / N, rtol=0, atol=1e-15)
        assert white_variance(var, N) == pytest.approx(x.var(axis=0, ddof=1).mean() / P, rel=1e-14)
        se = 0.5 * 1.25 * math.sqrt(2 / (2 * (P - 1) * (N // 2 - 1)))
        assert raw_noise_std(var, P, N) == pytest.approx(sigma, rel=3 * se), (N, P)
    with pytest.raises(ValueError, match="at least 2"):
        period_spectra(np.zeros(64), 1)


def test_another_channels_fit_at_the_drives_frequency_has_its_own_noise_variance():
    # The angle's reference for the repeat check (fit_at): its residual variance per sample at
    # the torque's frequency is the angle's own noise, sigma^2 within 10% (2000 - 7 degrees of
    # freedom: the estimate's relative sd is sqrt(2 / 1993) = 3%; 3 sd), not the torque's.
    from jointrig.identify.periods import estimate_fundamental, fit_at, repeat_statistic

    n, dt, w, s = 2000, 1e-3, 40.0, 1e-4
    t = np.arange(n) * dt
    rng = np.random.default_rng(1)
    best = estimate_fundamental(t, 50 * np.cos(w * t) + rng.normal(0, 0.5, n), harmonics=3)
    phi = 0.01 * np.cos(w * t - 0.7) + rng.normal(0, s, n)
    ref = fit_at(t, phi, best)
    assert ref.noise_var == pytest.approx(s**2, rel=0.1) and ref.omega_rad_s == best.omega_rad_s
    # at the best frequency itself the angle repeats: its statistic is nil
    assert repeat_statistic(t, phi, best.omega_rad_s, ref) == pytest.approx(0.0, abs=1e-9)


def test_a_matlab_files_settings_beside_the_channels_are_no_columns(tmp_path):
    # A DAQ's .mat holds its settings beside the channels (a sampling rate, a gain): among the
    # scalars only omega is read, and it is the record's (127.3 samples per period: not a whole
    # number, so a frequency estimated from the torque would differ from it in the last digits).
    import scipy.io

    dt = 2 * math.pi / W / 127.3
    t = np.arange(int(4.5 * 127.3)) * dt
    sig = _signals(t)
    sig["torque"] = sig["torque"] + np.random.default_rng(0).normal(0.0, 0.01 * np.std(sig["torque"]), t.size)
    scipy.io.savemat(tmp_path / "d.mat", {**sig, "omega": W, "fs_Hz": 1.0 / dt, "gain": 2.0})
    loaded = read_runs(tmp_path / "d.mat")
    assert loaded.run_ids == ("0",) and loaded.records[0].omega_rad_s == W
    # the settings are no columns, so no column of theirs is "ignored" (as a struct's scalar field)
    words = note_words(loaded.notes)
    assert not any("gain" in n or "fs_Hz" in n for n in words), words


def test_pooled_noise_is_a_moving_average_over_the_harmonics_and_leaves_the_mean():
    # A steadier noise estimate than one harmonic's: each harmonic's variance averaged with its
    # neighbours within the half width (fewer at the ends), the mean's (harmonic 0) left alone.
    from jointrig.identify.periods import pooled

    out = pooled(np.array([100.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), half_width=1)
    np.testing.assert_allclose(out, [100.0, 1.5, 2.0, 3.0, 4.0, 5.0, 5.5], rtol=1e-15)
    assert pooled(np.array([7.0, 3.0])).tolist() == [7.0, 3.0]
    assert pooled(np.array([7.0])).tolist() == [7.0]
    # fewer harmonics than the window is wide: each takes them all (a convolution's "same" output
    # took the window's length there, and the assignment failed)
    np.testing.assert_allclose(pooled(np.array([9.0, 1.0, 2.0, 6.0])), [9.0, 3.0, 3.0, 3.0], rtol=1e-15)


def test_a_fixed_sample_rate_record_names_its_unused_tail_and_keeps_every_harmonic(tmp_path):
    # 100.5 samples per period (1 kHz, not commensurate with the drive), 432 samples: 4 whole
    # periods use 402 of them and the last 30 are named. The periods are synthesised on 2 (H + 1)
    # samples, enough to hold harmonics 0..H.
    dt = 1e-3
    w = 2 * math.pi / (100.5 * dt)
    rng = np.random.default_rng(0)

    def write(n, name):
        t = np.arange(n) * dt  # (1 kHz)
        rows = ["run,time,torque,phi1,phi2"] + [
            f"0,{float(ti)!r},{1000 * math.cos(w * ti) + 0.5 * rng.normal()!r},"
            f"{0.01 * math.cos(w * ti - 0.3) + 1e-6 * rng.normal()!r},{0.005 * math.cos(w * ti - 0.5) + 1e-6 * rng.normal()!r}"
            for ti in t]
        (tmp_path / name).write_text("\n".join(rows) + "\n")
        return read_runs(tmp_path / name)

    loaded = write(432, "tail.csv")
    note = next(n for n in note_words(loaded.notes) if "is not a whole number" in n)
    H = int(note.split("harmonics 0..")[1].split()[0])
    assert loaded.records[0].n_periods == 4 and f"synthesised at {2 * (H + 1)} samples per period" in note
    assert note.endswith("; the first 30 samples (an incomplete period, where a record from rest settles) are not used"), note


def test_a_coarse_fixed_rate_record_is_synthesised_at_sixteen_samples_a_period_at_least(tmp_path):
    # 13.3 samples per period at a bench's fixed rate: 5 harmonics are estimated per period, which
    # 12 samples would hold; the record is synthesised at 16 (the least that the balance's rows
    # and the rate's spectrum are built on), every column still the signal at its own times
    dt = 2 * math.pi / W / 13.3
    t = np.arange(int(12 * 13.3)) * dt
    (tmp_path / "coarse.csv").write_text(csv_text(t))
    rec = read_runs(tmp_path / "coarse.csv").records[0]
    assert rec.samples_per_period == 16 and rec.n_periods == 11  # 159 samples: 11.96 periods
    check_columns(rec, 1e-8)  # the fundamental estimated to 5e-11 of itself moves the samples by 2e-9 of the swing


def test_a_slow_axis_states_an_omega_below_one_rad_per_second(tmp_path):
    # a positioning axis's reference of a 12.6 s period: an 'omega' column of 0.5 rad/s is one
    # positive value per run, as any other
    w = 0.5
    t = np.arange(3 * 64) * (2 * math.pi / w / 64)
    rows = ["run,time,torque,phi1,phi2,omega"] + [
        f"0,{float(ti)!r},{1000.0 * math.cos(w * ti)!r},{0.3 * math.cos(w * ti - 0.5)!r},{0.1 * math.cos(w * ti - 1.5)!r},"
        f"{w!r}" for ti in t]
    (tmp_path / "slow.csv").write_text("\n".join(rows) + "\n")
    rec = read_runs(tmp_path / "slow.csv").records[0]
    assert rec.omega_rad_s == pytest.approx(w, rel=1e-12) and rec.n_periods == 3


def test_a_fundamental_is_taken_after_the_first_period_only_beyond_its_bound():
    # measured.runs._steady_fundamental replaces the whole record's fundamental by the one after
    # its first period where the two differ by more than 5 combined standard errors (the bound its
    # docs state, STEADY_FUNDAMENTAL_SE): at 0.9 of it the whole record's stands, at 1.1 the later
    # one (with its note)
    from dataclasses import replace

    from jointrig.identify.periods import estimate_fundamental
    from jointrig.measured.runs import CHECK_HARMONICS, _steady_fundamental

    stated = 5.0  # the docs' bound; reading the module's constant would hide a change of it

    rng = np.random.default_rng(3)
    t = np.arange(6 * 128) * (2 * math.pi / W / 128)
    drive = torque(t) + rng.normal(0.0, 1.0, t.size)
    later = estimate_fundamental(t[128:], drive[128:], harmonics=CHECK_HARMONICS)
    se = later.std_error_rad_s
    for share, replaced in ((0.9, False), (1.1, True)):
        # the whole record's estimate, with the later one's standard error: their combined one is se sqrt(2)
        whole = replace(later, omega_rad_s=later.omega_rad_s + share * stated * se * math.sqrt(2))
        notes = []
        got = _steady_fundamental(t, drive, whole, "0", notes)
        assert (got is not whole) == replaced and len(notes) == replaced, (share, got, notes)
        if replaced:
            assert got.omega_rad_s == later.omega_rad_s


def test_a_fundamental_is_checked_after_the_first_period_from_exactly_three_periods_on():
    # measured.runs._steady_fundamental checks "with 3 periods or more at the first estimate": a
    # record of exactly 3 periods of 128 samples at the whole record's estimate (omega = W: 128.0
    # samples a period to the last bit at this spacing) is checked, and the later estimate (the
    # drive is at W + 0.02 rad/s, 9.1 combined standard errors off) is taken, with its note; 2.9
    # periods (371 samples) are not checked, the whole record's estimate stands however far off
    # (the later one would rest on less than 2 periods).
    from dataclasses import replace

    from jointrig.identify.periods import estimate_fundamental
    from jointrig.measured.runs import CHECK_HARMONICS, _steady_fundamental

    rng = np.random.default_rng(3)
    t = np.arange(3 * 128) * (2 * math.pi / W / 128)
    assert 2 * math.pi / (W * (t[1] - t[0])) == 128.0
    drive = 1000.0 * np.cos((W + 0.02) * t) + rng.normal(0.0, 1.0, t.size)
    later = estimate_fundamental(t[128:], drive[128:], harmonics=CHECK_HARMONICS)
    whole = replace(later, omega_rad_s=W)
    assert abs(later.omega_rad_s - W) > 5.0 * math.hypot(later.std_error_rad_s, whole.std_error_rad_s)
    notes = []
    got = _steady_fundamental(t, drive, whole, "0", notes)
    assert got.omega_rad_s == later.omega_rad_s and len(notes) == 1
    notes = []
    assert _steady_fundamental(t[:371], drive[:371], whole, "0", notes) is whole and notes == []

def test_a_steady_record_has_no_transient_cut(tmp_path):
    # a record that is steady from its first sample keeps every period, and says nothing of a transient
    from jointrig.measured.notes import TransientCut

    t = np.arange(4 * 256) * (2 * math.pi / W / 256)
    (tmp_path / "steady.csv").write_text(csv_text(t))
    loaded = read_runs(tmp_path / "steady.csv")
    assert loaded.records[0].n_periods == 4 and not any(isinstance(n, TransientCut) for n in loaded.notes)


def test_a_fixed_rate_record_is_synthesised_at_twice_its_harmonics_plus_one_per_period():
    # The README's example: 251.3 samples per period at 25 rad/s, 157.08 at 40, 114.24 at 55 (1 kHz): harmonics
    # 0..H estimated by least squares and synthesised at 2 (H + 1) samples per period, the fewest
    # that hold harmonic H with its sine and cosine (identify.harmonics.max_harmonic).
    from pathlib import Path

    from jointrig.identify.harmonics import max_harmonic
    from jointrig.measured.notes import LeastSquaresPeriods

    loaded = read_runs(Path(__file__).resolve().parent.parent / "examples" / "bench_dry_friction.csv")
    ls = {n.run: n for n in loaded.notes if isinstance(n, LeastSquaresPeriods)}
    assert set(ls) == set(loaded.run_ids)
    for run, rec in zip(loaded.run_ids, loaded.records):
        H = ls[run].harmonics
        assert rec.samples_per_period == ls[run].samples == 2 * (H + 1) and max_harmonic(rec.samples_per_period) >= H
    assert {ls[r].samples for r in ls} == {202, 126, 92}  # H 100 at 25 rad/s, 62 at 40, 45 at 55


def test_columns_given_from_python_as_a_list_of_pairs_read_as_the_command_lines(tmp_path):
    # jointrig.diagnose(..., columns=["torque=M", "phi1=enc1"]) is the same as the command line's
    # --columns "torque=M,phi1=enc1": the same records, sample for sample
    from jointrig.measured.runs import parse_mapping

    assert parse_mapping(["time=t", "torque = M"], "columns") == {"time": "t", "torque": "M"}
    assert parse_mapping(("time=t",), "columns") == parse_mapping("time=t", "columns")


def test_every_body_up_to_the_most_has_its_columns_and_si_units():
    # A line of up to MAX_BODIES bodies: each one's angle or position and drive column is known by
    # name with its SI unit (a train of 8 on slides names force8 [N]); one past it is not
    from jointrig.measured.runs import COLUMNS, MAX_BODIES

    for i in range(1, MAX_BODIES + 1):
        assert (COLUMNS[f"phi{i}"], COLUMNS[f"torque{i}"], COLUMNS[f"x{i}"], COLUMNS[f"force{i}"]) == \
            ("rad", "N m", "m", "N"), i
    assert not {f"{c}{i}" for c in ("phi", "torque", "x", "force") for i in (0, MAX_BODIES + 1)} & set(COLUMNS)


def test_a_column_mapped_in_another_case_than_the_header_is_found(tmp_path):
    # --columns torque=TORQUE on a file whose header says "torque": found as the header's
    # case-insensitive match (as header names are), the same record as without the mapping
    path = _one_run_csv(tmp_path, 3 * 64)
    plain, mapped = read_runs(path), read_runs(path, columns={"torque": "TORQUE", "phi2": "Phi2"})
    np.testing.assert_array_equal(mapped.records[0].torques_Nm[0], plain.records[0].torques_Nm[0])
    np.testing.assert_array_equal(mapped.records[0].angles_rad[1], plain.records[0].angles_rad[1])
    with pytest.raises(RunsFileError, match=r"column 'Torque2' \(mapped to 'torque'\) is not in the file"):
        read_runs(path, columns={"torque": "Torque2"})


def test_a_file_without_units_says_first_that_si_is_assumed(tmp_path):
    # no unit in the header, no sidecar, no --units: the first note says SI is assumed and how to
    # state others; a header with units, or --units, says nothing of it
    from jointrig.measured.notes import NoUnits

    # two runs, each with an incomplete last period (a note each, made before the units' one)
    t = np.arange(3 * 64 + 10) * (2 * math.pi / W / 64)
    path = tmp_path / "r.csv"
    path.write_text(csv_text(t) + csv_text(t, run="1").split("\n", 1)[1])
    loaded = read_runs(path)
    assert loaded.notes[0] == NoUnits() and len(loaded.notes) > 2, loaded.notes
    assert "SI assumed (time s, torque N m, angles rad" in note_words(loaded.notes)[0]
    assert NoUnits() not in read_runs(path, units={"torque": "N m"}).notes
    (tmp_path / "u.csv").write_text(path.read_text().replace("torque,phi1", "torque [N m],phi1 [rad]", 1))
    assert NoUnits() not in read_runs(tmp_path / "u.csv").notes
