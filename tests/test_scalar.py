"""identify.scalar.minimize_bounded against scipy.optimize.minimize_scalar(method="bounded"),
whose port it is: the same points visited, the same minimum, bit for bit."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from jointrig.identify.scalar import minimize_bounded

CASES = [
    ("parabola", lambda x: (x - 0.3) ** 2, (-1.0, 2.0), 1e-5),
    ("parabola, tight", lambda x: (x - 0.3) ** 2 + 1.0, (-1.0, 2.0), 1e-12),
    ("minimum at the bound", lambda x: x, (0.5, 3.0), 1e-8),
    ("two minima", lambda x: math.sin(3 * x) + 0.1 * x * x, (-4.0, 4.0), 1e-9),
    ("kinked", lambda x: abs(x - 1.234567), (0.0, 10.0), 1e-10),
    ("flat", lambda x: 1.0, (0.0, 1.0), 1e-6),
    ("log-spaced chi-square", lambda u: (math.exp(u) - 3e-3) ** 2 * 1e6 + 5.0, (math.log(1e-5), math.log(1e-1)), 1e-6),
    ("a point interval", lambda x: x * x, (2.0, 2.0), 1e-6),
    # ties, as a profile over a law whose columns do not change between trials gives them: the
    # search's comparisons of equal values (<= against <) decide its path
    ("steps", lambda x: math.floor(8.0 * x), (0.0, 1.0), 1e-6),
    ("flat bottom", lambda x: max(0.0, abs(x - 0.5) - 0.2), (0.0, 1.0), 1e-8),
    ("quantised parabola", lambda x: round((x - 0.3) ** 2, 3), (-1.0, 2.0), 1e-9),
    ("steps down", lambda x: -math.floor(8.0 * x), (0.0, 1.0), 1e-6),
    # a region where the objective is not a number (a fit that failed)
    ("nan above 0.7", lambda x: math.nan if x > 0.7 else (x - 0.2) ** 2, (0.0, 1.0), 1e-8),
    ("nan below 0.4", lambda x: math.nan if x < 0.4 else (x - 0.6) ** 2, (0.0, 1.0), 1e-8),
]


@pytest.mark.parametrize("name, f, bounds, xatol", CASES, ids=[c[0] for c in CASES])
def test_the_port_visits_what_scipy_visits(name, f, bounds, xatol):
    seen_ours, seen_scipy = [], []
    ours = minimize_bounded(lambda x: seen_ours.append(x) or f(x), bounds, xatol=xatol)
    ref = minimize_scalar(lambda x: seen_scipy.append(x) or f(x), bounds=bounds, method="bounded",
                          options={"xatol": xatol})
    assert seen_ours == [float(x) for x in seen_scipy]
    assert (ours.x, ours.nfev, ours.success) == (float(ref.x), ref.nfev, ref.success)
    assert ours.fun == float(ref.fun) or (math.isnan(ours.fun) and math.isnan(ref.fun))


def test_the_budget_and_bad_bounds():
    seen = []
    short = minimize_bounded(lambda x: seen.append(x) or math.sin(x), (0.0, 6.0), xatol=1e-14, maxiter=5)
    assert (short.nfev, short.success, len(seen)) == (5, False, 5)
    assert not minimize_bounded(lambda x: math.nan, (0.0, 1.0)).success
    with pytest.raises(ValueError, match="lower bound exceeds"):
        minimize_bounded(lambda x: x, (1.0, 0.0))
    with pytest.raises(ValueError, match="finite"):
        minimize_bounded(lambda x: x, (0.0, np.inf))
