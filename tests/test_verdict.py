"""A verdict that never throws a right answer away (issue 35), on files the project did not write.

The data come from the independent bench (tests/bench_sim.py: scipy, event-driven dry friction,
a DAQ's fixed 2 kHz clock, 0.2% noise), six runs as in tests/test_independent_bench.py.

* Dry friction is adopted whichever single run is held out (items 1 and 3): before the rig held
  dry friction as a constraint, the validation found no steady state for such a model in some
  runs and threw the right answer away.
* A candidate the rig cannot simulate (it diverges) is rejected with that reason; the command
  does not fail, and no "inf" or "nan" reaches the text, the JSON or the card (item 2).
* The joint card warns when its model was not adopted and measures the runs' rows with the
  best-supported inertias (item 7).
* Parsimony: a Stribeck friction whose peak the data do not show ranks behind dry friction
  (item 4).
"""

from __future__ import annotations

import json
import math
import re

import pytest

from bench_sim import JOINTS, POINTS, measure, with_effect
from jointrig.identify import diagnose as D
from jointrig.identify.causes import CAUSES
from jointrig.measured.runs import read_runs
from jointrig.present.diagnosis_report import format_report, report_json
from jointrig.rig.simulate import SimulationError
from jointrig.studies import validate
from jointrig.studies.joint_card import card_json, card_of_diagnosis
from jointrig.studies.validate import run_diagnosis

KIND = {c.name: c.kind for c in CAUSES}


def _points(joint: str):
    return [p for i, p in enumerate(POINTS[joint]) if i % 3 != 1]


def _loaded(tmp_path, joint: str, seed: int = 7, **effect):
    path = measure(with_effect(JOINTS[joint], **effect), _points(joint), tmp_path / "bench.csv", seed=seed,
                   fs_Hz=2000.0, n_periods=6.5)
    return read_runs(path)


@pytest.mark.slow
@pytest.mark.parametrize("joint, friction_Nm", [("paper", 20.0), ("light", 10.0)])
def test_dry_friction_is_adopted_whichever_run_is_held_out(tmp_path, joint, friction_Nm):
    loaded = _loaded(tmp_path, joint, Fc=friction_Nm)
    for held in range(len(loaded.records)):
        report = run_diagnosis(loaded.records, run_ids=loaded.run_ids, holdout=(held,))
        d = report.diagnosis
        dynamic = [e for e in report.adopted if KIND[e] == "dynamic"]
        assert report.verdict.verdict == "explained" and dynamic == ["coulomb_friction"], (held, report.verdict)
        value = d.extended.as_dict()["coulomb_torque_Nm"]
        se = d.extended.std_error("coulomb_torque_Nm")
        # 3 standard errors (the diagnosis's own, with its model-fidelity floor), as the
        # independent-bench acceptance
        assert abs(value - friction_Nm) <= 3 * se, (held, value, se)


def test_a_diverging_candidate_is_rejected_with_its_reason(tmp_path, monkeypatch):
    loaded = _loaded(tmp_path, "paper", Fc=20.0)
    real = validate._simulate

    def diverging(rig, plant, J, run, *args):
        # the extended model (with dry friction) diverges in the rig, as a gear-mesh candidate did
        if "coulomb_torque_Nm" in plant.law.names:
            raise SimulationError("two_flywheels.xml: MuJoCo warned: mjWARN_BADQACC x1; the simulation diverged")
        return real(rig, plant, J, run, *args)

    monkeypatch.setattr(validate, "_simulate", diverging)
    report = run_diagnosis(loaded.records, run_ids=loaded.run_ids)
    v = report.verdict
    assert v.verdict == "unexplained" and report.adopted == ()
    assert "rejected" in v.reason and "it diverges" in v.reason, v
    assert report.unsimulated("extended") == tuple(loaded.run_ids) and report.unsimulated("nominal") == ()
    text = format_report(report)
    assert not re.search(r"\b(inf|nan)\b", text, re.IGNORECASE), text
    assert "diverges" in text
    js = report_json(report)
    json.dumps(js, allow_nan=False)  # no inf or nan
    assert js["no_steady_state"]["extended"] == {r: "it diverges" for r in loaded.run_ids}
    assert js["gain"] is None
    # The card describes the nominal model, says so, and measures the runs with the inertias of
    # the fit that explains them better (the friction's)
    card = card_of_diagnosis(report, loaded.records, run_ids=loaded.run_ids)
    assert "did NOT adopt" in card.warning and "unexplained" in card.warning
    assert "tried extension" in card.runs_inertias
    cj = card_json(card)
    assert cj["model_adopted"] is False and cj["warning"] == card.warning
    json.dumps(cj, allow_nan=False)


def _score(effect: str, delta: float, q: int, n_rows: int) -> D.CauseScore:
    return D.CauseScore(effect, delta, q, delta - q * math.log(n_rows), 1e-30, True, None, (effect, 1.0, 0.1), {})


@pytest.mark.parametrize("extra_drop, stribeck_first", [(12.0, False), (30.0, True)])
def test_a_stribeck_peak_the_data_do_not_show_ranks_behind_dry_friction(extra_drop, stribeck_first):
    # Stribeck (3 parameters) lowers chi-square by `extra_drop` more than dry friction (1). Over
    # 100 rows BIC ranks it first beyond 2 ln(100) = 9.2, but its 2 extra parameters are
    # significant at alpha 1e-3 only beyond chi2(2)'s 13.8: at 12 it goes behind dry friction.
    n_rows = 100
    ranked = [_score("stribeck_friction", 1000.0 + extra_drop, 3, n_rows), _score("coulomb_friction", 1000.0, 1, n_rows)]
    ranked.sort(key=lambda s: -s.score)
    assert ranked[0].effect == "stribeck_friction"  # by BIC alone
    by_name = {c.name: c for c in CAUSES}
    out = D._parsimonious(ranked, by_name, n_rows, 1e-3)
    assert [s.effect for s in out][0] == ("stribeck_friction" if stribeck_first else "coulomb_friction")
    assert sorted(s.effect for s in out) == ["coulomb_friction", "stribeck_friction"]
