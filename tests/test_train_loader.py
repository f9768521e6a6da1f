"""A drive train's or a single axis's file through the loader (measured/runs.py), on hand-written
files: what it reads (units, idle motors, slides), what it refuses naming the joint or column,
and what it writes back. Fast: the loader's mutation tests run these (scripts/mutation_test.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointrig.measured.runs import RunsFileError, read_runs, write_runs
from conftest import note_words


def _train_csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in rows) + "\n")
    return path


def _rows(n=400, runs=1, torque_cols=1, angles=3, scale=1.0, zero=None):
    t = np.arange(n) * 1e-3
    out = []
    for r in range(runs):
        for k in range(n):
            th = 2 * math.pi * 10 * t[k]
            row = [r, t[k]] + [50 * math.cos(th)] * torque_cols
            row += [scale * (0.01 * (a + 1) * math.cos(th + 0.3 * a) + (zero[r] if zero else 0.0) * a)
                    for a in range(angles)]
            out.append(row)
    return out


@pytest.mark.parametrize("header,match", [
    (["run", "time", "torque1", "phi1", "phi3", "phi4"], "missing phi2"),
    (["run", "time", "torque1", "phi2", "phi3"], r"missing phi1 \("),  # the first body too
    (["run", "time", "torque5", "phi1", "phi2", "phi3"], r"\['torque5'\] act on bodies with no position column"),
    (["run", "time", "torque", "torque1", "phi1", "phi2", "phi3"], "both 'torque' and 'torque1'"),
    (["run", "t", "torque1", "phi1", "phi2", "phi3"], "missing column.*time.*a drive train's file"),
    (["run", "time", "force1", "x1", "phi2"], r"columns \['phi2'\] \(bodies on hinges.*\['force1', 'x1'\] \(bodies "
                                              r"on slides"),
    (["run", "time", "force", "x", "x2"], "both 'x' and numbered positions"),
])
def test_a_train_file_missing_what_a_joint_needs_is_refused_naming_it(tmp_path, header, match):
    n_t = sum(h.startswith(("torque", "force")) for h in header)
    n_a = sum(h.startswith(("phi", "x")) for h in header)
    path = _train_csv(tmp_path / "t.csv", header, _rows(torque_cols=n_t, angles=n_a))
    with pytest.raises(RunsFileError, match=match):
        read_runs(path)


def test_a_train_whose_drive_columns_are_all_zero_is_refused(tmp_path):
    rows = [r[:2] + [0.0] + r[3:] for r in _rows()]
    with pytest.raises(RunsFileError, match="run 0: every drive column .* is zero"):
        read_runs(_train_csv(tmp_path / "z.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], rows))


def test_a_trains_angles_in_degrees_without_a_unit_are_refused(tmp_path):
    path = _train_csv(tmp_path / "d.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], _rows(scale=400.0))
    # joint 2's twist, |8 e^(0.3i) - 12 e^(0.6i)| = 4.96 "rad", the larger of the two
    with pytest.raises(RunsFileError, match=r"a joint's twist swings by \+-4\.9\d rad.* are the angles in degrees"):
        read_runs(path)


def test_a_trains_encoders_zeroed_per_run_are_refused_or_centred(tmp_path):
    # Each run's encoders zeroed at its start: joint 1's mean twist jumps by 0.05 rad between
    # runs whose twist swings by 0.01-0.02 rad. Refused, naming the joint; --zero-per-run centres.
    rows = _rows(runs=3, zero=[0.0, 0.05, -0.04])
    path = _train_csv(tmp_path / "zr.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], rows)
    with pytest.raises(RunsFileError, match=r"joint 1's mean twist differs between runs by 0\.09 rad \(run 1: -0\.05 rad, run 2: 0\.04"):
        read_runs(path)
    loaded = read_runs(path, zero_per_run=True)
    assert all(abs(a.mean()) < 1e-12 for r in loaded.records for a in r.angles_rad)


def test_a_folder_that_mixes_a_train_and_two_flywheels_is_refused(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    _train_csv(folder / "a.csv", ["time", "torque1", "phi1", "phi2", "phi3"], [r[1:] for r in _rows()])
    _train_csv(folder / "b.csv", ["time", "torque", "phi1", "phi2"], [r[1:] for r in _rows(angles=2)])
    with pytest.raises(RunsFileError, match="b.csv.*torque, phi1, phi2.*the files before it phi1..phiN"):
        read_runs(folder)


def test_a_train_is_read_in_its_units_with_idle_motors_and_written_back(tmp_path):
    # mrad and ms in the header; the second motor idle in the first run (its cell reads 0 there):
    # that run has one drive. The writer writes the same columns back, and they read the same
    # (to the writer's 17 significant digits).
    rows = []
    for run, drive2 in ((0, 0.0), (1, 20.0)):
        for k in range(400):
            th = 2 * math.pi * 10 * k * 1e-3
            rows.append([run, k * 1.0, 50 * math.cos(th), drive2 * math.sin(th), 10 * math.cos(th),
                         5 * math.cos(th + 0.2), 2 * math.cos(th + 0.5)])
    path = _train_csv(tmp_path / "u.csv", ["run", "time [ms]", "torque1 [N m]", "torque2 [N m]", "phi1 [mrad]",
                                           "phi2 [mrad]", "phi3 [mrad]"], rows)
    loaded = read_runs(path)
    first, second = loaded.records
    assert first.driven == (True, False, False) and second.driven == (True, True, False)
    # Tolerances: the file holds 9 significant digits (1e-6 on a read value, 1e-9 on a frequency
    # fitted to 4 periods); a half swing read from 100 samples per period misses the peak by up
    # to 1 - cos(pi/100) = 5e-4 (1e-3).
    assert first.omega_rad_s == pytest.approx(2 * math.pi * 10, rel=1e-9)
    assert first.drive_amplitude_Nm == pytest.approx(50.0, rel=1e-3)  # the largest drive's half swing
    assert np.max(np.abs(first.angles_rad[0])) == pytest.approx(0.01, rel=1e-6)
    back = read_runs(write_runs(tmp_path / "back.csv", loaded.records))
    for a, b in zip(loaded.records, back.records):
        assert a.driven == b.driven
        for x, y in zip(a.angles_rad, b.angles_rad):
            assert np.allclose(x, y, rtol=0, atol=1e-15)




def test_every_gap_in_a_trains_positions_is_named(tmp_path):
    path = _train_csv(tmp_path / "g.csv", ["run", "time", "torque1", "phi1", "phi2", "phi4"], _rows(angles=3))
    with pytest.raises(RunsFileError, match="missing phi3"):
        read_runs(path)


def test_a_slides_file_is_read_in_m_and_N(tmp_path):
    # One body on a slide: time in ms, force in kN, position in mm; the records hold SI (m, N),
    # the layout says "slide", and the written file reads back the same.
    rows = [[k * 1.0, 0.05 * math.cos(2 * math.pi * 10 * k * 1e-3), 351.2 + 20 * math.cos(2 * math.pi * 10 * k * 1e-3 - 0.3)]
            for k in range(400)]
    path = _train_csv(tmp_path / "axis.csv", ["time [ms]", "force [kN]", "x [mm]"], rows)
    loaded = read_runs(path)
    assert loaded.kind == "slide" and loaded.records[0].n_flywheels == 1
    r = loaded.records[0]
    # (tolerances as in the test above: 9 digits written; a sampled peak 1e-3)
    assert np.max(np.abs(r.torques_Nm[0])) == pytest.approx(50.0, rel=1e-6)
    assert np.ptp(r.angles_rad[0]) / 2 == pytest.approx(0.020, rel=1e-3) and r.angles_rad[0].mean() == pytest.approx(0.3512)
    assert not any("phi" in n or "torque" in n for n in note_words(loaded.notes)), loaded.notes  # the file's names


@pytest.mark.parametrize("column,match", [
    ("twist", r"the twist phi2 - phi3 of joint 2 drifts"),
    ("torque", r"column 'torque1' drifts"),
])
def test_a_trains_drifting_twist_or_torque_is_refused_naming_it(tmp_path, column, match):
    # A slipping encoder on flywheel 3 (its angle ramps by 20% of the swing over the record), or
    # a torque amplifier's drift, in a steady-state record: refused, naming the joint or column.
    rows = _rows(n=600)
    for r in rows:
        ramp = r[1] / 0.6  # 0..1 over the record
        if column == "twist":
            r[5] += 0.2 * 0.03 * ramp
        else:
            r[2] += 10.0 * ramp
    path = _train_csv(tmp_path / "d.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], rows)
    with pytest.raises(RunsFileError, match=match):
        read_runs(path)


def test_a_trains_common_rotation_is_removed_with_a_note(tmp_path):
    # The whole train turning at 2 rad/s on top of its vibration loads no joint: removed, said.
    rows = _rows(n=600)
    for r in rows:
        for k in (3, 4, 5):
            r[k] += 2.0 * r[1]
    loaded = read_runs(_train_csv(tmp_path / "c.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], rows))
    a = loaded.records[0].angles_rad
    assert any("moves steadily at 2 rad/s" in n for n in note_words(loaded.notes)), loaded.notes
    # what is left is the vibration's own least-squares slope over 6 periods (1.7e-4 rad/s)
    assert abs(np.polyfit(loaded.records[0].time_s, a[0], 1)[0]) < 1e-3
    # ... on every body, the last one too: each angle is the same file's without the turning, to
    # 1e-8 rad (the 9 digits written of angles up to 1.2 rad; 4.9e-9 measured)
    plain = read_runs(_train_csv(tmp_path / "p.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"],
                                 _rows(n=600))).records[0].angles_rad
    for x, y in zip(a, plain):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-8)


def test_a_single_body_turning_steadily_is_not_a_transient(tmp_path):
    # One body (no joint, so no twist): its position's mean may move from period to period (a
    # free body turns as a whole), so its transient test leaves the mean out. Turning at 2 rad/s
    # over 10 periods, every period alike but for its mean: all 10 kept, no transient named, the
    # common motion removed and said.
    from jointrig.measured.notes import TransientCut

    rows = _rows(n=1000, angles=1)
    for r in rows:
        r[3] += 2.0 * r[1]
    loaded = read_runs(_train_csv(tmp_path / "one.csv", ["run", "time", "torque1", "phi1"], rows))
    assert loaded.records[0].n_periods == 10
    assert not any(isinstance(n, TransientCut) for n in loaded.notes), loaded.notes
    assert any("moves steadily at 2 rad/s" in n for n in note_words(loaded.notes)), loaded.notes


def test_a_trains_angles_in_degrees_with_their_unit_are_read(tmp_path):
    # 400 "units" of swing refused without a unit (above) are read when the header says deg.
    path = _train_csv(tmp_path / "deg.csv", ["run", "time", "torque1", "phi1 [deg]", "phi2 [deg]", "phi3 [deg]"],
                      _rows(scale=400.0))
    r = read_runs(path).records[0]
    assert np.ptp(r.angles_rad[0]) / 2 == pytest.approx(math.radians(400 * 0.01), rel=1e-3)  # a sampled peak


def test_a_run_of_two_whole_periods_is_enough_to_read(tmp_path):
    rows = _rows(n=200)  # 10 Hz at 1 kHz: exactly 2 periods
    assert read_runs(_train_csv(tmp_path / "p.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], rows)
                     ).records[0].n_periods == 2


def test_the_loaders_edges(tmp_path):
    # The shortest record read: 16 samples, 2 periods of 8. A value of exactly 1e12 in SI (the
    # bound) is read, one above it refused. A mapping's value may hold '=' itself.
    from jointrig.measured.runs import MAX_ABS_VALUE, parse_mapping

    t = np.arange(16) * 0.125
    rows = [[0, t[k], 10 * math.cos(2 * math.pi * t[k]), 0.01 * math.cos(2 * math.pi * t[k] + 0.2),
             0.005 * math.cos(2 * math.pi * t[k] + 0.5)] for k in range(16)]
    assert read_runs(_train_csv(tmp_path / "s.csv", ["run", "time", "torque", "phi1", "phi2"], rows)).records[0].n_periods == 2
    rows[3][2] = MAX_ABS_VALUE
    read_runs(_train_csv(tmp_path / "b.csv", ["run", "time", "torque", "phi1", "phi2"], rows))
    rows[3][2] = MAX_ABS_VALUE * 1.01
    with pytest.raises(RunsFileError, match="implausibly large"):
        read_runs(_train_csv(tmp_path / "c.csv", ["run", "time", "torque", "phi1", "phi2"], rows))
    assert parse_mapping("torque=M=drive, phi1 = enc1", "columns") == {"torque": "M=drive", "phi1": "enc1"}


def test_the_relative_angle_alone_is_one_body_driven_by_the_share_of_the_torque_with_its_sign(tmp_path):
    # The joint's twist as one body tied to the frame: J1 J2/(J1 + J2) phi'' + M = s T with s the
    # undriven flywheel's share, and -s T when the torque drives flywheel 2 (phi = phi1 - phi2).
    path = _train_csv(tmp_path / "phi.csv", ["run", "time", "torque", "phi"], _rows(torque_cols=1, angles=1))
    on1 = read_runs(path, torque_on="flywheel1", torque_share=0.25)
    on2 = read_runs(path, torque_on="flywheel2", torque_share=0.25)
    assert on1.records[0].n_flywheels == on2.records[0].n_flywheels == 1
    assert np.array_equal(on2.records[0].torques_Nm[0], -on1.records[0].torques_Nm[0])
    assert np.array_equal(on2.records[0].angles_rad[0], on1.records[0].angles_rad[0])
    t = on1.records[0].time_s  # the file's torque is 50 cos(2 pi 10 t), written to 9 digits
    np.testing.assert_allclose(on1.records[0].torques_Nm[0], 0.25 * 50 * np.cos(2 * np.pi * 10 * t), atol=1e-6)
    assert on1.torque_share == on2.torque_share == 0.25
    with pytest.raises(RunsFileError, match="strictly between 0 and 1"):
        read_runs(path, torque_share=1.0)


def test_two_flywheels_are_the_line_of_two_bodies_driven_where_the_torque_acts(tmp_path):
    # Both angles: two bodies, the bodies keep the file's numbering and the torque drives body 1,
    # or body 2 with torque_on="flywheel2"; a shaft's torque is refused with the reason, and a
    # drive train's file names its driven bodies itself.
    path = _train_csv(tmp_path / "two.csv", ["run", "time", "torque", "phi1", "phi2"], _rows(torque_cols=1, angles=2))
    on1, on2 = read_runs(path), read_runs(path, torque_on="flywheel2")
    r1, r2 = on1.records[0], on2.records[0]
    assert r1.n_flywheels == 2 and on1.torque_share is None
    assert r1.torques_Nm[1] is None and r2.torques_Nm[0] is None
    assert np.array_equal(r1.torques_Nm[0], r2.torques_Nm[1])
    assert all(np.array_equal(a, b) for a, b in zip(r1.angles_rad, r2.angles_rad))
    with pytest.raises(RunsFileError, match="the joint's own torque, not a drive"):
        read_runs(path, torque_on="shaft")
    train = _train_csv(tmp_path / "three.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], _rows())
    with pytest.raises(RunsFileError, match="names the driven bodies by its torque<i> columns; leave it out"):
        read_runs(train, torque_on="flywheel2")


def test_how_the_bodies_move_knows_its_names_units_and_words():
    # vocab.params.Coordinate: a str (files, JSON and MuJoCo's word) that knows the rest; a slide's
    # names are the hinge's in N and m, and back
    import json
    import pickle

    from jointrig.vocab.params import HINGE, SLIDE, Coordinate

    assert (SLIDE == "slide", HINGE == "hinge", json.dumps([SLIDE]), Coordinate("slide") is not SLIDE) == \
        (True, True, '["slide"]', True)
    with pytest.raises(ValueError, match="a body moves on a 'hinge' or a 'slide', got 'shaft'"):
        Coordinate("shaft")
    for name in ("J1_kgm2", "joint2_k_Nm_per_rad", "ground1_coulomb_torque_Nm", "bearing3_damping_Nms_per_rad"):
        assert HINGE.name(name) == name == HINGE.project_name(name)
        assert SLIDE.project_name(SLIDE.name(name)) == name
    assert [SLIDE.name(n) for n in ("J1_kgm2", "joint2_k_Nm_per_rad", "bearing3_damping_Nms_per_rad")] == \
        ["m1_kg", "joint2_k_N_per_m", "guide3_damping_Ns_per_m"]
    assert (SLIDE.channel("torque1"), SLIDE.channel("phi2"), HINGE.channel("phi2")) == ("force1", "x2", "phi2")
    assert (HINGE.in_degrees(0.5), SLIDE.in_degrees(0.5)) == (" (28.6 deg)", "")
    assert (HINGE.bodies(4), SLIDE.bodies(3)) == ("a train of 4 bodies", "3 bodies on slides")
    assert (SLIDE.unit, SLIDE.drive_unit, SLIDE.position, HINGE.position, SLIDE.bare_position_is_one_body,
            HINGE.bare_position_is_one_body) == ("m", "N", "x", "phi", True, False)
    back = pickle.loads(pickle.dumps(SLIDE))
    assert back == SLIDE and back.unit == "m" and back.name("J1_kgm2") == "m1_kg"


def test_a_trains_position_that_does_not_vary_is_named_by_its_column(tmp_path):
    # phi1 held constant (a disconnected encoder): the message names phi1, not another body's column.
    rows = [r[:3] + [0.25] + r[4:] for r in _rows()]
    with pytest.raises(RunsFileError, match=r"run 0: column 'phi1' does not vary \(spread 0 rad\)"):
        read_runs(_train_csv(tmp_path / "c.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3"], rows))


def test_a_stated_omega_that_is_the_records_own_period_is_taken_as_stated(tmp_path):
    # 100 samples per period at 1 kHz: the record repeats at 2 pi 10 rad/s. A stated omega that
    # agrees to round-off (1e-9) is the run's, exactly as written, without a note; one 1e-6 off is
    # noted and the record's own period is taken.
    w = 2 * math.pi * 10
    for stated, noted in ((w, False), (w * (1 + 1e-6), True)):
        rows = [r + [stated] for r in _rows()]
        loaded = read_runs(_train_csv(tmp_path / "w.csv", ["run", "time", "torque1", "phi1", "phi2", "phi3", "omega"],
                                      rows))
        written = float(f"{stated:.9g}")  # the file's nine digits
        assert loaded.records[0].omega_rad_s == pytest.approx(w, rel=1e-8)
        assert (loaded.records[0].omega_rad_s == written) == (not noted)
        assert any("column 'omega'" in n for n in note_words(loaded.notes)) == noted, loaded.notes


def test_a_line_of_carriages_reads_its_numbered_positions(tmp_path):
    # The unnumbered 'x' is a single carriage's position, and only a file that holds it may not
    # number others; two carriages numbered x1, x2 are a line of two bodies on slides.
    rows = [r[1:] for r in _rows(angles=2)]
    loaded = read_runs(_train_csv(tmp_path / "two.csv", ["time", "force1", "x1", "x2"], rows))
    assert loaded.kind == "slide" and loaded.records[0].n_flywheels == 2


def test_a_folder_of_trains_is_one_bench_and_another_line_in_it_is_refused(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    for name in ("a.csv", "b.csv", "c.csv"):  # three files of one 3-body train: its runs
        _train_csv(folder / name, ["time", "torque1", "phi1", "phi2", "phi3"], [r[1:] for r in _rows()])
    assert len(read_runs(folder).records) == 3
    _train_csv(folder / "d.csv", ["time", "torque1", "phi1", "phi2", "phi3", "phi4"], [r[1:] for r in _rows(angles=4)])
    with pytest.raises(RunsFileError, match="d.csv: 4 bodies on hinges, the files before it 3 on hinges"):
        read_runs(folder)


def test_a_single_bodys_positions_zeroed_per_run_are_centred_with_a_note_that_says_one_body(tmp_path):
    from jointrig.measured.notes import ZeroPerRun

    rows = [[k * 1.0, 0.05 * math.cos(2 * math.pi * 10 * k * 1e-3), 351.2 + 20 * math.cos(2 * math.pi * 10 * k * 1e-3)]
            for k in range(400)]
    loaded = read_runs(_train_csv(tmp_path / "axis.csv", ["time [ms]", "force [kN]", "x [mm]"], rows), zero_per_run=True)
    assert ZeroPerRun(single=True) in loaded.notes
    assert abs(loaded.records[0].angles_rad[0].mean()) < 1e-9  # centred: its own zero
