"""A misfit no catalogued cause explains, in words (pure): where it is, what it looks like
(:class:`identify.misfit.MisfitCharacter`), its restoring-force surface
(:class:`identify.surface.RestoringSurface`) and the measurements that would tell more
(:class:`identify.misfit.NextMeasurement`), each in the place's quantities and units: a
joint's torque over its twist, or a body's force to ground over its position on a slide."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jointrig.identify.misfit import (HIGH_SHARE, MORE_FREQUENCIES, MORE_LEVELS, PHASE_SPAN_RESONANT_DEG,
                                      PRELOAD_AND_ZERO, QUASI_STATIC_RAMP, REPEAT_CHANGE, REPEAT_START_END,
                                      REPEAT_WITH_TEMPERATURE, SENSOR_CALIBRATION, MisfitCharacter, NextMeasurement)
from jointrig.identify.surface import RestoringSurface
from jointrig.vocab.params import HINGE, SLIDE

__all__ = ["Words", "JOINT_WORDS", "PLACE_WORDS", "words_of", "character_text", "surface_text", "measurement_text",
           "places_text", "misfit_texts", "character_json", "surface_json"]


@dataclass(frozen=True)
class Words:
    """How a misfit's description names its place's quantities: a joint's torque over its relative
    angle (the default), or a body's force to ground over its position on a slide."""

    torque: str = "joint torque"
    angle: str = "phi"
    motion: str = "joint angle"
    torque_unit: str = "N m"
    angle_unit: str = "rad"
    load: str = "torque"
    sensors: str = "angle sensors'"
    encoders: str = "angle encoders"


#: A joint between two bodies on hinges (two flywheels, a train's joint).
JOINT_WORDS = Words()

#: ``(coordinate, single body) -> Words``: a joint between two bodies, or what holds a single
#: body to the frame, on hinges and on slides.
PLACE_WORDS = {
    (HINGE, False): JOINT_WORDS,
    (HINGE, True): Words("torque to ground", "phi", "angle", "N m", "rad", "torque", "angle encoder's", "angle encoder"),
    (SLIDE, False): Words("joint force", "x", "joint's stretch", "N", "m", "force", "position encoders'",
                          "position encoders"),
    (SLIDE, True): Words("force to ground", "x", "position", "N", "m", "force", "position encoder's",
                         "position encoder"),
}


def words_of(misfit) -> Words:
    """The words of a train's misfit's place (:class:`identify.chain_diagnose.TrainMisfit`)."""
    return PLACE_WORDS[(misfit.kind, misfit.single)]


def character_text(c: MisfitCharacter, words: Words = JOINT_WORDS) -> str:
    """What the residual looks like: its size, parity, dissipation, harmonics, how it scales with
    frequency and drive, and whether it changes with run order."""
    w = words
    parity = (f"even in {w.angle} (an asymmetry)" if c.even_share > 0.6 else
              f"odd in {w.angle} (symmetric)" if c.even_share < 0.4 else "both odd and even")
    kind = ("dissipative" if c.dissipative_share > 0.6 else
            "conservative (elastic)" if c.dissipative_share < 0.4 else "partly dissipative")
    f = ("grows with frequency" if c.frequency_slope > 0.5 else
         "falls with frequency" if c.frequency_slope < -0.5 else "about independent of frequency")
    a = ("grows faster than the drive" if c.amplitude_slope > 1.5 else
         "grows with the drive" if c.amplitude_slope > 0.5 else "about independent of the drive level")
    return (f"the residual {w.torque} is {max(c.relative):.2g} of the {w.torque} at most; it is {parity}, "
            f"{kind} at the fundamental (share {c.dissipative_share:.2f}), sits mostly on harmonics "
            f"{', '.join(map(str, c.top_harmonics))}, {f} (slope {c.frequency_slope:.2g}) and "
            f"{a} (slope {c.amplitude_slope:.2g}); largest in runs {', '.join(c.worst_runs)}"
            + (f"; {c.high_share:.0%} of it on harmonics 4 and up" if c.high_share > HIGH_SHARE else "")
            + (f"; at one drive level its axis at the fundamental turns by {c.phase_span_deg:.0f} deg between "
               f"frequencies (towards or away from quadrature with the {w.motion}: a frequency-dependent stiffness "
               f"and damping)"
               if c.phase_span_deg > PHASE_SPAN_RESONANT_DEG else "")
            + _order_text(c))


def _order_text(c: MisfitCharacter) -> str:
    if not math.isfinite(c.repeat_change):
        return "; no run repeats a setting, so a dependence on run order or time cannot be told apart"
    a, b = c.repeat_runs
    if c.repeat_change > REPEAT_CHANGE:
        return (f"; between runs {a} and {b}, which repeat one setting, it changes by {c.repeat_change:.2g} "
                f"of its size: it depends on run order or time (wear, temperature, drift)")
    return (f"; between runs {a} and {b}, which repeat one setting, it changes by {c.repeat_change:.2g} "
            f"of its size: no sign of run order or time")


