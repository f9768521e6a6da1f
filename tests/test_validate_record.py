"""A separate validation record (issue 50): ``jointrig diagnose DATA --validate OTHER`` fits every
run of DATA and holds out every run of OTHER, as benchmarks give one.

Both files come from the independent bench (tests/bench_sim.py: the paper's joint with 40 N m of
dry friction, 0.2% noise, sensor offsets), written separately as a lab records them: the fit
record at the outer frequencies and levels (25 and 55 rad/s, 1500 and 3500 N m), the validation
record at the middle frequency (40 rad/s, 2500 and 3500 N m), each with its own seed and sensor
offsets.
"""

from __future__ import annotations

import json

import pytest

from bench_sim import JOINTS, measure, with_effect
from jointrig.cli import main as cli


def _records(tmp_path):
    bench = with_effect(JOINTS["paper"], Fc=40.0)
    fit = measure(bench, [(w, m) for w in (25.0, 55.0) for m in (1500.0, 3500.0)], tmp_path / "fit.csv", seed=11,
                  fs_Hz=2000.0, n_periods=6.5)
    other = measure(bench, [(40.0, 2500.0), (40.0, 3500.0)], tmp_path / "other.csv", seed=12, fs_Hz=2000.0,
                    n_periods=6.5)
    return fit, other


@pytest.mark.slow
def test_a_separate_record_is_held_out_whole_and_the_friction_holds_on_it(tmp_path, capsys):
    # Fitted on the four runs of one file, validated on the two of the other: the friction found
    # and sized within 3 standard errors, the verdict explained on the other record's runs.
    fit, other = _records(tmp_path)
    out = tmp_path / "d.json"
    assert cli(["diagnose", str(fit), "--validate", str(other), "--json", str(out), "-q"]) == 0
    text = capsys.readouterr().out
    j = json.loads(out.read_text())
    assert j["fit_runs"] == ["0", "1", "2", "3"] and j["held_out_runs"] == ["validate:0", "validate:1"], j
    assert j["verdict"]["verdict"] == "explained", j["verdict"]
    # dry friction first (a second, small cogging of 2.9 +- 0.4 N m is adopted beside it on this seed:
    # not what this test is about; the calibration of a second cause is issue 48's)
    assert j["extended"]["effects"][0] == "coulomb_friction at joint 1", j["extended"]["effects"]
    value, se = (j["extended"][k]["joint1_coulomb_torque_Nm"] for k in ("parameters", "std_errors"))
    assert abs(value - 40.0) <= 3 * se, (value, se)
    assert "held out for validation: validate:0, validate:1" in text


def test_validate_beside_holdout_is_refused_before_anything_is_read(tmp_path, capsys):
    missing = tmp_path / "not-there.csv"
    assert cli(["diagnose", str(missing), "--validate", str(missing), "--holdout", "0", "-q"]) == 2
    assert "give one of them" in capsys.readouterr().err


def test_a_validation_record_of_another_bench_is_refused_naming_it(tmp_path, capsys):
    # the validation record holds the relative angle alone, the fit record both angles
    fit, other = _records(tmp_path)
    rows = [line.split(",") for line in other.read_text().splitlines()]
    one = tmp_path / "one.csv"
    one.write_text("\n".join(",".join(r[:3] + ["phi [rad]" if k == 0 else f"{float(r[3]) - float(r[4]):.9f}"])
                             for k, r in enumerate(rows)) + "\n")
    assert cli(["diagnose", str(fit), "--validate", str(one), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"--validate {one}" in err and "another bench" in err, err
