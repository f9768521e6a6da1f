"""Sensors as a lab has them (issue 49): every encoder with its own zero, a torque cell's offset.

The files come from the independent bench (tests/bench_sim.py: scipy, event-driven friction and
free play), each encoder's zero drawn uniform in +-pi and the torque cell's offset up to 2% of the
largest drive amplitude, added before the bench's own small offsets and its 0.2% noise (the same
noise as the zeroed file's: the bench draws it after the offsets). The diagnosis takes every angle
channel about its mean over the fitted runs (identify/zeros.py) and reads each twist's zero on
top, so the verdict, the causes and every parameter are those of the zeroed sensors; the zero
read and the torque's mean are each within 3 of their standard errors of what the bench added.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bench_sim import JOINTS, POINTS, measure, with_effect
from jointrig.identify.zeros import rezeroed, sensor_zeros
from jointrig.measured.runs import read_runs
from jointrig.present.train_report import reported_values, format_train_report, offset_readings, train_report_json
from jointrig.rig.chain import rig_of_bodies
from jointrig.studies.chain_validate import run_train_diagnosis

#: The two runs of the middle frequency held out, as tests/test_independent_bench.py holds them.
HOLDOUT = (2, 3)
EFFECT = {"none": {}, "backlash": {"gap": 0.003}}


def _file(tmp_path, joint: str, effect: str, zeros_rad=(0.0, 0.0), torque_offset_Nm: float = 0.0, seed: int = 7):
    pts = [p for i, p in enumerate(POINTS[joint]) if i % 3 != 1]

    def unzeroed(t, T, p1, p2):
        return t, T + torque_offset_Nm, p1 + zeros_rad[0], p2 + zeros_rad[1]

    name = f"{joint}-{effect}-{zeros_rad[0]:.3f}-{zeros_rad[1]:.3f}.csv"
    return measure(with_effect(JOINTS[joint], **EFFECT[effect]), pts, tmp_path / name, seed=seed, fs_Hz=2000.0,
                   n_periods=6.5, transform=unzeroed)


def _bench_offsets(seed: int) -> np.ndarray:
    """The bench's own sensor offsets (torque N m, phi1 rad, phi2 rad): its first draw
    (bench_sim.measure)."""
    return np.random.default_rng(seed).uniform(-1, 1, 3) * np.array([0.5, 2e-3, 2e-3])


def _diagnose(path, zeroed: bool = False):
    loaded = read_runs(path)
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=HOLDOUT,
                               zeroed=zeroed)


@pytest.mark.slow
@pytest.mark.parametrize("joint, effect", [("paper", "none"), ("light", "backlash")])
def test_encoders_with_their_own_zeros_give_the_zeroed_diagnosis_and_read_the_zero(tmp_path, joint, effect):
    rng = np.random.default_rng(sum(map(ord, joint + effect)))
    zeros = rng.uniform(-math.pi, math.pi, 2)
    amp = max(M0 for _, M0 in POINTS[joint])
    offset = rng.uniform(-0.02, 0.02) * amp
    zeroed = _diagnose(_file(tmp_path, joint, effect))
    lab = _diagnose(_file(tmp_path, joint, effect, tuple(zeros), offset))
    assert lab.verdict.verdict == zeroed.verdict.verdict, (lab.verdict, zeroed.verdict)
    assert [s.label for s in lab.diagnosis.steps] == [s.label for s in zeroed.diagnosis.steps]
    want = reported_values(zeroed.diagnosis.final, zeroed)
    got = reported_values(lab.diagnosis.final, lab)
    assert got.keys() == want.keys()
    bench = _bench_offsets(7)
    for name, (value, se) in got.items():
        if name == "joint1_angle_offset_rad":  # the zero each reads: the bench's own, and the one added
            continue
        assert abs(value - want[name][0]) <= 3 * want[name][1], (name, value, want[name])
    # the twist's zero read, against what the bench added: a symmetric joint under a drive with no
    # mean twists about its rest (the rubber joint's cubic law and the free play read it in the fit)
    value, se = got["joint1_angle_offset_rad"]
    truth = zeros[0] - zeros[1] + bench[1] - bench[2]
    assert abs(value - truth) <= 3 * se, (value, se, truth)
    # the torque cell's offset: a train free to turn carries no mean torque
    mean, se_t = lab.zeros.torques[0], lab.zeros.torque_se[0]
    assert abs(mean - (offset + bench[0])) <= 3 * se_t, (mean, se_t, offset + bench[0])
    # where the joint's zero is read from the data (its cubic, or its free play), the torque its
    # law carries at the mean twist (none: nothing loads the train) leaves the cell's offset alone
    from jointrig.present.train_report import _held_load

    held = _held_load(lab, 1)
    assert held is not None
    rest, rest_se = mean - held[0], math.hypot(se_t, held[1])
    assert abs(rest - (offset + bench[0])) <= 3 * rest_se, (rest, rest_se, offset + bench[0])
    text = format_train_report(lab)
    assert "reads" in text and "at rest: the angle sensors were not zeroed together" in text, text[:2000]
    assert f"averages {mean:.4g}" in text
    # the report's first screen says it too, before the causes
    from jointrig.present.train_report import write_train_html

    write_train_html(tmp_path / "r.html", lab, text, title="t")
    page = (tmp_path / "r.html").read_text()
    assert page.index("What your sensors read at rest") < page.index("Extended model"), page[:3000]
    # the JSON's twist zero is the one read, as the text's
    j = train_report_json(lab)
    assert j["extended"]["parameters"]["joint1_angle_offset_rad"] == pytest.approx(value, rel=1e-12)


@pytest.mark.slow
def test_zeroed_sensors_are_kept_and_checked_against_the_data(tmp_path):
    # --zeroed keeps the encoders' zeros: nothing is taken out of the records, and where the data's
    # mean twist says the encoders were not zeroed together, the report says so.
    path = _file(tmp_path, "paper", "none", (2.0, 0.5))
    loaded = read_runs(path)
    kept = sensor_zeros(loaded.records, keep=True)
    assert kept.angles == (0.0, 0.0) and all(rezeroed(r, kept) is r for r in loaded.records)
    report = _diagnose(path, zeroed=True)
    assert report.zeros.kept and report.zeros.twists[0] == pytest.approx(1.5, abs=0.01)
    (line,) = [s for s in offset_readings(report) if "--zeroed" in s]
    assert "the twist of joint 1 (phi1 - phi2) averages 1.5" in line, line


@pytest.mark.slow
def test_a_constant_force_on_a_free_carriage_is_reported_and_changes_nothing(tmp_path):
    # The independent carriage (12 kg, 40 N s/m, 25 N of dry friction; one long run at 150 N),
    # its force sensor reading 6 N at rest (or a constant load: the two are the same data): the
    # verdict and the friction as without it, each parameter within 3 of its standard errors of
    # the zeroed sensor's, the mean force reported within 3 standard errors of the 6 N.
    from bench_slide_sim import Carriage, daq_file as slide_file

    def diagnosed(path):
        loaded = read_runs(path)
        return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(1, [1], "slide"))

    zeroed = diagnosed(slide_file(Carriage(), 12.566, 150.0, tmp_path / "a.csv"))
    loaded = diagnosed(slide_file(Carriage(), 12.566, 150.0, tmp_path / "b.csv", force_offset_N=6.0))
    assert loaded.verdict.verdict == zeroed.verdict.verdict == "explained"
    assert [s.label for s in loaded.diagnosis.steps] == [s.label for s in zeroed.diagnosis.steps]
    want, got = reported_values(zeroed.diagnosis.final, zeroed), reported_values(loaded.diagnosis.final, loaded)
    for name, (value, se) in got.items():
        assert abs(value - want[name][0]) <= 3 * want[name][1], (name, value, want[name])
    mean, se = loaded.zeros.torques[0], loaded.zeros.torque_se[0]
    assert abs(mean - 6.0) <= 3 * se if math.isfinite(se) else abs(mean - 6.0) < 0.1, (mean, se)
    line = [s for s in offset_readings(loaded) if s.startswith("the drive force on body 1 averages")]
    assert line and "a carriage free to move" in line[0] and "gravity on the axis" in line[0], line


def test_a_channels_mean_over_few_runs_has_a_standard_error_that_covers():
    # identify.zeros.channel_mean over 4000 draws of 4 runs x 6 periods of white noise about a
    # known mean. The runs' spread alone (3 degrees of freedom) covered 85.6% at 1.96 and passed
    # 3 standard errors in 5.6% (a t with 3 degrees of freedom); the larger of the spread's and
    # the noise's (20 degrees of freedom, each period's mean about its run's) covers 95.4% and
    # passes 3 in 0.4% (the Gaussian's 0.27%). Bounds: 4000 draws give +-0.35% on 95% and
    # +-0.1% on 0.27% (binomial SE); a spread-only error fails both.
    from jointrig.identify.zeros import channel_mean

    rng = np.random.default_rng(0)
    z = []
    for _ in range(4000):
        m, se = channel_mean([0.3 + rng.standard_normal(6 * 50) for _ in range(4)], [6] * 4)
        z.append(abs(m - 0.3) / se)
    z = np.array(z)
    assert 0.94 <= np.mean(z <= 1.96) <= 0.975 and np.mean(z > 3) <= 0.008
    # runs that differ by a load beyond their noise keep their spread: the means 0, 1, 2, 3
    runs = [k + 0.01 * rng.standard_normal(6 * 50) for k in range(4)]
    m, se = channel_mean(runs, [6] * 4)
    assert m == pytest.approx(1.5, abs=0.01) and se == pytest.approx(np.std([0, 1, 2, 3], ddof=1) / 2, rel=0.01)
    # one run of 5 periods: the noise's error (the periods' means' spread over sqrt(5)), not NaN
    one = 0.3 + rng.standard_normal(5 * 40)
    m, se = channel_mean([one], [5])
    assert se == pytest.approx(np.std(one.reshape(5, -1).mean(axis=1), ddof=1) / math.sqrt(5))
    assert math.isnan(channel_mean([one], [1])[1])  # one run of one period: nothing to go on
    two = one[:80]  # one run of 2 periods: one degree of freedom is enough for the noise's error
    assert channel_mean([two], [2])[1] == pytest.approx(abs(two[:40].mean() - two[40:].mean()) / 2)


def test_sensor_zeros_are_the_channels_means_with_their_spread_across_runs():
    # identify.zeros.sensor_zeros on records made by hand, one noise-free period each: each
    # channel's mean per run, their mean and its standard error across runs (std / sqrt(runs),
    # ddof 1; NaN with one run: no period's spread either); an angle
    # not measured takes nothing out and has no twist; the user's zeros kept with keep=True.
    from jointrig.identify.chain import ChainRecord

    t = np.arange(64) / 64 * (2 * np.pi / 10.0)
    s = np.sin(10.0 * t)

    def rec(a1, a2, a3, torque_mean, measured3=True):
        return ChainRecord(10.0, t, (torque_mean + s, None, None),
                           (a1 + s, a2 + 0.5 * s, (a3 + 0.2 * s) if measured3 else None))

    runs = [rec(1.0, 0.25, -2.0, 3.0), rec(1.2, 0.25, -2.0, 5.0)]
    z = sensor_zeros(runs)
    assert z.angles == pytest.approx((1.1, 0.25, -2.0)) and z.twists == pytest.approx((0.85, 2.25))
    assert z.twist_se[0] == pytest.approx(0.1) and z.twist_se[1] == pytest.approx(0.0, abs=1e-12)
    assert z.torques[0] == pytest.approx(4.0) and z.torque_se[0] == pytest.approx(1.0)
    assert math.isnan(z.torques[1]) and not z.kept
    assert rezeroed(runs[0], z).angles_rad[0] == pytest.approx(s - 0.1)
    assert rezeroed(runs[0], None) is runs[0]  # nothing to take out: the record itself
    one = sensor_zeros(runs[:1])
    assert math.isnan(one.angle_se[0]) and math.isnan(one.torque_se[0])
    blind = sensor_zeros([rec(1.0, 0.25, -2.0, 3.0, measured3=False)] * 2)
    assert blind.angles[2] == 0.0 and math.isnan(blind.twists[1])
    kept = sensor_zeros(runs, keep=True)
    assert kept.angles == (0.0, 0.0, 0.0) and kept.twists == pytest.approx((0.85, 2.25)) and kept.kept
