"""The diagnosis's notes are values (studies.notes) and their sentences are made in one place
(present.notes.note_text): every kind of note has its words, and the words carry the values."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from jointrig.present.notes import bias_unmeasured_text, failures_text, no_replay_text, note_text
from jointrig.studies import notes
from jointrig.studies.notes import (DIVERGED, NO_INERTIA, NO_STEADY_STATE, NOR_SPANNED, NOT_FOLLOWED, BandCut, BiasUnmeasured,
                                    BodyRests, FidelityCycle, FixedFidelity, JointSticks, NoReplay, NoSpringToFrame, RelativeAngle,
                                    Spanned)

from jointrig.measured import notes as reader  # noqa: E402

#: the reader's notes (measured.notes): the same words function
READER = [c for _, c in inspect.getmembers(reader, inspect.isclass)
          if dataclasses.is_dataclass(c) and c.__module__ == reader.__name__]

#: the values a note quotes (why a replay failed, why a bias was not measured): words of their own
PARTS = {NoReplay, BiasUnmeasured}
KINDS = [c for _, c in inspect.getmembers(notes, inspect.isclass)
         if dataclasses.is_dataclass(c) and c.__module__ == notes.__name__ and c not in PARTS]


def test_every_kind_of_note_has_its_words_and_nothing_else_does():
    assert {c.__name__ for c in KINDS} == {"BandCut", "FixedFidelity", "FidelityCycle", "BodyRests", "JointSticks",
                                           "NoSpringToFrame",
                                           "Spanned", "RelativeAngle"}
    for kind in KINDS + READER:
        assert kind in note_text.registry, kind
    with pytest.raises(TypeError, match="no words for a note of type int"):
        note_text(3)
    with pytest.raises(TypeError, match="no words for a note of type str"):  # a sentence made elsewhere
        note_text("a reader's note, in words already")


def test_a_notes_words_carry_its_values():
    assert note_text(BandCut(7, 20, "run3", 16)) == ("harmonics 1..7 fitted, not 1..20: run run3 holds 16 samples per "
                                                     "period, enough for 7")
    stuck = JointSticks("a", 2, 0.62, True, 0.7, 0.05, 0.1)
    assert note_text(stuck).startswith("run a: joint 2 may stick: its twist rests 62% of its period (its twist rate "
                                       "below 5% of its peak)")
    assert "and one of them on its own where the joint slides (its twist rate above 10% of its peak; 70% of the " \
           "period left out)" in note_text(stuck)
    whole = dataclasses.replace(stuck, resolved=False, left_out=1.0)
    assert "not resolved above the noise" in note_text(whole) and "as their sum alone in this run" in note_text(whole)
    rests = note_text(BodyRests("0", 1, 0.4, 0.3, 0.05, 0.1))
    assert rests.startswith("run 0: body 1 rests 40% of its period (its rate below 5% of its peak") and "30% of the " \
        "period left out" in rests
    assert note_text(NoSpringToFrame((1, 3))).startswith("body 1, 3 has no spring to the frame")
    assert note_text(Spanned("extended", "f.csv run 2", 115)).startswith(
        "the extended model under the drive of f.csv run 2 (no periodic steady state in the rig within 115 periods): ")
    assert "within 115 periods or 30 s)" in note_text(Spanned("nominal", "r", 115, 30.0))
    failed = note_text(FixedFidelity(1e-3, "the nominal model", failure=(NoReplay("", "run 2", NO_STEADY_STATE,
                                                                                   "it diverged"),)))
    assert failed == ("the model fidelity is fixed at 0.001 of each run's largest balanced torque: the nominal model "
                      "could not be replayed to measure it (no periodic steady state under the drive of run 2: it "
                      "diverged)")
    clean = note_text(FixedFidelity(1e-3, "the nominal model", measured=2.5e-5, chi2_per_dof=7.25, noise_free_below=1e-6))
    assert "the records are noise-free (below 1e-06 of every channel), and measured on the replay of the nominal " \
           "model (2.5e-05 of the balanced torque) it left the best model at chi2/dof 7.25" in clean
    assert "two periods alone" in note_text(FixedFidelity(1e-3, "m", measured=1e-4, chi2_per_dof=3.0, two_periods=True))
    assert "driven by 0.25 of the torque" in note_text(RelativeAngle(0.25))
    assert note_text(FidelityCycle("a", "a + b")) == (
        "the measured fidelity does not settle: measured on the replay of a it adopts a + b, measured on a + b's, a; "
        "the catalogue holds no model that its own fidelity keeps")
    assert ", from your model)" in note_text(RelativeAngle(0.5, True))


@pytest.mark.parametrize("failure, words", [
    (NoReplay("extended", "f.csv run 3", NO_INERTIA, inertias=((1, -0.5), (2, float("nan")))),
     "the extended model has no body's inertia (J1 = -0.5, J2 = nan kg m^2): it cannot be simulated"),
    (NoReplay("", "", NO_INERTIA, inertias=((1, -0.5),)), "a fitted inertia is no body's"),
    (NoReplay("nominal", "r1", NOT_FOLLOWED, "diverged"),
     "the nominal model does not follow the measured drive of r1: diverged"),
    (NoReplay("nominal", "r1", NO_STEADY_STATE), "the nominal model reaches no periodic steady state under the "
                                                 "measured drive of r1"),
    (NoReplay("extended", "r1", NO_STEADY_STATE, "MuJoCo warned"),
     "the extended model reaches no periodic steady state under the measured drive of r1: MuJoCo warned"),
    (NoReplay("extended", "r1", NOR_SPANNED, "diverged", periods=4), "the extended model reaches no periodic steady "
     "state under the measured drive of r1, nor follows it over its 4 periods: diverged"),
    # a fitted model that diverges: its instability, not the rig's step, which a diagnosis's user
    # does not set (the rig's own message advised "reduce max_step_s")
    (NoReplay("extended", "r1", DIVERGED, "mjWARN_BADQACC x1 (info 0)"), "the extended model diverges in the rig "
     "under the measured drive of r1 (MuJoCo warned: mjWARN_BADQACC x1 (info 0)): a fitted value makes it unstable"),
    (NoReplay("", "r2", DIVERGED, "mjWARN_BADQACC x1 (info 0)"), "the fitted model diverges in the rig under the "
     "drive of r2 (MuJoCo warned: mjWARN_BADQACC x1 (info 0)): a fitted value makes it unstable"),
])
def test_a_failed_replays_words_carry_its_model_run_and_the_rigs_reason(failure, words):
    assert no_replay_text(failure) == words
    assert failures_text((failure, failure)) == words + "; " + words
    with pytest.raises(ValueError, match="no words for a replay that failed by 'x'"):
        no_replay_text(dataclasses.replace(failure, model="nominal", why="x"))


def test_why_a_bias_was_not_measured_in_words():
    assert bias_unmeasured_text(BiasUnmeasured(smooth=True)) == "the nominal law is smooth: not measured"
    assert bias_unmeasured_text(BiasUnmeasured()) == "no replay of the fitted runs was made"
    assert bias_unmeasured_text(BiasUnmeasured(failures=(NoReplay("", "", NO_INERTIA),))) == (
        "the model could not be replayed on the fitted runs (a fitted inertia is no body's)")


def test_the_readers_notes_carry_their_values_into_their_words():
    assert note_text(reader.IncompletePeriod("3", 1100, 256, 4)) == (
        "run 3: 1100 samples hold 4.297 periods; the first 76 samples (an incomplete period, where a record from rest settles) are not used")
    ls = reader.LeastSquaresPeriods("0", 114.239, 55.0002008, "torque", 0.00059, 45, 4, 92,
                                    (("torque", 0.0008), ("phi1", 0.0009)), 57)
    assert note_text(ls) == (
        "run 0: 114.239 samples per period at omega = 55.0002008 rad/s (from the torque's line, +- 0.00059) is not a "
        "whole number (a fixed sample rate): harmonics 0..45 of each of 4 whole periods estimated by least squares on "
        "its own samples and synthesised at 92 samples per period; residual RMS relative to each channel's RMS (noise "
        "plus content above harmonic 45): torque 0.08%, phi1 0.09%; the first 57 samples (an incomplete period, where a "
        "record from rest settles) are not used")
    assert "(from the 'omega' column)" in note_text(dataclasses.replace(ls, omega_column=True, unused=0))
    assert not note_text(dataclasses.replace(ls, unused=0)).endswith("not used")
    assert note_text(reader.CommonMotion("1", 3.0)).startswith("run 1: both flywheels rotate steadily at 3 rad/s")
    assert note_text(reader.CommonMotion("1", 0.002, "m", "carriage line")) == (
        "run 1: the whole carriage line moves steadily at 0.002 m/s on top of the vibration; that common motion is "
        "removed")
    assert note_text(reader.PreloadChanges(2, 0.0123, 45.5)).startswith("joint 2's mean twist differs between runs "
                                                                        "by 0.0123 rad, as the drives' mean does (by 45.5)")
    assert note_text(reader.PreloadChanges(0, 0.1, 1.0)).startswith("the relative angle's mean differs")
    assert note_text(reader.IgnoredColumns("f.csv", ("temp", "rpm"), 8)).startswith(
        "f.csv: column(s) ['temp', 'rpm'] ignored (the diagnosis uses run, time")
    assert note_text(reader.FromValidate("pulses.csv", reader.ZeroPerRun(True))) == (
        "pulses.csv (--validate): each run's position taken about its own mean (--zero-per-run)")


def test_the_verdicts_words_say_which_causes_the_runs_cannot_tell_the_adopted_one_from():
    # The first screen names the adopted cause; where the data cannot tell it from another (an
    # Iwan element from a Jenkins element at 10% noise) the same sentence says so, and says
    # nothing of an ambiguity between two causes neither of which was adopted.
    from types import SimpleNamespace

    from jointrig.identify.causes import SAME_PLACE, Ambiguity
    from jointrig.present.train_report import _untold

    step = SimpleNamespace(label="micro_slip at joint 1")
    amb = (Ambiguity(("micro_slip at joint 1", "hysteresis at joint 1"), unplaced=SAME_PLACE, excitation="x"),
           Ambiguity(("cogging at joint 1", "micro_slip at joint 1"), unplaced=SAME_PLACE, excitation="y"),
           Ambiguity(("backlash at joint 2", "cogging at joint 2"), unplaced=SAME_PLACE, excitation="z"))
    assert _untold(SimpleNamespace(steps=(step,), ambiguities=amb)) == (
        " These runs cannot tell micro_slip at joint 1 from hysteresis at joint 1 or cogging at joint 1 (what would: "
        "below).")
    assert _untold(SimpleNamespace(steps=(step,), ambiguities=amb[2:])) == ""
