"""D-optimal excitation design: the allocation (pure) and the designer against the default sweep."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jointrig.identify.design import d_optimal, design_cost_s


from jointrig.commands import design_excitation  # noqa: E402


def test_allocation_balances_complementary_candidates_within_budget():
    F = [np.diag([1.0, 0.0]), np.diag([0.0, 1.0]), np.diag([0.1, 0.1])]
    T = [1.0, 1.0, 1.0]
    d = d_optimal(F, T, budget_s=22.0, setup_s=1.0, min_periods=4)
    # log det(a F1 + b F2) = log a + log b: the budget splits evenly between the two, the
    # weak third candidate is not worth its setup.
    assert d.periods[2] == 0 and abs(d.periods[0] - d.periods[1]) <= 1
    assert d.cost_s == pytest.approx(design_cost_s(d.periods, T, 1.0)) and d.cost_s <= 22.0
    np.testing.assert_allclose(d.covariance, np.linalg.inv(d.periods[0] * F[0] + d.periods[1] * F[1]))


def test_allocation_does_not_depend_on_parameter_units():
    rng = np.random.default_rng(2)
    F = [(lambda a: a.T @ a)(rng.normal(size=(5, 3))) for _ in range(6)]
    T = list(rng.uniform(0.1, 2.0, 6))
    D = np.diag([1e-3, 1.0, 1e4])  # e.g. kg m^2, N m s/rad, N m/rad^3 rescaled
    a = d_optimal(F, T, 30.0)
    b = d_optimal([D @ f @ D for f in F], T, 30.0)
    assert a.periods == b.periods  # D-optimality: log det shifts by a constant under rescaling


def test_budget_too_small_is_refused():
    with pytest.raises(ValueError, match="admits no design"):
        d_optimal([np.diag([1.0, 0.0]), np.diag([0.0, 1.0])], [1.0, 1.0], budget_s=6.0, setup_s=1.0, min_periods=4)


def test_design_beats_the_default_sweep_on_its_budget(tmp_path):
    out = tmp_path / "d.json"
    assert design_excitation.main(["--json", str(out)]) == 0
    data = json.loads(out.read_text())
    used = sum(d["periods"] * 2 * np.pi / d["omega_rad_s"] + data["setup_s"] for d in data["design"])
    assert used <= data["budget_s"] + 1e-9
    # Measured: D-efficiency 7.1, every CRLB standard deviation 2.1-3.1x smaller. The greedy
    # design must at least not lose on any parameter.
    assert data["d_efficiency"] > 2
    for name, sd in data["crlb_std"].items():
        assert sd["design"] < sd["default"], name
