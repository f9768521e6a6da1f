"""The diagnosis on files it did not write: an independent bench (tests/bench_sim.py).

The data come from scipy's DOP853 with event-driven dry friction (with a Stribeck peak), a
Jenkins slider and a continuum Iwan element (not the
MuJoCo rig, not ``vocab.law``), written as a DAQ writes them: fixed 2 kHz sampling not
commensurate with the drive, arbitrary start phase, small sensor offsets on all three
channels, 0.2% white noise per channel, time stamps rounded to 0.1 us, units in brackets in
the header, no ``omega`` column. Two joints: the paper's (J 2 + 2 kg m^2, c 100, k 2000,
gamma 200) and a stiff, lightly damped one (c 5 N m s/rad, k 20000 N m/rad, gamma 1e5).
Every catalogued effect at two magnitudes on both joints, and no effect on both.

Acceptance (issue 11): the hidden effect ranked first among the dynamic causes and the only
dynamic cause adopted; its magnitude within 3 standard errors (the diagnosis's own, which
carries the measured model fidelity); the verdict "explained" (the extended model's held-out
error within what a right model misses there, the nominal model's beyond it:
identify.verdict); for no effect nothing dynamic is adopted. A measurement cause (the angle
sensors' zero) may be adopted beside: the bench does offset its sensors.

The diagnosis is the one of every bench (``jointrig diagnose``): two flywheels are the train of
two bodies (:mod:`measured.runs`), the held-out runs replayed in the rig of the file's
bodies. Measured (``.venv/bin/python tests/test_independent_bench.py``, which prints each
case's held-out errors over the noise floor and over what a right model misses, the bound, the
gain, and the propagated and method parts over the noise).
"""

from __future__ import annotations

import math

import pytest

from bench_sim import JOINTS, POINTS, measure, with_effect
from jointrig.identify.causes import CATALOGUE
from jointrig.identify.chain_diagnose import plant_and_inertias
from jointrig.measured.runs import read_runs
from jointrig.rig.chain import rig_of_bodies
from jointrig.studies.chain_validate import run_train_diagnosis
from jointrig.vocab.params import train_name

KIND = {c.name: c.kind for c in CATALOGUE}


