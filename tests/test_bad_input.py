"""Every bad input answered: a clear message naming the file, run, column or option, exit code 2
for bad input, before any long work, and nothing left behind.

The battery runs each case through the loader, the Python API, the MJCF reader or a command's
``main`` in this process (from ``jointrig.commands``) and checks the error
type and message, the exit code, that no traceback reached the user and that the output
folder holds no temporary file afterwards.
"""

from __future__ import annotations

import importlib
import math
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from jointrig.vocab.plant import Plant
from jointrig.vocab.law import JointLaw, Viscous
from jointrig.vocab.records import RecordError, SteadyStateRecord
from jointrig.measured.runs import RunsFileError, read_runs
from jointrig.rig import RigModelError, load_rig
from conftest import note_words

ROOT = Path(__file__).resolve().parent.parent
W = 60.0


def _script(name):
    return importlib.import_module(f"jointrig.commands.{name}")


def _good_rows(n_periods=3, N=64, *, run="0", t0=0.0, omega=W, phi1_extra=None, torque_extra=None, rigid=False):
    """Rows of a two-flywheel run; ``rigid``: both flywheels move alike (no twist)."""
    dt = 2 * math.pi / omega / N
    rows = []
    for k in range(n_periods * N):
        t = t0 + k * dt
        p1 = 0.3 * math.cos(omega * t - 0.5) + (phi1_extra(t) if phi1_extra else 0.0)
        p2 = p1 if rigid else 0.1 * math.cos(omega * t - 1.5)
        torque = 1000 * math.cos(omega * t) + (torque_extra(t) if torque_extra else 0.0)
        rows.append(f"{run},{t!r},{torque!r},{p1!r},{p2!r}")
    return rows


def _edit(rows, i, col, value):
    rows = list(rows)
    parts = rows[i].split(",")
    parts[col] = value
    rows[i] = ",".join(parts)
    return rows


def good_csv(**kw):
    return "run,time,torque,phi1,phi2\n" + "\n".join(_good_rows(**kw)) + "\n"


def relative(text: str) -> str:
    """A two-encoder file as a one-twist-sensor file (columns run, time, torque, phi = phi1 - phi2)."""
    head, *rows = text.strip().splitlines()
    assert head == "run,time,torque,phi1,phi2"
    out = ["run,time,torque,phi"]
    for row in rows:
        run, t, torque, p1, p2 = row.split(",")
        out.append(f"{run},{t},{torque},{float(p1) - float(p2)!r}")
    return "\n".join(out) + "\n"


def three_runs():
    return "run,time,torque,phi1,phi2\n" + "\n".join(
        sum((_good_rows(run=str(r), omega=W * (1 + 0.2 * r)) for r in range(3)), [])) + "\n"


# ------------------------------------------------------------------------------ loader cases

LOADER = {
    "empty file": ("", "no header row"),
    "header only": ("run,time,torque,phi1,phi2\n", "no data rows"),
    "short row": ("run,time,torque,phi1,phi2\n0,0,1,2\n", "data row 1 has 4 fields"),
    "text in torque": ("run,time,torque,phi1,phi2\n" + "\n".join(_good_rows()).replace(",1000.0,", ",abc,", 1),
                       r"column 'torque' holds a non-number \('abc' in data row 1\)"),
    "nan in phi1": ("run,time,torque,phi1,phi2\n" + "\n".join(_edit(_good_rows(), 5, 3, "nan")) + "\n",
                    r"column 'phi1' holds 1 missing.*run 0, data row 6"),
    # a blank cell and a spreadsheet's "NA": not numbers numpy parses, read as missing by the loader's own parser
    "blank cell in phi1": ("run,time,torque,phi1,phi2\n" + "\n".join(_edit(_good_rows(), 5, 3, "")) + "\n",
                           r"column 'phi1' holds 1 missing.*run 0, data row 6"),
    "NA in phi2": ("run,time,torque,phi1,phi2\n" + "\n".join(_edit(_good_rows(), 2, 4, "NA")) + "\n",
                   r"column 'phi2' holds 1 missing.*run 0, data row 3"),
    "inf value": (good_csv().replace("1000.0", "inf", 1), r"column 'torque' holds 1 missing, non-finite.*run 0, data row 1"),
    "huge value": (good_csv().replace("1000.0", "1e300", 1), r"implausibly large.*1e\+300"),
    "duplicate column": ("run,time,torque,phi1,phi1\n0,0,1,2,3\n", "appears twice"),
    "columns differing in case": ("run,time,torque,phi1,PHI1,phi2\n0,0,1,2,3,4\n", "differ only in case"),
    "no torque": ("run,time,phi1,phi2\n0,0,1,2\n", r"missing column\(s\) torque; expected"),
    "no angles": ("run,time,torque\n0,0,1\n", r"missing column\(s\) phi1, phi2 \(or phi\)"),
    "phi and phi1": ("run,time,torque,phi,phi1\n0,0,1,2,3\n", "either 'phi' or"),
    "only phi1": ("run,time,torque,phi1\n0,0,1,2\n", r"missing column\(s\) phi2; expected"),
    "too short": ("run,time,torque,phi1,phi2\n" + "\n".join(_good_rows()[:10]) + "\n", "too short"),
    # one row does not vary either, but what the user must fix is the run's length
    "one row": ("run,time,torque,phi1,phi2\n" + _good_rows()[3] + "\n", r"run 0: 1 samples is too short; expected at least 16"),
    "one period and a half": ("run,time,torque,phi1,phi2\n" + "\n".join(_good_rows(n_periods=2, N=64)[:96]) + "\n",
                              "expected at least 2 whole periods"),
    "time not increasing": (good_csv().replace("\n0,0.0,", "\n0,5.0,", 1), "time must increase strictly"),
    "missing samples": ("run,time,torque,phi1,phi2\n" + "\n".join(r for i, r in enumerate(_good_rows()) if i != 70)
                        + "\n", r"not uniformly sampled: sample \d+"),
    "omega 20% off": ("run,time,torque,phi1,phi2,omega\n" + "\n".join(f"{r},72.0" for r in _good_rows()) + "\n",
                      "does not repeat at that period"),
    "omega varies in a run": ("run,time,torque,phi1,phi2,omega\n" + "\n".join(
        f"{r},{60 + (i > 100)}" for i, r in enumerate(_good_rows())) + "\n", "one positive value per run"),
    # a run cut to its first row (a logger stopped at once) with an omega column: refused as a run
    # (its angles cannot vary), not a crash on the omega column's check of its one value
    "one-row run with omega": ("run,time,torque,phi1,phi2,omega\n" + "\n".join(
        [f"{r},{W}" for r in _good_rows()] + [f"{_good_rows(run='1')[0]},{W}"]) + "\n", "run 1"),
    "omega negative": ("run,time,torque,phi1,phi2,omega\n" + "\n".join(f"{r},-60" for r in _good_rows()) + "\n",
                       "one positive value per run"),
    "slipping encoder": (good_csv(n_periods=4, phi1_extra=lambda t: 0.2 * t), "drifts"),
    # the twist's unit is the angle's, the torque's N m
    "drifting amplifier": (good_csv(n_periods=4, torque_extra=lambda t: 2000.0 * t),
                           r"run 0: column 'torque' drifts by [0-9.e+-]+ N m over the record \([0-9.e+-]+ N m/s"),
    # one twist sensor: its column is named as the file names it, and the torque's as its own
    "slipping twist sensor": (relative(good_csv(n_periods=4, phi1_extra=lambda t: 0.2 * t)),
                              r"run 0: column 'phi' drifts by [0-9.e+-]+ rad over the record"),
    "drifting amplifier, one twist sensor": (relative(good_csv(n_periods=4, torque_extra=lambda t: 2000.0 * t)),
                                             r"run 0: column 'torque' drifts by [0-9.e+-]+ N m over the record"),
    # both flywheels turn alike: the joint never twists, whatever each angle does
    "no twist": (good_csv(rigid=True), r"run 0: column 'phi1 - phi2' does not vary \(spread 0 rad\)"),
    "no drive": ("run,time,torque,phi1,phi2\n" + "\n".join(
        f"0,{k * 1e-3!r},5.0,{math.sin(k * 0.06)!r},0.0" for k in range(300)) + "\n", "does not vary"),
    "unknown unit": (good_csv().replace("phi1,", "phi1 [furlong],", 1), "unit 'furlong'.*expected one of rad"),
    "binary garbage": ("\x00\x01\x02garbage", "NUL bytes"),
    "run label used twice": ("run,time,torque,phi1,phi2\n" + "\n".join(_good_rows(run="a") + _good_rows(run="b")
                                                                      + _good_rows(run="a")[:50]) + "\n",
                             "time must increase strictly"),
}


