"""Held-out runs of another kind than the fit (issue 13: a gain that generalises).

The choice is a pure function of the runs' settings (tested on tables written by hand), and the
whole path holds out multisines when the fit has stepped sines (tested on runs of the rig). The
misfit's dependence on run order is judged from runs that repeat a setting, the same notion of a
setting (tested on synthetic residuals).
"""

from __future__ import annotations

import numpy as np
import pytest

from jointrig.studies.holdout import default_holdout, holdout_of_another_kind


def _sweep(freqs, levels, lines=0):
    return [(w, a, lines) for w in freqs for a in levels]


def test_a_sorted_sweep_holds_out_its_middle_level_as_before():
    settings = _sweep((25.0, 40.0, 55.0), (1500.0, 2500.0, 3500.0))
    assert holdout_of_another_kind(settings) == (1, 4, 7) == default_holdout(9)


def test_another_level_whatever_the_order_and_with_estimated_settings():
    # levels as a measured torque gives them (last digits differ), runs in no order
    settings = [(40.0, 3499.7, 0), (25.0, 1500.2, 0), (55.0, 2500.4, 0), (25.0, 2499.9, 0), (40.0, 1499.8, 0),
                (55.0, 3500.3, 0), (40.0, 2500.1, 0)]
    assert holdout_of_another_kind(settings) == (2, 3, 6)  # the 2500 N m runs
    # five levels: the second and the fourth are held out, the outer and middle ones fitted
    settings = _sweep((30.0,), (1000.0, 1500.0, 2000.0, 2500.0, 3000.0)) + _sweep((50.0,), (1000.0, 3000.0))
    assert holdout_of_another_kind(settings) == (1, 3)


def test_another_frequency_when_there_are_two_levels():
    settings = _sweep((90.0, 115.0, 175.0), (1000.0, 2400.0))
    assert holdout_of_another_kind(settings) == (2, 3)  # the middle frequency at both levels


def test_another_excitation_comes_first():
    settings = _sweep((25.0, 40.0, 55.0), (1500.0, 3500.0)) + [(8.0, 40.0, 4), (8.0, 60.0, 4)]
    assert holdout_of_another_kind(settings) == (6, 7)
    # too few runs of the other kind left to fit: fall back to another level or frequency
    settings = [(8.0, 40.0, 4), (8.0, 60.0, 4), (25.0, 1500.0, 0), (40.0, 1500.0, 0)]
    assert holdout_of_another_kind(settings) == default_holdout(4)


def test_too_few_runs_is_refused():
    with pytest.raises(ValueError, match="at least 3"):
        holdout_of_another_kind([(25.0, 1500.0, 0), (40.0, 1500.0, 0)])


@pytest.mark.slow
def test_the_diagnosis_holds_out_multisines_and_says_so(rig):
    # Stepped sines and two multisines of the paper's joint (no hidden effect), 40 dB, through the
    # one pipeline (the train of two bodies): each run's kind is read from its drive's lines that
    # stand out of the noise (studies.chain_validate.train_setting: 0 for a sine, several for these
    # multisines); the fit sees only the sines, the multisines are predicted, and the
    # nominal model, which is right, predicts them to the noise.
    from jointrig.identify.chain import ChainRecord
    from jointrig.identify.multisine import odd_multisine
    from jointrig.rig import SimulationConfig, simulate_steady_state
    from jointrig.rig.chain import chain_of_two_flywheels
    from jointrig.rig.measurement import add_noise
    from jointrig.studies.chain_validate import run_train_diagnosis, train_setting

    rng = np.random.default_rng(5)
    cfg = SimulationConfig(n_periods=8)
    records = [simulate_steady_state(rig, w, a, cfg, backend="native")[0]
               for w, a in ((25.0, 1500.0), (25.0, 3500.0), (40.0, 2500.0), (55.0, 1500.0), (55.0, 3500.0))]
    for seed, rms in ((0, 1500.0), (1, 2500.0)):
        ms = odd_multisine(8.0, 11, rms, seed=seed)
        records.append(simulate_steady_state(rig, 8.0, rms, cfg, drive=ms.drive, backend="native")[0])
    train = [ChainRecord.of_two_flywheels(add_noise(r, 40.0, rng)) for r in records]
    lines = [train_setting(r)[2] for r in train]
    assert lines[:5] == [0] * 5 and min(lines[5:]) >= 3, lines
    report = run_train_diagnosis(train, run_ids=[str(i) for i in range(7)], rig=chain_of_two_flywheels(rig, (1,)))
    assert report.held_out == (5, 6)
    from jointrig.present.notes import generalisation_text

    words = generalisation_text(report.generalisation)
    assert report.generalisation.another_excitation is True and words.startswith(
        "the held-out runs test another excitation (held-out drives with several lines"), words
    assert report.verdict.verdict == "no_misfit", (report.verdict, [s.label for s in report.diagnosis.steps])