#: case -> (bench parameters, {reported magnitude: true value}) per joint; two magnitudes each.
CASES = {
    "paper": {
        "none": ({}, {}),
        "coulomb_friction/1": ({"Fc": 40.0}, {"coulomb_torque_Nm": 40.0}),
        "coulomb_friction/2": ({"Fc": 90.0}, {"coulomb_torque_Nm": 90.0}),
        "backlash/1": ({"gap": 0.01}, {"backlash_half_gap_rad": 0.01}),
        "backlash/2": ({"gap": 0.03}, {"backlash_half_gap_rad": 0.03}),
        "asymmetric_stiffness/1": ({"a": 150.0}, {"a_Nm_per_rad2": 150.0}),
        "asymmetric_stiffness/2": ({"a": 400.0}, {"a_Nm_per_rad2": 400.0}),
        "hysteresis/1": ({"Fs": 50.0, "r": 0.05}, {"hysteresis_slip_torque_Nm": 50.0}),
        "hysteresis/2": ({"Fs": 90.0, "r": 0.02}, {"hysteresis_slip_torque_Nm": 90.0}),
        "quadratic_damping/1": ({"q": 0.5}, {"quadratic_damping_Nms2_per_rad2": 0.5}),
        "quadratic_damping/2": ({"q": 1.5}, {"quadratic_damping_Nms2_per_rad2": 1.5}),
        "drive_delay/1": ({"delay": 0.0005}, {"drive_delay_s": 0.0005}),
        "drive_delay/2": ({"delay": 0.002}, {"drive_delay_s": 0.002}),
        "bearing_friction/1": ({"b2": 3.0}, {"bearing2_damping_Nms_per_rad": 3.0}),
        "bearing_friction/2": ({"b2": 8.0}, {"bearing2_damping_Nms_per_rad": 8.0}),
        "stribeck_friction/1": ({"Fc": 40.0, "Fx": 40.0, "vs": 2.0},
                                {"stribeck_torque_Nm": 40.0, "coulomb_torque_Nm": 40.0, "stribeck_velocity_rad_s": 2.0}),
        "stribeck_friction/2": ({"Fc": 60.0, "Fx": 30.0, "vs": 5.0},
                                {"stribeck_torque_Nm": 30.0, "coulomb_torque_Nm": 60.0, "stribeck_velocity_rad_s": 5.0}),
        # a continuum Iwan element in the bench (closed-form backbone, Masing's rule), chi = -0.5, beta = 0.1
        "micro_slip/1": ({"Fi": 60.0, "smax": 0.15}, {"iwan_slip_torque_Nm": 60.0, "iwan_slip_angle_rad": 0.15}),
        "micro_slip/2": ({"Fi": 120.0, "smax": 0.3}, {"iwan_slip_torque_Nm": 120.0, "iwan_slip_angle_rad": 0.3}),
        # the free play's damping only in contact (a rubber insert with play), none within the gap
        "contact_damping/1": ({"gap": 0.01, "c": 0.0, "cc": 100.0},
                              {"backlash_half_gap_rad": 0.01, "contact_c_Nms_per_rad": 100.0}),
        "contact_damping/2": ({"gap": 0.03, "c": 0.0, "cc": 100.0},
                              {"backlash_half_gap_rad": 0.03, "contact_c_Nms_per_rad": 100.0}),
        # a joint that sticks most of its cycle: 57-61% at the lower level, 10-19% at the higher
        "coulomb_friction/sticks": ({"Fc": 650.0}, {"coulomb_torque_Nm": 650.0}),
    },
    "light": {
        "none": ({}, {}),
        "coulomb_friction/1": ({"Fc": 20.0}, {"coulomb_torque_Nm": 20.0}),
        "coulomb_friction/2": ({"Fc": 50.0}, {"coulomb_torque_Nm": 50.0}),
        "backlash/1": ({"gap": 0.003}, {"backlash_half_gap_rad": 0.003}),
        "backlash/2": ({"gap": 0.008}, {"backlash_half_gap_rad": 0.008}),
        "asymmetric_stiffness/1": ({"a": 5000.0}, {"a_Nm_per_rad2": 5000.0}),
        "asymmetric_stiffness/2": ({"a": 15000.0}, {"a_Nm_per_rad2": 15000.0}),
        "hysteresis/1": ({"Fs": 30.0, "r": 0.003}, {"hysteresis_slip_torque_Nm": 30.0}),
        "hysteresis/2": ({"Fs": 60.0, "r": 0.01}, {"hysteresis_slip_torque_Nm": 60.0}),
        "quadratic_damping/1": ({"q": 0.15}, {"quadratic_damping_Nms2_per_rad2": 0.15}),
        "quadratic_damping/2": ({"q": 0.4}, {"quadratic_damping_Nms2_per_rad2": 0.4}),
        "drive_delay/1": ({"delay": 0.0002}, {"drive_delay_s": 0.0002}),
        "drive_delay/2": ({"delay": 0.0005}, {"drive_delay_s": 0.0005}),
        # on this joint (c = 5) a drag of 3 (5) is found and sized right but pays off only 2.6x
        # (4.1x): the extended model stays 13x the noise floor near the resonance
        "bearing_friction/1": ({"b2": 8.0}, {"bearing2_damping_Nms_per_rad": 8.0}),
        "bearing_friction/2": ({"b2": 12.0}, {"bearing2_damping_Nms_per_rad": 12.0}),
        "stribeck_friction/1": ({"Fc": 20.0, "Fx": 20.0, "vs": 1.0},
                                {"stribeck_torque_Nm": 20.0, "coulomb_torque_Nm": 20.0, "stribeck_velocity_rad_s": 1.0}),
        "stribeck_friction/2": ({"Fc": 30.0, "Fx": 40.0, "vs": 2.0},
                                {"stribeck_torque_Nm": 40.0, "coulomb_torque_Nm": 30.0, "stribeck_velocity_rad_s": 2.0}),
        "micro_slip/1": ({"Fi": 25.0, "smax": 0.02}, {"iwan_slip_torque_Nm": 25.0, "iwan_slip_angle_rad": 0.02}),
        "micro_slip/2": ({"Fi": 40.0, "smax": 0.05}, {"iwan_slip_torque_Nm": 40.0, "iwan_slip_angle_rad": 0.05}),
        # the free play's damping only in contact, none within the gap
        "contact_damping/1": ({"gap": 0.003, "c": 0.0, "cc": 5.0},
                              {"backlash_half_gap_rad": 0.003, "contact_c_Nms_per_rad": 5.0}),
        "contact_damping/2": ({"gap": 0.008, "c": 0.0, "cc": 5.0},
                              {"backlash_half_gap_rad": 0.008, "contact_c_Nms_per_rad": 5.0}),
    },
}

