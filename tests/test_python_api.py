"""The diagnosis from Python: ``jointrig.diagnose(path)`` and its :class:`jointrig.diagnosis.Diagnosis`."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "bench_dry_friction.csv"


@pytest.mark.xdist_group("example")
def test_the_shipped_example_diagnosed_from_python_names_its_dry_friction(tmp_path, example_diagnosis):
    # The README's file: two flywheels (J 2 kg m^2 each) whose joint has 60 N m of dry friction,
    # 0.1% noise. What the command prints and writes comes from the same result object.
    from jointrig.present.diagnosis_json import schema_problems
    from jointrig.rig.chain import load_chain

    d = example_diagnosis  # jointrig.diagnose(EXAMPLE)
    assert d.verdict == "explained" and [s.label for s in d.report.diagnosis.steps] == ["coulomb_friction at joint 1"]
    p, se = d.parameters(), d.std_errors()
    # within 4 of its standard errors of the truth (the file's noise; 4 leaves room for the
    # sandwich's own scatter), and the errors are finite and positive
    for name, true in (("J1_kgm2", 2.0), ("J2_kgm2", 2.0), ("joint1_coulomb_torque_Nm", 60.0)):
        assert math.isfinite(se[name]) and se[name] > 0, (name, se[name])
        assert abs(p[name] - true) <= 4 * se[name], (name, p[name], se[name])
    # each 95% interval is at least 1.95996 errors wide (Student's t at the error's degrees of
    # freedom, above 1.96 at any finite count), the JSON's the same figures
    ci = d.intervals()
    assert set(ci) == set(se) and all(ci[n] >= 1.95996 * se[n] for n in ci if math.isfinite(se[n]))
    j = d.json()
    assert schema_problems(j) == [] and j["verdict"]["verdict"] == "explained"
    assert j["extended"]["intervals_95"]["joint1_k_Nm_per_rad"] == pytest.approx(ci["joint1_k_Nm_per_rad"], rel=1e-12)
    assert j["extended"]["std_error_dofs"]["joint1_k_Nm_per_rad"] < 100  # read from the periods' scatter
    assert d.text().startswith("VERDICT: EXPLAINED: coulomb_friction at joint 1")
    xml = tmp_path / "identified.xml"
    xml.write_text(d.model_xml("from the test"), encoding="utf-8")
    assert load_chain(xml).n_flywheels == 2


def test_bad_input_is_refused_by_name_before_any_diagnosis(tmp_path):
    from jointrig import diagnose
    from jointrig.diagnosis import DiagnosisInputError
    from jointrig.measured.runs import RunsFileError

    with pytest.raises(RunsFileError, match=r"--holdout names run\(s\) \['99'\] not in the file"):
        diagnose(EXAMPLE, holdout=["99"])
    with pytest.raises(DiagnosisInputError, match="give one of them"):
        diagnose(EXAMPLE, holdout=["1"], validate=EXAMPLE)
    bad = tmp_path / "model.xml"
    bad.write_text("<mujoco><worldbody/></mujoco>", encoding="utf-8")
    with pytest.raises(DiagnosisInputError, match="^--model: "):
        diagnose(EXAMPLE, model=bad)
    with pytest.raises(DiagnosisInputError, match="--torque-on must be"):
        diagnose(EXAMPLE, torque_on="flywheel3")