@pytest.mark.parametrize("case", list(LOADER))
def test_loader_refuses_bad_csv_with_the_place_named(tmp_path, case):
    text, match = LOADER[case]
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(RunsFileError) as err:
        read_runs(path)
    assert str(path) in str(err.value)
    if match:
        assert err.match(match)
    assert list(tmp_path.iterdir()) == [path]


OPTION_CASES = {
    "units bad key": (dict(units="angle=deg"), "'angle' is not a column"),
    "units unknown": (dict(units="phi1=grad"), "unit 'grad'"),
    "units malformed": (dict(units="phi1deg"), "not NAME=VALUE"),
    "columns to a missing column": (dict(columns="torque=M_drive"), r"column 'M_drive' \(mapped to 'torque'\) is not"),
    "columns bad key": (dict(columns="moment=M"), "'moment' is not a column"),
    # from Python a list of pairs is read as the command line's comma-separated ones; anything
    # else that is not a string or a mapping is named as such, not quoted back as a column
    "columns a list, bad key": (dict(columns=["time=t", "moment=M"]), "'moment' is not a column"),
    "columns a number": (dict(columns=3), "expected NAME=VALUE pairs as a string"),
    "samples per period too few": (dict(samples_per_period=4), "samples_per_period must be an integer >= 16"),
}


@pytest.mark.parametrize("case", list(OPTION_CASES))
def test_loader_options_are_checked(tmp_path, case):
    path = tmp_path / "ok.csv"
    path.write_text(good_csv())
    kw, match = OPTION_CASES[case]
    with pytest.raises(RunsFileError, match=match):
        read_runs(path, **kw)


@pytest.mark.parametrize("name, content, match", [
    ("missing.csv", None, "no such file or folder"),
    ("x.xlsx", b"PK", "unknown file type '.xlsx'"),
    ("bad.parquet", b"PAR1 not really", "not a readable Parquet file"),
    ("bad.mat", b"MATLAB 5.0 garbage" * 3, "MATLAB"),
    ("bad.h5", b"\x89HDF\r\n\x1a\n garbage", "not a readable HDF5 file"),
    ("bad.tdms", b"TDSm garbage garbage", "TDMS"),
    ("bad.uff", b"    -1\n    58\ngarbage\n    -1\n", "UFF|universal|dataset 58"),
    ("empty_folder", "dir", "a folder without run files"),
])
def test_unreadable_files_in_every_format(tmp_path, name, content, match):
    path = tmp_path / name
    if content == "dir":
        path.mkdir()
    elif content is not None:
        path.write_bytes(content)
    with pytest.raises(RunsFileError, match=match):
        read_runs(path)


def test_sidecar_errors(tmp_path):
    path = tmp_path / "ok.csv"
    path.write_text(good_csv())
    side = tmp_path / "ok.csv.meta.json"
    side.write_text("{not json")
    with pytest.raises(RunsFileError, match="meta.json: not readable JSON"):
        read_runs(path)
    side.write_text('{"colums": {}}')
    with pytest.raises(RunsFileError, match="expected an object with keys 'columns', 'units'"):
        read_runs(path)


def test_fuzzed_files_give_only_clean_errors(tmp_path):
    # Every mutation of a valid file (bytes dropped, duplicated, replaced) is either read or
    # refused with a RunsFileError: no other exception type reaches the user.
    pytest.importorskip("hypothesis")
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    base = good_csv().encode()

    @settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(st.lists(st.tuples(st.integers(0, len(base) - 1), st.sampled_from([b"", b",", b"\n", b"x", b"-", b"9",
                                                                             b"e", b";", b"\x00"])), max_size=6),
           st.sampled_from([".csv", ".txt"]))
    def check(edits, suffix):
        data = bytearray(base)
        for pos, rep in sorted(edits, reverse=True):
            data[pos:pos + 1] = rep
        path = tmp_path / f"fuzz{suffix}"
        path.write_bytes(bytes(data))
        try:
            read_runs(path)
        except RunsFileError:
            pass

    check()