#: 6 runs: 3 frequencies x the lowest and highest level; the middle frequency's two runs are
#: held out (the fit sees the outer frequencies: validation interpolates in frequency).
HOLDOUT = (2, 3)


def _points(joint: str):
    pts = POINTS[joint]
    return [p for i, p in enumerate(pts) if i % 3 != 1]


def _diagnose(tmp_path, joint: str, case: str, relative: bool = False):
    params, _ = CASES[joint][case]
    bench = with_effect(JOINTS[joint], **params)
    seed = sum(map(ord, joint + case))
    path = measure(bench, _points(joint), tmp_path / "bench.csv", seed=seed, fs_Hz=2000.0, n_periods=6.5,
                   relative=relative)
    loaded = read_runs(path)  # the relative angle: the share of two equal flywheels, 0.5
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(1 if relative else 2, [1]),
                               holdout=HOLDOUT, form="relative" if relative else "train")


#: The suite's cases: no effect on both joints, and every effect at its smaller magnitude (the
#: harder to find) on one joint, the paper's and the light one's in turn down the catalogue;
#: the other joint and the larger magnitudes are measured with the figures below
#: (``.venv/bin/python tests/test_independent_bench.py``: every case, 38 of them, and the
#: relative angle's).
_EFFECTS = [c for c in CASES["paper"] if c.endswith("/1")]
SUITE = [(j, "none") for j in CASES] + [("paper" if k % 2 == 0 else "light", c) for k, c in enumerate(_EFFECTS)]


#: Cases the diagnosis gets wrong today, each with what is wrong and its issue: the test is
#: expected to fail on them, and strictly (it fails the run when one passes, so the mark goes).
#: None today: the light joint's Stribeck excess, which read 15.47 +- 1.48 N m against the
#: bench's 20 with the fundamental read from the torque alone, reads 18.72 +- 1.05 with the
#: twist's frequency combined in (its speed 1.054 +- 0.023 rad/s against 1; the Stribeck law's
#: coverage over seeds is docs/noisy-measurements.md's).
KNOWN_MISSES: dict = {}


@pytest.mark.slow
@pytest.mark.parametrize("joint, case", [
    pytest.param(j, c, marks=pytest.mark.xfail(strict=True, reason=KNOWN_MISSES[(j, c)])) if (j, c) in KNOWN_MISSES
    else (j, c) for j, c in SUITE])
def test_independent_bench_effect_is_found_sized_and_pays_off(tmp_path, joint, case):
    _accept(_diagnose(tmp_path, joint, case), joint, case)


#: The relative angle alone (one twist sensor): the joint's twist as one body tied to the frame
#: by the joint's law (:mod:`measured.runs`), its causes sought there; a cause of each
#: kind the form can hold (the sliders' memory replayed at a body's law to ground).
#: The suite runs the sliders' (hysteresis, micro-slip) and no effect; the script all of them.
RELATIVE = [("paper", "hysteresis/1"), ("light", "micro_slip/1"), ("paper", "none"), ("paper", "backlash/1"),
            ("light", "coulomb_friction/1")]


