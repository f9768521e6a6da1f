"""Effects outside the catalogue: the diagnosis must say "unexplained" and describe the misfit.

The independent bench (tests/bench_sim.py) hides two effects the catalogue does not know, on
the paper's joint and on the stiff, lightly damped one, under the same DAQ conditions as
tests/test_independent_bench.py:

* a Maxwell element across the joint (a spring in series with a dashpot, relaxation time 1/40 s
  on the paper's joint, 1/130 s on the light one: stiffness and damping that depend on
  frequency, as a rubber joint's do);
* a torque cell with a cubic calibration error (2% at 3500 N m).

Acceptance (issue 13): verdict "unexplained", nothing adopted, and a description whose numbers
match what each effect is.

One angle (phi2) read 1 ms late, a DAQ's channel skew, was the first of these; it is now the
catalogue's measurement cause ``angle_skew`` and must be found as such. A torque periodic in the
joint angle (cogging, pitch 0.05 rad) was the third; it is now the catalogue's ``cogging``, found
with its amplitude and pitch (the last tests).
"""

from __future__ import annotations

import math

import pytest

from bench_sim import (JOINTS, POINTS, cogging, late_channel, maxwell, measure, scaled_channel, torque_calibration,
                       with_effect)
from jointrig.measured.runs import read_runs
from jointrig.studies.validate import run_diagnosis

HOLDOUT = (2, 3)
#: Held-out runs for the torque cell's calibration error: the lowest level's middle frequency and
#: the highest level's lowest one (the other level of the runs at 25 and 40 rad/s). A cubic error
#: grows as T^3, quadratic damping as the rate squared: at the held-out middle frequency and the
#: fit's own levels (HOLDOUT) quadratic damping predicts 8x better than the nominal model and
#: passes for the cause (gain 7.95, measured once the rig simulated the identified inertias);
#: at another level it fails (gain 1.3), as a test engineer's check at another level would show.
LEVEL_HOLDOUT = (1, 3)


def _points(joint):
    return [p for i, p in enumerate(POINTS[joint]) if i % 3 != 1]


CASES = {
    # corner frequencies 40 and 130 rad/s, inside each joint's drive band
    "maxwell": lambda joint: (maxwell(JOINTS[joint], *({"paper": (1000.0, 1 / 40), "light": (6000.0, 1 / 130)}[joint])),
                              None),
    "torque_calibration": lambda joint: (JOINTS[joint], torque_calibration(0.02, 3500.0)),
}

#: Once outside the catalogue, now its ``cogging``: (amplitude N m, pitch rad) per joint.
COGGING = {"paper": (40.0, 0.05), "light": (60.0, 0.05)}


#: Not open-world cases any more: the catalogue's measurement causes (tests below).
MEASUREMENT = {"late_phi2": lambda joint: (JOINTS[joint], late_channel(0.001)),
               "phi2_gain": lambda joint: (JOINTS[joint], scaled_channel(1.02)),
               "cogging": lambda joint: (with_effect(JOINTS[joint], extra=cogging(*COGGING[joint])), None)}


def _report(tmp_path, joint, case):
    bench, transform = {**CASES, **MEASUREMENT}[case](joint)
    path = measure(bench, _points(joint), tmp_path / "bench.csv", seed=sum(map(ord, joint + case)), fs_Hz=2000.0,
                   n_periods=6.5, transform=transform)
    loaded = read_runs(path)
    holdout = LEVEL_HOLDOUT if case == "torque_calibration" else HOLDOUT
    return run_diagnosis(loaded.records, run_ids=loaded.run_ids, holdout=holdout)


@pytest.mark.slow
@pytest.mark.parametrize("joint", ["paper", "light"])
@pytest.mark.parametrize("case", list(CASES))
def test_an_effect_outside_the_catalogue_is_unexplained_and_described(tmp_path, joint, case):
    report = _report(tmp_path, joint, case)
    v = report.verdict
    ch = report.character
    info = (v, report.diagnosis.effects, ch.describe())
    assert v.verdict == "unexplained", info
    assert report.adopted == (), info
    surface, nxt = report.surface, " | ".join(report.next_measurements)
    info += (surface.describe(), nxt)
    # The restoring-force surface follows the residual (measured: it carries 88-100% of its power)
    assert surface.fit_rms_Nm < 0.7 * surface.rms_Nm, info
    if case == "maxwell":
        # linear in the motion (odd), on the fundamental, both elastic and dissipative (its
        # stiffness and damping both change with frequency); measured shares 0.44 and 0.45, and
        # the residual's axis turns with frequency at one level (40 and 86 deg): the next
        # measurement is a finer frequency sweep
        assert ch.even_share < 0.4 and 1 in ch.top_harmonics and 0.25 < ch.dissipative_share < 0.75, info
        assert ch.phase_span_deg > 30 and "more frequencies" in nxt, info
    elif case == "torque_calibration":
        # T^3: odd, on the third harmonic, and growing with the drive level; a reference
        # calibration of the sensors is what tells a sensor from a law
        assert ch.even_share < 0.4 and 3 in ch.top_harmonics and ch.amplitude_slope > 0.5, info
        assert "calibration of the torque cell" in nxt, info
    if (joint, case) == ("paper", "maxwell"):
        _check_shown(report, tmp_path, "more frequencies")


