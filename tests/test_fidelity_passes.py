"""How the diagnosis settles its measured fidelity (studies.chain_validate.measured_diagnosis):
each pass measures the balance's misfit on the replay of the model the one before adopted, until
the kind of model adopted repeats; a return to a model whose own fidelity led elsewhere is a cycle.
Pure and fast: the diagnoses and replays are stand-ins that adopt by a table."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

import jointrig.identify.chain_diagnose as chain_diagnose
from jointrig.identify.defaults import DEFAULT_FIDELITY
from jointrig.studies.chain_validate import FIDELITY_PASSES, measured_diagnosis
from jointrig.studies.notes import FidelityCycle


@dataclass(frozen=True)
class _Fit:
    spec: str


@dataclass(frozen=True)
class _Step:
    label: str


@dataclass(frozen=True)
class _Diagnosis:
    model: str
    n_harmonics: int = 20
    masked: tuple = ()
    merging: tuple = ()

    @property
    def final(self):
        return _Fit(self.model)

    @property
    def steps(self):
        return tuple(_Step(s) for s in self.model.split(" + ")) if self.model else ()

    def reduced_chi2(self, fit):
        return 1.0


def _passes(monkeypatch, adopts):
    """Run measured_diagnosis where the fixed floor adopts ``adopts[None]`` and the fidelity
    measured on model m adopts ``adopts[m]``; returns (the diagnosis, notes, the fidelities used)."""
    monkeypatch.setattr(chain_diagnose, "balance_fidelity", lambda got, fit, *a: fit.spec)
    monkeypatch.setattr(chain_diagnose, "model_kind", lambda spec: spec)
    used = []

    def diagnosed(fid):
        used.append(fid)
        return _Diagnosis(adopts[None] if fid == DEFAULT_FIDELITY else adopts[fid])

    d, notes = measured_diagnosis(diagnosed, lambda fit: [object()])
    return d, notes, used


def test_the_fidelity_passes_stop_where_the_adopted_model_repeats(monkeypatch):
    d, notes, used = _passes(monkeypatch, {None: "a", "a": "a + b", "a + b": "a + b"})
    assert d.model == "a + b" and notes == () and used == [DEFAULT_FIDELITY, "a", "a + b"]


def test_a_model_whose_own_fidelity_adopts_another_that_adopts_it_back_is_a_cycle(monkeypatch):
    # the torque cell's cubic calibration error (tests/test_open_world.py): on quadratic damping's
    # own fidelity the data ask for four causes; on theirs (a friction's kinks, a misfit of 7%),
    # quadratic damping alone; no model holds under its own fidelity
    d, notes, used = _passes(monkeypatch, {None: "q", "q": "q + f", "q + f": "q"})
    assert notes == (FidelityCycle("q", "q + f"),) and d.model == "q"
    assert used == [DEFAULT_FIDELITY, "q", "q + f"]


def test_passes_that_wander_without_a_cycle_end_at_the_last(monkeypatch):
    # a -> b -> c: no kind returns; the last diagnosis stands (at most FIDELITY_PASSES passes)
    assert FIDELITY_PASSES == 2
    d, notes, used = _passes(monkeypatch, {None: "a", "a": "b", "b": "c", "c": "a"})
    assert d.model == "c" and notes == () and len(used) == 1 + FIDELITY_PASSES


@pytest.mark.parametrize("adopts", [{None: "", "": "a", "a": ""}])
def test_the_nominal_model_can_be_one_side_of_a_cycle(monkeypatch, adopts):
    d, notes, _ = _passes(monkeypatch, adopts)
    assert notes == (FidelityCycle("the nominal model", "a"),) and d.model == ""
