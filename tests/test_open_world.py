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
from jointrig.present.misfit_words import measurement_text, misfit_texts
from jointrig.rig.chain import rig_of_bodies
from jointrig.studies.chain_validate import run_train_diagnosis

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
    """The diagnosis of every bench (``jointrig diagnose``): two flywheels as the train of two bodies."""
    bench, transform = {**CASES, **MEASUREMENT}[case](joint)
    path = measure(bench, _points(joint), tmp_path / "bench.csv", seed=sum(map(ord, joint + case)), fs_Hz=2000.0,
                   n_periods=6.5, transform=transform)
    loaded = read_runs(path)
    holdout = LEVEL_HOLDOUT if case == "torque_calibration" else HOLDOUT
    return run_train_diagnosis(loaded.records, run_ids=loaded.run_ids, rig=rig_of_bodies(2, [1]), holdout=holdout)


@pytest.mark.slow
@pytest.mark.parametrize("joint", ["paper", "light"])
@pytest.mark.parametrize("case", list(CASES))
def test_an_effect_outside_the_catalogue_is_unexplained_and_described(tmp_path, joint, case):
    report = _report(tmp_path, joint, case)
    v, m = report.verdict, report.misfit
    info = (v, [s.label for s in report.diagnosis.steps], misfit_texts(m) if m is not None else None)
    assert v.verdict == "unexplained" and not report.adopted, info
    ch, surface, nxt = m.character, m.surface, " | ".join(measurement_text(n) for n in m.next_measurements)
    assert m.where == "joint 1", info
    # The restoring-force surface follows the residual (measured: it carries 82-100% of its power)
    assert surface.fit_rms_Nm < 0.7 * surface.rms_Nm, info
    if case == "maxwell":
        # linear in the motion (odd), on the fundamental, not only elastic (its stiffness and
        # damping both change with frequency; the nominal fit takes up part of each: measured
        # dissipative shares 0.84 on the paper's joint), and the residual's axis turns with
        # frequency at one level (84 deg on the paper's joint): the next measurement is a finer
        # frequency sweep
        assert ch.even_share < 0.4 and 1 in ch.top_harmonics and ch.dissipative_share > 0.25, info
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
    from jointrig.present.recording import log_chain_diagnosis, open_recording
    from jointrig.present.train_report import format_train_report, train_report_json, write_train_html

    m = report.misfit
    text = format_train_report(report)
    assert "Its restoring-force surface: as a surface over (phi, phi')" in text
    assert "measurements that would tell more" in text and hint in text
    out = json.loads(json.dumps(train_report_json(report)))
    assert out["verdict"]["verdict"] == "unexplained"
    assert out["misfit_surface"]["elastic_share"] == m.surface.elastic_share
    assert len(out["misfit_surface"]["torque_Nm"]) == m.surface.phi_knots_rad.size
    assert out["next_measurements"] == [measurement_text(n) for n in m.next_measurements]
    page = write_train_html(tmp_path / "r.html", report, text, title="t").read_text()
    assert "What the misfit looks like" in page and "restoring-force surface" in page
    with open_recording(tmp_path / "r.rrd") as rec:
        log_chain_diagnosis(rec, report.diagnosis, report.validation, 2, m, text=text)
    names, origins = blueprint_views(tmp_path / "r.rrd")
    assert "Unexplained misfit at joint 1" in names
    paths = {str(p) for p in rr.chunk.RrdReader(str(tmp_path / "r.rrd")).store().schema().entity_paths()}
    for entity in ("surface/knots", "surface/loops", "stiffness_section_Nm", "damping_section_Nm", "description"):
        assert f"/misfit/{entity}" in paths, (entity, sorted(paths))


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
    # The measurement cause alone, at flywheel 2's angle channel, within 3 standard errors of the
    # truth, and the verdict "explained" (a held-out gain >= 3; measured 18 to 57).
    cause, name, true = FOUND[case]
    report = _report(tmp_path, joint, case)
    d = report.diagnosis
    info = (report.verdict, [s.label for s in d.steps])
    assert report.verdict.verdict == "explained" and [s.label for s in d.steps] == \
        [f"{cause} at body 2's angle channel"], info
    value, se = d.final.parameters()[name], d.final.std_error(name)
    assert abs(value - true) <= 3 * se, (value, se)


@pytest.mark.slow
@pytest.mark.parametrize("joint", ["paper", "light"])
def test_a_torque_periodic_in_the_angle_is_found_as_cogging(tmp_path, joint):
    # Found alone, its amplitude and order within 3 standard errors of the truth, the verdict
    # "explained". Measured: paper 39.5 +- 1.4 N m, z = 125.74 +- 0.28 per rad, gain 8.3; light
    # 59.9 +- 0.8, gain 86 (truth 40 / 60 N m, z = 2 pi / 0.05 = 125.66). The order was out of
    # reach while the search stopped at 20 rad of phase at the largest swing.
    amplitude, pitch = COGGING[joint]
    report = _report(tmp_path, joint, "cogging")
    d = report.diagnosis
    assert report.verdict.verdict == "explained" and [s.label for s in d.steps] == ["cogging at joint 1"], \
        (report.verdict, [s.label for s in d.steps])
    p = d.final.parameters()
    order = "joint1_cogging_order_rad_per_rad"
    order_se = d.final.std_error(order)
    assert abs(p[order] - 2 * math.pi / pitch) <= 3 * order_se, (p, order_se)
    assert abs(d.steps[0].magnitude[1] - amplitude) <= 3 * d.steps[0].magnitude[2], d.steps[0].magnitude


def _figures(case):
    import tempfile
    from pathlib import Path

    joint, name = case
    with tempfile.TemporaryDirectory() as tmp:
        r = _report(Path(tmp), joint, name)
    d, v = r.diagnosis, r.validation
    out = (f"{joint:6s} {name:20s} {r.verdict.verdict:12s} tried {'+'.join(s.label for s in d.steps) or '-':40s} "
           f"gain {v.gain:6.3g} chi2/dof {d.reduced_chi2(d.final):6.3g} held-out/floor "
           f"{v.extended_error / v.noise_floor:6.3g}\n")
    if r.misfit is not None:
        out += "".join(f"    {t}\n" for t in misfit_texts(r.misfit)) + "".join(
            f"    next: {measurement_text(t)}\n" for t in r.misfit.next_measurements)
    return out


if __name__ == "__main__":
    # What the diagnosis says of each effect outside the catalogue:
    #   .venv/bin/python tests/test_open_world.py
    from concurrent.futures import ProcessPoolExecutor

    from jointrig.rig.runtime import limit_threads

    limit_threads()
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(_figures, [(j, c) for c in CASES for j in ("paper", "light")]):
            print(row, flush=True)
