"""The result family (identify.estimates) and typed parameter names (vocab.params)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from jointrig.identify.chain_diagnose import ChainFit
from jointrig.identify.eiv import EivResult
from jointrig.identify.estimates import Estimates, equilibrated_condition
from jointrig.identify.output_error import OutputErrorResult
from jointrig.identify.solve import IdentificationResult
from jointrig.vocab.params import BEARING1, J1, JE, Param

FAMILY = (IdentificationResult, EivResult, ChainFit, OutputErrorResult)


@pytest.mark.parametrize("cls", FAMILY, ids=lambda c: c.__name__)
def test_every_fit_result_is_an_estimates_with_status_and_conditioning(cls):
    fields = {f.name for f in dataclasses.fields(cls)}
    assert issubclass(cls, Estimates)
    assert {"names", "values", "std_errors", "condition_number", "success", "message"} <= fields


def test_equilibrated_condition_ignores_column_units_and_sees_near_dependence():
    # Columns of 1 and 1e-6 scale are equilibrated away: orthogonal columns give exactly 1.
    assert equilibrated_condition(np.diag([1.0, 1e-6])) == pytest.approx(1.0, rel=1e-15)
    # Two unit columns at angle a: singular values sqrt(1 +- cos a), so the ratio is
    # cot(a / 2); at a = 1e-3 that is 2000 (to the round-off of the SVD, 1e-12 relative).
    a = 1e-3
    J = np.array([[1.0, math.cos(a)], [0.0, math.sin(a)]]) * np.array([1.0, 1e4])
    assert equilibrated_condition(J) == pytest.approx(1 / math.tan(a / 2), rel=1e-9)
    assert equilibrated_condition(np.array([[1.0, 0.0], [2.0, 0.0]])) == math.inf


def test_a_result_is_asked_by_typed_name():
    res = IdentificationResult(names=(J1, "k_Nm_per_rad"), values=np.array([2.0, 2000.0]),
                               std_errors=np.array([0.01, 3.0]), covariance=np.eye(2), condition_number=4.0,
                               residual_rms=0.0, relative_residual=0.0, n_rows=10, dof=8, success=True, message="ok")
    assert J1 in res and JE not in res and "J1_kgm2" in res
    assert res.value(J1) == 2.0 and res.std_error("k_Nm_per_rad") == 3.0
    assert math.isnan(res.std_error(JE))
    with pytest.raises(KeyError, match="Je_kgm2"):
        res.value(JE)
    assert [p.unit for p in res.params] == ["kg m²", "N m/rad"]


def test_param_is_its_plain_name_with_a_unit():
    assert Param("k_Nm_per_rad") == "k_Nm_per_rad" and {Param("k_Nm_per_rad"): 1}["k_Nm_per_rad"] == 1
    assert BEARING1.unit == "N m s/rad" and BEARING1.quantity == "bearing1_damping"
    assert Param("omega_rad_s").unit == "rad/s" and Param("no_unit").unit == ""