@pytest.mark.slow
@pytest.mark.parametrize("joint, case", RELATIVE[:3])
def test_the_relative_angle_alone_is_diagnosed_as_one_body(tmp_path, joint, case):
    _accept(_diagnose(tmp_path, joint, case, relative=True), joint, case, relative=True)


@pytest.mark.slow
def test_a_joint_that_sticks_most_of_its_cycle_is_explained_with_every_parameter_within_3_se(tmp_path):
    # Issue 50: where the joint sticks, its two flywheels' equations are balanced as their sum and
    # the undriven one's on its own where it slides. Every parameter of the law, not only the
    # friction, within 3 standard errors. Over seeds 0-9 of this file
    # (``.venv/bin/python scripts/bench_sticking.py --seeds 0-9``) all 10 are explained with dry
    # friction alone, chi2/dof 0.75-1.06, and 9 of 10 have every parameter within 3 SE (seed 7:
    # k at -2.96, gamma at +3.44); RMS z 0.7-1.36 per parameter.
    report = _diagnose(tmp_path, "paper", "coulomb_friction/sticks")
    _accept(report, "paper", "coulomb_friction/sticks")
    d = report.diagnosis
    assert [s.label for s in d.steps] == ["coulomb_friction at joint 1"]
    assert any(left < 1.0 for *_, left in d.stuck_joints)  # balanced where it slides
    params = d.final.parameters()
    truth = {"J1_kgm2": 2.0, "J2_kgm2": 2.0, "joint1_c_Nms_per_rad": 100.0, "joint1_k_Nm_per_rad": 2000.0,
             "joint1_gamma_Nm_per_rad3": 200.0}
    for name, true in truth.items():
        assert abs(params[name] - true) <= 3 * d.final.std_error(name), (name, params[name], true)


@pytest.mark.slow
def test_a_jenkins_element_below_one_samples_resolution_is_not_named_with_confidence(tmp_path):
    # At 10% noise on every channel (20 dB) the Jenkins element's slip angle (0.05 rad) reads
    # below one sample's angle resolution (about 0.04 rad), and the element sits at the edge of
    # detection: over the runs' last six periods its chi-square drop (27) gives p = 7.8e-5
    # against the 1e-3 / 14 causes' 7.1e-5 (over the first six it passed). Either way no cause
    # is named with confidence: where the element is significant, it stands (chi-square tells
    # its slip angle from zero, dry friction: identify.causes.told_from_zero) and an Iwan element
    # explains the runs as well, so whichever is adopted the other is reported as not told apart,
    # with the runs that would (several small amplitudes); where it is not, nothing is adopted and
    # the verdict names no cause. Refused as dry friction, the Jenkins element was once named an
    # Iwan element with no word of doubt.
    params, _ = CASES["paper"]["hysteresis/1"]
    path = measure(with_effect(JOINTS["paper"], **params), _points("paper"), tmp_path / "bench.csv",
                   seed=sum(map(ord, "paperhysteresis/1")), fs_Hz=2000.0, n_periods=6.5, noise=0.1)
    loaded = read_runs(path)
    report = run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=HOLDOUT)
    d = report.diagnosis
    slips = {"hysteresis at joint 1", "micro_slip at joint 1"}
    jenkins = next(s for s in d.first_round if s.label == "hysteresis at joint 1")
    assert jenkins.note is None, jenkins  # never refused as below resolution
    adopted = [s.label for s in d.steps]
    if not jenkins.significant:
        assert adopted == [] and report.verdict.causes == () and report.verdict.verdict != "explained", (
            adopted, report.verdict)
        return
    assert len(adopted) == 1 and adopted[0] in slips, adopted
    (other,) = slips - set(adopted)
    told = [a for a in d.ambiguities if set(a.effects) == {adopted[0], other}]
    assert len(told) == 1 and "several small amplitudes" in told[0].excitation, d.ambiguities