# ------------------------------------------------------------------------------ API and MJCF


@pytest.mark.parametrize("make, match", [
    (lambda: SteadyStateRecord(W, np.arange(64) * 0.001, np.full(64, np.nan), np.zeros(64), None, n_periods=2),
     "'torque_Nm' holds 64 non-finite"),
    (lambda: SteadyStateRecord(-1.0, np.arange(64) * 0.001, np.zeros(64), np.zeros(64), None), "omega_rad_s"),
    (lambda: SteadyStateRecord(W, np.arange(64) * 0.001, np.zeros(63), np.zeros(64), None), "has 63 samples"),
    (lambda: Plant(JointLaw((Viscous(),), (1.0,)), bearing1_damping_Nms_per_rad=-1.0), "bearing1_damping"),
    (lambda: Plant(JointLaw((Viscous(),), (1.0,)), drive_delay_s=math.nan), "drive_delay_s"),
])
def test_python_api_refuses_bad_values(make, match):
    with pytest.raises((RecordError, ValueError), match=match):
        make()


MJCF_LAW = """<mujoco><custom>{fields}</custom><worldbody>
<body name="f1"><joint name="phi1" type="hinge"/><geom size=".1" mass="1"/></body>
<body name="f2"><joint name="phi2" type="hinge"/><geom size=".1" mass="1"/></body></worldbody>
<actuator><motor name="drive" joint="phi1"/></actuator>
<sensor><jointpos name="phi1" joint="phi1"/><jointpos name="phi2" joint="phi2"/>
<jointvel name="rate1" joint="phi1"/><jointvel name="rate2" joint="phi2"/>
<actuatorfrc name="drive_torque" actuator="drive"/></sensor></mujoco>"""


@pytest.mark.parametrize("fields, match", [
    ('<numeric name="jointrig_k_Nm_per_rad" data="2000"/><numeric name="jointrig_coulomb_torque_Nm" data="-5"/>',
     "coulomb_torque_Nm must be >= 0"),
    ('<numeric name="jointrig_k_Nm_per_rad" data="2000"/><numeric name="jointrig_stiffness" data="1"/>',
     "unknown joint-law field"),
    ("", "no joint law"),
    ('<numeric name="jointrig_k_Nm_per_rad" data="2000"/><numeric name="jointrig_backlash_half_gap_rad" data="-1"/>',
     "must hold one finite number >= 0"),
])
def test_mjcf_law_fields_are_checked(tmp_path, fields, match):
    path = tmp_path / "m.xml"
    path.write_text(MJCF_LAW.format(fields=fields))
    with pytest.raises(RigModelError, match=match):
        load_rig(path)


def test_mjcf_without_a_drive_is_refused(tmp_path):
    path = tmp_path / "m.xml"
    path.write_text(MJCF_LAW.format(fields='<numeric name="jointrig_k_Nm_per_rad" data="2000"/>')
                    .replace('<motor name="drive" joint="phi1"/>', "").replace(
                        '<actuatorfrc name="drive_torque" actuator="drive"/>', ""))
    with pytest.raises(RigModelError, match="drive"):
        load_rig(path)


# ------------------------------------------------------------------------------ commands


@pytest.fixture(scope="session")  # once per worker, even when xdist interleaves other modules
def data3(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "three.csv"
    path.write_text(three_runs())
    return path


DIAGNOSE = {
    "band 0": (["--band", "0"], "--band 0: expected an integer in [1, 100]"),
    "alpha 2": (["--alpha", "2"], "--alpha 2.0: expected a number in (0, 1)"),
    "fidelity -1": (["--fidelity", "-1"], "--fidelity -1.0"),
    "torque share 1.5": (["--torque-share", "1.5"], "--torque-share 1.5"),
    "json is a folder": (["--json", "{tmp}"], "is a folder"),
    "report under a file": (["--report", "{data}/x.html"], "is a file, not a folder"),
    "rrd where nothing can be written": (["--rrd", "/proc/jointrig.rrd"], "cannot create a file"),
    "holdout unknown run": (["--holdout", "7"], r"--holdout names run\(s\) \['7'\]"),
    "holdout everything": (["--holdout", "0", "1", "2"], r"--holdout leaves 0 run\(s\) to fit; expected at least 3"),
    "columns bad": (["--columns", "torque"], "not NAME=VALUE"),
    "units bad": (["--units", "phi1=parsec"], "unit 'parsec'"),
}


@pytest.mark.parametrize("case", list(DIAGNOSE))
def test_diagnose_command_refuses_before_any_work(tmp_path, data3, capsys, case):
    args, match = DIAGNOSE[case]
    args = [a.format(tmp=tmp_path, data=data3) for a in args]
    code = _script("diagnose").main([str(data3), "-q", *args])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    import re

    assert match in err or re.search(match, err), err
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]


@pytest.mark.parametrize("data, match", [
    ("missing.csv", "no such file or folder"),
    ("two_runs.csv", r"2 run\(s\), and run\(s\) a \(2\), b \(2\) hold fewer than 3 whole periods: the diagnosis "
                     r"needs 4 runs \(some held out for validation\), runs of at least 3 steady periods .*--validate"),
    ("header_only.csv", "no data rows"),
    ("nan.csv", "non-finite"),
    # a dead channel: all-zero angles, and angles so small that their squares underflow (issue 35:
    # both ended in a ZeroDivisionError traceback in the noise estimate)
    ("zero_angles.csv", r"run 0: column 'phi1' does not vary \(spread 0 rad\)"),
    ("tiny_angles.csv", r"run 0: column 'phi1' does not vary \(spread 2e-300 rad\)"),
])
def test_diagnose_command_refuses_bad_data(tmp_path, capsys, data, match):
    if data == "two_runs.csv":
        (tmp_path / data).write_text("run,time,torque,phi1,phi2\n" + "\n".join(
            _good_rows(2, run="a") + _good_rows(2, run="b", omega=70.0)) + "\n")
    elif data == "header_only.csv":
        (tmp_path / data).write_text("run,time,torque,phi1,phi2,speed\n")
    elif data == "nan.csv":
        (tmp_path / data).write_text("run,time,torque,phi\n0,0,1,nan\n")
    elif data.endswith("_angles.csv"):
        scale = 0.0 if data.startswith("zero") else 1e-300
        rows = []
        for r in range(3):
            w = W * (1 + 0.2 * r)
            for k in range(192):
                t = k * 2 * math.pi / w / 64
                rows.append(f"{r},{t!r},{1000 * math.cos(w * t)!r},{scale * math.cos(w * t)!r},"
                            f"{0.5 * scale * math.sin(w * t)!r}")
        (tmp_path / data).write_text("run,time,torque,phi1,phi2\n" + "\n".join(rows) + "\n")
    code = _script("diagnose").main([str(tmp_path / data), "-q"])
    err = capsys.readouterr().err
    import re

    assert code == 2 and re.search(match, err), err