def _residual(run_id, omega, amplitude, residual_scale, *, n=256):
    """A run's residual joint torque departing from the model's by a known residual (a third
    harmonic of the given size on a 1000 N m fundamental)."""
    from jointrig.identify.misfit import ResidualRun

    t = np.arange(n) * 2 * np.pi / omega / n
    phi = 0.1 * np.cos(omega * t)
    model = 1000.0 * np.cos(omega * t)
    measured = model + residual_scale * np.cos(3 * omega * t + 0.4)
    return ResidualRun(run_id, omega, amplitude, phi, measured, model)


def test_run_order_is_judged_only_from_repeated_settings():
    from jointrig.identify.misfit import misfit_character, next_measurements, residual_surface
    from jointrig.present.misfit_words import character_text, measurement_text

    sweep = [("0", 25.0, 1500.0), ("1", 40.0, 1500.0), ("2", 55.0, 1500.0)]
    # no repeat: said to be undecidable, and a repeated run is suggested
    ch = misfit_character([_residual(i, w, a, 20.0) for i, w, a in sweep], 20)
    assert np.isnan(ch.repeat_change) and "cannot be told apart" in character_text(ch)
    # the first setting repeated at the end with the same residual: no sign of run order
    same = [_residual(i, w, a, 20.0) for i, w, a in sweep] + [_residual("3", 25.0, 1502.0, 20.0)]
    ch = misfit_character(same, 20)
    assert ch.repeat_change == pytest.approx(0.0, abs=1e-12) and ch.repeat_runs == ("0", "3")
    assert "no sign of run order or time" in character_text(ch)
    # ... with the residual doubled (a joint that wears during the test): changes by 0.5 of its size
    worn = [_residual(i, w, a, 20.0) for i, w, a in sweep] + [_residual("3", 25.0, 1502.0, 40.0)]
    ch = misfit_character(worn, 20)
    assert ch.repeat_change == pytest.approx(0.5, rel=1e-9) and "depends on run order or time" in character_text(ch)
    assert any("changed between runs 0 and 3" in measurement_text(m) for m in next_measurements(ch, residual_surface(worn), worn))


def test_what_the_held_out_runs_test_is_a_value_with_words_in_the_benchs_units():
    # fitted at 20 and 40 rad/s, 100-300 N m with sines; held out: 60 rad/s (outside), 30 rad/s
    # (inside, unseen), 500 N m (outside) and 200 N m (between), a multisine (another excitation)
    from jointrig.present.notes import generalisation_text
    from jointrig.studies.holdout import Generalisation, generalisation_kind
    from jointrig.vocab.params import SLIDE

    fit = [(20.0, 100.0, 0), (40.0, 300.0, 0), (20.0, 300.0, 0)]
    g = generalisation_kind(fit, [(60.0, 500.0, 3), (30.0, 200.0, 0)])
    assert g == Generalisation(another_excitation=True, levels_outside=(500.0,), level_range=(100.0, 300.0),
                               omegas_outside=(60.0,), omega_range=(20.0, 40.0), new_omegas=(30.0,),
                               new_levels=(200.0,))
    words = generalisation_text(g, SLIDE)
    assert words == ("the held-out runs test another excitation (held-out drives with several lines, the fit's sines); "
                     "extrapolation in drive level (500 N, outside the fitted 100-300 N); extrapolation in frequency "
                     "(60 rad/s, outside the fitted 20-40 rad/s); frequencies the fit did not see (30 rad/s, inside its "
                     "range); drive levels between the fitted ones (200 N)")
    assert "500 N m" in generalisation_text(g)
    again = generalisation_kind(fit, [(20.2, 100.5, 0)])  # within 1%: the same setting
    assert generalisation_text(again) == ("the held-out runs repeat frequencies and drive levels of the fit (another "
                                          "realisation only)")
    assert generalisation_text(Generalisation(later_periods=(3, 4), runs=2)).startswith(
        "the later 3, 4 period(s) of the same run(s), fitted on their earlier periods: with 2 run(s)")
