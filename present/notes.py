"""The sentences of the diagnosis's notes (:mod:`studies.notes`), made in one place: the text
report, the JSON and the HTML report all read them from :func:`note_text`."""

from __future__ import annotations

from functools import singledispatch

from jointrig.studies.notes import (BandCut, BodyRests, FixedFidelity, JointSticks, NoSpringToFrame, RelativeAngle,
                                    Spanned)


@singledispatch
def note_text(note) -> str:
    """A note in words. The reader's notes (:attr:`measured.runs.LoadedRuns.notes`) come as words
    already, made where the file is read, and are passed as they are."""
    raise TypeError(f"no words for a note of type {type(note).__name__}")


@note_text.register
def _(note: str) -> str:
    return note


@note_text.register
def _(note: BandCut) -> str:
    return (f"harmonics 1..{note.top} fitted, not 1..{note.asked}: run {note.run} holds {note.samples_per_period} "
            f"samples per period, enough for {note.top}")


@note_text.register
def _(note: FixedFidelity) -> str:
    head = f"the model fidelity is fixed at {note.fidelity:g} of each run's largest balanced torque: "
    if note.failure is not None:
        return head + f"{note.model} could not be replayed to measure it ({note.failure})"
    why = (f"the records are noise-free (below {note.noise_free_below:g} of every channel)"
           if note.noise_free_below is not None else
           "a run's noise comes from two periods alone (one degree of freedom per line: its weights give a "
           "chi-square without a finite expectation)")
    return head + (f"{why}, and measured on the replay of {note.model} ({note.measured:.2g} of the balanced torque) it "
                   f"left the best model at chi2/dof {note.chi2_per_dof:.3g}")


@note_text.register
def _(note: BodyRests) -> str:
    return (f"run {note.run}: body {note.body} rests {note.rest:.0%} of its period (its rate below "
            f"{note.rest_below:.0%} of its peak; it may stick, held by whatever force its dry friction supplies there, "
            f"not the law's): its equation is balanced only where its rate exceeds {note.balanced_above:.0%} of its "
            f"peak ({note.masked:.0%} of the period left out, in every model compared)")


@note_text.register
def _(note: JointSticks) -> str:
    how = (f"its twist rests {note.rest:.0%} of its period (its twist rate below {note.rest_below:.0%} of its peak)"
           if note.resolved else "its twist is not resolved above the noise (stuck the whole period, or nearly)")
    own = (f", and one of them on its own where the joint slides (its twist rate above {note.balanced_above:.0%} of "
           f"its peak; {note.left_out:.0%} of the period left out)" if note.left_out < 1.0 else " alone")
    return (f"run {note.run}: joint {note.joint} may stick: {how}; while it sticks its torque is whatever holds it, not "
            f"its law's, so its two bodies' equations are balanced as their sum{own} in this run (in every model "
            f"compared)")


@note_text.register
def _(note: NoSpringToFrame) -> str:
    return (f"body {', '.join(str(i) for i in note.bodies)} has no spring to the frame: under the measured drive alone a "
            f"replay would walk off by whatever mean drive the fit misses, so every replay in the rig adds the constant "
            f"load that leaves it without drift, as its position controller (or the bench) held it, and compares the "
            f"motion about its mean")


@note_text.register
def _(note: Spanned) -> str:
    limit = f"within {note.max_periods} periods" + (f" or {note.max_wall_s:g} s" if note.max_wall_s else "")
    return (f"the {note.model} model under the drive of {note.record} (no periodic steady state in the rig {limit}): "
            f"compared over the record's own periods from its measured state instead of a steady state (a model that "
            f"settles slowly, or never, in the rig may still follow the record)")


@note_text.register
def _(note: RelativeAngle) -> str:
    return (f"the relative angle alone ('phi'): the joint's twist moves as one body of inertia J1 J2/(J1 + J2) (J1 "
            f"below) tied to the frame by the joint's law (ground1_* below are the joint's), driven by {note.share:g} "
            f"of the torque (--torque-share: the undriven flywheel's J over J1 + J2"
            + (", from your model" if note.from_model else "") + "); bearing drag and the angle sensors' zero offset "
            "are not sought: they need both angles")