@pytest.mark.parametrize("args, match", [
    (["{tmp}/out.xlsx"], "expected a .csv or .parquet"),
    (["{tmp}/out.csv", "--periods", "0"], "--periods 0"),
    (["{tmp}/out.csv", "--omegas", "-5"], "--omegas -5.0"),
    (["{tmp}/out.csv", "--model", "{tmp}/nope.xml"], "nope.xml"),
    (["/proc/out.csv"], "cannot create a file"),
    (["{tmp}/out.csv", "--seed", "-1"], "--seed -1"),
])
def test_make_data_command(tmp_path, capsys, args, match):
    args = [a.format(tmp=tmp_path) for a in args]
    code = _script("make_data").main(args)
    err = capsys.readouterr().err
    assert code == 2 and match in err, err
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("args, match", [
    (["--json", "{tmp}"], "is a folder"),
    (["--rrd", "/proc/x.rrd"], "cannot create a file"),
    (["--harmonics", "0"], "--harmonics 0"),
    (["--workers", "0"], "--workers 0"),
    (["--omegas", "0"], "--omegas 0.0"),
    (["--amplitudes", "nan"], "--amplitudes nan"),
    (["--model", "{tmp}/none.xml"], "none.xml"),
    # issue 38: limits every numeric option states, the option named (1e7 samples hung, 1e-6 rad/s
    # was a MemoryError, the rest were ignored or named no option)
    (["--samples-per-period", "10000000"], "--samples-per-period 10000000: expected an integer in [8, 65536]"),
    (["--omegas", "1e-6"], "--omegas 1e-06: expected a number in [0.1, 10000]"),
    (["--seed", "-1"], "--seed -1"),
    (["--sample-rate-hz", "0"], "--sample-rate-hz 0.0"),
    (["--sample-rate-hz", "nan"], "--sample-rate-hz nan"),
    (["--drive-at", "0"], "--drive-at 0"),
    (["--snr-db", "-200"], "--snr-db -200.0"),
    (["--store", "/proc/st"], "--store /proc/st: cannot create a file in /proc"),
])
def test_run_sweep_command(tmp_path, capsys, args, match):
    from jointrig.commands.options import run_cli

    args = [a.format(tmp=tmp_path) for a in args]
    code = run_cli(_script("run_sweep").main, "run_sweep.py", ([] if "--store" in args else ["--no-store"]) + ["-q", *args])
    err = capsys.readouterr().err
    assert code == 2 and match in err, err


@pytest.mark.parametrize("script, args, match", [
    ("design_excitation", ["--harmonics", "0"], "--harmonics 0"),
    ("design_excitation", ["--snr-db", "-3"], "--snr-db -3.0"),
    ("design_excitation", ["--json", "/proc/d.json"], "cannot create a file"),
    ("unknown_law", ["--knots", "1"], "--knots 1"),
    ("unknown_law", ["--periods", "1"], "--periods 1"),
    ("unknown_law", ["--model", "/nonexistent.xml"], "no such file"),
    ("unknown_law", ["--png", "/proc/u.png"], "cannot create a file"),
    # issue 38: these wrote their outputs only after the work, and a bad path was a traceback
    ("paper_example", ["--json", "/proc/p.json"], "--json /proc/p.json: cannot create a file"),
    ("diagnose_cases", ["--json", "/proc/c.json"], "--json /proc/c.json: cannot create a file"),
    ("silverbox", ["--json", "/proc/s.json"], "--json /proc/s.json: cannot create a file"),
    ("silverbox", ["--rrd", "/proc/s.rrd"], "--rrd /proc/s.rrd: cannot create a file"),
])
def test_other_commands_check_arguments_first(capsys, script, args, match):
    from jointrig.commands.options import run_cli

    code = run_cli(_script(script).main, script, args)
    err = capsys.readouterr().err
    assert code == 2 and match in err, err


def test_truncated_store_point_is_simulated_again(tmp_path, rig, caplog):
    from jointrig.rig import SimulationConfig
    from jointrig.studies.sweep import SweepPlan, run_sweep

    plan = SweepPlan((30.0,), (500.0,))
    cfg = SimulationConfig(samples_per_period=64)
    first = run_sweep(rig, plan, cfg, store=tmp_path)
    (npz,) = tmp_path.glob("*.npz")
    npz.write_bytes(npz.read_bytes()[:100])  # a sweep killed while a disk filled up
    with pytest.raises(zipfile.BadZipFile):
        zipfile.ZipFile(npz)
    again = run_sweep(rig, plan, cfg, store=tmp_path)
    assert not again[0].from_store and npz.name in caplog.text
    np.testing.assert_array_equal(again[0].record.phi1_rad, first[0].record.phi1_rad)