def surface_text(s: RestoringSurface, words: Words = JOINT_WORDS) -> str:
    """The restoring-force surface: elastic or dissipative, symmetric or not, how much of the
    residual it carries, and its stiffness and damping sections' spans."""
    kind = (f"a {words.torque} of the {words.motion} (elastic)" if s.elastic_share > 0.7 else
            f"a {words.torque} of the rate (dissipative)" if s.elastic_share < 0.3 else
            "both elastic and dissipative")
    sym = ("point-symmetric (a symmetric law)" if s.symmetric_share > 0.7 else
           "not point-symmetric (an asymmetry, or an offset)" if s.symmetric_share < 0.3 else
           "partly point-symmetric")
    phi, st = s.stiffness_section
    v, d = s.damping_section
    tiny = 1e-9 * s.rms_Nm  # round-off of the solve, not torque
    st, d = np.where(np.abs(st) < tiny, 0.0, st), np.where(np.abs(d) < tiny, 0.0, d)
    w = words
    parts = [f"as a surface over ({w.angle}, {w.angle}') it is {kind}, share even in the rate {s.elastic_share:.2f}, "
             f"and {sym}, share {s.symmetric_share:.2f}; the surface carries "
             f"{1 - (s.fit_rms_Nm / s.rms_Nm) ** 2 if s.rms_Nm > 0 else 0:.0%} of the residual's power"]
    if phi.size >= 2:
        parts.append(f"its stiffness section S({w.angle}, 0) spans {st.min():.3g} to {st.max():.3g} {w.torque_unit} "
                     f"over {w.angle} {phi.min():.3g} to {phi.max():.3g} {w.angle_unit}")
    if v.size >= 2:
        parts.append(f"its damping section S(0, {w.angle}') spans {d.min():.3g} to {d.max():.3g} {w.torque_unit} "
                     f"over {w.angle}' {v.min():.3g} to {v.max():.3g} {w.angle_unit}/s")
    return "; ".join(parts)


def measurement_text(m: NextMeasurement, words: Words = JOINT_WORDS) -> str:
    """A measurement that would tell more about a misfit, and what it would show."""
    w = words
    if m.kind == MORE_FREQUENCIES:
        return (f"a stepped sine at one drive level over more frequencies (the runs hold {m.count}): a "
                "stiffness and damping that change with frequency at equal amplitude (a viscoelastic element "
                "with its own time constant) show as a turning phase of the residual")
    if m.kind == QUASI_STATIC_RAMP:
        return (f"a slow, quasi-static ramp of the {w.motion} with the {w.torque} measured: a "
                f"{w.torque} that repeats at a fixed pitch of the {w.motion} (cogging, a detent, a damaged "
                f"tooth) shows as ripple in the stiffness section against the {w.motion}")
    if m.kind == SENSOR_CALIBRATION:
        return (f"a static calibration of the {w.load} cell and the {w.encoders} against a reference over "
                "their range: a misfit that grows faster than the drive on odd harmonics can be the joint's law or a "
                "sensor's nonlinearity, and only a reference tells them apart")
    if m.kind == PRELOAD_AND_ZERO:
        return (f"runs with a mean (preload) {w.load} and a check of the {w.sensors} zero: an even misfit "
                f"is an asymmetry or an offset")
    if m.kind == MORE_LEVELS:
        return (f"runs at more drive levels (the runs hold {m.count}): how the misfit scales with the drive "
                "tells a law of the motion (it grows faster) from a linear one (it scales with the drive)")
    if m.kind == REPEAT_WITH_TEMPERATURE:
        return (f"the misfit changed between runs {' and '.join(m.runs)} of one setting: repeat "
                "that setting through the test with the joint's temperature logged (wear, temperature or "
                "drift is not a law a model of the joint can hold)")
    if m.kind == REPEAT_START_END:
        return ("one run repeated at the start and the end of the test: a misfit that changes with run order is "
                "wear, temperature or drift, not a law")
    raise ValueError(f"no words for a measurement of kind {m.kind!r}")


def places_text(misfit) -> str:
    """Where a train's misfit is: the place it is largest at, and its size at the others."""
    if len(misfit.by_place) == 1:
        return f"at {misfit.where}"
    rest = ", ".join(f"{p} {r:.2g}" for p, r in misfit.by_place if p != misfit.where)
    top = dict(misfit.by_place)[misfit.where]
    return (f"at {misfit.where}, where the residual torque is largest ({top:.2g} of the torque there; {rest}: a "
            f"misfit at a joint shows beyond it too when the fit has moved an inertia or a drag to absorb it)")


def misfit_texts(misfit) -> tuple[str, str]:
    """A train's misfit's character and surface in words, at its place."""
    w = words_of(misfit)
    return character_text(misfit.character, w), surface_text(misfit.surface, w)


def character_json(misfit) -> dict:
    """A train's misfit's place and character as JSON, with its description."""
    return {"where": misfit.where, "by_place": {p: r for p, r in misfit.by_place}, **misfit.character.as_json(),
            "description": misfit_texts(misfit)[0]}


def surface_json(misfit) -> dict:
    """A train's misfit's restoring-force surface as JSON, with its description in the place's words."""
    return {**misfit.surface.as_json(), "description": misfit_texts(misfit)[1]}