def _accept(report, joint: str, case: str, relative: bool = False) -> None:
    """The acceptance (module docstring), as assertions; ``relative``: the law's parameters are
    body 1's to ground (``ground1_*``), the inertia J1 J2/(J1 + J2)."""
    d = report.diagnosis
    # The relative angle's zero (one twist sensor with its own offset) is not yet part of a body's
    # law to ground as a twist's zero is of a joint's: under the cubic it reads as an even
    # stiffness, which the report reads back as that zero (present.train_report.offset_readings).
    offset = {c.name for c in CATALOGUE if c.reads_as_offset} if relative else set()
    dynamic = [s.effect for s in d.steps if KIND[s.effect] == "dynamic" and s.effect not in offset]
    ranked = [c.effect for c in d.first_round if KIND[c.effect] == "dynamic"]
    table = [(c.label, round(c.score), c.significant, c.note) for c in d.first_round]
    if case == "none":
        assert dynamic == [], table
        assert report.verdict.verdict == "no_misfit", report.verdict
        return
    assert report.verdict.verdict == "explained", report.verdict
    effect = case.split("/")[0]
    first = d.first_round[[c.effect for c in d.first_round].index(effect)]
    assert ranked[0] == effect and first.significant, table
    assert dynamic == [effect], (dynamic, table)
    params = d.final.parameters()
    if relative:
        assert abs(params["J1_kgm2"] - 1.0) <= 3 * d.final.std_error("J1_kgm2")  # 2 and 2 kg m^2: 1
    for name, true in CASES[joint][case][1].items():  # a Stribeck friction: all three of its parameters
        name = "ground1_" + name if relative else train_name(name)
        value, se = params[name], d.final.std_error(name)
        assert math.isfinite(se) and se > 0
        assert abs(value - true) <= 3 * se, (name, value, se, true)
    # The model reported is the model simulated: a drag fitted below 0 is simulated as 0.
    plant, _ = plant_and_inertias(d.final)
    assert all(b >= 0 for b in plant.bearings_Nms_per_rad)


def _figures(case):
    import tempfile
    from pathlib import Path

    joint, name, *relative = case
    with tempfile.TemporaryDirectory() as tmp:
        r = _diagnose(Path(tmp), joint, name, relative=bool(relative))
    d, v = r.diagnosis, r.validation
    try:
        _accept(r, joint, name, relative=bool(relative))
        ok = "ok"
    except AssertionError:
        ok = "FAILS"
    name = name + (" (phi)" if relative else "")
    return (f"{ok:5s} {joint:6s} {name:24s} {r.verdict.verdict:12s} {'+'.join(s.label for s in d.steps) or '-':44s} "
            f"{d.reduced_chi2(d.nominal):8.3g} {d.reduced_chi2(d.final):8.3g} "
            f"{v.nominal_error / v.noise_floor:8.3g} {v.extended_error / v.noise_floor:8.3g} {v.gain:8.3g} "
            f"{v.nominal_error / v.expected_error:8.3g} {v.extended_error / v.expected_error:8.3g} {v.bound:6.3g} "
            f"{v.right.propagated / v.right.noise:6.2g} {v.right.method / v.right.noise:6.2g}")


if __name__ == "__main__":
    # Every case (the suite runs SUITE), then the relative angle's (RELATIVE, "(phi)"), with its
    # acceptance and the figures behind the verdict's thresholds (identify/verdict.py), on two cores:
    #   .venv/bin/python tests/test_independent_bench.py
    from concurrent.futures import ProcessPoolExecutor

    from jointrig.rig.runtime import limit_threads

    limit_threads()
    print(f"{'':5s} {'joint':6s} {'case':24s} {'verdict':12s} {'adopted':44s} {'chi2/dof':>8s} {'ext.':>8s} "
          f"{'nom/flr':>8s} {'ext/flr':>8s} {'gain':>8s} {'nom/rgt':>8s} {'ext/rgt':>8s} {'bound':>6s} {'prop/n':>6s} {'met/n':>6s}")
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(_figures, [(j, c) for j in CASES for c in CASES[j]] + [(j, c, "phi") for j, c in RELATIVE]):
            print(row, flush=True)
