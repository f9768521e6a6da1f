"""One cause catalogue and one evidence measure for every pipeline (identify.causes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointrig.identify.causes import CATALOGUE, CAUSES, OSCILLATOR_CAUSES, by_name, evidence, forward_select
from jointrig.identify.extend import _added_term
from jointrig.vocab.law import Monomial, Power


def test_every_selection_is_drawn_from_the_one_catalogue():
    names = [c.name for c in CATALOGUE]
    assert len(names) == len(set(names))
    for selection in (CAUSES, OSCILLATOR_CAUSES):
        assert all(any(c is k for k in CATALOGUE) for c in selection)
    # the causes both pipelines seek are the very same entries
    shared = {c.name for c in CAUSES} & {c.name for c in OSCILLATOR_CAUSES}
    assert shared == {"asymmetric_stiffness", "drive_delay"}
    assert by_name("drive_delay") is next(c for c in OSCILLATOR_CAUSES if c.name == "drive_delay")
    with pytest.raises(KeyError, match="quartic"):
        by_name("quartic")


def test_the_oscillator_adds_each_causes_own_term():
    added = {c.name: _added_term(c) for c in OSCILLATOR_CAUSES}
    assert added["drive_delay"] is None  # a late input is a parameter of the simulation, not a term
    assert added["asymmetric_stiffness"] == Power(2) and added["quintic_stiffness"] == Power(5)
    assert added["cubic_damping"] == Monomial(0, 3) and added["amplitude_damping"] == Monomial(2, 1)


def test_evidence_by_hand():
    # chi-square(1) survival at 10 is erfc(sqrt(5)) = 1.565e-3; BIC 10 - ln(100) = 5.395.
    score, p, sig = evidence(10.0, 1, 100, alpha=1e-2, n_causes=1)
    assert score == pytest.approx(10.0 - math.log(100.0), rel=1e-15)
    assert p == pytest.approx(math.erfc(math.sqrt(5.0)), rel=1e-12)
    assert sig  # p < 1e-2 and the score is positive
    assert not evidence(10.0, 1, 100, alpha=1e-2, n_causes=10)[2]  # Bonferroni: p > 1e-3
    assert not evidence(10.0, 3, 100, alpha=1.0, n_causes=1)[2]  # significant, but 3 parameters do not pay
    # A cause already in the model adds no parameter: its refit's round-off is no evidence.
    assert evidence(2.6e-8, 0, 100, alpha=1.0, n_causes=1) == (2.6e-8, 1.0, False)
    # a drop below one: chi-square(1) survival at 0.5 is erfc(0.5); a rise counts as no drop
    assert evidence(0.5, 1, 100)[1] == pytest.approx(math.erfc(0.5), rel=1e-12)
    assert evidence(-3.0, 2, 100)[1] == 1.0
    # the default family-wise level is 1e-3: a drop of 12 with one parameter (p = 5.3e-4) passes
    # it, a drop of 10 (p = 1.6e-3) does not
    assert evidence(12.0, 1, 100)[2] and not evidence(10.0, 1, 100)[2]


def test_forward_select_adopts_until_nothing_earns_it_and_drops_first_only_causes():
    # A toy pipeline whose base is the tuple of adopted names: each round ranks the causes left
    # by a fixed strength, adoption takes the best if it is strong enough. "angle_skew" is
    # first_only: it stays in the pool of round 1 only.
    strength = {"coulomb_friction": 5.0, "backlash": 3.0, "angle_skew": 4.0, "drive_delay": 0.5}
    pool = [by_name(n) for n in strength]
    seen, looked = [], []

    def rank(base, remaining, rnd):
        seen.append((rnd, tuple(c.name for c in remaining)))
        return sorted(((c.name, strength[c.name]) for c in remaining), key=lambda s: -s[1])

    def adopt(base, ranked):
        best = ranked[0]
        return (best, base + (best[0],)) if best[1] > 1.0 else None

    sel = forward_select((), pool, rank=rank, adopt=adopt, max_effects=5, name_of=lambda s: s[0],
                         after=lambda base, chosen, ranked, remaining: looked.append((base, len(remaining))))
    assert sel.base == ("coulomb_friction", "backlash")
    assert [s[0] for s in sel.adopted] == ["coulomb_friction", "backlash"]
    assert seen == [(0, ("coulomb_friction", "backlash", "angle_skew", "drive_delay")),
                    (1, ("backlash", "drive_delay")), (2, ("drive_delay",))]
    assert looked == [(("coulomb_friction",), 2), (("coulomb_friction", "backlash"), 1)]
    assert len(sel.rounds) == 3 and sel.rounds[0][0] == ("coulomb_friction", 5.0)
    # max_effects caps the rounds that adopt; an empty pool ends the loop without a round
    assert forward_select((), pool, rank=rank, adopt=adopt, max_effects=1, name_of=lambda s: s[0]).base == \
        ("coulomb_friction",)
    assert forward_select((), [], rank=rank, adopt=adopt, max_effects=3).rounds == ()


@pytest.mark.parametrize("dof", range(1, 9))
def test_chi2_survival_is_scipys(dof):
    # identify.causes.chi2_survival (closed form for whole degrees of freedom) against
    # scipy.special.chdtrc, from p ~ 1 to p ~ 1e-300: 1e-13 relative (a sum of a few positive
    # terms, each exp(log) to ~10 ulp; where p underflows to 0 both give 0 or a subnormal).
    from scipy.special import chdtrc

    from jointrig.identify.causes import chi2_survival

    for x in np.concatenate([[0.0, 1e-12], np.geomspace(1e-6, 1400.0, 400)]):
        ref = float(chdtrc(dof, x))
        got = chi2_survival(float(x), dof)
        if ref > 1e-290:
            assert abs(got - ref) <= 1e-13 * ref, (dof, x, got, ref)
        else:
            assert got <= 1e-290
    with pytest.raises(ValueError, match="whole number"):
        chi2_survival(1.0, 0)
