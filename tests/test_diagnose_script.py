"""scripts/make_data.py and scripts/diagnose.py end to end: JSON schema, recording, report, errors."""

import json
from pathlib import Path

import pytest
import rerun as rr

ROOT = Path(__file__).resolve().parent.parent

from jointrig.commands import diagnose  # noqa: E402
from jointrig.commands import make_data  # noqa: E402


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    out = tmp_path_factory.mktemp("diag")
    # The worn model (dry friction 60 N m and free play +-0.03 rad), Parquet this time.
    assert make_data.main([str(out / "worn.parquet"), "--model", str(ROOT / "models" / "two_flywheels_worn.xml"),
                           "--periods", "12", "--seed", "3"]) == 0
    argv = [str(out / "worn.parquet"), "--json", str(out / "d.json"), "--rrd", str(out / "d.rrd"),
            "--report", str(out / "d.html"), "-q"]
    assert diagnose.main(argv) == 0
    return out


def test_json_has_ranked_causes_extended_model_and_gain(outputs):
    d = json.loads((outputs / "d.json").read_text())
    causes = d["causes"]
    assert {c["effect"] for c in causes} == {"coulomb_friction", "backlash", "asymmetric_stiffness", "hysteresis",
                                             "quadratic_damping", "drive_delay", "bearing_friction", "angle_offset"}
    scores = [c["score"] for c in causes if c["note"] == ""]
    assert scores == sorted(scores, reverse=True)  # ranked by evidence
    assert all(isinstance(c["significant"], bool) for c in causes)
    assert set(d["extended"]["effects"]) == {"coulomb_friction", "backlash"}
    assert d["extended"]["effect"] in {"coulomb_friction", "backlash"}
    p = d["extended"]["parameters"]
    # 15%: the bound for a recovered magnitude.
    assert p["coulomb_torque_Nm"] == pytest.approx(60.0, rel=0.15)
    assert p["backlash_half_gap_rad"] == pytest.approx(0.03, rel=0.15)
    v = d["validation_rms"]
    assert d["gain"] == pytest.approx(v["nominal"] / v["extended"]) and d["gain"] >= 5
    assert d["holdout_runs"] == ["1", "4", "7"] and len(d["fit_runs"]) == 6


def test_recording_and_report(outputs):
    paths = {str(p) for p in rr.chunk.RrdReader(str(outputs / "d.rrd")).store().schema().entity_paths()}
    for run in range(9):
        for w in ("measured", "nominal", "extended"):
            assert f"/diagnosis/runs/run{run}/phi_rad/{w}" in paths
            assert f"/diagnosis/loops/run{run}/{w}" in paths
        for w in ("nominal", "extended"):
            assert f"/diagnosis/runs/run{run}/departure_rad/{w}" in paths
    assert "/diagnosis/causes" in paths and "/diagnosis/summary" in paths
    # The blueprint read back: the first tab answers the question, one tab per run titled with
    # omega and M0, and every view's origin holds data the recording has.
    from conftest import blueprint_views

    names, origins = blueprint_views(outputs / "d.rrd")
    assert {"Verdict", "Verdict and report", "Causes (adopted marked)"} <= set(names)
    assert "run 1: 25 rad/s, 2500 N m, held out" in names
    assert sum(n.startswith("run ") for n in names) == 9
    for origin in origins:
        assert any(p == "/" + origin or p.startswith("/" + origin + "/") for p in paths), origin
    assert len(origins) == 3 + 4 * 9
    html = (outputs / "d.html").read_text()
    assert html.count("<img") == 5 and "Restoring-force loops" in html and "coulomb_friction" in html
    assert "departs from the measurement" in html


@pytest.mark.parametrize("text, match", [
    ("run,time,torque,phi1,phi2,speed\n", "no data rows"),
    ("run,time,torque,phi\n0,0,1,nan\n", "non-finite"),
])
def test_bad_input_exits_2_naming_the_column(tmp_path, capsys, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    assert diagnose.main([str(path), "-q"]) == 2
    assert match in capsys.readouterr().err


def test_unknown_holdout_run_is_refused(outputs, capsys):
    assert diagnose.main([str(outputs / "worn.parquet"), "--holdout", "99", "-q"]) == 2
    assert "--holdout names run(s) ['99']" in capsys.readouterr().err
