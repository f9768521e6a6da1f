"""The one diagnosis document (present/diagnosis_json.py): its check, and its page in docs.

The documents of real diagnoses are checked where they are written: two flywheels in
tests/test_diagnose_script.py and tests/test_verdict.py, a train and a single axis in
tests/test_train_files.py."""

import math
import re
from pathlib import Path

import pytest

from jointrig.present import diagnosis_json as dj

DOC = Path(__file__).resolve().parents[1] / "docs" / "diagnosis-json.md"


def _document() -> dict:
    fit = {k: None for k in dj.FIT_KEYS}
    run = {k: None for k in dj.RUN_KEYS}
    cause = lambda: {k: None for k in dj.CAUSE_KEYS}  # noqa: E731  (one object per place)
    doc = {k: None for k in dj.KEYS} | {"schema": dj.SCHEMA, "bench": {k: None for k in dj.BENCH_KEYS},
                                       "verdict": {k: None for k in dj.VERDICT_KEYS},
                                       "fidelity": {k: None for k in dj.FIDELITY_KEYS},
                                       "ruled_out": [{k: None for k in dj.RULED_OUT_KEYS}],
                                       "nominal": fit, "causes": [cause()],
                                       "extended": {k: [] for k in dj.EXTENDED_KEYS} | fit | {"steps": [cause()]},
                                       "validation": {k: None for k in dj.VALIDATION_KEYS} | {"per_run": [run]}}
    return doc


def test_the_check_names_what_departs_from_the_schema():
    doc = _document()
    assert dj.schema_problems(doc) == []
    assert dj.schema_problems(doc | {"demo": {}}) == []  # the demo's own key, last
    missing = {k: v for k, v in doc.items() if k != "ambiguities"}
    assert "document" in dj.schema_problems(missing)[0] and "ambiguities" in dj.schema_problems(missing)[0]
    swapped = dict(reversed(list(doc.items())))
    assert dj.schema_problems(swapped)  # the order is part of the schema: a diff of two files lines up
    assert dj.schema_problems(doc | {"schema": "jointrig-diagnosis/1"}) == [
        "schema: 'jointrig-diagnosis/1', expected 'jointrig-diagnosis/8'"]
    bad_run = _document()
    del bad_run["validation"]["per_run"][0]["noise_floor"]
    assert dj.schema_problems(bad_run)[0].startswith("validation.per_run[0]: keys")
    bad_cause = _document()
    bad_cause["extended"]["steps"][0]["candidate"] = "x"
    assert dj.schema_problems(bad_cause)[0].startswith("extended.steps[0]: keys")
    bad_limit = _document()
    del bad_limit["ruled_out"][0]["limit"]
    assert dj.schema_problems(bad_limit)[0].startswith("ruled_out[0]: keys")
    no_grounds = _document()
    del no_grounds["verdict"]["grounds"]
    assert dj.schema_problems(no_grounds)[0].startswith("verdict: keys")
    # what a right model misses (schema 5) is checked where it is given, and null is allowed
    right = _document()
    right["validation"]["right_model"] = {k: None for k in dj.RIGHT_KEYS}
    assert dj.schema_problems(right) == []
    del right["validation"]["right_model"]["bound"]
    assert dj.schema_problems(right)[0].startswith("validation.right_model: keys")


def test_a_document_missing_a_list_or_an_object_is_listed_not_raised():
    # a hand-edited or foreign file: the check names what departs, it does not fail on it
    no_runs = _document()
    del no_runs["validation"]["per_run"]
    assert dj.schema_problems(no_runs) == [
        f"validation: keys {list(no_runs['validation'])}, expected {list(dj.VALIDATION_KEYS)}"]
    flat = _document() | {"extended": "x", "causes": None}
    assert dj.schema_problems(flat) == ["extended: expected an object, got str"]
    bad_steps = _document()
    bad_steps["extended"]["steps"] = 3
    assert dj.schema_problems(bad_steps) == []  # a value's type is not the schema's: its keys are


def test_the_docs_page_describes_every_key():
    text = DOC.read_text()
    named = set(re.findall(r"`([a-z_0-9]+)`", text))
    keys = set(dj.KEYS + dj.BENCH_KEYS + dj.VERDICT_KEYS + dj.FIDELITY_KEYS + dj.RULED_OUT_KEYS + dj.FIT_KEYS + dj.EXTENDED_KEYS + dj.VALIDATION_KEYS + dj.RUN_KEYS
               + dj.CAUSE_KEYS + dj.RIGHT_KEYS)
    assert keys - named == set()
    assert dj.SCHEMA in text
    from jointrig.identify.verdict import Grounds

    assert {g.value for g in Grounds} - named == set()  # every value a script may branch on


def test_non_finite_numbers_become_null():
    assert dj.finite({"a": [1.0, float("inf"), (float("nan"),)], "b": "x"}) == {"a": [1.0, None, [None]], "b": "x"}


def test_a_fits_chi2_per_dof_is_chi2_over_its_degrees_of_freedom():
    assert dj.FitJson(12.0, 4, {}, {}).as_json()["chi2_per_dof"] == 3.0
    assert dj.FitJson(12.0, 0, {}, {}).as_json()["chi2_per_dof"] == 12.0  # no degree of freedom: chi2 itself


def test_a_causes_entry_names_its_parameters_and_its_rejection_for_the_bench():
    # On a slide the magnitude, the parameters and a rejection's words are the slide's; a cause
    # nothing rejected carries an empty note.
    from dataclasses import replace

    from jointrig.identify.causes import CauseScore, Unphysical
    from jointrig.vocab.params import HINGE, SLIDE

    name = "ground1_quadratic_damping_Nms2_per_rad2"
    s = CauseScore("quadratic_damping", 1.0, 1, 0.5, 0.1, False, None, (name, -82.0, 2.6),
                   note=Unphysical(name, -82.0))
    got = dj.cause_json(s, SLIDE)
    assert got["magnitude"]["name"] == "ground1_quadratic_damping_Ns2_per_m2"
    assert got["note"] == "fitted with an unphysical negative ground1_quadratic_damping_Ns2_per_m2 = -82: rejected"
    assert dj.cause_json(replace(s, note=None), HINGE)["note"] == ""


def test_a_fits_entry_adds_only_the_constants_it_is_given():
    # A twist's zero carries the mean taken out before the fit; every other parameter is the fit's.
    class Fit:
        chi2, dof = 4.0, 2

        @staticmethod
        def parameters():
            return {"J1_kgm2": 2.0, "joint1_angle_offset_rad": 0.01}

        @staticmethod
        def std_error(n):
            return 0.1

        @staticmethod
        def std_error_dof(n):
            return 5.0 if n == "J1_kgm2" else math.inf

        def interval(self, n):
            return 0.1 * (2.5706 if n == "J1_kgm2" else 1.96)

    got = dj.FitJson.of(Fit(), added={"joint1_angle_offset_rad": 0.5})
    assert got.parameters == {"J1_kgm2": 2.0, "joint1_angle_offset_rad": 0.51}
    # each error's degrees of freedom (None where known) and its interval, not moved by the constants
    assert got.std_error_dofs == {"J1_kgm2": 5.0, "joint1_angle_offset_rad": None}
    assert got.intervals_95 == pytest.approx({"J1_kgm2": 0.25706, "joint1_angle_offset_rad": 0.196})