def test_killed_sweep_resumes_from_its_store(tmp_path):
    # A sweep killed mid-way (SIGKILL: no cleanup runs) leaves whole points in its store and no
    # temporary file that blocks the next run; the next run loads them and simulates the rest.
    import signal
    import subprocess
    import sys
    import time

    store = tmp_path / "store"
    cmd = [sys.executable, str(ROOT / "scripts" / "run_sweep.py"), "--omegas", "1", "2", "3", "4", "5", "6",
           "--amplitudes", "400", "--samples-per-period", "64", "--store", str(store),
           "--json", str(tmp_path / "s.json"), "--no-rrd"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None and len(list(store.glob("*.npz"))) < 2:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    kept = sorted(p.name for p in store.glob("*.npz"))
    assert kept, "the sweep stored no point before it was killed"
    import os

    env = {**os.environ, "JOINTRIG_PROGRESS": "1"}  # progress lines on a pipe too (they say "from store")
    out = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stderr.count("from store") >= len(kept), out.stderr
    assert not list(tmp_path.rglob("*.tmp")) and (tmp_path / "s.json").is_file()


def _bench_file(tmp_path, edit):
    """Six runs of the independent bench (tests/bench_sim.py) rewritten by ``edit(run, t, T, phi1, phi2)``
    as a lab would have them, under a header without units."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_sim import JOINTS, POINTS, measure

    pts = [p for i, p in enumerate(POINTS["paper"]) if i % 3 != 1]
    src = measure(JOINTS["paper"], pts, tmp_path / "bench.csv", seed=5, fs_Hz=1000.0, n_periods=4.5)
    rows, first = ["run,time,torque,phi1,phi2"], {}
    for line in src.read_text().splitlines()[1:]:
        r, t, T, a, b = line.split(",")
        first.setdefault(r, (float(a), float(b)))
        rows.append(",".join([r, t, T] + [f"{v:.9f}" for v in edit(first[r], float(a), float(b))]))
    out = tmp_path / "lab.csv"
    out.write_text("\n".join(rows) + "\n")
    return out


def test_angles_in_degrees_without_a_unit_are_refused_with_the_fix(tmp_path, capsys):
    # issue 37: a file in degrees with no unit label was read as rad (J1 = 0.035 kg m^2, k = 34.8)
    path = _bench_file(tmp_path, lambda first, a, b: (math.degrees(a), math.degrees(b)))
    assert _script("diagnose").main([str(path), "-q"]) == 2
    err = capsys.readouterr().err
    assert "are the angles in degrees" in err and "--units phi1=deg,phi2=deg" in err, err
    # with the unit stated, the same file is read
    assert len(read_runs(path, units="phi1=deg,phi2=deg").records) == 6


def test_one_angle_unit_forgotten_is_named_not_taken_for_a_zero(tmp_path, capsys):
    # issue 49: both angles in degrees, the unit written for phi1 only: phi2 read as rad swings the
    # twist by tens of "rad". The advice names phi2's unit, not a re-zeroing per run.
    path = _bench_file(tmp_path, lambda first, a, b: (math.degrees(a), math.degrees(b)))
    path.write_text(path.read_text().replace("run,time,torque,phi1,phi2", "run,time,torque,phi1 [deg],phi2", 1))
    assert _script("diagnose").main([str(path), "-q"]) == 2
    err = capsys.readouterr().err
    assert "phi2 has no unit stated" in err and "--units phi2=deg" in err, err
    assert "--zero-per-run" not in err, err
    assert len(read_runs(path, units="phi2=deg").records) == 6


def test_encoders_zeroed_per_recording_are_refused_or_centred(tmp_path, capsys):
    # issue 37: encoders zeroed at the start of each recording shifted the relative angle's mean
    # by up to 0.37 rad between runs and the law came out wrong without a warning
    path = _bench_file(tmp_path, lambda first, a, b: (a - first[0], b - first[1]))
    assert _script("diagnose").main([str(path), "-q"]) == 2
    err = capsys.readouterr().err
    assert "zeroed at the start of each recording" in err and "--zero-per-run" in err, err
    loaded = read_runs(path, zero_per_run=True)
    assert any("--zero-per-run" in n for n in note_words(loaded.notes))
    for r in loaded.records:
        assert abs(float(np.mean(r.angles_rad[0] - r.angles_rad[1]))) < 1e-9


def _layout_rows(fmt_time, t0=0.0):
    rows = []
    for r in range(3):
        w = W * (1 + 0.2 * r)
        for k in range(64 * 4):
            dt = k * 2 * math.pi / w / 64
            rows.append(f"{r},{fmt_time(t0 + 1000 * r + dt)},{1000 * math.cos(w * dt)!r},"
                        f"{0.3 * math.cos(w * dt - 0.5)!r},{0.1 * math.cos(w * dt - 1.5)!r}")
    return rows


@pytest.mark.parametrize("layout", ["units row, empty under run", "epoch stamps, 6 decimals", "epoch stamps, 9 decimals",
                                    "ISO 8601 stamps"])
def test_lab_layouts_are_read(tmp_path, layout):
    # issue 37: each of these was refused, some with the wrong advice ("trim it to whole periods")
    import datetime

    head = "run,time,torque,phi1,phi2\n"
    if layout.startswith("units row"):
        text = head + ",s,N m,rad,rad\n" + "\n".join(_layout_rows(repr))
    elif layout.startswith("epoch"):
        digits = int(layout.split(", ")[1][0])
        text = head + "\n".join(_layout_rows(lambda t: f"{t:.{digits}f}", 1.7e9))
    else:
        text = head + "\n".join(_layout_rows(lambda t: datetime.datetime.fromtimestamp(t, datetime.timezone.utc)
                                            .isoformat(timespec="microseconds"), 1.7e9))
    (tmp_path / "lab.csv").write_text(text + "\n")
    loaded = read_runs(tmp_path / "lab.csv")
    assert len(loaded.records) == 3
    for r, rec in enumerate(loaded.records):
        # the period found from the data: within the stamps' rounding (1e-6 s of 0.1 s periods)
        assert rec.omega_rad_s == pytest.approx(W * (1 + 0.2 * r), rel=1e-4)
        if layout.startswith("epoch"):  # epoch stamps: each run's time from its first stamp
            assert abs(rec.time_s[0]) < 1e-5, (r, rec.time_s[0])


def test_every_missing_column_is_named_at_once(tmp_path):
    (tmp_path / "lab.csv").write_text("run,Zeit,M\n0,0,1\n")
    with pytest.raises(RunsFileError, match=r"missing column\(s\) time, torque, phi1, phi2 \(or phi\)"):
        read_runs(tmp_path / "lab.csv")
    (tmp_path / "lab.csv").write_text("run,time,torque,phi1\n0,0,1,2\n")
    with pytest.raises(RunsFileError, match=r"missing column\(s\) phi2;"):
        read_runs(tmp_path / "lab.csv")


def _model_edited(tmp_path, old: str, new: str) -> Path:
    """The shipped two-flywheel model with one piece of its text replaced."""
    text = (ROOT / "models" / "two_flywheels.xml").read_text()
    assert old in text
    (tmp_path / "edited.xml").write_text(text.replace(old, new, 1))
    return tmp_path / "edited.xml"


@pytest.mark.parametrize("old, new, match", [
    # issue 38: MuJoCo's own damping on a flywheel's hinge was added on top of the jointrig law
    # ("status ok" with k 51% off)
    ('<joint name="phi2" type="hinge" axis="0 0 1" damping="0"', '<joint name="phi2" type="hinge" axis="0 0 1" damping="3"',
     r"joint 'phi2' sets MuJoCo's own damping=3"),
    # issue 38: gamma = 1e15 was accepted
    ('name="jointrig_gamma_Nm_per_rad3" data="200"', 'name="jointrig_gamma_Nm_per_rad3" data="1e15"',
     r"gamma_Nm_per_rad3 = 1e\+15 is beyond 1e\+12 in SI units"),
])
def test_model_fields_the_rig_would_misread_are_refused(tmp_path, old, new, match):
    with pytest.raises(RigModelError, match=match):
        load_rig(_model_edited(tmp_path, old, new))


def test_units_given_twice_must_agree(tmp_path):
    # issue 38: --units contradicting a header that says [rad] won without a word (57x off)
    text = good_csv().replace("run,time,torque,phi1,phi2", "run,time [s],torque [N m],phi1 [rad],phi2 [rad]", 1)
    (tmp_path / "d.csv").write_text(text)
    with pytest.raises(RunsFileError, match=r"column 'phi1 \[rad\]'|column 'phi1'.*units given twice must agree"):
        read_runs(tmp_path / "d.csv", units="phi1=deg")
    assert len(read_runs(tmp_path / "d.csv", units="phi1=rad").records) == 1  # the same unit twice is fine


def _segfault(path):
    """A reader that crashes its process (module level: the child is sent it by reference)."""
    import faulthandler
    import signal

    faulthandler.disable()  # as the real reader's child: no dump in the test's log
    os.kill(os.getpid(), signal.SIGSEGV)


def test_a_reader_that_crashes_the_process_is_a_clear_error(tmp_path, monkeypatch):
    # issue 38: scipy's MAT v5 reader died by SIGSEGV on a fuzzed file, with no message at all.
    # The MAT reader runs in a forked child: a crash there ends the child, and the file is named.
    import scipy.io

    from jointrig.measured import formats

    t = np.arange(0, 0.5, 0.001)
    scipy.io.savemat(tmp_path / "runs.mat", {"time": t, "torque": np.cos(60 * t), "phi1": np.sin(60 * t),
                                             "phi2": 0.5 * np.sin(60 * t)})
    assert formats.read_tables(tmp_path / "runs.mat")  # read whole through the child

    monkeypatch.setattr(formats, "_loadmat", _segfault)
    with pytest.raises(formats.FormatError, match=r"runs\.mat: the reader crashed on this file \(exit -11\)"):
        formats.read_tables(tmp_path / "runs.mat")


def test_a_store_point_that_holds_another_point_is_simulated_again(tmp_path, rig, caplog):
    # issue 38: a point file holding another point was loaded unchecked: one point counted twice,
    # one missing
    from jointrig.rig import SimulationConfig
    from jointrig.studies.sweep import SweepPlan, run_sweep

    plan = SweepPlan((30.0, 40.0), (500.0,))
    cfg = SimulationConfig(samples_per_period=64)
    first = run_sweep(rig, plan, cfg, store=tmp_path)
    a, b = sorted(tmp_path.glob("*.npz"))
    b.write_bytes(a.read_bytes())  # a copied file, a mix-up of two stores
    again = run_sweep(rig, plan, cfg, store=tmp_path)
    assert [p.record.omega_rad_s for p in again] == [30.0, 40.0]
    assert again[0].from_store and not again[1].from_store and "holds the point omega = 30" in caplog.text
    np.testing.assert_array_equal(again[1].record.phi1_rad, first[1].record.phi1_rad)


def test_a_cut_store_manifest_is_named(tmp_path, rig):
    from jointrig.rig import SimulationConfig
    from jointrig.studies.sweep import SweepPlan, SweepStoreMismatch, run_sweep

    plan = SweepPlan((30.0,), (500.0,))
    cfg = SimulationConfig(samples_per_period=64)
    run_sweep(rig, plan, cfg, store=tmp_path)
    manifest = tmp_path / "manifest.json"
    manifest.write_text(manifest.read_text()[:40])
    with pytest.raises(SweepStoreMismatch, match=r"manifest\.json: not readable JSON .*delete the folder"):
        run_sweep(rig, plan, cfg, store=tmp_path)


@pytest.mark.parametrize("column, values, match", [
    ("torque", lambda t: np.cos(60 * t) + 0.1j, r"column 'torque' holds complex numbers"),
    ("phi1", lambda t: np.sin(60 * t) > 0, r"column 'phi1' holds true/false values"),
])
def test_complex_and_boolean_channels_are_named(tmp_path, column, values, match):
    # issue 38: a complex torque was reported as a missing column (the HDF5 reader dropped it), a
    # boolean angle failed later as a MuJoCo divergence
    import h5py

    t = np.arange(0, 0.5, 0.001)
    cols = {"time": t, "torque": np.cos(60 * t), "phi1": np.sin(60 * t), "phi2": 0.5 * np.sin(60 * t)}
    cols[column] = values(t)
    with h5py.File(tmp_path / "runs.h5", "w") as f:
        for name, data in cols.items():
            f[name] = data
    with pytest.raises(RunsFileError, match=match):
        read_runs(tmp_path / "runs.h5")


def test_a_writer_that_meets_a_full_disk_names_the_file_and_leaves_nothing(tmp_path):
    # issue 38: every writer ended in an OSError traceback on a full disk
    import errno

    from jointrig.files import OutputError, write_atomic

    (tmp_path / "old.json").write_text("old")

    def full(tmp):
        tmp.write_text("half")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OutputError, match=r"old\.json: could not be written \(no space left on the device\)"):
        write_atomic(tmp_path / "old.json", full)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]
    assert (tmp_path / "old.json").read_text() == "old"  # the older file survives


def test_stale_temporary_files_of_a_killed_run_are_removed(tmp_path):
    # issue 38: a SIGKILL while a recording was written left .NAME.rrd.*.tmp for good
    import subprocess
    import sys

    from jointrig.files import write_atomic

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    stale = tmp_path / f".out.json.{dead}.abc123.tmp"
    stale.write_text("half")
    other = tmp_path / f".out.json.{os.getpid()}.live12.tmp"  # a live writer's (this process): kept
    other.write_text("being written")
    write_atomic(tmp_path / "out.json", lambda tmp: tmp.write_text("{}"))
    assert not stale.exists() and other.exists() and (tmp_path / "out.json").read_text() == "{}"


@pytest.mark.slow  # slow: a whole diagnosis before the recording meets the full disk (20-30 s on 2 cores)
def test_a_diagnosis_on_a_full_disk_is_a_clear_error(tmp_path):
    # A real full disk where this machine allows a small tmpfs (root); the recording's writer
    # said only "File-writer thread shut down prematurely" and left its temporary file.
    import shutil
    import subprocess
    import sys

    full = tmp_path / "full"
    full.mkdir()
    if shutil.which("mount") is None or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(full)],
                                                     capture_output=True).returncode != 0:
        pytest.skip("no tmpfs can be mounted here (needs root)")
    try:
        data = ROOT / "examples" / "bench_dry_friction.csv"
        done = subprocess.run([sys.executable, "-m", "jointrig", "diagnose", str(data), "-q", "--rrd",
                               str(full / "d.rrd")], capture_output=True, text=True)
        assert done.returncode == 2, done.stderr
        assert "d.rrd: could not be written (no space left on the device)" in done.stderr
        assert list(full.iterdir()) == []
    finally:
        subprocess.run(["umount", str(full)], capture_output=True)


def test_an_unreachable_scheduler_is_named(monkeypatch):
    # issue 38: a --scheduler nobody answers at was a traceback after 30 s
    from jointrig.studies import sweep

    monkeypatch.setattr(sweep, "SCHEDULER_TIMEOUT_S", 1)
    with pytest.raises(ValueError, match=r"--scheduler tcp://127\.0\.0\.1:1: no dask scheduler answered there within 1 s"):
        sweep.connect_scheduler("tcp://127.0.0.1:1")


def test_a_truncated_universal_file_is_refused(tmp_path):
    # issue 38: a truncated UFF silently lost its last runs
    import pyuff

    from jointrig.measured import formats

    t = np.arange(3 * 128) * (2 * math.pi / W / 128)
    uff = pyuff.UFF(str(tmp_path / "r.uff"))
    for run in (1, 2):
        for name, data in (("torque", 1000 * np.cos(W * t)), ("phi1", 0.3 * np.sin(W * t)),
                           ("phi2", 0.1 * np.sin(W * t))):
            uff.write_sets(pyuff.prepare_58(binary=0, id1=name, func_type=1, load_case_id=run, rsp_node=1, rsp_dir=1,
                                            ref_node=1, ref_dir=1, data=data, x=t, abscissa_spacing=1,
                                            abscissa_min=0.0, abscissa_inc=float(t[1]), abscissa_spec_data_type=17,
                                            ordinate_spec_data_type=0, orddenom_spec_data_type=0,
                                            z_axis_spec_data_type=0, ord_data_type=4), mode="add")
    whole = (tmp_path / "r.uff").read_bytes()
    assert len(formats.read_tables(tmp_path / "r.uff")) == 2
    (tmp_path / "r.uff").write_bytes(whole[: int(len(whole) * 0.8)])
    with pytest.raises(formats.FormatError, match=r"r\.uff: the file ends inside a dataset"):
        formats.read_tables(tmp_path / "r.uff")


def test_a_term_given_twice_to_the_identifier_is_refused():
    # issue 38: duplicated terms in the API returned half the values (the estimate split between
    # two identical columns)
    from jointrig.identify.solve import identify
    from jointrig.vocab.law import Power

    t = np.arange(64) * 2 * np.pi / (W * 32)
    rec = SteadyStateRecord(W, t, np.cos(W * t), np.sin(W * t), 0.5 * np.sin(W * t), n_periods=2)
    with pytest.raises(ValueError, match=r"the terms \['k_Nm_per_rad'\] are given more than once"):
        identify([rec], (Viscous(), Power(1), Power(1)), form="two_dof")


def test_units_stated_only_in_a_comment_are_refused(tmp_path):
    # issue 38: units stated only in a comment line were read as SI
    (tmp_path / "d.csv").write_text("# bench 3, encoders: phi1 and phi2 in deg\n" + good_csv())
    with pytest.raises(RunsFileError, match=r"reads as column 'phi1' in 'deg'.*--units phi1=deg"):
        read_runs(tmp_path / "d.csv")
    # the header states it: the comment is no contradiction
    text = good_csv().replace("run,time,torque,phi1,phi2", "run,time,torque,phi1 [deg],phi2 [deg]", 1)
    (tmp_path / "d.csv").write_text("# bench 3, encoders: phi1 and phi2 in deg\n" + text)
    assert read_runs(tmp_path / "d.csv").records


def test_periods_the_rig_would_replay_for_minutes_are_refused(tmp_path, capsys):
    # A fuzz of periodic records ran past 120 s: time stretched (a time column in ms read as s)
    # makes every period thousands of times more integrator steps in the diagnosis's replays.
    lines = (ROOT / "examples" / "bench_dry_friction.csv").read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    stretched = tmp_path / "ms.csv"
    stretched.write_text("run,time,torque,phi1,phi2\n" + "\n".join(
        ",".join([r[0], repr(float(r[1]) * 1000), *r[2:]]) for r in rows) + "\n")
    code = _script("diagnose").main([str(stretched), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    assert "run(s) 0 (0.025 rad/s)" in err and "expected periods of at most 10 s (omega >= 0.628 rad/s)" in err, err
    assert "--units time=ms" in err


def test_a_relative_angles_mean_that_follows_the_drives_mean_is_read_as_a_preload(tmp_path):
    # The relative angle alone, two runs: the second under a mean drive of 300 N m (its share on the
    # joint, 150) and its mean angle 6 mrad further: a preload that changes between runs, said of
    # the relative angle (not of a joint's twist), not refused as encoders zeroed per run.
    def rows(run, mean_torque, mean_phi, omega=60.0, N=64, periods=4):
        dt = 2 * math.pi / omega / N
        return [f"{run},{k * dt!r},{mean_torque + 1000 * math.cos(omega * k * dt)!r},"
                f"{mean_phi + 0.01 * math.cos(omega * k * dt - 0.4)!r}" for k in range(N * periods)]

    path = tmp_path / "relative_loads.csv"
    path.write_text("run,time,torque,phi\n" + "\n".join(rows("a", 0.0, 0.0) + rows("b", 300.0, 0.006)) + "\n")
    said = [n for n in note_words(read_runs(path).notes) if "preload" in n]
    assert said == ["the relative angle's mean differs between runs by 0.006 rad, as the drives' mean does (by 150): "
                    "read as a preload that changes between runs (each run's replay holds its own), not as encoders "
                    "zeroed per run"]


def test_a_forgotten_unit_is_named_on_encoders_with_their_own_zeros(tmp_path):
    # The same forgotten unit on encoders that each read their own zero (30 and -20 deg): the twist
    # read in degrees has one mean in every run, 0.87 rad off zero, which is a zero, not a
    # re-zeroing per run: the advice still names phi2's unit.
    path = _bench_file(tmp_path, lambda first, a, b: (math.degrees(a) + 30.0, math.degrees(b) - 20.0))
    path.write_text(path.read_text().replace("run,time,torque,phi1,phi2", "run,time,torque,phi1 [deg],phi2", 1))
    with pytest.raises(RunsFileError, match=r"phi2 has no unit stated.*--units phi2=deg"):
        read_runs(path)


def test_a_forgotten_unit_is_named_when_the_shaft_turned_between_runs(tmp_path):
    # Both encoders count the shaft's turns, and between runs the rig came to rest 40 deg further on
    # (both flywheels alike): the angles' means move from run to run, the twist's does not. Read in
    # degrees the twist, the first angle minus the second, has one zero: the advice names phi2's unit.
    path = _bench_file(tmp_path, lambda first, a, b: (math.degrees(a), math.degrees(b)))
    rows, turns = ["run,time,torque,phi1 [deg],phi2"], {}
    for line in path.read_text().splitlines()[1:]:
        r, t, T, a, b = line.split(",")
        turn = 40.0 * turns.setdefault(r, len(turns))
        rows.append(",".join([r, t, T, f"{float(a) + turn:.9f}", f"{float(b) + turn:.9f}"]))
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(RunsFileError, match=r"phi2 has no unit stated.*--units phi2=deg"):
        read_runs(path)
    assert len(read_runs(path, units="phi2=deg").records) == 6


def test_a_forgotten_unit_beside_encoders_zeroed_per_recording_names_both_fixes(tmp_path):
    # phi2's unit forgotten and the encoders zeroed at the start of each recording: read in degrees
    # the twist's mean still differs between runs, so degrees alone do not make the twists
    # plausible. The refusal names the unit forgotten and the re-zeroing both, so that one retry
    # reads the file (it named the re-zeroing alone, and under --zero-per-run phi2 was read as rad).
    path = _bench_file(tmp_path, lambda first, a, b: (math.degrees(a - first[0]), math.degrees(b - first[1])))
    path.write_text(path.read_text().replace("run,time,torque,phi1,phi2", "run,time,torque,phi1 [deg],phi2", 1))
    with pytest.raises(RunsFileError) as err:
        read_runs(path)
    # not that degrees alone would do: both fixes are named, the unit and the zero per run
    assert "one zero for all runs" not in str(err.value), err.value
    assert "--units phi2=deg, and pass --zero-per-run" in str(err.value), err.value


def test_a_forgotten_unit_is_named_under_zero_per_run_too(tmp_path):
    # The file above, read with --zero-per-run as its refusal advises: each run then takes its own
    # zero, and read in degrees every twist is plausible. It was accepted with phi2 read as rad
    # (a twist of +-38 rad); it is refused naming the unit forgotten.
    path = _bench_file(tmp_path, lambda first, a, b: (math.degrees(a - first[0]), math.degrees(b - first[1])))
    path.write_text(path.read_text().replace("run,time,torque,phi1,phi2", "run,time,torque,phi1 [deg],phi2", 1))
    with pytest.raises(RunsFileError, match=r"phi2 has no unit stated .*each run on its own zero.*--units phi2=deg"):
        read_runs(path, zero_per_run=True)
    # stated, the same file is read, each run centred
    path.write_text(path.read_text().replace("phi1 [deg],phi2", "phi1 [deg],phi2 [deg]", 1))
    assert read_runs(path, zero_per_run=True).records


def test_runs_whose_mean_twists_differ_by_a_fifth_of_the_swing_in_degrees_are_zeroed_per_recording(tmp_path):
    # phi2's unit forgotten; read in degrees, the runs' mean twists differ by 0.2 rad against a
    # swing of about +-0.6 rad: more than ZERO_SPREAD (0.2) of the swing, so one zero for all
    # runs does not hold and the refusal names both fixes, not degrees alone. (This file was read,
    # phi2 as rad and a twist of +-38 rad: its runs' mean drive torques differ, so the twists'
    # differing means were taken for a preload that changes between runs.)
    seen = {}

    def edit(first, a, b):
        k = seen.setdefault(first, len(seen))
        return math.degrees(a), math.degrees(b + (0.0, 0.2, 0.1, 0.0, 0.2, 0.1)[k % 6])

    path = _bench_file(tmp_path, edit)
    path.write_text(path.read_text().replace("run,time,torque,phi1,phi2", "run,time,torque,phi1 [deg],phi2", 1))
    with pytest.raises(RunsFileError) as err:
        read_runs(path)
    assert "each run on its own zero" in str(err.value) and "pass --zero-per-run" in str(err.value), err.value