def _check_shown(report, tmp_path, hint):
    """The unexplained misfit reaches the user: the text, the JSON, the HTML report (with the
    surface's figure) and the recording (its tab, the surface, the sections)."""
    import json

    import rerun as rr
    from conftest import blueprint_views
    from jointrig.present.diagnosis_report import format_report, log_diagnosis, report_json, write_html
    from jointrig.present.recording import open_recording

    text = format_report(report)
    assert "Its restoring-force surface: as a surface over (phi, phi')" in text
    assert "measurements that would tell more" in text and hint in text
    out = json.loads(json.dumps(report_json(report)))
    assert out["verdict"]["verdict"] == "unexplained"
    assert out["misfit_surface"]["elastic_share"] == report.surface.elastic_share
    assert len(out["misfit_surface"]["torque_Nm"]) == report.surface.phi_knots_rad.size
    assert out["next_measurements"] == list(report.next_measurements)
    page = write_html(tmp_path / "r.html", report, text).read_text()
    assert "What the unexplained misfit looks like" in page and "restoring-force surface: the residual" in page
    with open_recording(tmp_path / "r.rrd") as rec:
        log_diagnosis(rec, report, text)
    names, origins = blueprint_views(tmp_path / "r.rrd")
    assert "Unexplained misfit" in names
    paths = {str(p) for p in rr.chunk.RrdReader(str(tmp_path / "r.rrd")).store().schema().entity_paths()}
    for entity in ("surface/knots", "surface/loops", "stiffness_section_Nm", "damping_section_Nm", "description"):
        assert f"/diagnosis/misfit/{entity}" in paths, (entity, sorted(paths))


#: measurement artefacts the catalogue knows: case -> (cause, its parameter, true value). Measured:
#: phi2 read 1 ms late (cubic interpolation of the clean record, independent of the diagnosis's
#: harmonic shift): 1.0006 +- 0.026 ms (paper), 1.0009 +- 0.0063 ms (light), gains 69 and 88;
#: phi2 read 1.02 times the truth (an encoder's line count or a gear ratio set wrong):
#: 0.02009 +- 0.00054 (paper), 0.0198 +- 0.0017 (light), gains 115 and 39.
FOUND = {"late_phi2": ("angle_skew", "angle2_delay_s", 0.001),
         "phi2_gain": ("angle_gain", "angle2_gain_error", 0.02)}


@pytest.mark.slow
@pytest.mark.parametrize("joint", ["paper", "light"])
@pytest.mark.parametrize("case", list(FOUND))
def test_a_measurement_artefact_is_found_as_its_sensor_cause(tmp_path, joint, case):
    # The measurement cause alone, within 3 standard errors of the truth, and a gain >= 5
    # (issue 13's bounds for an in-catalogue effect).
    cause, name, true = FOUND[case]
    report = _report(tmp_path, joint, case)
    d = report.diagnosis
    info = (report.verdict, d.effects)
    assert report.verdict.verdict == "explained" and report.adopted == (cause,), info
    assert d.effects_of_kind("measurement") == (cause,)
    value, se = d.extended.effect_parameters()[name], d.extended.std_error(name)
    assert abs(value - true) <= 3 * se, (value, se)
    assert report.gain >= 5, report.gain


@pytest.mark.slow
@pytest.mark.parametrize("joint", ["paper", "light"])
def test_a_torque_periodic_in_the_angle_is_found_as_cogging(tmp_path, joint):
    # Found alone, its amplitude and order within 3 standard errors of the truth, gain >= 5.
    # Measured: paper 39.5 +- 1.4 N m, z = 125.74 +- 0.28 per rad, gain 15.3; light 59.9 +- 0.8,
    # 125.94 +- 0.36, gain 98 (truth 40 / 60 N m, z = 2 pi / 0.05 = 125.66). The order was out
    # of reach while the search stopped at 20 rad of phase at the largest swing.
    amplitude, pitch = COGGING[joint]
    report = _report(tmp_path, joint, "cogging")
    d = report.diagnosis
    assert report.verdict.verdict == "explained" and report.adopted == ("cogging",), (report.verdict, d.effects)
    p = d.extended.effect_parameters()
    order_se = d.extended.std_error("cogging_order_rad_per_rad")
    assert abs(p["cogging_order_rad_per_rad"] - 2 * math.pi / pitch) <= 3 * order_se, (p, order_se)
    assert abs(d.steps[0].magnitude[1] - amplitude) <= 3 * d.steps[0].magnitude[2], d.steps[0].magnitude
    assert report.gain >= 5, report.gain


def _figures(case):
    import tempfile
    from pathlib import Path

    joint, name = case
    with tempfile.TemporaryDirectory() as tmp:
        r = _report(Path(tmp), joint, name)
    d, floor = r.diagnosis, r.noise_floor_rad
    return (f"{joint:6s} {name:20s} {r.verdict.verdict:12s} tried {'+'.join(d.effects) or '-':30s} gain {r.gain:6.3g} "
            f"chi2/dof {d.extended.chi2 / d.extended.dof:6.3g} held-out/floor "
            f"{r.validation_rms('extended') / floor:6.3g}\n    {r.character.describe()}\n    {r.surface.describe()}\n"
            + "".join(f"    next: {m}\n" for m in r.next_measurements))


if __name__ == "__main__":
    # What the diagnosis says of each effect outside the catalogue:
    #   .venv/bin/python tests/test_open_world.py
    from concurrent.futures import ProcessPoolExecutor

    from jointrig.rig.runtime import limit_threads

    limit_threads()
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(_figures, [(j, c) for c in CASES for j in ("paper", "light")]):
            print(row, flush=True)
